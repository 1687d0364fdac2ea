//! The partitioned hybrid engine (`hybrid_core::hybrid`) against the independent dense
//! reference (`hybrid_core::hybrid::reference`): accelerations at consistent states,
//! trajectories, the energy account, re-partitioning and determinism (issue #10,
//! "Verified by").
//!
//! Mechanisms: the compiled `double_bar` and `slider_crank` of `models/`, and the
//! interpreted fixtures `tests/fixtures/{carriage_arm,chain3,four_bar_arm}.toml`.

use std::f64::consts::PI;

use fem_beam::TimeFunction;
use hybrid_core::hybrid::Method;
use hybrid_core::hybrid::reference::{self, Reference};
use hybrid_core::hybrid::{
    Attachment, AttachmentKind, BeamPoint, Excitation, ExcitationTarget, ForceKind, HybridModel,
    HybridState, Integrator, JointForce, MountedMechanism, Stored, balance_error, initial_state,
    input_work,
};
use mbs_symbolic::runtime::System;
use mbs_symbolic::samples::SplitMix64;

use crate::common;

use common::*;

/// The largest differences between the engine's accelerations and the dense KKT solution
/// at the same positions, velocities and currents, and the largest reference entries, per
/// block (the beam, each mechanism), accumulated over the states of a run.
///
/// The beam's accelerations balance elastic forces far larger than their net result when
/// the mechanism's reaction nearly cancels them (cond(A) ~ 3e5 at 20 elements), and a
/// mechanism's accelerations pass through zero while the beam drives it: both solutions
/// carry round-off relative to the block's size over the run, not to its value at one
/// instant. So the scale of the beam block is the larger of its largest acceleration and
/// the largest entry of `A^-1 C q` (the elastic term alone), each over the run; that of a
/// mechanism its largest acceleration over the run.
#[derive(Default)]
struct AccCheck {
    diff: Vec<f64>,
    scale: Vec<f64>,
}

impl AccCheck {
    /// Compares at `state` (and checks it is consistent: |h| at rounding level).
    fn add(&mut self, model: &HybridModel, state: &HybridState) {
        let mq: Vec<Vec<f64>> = state.mechanisms.iter().map(|m| m.q.clone()).collect();
        let mqd: Vec<Vec<f64>> = state.mechanisms.iter().map(|m| m.qd.clone()).collect();
        let h = reference::constraints(model, &state.q, &mq);
        assert!(
            max_abs(&h) < 1e-12,
            "t = {}: |h| = {:e}",
            state.t,
            max_abs(&h)
        );
        let (a, qdd, lambda) = reference::accelerations(
            model,
            state.t,
            &state.q,
            &state.v,
            &mq,
            &mqd,
            &state.currents,
        );
        assert!(lambda.iter().all(|l| l.is_finite()));
        let [mass, _, stiffness] = reference::structure_matrices(model).unwrap();
        let cq = stiffness * nalgebra::DVector::from_column_slice(&state.q);
        let elastic = mass.lu().solve(&cq).unwrap();
        let elastic = elastic.as_slice();
        let nm = qdd.len();
        self.diff.resize(nm + 1, 0.0);
        self.scale.resize(nm + 1, 0.0);
        self.diff[0] = self.diff[0].max(max_diff(&a, &state.a));
        self.scale[0] = self.scale[0].max(max_abs(&a)).max(max_abs(elastic));
        for (i, (r, m)) in qdd.iter().zip(&state.mechanisms).enumerate() {
            self.diff[i + 1] = self.diff[i + 1].max(max_diff(r, &m.qdd));
            self.scale[i + 1] = self.scale[i + 1].max(max_abs(r));
        }
    }

    /// Worst block's relative difference.
    fn worst(&self) -> f64 {
        self.diff
            .iter()
            .zip(&self.scale)
            .map(|(d, s)| d / s.max(1e-300))
            .fold(0.0, f64::max)
    }
}

// ---------------------------------------------------------------------------------------
// Accelerations: partitioned == dense KKT
// ---------------------------------------------------------------------------------------

/// Partitioned and KKT accelerations differ by the position solve's residual (Newton on
/// `h = 0` to 1e-12 of the geometry's scale), the Broyden iteration's stopping test (steps
/// below 1e-13 of the unknowns) and round-off in two different factorisations: 1e-10 of
/// the largest entry leaves a margin of about 100 over what is measured.
const ACC_TOL: f64 = 1e-10;

#[test]
fn paper_damper_accelerations_equal_the_kkt_solution() {
    for inductance in [0.0, 2e-3] {
        let (model, q0) = paper_damper(20, true, true, inductance);
        let n = q0.len();
        let mut state = initial_state(&model, q0, vec![0.0; n]).unwrap();
        let mut check = AccCheck::default();
        check.add(&model, &state);
        let mut integ = Integrator::new(&model, Method::Newmark, 1e-4, &state).unwrap();
        for _ in 0..200 {
            integ.step(&model, &mut state).unwrap();
            check.add(&model, &state);
        }
        let worst = check.worst();
        println!("paper damper (L = {inductance}): worst relative acceleration error {worst:e}");
        assert!(worst < ACC_TOL, "worst {worst:e}");
    }
}

#[test]
fn random_shapes_accelerations_equal_the_kkt_solution() {
    let mut seen = Vec::new();
    let mut worst_all = 0.0f64;
    for seed in 0..24u64 {
        let case = random_case(1000 + seed, None, false);
        for m in &case.model.mechanisms {
            if !seen.contains(&m.name) {
                seen.push(m.name.clone());
            }
        }
        let mut state = initial_state(&case.model, case.q0, case.v0)
            .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let mut check = AccCheck::default();
        check.add(&case.model, &state);
        let mut integ = Integrator::new(&case.model, Method::Newmark, 1e-4, &state).unwrap();
        for _ in 0..30 {
            integ
                .step(&case.model, &mut state)
                .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
            check.add(&case.model, &state);
        }
        let worst = check.worst();
        println!(
            "seed {seed}: {:?} free {:?}: worst {worst:e}",
            case.model
                .mechanisms
                .iter()
                .map(|m| m.name.as_str())
                .collect::<Vec<_>>(),
            state
                .mechanisms
                .iter()
                .map(|m| m.free.clone())
                .collect::<Vec<_>>()
        );
        assert!(worst < ACC_TOL, "seed {seed}: worst {worst:e}");
        worst_all = worst_all.max(worst);
    }
    println!("worst over all random shapes: {worst_all:e}");
    assert_eq!(seen.len(), SHAPES.len(), "every shape drawn: {seen:?}");
}

/// Under a support acceleration (beam and mechanism inertial loads, every mounting angle
/// of the random shapes) the engine's accelerations are the KKT solution's (whose beam load
/// is assembled apart, from `-(A r) a_b(t)` added to the dense right-hand side).
#[test]
fn base_excited_accelerations_equal_the_kkt_solution() {
    let mut worst_all = 0.0f64;
    for seed in 0..8u64 {
        let mut case = random_case(2000 + seed, None, false);
        case.model.excitations.push(Excitation {
            name: "support".into(),
            target: ExcitationTarget::BASE_Y,
            amplitude: 3.0,
            time: TimeFunction::Harmonic {
                frequency_hz: 7.0,
                phase: 0.3,
            },
        });
        let mut state = initial_state(&case.model, case.q0, case.v0)
            .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let mut check = AccCheck::default();
        check.add(&case.model, &state);
        let mut integ = Integrator::new(&case.model, Method::Newmark, 1e-4, &state).unwrap();
        for _ in 0..30 {
            integ
                .step(&case.model, &mut state)
                .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
            check.add(&case.model, &state);
        }
        let worst = check.worst();
        println!("base, seed {seed}: worst {worst:e}");
        assert!(worst < ACC_TOL, "seed {seed}: worst {worst:e}");
        worst_all = worst_all.max(worst);
    }
    println!("worst over the base-excited shapes: {worst_all:e}");
}

/// On a structure's node (the one-node model of `structures.rs`: 2 kg, springs along `x` and
/// `y`), the double bar pinned (two rows, the node's `ux` and `uy`) or on a roller along
/// `[0, 1]` and along the oblique `[0.6, 0.8]` (one row `d . (P - P_0) = d . u`): the engine's
/// accelerations are the dense KKT solution's, whose rows are written from the attachment's
/// position, direction and weights apart from the engine's follower.
#[test]
fn node_attachments_accelerations_equal_the_kkt_solution() {
    let paper = crate::structures::weightless_paper();
    for (kind, direction) in [
        (AttachmentKind::Pin, [0.0, 1.0]),
        (AttachmentKind::Roller, [0.0, 1.0]),
        (AttachmentKind::Roller, [0.6, 0.8]),
    ] {
        let model = crate::structures::damper_on_node(&paper, kind, direction, false);
        let mut state = initial_state(&model, vec![1e-3, 4e-4], vec![0.0; 2]).unwrap();
        let mut check = AccCheck::default();
        check.add(&model, &state);
        let mut integ = Integrator::new(&model, Method::Newmark, 1e-4, &state).unwrap();
        for _ in 0..300 {
            integ.step(&model, &mut state).unwrap();
            check.add(&model, &state);
        }
        let worst = check.worst();
        println!("{kind:?} along {direction:?}: worst relative acceleration error {worst:e}");
        assert!(worst < ACC_TOL, "{kind:?} {direction:?}: worst {worst:e}");
    }
}

// ---------------------------------------------------------------------------------------
// Trajectories: partitioned Newmark == RK4 on the KKT system with projection
// ---------------------------------------------------------------------------------------

/// Relative differences of a trajectory from the reference, sampled: per block (beam DOFs,
/// each mechanism's coordinates) the largest difference over the run divided by the
/// block's largest reference value over the run, the worst block.
#[derive(Default)]
struct TrajCheck {
    diff: Vec<f64>,
    scale: Vec<f64>,
}

impl TrajCheck {
    fn add(&mut self, model: &HybridModel, beam: &[f64], mech: &[Vec<f64>], reference: &Reference) {
        let nm = mech.len();
        self.diff.resize(nm + 1, 0.0);
        self.scale.resize(nm + 1, 0.0);
        self.diff[0] = self.diff[0].max(max_diff(beam, reference.beam_q()));
        self.scale[0] = self.scale[0].max(max_abs(reference.beam_q()));
        for (i, q) in mech.iter().enumerate() {
            let r = reference.mech_q(model, i);
            self.diff[i + 1] = self.diff[i + 1].max(max_diff(q, r));
            self.scale[i + 1] = self.scale[i + 1].max(max_abs(r));
        }
    }

    fn worst(&self) -> f64 {
        self.diff
            .iter()
            .zip(&self.scale)
            .map(|(d, s)| d / s)
            .fold(0.0, f64::max)
    }
}

/// What [`trajectory_errors`] measures: the engine at `h` and at `h/2` against the
/// reference, and their Richardson extrapolation `(4 x_{h/2} - x_h) / 3`.
struct TrajErrors {
    coarse: f64,
    fine: f64,
    extrapolated: f64,
}

/// Runs the engine (Newmark) at `dt_engine` and at `dt_engine / 2` and the reference (RK4 +
/// projection) at `dt_reference` over `t_end`, compared every `sample` s.
fn trajectory_errors(
    model: &HybridModel,
    q0: Vec<f64>,
    v0: Vec<f64>,
    dt_engine: f64,
    dt_reference: f64,
    t_end: f64,
    sample: f64,
) -> TrajErrors {
    let mut coarse = initial_state(model, q0, v0).unwrap();
    let mut fine = coarse.clone();
    let mut reference = Reference::from_state(model, &coarse);
    let mut ic = Integrator::new(model, Method::Newmark, dt_engine, &coarse).unwrap();
    let mut ifi = Integrator::new(model, Method::Newmark, 0.5 * dt_engine, &fine).unwrap();
    let per_engine = (sample / dt_engine).round() as usize;
    let per_reference = (sample / dt_reference).round() as usize;
    let samples = (t_end / sample).round() as usize;
    let (mut cc, mut cf, mut ce) = (
        TrajCheck::default(),
        TrajCheck::default(),
        TrajCheck::default(),
    );
    let extrapolate = |f: &[f64], c: &[f64]| -> Vec<f64> {
        f.iter().zip(c).map(|(f, c)| (4.0 * f - c) / 3.0).collect()
    };
    for _ in 0..samples {
        for _ in 0..per_engine {
            ic.step(model, &mut coarse).unwrap();
            ifi.step(model, &mut fine).unwrap();
            ifi.step(model, &mut fine).unwrap();
        }
        for _ in 0..per_reference {
            reference.step(model, dt_reference);
        }
        assert!((coarse.t - reference.t).abs() < 1e-9 && (fine.t - reference.t).abs() < 1e-9);
        let mq = |s: &HybridState| -> Vec<Vec<f64>> {
            s.mechanisms.iter().map(|m| m.q.clone()).collect()
        };
        cc.add(model, &coarse.q, &mq(&coarse), &reference);
        cf.add(model, &fine.q, &mq(&fine), &reference);
        let me: Vec<Vec<f64>> = mq(&fine)
            .iter()
            .zip(&mq(&coarse))
            .map(|(f, c)| extrapolate(f, c))
            .collect();
        ce.add(model, &extrapolate(&fine.q, &coarse.q), &me, &reference);
    }
    let (pos, vel) = reference.worst_residual;
    assert!(
        pos < 1e-12 && vel < 1e-9,
        "reference residuals {pos:e} {vel:e}"
    );
    TrajErrors {
        coarse: cc.worst(),
        fine: cf.worst(),
        extrapolated: ce.worst(),
    }
}

/// The tolerance on trajectories, 1e-6 of each block's amplitude over 0.5 s.
///
/// Newmark's average acceleration rule is the trapezoidal rule (symmetric), so its global
/// error is `c2 h^2 + c4 h^4 + ...`: the engine's own difference from the reference must
/// fall by 4 when `h` is halved (checked: a ratio between 3.5 and 4.5 — the engine
/// converges to the reference at second order), and the Richardson extrapolation
/// `(4 x_{h/2} - x_h) / 3` removes the `h^2` term. Where the initial state excites the
/// beam's high modes (random velocities, preloaded springs) the raw `h^2` term at any
/// affordable step is above 1e-6 (`(omega h)^2 / 12` with `omega` ~ 1e4 rad/s), so the
/// 1e-6 is asserted on the extrapolation (the paper's damper, released from its static
/// shape: 4.1e-6 at h = 1e-5, 1.0e-6 at 5e-6 measured). RK4 (`O(h^4)`) at its
/// stability-limited step is well below either (halving its step changes nothing
/// visible).
const TRAJ_TOL: f64 = 1e-6;

fn assert_converges(what: &str, e: &TrajErrors) {
    let ratio = e.coarse / e.fine;
    println!(
        "{what}: relative difference Newmark(h) {:e}, Newmark(h/2) {:e} (ratio {ratio:.2}), extrapolated {:e}",
        e.coarse, e.fine, e.extrapolated
    );
    assert!(
        (3.5..4.5).contains(&ratio),
        "{what}: second order: ratio {ratio}"
    );
    assert!(e.extrapolated < TRAJ_TOL, "{what}: {:e}", e.extrapolated);
}

#[test]
fn paper_damper_trajectory_matches_the_rk4_kkt_reference() {
    // 20 elements: the highest beam mode is at 2.86e5 rad/s, overdamped by the Rayleigh
    // term (beta omega^2 ~ 1.1e6 1/s), and RK4's real stability limit (2.79 / 1.1e6) asks
    // h < 2.6e-6: 2e-6. Newmark at 1e-5 and 5e-6.
    let (model, q0) = paper_damper(20, true, true, 0.0);
    let n = q0.len();
    let e = trajectory_errors(&model, q0, vec![0.0; n], 1e-5, 2e-6, 0.5, 1e-3);
    assert_converges("paper damper", &e);
}

/// The node attachments' trajectories (a pin; a roller along the oblique `[0.6, 0.8]`)
/// converge to the RK4 KKT reference at second order, the extrapolation within 1e-6. The
/// node's springs are soft (141 and 224 rad/s); the generator's damping reflected on the
/// crank sets RK4's step: 1e-5.
#[test]
fn node_attachment_trajectories_match_the_rk4_kkt_reference() {
    let paper = crate::structures::weightless_paper();
    for (kind, direction) in [
        (AttachmentKind::Pin, [0.0, 1.0]),
        (AttachmentKind::Roller, [0.6, 0.8]),
    ] {
        let model = crate::structures::damper_on_node(&paper, kind, direction, false);
        let e = trajectory_errors(
            &model,
            vec![1e-3, 4e-4],
            vec![0.0; 2],
            1e-4,
            1e-5,
            0.2,
            1e-3,
        );
        assert_converges(&format!("{kind:?} along {direction:?}"), &e);
    }
}

#[test]
fn random_shape_trajectories_match_the_rk4_kkt_reference() {
    // Three mechanisms (free coordinates, a loop, pin and rollers, an inductive generator
    // possibly), and two more random systems; 4–7 elements, with Rayleigh damping (1 % on
    // modes 1 and 2). Undamped, the highest modes (up to ~3e4 rad/s, excited by the
    // random initial velocities and the mechanisms' preloaded springs) keep ringing, and
    // Newmark's phase error on them, (omega h)^2 omega t / 12, is O(1) at any affordable
    // step: no step-halving sequence is then in its asymptotic regime (measured on case 1
    // undamped: 3.0e-3 at 5e-6, 1.3e-3 at 2.5e-6). Damped, they die out and the comparison
    // measures the engine. Newmark at 5e-6 and 2.5e-6, RK4 at 2.5e-6 (its step is limited
    // by stability, beta omega^2 < 2.79 / h, far from binding here; halving it changes
    // nothing visible).
    let cases = [
        random_case(
            7,
            Some(&[Shape::CarriageArm, Shape::SliderCrank, Shape::DoubleBarPin]),
            true,
        ),
        random_case(10, Some(&[Shape::FourBarArm, Shape::DoubleBarRoller]), true),
        random_case(9, Some(&[Shape::Chain3]), true),
    ];
    for (k, case) in cases.into_iter().enumerate() {
        let e = trajectory_errors(&case.model, case.q0, case.v0, 1e-5, 2.5e-6, 0.5, 1e-3);
        assert_converges(&format!("random case {k}"), &e);
    }
}

/// Regression test of the engine's quasi-Newton stopping test: the three-bar chain pinned
/// to the beam in a configuration where its rocker points away from the tip (a
/// non-Grashof four-bar with the beam), driven by a small torque against the knee spring,
/// Newmark at 1e-4 s for 2 s. Before the stalled-Newton test of `Integrator::solve` it
/// stopped at t = 0.8902 s with `NoConvergence` (residual 2.9e-14, i.e. round-off, after
/// 40 iterations, cond(J_d) = 13.3). Every state stays consistent.
#[test]
fn the_quasi_newton_iteration_stops_at_round_off() {
    let bm = beam(6, &[(0.0, "clamped")], None);
    let n = bm.dof_count();
    let x = 0.9;
    let bp = BeamPoint::on(&bm, x).unwrap();
    let q1 = 0.3;
    let (t2, t3) = close_triangle(0.05, q1, 0.15, 0.12, 0.15);
    let q = vec![q1, t2 - q1, t3 - t2];
    let system = fixture("chain3");
    let tip = system.point_index("tip").unwrap();
    let mount = mount_for(system.as_ref(), tip, &q, 0.0, [x, 0.0]);
    let model = HybridModel::new(
        Some(bm.into()),
        vec![MountedMechanism {
            name: "chain".into(),
            system,
            mount,
            max_condition: 1e8,
            reach: None,
            initial_q: q,
        }],
        vec![Attachment {
            name: "tip".into(),
            mechanism: 0,
            point: tip,
            kind: AttachmentKind::Pin,
            beam: bp,
        }],
        vec![],
        vec![Excitation {
            name: "motor".into(),
            target: ExcitationTarget::Joint {
                mechanism: 0,
                joint: 0,
            },
            amplitude: 2e-3,
            time: TimeFunction::Constant,
        }],
    )
    .unwrap();
    let mut state = initial_state(&model, vec![0.0; n], vec![0.0; n]).unwrap();
    state.mechanisms[0].free = vec![2];
    let mut integ = Integrator::new(&model, Method::Newmark, 1e-4, &state).unwrap();
    for _ in 0..20_000 {
        integ
            .step(&model, &mut state)
            .unwrap_or_else(|e| panic!("{e:?}"));
        assert!(state.mechanisms[0].residual < 1e-12);
    }
    assert!(!integ.repartitions.is_empty());
}

// ---------------------------------------------------------------------------------------
// Energy
// ---------------------------------------------------------------------------------------

/// A beam with five mechanisms of every kind: the double bar pinned near the tip (the
/// generator on its crank, with inductance), the carriage arm on a roller (a spring on the
/// arm), the slider-crank on a roller (gravity: potential energy), the four-bar with its
/// arm on a roller (loop + free coordinate, a spring on the arm) and the three-bar chain
/// pinned (a model spring at its knee). `dissipative`: Rayleigh damping, the generator
/// connected and dampers on the arm and the chain's crank; `excited`: a harmonic tip
/// force and a harmonic torque on the carriage's arm.
fn composite(dissipative: bool, excited: bool) -> Case {
    let bm = beam(8, &[(0.0, "clamped")], dissipative.then_some(0.01));
    let q0 = static_shape(&bm, 1.0, 2e-3);
    let mut rng = SplitMix64::new(2024);
    let spots = [
        (Shape::DoubleBarPin, 0.97),
        (Shape::CarriageArm, 0.55),
        (Shape::SliderCrank, 0.8),
        (Shape::FourBarArm, 0.3),
        (Shape::Chain3, 0.15),
    ];
    let (mut mechs, mut atts, mut forces) = (Vec::new(), Vec::new(), Vec::new());
    for (i, &(shape, x)) in spots.iter().enumerate() {
        let bp = BeamPoint::on(&bm, x).unwrap();
        let placed = place(shape, &mut rng, [x, bp.value(&q0)], 2e-3);
        let keep = |kind| match kind {
            ForceKind::Generator(mut g) => {
                g.connected = dissipative;
                Some(ForceKind::Generator(g))
            }
            ForceKind::Damper { .. } if !dissipative => None,
            other => Some(other),
        };
        placed.push_into(i, bp, (&mut mechs, &mut atts, &mut forces), keep);
    }
    let excitations = if excited {
        vec![
            Excitation {
                name: "tip_force".into(),
                target: ExcitationTarget::Beam(BeamPoint::on(&bm, 0.9).unwrap()),
                amplitude: 5.0,
                time: TimeFunction::Harmonic {
                    frequency_hz: 8.0,
                    phase: 0.3,
                },
            },
            Excitation {
                name: "arm_torque".into(),
                target: ExcitationTarget::Joint {
                    mechanism: 1,
                    joint: 1,
                },
                amplitude: 5e-3,
                time: TimeFunction::Harmonic {
                    frequency_hz: 5.0,
                    phase: 0.0,
                },
            },
        ]
    } else {
        vec![]
    };
    let n = q0.len();
    Case {
        model: HybridModel::new(Some(bm.into()), mechs, atts, forces, excitations).unwrap(),
        q0,
        v0: vec![0.0; n],
    }
}

/// Runs `case` with Newmark at `dt` for `t_end` and returns `(initial stored, worst
/// |balance| over the run, input work at the end)`, the balance being
/// `initial stored + input work - stored - dissipated` (all of it: beam loads, excitations,
/// the mechanism models' own loads; structure, scenario elements, model dampers).
fn energy_run(case: Case, dt: f64, t_end: f64) -> (f64, f64, f64) {
    let model = &case.model;
    let mut state = initial_state(model, case.q0, case.v0).unwrap();
    let mut integ = Integrator::new(model, Method::Newmark, dt, &state).unwrap();
    let mut stored = Stored::default();
    integ.stored_into(model, &state, &mut stored);
    let e0 = stored.total();
    let mut worst = 0.0f64;
    let mut input = 0.0;
    for k in 1..=(t_end / dt).round() as usize {
        integ.step(model, &mut state).unwrap();
        if k % 10 != 0 {
            continue;
        }
        integ.stored_into(model, &state, &mut stored);
        input = input_work(&state.account);
        worst = worst.max(balance_error(e0, &stored, &state.account).abs());
    }
    (e0, worst, input)
}

#[test]
fn conservative_systems_conserve_energy() {
    // No Rayleigh damping, generator disconnected, no damper, no excitation. The average
    // acceleration rule conserves the energy of the linear beam exactly; the mechanisms'
    // terms at t_{n+1} make an O(h^2) error that oscillates without drift (measured:
    // 1.07e-5 of E0 at dt = 1e-4 s). dt = 2.5e-5 s.
    let (e0, worst, input) = energy_run(composite(false, false), 2.5e-5, 2.0);
    println!(
        "conservative: initial energy {e0:e} J, worst |E - E0| / E0 = {:e}",
        worst / e0
    );
    assert_eq!(input, 0.0);
    assert!(worst < 1e-6 * e0, "{:e}", worst / e0);
}

#[test]
fn dissipation_and_excitation_balance_the_energy_account() {
    // Rayleigh damping, the inductive generator, dampers, a harmonic beam force and joint
    // torque; the account's integrals are trapezoidal / midpoint rules, exact for the
    // linear beam under the average-acceleration rule, O(h^2) for the mechanisms' terms
    // (measured with a 2 N force: 7.6e-6 of E0 at dt = 1e-4 s). dt = 2.5e-5 s over 2 s.
    let (e0, worst, input) = energy_run(composite(true, true), 2.5e-5, 2.0);
    let scale = e0.max(input.abs());
    println!(
        "dissipative + excited: initial {e0:e} J, input work {input:e} J, worst balance / scale = {:e}",
        worst / scale
    );
    assert!(input.abs() > 0.05 * e0, "the excitation does work");
    assert!(worst < 1e-6 * scale, "{:e}", worst / scale);
}

/// The carriage arm on a roller at `x = 0.8` of a damped cantilever deflected by 2 mm, its
/// arm carrying a pivot spring-damper (`k = 0.05 N m/rad`, `c = 2e-4 N m s/rad`, rest
/// 0.3 rad) either as scenario force elements on its joint (`model_level = false`, the
/// `carriage_arm` fixture) or in the model file (`carriage_arm_damped.toml`, which adds a
/// tether spring-damper to a ground anchor and a constant ground-frame force on the arm's
/// end: model-level dissipation of both kinds and model-level input work).
fn arm_case(model_level: bool) -> Case {
    let bm = beam(8, &[(0.0, "clamped")], Some(0.01));
    let q0 = static_shape(&bm, 1.0, 2e-3);
    let x = 0.8;
    let bp = BeamPoint::on(&bm, x).unwrap();
    let system = fixture(if model_level {
        "carriage_arm_damped"
    } else {
        "carriage_arm"
    });
    let roller = system.point_index("roller").unwrap();
    let q = vec![0.0, 1.2];
    let mount = mount_for(system.as_ref(), roller, &q, 0.2, [x, bp.value(&q0)]);
    let forces = if model_level {
        vec![]
    } else {
        [
            ForceKind::Spring { k: 0.05, q0: 0.3 },
            ForceKind::Damper { c: 2e-4 },
        ]
        .into_iter()
        .enumerate()
        .map(|(k, kind)| JointForce {
            name: format!("pivot{k}"),
            mechanism: 0,
            joint: 1,
            kind,
        })
        .collect()
    };
    let n = q0.len();
    Case {
        model: HybridModel::new(
            Some(bm.into()),
            vec![MountedMechanism {
                name: "arm".into(),
                system,
                mount,
                max_condition: 1e8,
                reach: None,
                initial_q: q,
            }],
            vec![Attachment {
                name: "roller".into(),
                mechanism: 0,
                point: roller,
                kind: AttachmentKind::Roller,
                beam: bp,
            }],
            forces,
            vec![],
        )
        .unwrap(),
        q0,
        v0: vec![0.0; n],
    }
}

/// What an energy run of [`arm_case`] measured: the initial stored energy, the worst
/// |balance| (the engine's account) and the worst |balance| with the model elements' terms
/// left out (the account as it was before they entered it), the model dampers' dissipation
/// and the model loads' work at the end, and the scenario elements' dissipation at the end.
struct ArmRun {
    e0: f64,
    worst: f64,
    worst_without_model_terms: f64,
    dissipated_model: f64,
    model_work: f64,
    dissipated_scenario: f64,
}

fn arm_run(case: Case, dt: f64, t_end: f64) -> ArmRun {
    let model = &case.model;
    let mut state = initial_state(model, case.q0, case.v0).unwrap();
    let mut integ = Integrator::new(model, Method::Newmark, dt, &state).unwrap();
    let mut stored = Stored::default();
    integ.stored_into(model, &state, &mut stored);
    let e0 = stored.total();
    let (mut worst, mut without) = (0.0f64, 0.0f64);
    for k in 1..=(t_end / dt).round() as usize {
        integ.step(model, &mut state).unwrap();
        if k % 10 != 0 {
            continue;
        }
        integ.stored_into(model, &state, &mut stored);
        let acc = &state.account;
        let err = balance_error(e0, &stored, acc);
        let model_terms =
            acc.model_input_work.iter().sum::<f64>() - acc.dissipated_model.iter().sum::<f64>();
        worst = worst.max(err.abs());
        without = without.max((err - model_terms).abs());
    }
    let acc = &state.account;
    ArmRun {
        e0,
        worst,
        worst_without_model_terms: without,
        dissipated_model: acc.dissipated_model.iter().sum(),
        model_work: acc.model_input_work.iter().sum(),
        dissipated_scenario: acc.dissipated.iter().sum(),
    }
}

#[test]
fn model_level_dampers_and_loads_enter_the_energy_account() {
    // The same pivot spring-damper as scenario elements and as model elements (plus, at
    // model level, a tether spring-damper and a constant force): both accounts must close
    // to the same tolerance (O(h^2) of the mechanism terms, dt = 5e-5 s over 1 s), and the
    // model terms must matter: leaving them out breaks the balance by orders of magnitude
    // more than its tolerance.
    let (dt, t_end) = (5e-5, 1.0);
    let scenario = arm_run(arm_case(false), dt, t_end);
    let model = arm_run(arm_case(true), dt, t_end);
    println!(
        "scenario-level: E0 {:e} J, dissipated {:e} J, worst balance / E0 {:e}",
        scenario.e0,
        scenario.dissipated_scenario,
        scenario.worst / scenario.e0
    );
    println!(
        "model-level: E0 {:e} J, dissipated by the model's dampers {:e} J, model work {:e} J, worst balance / E0 {:e}, without the model terms {:e}",
        model.e0,
        model.dissipated_model,
        model.model_work,
        model.worst / model.e0,
        model.worst_without_model_terms / model.e0
    );
    assert_eq!(scenario.dissipated_model, 0.0);
    assert!(scenario.dissipated_scenario > 0.0);
    assert!(model.dissipated_model > 0.0 && model.model_work != 0.0);
    assert_eq!(model.dissipated_scenario, 0.0);
    for run in [&scenario, &model] {
        assert!(run.worst < 1e-6 * run.e0, "{:e}", run.worst / run.e0);
    }
    assert!(
        model.worst_without_model_terms > 100.0 * model.worst.max(scenario.worst),
        "the model terms are significant: {:e} vs {:e}",
        model.worst_without_model_terms,
        model.worst
    );
}

// ---------------------------------------------------------------------------------------
// Re-partitioning and determinism
// ---------------------------------------------------------------------------------------

#[test]
fn degenerating_free_coordinates_trigger_a_logged_repartition() {
    // The three-bar chain pinned to the beam is a crank-rocker four-bar with the ground
    // pivot G and the tip T; a constant torque turns the crank. With the rocker angle q3
    // free, the dependent block (q1, q2) is singular when the crank lies along G-T (crank
    // angle pi), which the crank reaches (the torque, 0.1 N m, overcomes the knee spring):
    // the engine must switch to a better block before, as often as the blocks degrade.
    let bm = beam(6, &[(0.0, "clamped")], None);
    let n = bm.dof_count();
    let x = 0.9;
    let bp = BeamPoint::on(&bm, x).unwrap();
    let (l1, l2, l3, d) = (0.05, 0.15, 0.12, 0.15);
    let q1 = PI / 2.0;
    let (t2, t3) = close_triangle(l1, q1, l2, l3, d);
    let q = vec![q1, t2 - q1, t3 + PI - t2];
    let system = fixture("chain3");
    let tip = system.point_index("tip").unwrap();
    let mount = mount_for(system.as_ref(), tip, &q, 0.0, [x, 0.0]);
    let model = HybridModel::new(
        Some(bm.into()),
        vec![MountedMechanism {
            name: "chain".into(),
            system,
            mount,
            max_condition: 1e8,
            reach: None,
            initial_q: q,
        }],
        vec![Attachment {
            name: "tip".into(),
            mechanism: 0,
            point: tip,
            kind: AttachmentKind::Pin,
            beam: bp,
        }],
        vec![],
        vec![Excitation {
            name: "motor".into(),
            target: ExcitationTarget::Joint {
                mechanism: 0,
                joint: 0,
            },
            amplitude: 0.1,
            time: TimeFunction::Constant,
        }],
    )
    .unwrap();
    let mut state = initial_state(&model, vec![0.0; n], vec![0.0; n]).unwrap();
    state.mechanisms[0].free = vec![2];
    let mut integ = Integrator::new(&model, Method::Newmark, 1e-4, &state).unwrap();
    let mut steps = 0;
    while state.mechanisms[0].q[0] < 2.0 * PI && steps < 20_000 {
        integ.step(&model, &mut state).unwrap();
        steps += 1;
        let m = &state.mechanisms[0];
        assert!(
            m.residual < 1e-12,
            "t = {}: residual {:e}",
            state.t,
            m.residual
        );
        let h = reference::constraints(&model, &state.q, std::slice::from_ref(&m.q));
        assert!(
            max_abs(&h) < 1e-12,
            "t = {}: |h| = {:e}",
            state.t,
            max_abs(&h)
        );
    }
    println!(
        "crank at {:.3} rad after {steps} steps (t = {:.4} s); re-partitions: {:?}",
        state.mechanisms[0].q[0], state.t, integ.repartitions
    );
    assert!(
        state.mechanisms[0].q[0] >= 2.0 * PI,
        "the crank turned round"
    );
    let first = integ.repartitions.first().expect("a logged re-partition");
    assert_eq!(first.mechanism, 0);
    assert_eq!(first.from, vec![2]);
    assert!(
        first.t > 0.01,
        "the block degraded during the motion, not at the start"
    );
    assert!(first.condition.1 < first.condition.0);
}

#[test]
fn identical_runs_are_bit_identical() {
    let run = || {
        let case = random_case(
            4242,
            Some(&[
                Shape::FourBarArm,
                Shape::DoubleBarRoller,
                Shape::SliderCrank,
            ]),
            false,
        );
        let mut state = initial_state(&case.model, case.q0, case.v0).unwrap();
        let mut integ = Integrator::new(&case.model, Method::Newmark, 1e-4, &state).unwrap();
        let mut stored = Stored::default();
        let mut energies = Vec::new();
        for _ in 0..2000 {
            integ.step(&case.model, &mut state).unwrap();
            integ.stored_into(&case.model, &state, &mut stored);
            energies.push(stored.total().to_bits());
        }
        (state, integ.repartitions.clone(), energies)
    };
    let (a, b) = (run(), run());
    assert!(a.0.q.iter().any(|x| *x != 0.0));
    assert_eq!(a.0, b.0);
    assert_eq!(a.1, b.1);
    assert_eq!(a.2, b.2);
}

/// The one-unknown iteration's secant acceptance (the third iterate of a step taken from
/// the secant through the first two evaluations, the mechanism's state moved along it,
/// without evaluating it) gives the states of evaluating every accepted iterate to the
/// iteration's tolerance, with fewer evaluations per step (about 2.5 against 3 here). Both
/// accept iterates whose next correction is below 1e-13 of the unknown's scale, which is
/// `|z| + |a0_w|`, some 15 |z| here: the tip accelerations may differ by a few 1e-12 of
/// themselves, and the beam's undamped high modes (average acceleration) carry such a
/// difference on, and its accelerations amplify it by 1 / (gamma h): measured, 1.3e-11 of
/// the beam velocities' amplitude and 1.8e-10 of the accelerations' at worst. Both start
/// each step from the state's own value (not the extrapolated start, whose first
/// corrections are so small that the third iterate is rarely needed, evaluated or not:
/// [`extrapolated_start_matches_the_state_start`]).
#[test]
fn secant_acceptance_matches_evaluated_iterates() {
    let runs = [true, false].map(|on| {
        paper_damper_rows(3000, |integ| {
            integ.set_secant_acceptance(on);
            integ.set_extrapolated_start(false);
        })
    });
    let [(on, on_evals), (off, off_evals)] = &runs;
    assert_paper_damper_rows_agree(on, off, 1e-9);
    assert!(
        *on_evals <= 2.6 && *off_evals >= 2.9,
        "evaluations per step {on_evals} (secant acceptance) and {off_evals} (without)"
    );
}

/// The one-unknown iteration's extrapolated warm start (the polynomial through the last
/// steps' values the last step found best, `Integrator::extrapolate_start`) gives the states
/// of starting from the state's own value to the iteration's tolerance, with fewer
/// evaluations over the release's transient (measured 2.02 against 2.49 per step here). Both
/// accept iterates whose next correction is below 1e-13 of the unknown's scale, the
/// tolerance of [`secant_acceptance_matches_evaluated_iterates`], which the beam's undamped
/// high modes carry on: the same bound per group of quantities (measured 2.0e-10 of the
/// group's amplitude at worst).
#[test]
fn extrapolated_start_matches_the_state_start() {
    let runs =
        [true, false].map(|on| paper_damper_rows(3000, |integ| integ.set_extrapolated_start(on)));
    let [(on, on_evals), (off, off_evals)] = &runs;
    let worst_ratio = assert_paper_damper_rows_agree(on, off, 1e-9);
    // Not the same iterates: the test compares two different iterations.
    assert!(worst_ratio > 0.0);
    assert!(
        *on_evals <= 2.05 && *off_evals >= 2.3,
        "evaluations per step {on_evals} (extrapolated start) and {off_evals} (without)"
    );
}

/// The paper's damper from its initial state over `steps` Newmark steps of 1e-4 s, with
/// the integrator set by `configure`: per step the beam's q, v, a, the mechanism's q, q',
/// q'', the currents, the force elements' and the beam's dissipations in one row, and the
/// residual evaluations per step.
fn paper_damper_rows(
    steps: usize,
    configure: impl Fn(&mut hybrid_core::hybrid::Integrator),
) -> (Vec<Vec<f64>>, f64) {
    let d = PaperDamper::default();
    let (hm, q0) = d.hybrid();
    let n = q0.len();
    let mut state = hybrid_core::hybrid::initial_state(&hm, q0, vec![0.0; n]).unwrap();
    let mut integ =
        hybrid_core::hybrid::Integrator::new(&hm, Method::Newmark, 1e-4, &state).unwrap();
    configure(&mut integ);
    let before = integ.evaluations();
    let mut history: Vec<Vec<f64>> = vec![];
    for _ in 0..steps {
        integ.step(&hm, &mut state).unwrap();
        let m = &state.mechanisms[0];
        let acc = &state.account;
        history.push(
            [
                &state.q,
                &state.v,
                &state.a,
                &m.q,
                &m.qd,
                &m.qdd,
                &state.currents,
            ]
            .into_iter()
            .flatten()
            .chain(&acc.dissipated)
            .copied()
            .chain([acc.dissipated_structure])
            .collect(),
        );
    }
    let per_step = (integ.evaluations() - before) as f64 / steps as f64;
    (history, per_step)
}

/// Asserts that the rows of [`paper_damper_rows`] `a` and `b` agree within `tol` of each
/// group's amplitude in `b` (beam q, v, a; the mechanism's q, q', q''; currents;
/// dissipations), as compare-trajectories measures a column against its signal: a beam DOF
/// near the clamp is measured against the beam's motion. Returns the worst difference over
/// its group's amplitude.
fn assert_paper_damper_rows_agree(a: &[Vec<f64>], b: &[Vec<f64>], tol: f64) -> f64 {
    let d = PaperDamper::default();
    let (hm, q0) = d.hybrid();
    let n = q0.len();
    let start = hybrid_core::hybrid::initial_state(&hm, q0, vec![0.0; n]).unwrap();
    let (nm, nf) = (start.mechanisms[0].q.len(), start.currents.len());
    let mut from = 0;
    let mut worst_ratio = 0.0f64;
    for (group, len) in [n, n, n, nm, nm, nm, nf, nf, 1].into_iter().enumerate() {
        let range = from..from + len;
        from += len;
        let amplitude = b
            .iter()
            .flat_map(|h| &h[range.clone()])
            .fold(0.0, |m: f64, x| m.max(x.abs()));
        let worst = a
            .iter()
            .zip(b)
            .flat_map(|(x, y)| x[range.clone()].iter().zip(&y[range.clone()]))
            .fold(0.0, |m: f64, (x, y)| m.max((x - y).abs()));
        assert!(
            worst <= tol * amplitude,
            "group {group}: {worst:e} of amplitude {amplitude:e}"
        );
        worst_ratio = worst_ratio.max(worst / amplitude);
    }
    assert_eq!(from, a[0].len());
    worst_ratio
}

/// Step by step, the state the secant acceptance moves along the secant is the state of
/// evaluating the same iterate: from the same integrator and state, one step with and one
/// without it give the mechanism's `q`, `q'`, `q''` and the current within 1e-13 of their
/// amplitudes, the beam accelerations within 1e-12, over the 1,000 steps of the paper's damper compared (the
/// moved state's error is of second order in a move of about 1e-8 of the unknown; the
/// evaluations' own rounding is larger), nearly all of them taken with two evaluations
/// instead of three (each step started from the state's own value, as in
/// [`secant_acceptance_matches_evaluated_iterates`]).
#[test]
fn secant_acceptance_step_equals_the_evaluated_step() {
    let d = PaperDamper::default();
    let (hm, q0) = d.hybrid();
    let n = q0.len();
    let mut state = hybrid_core::hybrid::initial_state(&hm, q0, vec![0.0; n]).unwrap();
    let mut integ =
        hybrid_core::hybrid::Integrator::new(&hm, Method::Newmark, 1e-4, &state).unwrap();
    integ.set_extrapolated_start(false);
    // Past the release's transient (0.5 s), where nearly every step is shortened.
    for _ in 0..5000 {
        integ.step(&hm, &mut state).unwrap();
    }
    let mut shortened = 0;
    // Per group (q, q', q'', currents, beam a): the largest difference and magnitude.
    let (mut worst, mut amplitude) = ([0.0f64; 5], [0.0f64; 5]);
    for _ in 0..1000 {
        let (mut other, mut evaluated) = (integ.clone(), state.clone());
        other.set_secant_acceptance(false);
        let before = (integ.evaluations(), other.evaluations());
        integ.step(&hm, &mut state).unwrap();
        other.step(&hm, &mut evaluated).unwrap();
        let taken = (
            integ.evaluations() - before.0,
            other.evaluations() - before.1,
        );
        assert!(taken.0 <= taken.1, "{taken:?}");
        if taken.0 < taken.1 {
            shortened += 1;
        }
        let (m, e) = (&state.mechanisms[0], &evaluated.mechanisms[0]);
        for (k, (a, b)) in [
            (&m.q, &e.q),
            (&m.qd, &e.qd),
            (&m.qdd, &e.qdd),
            (&state.currents, &evaluated.currents),
            (&state.a, &evaluated.a),
        ]
        .into_iter()
        .enumerate()
        {
            for (x, y) in a.iter().zip(b) {
                worst[k] = worst[k].max((x - y).abs());
                amplitude[k] = amplitude[k].max(y.abs());
            }
        }
    }
    // The beam accelerations take `phi_w`, the multiplier of the pin's row: a sum of
    // inertial, generator and constraint forces that nearly cancel, whose rounding in an
    // evaluation is about 1e-13 of the accelerations' amplitude (measured 1.8e-13).
    let tolerance = [1e-13, 1e-13, 1e-13, 1e-13, 1e-12];
    for (k, what) in ["q", "q'", "q''", "currents", "beam a"].iter().enumerate() {
        assert!(
            worst[k] <= tolerance[k] * amplitude[k],
            "{what}: {:e} of amplitude {:e}",
            worst[k],
            amplitude[k]
        );
    }
    assert!(shortened >= 900, "{shortened} of 1000 steps shortened");
}
