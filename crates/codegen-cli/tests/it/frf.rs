//! The frequency response (issue #11, item 4): the pendulum absorber scenario against the
//! two-degree-of-freedom closed form and Den Hartog's equal-peak tuning, and `damper frf`
//! run as a user would.

use crate::common;

use std::f64::consts::PI;

use codegen_cli::setup::{Linearizable, tangents_for};
use common::{assert_bad_input, damper, root};
use hybrid_core::hybrid::{
    BeamPoint, EigenMethod, EquilibriumOptions, ExcitationTarget, ForceKind, HybridModel,
    Linearization, modes,
};
use nalgebra::{Complex, DMatrix};

/// The absorber scenario, loaded and built as the CLI does.
fn absorber() -> Linearizable {
    let sc = codegen_cli::scenario::load(&root().join("scenarios/pendulum_absorber.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    tangents_for(&sc).unwrap_or_else(|e| panic!("{e}"))
}

/// The arm's run-time parameters (`models/absorber.toml` defaults; the scenario keeps them).
struct Arm {
    m_c: f64,
    mass: f64,
    /// `M l_c`.
    first_moment: f64,
    /// `l_a^2 (m_a/3 + m_t)`.
    i_pivot: f64,
}

fn arm() -> Arm {
    let model = mbs_symbolic::model::load(&root().join("models/absorber.toml")).unwrap();
    let values = model.default_params();
    let p = |name: &str| values[model.param_index(name).unwrap()];
    let (m_c, m_a, m_t, l_a) = (p("m_c"), p("m_a"), p("m_t"), p("l_a"));
    Arm {
        m_c,
        mass: m_a + m_t,
        first_moment: l_a * (m_a / 2.0 + m_t),
        i_pivot: l_a * l_a * (m_a / 3.0 + m_t),
    }
}

/// The beam's first mode reduced to the tip (`q^c = y phi / phi_tip`, unit modal mass):
/// `(m1, k1, omega_1, zeta_1)` with `zeta_1` its Rayleigh damping ratio.
fn primary(model: &HybridModel) -> (f64, f64, f64, f64) {
    let beam = model.beam().unwrap();
    let modes = beam.modes(1).unwrap();
    let w1 = modes.angular_frequencies()[0];
    let tip = BeamPoint::on(beam, 1.0).unwrap();
    let phi_tip = tip.value(modes.shape(0));
    let m1 = 1.0 / (phi_tip * phi_tip);
    let (a, b) = beam.rayleigh_coefficients();
    (m1, w1 * w1 * m1, w1, a / (2.0 * w1) + b * w1 / 2.0)
}

/// The eigenvalues (upper half plane, by increasing imaginary part) of the two-DOF model
/// `M2 x'' + C2 x' + K2 x = 0` in `x = (y, theta)` (see `hybrid-core/tests/hybrid_absorber.rs`
/// for its derivation from the absorber's kinetic energy):
///
/// ```text
/// M2 = [[m1 + m_c + M, M l_c], [M l_c, I_p]],  C2 = diag(2 zeta_1 omega_1 m1, c),
/// K2 = diag(k1, k_t)
/// ```
///
/// solved through the 4 x 4 first-order matrix.
fn two_dof(
    (m1, k1, w1, z1): (f64, f64, f64, f64),
    arm: &Arm,
    i_p: f64,
    k_t: f64,
    c: f64,
) -> Vec<Complex<f64>> {
    let m2 = DMatrix::from_row_slice(
        2,
        2,
        &[
            m1 + arm.m_c + arm.mass,
            arm.first_moment,
            arm.first_moment,
            i_p,
        ],
    );
    let c2 = DMatrix::from_row_slice(2, 2, &[2.0 * z1 * w1 * m1, 0.0, 0.0, c]);
    let k2 = DMatrix::from_row_slice(2, 2, &[k1, 0.0, 0.0, k_t]);
    let minv = m2.try_inverse().unwrap();
    let mut a = DMatrix::zeros(4, 4);
    a.view_mut((0, 2), (2, 2))
        .copy_from(&DMatrix::identity(2, 2));
    a.view_mut((2, 0), (2, 2)).copy_from(&(-&minv * k2));
    a.view_mut((2, 2), (2, 2)).copy_from(&(-&minv * c2));
    let mut l: Vec<Complex<f64>> = a
        .complex_eigenvalues()
        .iter()
        .copied()
        .filter(|l| l.im > 0.0)
        .collect();
    l.sort_by(|a, b| a.im.total_cmp(&b.im));
    l
}

fn joint_forces(model: &HybridModel) -> (f64, f64, Option<f64>) {
    let mut k_t = 0.0;
    let mut rotor = 0.0;
    let mut c = None;
    for f in &model.forces {
        match &f.kind {
            ForceKind::Spring { k, .. } => k_t = *k,
            ForceKind::Generator(g) => {
                rotor = g.reflected_inertia();
                c = Some(g.damping_coefficient());
            }
            ForceKind::Damper { c: d } => c = Some(*d),
        }
    }
    (k_t, rotor, c)
}

#[test]
fn absorber_scenario_linearised_modes_equal_the_two_dof_closed_form() {
    let lz = absorber();
    let arm = arm();
    let p = primary(&lz.model);
    let (k_t, rotor, c_g) = joint_forces(&lz.model);
    // The rotor stays attached when the generator is disconnected: n^2 J_r at the pivot.
    let i_p = arm.i_pivot + rotor;
    for (label, model, c) in [
        (
            "generator disconnected",
            lz.model.generators_disconnected(),
            0.0,
        ),
        ("with generator", lz.model.clone(), c_g.unwrap()),
    ] {
        let lin = lz.linearize(&model).unwrap();
        let found = modes(&lin, 2, EigenMethod::Dense).unwrap();
        let reference = two_dof(p, &arm, i_p, k_t, c);
        for (m, r) in found.iter().zip(&reference) {
            let l = m.lambda();
            let rel = (l - r).norm() / r.norm();
            let fn_rel = (m.natural_frequency_hz * 2.0 * PI - r.norm()) / r.norm();
            println!(
                "{label}: linearised {l:.5} ({:.5} Hz, zeta {:.4}), 2-DOF {r:.5} ({:.5} Hz, zeta {:.4}): eigenvalue {rel:.2e}, natural frequency {fn_rel:.2e}",
                m.natural_frequency_hz,
                m.damping_ratio,
                r.norm() / (2.0 * PI),
                -r.re / r.norm()
            );
            // The 2-DOF model leaves out the higher beam modes (their static flexibility
            // at the tip shifts the frequencies by ~1e-3): 0.5 % per the issue.
            assert!(rel < 5e-3, "{label}: {rel:e}");
        }
    }
}

/// Den Hartog's tuning of the absorber on the scenario's beam, with a viscous damper `c` on
/// the arm in place of the generator (no rotor inertia).
///
/// The arm is a translational absorber in disguise: with `x_a = y + (I_p / b) theta`
/// (`b = M l_c`) the kinetic energy `(a y'^2 + 2 b y' theta' + I_p theta'^2) / 2` splits
/// into `m_p y'^2 / 2 + m_a x_a'^2 / 2` with `m_a = b^2 / I_p`, `m_p = a - m_a`, the spring
/// `k_t theta^2 / 2` into `k_a (x_a - y)^2 / 2` with `k_a = k_t b^2 / I_p^2` (so
/// `omega_a^2 = k_t / I_p`), the damper into `c_a = c b^2 / I_p^2`. With `mu = m_a / m_p`,
/// `omega_p^2 = k1 / m_p`: `omega_a = omega_p / (1 + mu)`,
/// `zeta = c_a / (2 m_a omega_p) = sqrt(3 mu / (8 (1 + mu)^3))`.
fn tuned(lz: &Linearizable, detune: f64) -> (HybridModel, f64, f64) {
    let arm = arm();
    let (m1, k1, _, _) = primary(&lz.model);
    let i_p = arm.i_pivot;
    let b = arm.first_moment;
    let m_a = b * b / i_p;
    let m_p = m1 + arm.m_c + arm.mass - m_a;
    let mu = m_a / m_p;
    let w_p = (k1 / m_p).sqrt();
    let w_a = detune * w_p / (1.0 + mu);
    let zeta = (3.0 * mu / (8.0 * (1.0 + mu).powi(3))).sqrt();
    let c_a = 2.0 * zeta * m_a * w_p;
    let mut model = lz.model.clone();
    for f in &mut model.forces {
        f.kind = match f.kind {
            ForceKind::Spring { q0, .. } => ForceKind::Spring {
                k: i_p * w_a * w_a,
                q0,
            },
            _ => ForceKind::Damper {
                c: c_a * i_p * i_p / (b * b),
            },
        };
    }
    (model, mu, w_p)
}

/// `|H|` at the tip for a force at the tip.
fn tip_receptance(lin: &Linearization, tip: &BeamPoint, omega: f64) -> f64 {
    let f = lin.force_vector(&ExcitationTarget::Beam(tip.clone()));
    let z = lin.harmonic_response(&f, omega).unwrap();
    let re: Vec<f64> = z.iter().map(|v| v.re).collect();
    let im: Vec<f64> = z.iter().map(|v| v.im).collect();
    tip.value(&re).hypot(tip.value(&im))
}

/// The two highest local maxima of `|H|` (rad/s, value) between `lo` and `hi`: a grid, then
/// golden-section refinement of each.
fn two_peaks(h: &dyn Fn(f64) -> f64, lo: f64, hi: f64) -> Vec<(f64, f64)> {
    let n = 2000;
    let w: Vec<f64> = (0..=n)
        .map(|k| lo + (hi - lo) * k as f64 / n as f64)
        .collect();
    let v: Vec<f64> = w.iter().map(|&x| h(x)).collect();
    let mut peaks: Vec<(f64, f64)> = (1..n)
        .filter(|&k| v[k] > v[k - 1] && v[k] >= v[k + 1])
        .map(|k| {
            let (mut a, mut b) = (w[k - 1], w[k + 1]);
            let g = (5f64.sqrt() - 1.0) / 2.0;
            for _ in 0..60 {
                let (c, d) = (b - g * (b - a), a + g * (b - a));
                if h(c) > h(d) {
                    b = d;
                } else {
                    a = c;
                }
            }
            let x = 0.5 * (a + b);
            (x, h(x))
        })
        .collect();
    peaks.sort_by(|a, b| b.1.total_cmp(&a.1));
    peaks.truncate(2);
    peaks.sort_by(|a, b| a.0.total_cmp(&b.0));
    peaks
}

#[test]
fn den_hartog_tuning_gives_equal_peaks_in_the_frf() {
    let lz = absorber();
    let tip = BeamPoint::on(lz.model.beam().unwrap(), 1.0).unwrap();
    let arm = arm();
    let mut ratios = vec![];
    for detune in [1.0, 0.9] {
        let (model, mu, w_p) = tuned(&lz, detune);
        let lin =
            Linearization::new(&model, &lz.tangent_refs(), EquilibriumOptions::default()).unwrap();
        let h = |w: f64| tip_receptance(&lin, &tip, w);
        let peaks = two_peaks(&h, 0.6 * w_p, 1.4 * w_p);
        // The ideal two-DOF system (undamped primary, first beam mode only) with the same
        // arm, spring and damper: Den Hartog's own setting.
        let (k_t, _, c) = joint_forces(&model);
        let (m1, k1, _, _) = primary(&lz.model);
        let h2 = |w: f64| {
            let m = [
                [m1 + arm.m_c + arm.mass, arm.first_moment],
                [arm.first_moment, arm.i_pivot],
            ];
            let d =
                |r: usize, col: usize, k: f64, c: f64| Complex::new(k - w * w * m[r][col], w * c);
            let (a, b) = (d(0, 0, k1, 0.0), d(0, 1, 0.0, 0.0));
            let dd = d(1, 1, k_t, c.unwrap());
            (dd / (a * dd - b * b)).norm()
        };
        let ideal = two_peaks(&h2, 0.6 * w_p, 1.4 * w_p);
        let ratio = |p: &[(f64, f64)]| {
            if p.len() == 2 {
                p[0].1 / p[1].1
            } else {
                f64::INFINITY // one peak: the other is a shoulder
            }
        };
        println!(
            "mu = {mu:.4}, f_p = {:.4} Hz, arm tuned to {detune} x f_opt: peaks (Hz, m/N) {:?}: ratio {:.4}; ideal two-DOF: {:?}, ratio {:.4}",
            w_p / (2.0 * PI),
            peaks
                .iter()
                .map(|p| (p.0 / (2.0 * PI), p.1))
                .collect::<Vec<_>>(),
            ratio(&peaks),
            ideal
                .iter()
                .map(|p| (p.0 / (2.0 * PI), p.1))
                .collect::<Vec<_>>(),
            ratio(&ideal)
        );
        ratios.push((ratio(&peaks), ratio(&ideal)));
    }
    // Tuned: Den Hartog's damping is the mean of the two values that put the maximum at
    // either fixed point, so the peaks are equal only approximately; in the ideal two-DOF
    // system at this mass ratio they agree to 2e-4 (measured: 0.9998). The scenario's
    // beam adds its 0.2 % structural damping and its higher modes' flexibility: measured
    // 1.014 (the lower peak 1.4 % above the upper one). 3 % is
    // the classical "equal within a few percent", twice the measured mismatch.
    let (tuned_ratio, ideal_ratio) = ratios[0];
    assert!((tuned_ratio - 1.0).abs() < 0.03, "tuned: {tuned_ratio}");
    assert!((ideal_ratio - 1.0).abs() < 1e-3, "ideal: {ideal_ratio}");
    // Detuned to 0.9 f_opt, the peaks are clearly unequal (here the upper one becomes a
    // shoulder): the test can fail.
    assert!((ratios[1].0 - 1.0).abs() > 0.2, "detuned: {:?}", ratios[1]);
}

#[test]
fn frf_command_writes_linear_and_nonlinear_responses() {
    let dir = std::env::temp_dir().join(format!("frf_cli_{}", std::process::id()));
    let out = dir.to_str().unwrap();
    let (code, stdout, stderr) = damper(&[
        "frf",
        "scenarios/forced_damper.toml",
        "--output",
        "1.0",
        "--from",
        "4",
        "--to",
        "8",
        "--points",
        "41",
        "--nonlinear",
        "3",
        "-o",
        out,
    ]);
    assert_eq!(code, 0, "{stdout} {stderr}");
    assert!(stdout.contains("3 settled"), "{stdout}");
    let csv = std::fs::read_to_string(dir.join("frf.csv")).unwrap();
    let mut lines = csv.lines();
    assert!(
        lines.next().unwrap().starts_with(
            "f [Hz],|H| with generator [m/N],phase with generator [deg],|H| generator disconnected [m/N]"
        )
    );
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |header: &[&str], name: &str| header.iter().position(|h| *h == name).unwrap();
    let (i, v, p) = (
        col(&header, "generator.current [A/N]"),
        col(&header, "generator.voltage [V/N]"),
        col(&header, "generator.load_power [W/N^2]"),
    );
    for line in lines.by_ref() {
        // The terminal voltage and the load power follow from the current through the
        // scenario's load resistance (3.5 ohm).
        let r: Vec<f64> = line.split(',').map(|c| c.parse().unwrap()).collect();
        assert!((r[v] - 3.5 * r[i]).abs() <= 1e-12 * r[v], "{line}");
        assert!(
            (r[p] - 0.5 * 3.5 * r[i] * r[i]).abs() <= 1e-12 * r[p],
            "{line}"
        );
    }
    assert_eq!(csv.lines().count(), 42);
    let nl = std::fs::read_to_string(dir.join("frf_nonlinear.csv")).unwrap();
    let nl_header: Vec<&str> = nl.lines().next().unwrap().split(',').collect();
    let (power, power_linear) = (
        col(&nl_header, "generator.load_power [W]"),
        col(&nl_header, "generator.load_power linear [W]"),
    );
    let rows: Vec<Vec<&str>> = nl.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 3);
    for r in &rows {
        // |H| nonlinear against linear: the shaker's 0.05 N keeps the tip far from the
        // toggle (linear regime), and the scheme's frequency warping at 200 steps per
        // period is 1e-4.
        let (h, hl): (f64, f64) = (r[2].parse().unwrap(), r[4].parse().unwrap());
        assert!((h - hl).abs() < 0.02 * hl, "{r:?}");
        assert_eq!(r[7], "true");
        // The load power measured over the last settled period of the time-domain run
        // against the linear steady state at the shaker's amplitude (square of the
        // amplitude's agreement).
        let (pw, pl): (f64, f64) = (r[power].parse().unwrap(), r[power_linear].parse().unwrap());
        assert!(pl > 0.0 && (pw - pl).abs() < 0.04 * pl, "{r:?}");
    }
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("frf.json")).unwrap()).unwrap();
    // The band holds the resonance (5.94 Hz): no band-edge warning.
    assert_eq!(json["warnings"], serde_json::json!([]), "{stderr}");
    assert!(!stderr.contains("warning"), "{stderr}");
    assert_eq!(json["linear"].as_array().unwrap().len(), 41);
    assert_eq!(json["nonlinear"].as_array().unwrap().len(), 3);
    assert_eq!(json["excitation"], "shaker");
    let svg = crate::common::svg::checked(&dir.join("frf.svg"), &["frequency [Hz]"]).text;
    assert!(svg.contains("generator disconnected") && svg.contains("<circle"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn frf_warns_when_the_largest_response_is_at_a_band_edge() {
    // The paper's damper resonates at 5.9 Hz: a band 1-5 Hz has its largest response at
    // the last frequency, a band 7-20 Hz at the first.
    for (from, to, side) in [("1", "5", "last"), ("7", "20", "first")] {
        let dir = std::env::temp_dir().join(format!("frf_edge_{}_{from}", std::process::id()));
        let (code, stdout, stderr) = damper(&[
            "frf",
            "scenarios/damper.toml",
            "--output",
            "1.0",
            "--from",
            from,
            "--to",
            to,
            "--points",
            "30",
            "-o",
            dir.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{stdout} {stderr}");
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join("frf.json")).unwrap()).unwrap();
        let warnings = json["warnings"].as_array().unwrap();
        assert_eq!(warnings.len(), 2, "{json}");
        for w in warnings {
            let w = w.as_str().unwrap();
            assert!(w.contains(&format!("at the {side} frequency")), "{w}");
            assert!(stderr.contains(w), "{stderr}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn frf_command_rejects_what_it_cannot_do_in_one_line() {
    let dir = std::env::temp_dir().join(format!("frf_bad_{}", std::process::id()));
    let out = dir.to_str().unwrap();
    let base = ["frf", "scenarios/damper.toml", "--from", "2", "--to", "20"];
    let with = |extra: &[&'static str]| {
        let mut v: Vec<&str> = base.to_vec();
        v.extend_from_slice(extra);
        v.extend_from_slice(&["-o", out]);
        v
    };
    assert_bad_input(
        &with(&["--output", "1.0", "--nonlinear", "2"]),
        &["--force"],
    );
    assert_bad_input(&with(&["--output", "1.5"]), &["--output 1.5"]);
    assert_bad_input(&with(&["--output", "damper/q9"]), &["q9", "q1"]);
    assert_bad_input(
        &with(&["--output", "1.0", "--excitation", "shaker"]),
        &["shaker", "none"],
    );
    assert!(!dir.exists(), "nothing written on an error");
}

#[test]
fn frf_work_above_the_limits_is_refused_before_loading_and_allow_long_lifts_it() {
    let dir = std::env::temp_dir().join(format!("frf_limits_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = dir.to_str().unwrap();
    let args = |scenario: &'static str, extra: &[&'static str]| {
        let mut v = vec![
            "frf", scenario, "--output", "1.0", "--from", "4", "--to", "8", "--quiet", "-o", out,
        ];
        v.extend_from_slice(extra);
        v
    };
    // Refused before the scenario is read (it does not exist).
    let missing = "scenarios/no-such.toml";
    assert_bad_input(
        &args(missing, &["--points", "1000000000"]),
        &["GiB of memory", "--points", "--allow-long"],
    );
    assert_bad_input(
        &args(
            missing,
            &["--nonlinear", "3", "--steps-per-period", "100000"],
        ),
        &["3.00e8 time steps", "--allow-long"],
    );
    assert_bad_input(
        &args(missing, &["--nonlinear", "3", "--max-periods", "1000000"]),
        &["6.00e8 time steps", "--allow-long"],
    );
    // Just above the limit (1 x 100001 x 200 steps at most): refused; with --allow-long it
    // runs, and settles long before its last period.
    let above = [
        "--points",
        "5",
        "--nonlinear",
        "1",
        "--max-periods",
        "100001",
    ];
    assert_bad_input(
        &args("scenarios/forced_damper.toml", &above),
        &["2.00e7 time steps"],
    );
    assert!(!dir.exists(), "nothing written on a refusal");
    let mut long = args("scenarios/forced_damper.toml", &above);
    long.push("--allow-long");
    let (code, stdout, stderr) = damper(&long);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("1 settled"), "{stdout}");
    assert!(dir.join("frf_nonlinear.csv").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Mutation-campaign regression: a band from a subnormal frequency overflowed the geometric
/// spacing ("harmonic response at inf rad/s"); the band is bounded and the refusal says so.
#[test]
fn frequencies_outside_the_physical_band_are_refused() {
    for (from, to) in [("5e-324", "20"), ("1e-300", "1e300"), ("1", "1e13")] {
        assert_bad_input(
            &[
                "frf",
                "scenarios/damper.toml",
                "--output",
                "1.0",
                "--from",
                from,
                "--to",
                to,
                "--log",
                "--points",
                "10",
            ],
            &["--from", "(Hz)"],
        );
    }
}

#[test]
fn forced_simulate_reports_the_steady_power_of_the_linear_steady_state() {
    // The bundled forced damper (0.05 N at 5.94 Hz, 5 s): the summary's steady-state load
    // power, read over the settled periods of the time-domain run, against the linear load
    // power per unit force squared of `damper frf` at the shaker's frequency.
    let dir = std::env::temp_dir().join(format!("frf_power_{}", std::process::id()));
    let (sim, lin) = (dir.join("sim"), dir.join("lin"));
    let (code, stdout, stderr) = damper(&[
        "simulate",
        "scenarios/forced_damper.toml",
        "-o",
        sim.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stdout} {stderr}");
    assert!(stdout.contains("steady load power"), "{stdout}");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(sim.join("summary.json")).unwrap()).unwrap();
    let steady = &summary["steady_power"];
    assert_eq!(steady["settled"], true, "{steady}");
    assert!((steady["period_s"].as_f64().unwrap() - 1.0 / 5.94).abs() < 1e-12);
    let load = steady["generators"][0]["mean_power_load"].as_f64().unwrap();
    let dissipated = steady["generators"][0]["mean_power_dissipated"]
        .as_f64()
        .unwrap();
    assert!((load - dissipated * 3.5 / 5.0).abs() <= 1e-12 * load);
    // A periodic state stores nothing over a period: the shaker's input is the dissipation
    // (structure and generator), up to the transient left (settle tolerance 1e-3 per period).
    let input = steady["excitations"][0][1].as_f64().unwrap();
    let out = steady["structure"].as_f64().unwrap() + steady["elements"].as_f64().unwrap();
    assert!((input - out).abs() < 5e-3 * input, "{input} {out}");
    // The whole-run mean includes the start-up transient.
    let whole = summary["generators"][0]["mean_load_power"]
        .as_f64()
        .unwrap();
    assert!(whole < 0.9 * load, "{whole} {load}");
    let (code, stdout, stderr) = damper(&[
        "frf",
        "scenarios/forced_damper.toml",
        "--output",
        "1.0",
        "--from",
        "5.94",
        "--to",
        "6.0",
        "--points",
        "2",
        "-o",
        lin.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stdout} {stderr}");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(lin.join("frf.json")).unwrap()).unwrap();
    let per_f2 = json["linear"][0]["generators"][0]["load_power"]
        .as_f64()
        .unwrap();
    let linear = per_f2 * 0.05 * 0.05;
    let rel = (load - linear) / linear;
    println!("steady load power {load:.6e} W, linear {linear:.6e} W ({rel:.2e})");
    // The tip moves 0.55 mm of its 3 mm reach: the mechanism's nonlinearity lowers the
    // power by a few per cent (frf's nonlinear runs at 6 Hz: -2.4 %).
    assert!(rel.abs() < 0.05, "{rel}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The absorber scenario with a viscous damper on the arm in place of the generator (no
/// rotor inertia: Den Hartog's setting) and a unit harmonic tip force (the peak objective's
/// input), its spring `k` and damper `c` written in; the
/// model path made absolute so that the file can live in a scratch directory.
fn absorber_with_damper(dir: &std::path::Path, k: f64, c: f64) -> std::path::PathBuf {
    absorber_with_damper_and(
        dir,
        k,
        c,
        "time = { kind = \"harmonic\", frequency_hz = 6.0 }\namplitude = 1.0",
    )
}

/// [`absorber_with_damper`] with the tip excitation's `time` (and `amplitude`) lines given.
fn absorber_with_damper_and(
    dir: &std::path::Path,
    k: f64,
    c: f64,
    time: &str,
) -> std::path::PathBuf {
    let text = std::fs::read_to_string(root().join("scenarios/pendulum_absorber.toml")).unwrap();
    let model = root().join("models/absorber.toml");
    let start = text.find("[[force]]\nname = \"generator\"").unwrap();
    let end = text.find("[initial]").unwrap();
    let text = format!(
        "{}[[force]]\nname = \"arm_damper\"\nmechanism = \"absorber\"\njoint = \"arm\"\nkind = \"damper\"\nc = {c:e}\n\n[[excitation]]\nname = \"shaker\"\nat = {{ x = 1.0 }}\n{time}\n\n{}",
        &text[..start],
        &text[end..]
    )
    .replace("\"../models/absorber.toml\"", &format!("{:?}", model.display().to_string()))
    .replacen("k = 0.5879", &format!("k = {k:e}"), 1);
    std::fs::create_dir_all(dir).unwrap();
    let path = dir.join("absorber_damper.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// `damper optimize` of the absorber scenario at `path` over the arm's spring (0.7-1.3 k0)
/// and damper (0.3-3 c0), minimising `objective`: `(k, c, objective value)`.
fn optimize_arm(
    dir: &std::path::Path,
    path: &std::path::Path,
    (k0, c0): (f64, f64),
    objective: &str,
) -> (f64, f64, f64) {
    let (code, out, err) = damper(&[
        "optimize",
        path.to_str().unwrap(),
        "--vary",
        &format!("force[0].k={}:{}", 0.7 * k0, 1.3 * k0),
        "--vary",
        &format!("force[1].c={}:{}", 0.3 * c0, 3.0 * c0),
        "--minimize",
        objective,
        "--json",
        "-o",
        dir.join("opt").to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{out} {err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    (
        j["optimum"][0][1].as_f64().unwrap(),
        j["optimum"][1][1].as_f64().unwrap(),
        j["objective"][1].as_f64().unwrap(),
    )
}

/// The smallest `f` on an `n x n` grid around `(k, c)` (+-2 % in k, +-20 % in c).
fn best_around(f: &dyn Fn(f64, f64) -> f64, k: f64, c: f64, n: usize) -> f64 {
    let h = (n / 2) as f64;
    let mut best = f64::INFINITY;
    for a in 0..n {
        for b in 0..n {
            let kk = k * (1.0 + 0.02 * (a as f64 - h) / h);
            let cc = c * (1.0 + 0.2 * (b as f64 - h) / h);
            best = best.min(f(kk, cc));
        }
    }
    best
}

/// The H-infinity design of the tuned rotational absorber by `damper optimize`: minimise the
/// largest tip receptance over the band of the first mode by the arm's spring and damper.
/// Den Hartog's equal-peak tuning is approximate (its damping is the mean of the two values
/// that put the maximum at either fixed point), so the optimiser's design is checked against
/// the tool's own receptance: its peak is no higher than at Den Hartog's tuning and no point
/// of a dense grid around it does better; and it lies within the formula's own accuracy of
/// Den Hartog's stiffness and damping.
#[test]
fn the_h_infinity_optimum_of_the_tuned_absorber_is_den_hartogs_tuning_refined() {
    let lz = absorber();
    let (dh_model, mu, w_p) = tuned(&lz, 1.0);
    let (k_dh, _, c_dh) = joint_forces(&dh_model);
    let c_dh = c_dh.unwrap();
    let (f1, f2) = (0.6 * w_p / (2.0 * PI), 1.4 * w_p / (2.0 * PI));
    let dir = std::env::temp_dir().join(format!("frf_hinf_{}", std::process::id()));
    let path = absorber_with_damper(&dir, k_dh, c_dh);
    let objective = format!("peak:1.0:{f1}:{f2}");
    let (k, c, peak) = optimize_arm(&dir, &path, (k_dh, c_dh), &objective);
    // The same figure from the library at any (k, c).
    let peak_at = |k: f64, c: f64| -> f64 {
        let p = absorber_with_damper(&dir, k, c);
        let sc = codegen_cli::scenario::load(&p).unwrap_or_else(|e| panic!("{e}"));
        let spec = codegen_cli::linear::PeakSpec::parse(&objective).unwrap();
        codegen_cli::linear::receptance_peak("absorber_damper.toml", &sc, &spec)
            .unwrap()
            .1
    };
    let at_dh = peak_at(k_dh, c_dh);
    println!(
        "mu = {mu:.4}: optimum k = {k:.6e} N m/rad ({:.4} x Den Hartog), c = {c:.6e} N m s/rad ({:.4} x Den Hartog), peak {peak:.6e} m/N; at Den Hartog's tuning {at_dh:.6e} m/N",
        k / k_dh,
        c / c_dh
    );
    assert!(peak <= at_dh * (1.0 + 1e-9), "{peak} vs {at_dh}");
    // A dense grid around the optimum (+-2 % in k, +-20 % in c, 11 x 11): none better.
    let best = best_around(&peak_at, k, c, 11);
    println!("dense grid around the optimum: best {best:.6e} m/N");
    assert!(peak <= best * (1.0 + 1e-6), "{peak} vs grid {best}");
    // Den Hartog's tuning: the frequency ratio 1/(1+mu) holds to the beam's flexibility and
    // structural damping (measured 0.998); his damping, the approximate mean of the fixed
    // points' values, a few per cent off the exact H-infinity optimum at this mass ratio
    // (measured 0.976). The peak is 0.6 % below Den Hartog's.
    assert!((k / k_dh - 1.0).abs() < 0.01, "{}", k / k_dh);
    assert!((c / c_dh - 1.0).abs() < 0.1, "{}", c / c_dh);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The H2 design of the same absorber by `damper optimize --minimize rms:1.0`: the tip's RMS
/// under a white-noise tip force (G = 1e-4 N^2/Hz on 0.5-500 Hz, the Lyapunov equation of the
/// linearised system) minimised by the arm's spring and damper, against the classical H2
/// tuning of a tuned-mass absorber on an undamped primary under white-noise force
/// (Warburton 1982; Asami, Nishihara & Baz 2002, exact for the two-degree-of-freedom
/// system): `omega_a / omega_p = sqrt(1 + mu/2) / (1 + mu)`,
/// `zeta_a = sqrt(mu (1 + 3 mu/4) / (4 (1 + mu) (1 + mu/2)))` with
/// `zeta_a = c_a / (2 m_a omega_a)` (here `k_t = I_p omega_a^2`, `c = 2 zeta_a I_p omega_a`).
/// The beam adds its higher modes and 0.2 % structural damping, so the scenario's optimum
/// lies near, not at, the formula's; the optimum is no worse than the formula's tuning and no
/// point of a dense grid around it does better.
#[test]
fn the_h2_optimum_of_the_tuned_absorber_is_the_classical_h2_tuning() {
    let lz = absorber();
    let (_, mu, w_p) = tuned(&lz, 1.0);
    let arm = arm();
    let i_p = arm.i_pivot;
    let w_a = w_p * (1.0 + mu / 2.0).sqrt() / (1.0 + mu);
    let zeta = (mu * (1.0 + 0.75 * mu) / (4.0 * (1.0 + mu) * (1.0 + mu / 2.0))).sqrt();
    let (k_h2, c_h2) = (i_p * w_a * w_a, 2.0 * zeta * i_p * w_a);
    let noise = "time = { kind = \"white_noise\", psd = 1e-4, band = [0.5, 500.0], seed = 1 }";
    let dir = std::env::temp_dir().join(format!("frf_h2_{}", std::process::id()));
    let path = absorber_with_damper_and(&dir, k_h2, c_h2, noise);
    let (k, c, rms) = optimize_arm(&dir, &path, (k_h2, c_h2), "rms:1.0");
    let rms_at = |k: f64, c: f64| -> f64 {
        let p = absorber_with_damper_and(&dir, k, c, noise);
        let sc = codegen_cli::scenario::load(&p).unwrap_or_else(|e| panic!("{e}"));
        codegen_cli::random::output_rms("absorber_damper.toml", &sc, "1.0")
            .unwrap()
            .0
    };
    let at_formula = rms_at(k_h2, c_h2);
    println!(
        "mu = {mu:.4}: optimum k = {k:.6e} N m/rad ({:.4} x H2 formula), c = {c:.6e} N m s/rad ({:.4} x H2 formula), tip RMS {rms:.6e} m; at the formula's tuning {at_formula:.6e} m",
        k / k_h2,
        c / c_h2
    );
    assert!(rms <= at_formula * (1.0 + 1e-9), "{rms} vs {at_formula}");
    let best = best_around(&rms_at, k, c, 7);
    println!("dense grid around the optimum: best {best:.6e} m");
    assert!(rms <= best * (1.0 + 1e-6), "{rms} vs grid {best}");
    // Measured 0.998 and 1.026: the beam's higher modes and structural damping shift the
    // two-degree-of-freedom optimum by a few per cent at most.
    assert!((k / k_h2 - 1.0).abs() < 0.01, "{}", k / k_h2);
    assert!((c / c_h2 - 1.0).abs() < 0.05, "{}", c / c_h2);
    std::fs::remove_dir_all(&dir).unwrap();
}
