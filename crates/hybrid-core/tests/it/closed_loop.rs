//! Closed-loop mechanisms (paper section 2.2, eqs. 14–25): the general partitioning routine
//! against the augmented system, position and velocity analysis against closed forms,
//! energy conservation and convergence order of the integrators, automatic re-partitioning
//! through a degenerate partition, and the diagnoses of redundant, infeasible and singular
//! mechanisms. Uses the generated four-bar and slider-crank (compiled by `build.rs`), with
//! the DAG interpreter and the numeric reference on the same model files as cross-checks.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use hybrid_core::closed_loop::{
    AssemblyError, AssemblyOptions, InterpretedSystem, NumericSystem, SimError, Simulator, System,
    Trajectory, assemble, simulate,
};
use hybrid_core::closed_loop::{Settings, assemble_positions};
use hybrid_core::partition::{Partition, choose_partition, dependent_accelerations, reduce};
use mbs_symbolic::model::{self, Format, Model};
use mbs_symbolic::samples::SplitMix64;
use nalgebra::{DMatrix, DVector};

// ---------------------------------------------------------------------------------------
// Helpers

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn load(rel: &str) -> Model {
    model::load(&root().join(rel)).unwrap_or_else(|e| panic!("{e}"))
}

fn model_text(rel: &str) -> String {
    std::fs::read_to_string(root().join(rel)).unwrap()
}

/// Generated code of a model under `models/`, from the model registry.
fn compiled(name: &str) -> Box<dyn System> {
    model_registry::find_by_name(name)
        .unwrap_or_else(|| panic!("models/{name} is compiled in"))
        .system()
}

fn four_bar() -> Box<dyn System> {
    compiled("four_bar")
}

fn slider_crank() -> Box<dyn System> {
    compiled("slider_crank")
}

/// Four-bar geometry of `models/four_bar.toml`: crank a, coupler b, rocker c, ground d.
const A: f64 = 0.10;
const B: f64 = 0.25;
const C: f64 = 0.20;
const D: f64 = 0.30;

/// Closed-form position analysis of the four-bar (loop closure / Freudenstein): for crank
/// angle q1 and branch `sign`, the rocker angle q3 and the coupler angle relative to the
/// crank q2.
///
/// |B - A| = b with A = a e(q1), B = (d, 0) + c e(q3) gives P cos q3 + Q sin q3 = R.
fn four_bar_closed_form(q1: f64, sign: f64) -> (f64, f64) {
    let p = 2.0 * C * (D - A * q1.cos());
    let q = -2.0 * A * C * q1.sin();
    let r = B * B - C * C - (D - A * q1.cos()).powi(2) - (A * q1.sin()).powi(2);
    let q3 = q.atan2(p) + sign * (r / p.hypot(q)).acos();
    let (ax, ay) = (A * q1.cos(), A * q1.sin());
    let (bx, by) = (D + C * q3.cos(), C * q3.sin());
    let theta2 = (by - ay).atan2(bx - ax);
    (q3, theta2 - q1)
}

/// Difference of two angles reduced to (-pi, pi].
fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(2.0 * PI);
    if d > PI { d - 2.0 * PI } else { d }
}

fn energy_scale(traj: &Trajectory) -> f64 {
    traj.stats
        .initial_energy
        .unwrap()
        .abs()
        .max(traj.stats.max_kinetic_energy)
}

fn max_energy_error(traj: &Trajectory) -> f64 {
    traj.stats.max_energy_error.unwrap() / energy_scale(traj)
}

/// Assembles the four-bar at crank angle q1 (held) with crank speed w1 (held).
fn four_bar_state(sys: &dyn System, q1: f64, guess: (f64, f64), w1: f64) -> (Vec<f64>, Vec<f64>) {
    assemble(
        sys,
        &[q1, guess.0, guess.1],
        &[0],
        &[w1, 0.0, 0.0],
        &[0],
        &AssemblyOptions::default(),
    )
    .unwrap()
}

// ---------------------------------------------------------------------------------------
// The general partitioning routine

/// `reduce` (eqs. 23–25) and eq. (19) reproduce the solution of the full augmented system
/// `[M J^T; J 0] [q''; lambda] = [-(F + Q); -A]` (eq. 17 with eq. 16) on random data, for
/// automatic and for arbitrary non-singular partitions. Tolerance 1e-10 relative.
#[test]
fn reduce_matches_the_augmented_system_on_random_data() {
    let mut rng = SplitMix64::new(7);
    let mut worst = 0.0f64;
    for trial in 0..200 {
        let n = 2 + trial % 7;
        let r = 1 + (trial / 7) % (n - 1);
        let x = DMatrix::from_fn(n, n, |_, _| rng.symmetric(1.0));
        let m = &x * x.transpose() + DMatrix::identity(n, n) * (n as f64);
        let j = DMatrix::from_fn(r, n, |_, _| rng.symmetric(1.0));
        let f = DVector::from_fn(n, |_, _| rng.symmetric(1.0));
        let q = DVector::from_fn(n, |_, _| rng.symmetric(1.0));
        let a = DVector::from_fn(r, |_, _| rng.symmetric(1.0));
        let mut aug = DMatrix::zeros(n + r, n + r);
        aug.view_mut((0, 0), (n, n)).copy_from(&m);
        aug.view_mut((0, n), (n, r)).copy_from(&j.transpose());
        aug.view_mut((n, 0), (r, n)).copy_from(&j);
        let mut rhs = DVector::zeros(n + r);
        rhs.rows_mut(0, n).copy_from(&(-(&f + &q)));
        rhs.rows_mut(n, r).copy_from(&(-&a));
        let sol = aug.lu().solve(&rhs).unwrap();
        let qdd = sol.rows(0, n).into_owned();

        let auto = choose_partition(&j, 1e-9).partition;
        // Another partition: the first n - r coordinates independent, when J_v is fine.
        let other = Partition::from_independent(n, &(0..n - r).collect::<Vec<_>>()).unwrap();
        for p in [auto, other] {
            let red = match reduce(&m, &f, &q, &j, &a, &p) {
                Ok(red) => red,
                Err(e) => {
                    assert!(
                        p != choose_partition(&j, 1e-9).partition,
                        "auto failed: {e}"
                    );
                    continue;
                }
            };
            let udd = red.accelerations().unwrap();
            let vdd = dependent_accelerations(&j, &a, &p, &udd).unwrap();
            let scale = qdd.amax().max(1.0) * red.jv_condition.max(1.0).sqrt();
            for (k, &i) in p.independent.iter().enumerate() {
                worst = worst.max((udd[k] - qdd[i]).abs() / scale);
            }
            for (k, &i) in p.dependent.iter().enumerate() {
                worst = worst.max((vdd[k] - qdd[i]).abs() / scale);
            }
            // M^R symmetric, B maps onto the null space of J.
            let mut jb = DMatrix::zeros(r, p.independent.len());
            for (l, &i) in p.independent.iter().enumerate() {
                for row in 0..r {
                    let mut s = j[(row, i)];
                    for (k, &d) in p.dependent.iter().enumerate() {
                        s += j[(row, d)] * red.b[(k, l)];
                    }
                    jb[(row, l)] = s;
                }
            }
            assert!(
                jb.amax() < 1e-10 * red.jv_condition,
                "J [I; B] != 0: {}",
                jb.amax()
            );
            assert_eq!(red.m, red.m.transpose());
        }
    }
    eprintln!("reduce vs augmented system: worst relative difference {worst:.2e}");
    assert!(worst < 1e-10, "worst relative difference {worst:e}");
}

// ---------------------------------------------------------------------------------------
// Position and velocity analysis

/// Four-bar assembly over a full crank turn (72 positions, each starting from the previous
/// solution) against the closed form on both branches: positions to 1e-12 rad, and the
/// rocker speed from `J q' = 0` against `w3 = a w1 sin(th2 - q1) / (c sin(th2 - q3))` to
/// 1e-12 (measured: ~1e-15, rounding level).
#[test]
fn four_bar_position_analysis_matches_the_closed_form_over_a_full_turn() {
    let sys = four_bar();
    for sign in [1.0, -1.0] {
        let (q3, q2) = four_bar_closed_form(0.0, sign);
        let mut guess = (q2 + 0.2, q3 - 0.2);
        let mut worst = (0.0f64, 0.0f64);
        for k in 0..=72 {
            let q1 = k as f64 * 2.0 * PI / 72.0;
            let (q, qd) = four_bar_state(&sys, q1, guess, 1.0);
            let (q3c, q2c) = four_bar_closed_form(q1, sign);
            worst.0 = worst
                .0
                .max(angle_diff(q[2], q3c).abs())
                .max(angle_diff(q[1], q2c).abs());
            let th2 = q1 + q2c;
            let w3 = A * (th2 - q1).sin() / (C * (th2 - q3c).sin());
            worst.1 = worst.1.max((qd[2] - w3).abs() / w3.abs().max(1.0));
            guess = (q[1], q[2]);
        }
        eprintln!(
            "four-bar branch {sign}: position error {:.2e}, velocity error {:.2e}",
            worst.0, worst.1
        );
        assert!(
            worst.0 < 1e-12,
            "branch {sign}: position error {:e}",
            worst.0
        );
        assert!(
            worst.1 < 1e-12,
            "branch {sign}: velocity error {:e}",
            worst.1
        );
    }
}

/// Slider-crank: piston position `x = r cos q1 + sqrt(l^2 - r^2 sin^2 q1)` and velocity
/// `x' = -r w sin q1 - r^2 w sin q1 cos q1 / sqrt(l^2 - r^2 sin^2 q1)` over a full turn,
/// to 1e-13 (metres, m/s; measured ~1e-16).
#[test]
fn slider_crank_piston_position_and_velocity_match_the_closed_form() {
    let (r, l, w) = (0.05, 0.20, 3.0);
    let sys = slider_crank();
    let mut guess = (0.0, r + l);
    let mut worst = (0.0f64, 0.0f64);
    for k in 0..=72 {
        let q1 = k as f64 * 2.0 * PI / 72.0;
        let (q, qd) = assemble(
            &sys,
            &[q1, guess.0, guess.1],
            &[0],
            &[w, 0.0, 0.0],
            &[0],
            &AssemblyOptions::default(),
        )
        .unwrap();
        let s = (l * l - (r * q1.sin()).powi(2)).sqrt();
        let x = r * q1.cos() + s;
        let xd = -r * w * q1.sin() - r * r * w * q1.sin() * q1.cos() / s;
        worst.0 = worst.0.max((q[2] - x).abs());
        worst.1 = worst.1.max((qd[2] - xd).abs());
        guess = (q[1], q[2]);
    }
    eprintln!(
        "slider-crank: position error {:.2e}, velocity error {:.2e}",
        worst.0, worst.1
    );
    assert!(worst.0 < 1e-13, "position error {:e}", worst.0);
    assert!(worst.1 < 1e-13, "velocity error {:e}", worst.1);
}

// ---------------------------------------------------------------------------------------
// Integration

fn four_bar_release(sys: &dyn System) -> (Vec<f64>, Vec<f64>) {
    four_bar_state(sys, 0.6, (0.0, 1.6), 0.0)
}

/// The conservative four-bar (gravity only, no driving torque) released from rest at
/// q1 = 0.6 rad conserves `T + V` to 1e-8 of the energy scale over 5 s with Dormand–Prince
/// at rtol 1e-11, atol 1e-13: the local error per step is held near 1e-11 relative, and
/// over ~10^3 steps its accumulation stays orders of magnitude below 1e-8 (measured ~1e-11).
/// The constraints hold to rounding (`|h| < 1e-14`) because `v(u)` is solved at every
/// stage.
#[test]
fn four_bar_conserves_energy_over_five_seconds() {
    let sys = four_bar();
    let (q0, qd0) = four_bar_release(&sys);
    let mut settings = Settings::dopri5(5.0, 1e-11, 1e-13, 0.01);
    settings.partition.independent = Some(vec![0]);
    let traj = simulate(&sys, settings, &q0, &qd0).unwrap();
    let err = max_energy_error(&traj);
    eprintln!(
        "energy: E0 = {:.6} J, relative error {err:.2e}, max |h| {:.2e}, {} steps ({} rejected), changes {}",
        traj.stats.initial_energy.unwrap(),
        traj.stats.max_residual,
        traj.stats.steps_accepted,
        traj.stats.steps_rejected,
        traj.changes.len()
    );
    assert_eq!(traj.rows.len(), 501);
    assert!((traj.rows.last().unwrap().t - 5.0).abs() < 1e-12);
    assert!(err < 1e-8, "relative energy error {err:e}");
    assert!(
        traj.stats.max_residual < 1e-14,
        "residual {:e}",
        traj.stats.max_residual
    );
    // It really moves: the crank swings through a large angle.
    let (lo, hi) = traj.rows.iter().fold((f64::MAX, f64::MIN), |(lo, hi), r| {
        (lo.min(r.q[0]), hi.max(r.q[0]))
    });
    assert!(hi - lo > 1.0, "crank range {lo}..{hi}");
}

/// Steps polled by [`counted_stop`] (one test uses it: a `fn` pointer cannot capture).
static POLLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// A stop that asks to stop at its 51st poll.
fn counted_stop() -> bool {
    POLLS.fetch_add(1, std::sync::atomic::Ordering::SeqCst) >= 50
}

/// The stop polled before every step (`Simulator::set_stop`, what an interrupt uses): one
/// that never fires leaves the run identical, one that fires at its 51st poll ends the run
/// there with `SimError::Stopped` after exactly 50 steps (both integrators), before `t_end`.
#[test]
fn a_stop_polled_before_every_step_ends_the_run_there() {
    let sys = four_bar();
    let (q0, qd0) = four_bar_release(&sys);
    for settings in [
        Settings::dopri5(5.0, 1e-11, 1e-13, 0.01),
        Settings::rk4(5.0, 2e-3, 0.01),
    ] {
        let run = |stop: Option<fn() -> bool>| {
            let mut sim = Simulator::new(&sys, settings.clone(), &q0, &qd0).unwrap();
            if let Some(s) = stop {
                sim.set_stop(s);
            }
            let mut rows = 0;
            let r = sim.run(&mut |e| {
                if let hybrid_core::closed_loop::Event::Output(_) = e {
                    rows += 1;
                }
            });
            (r, rows, sim.stats().clone())
        };
        let (plain, rows, stats) = run(None);
        plain.unwrap();
        let (never, rows_never, stats_never) = run(Some(|| false));
        never.unwrap();
        assert_eq!((rows, &stats), (rows_never, &stats_never));
        POLLS.store(0, std::sync::atomic::Ordering::SeqCst);
        let (stopped, _, stats_stopped) = run(Some(counted_stop));
        match stopped {
            Err(SimError::Stopped { t }) => assert!(t > 0.0 && t < 5.0, "{t}"),
            other => panic!("{other:?}"),
        }
        assert_eq!(
            stats_stopped.steps_accepted + stats_stopped.steps_rejected,
            50
        );
    }
}

/// Fixed-step RK4 converges at order 4 under step halving: the largest error of all
/// coordinates and velocities (velocities weighted 1/10 s) over 1 s, sampled every 0.04 s
/// on step points, against a tight Dormand–Prince reference (rtol 1e-13), falls by 2^4 per
/// halving (observed order within 3.6–4.4; measured 3.96–3.99).
///
/// The motion is a moderate swing (crank thrown at 6 rad/s from q1 = -1.5 rad). In the
/// violent motions of the other tests (crank speeds of 25–50 rad/s through poor
/// transmission angles) the steps 4e-3..5e-4 s are still pre-asymptotic for RK4 and the
/// observed order drifts to ~5; that is a property of those trajectories, not of the method.
#[test]
fn rk4_converges_at_fourth_order() {
    let sys = four_bar();
    let (q3, q2) = four_bar_closed_form(-1.5, 1.0);
    let (q0, qd0) = four_bar_state(&sys, -1.5, (q2, q3), 6.0);
    let run = |settings: Settings| {
        let mut s = settings;
        s.partition.independent = Some(vec![0]);
        s.partition.repartition = false;
        simulate(&sys, s, &q0, &qd0).unwrap().rows
    };
    let reference = run(Settings::dopri5(1.0, 1e-13, 1e-15, 0.04));
    let steps = [4e-3, 2e-3, 1e-3, 5e-4];
    let errors: Vec<f64> = steps
        .iter()
        .map(|&h| {
            let rows = run(Settings::rk4(1.0, h, 0.04));
            assert_eq!(rows.len(), reference.len());
            let mut e = 0.0f64;
            for (a, b) in rows.iter().zip(&reference) {
                for k in 0..3 {
                    e = e
                        .max((a.q[k] - b.q[k]).abs())
                        .max((a.qd[k] - b.qd[k]).abs() / 10.0);
                }
            }
            e
        })
        .collect();
    let orders: Vec<f64> = errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    eprintln!("rk4 errors {errors:?}, observed orders {orders:?}");
    for &order in &orders {
        assert!(
            (3.6..=4.4).contains(&order),
            "observed order {order} ({errors:?})"
        );
    }
}

/// A four-bar whose crank turns through full revolutions, started with the rocker as the
/// independent coordinate: at the rocker's extreme positions (crank and coupler collinear,
/// dq3/dq1 = 0) the partition u = [q3] makes J_v singular. The automatic re-partitioning
/// must switch away before that, keep the constraint residuals below 1e-10 and the energy
/// error bounded (1e-7 of the energy scale at rtol 1e-10).
#[test]
fn automatic_repartitioning_carries_the_four_bar_through_the_rocker_extremes() {
    let sys = four_bar();
    let (q3, q2) = four_bar_closed_form(2.0, 1.0);
    let (q0, qd0) = four_bar_state(&sys, 2.0, (q2, q3), 25.0);
    let mut settings = Settings::dopri5(2.0, 1e-10, 1e-12, 0.005);
    settings.partition.independent = Some(vec![2]);
    let traj = simulate(&sys, settings, &q0, &qd0).unwrap();
    for c in &traj.changes {
        eprintln!("{c}");
    }
    assert_eq!(traj.initial_independent, vec!["q3".to_string()]);
    assert!(!traj.changes.is_empty(), "no partition change");
    assert_eq!(traj.changes[0].from, vec!["q3".to_string()]);
    assert!(traj.changes[0].cond_after < traj.changes[0].cond_before);
    // The crank really went round (through both rocker extremes, more than once).
    let turns = (traj.rows.last().unwrap().q[0] - q0[0]).abs() / (2.0 * PI);
    assert!(turns > 2.0, "crank turns {turns}");
    let max_res = traj.rows.iter().fold(0.0f64, |m, r| m.max(r.residual_norm));
    assert!(max_res < 1e-10, "residual {max_res:e}");
    assert!(traj.stats.max_residual < 1e-10);
    let err = max_energy_error(&traj);
    eprintln!(
        "repartition: {} changes, energy error {err:.2e}, max |h| {max_res:.2e}, {} steps",
        traj.changes.len(),
        traj.stats.steps_accepted
    );
    assert!(err < 1e-7, "relative energy error {err:e}");
    // Without re-partitioning the same run cannot pass the first extreme.
    let mut stuck = Settings::dopri5(2.0, 1e-10, 1e-12, 0.005);
    stuck.partition.independent = Some(vec![2]);
    stuck.partition.repartition = false;
    let e = simulate(&sys, stuck, &q0, &qd0).unwrap_err();
    eprintln!("without re-partitioning: {e}");
    assert!(
        e.is_singular() || matches!(e, SimError::Diverged { .. }),
        "{e}"
    );
    assert!(!e.to_string().contains("NaN"), "{e}");
}

/// Generated code, the DAG interpreter and the numeric reference evaluate the same
/// equations: the same runs give the same trajectories (to 1e-9: identical expressions,
/// rounding differences amplified only through step-size decisions).
#[test]
fn generated_interpreted_and_numeric_backends_give_the_same_trajectories() {
    for (rel, generated) in [
        ("models/four_bar.toml", four_bar()),
        ("models/slider_crank.toml", slider_crank()),
    ] {
        let model = load(rel);
        let interp = InterpretedSystem::new(&model);
        let numeric = NumericSystem::new(&model);
        assert_eq!(interp.coordinate_names(), generated.coordinate_names());
        assert_eq!(numeric.constraint_names(), generated.constraint_names());
        let (q0, qd0) = assemble(
            &generated,
            &[0.5, -0.3, if rel.contains("four") { 1.6 } else { 0.24 }],
            &[0],
            &[2.0, 0.0, 0.0],
            &[0],
            &AssemblyOptions::default(),
        )
        .unwrap();
        let settings = Settings::dopri5(1.0, 1e-9, 1e-11, 0.05);
        let runs: Vec<Trajectory> = [&generated as &dyn System, &interp, &numeric]
            .iter()
            .map(|s| simulate(*s, settings.clone(), &q0, &qd0).unwrap())
            .collect();
        for other in &runs[1..] {
            assert_eq!(other.rows.len(), runs[0].rows.len());
            for (a, b) in runs[0].rows.iter().zip(&other.rows) {
                for k in 0..3 {
                    assert!((a.q[k] - b.q[k]).abs() < 1e-9, "{rel}: t={} q{k}", a.t);
                    assert!((a.qd[k] - b.qd[k]).abs() < 1e-8, "{rel}: t={} qd{k}", a.t);
                }
                let (ea, eb) = (a.total_energy().unwrap(), b.total_energy().unwrap());
                assert!((ea - eb).abs() < 1e-9, "{rel}: energy at t={}", a.t);
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Diagnoses

fn parse_model(text: &str, name: &str) -> Model {
    model::parse_str(text, name, Format::Toml).unwrap_or_else(|e| panic!("{e}"))
}

/// A second closure of the same pin (`pin2`, x component) is redundant: the rank of J is 2
/// for 3 rows. The run stops with the named diagnosis (`pin2.x = 1 * pin.x` or the
/// reverse); with `allow_redundant` the row is dropped and the run proceeds.
#[test]
fn redundant_closure_gets_the_named_diagnosis() {
    let text = format!(
        "{}\n[[constraints]]\nname = \"pin2\"\ntype = \"loop\"\na = \"coupler_end\"\nb = \"rocker_end\"\ncomponents = [\"x\"]\n",
        model_text("models/four_bar.toml")
    );
    let model = parse_model(&text, "four_bar_redundant.toml");
    let sys = InterpretedSystem::new(&model);
    assert_eq!(sys.rows(), 3);
    let (q0, qd0) = four_bar_release(&sys);
    let settings = Settings::dopri5(0.2, 1e-9, 1e-11, 0.1);
    let err = Simulator::new(&sys, settings.clone(), &q0, &qd0)
        .err()
        .unwrap();
    let msg = err.to_string();
    eprintln!("{msg}");
    match &err {
        SimError::Redundant(report) => {
            assert_eq!((report.rank, report.rows), (2, 3));
            assert_eq!(report.redundant.len(), 1);
            let row = &report.redundant[0];
            assert!(row.name == "pin2.x" || row.name == "pin.x", "{msg}");
            assert_eq!(row.combination.len(), 1, "{msg}");
            assert!((row.combination[0].1 - 1.0).abs() < 1e-9, "{msg}");
        }
        other => panic!("expected a redundancy diagnosis, got {other}"),
    }
    assert!(
        msg.contains("redundant") && msg.contains("pin2.x") && msg.contains("pin.x"),
        "{msg}"
    );
    let mut allow = settings;
    allow.partition.allow_redundant = true;
    let traj = simulate(&sys, allow, &q0, &qd0).unwrap();
    assert_eq!(traj.dropped_rows.len(), 1);
    assert!(traj.stats.max_residual < 1e-12);
}

/// A four-bar whose ground link (0.9 m) is longer than the three other links together
/// (0.55 m) cannot close: assembly fails with the residual and the rows involved. So does
/// a slider-crank asked to put its piston beyond the reach of crank and rod.
#[test]
fn infeasible_assembly_gets_the_clear_error() {
    let text = model_text("models/four_bar.toml").replace("d = 0.30", "d = 0.90");
    let model = parse_model(&text, "four_bar_too_long.toml");
    let sys = InterpretedSystem::new(&model);
    let mut ws = sys.workspace();
    let err = assemble_positions(
        &sys,
        &mut ws,
        &[0.3, 0.0, 1.0],
        &[],
        &AssemblyOptions::default(),
    )
    .unwrap_err();
    let msg = err.to_string();
    eprintln!("{msg}");
    match &err {
        AssemblyError::Infeasible { residual, rows, .. } => {
            // The best the linkage can do leaves a gap of 0.9 - 0.55 = 0.35 m.
            let gap = rows.iter().map(|r| r.value * r.value).sum::<f64>().sqrt();
            assert!((gap - 0.35).abs() < 1e-3, "gap {gap} ({msg})");
            assert!(*residual > 0.1);
            assert!(rows.iter().any(|r| r.name == "pin.x"), "{msg}");
        }
        other => panic!("expected Infeasible, got {other}"),
    }
    assert!(
        msg.contains("cannot be satisfied") && msg.contains("pin.x"),
        "{msg}"
    );
    assert!(!msg.contains("NaN"), "{msg}");

    let sc = slider_crank();
    let mut ws = sc.workspace();
    let err = assemble_positions(
        &sc,
        &mut ws,
        &[0.0, 0.0, 0.4],
        &[2],
        &AssemblyOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(err, AssemblyError::Infeasible { .. }), "{err}");
    assert!(err.to_string().contains("pin.x"), "{err}");
}

/// A parallelogram four-bar (a = c, b = d) at q1 = 0 has all its links on one line: J
/// loses rank there and no choice of independent coordinates works. The run refuses to
/// start with an error naming the time, the coordinates and the smallest singular value.
#[test]
fn singular_configuration_stops_with_a_clear_error() {
    let text = model_text("models/four_bar.toml")
        .replace("b = 0.25", "b = 0.30")
        .replace("c = 0.20", "c = 0.10");
    let model = parse_model(&text, "parallelogram.toml");
    let sys = InterpretedSystem::new(&model);
    let (q0, qd0) = assemble(
        &sys,
        &[0.0, 0.0, 0.0],
        &[0],
        &[1.0, 0.0, 0.0],
        &[0],
        &AssemblyOptions::default(),
    )
    .unwrap();
    let err = Simulator::new(&sys, Settings::dopri5(1.0, 1e-9, 1e-11, 0.1), &q0, &qd0)
        .err()
        .unwrap();
    let msg = err.to_string();
    eprintln!("{msg}");
    assert!(err.is_singular(), "{msg}");
    match &err {
        SimError::Singular(r) => {
            assert_eq!((r.rank, r.expected_rank), (1, 2));
            assert!(r.sigma_min < 1e-12, "{msg}");
            assert_eq!(r.t, 0.0);
        }
        other => panic!("expected Singular, got {other}"),
    }
    assert!(msg.contains("singular configuration at t = 0"), "{msg}");
    assert!(
        msg.contains("q1 = ") && msg.contains("smallest singular value"),
        "{msg}"
    );
}
