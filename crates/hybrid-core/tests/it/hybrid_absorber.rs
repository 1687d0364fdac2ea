//! The two bundled mechanism shapes of issue #10 on the general hybrid engine
//! (`hybrid_core::hybrid`), against closed forms:
//!
//! - `models/absorber.toml` (a carriage on a ground guide along y, attached to the beam tip by
//!   a roller, with a pivoted arm: one free coordinate): on a very stiff beam the arm
//!   oscillates at `sqrt(k_t / I_pivot)`; on the paper's cantilever, without generator and
//!   damping, the two coupled frequencies are those of the two-degree-of-freedom model built
//!   from the beam's first mode;
//! - `models/slider_crank_damper.toml` (an in-line slider-crank whose slider follows the beam
//!   tip, generator on the crank, near the dead centre): the crank/slider velocity
//!   amplification is the closed-form kinematics, and the energy account balances;
//! - at every step of every run the attached point stays on the beam (independent check of
//!   the attachment row from the point kinematics and the beam state);
//! - the generated code (model registry) and the DAG interpreter on the same model files
//!   give the same trajectories.
//!
//! The measured side of every comparison is the simulated time history.

use crate::common;

use std::f64::consts::PI;
use std::path::Path;

use fem_beam::{Beam, BeamModel, Dof};
use hybrid_core::generator::GeneratorSpec;
use hybrid_core::hybrid::Method;
use hybrid_core::hybrid::{
    Attachment, AttachmentKind, BeamPoint, ForceKind, HybridModel, HybridState, Integrator,
    JointForce, Mount, MountedMechanism, Stored, initial_state,
};
use mbs_symbolic::runtime::{InterpretedSystem, System, Workspace};
use nalgebra::{DMatrix, DVector};

// ---------------------------------------------------------------------------------------
// Helpers

/// Length of every test beam (m): the paper's cantilever.
const L: f64 = 1.0;

/// Which implementation of a model file.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Backend {
    /// Generated at build time (`model_registry`).
    Compiled,
    /// The DAG interpreter on the model file.
    Interpreted,
}

fn system(name: &str, backend: Backend) -> Box<dyn System> {
    match backend {
        Backend::Compiled => model_registry::find_by_name(name)
            .unwrap_or_else(|| panic!("models/{name} is compiled in"))
            .system(),
        Backend::Interpreted => {
            let path = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../models")
                .join(format!("{name}.toml"));
            let model = mbs_symbolic::model::load(&path).unwrap_or_else(|e| panic!("{e}"));
            Box::new(InterpretedSystem::new(&model))
        }
    }
}

/// The paper's steel cantilever (1 m, 40 x 8 mm, clamped at x = 0) with Young's modulus
/// scaled by `e_scale`, `elements` elements, and Rayleigh damping of 0.2 % on modes 1 and
/// 2 when `damped` (none otherwise).
fn cantilever(e_scale: f64, elements: usize, damped: bool) -> BeamModel {
    let damping = if damped {
        "[damping]\nratios = [{ mode = 1, ratio = 0.002 }, { mode = 2, ratio = 0.002 }]\n"
    } else {
        ""
    };
    let text = format!(
        "name = \"test cantilever\"\n\
         [[segment]]\nlength = {L:?}\nyoungs_modulus = {e:e}\ndensity = 7850.0\n\
         width = 0.040\nheight = 0.008\nelements = {elements}\n\
         [[support]]\nx = 0.0\nkind = \"clamped\"\n{damping}",
        e = 210e9 * e_scale
    );
    let beam = Beam::from_toml_str(&text, "test cantilever").unwrap_or_else(|e| panic!("{e}"));
    BeamModel::new(&beam).unwrap()
}

/// Reduced index of the tip's transverse DOF.
fn tip_dof(beam: &BeamModel) -> usize {
    beam.dof_index(beam.beam().node_count() - 1, Dof::Transverse)
        .unwrap()
}

/// The beam's first mode `(omega_1, phi_1)` (unit modal mass, `phi^T A phi = 1`).
fn first_mode(beam: &BeamModel) -> (f64, Vec<f64>) {
    let modes = beam.modes(1).unwrap();
    (modes.angular_frequencies()[0], modes.shape(0).to_vec())
}

/// The paper's generator (scenarios/damper.toml), connected, with inductance `inductance`.
fn generator(inductance: f64) -> GeneratorSpec {
    common::generator(inductance, true)
}

/// Independent check that every attached point is on its beam point: the transverse
/// attachment row `P_y - w(x_b)` from the mechanism's point kinematics (mounted into the
/// beam frame) and the beam state; also the engine's own constraint residual (loops
/// included). Returns the worst of both.
struct OnBeam {
    ws: Vec<Workspace>,
    zero: Vec<Vec<f64>>,
}

impl OnBeam {
    fn new(model: &HybridModel) -> Self {
        OnBeam {
            ws: model
                .mechanisms
                .iter()
                .map(|m| m.system.workspace())
                .collect(),
            zero: model
                .mechanisms
                .iter()
                .map(|m| vec![0.0; m.system.dof()])
                .collect(),
        }
    }

    fn residual(&mut self, model: &HybridModel, state: &HybridState) -> f64 {
        let mut worst = 0.0f64;
        for a in &model.attachments {
            let m = &model.mechanisms[a.mechanism];
            let ws = &mut self.ws[a.mechanism];
            let q = &state.mechanisms[a.mechanism].q;
            m.system
                .point_kinematics(a.point, q, &self.zero[a.mechanism], ws);
            let p = m.mount.to_beam([ws.point_p[0], ws.point_p[1]]);
            worst = worst.max((p[1] - a.beam.value(&state.q)).abs());
        }
        for ms in &state.mechanisms {
            worst = worst.max(ms.residual);
        }
        worst
    }
}

/// Runs `steps` steps of `dt`, checking after each that the attached points stay on the
/// beam (`< 1e-12` m), and calls `each` with the state after every step.
fn run(
    model: &HybridModel,
    state: &mut HybridState,
    dt: f64,
    steps: usize,
    mut each: impl FnMut(&HybridState, &mut Integrator),
) -> Integrator {
    let mut integrator = Integrator::new(model, Method::Newmark, dt, state).unwrap();
    let mut on_beam = OnBeam::new(model);
    let r0 = on_beam.residual(model, state);
    assert!(r0 < 1e-12, "initial attachment residual {r0:e}");
    for _ in 0..steps {
        integrator
            .step(model, state)
            .unwrap_or_else(|e| panic!("{e}"));
        let r = on_beam.residual(model, state);
        assert!(r < 1e-12, "t = {}: attachment residual {r:e}", state.t);
        each(state, &mut integrator);
    }
    integrator
}

fn stored(model: &HybridModel, state: &HybridState, integrator: &mut Integrator) -> Stored {
    let mut out = Stored::default();
    integrator.stored_into(model, state, &mut out);
    out
}

// ---------------------------------------------------------------------------------------
// The absorber

/// Run-time parameters of `models/absorber.toml` (not its defaults, to exercise them): the
/// arm is a uniform rod `m_a`, `l_a` with a tip mass `m_t`.
#[derive(Clone, Copy, Debug)]
struct Arm {
    m_c: f64,
    m_a: f64,
    m_t: f64,
    l_a: f64,
}

const ARM: Arm = Arm {
    m_c: 0.015,
    m_a: 0.012,
    m_t: 0.025,
    l_a: 0.12,
};

impl Arm {
    /// Arm mass `M = m_a + m_t`.
    fn mass(&self) -> f64 {
        self.m_a + self.m_t
    }

    /// `M l_c` (first moment of the arm's mass about the pivot).
    fn first_moment(&self) -> f64 {
        self.l_a * (self.m_a / 2.0 + self.m_t)
    }

    /// Moment of inertia about the pivot, `l_a^2 (m_a/3 + m_t)`.
    fn i_pivot(&self) -> f64 {
        self.l_a * self.l_a * (self.m_a / 3.0 + self.m_t)
    }

    fn system(&self, backend: Backend) -> Box<dyn System> {
        let mut s = system("absorber", backend);
        for (name, v) in [
            ("m_c", self.m_c),
            ("m_a", self.m_a),
            ("m_t", self.m_t),
            ("l_a", self.l_a),
        ] {
            s.set_param(name, v).unwrap();
        }
        s
    }
}

/// The absorber mounted at the beam tip (its ground origin at the undeformed tip, axes
/// aligned), carriage on the tip by a roller, a torsional spring `k_t` on the arm's joint.
fn absorber_model(
    beam: BeamModel,
    sys: Box<dyn System>,
    beam_q: &[f64],
    theta0: f64,
    k_t: f64,
) -> HybridModel {
    let point = sys.point_index("carriage").unwrap();
    let theta = sys.coordinate_index("theta").unwrap();
    assert_eq!(sys.coordinate_index("s"), Some(0));
    assert_eq!((sys.dof(), sys.rows()), (2, 0));
    let tip = BeamPoint::on(&beam, L).unwrap();
    // The carriage's coordinate is dependent (s = w); its value here is only the guess.
    let mut initial_q = vec![0.0; 2];
    initial_q[theta] = theta0;
    initial_q[0] = tip.value(beam_q);
    let mech = MountedMechanism {
        name: "absorber".into(),
        system: sys,
        mount: Mount {
            origin: [L, 0.0],
            angle: 0.0,
        },
        max_condition: 1e8,
        reach: None,
        initial_q,
    };
    let attachment = Attachment {
        name: "tip".into(),
        mechanism: 0,
        point,
        kind: AttachmentKind::Roller,
        beam: tip,
    };
    let spring = JointForce {
        name: "torsion".into(),
        mechanism: 0,
        joint: theta,
        kind: ForceKind::Spring { k: k_t, q0: 0.0 },
    };
    HybridModel::new(
        Some(beam.into()),
        vec![mech],
        vec![attachment],
        vec![spring],
        vec![],
    )
    .unwrap()
}

/// Times of the zero crossings of a sampled signal (linear interpolation between samples;
/// at a crossing of a sinusoid the curvature vanishes, so the interpolation error is third
/// order in the sampling interval).
fn zero_crossings(t: &[f64], x: &[f64]) -> Vec<f64> {
    let mut out = Vec::new();
    for k in 1..x.len() {
        let (a, b) = (x[k - 1], x[k]);
        if (a < 0.0 && b >= 0.0) || (a > 0.0 && b <= 0.0) {
            out.push(t[k - 1] + (t[k] - t[k - 1]) * a / (a - b));
        }
    }
    out
}

/// Slope of the least-squares line through `(k, y_k)`.
fn slope(y: &[f64]) -> f64 {
    let n = y.len() as f64;
    let kbar = (n - 1.0) / 2.0;
    let ybar = y.iter().sum::<f64>() / n;
    let (mut num, mut den) = (0.0, 0.0);
    for (k, &v) in y.iter().enumerate() {
        let dk = k as f64 - kbar;
        num += dk * (v - ybar);
        den += dk * dk;
    }
    num / den
}

#[test]
fn on_a_very_stiff_beam_the_arm_oscillates_at_sqrt_kt_over_i_pivot() {
    // E x 1e6: the tip's static stiffness 3EI/L^3 ~ 1.1e9 N/m, the first beam mode at
    // ~42,000 rad/s against the arm's ~31 rad/s. The carriage then hardly moves, and with
    // s' = 0 the arm's equation is exactly I_pivot theta'' + k_t theta = 0 (no gravity, no
    // other term: T = I_pivot theta'^2 / 2), linear whatever the amplitude — the large
    // initial angle (0.3 rad) tests that the model's inertia is the pivot inertia, not a
    // linearisation. The beam's compliance shifts the frequency by about
    // (M l_c)^2 omega_a^2 / (I_pivot k_tip) ~ 1e-9 relative.
    let beam = cantilever(1e6, 4, false);
    let n = beam.dof_count();
    let i_pivot = ARM.i_pivot();
    let k_t = 0.4; // N m / rad: f_a ~ 4.9 Hz
    let expected = (k_t / i_pivot).sqrt();
    let model = absorber_model(beam, ARM.system(Backend::Compiled), &vec![0.0; n], 0.3, k_t);
    let mut state = initial_state(&model, vec![0.0; n], vec![0.0; n]).unwrap();
    assert_eq!(
        state.mechanisms[0].free,
        vec![1],
        "theta is the free coordinate"
    );
    let dt = 1e-4;
    let (mut t, mut theta) = (vec![state.t], vec![state.mechanisms[0].q[1]]);
    let mut carriage = 0.0f64;
    // Ten periods.
    let steps = (10.0 * 2.0 * PI / expected / dt).ceil() as usize;
    run(&model, &mut state, dt, steps, |s, _| {
        t.push(s.t);
        theta.push(s.mechanisms[0].q[1]);
        carriage = carriage.max(s.mechanisms[0].q[0].abs());
    });
    let crossings = zero_crossings(&t, &theta);
    assert!(crossings.len() >= 19, "{} crossings", crossings.len());
    let measured = PI / slope(&crossings);
    let error = (measured - expected).abs() / expected;
    // Error budget: Newmark's period elongation (omega h)^2 / 12 = 8e-7 at h = 1e-4, the
    // crossing interpolation ~1e-9, the beam's compliance ~1e-9: 1e-5 is tight and safe.
    // Sharper: the average-acceleration rule turns omega into exactly
    // (2/h) atan(omega h / 2) for a linear oscillator; against that, what is left is the
    // interpolation and the compliance: 1e-7.
    let discrete = 2.0 / dt * (expected * dt / 2.0).atan();
    let error_discrete = (measured - discrete).abs() / expected;
    eprintln!(
        "stiff beam: omega measured {measured:.9} vs sqrt(k_t/I_pivot) {expected:.9} rad/s, relative {error:.2e}; vs Newmark's discrete frequency {error_discrete:.2e}; max |s| = {carriage:.2e} m"
    );
    assert!(error < 1e-5, "relative error {error:e}");
    assert!(
        error_discrete < 1e-7,
        "relative error against Newmark's frequency {error_discrete:e}"
    );
    assert!(carriage < 1e-8, "the carriage moved {carriage:e} m");
}

/// Frequencies (rad/s) of the two-degree-of-freedom model of beam + absorber.
///
/// Coordinates: the tip's transverse displacement `y` (the carriage follows it, `s = y`)
/// and the arm angle `theta`. The beam is reduced to its first mode, scaled to the tip:
/// `q^c = y phi_1 / phi_1,tip`, so its kinetic and potential energies are `m1 y'^2 / 2` and
/// `k1 y^2 / 2` with `m1 = phi^T A phi / phi_tip^2 = 1 / phi_tip^2` (unit modal mass) and
/// `k1 = omega_1^2 m1`. The absorber adds (models/absorber.toml, arm along the beam axis at
/// theta = 0)
///
/// ```text
/// T = (m_c + M) y'^2 / 2 + M l_c cos(theta) y' theta' + I_pivot theta'^2 / 2,
/// V = k_t theta^2 / 2,
/// ```
///
/// whose linearisation about `theta = 0` (cos = 1, the arm's transverse velocity
/// `y' + l_c theta'`) gives
///
/// ```text
/// M2 = [[m1 + m_c + M, M l_c], [M l_c, I_pivot]],   K2 = diag(k1, k_t),
/// det(K2 - w^2 M2) = 0:
/// (a I_p - b^2) w^4 - (k1 I_p + k_t a) w^2 + k1 k_t = 0,  a = m1 + m_c + M,  b = M l_c.
/// ```
fn two_dof_frequencies(m1: f64, k1: f64, arm: &Arm, k_t: f64) -> [f64; 2] {
    let (a, b, ip) = (m1 + arm.m_c + arm.mass(), arm.first_moment(), arm.i_pivot());
    let qa = a * ip - b * b;
    let qb = -(k1 * ip + k_t * a);
    let qc = k1 * k_t;
    let disc = (qb * qb - 4.0 * qa * qc).sqrt();
    // The two roots in w^2, each computed without cancellation.
    let hi = (-qb + disc) / (2.0 * qa);
    let lo = qc / (qa * hi);
    [lo.sqrt(), hi.sqrt()]
}

/// Least-squares basis `[cos w1 t, sin w1 t, cos w2 t, sin w2 t]`.
fn basis(t: &[f64], w: [f64; 2]) -> DMatrix<f64> {
    DMatrix::from_fn(t.len(), 4, |i, j| {
        let arg = w[j / 2] * t[i];
        if j % 2 == 0 { arg.cos() } else { arg.sin() }
    })
}

/// Residual of the best fit of two sinusoids of frequencies `w` (shared) to every signal
/// (variable projection: the amplitudes and phases are eliminated by linear least squares).
fn projected_residual(t: &[f64], signals: &[DVector<f64>], w: [f64; 2]) -> DVector<f64> {
    let phi = basis(t, w);
    let normal = (phi.transpose() * &phi)
        .cholesky()
        .expect("independent sinusoids");
    let mut out = DVector::zeros(t.len() * signals.len());
    for (k, y) in signals.iter().enumerate() {
        let c = normal.solve(&(phi.transpose() * y));
        let r = y - &phi * c;
        out.rows_mut(k * t.len(), t.len()).copy_from(&r);
    }
    out
}

/// The two frequencies (rad/s) of a least-squares fit of two sinusoids to the signals
/// (each normalised by its RMS): starting values from the two highest peaks of the summed
/// periodograms between `band.0` and `band.1` Hz, refined by Gauss–Newton on the
/// frequencies.
fn fit_two_frequencies(t: &[f64], signals: &[Vec<f64>], band: (f64, f64)) -> [f64; 2] {
    let signals: Vec<DVector<f64>> = signals
        .iter()
        .map(|y| {
            let rms = (y.iter().map(|v| v * v).sum::<f64>() / y.len() as f64).sqrt();
            DVector::from_iterator(y.len(), y.iter().map(|v| v / rms))
        })
        .collect();
    // Periodogram on a 0.01 Hz grid.
    let df = 0.01;
    let nf = ((band.1 - band.0) / df) as usize;
    let power: Vec<f64> = (0..=nf)
        .map(|k| {
            let w = 2.0 * PI * (band.0 + k as f64 * df);
            signals
                .iter()
                .map(|y| {
                    let (mut c, mut s) = (0.0, 0.0);
                    for (ti, yi) in t.iter().zip(y.iter()) {
                        c += yi * (w * ti).cos();
                        s += yi * (w * ti).sin();
                    }
                    c * c + s * s
                })
                .sum()
        })
        .collect();
    let mut peaks: Vec<(f64, usize)> = (1..nf)
        .filter(|&k| power[k] > power[k - 1] && power[k] >= power[k + 1])
        .map(|k| (power[k], k))
        .collect();
    peaks.sort_by(|a, b| b.0.total_cmp(&a.0));
    assert!(peaks.len() >= 2, "fewer than two spectral peaks");
    let mut w = [peaks[0].1, peaks[1].1].map(|k| 2.0 * PI * (band.0 + k as f64 * df));
    w.sort_by(f64::total_cmp);
    // Gauss–Newton on the projected residual (central differences for its Jacobian).
    for _ in 0..50 {
        let r = projected_residual(t, &signals, w);
        let mut jac = DMatrix::zeros(r.len(), 2);
        for k in 0..2 {
            let d = 1e-6 * w[k];
            let (mut wp, mut wm) = (w, w);
            wp[k] += d;
            wm[k] -= d;
            let col = (projected_residual(t, &signals, wp) - projected_residual(t, &signals, wm))
                / (2.0 * d);
            jac.set_column(k, &col);
        }
        let step = (jac.transpose() * &jac)
            .lu()
            .solve(&(-jac.transpose() * &r))
            .expect("a regular Gauss-Newton matrix");
        w[0] += step[0];
        w[1] += step[1];
        if step.amax() <= 1e-10 * w[1] {
            return w;
        }
    }
    panic!("the frequency fit did not converge: {w:?}");
}

#[test]
fn generator_off_the_two_coupled_frequencies_match_the_two_dof_closed_form() {
    // The paper's cantilever, undamped, 20 elements; the absorber tuned to its first mode
    // (k_t = omega_1^2 I_pivot); no generator, no damper: a conservative system.
    let beam = cantilever(1.0, 20, false);
    let n = beam.dof_count();
    let (w1, phi) = first_mode(&beam);
    let tip = tip_dof(&beam);
    let m1 = 1.0 / (phi[tip] * phi[tip]);
    let k1 = w1 * w1 * m1;
    let k_t = w1 * w1 * ARM.i_pivot();
    let reference = two_dof_frequencies(m1, k1, &ARM, k_t);
    // Released from rest with the beam in its first mode (1 mm at the tip) and the arm at
    // theta = 0: both coupled modes are excited.
    let q0: Vec<f64> = phi.iter().map(|p| 1e-3 * p / phi[tip]).collect();
    let model = absorber_model(beam, ARM.system(Backend::Compiled), &q0, 0.0, k_t);
    let mut state = initial_state(&model, q0, vec![0.0; n]).unwrap();
    assert_eq!(state.mechanisms[0].free, vec![1]);
    let dt = 1e-4;
    let steps = 40_000; // 4 s, ~ 27 periods
    let mut integrator0 = Integrator::new(&model, Method::Newmark, dt, &state).unwrap();
    let e0 = stored(&model, &state, &mut integrator0).total();
    let (mut t, mut y, mut theta) = (vec![], vec![], vec![]);
    let mut drift = 0.0f64;
    let mut stored_now = Stored::default();
    run(&model, &mut state, dt, steps, |s, integ| {
        if s.steps % 10 == 0 {
            t.push(s.t);
            y.push(s.mechanisms[0].q[0]);
            theta.push(s.mechanisms[0].q[1]);
            integ.stored_into(&model, s, &mut stored_now);
            drift = drift.max((stored_now.total() - e0).abs() / e0);
        }
    });
    // Conservative: the stored energy stays constant (Newmark's average acceleration
    // conserves the linear part exactly; the arm's geometric nonlinearity at theta ~ 1e-2
    // leaves an O(h^2) error).
    eprintln!("two-dof: energy drift {drift:.2e} of {e0:.4e} J");
    assert!(drift < 1e-6, "energy drift {drift:e}");
    // Measured: a fit of two sinusoids to the simulated tip displacement and arm angle.
    // Band 0.5–30 Hz: around the first beam mode (6.7 Hz), below the second (42 Hz).
    let measured = fit_two_frequencies(&t, &[y, theta], (0.5, 30.0));
    for k in 0..2 {
        let error = (measured[k] - reference[k]).abs() / reference[k];
        eprintln!(
            "two-dof: mode {k}: measured {:.6} rad/s, closed form {:.6} rad/s, relative {error:.2e} (omega_1 alone {w1:.6})",
            measured[k], reference[k]
        );
        // The 2-DOF model leaves out the higher beam modes (their static flexibility is
        // ~3 % of the tip's): an estimated shift of ~1e-3 at this coupling; 0.5 % per the
        // issue.
        assert!(error < 5e-3, "mode {k}: relative error {error:e}");
    }
    // The two frequencies are split around omega_1 (the absorber is tuned to it).
    assert!(measured[0] < w1 && measured[1] > w1);
}

// ---------------------------------------------------------------------------------------
// The slider-crank damper

/// Geometry of the slider-crank (run-time parameters, not the defaults).
const R: f64 = 0.04;
const ROD: f64 = 0.12;

/// Slider position of the in-line slider-crank at crank angle `q1` (rod above the crank
/// pin): the closure `r cos q1 + l cos psi = 0`, `s = r sin q1 + l sin psi`, so
/// `s = r sin q1 + sqrt(l^2 - r^2 cos^2 q1)`.
fn slider_of(q1: f64) -> f64 {
    R * q1.sin() + (ROD * ROD - (R * q1.cos()).powi(2)).sqrt()
}

/// `ds/dq1 = r cos q1 (1 + r sin q1 / sqrt(l^2 - r^2 cos^2 q1))`: the velocity
/// amplification is `q1'/s' = 1 / (ds/dq1)`, unbounded at the dead centre q1 = pi/2.
fn ds_dq1(q1: f64) -> f64 {
    let root = (ROD * ROD - (R * q1.cos()).powi(2)).sqrt();
    R * q1.cos() * (1.0 + R * q1.sin() / root)
}

/// The slider-crank damper at the beam tip: crank angle `pi/2 - beta0` (beta0 from the
/// dead centre) in the undeformed position, the ground frame shifted so that the slider pin
/// is at the undeformed tip, a roller from the pin to the tip, the generator on the crank.
fn slider_crank_model(
    beam: BeamModel,
    backend: Backend,
    beta0: f64,
    gen_spec: GeneratorSpec,
) -> HybridModel {
    let mut sys = system("slider_crank_damper", backend);
    sys.set_param("r", R).unwrap();
    sys.set_param("l", ROD).unwrap();
    let (q1, q2, s) = (
        sys.coordinate_index("q1").unwrap(),
        sys.coordinate_index("q2").unwrap(),
        sys.coordinate_index("s").unwrap(),
    );
    assert_eq!((q1, q2, s), (0, 1, 2));
    assert_eq!((sys.dof(), sys.rows()), (3, 2));
    let point = sys.point_index("slider").unwrap();
    let crank = PI / 2.0 - beta0;
    let s0 = slider_of(crank);
    // Rod angle from ground x: cos psi = -(r/l) cos q1, psi in (pi/2, pi) above the pin.
    let psi = (-(R / ROD) * crank.cos()).acos();
    let mech = MountedMechanism {
        name: "slider-crank".into(),
        system: sys,
        mount: Mount {
            origin: [L, -s0],
            angle: 0.0,
        },
        max_condition: 1e6,
        reach: Some(R + ROD - s0),
        initial_q: vec![crank, psi - crank, s0],
    };
    let attachment = Attachment {
        name: "tip".into(),
        mechanism: 0,
        point,
        kind: AttachmentKind::Roller,
        beam: BeamPoint::on(&beam, L).unwrap(),
    };
    let force = JointForce {
        name: "generator".into(),
        mechanism: 0,
        joint: 0,
        kind: ForceKind::Generator(gen_spec),
    };
    HybridModel::new(
        Some(beam.into()),
        vec![mech],
        vec![attachment],
        vec![force],
        vec![],
    )
    .unwrap()
}

#[test]
fn slider_crank_near_dead_centre_amplifies_as_the_closed_form_and_the_generator_dissipates() {
    // 0.3 rad (17 deg) from the dead centre: amplification q1'/s' ~ 65 rad/m, reach 2.4 mm;
    // the tip starts 1 mm towards the dead centre in the first mode shape.
    let beam = cantilever(1.0, 20, true);
    let n = beam.dof_count();
    let (_, phi) = first_mode(&beam);
    let tip = tip_dof(&beam);
    let q0: Vec<f64> = phi.iter().map(|p| 1e-3 * p / phi[tip]).collect();
    let model = slider_crank_model(beam, Backend::Compiled, 0.3, generator(1e-3));
    let mut state = initial_state(&model, q0, vec![0.0; n]).unwrap();
    assert!(state.mechanisms[0].free.is_empty(), "no free coordinate");
    let dt = 2e-5;
    let steps = 25_000; // 0.5 s, ~3 periods
    let mut integrator0 = Integrator::new(&model, Method::Newmark, dt, &state).unwrap();
    let e0 = stored(&model, &state, &mut integrator0).total();
    let (mut checked, mut worst_ratio, mut worst_position) = (0usize, 0.0f64, 0.0f64);
    let (mut max_amplification, mut min_beta) = (0.0f64, f64::INFINITY);
    let mut worst_balance = 0.0f64;
    let mut now = Stored::default();
    run(&model, &mut state, dt, steps, |s, integ| {
        let m = &s.mechanisms[0];
        let (q1, sd, q1d) = (m.q[0], m.qd[2], m.qd[0]);
        // Position: the slider where the closure puts it.
        worst_position = worst_position.max((m.q[2] - slider_of(q1)).abs());
        min_beta = min_beta.min(PI / 2.0 - q1);
        // Velocity amplification at this instant (every 50th step: 500 instants).
        if s.steps % 50 == 0 && sd.abs() > 1e-6 {
            let closed = 1.0 / ds_dq1(q1);
            let ratio = q1d / sd;
            worst_ratio = worst_ratio.max((ratio - closed).abs() / closed.abs());
            max_amplification = max_amplification.max(ratio.abs());
            checked += 1;
        }
        // Energy account every 100th step.
        if s.steps % 100 == 0 {
            integ.stored_into(&model, s, &mut now);
            let a = &s.account;
            let input = e0 + a.beam_load_work + a.excitation_work.iter().sum::<f64>();
            let out = now.total() + a.dissipated_structure + a.dissipated.iter().sum::<f64>();
            worst_balance = worst_balance.max((input - out).abs() / e0);
        }
    });
    eprintln!(
        "slider-crank: {checked} instants, amplification up to {max_amplification:.2} rad/m (closed form at beta0: {:.2}), relative error {worst_ratio:.2e}; slider position error {worst_position:.2e} m; closest to dead centre {min_beta:.4} rad",
        1.0 / ds_dq1(PI / 2.0 - 0.3)
    );
    assert!(checked >= 400, "{checked} instants checked");
    assert!(worst_ratio < 1e-8, "amplification error {worst_ratio:e}");
    assert!(
        worst_position < 1e-12,
        "slider position error {worst_position:e}"
    );
    assert!(min_beta > 0.0, "crossed the dead centre");
    // The energy account balances; the generator took the energy.
    let a = &state.account;
    integrator0.stored_into(&model, &state, &mut now);
    eprintln!(
        "slider-crank: dt = {dt:e}: e0 {e0:.4e} J, stored now {:.3e} J, generator {:.4e} J, structure {:.3e} J, worst balance {worst_balance:.2e}",
        now.total(),
        a.dissipated[0],
        a.dissipated_structure
    );
    assert!(worst_balance < 1e-6, "energy balance {worst_balance:e}");
    assert!(
        a.dissipated[0] > 0.5 * e0 && a.dissipated[0] > 10.0 * a.dissipated_structure,
        "generator {} J, structure {} J of {e0} J",
        a.dissipated[0],
        a.dissipated_structure
    );
}

// ---------------------------------------------------------------------------------------
// Generated code against the interpreter

fn max_relative(a: &[f64], b: &[f64]) -> f64 {
    let scale = a.iter().fold(1e-300f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs() / scale))
}

fn same_trajectory(build: impl Fn(Backend) -> (HybridModel, Vec<f64>), dt: f64, steps: usize) {
    let (compiled, q0) = build(Backend::Compiled);
    let (interpreted, _) = build(Backend::Interpreted);
    let n = q0.len();
    let mut a = initial_state(&compiled, q0.clone(), vec![0.0; n]).unwrap();
    let mut b = initial_state(&interpreted, q0, vec![0.0; n]).unwrap();
    let mut ia = Integrator::new(&compiled, Method::Newmark, dt, &a).unwrap();
    let mut ib = Integrator::new(&interpreted, Method::Newmark, dt, &b).unwrap();
    let mut worst = 0.0f64;
    for _ in 0..steps {
        ia.step(&compiled, &mut a).unwrap();
        ib.step(&interpreted, &mut b).unwrap();
        worst = worst
            .max(max_relative(&a.q, &b.q))
            .max(max_relative(&a.v, &b.v))
            .max(max_relative(&a.mechanisms[0].q, &b.mechanisms[0].q))
            .max(max_relative(&a.mechanisms[0].qd, &b.mechanisms[0].qd));
    }
    eprintln!("generated vs interpreted: worst relative difference {worst:.2e}");
    assert!(worst < 1e-9, "{worst:e}");
}

#[test]
fn generated_and_interpreted_models_give_the_same_trajectories() {
    same_trajectory(
        |backend| {
            let beam = cantilever(1.0, 10, false);
            let (w1, phi) = first_mode(&beam);
            let tip = tip_dof(&beam);
            let q0: Vec<f64> = phi.iter().map(|p| 1e-3 * p / phi[tip]).collect();
            let k_t = w1 * w1 * ARM.i_pivot();
            (
                absorber_model(beam, ARM.system(backend), &q0, 0.05, k_t),
                q0,
            )
        },
        1e-4,
        2000,
    );
    same_trajectory(
        |backend| {
            let beam = cantilever(1.0, 10, true);
            let (_, phi) = first_mode(&beam);
            let tip = tip_dof(&beam);
            let q0: Vec<f64> = phi.iter().map(|p| 1e-3 * p / phi[tip]).collect();
            (slider_crank_model(beam, backend, 0.3, generator(0.0)), q0)
        },
        1e-4,
        2000,
    );
}

// ---------------------------------------------------------------------------------------
// The modal filter of a complex mode

/// Issue 23 item 7: the absorber's two close, non-proportionally damped modes (the beam's
/// first mode split by the tuned arm, damped by the generator on the arm and 0.2 % Rayleigh
/// damping on the beam). Read through the exact modal coordinate of the first linearised
/// mode (`ModalFilter::of_mode`, the left-eigenvector projection of the state), the free
/// decay at small amplitude (0.1 mm at the tip) gives the linearised damping ratio within
/// 1e-5 relative (the issue asks 1e-4), with and without inductance; 2.3e-6 measured.
/// (The real part of the complex mode shape, the filter before, read the bundled
/// scenario's 4.127 % as 4.142 %: 3.7e-3.) Error budget: Newmark's `(omega h)^2 / 4 =
/// 3.4e-6` on the damping ratio at `omega = 37 rad/s`, `h = 1e-4`; the geometric
/// nonlinearity at theta ~ 1e-3 and the estimator's peak interpolation below 1e-6.
#[test]
fn the_exact_modal_filter_reads_the_linearised_damping_of_a_complex_mode() {
    use hybrid_core::decay::{ModalFilter, estimate};
    use hybrid_core::hybrid::{EigenMethod, EquilibriumOptions, Linearization, modes};
    for inductance in [0.0, 2e-3] {
        let beam = cantilever(1.0, 20, true);
        let n = beam.dof_count();
        let (w1, phi) = first_mode(&beam);
        let tip = tip_dof(&beam);
        let k_t = w1 * w1 * ARM.i_pivot();
        let q0: Vec<f64> = phi.iter().map(|p| 1e-4 * p / phi[tip]).collect();
        let mut model = absorber_model(beam, ARM.system(Backend::Compiled), &q0, 0.0, k_t);
        let theta = model.mechanisms[0]
            .system
            .coordinate_index("theta")
            .unwrap();
        model.forces.push(JointForce {
            name: "generator".into(),
            mechanism: 0,
            joint: theta,
            kind: ForceKind::Generator(generator(inductance)),
        });
        // The exact tangent model of the same mechanism, with the same parameters.
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/absorber.toml");
        let file = mbs_symbolic::model::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let mut tangent = mbs_symbolic::runtime::TangentSystem::new(&file);
        for (name, v) in [
            ("m_c", ARM.m_c),
            ("m_a", ARM.m_a),
            ("m_t", ARM.m_t),
            ("l_a", ARM.l_a),
        ] {
            tangent.set_param(name, v).unwrap();
        }
        let lin = Linearization::new(&model, &[&tangent], EquilibriumOptions::default()).unwrap();
        let found = modes(&lin, 2, EigenMethod::Auto).unwrap();
        let (first, second) = (&found[0], &found[1]);
        // Two close modes: the filter has something to separate.
        assert!(second.natural_frequency_hz < 1.5 * first.natural_frequency_hz);
        let point = model.attachments[0].beam.clone();
        let filter = ModalFilter::of_mode(&lin, first, &point).unwrap();
        let free = lin.equilibrium.free.clone();
        let mut state = initial_state(&model, q0, vec![0.0; n]).unwrap();
        let (mut t, mut y) = (vec![], vec![]);
        let (mut z, mut zd) = (vec![], vec![]);
        let dt = 1e-4;
        run(&model, &mut state, dt, 60_000, |s, _| {
            z.clear();
            z.extend_from_slice(&s.q);
            zd.clear();
            zd.extend_from_slice(&s.v);
            for (m, free) in s.mechanisms.iter().zip(&free) {
                z.extend(free.iter().map(|&c| m.q[c]));
                zd.extend(free.iter().map(|&c| m.qd[c]));
            }
            t.push(s.t);
            y.push(filter.apply_state(&z, &zd, &s.currents));
        });
        let measured = estimate(&t, &y);
        let zeta = measured.zeta().expect("an oscillatory decay");
        let error = (zeta - first.damping_ratio).abs() / first.damping_ratio;
        eprintln!(
            "L = {inductance}: zeta time domain {zeta:.7}, linearised {:.7} (second mode {:.7} at {:.4} Hz vs {:.4} Hz): relative {error:.2e}",
            first.damping_ratio,
            second.damping_ratio,
            second.natural_frequency_hz,
            first.natural_frequency_hz
        );
        assert!(error < 1e-5, "relative error {error:e}");
    }
}
