//! The linearised analyses on every kind of structure (issue #30, item 5):
//!
//! - the paper's damper linearised on its beam, on the beam's Matrix Market export (an
//!   imported sparse model) and on its Craig–Bampton reduction with every mode: the same
//!   modes (frequency and damping), the same receptance at the attachment point and the same
//!   response to a support acceleration;
//! - a one-node structure (a mass on a spring along `x`, locked along `y`) with the double
//!   bar pinned to its node and its ground pivot along `x`: the linearised system is a
//!   single-degree-of-freedom oscillator carrying the double bar's reflected mass and the
//!   generator's reflected damping, worked out by hand from the double bar's geometry; its
//!   frequency, damping ratio and white-noise variances are the closed forms.

use std::f64::consts::{FRAC_PI_2, PI};

use fem_beam::TimeFunction;
use hybrid_core::hybrid::{
    AttachmentKind, BeamPoint, EigenMethod, EquilibriumOptions, Excitation, ExcitationTarget,
    HybridModel, Integrator, Linearization, Method, Mode, ModeKind, Mount, StateOutput, StateSpace,
    Structure, initial_state, modes,
};
use nalgebra::Complex;

use crate::common::damper::{Geometry, PaperDamper};
use crate::common::tangents;
use crate::structures::{
    double_bar_on, exported, node_on_springs, reduced_variant, weightless_paper,
};

fn linearize(model: &HybridModel) -> Linearization {
    let t = tangents(model, &[]);
    let refs: Vec<_> = t.iter().collect();
    Linearization::new(model, &refs, EquilibriumOptions::default()).unwrap()
}

fn oscillatory(lin: &Linearization, count: usize) -> Vec<Mode> {
    let found = modes(lin, count, EigenMethod::Auto).unwrap();
    assert!(found.iter().all(|m| m.kind == ModeKind::Oscillatory));
    found
}

fn close(a: f64, b: f64, tol: f64, what: &str) {
    assert!(
        (a - b).abs() <= tol * b.abs(),
        "{what}: {a} vs {b} ({:e})",
        (a - b).abs() / b.abs()
    );
}

/// The receptance at the attachment point (a force there, the displacement there) at
/// `hz`, and the point's response to a unit support acceleration.
fn responses(model: &HybridModel, lin: &Linearization, hz: f64) -> [f64; 2] {
    let point = model.attachments[0].beam.clone();
    let omega = 2.0 * PI * hz;
    let at = |target: &ExcitationTarget| {
        let z = lin
            .harmonic_response(&lin.force_vector(target), omega)
            .unwrap();
        point.complex_value(&z).norm()
    };
    [
        at(&ExcitationTarget::Beam(point.clone())),
        at(&ExcitationTarget::BASE_Y),
    ]
}

#[test]
fn the_linearised_damper_is_the_same_on_every_kind_of_structure() {
    let (beam_model, _) = PaperDamper::default().hybrid();
    let n = beam_model.structure_dofs();
    let mut imported = beam_model.clone();
    imported.structure = Some(Structure::Imported(exported(beam_model.beam().unwrap())));
    let (reduced, _) = reduced_variant(&beam_model, n);

    let reference = linearize(&beam_model);
    let want = oscillatory(&reference, 4);
    for (model, tol, kind) in [(&imported, 1e-10, "imported"), (&reduced, 1e-9, "reduced")] {
        let lin = linearize(model);
        assert_eq!(
            lin.structure().unwrap().kind(),
            model.structure.as_ref().unwrap().kind()
        );
        let got = oscillatory(&lin, 4);
        for (a, b) in got.iter().zip(&want) {
            close(
                a.natural_frequency_hz,
                b.natural_frequency_hz,
                tol,
                &format!("{kind} frequency"),
            );
            close(
                a.damping_ratio,
                b.damping_ratio,
                tol,
                &format!("{kind} damping"),
            );
            assert!(
                a.residual < 1e-12,
                "{kind}: backward error {:e}",
                a.residual
            );
        }
        for hz in [3.0, want[0].natural_frequency_hz, 40.0, 250.0] {
            let [h, t] = responses(model, &lin, hz);
            let [h0, t0] = responses(&beam_model, &reference, hz);
            close(h, h0, tol, &format!("{kind} receptance at {hz} Hz"));
            close(t, t0, tol, &format!("{kind} base response at {hz} Hz"));
        }
    }
}

/// The double bar's parameters at its equilibrium on the one-node structure
/// ([`node_with_double_bar`]), worked out by hand (docs/theory.md sections 13.4, 13.5).
struct Reflected {
    /// The crank rate per unit node velocity, `1 / (2 L sin a)`.
    g1: f64,
    /// The reflected mass `m_eff` (kg).
    m_eff: f64,
    /// The reflected damping `c_eff` (N s/m).
    c_eff: f64,
    /// The mechanism's momentum along `x` per unit node velocity, `m1/4 + 3 m2/4` (kg):
    /// the mass its ground's acceleration along `x` loads the node with.
    m_base: f64,
    /// The magnitude of its momentum along `y` per unit node velocity along `x`,
    /// `(m1 + m2) cot(a) / 4` (kg): what a ground acceleration along `y` loads the node with.
    m_base_y: f64,
}

/// A node of mass `m` on a spring `k` along `x` (held along `y`) with the paper's double
/// bar (no gravity) pinned at it, its ground pivot on the `x` axis, the generator on its
/// crank, and `excitations`; the double bar's reflected figures from the linearisation's
/// equilibrium (checked against the placement).
fn node_with_double_bar(
    m: f64,
    k: f64,
    excitations: Vec<Excitation>,
) -> (HybridModel, usize, Linearization, Reflected) {
    let paper = weightless_paper();
    // The double bar turned by 90 degrees so that its ground pivot lies on the x axis.
    let mount = |g: &Geometry| Mount {
        origin: [g.target[1], -g.target[0]],
        angle: FRAC_PI_2,
    };
    let (mut model, g) = double_bar_on(
        &paper,
        node_on_springs(m, &[("ux", k)]),
        mount,
        AttachmentKind::Pin,
        BeamPoint::node([0.0, 0.0], Some(0), None),
    );
    model.excitations = excitations;
    let mount = model.mechanisms[0].mount;
    assert!(
        mount.origin[1].abs() < 1e-12 * mount.origin[0].abs(),
        "{mount:?}"
    );
    let lin = linearize(&model);

    // The double bar at the equilibrium: both bars of length L, the knee at the half-angle
    // alpha = |q2| / 2 from the pivot->node axis, whose length is 2 L cos(alpha).
    let l = 0.10;
    let q = &lin.equilibrium.mech_q[0];
    let alpha = q[1].abs() / 2.0;
    close(
        mount.origin[0].abs(),
        2.0 * l * alpha.cos(),
        1e-12,
        "pivot distance",
    );
    close(alpha, paper.half_angle_deg.to_radians(), 1e-9, "half-angle");
    // A node velocity 1 along the axis: d' = 1 = -2 L sin(alpha) q1', so the crank turns at
    // g1 = 1 / (2 L sin(alpha)), the knee moves at (1/2, -cot(alpha)/2), the node at (1, 0),
    // the coupler's centre at their mean and the coupler turns at -q1'.
    let g1 = 1.0 / (2.0 * l * alpha.sin());
    let cot = alpha.cos() / alpha.sin();
    let (m1, m2) = (0.024, 0.024);
    let generator = &paper.generator;
    let n = generator.gear_ratio;
    let m_eff = m1 * l * l / 3.0 * g1 * g1
        + m2 * (9.0 + cot * cot) / 16.0
        + m2 * l * l / 12.0 * g1 * g1
        + n * n * generator.rotor_inertia * g1 * g1;
    let c_joint = n * n * generator.kt * generator.ke
        / (generator.armature_resistance + generator.load_resistance);
    // The centres' x velocities per unit node velocity: the crank's 1/4 (half the knee's),
    // the coupler's 3/4 (the mean of the knee's 1/2 and the node's 1).
    let reflected = Reflected {
        g1,
        m_eff,
        c_eff: c_joint * g1 * g1,
        m_base: m1 / 4.0 + 3.0 * m2 / 4.0,
        m_base_y: (m1 + m2) * cot / 4.0,
    };
    (model, g.joint, lin, reflected)
}

#[test]
fn a_node_on_a_spring_carries_the_double_bars_reflected_mass_and_damping() {
    let (m, k) = (2.0, 4e4);
    let (model, joint, lin, r) = node_with_double_bar(m, k, vec![]);
    let Reflected {
        g1, m_eff, c_eff, ..
    } = r;
    close(lin.amplification(0, joint, 1).abs(), g1, 1e-10, "g1");

    let total = m + m_eff;
    let found = oscillatory(&lin, 1);
    assert_eq!(found.len(), 1, "one degree of freedom");
    let omega = (k / total).sqrt();
    close(
        found[0].natural_frequency_hz,
        omega / (2.0 * PI),
        1e-10,
        "frequency",
    );
    close(
        found[0].damping_ratio,
        c_eff / (2.0 * (k * total).sqrt()),
        1e-10,
        "damping ratio",
    );

    // White noise of intensity W (N^2 s) on the node: var(x) = W / (2 k c),
    // var(x') = W / (2 m c).
    let w = 3.0;
    let along_x = model.attachments[0].beam.along([1.0, 0.0]);
    assert_eq!(along_x.weights, vec![(0, 1.0)]);
    let force = lin.force_vector(&ExcitationTarget::Beam(along_x));
    let ss = StateSpace::new(&lin, &[force], None).unwrap();
    let (p, residual) = ss.covariance(&[w]).unwrap();
    assert!(residual < 1e-12, "Lyapunov residual {residual:e}");
    let var = |o: StateOutput| {
        let c = ss.row(&o);
        (c.transpose() * &p * &c)[(0, 0)]
    };
    close(
        var(StateOutput::position(vec![1.0])),
        w / (2.0 * k * c_eff),
        1e-10,
        "var(x)",
    );
    close(
        var(StateOutput::rate(vec![1.0])),
        w / (2.0 * total * c_eff),
        1e-10,
        "var(x')",
    );
}

/// A support acceleration `a(t)` along `x` under the one-node structure of
/// [`node_with_double_bar`]: relative to the supports the node is the oscillator
/// `(m + m_eff) x'' + c_eff x' + k x = -(m + m_base) a(t)` (docs/theory.md section 13.5:
/// the node's own mass and the double bar's momentum along `x` per unit node velocity).
/// Checked two ways: the linearisation's response to the unit support acceleration along
/// `[1, 0]` against the closed-form receptance at five frequencies (1e-10), and the time
/// integration of a small harmonic support acceleration (node amplitude 0.09 um) against
/// the same oscillator integrated by hand with the same average-acceleration Newmark rule
/// and step (1e-4 of the amplitude; measured 2e-5, the double bar's nonlinearity: it grows
/// with the square of the amplitude, 2e-4 at 0.9 um).
/// The support moving along `y` (the direction the node is held in) loads the node only
/// through the double bar: its momentum along `y` per unit node velocity, the knee's and
/// the coupler centre's `-cot(a)/2` and `-cot(a)/4` times the bars' masses; checked too.
#[test]
fn a_support_motion_along_x_moves_the_node_as_the_reflected_oscillator() {
    let (m, k) = (0.05, 4e4);
    let (amplitude, hz) = (0.03, 30.0);
    let along_x = ExcitationTarget::Base {
        direction: [1.0, 0.0],
    };
    let shake = Excitation {
        name: "base".into(),
        target: along_x.clone(),
        amplitude,
        time: TimeFunction::Harmonic {
            frequency_hz: hz,
            phase: 0.0,
        },
    };
    let (model, _, lin, r) = node_with_double_bar(m, k, vec![shake]);
    let total = m + r.m_eff;
    let loaded = m + r.m_base;
    assert!(r.m_base > 0.2 * m, "the double bar's share is visible");
    let receptance =
        |omega: f64| -loaded / Complex::new(k - omega * omega * total, omega * r.c_eff);
    let f = lin.force_vector(&along_x);
    for f_hz in [3.0, 20.0, 45.0, 52.0, 80.0] {
        let omega = 2.0 * PI * f_hz;
        let z = lin.harmonic_response(&f, omega).unwrap();
        let expected = receptance(omega);
        assert!(
            (z[0] - expected).norm() <= 1e-10 * expected.norm(),
            "{f_hz} Hz: {} vs {expected}",
            z[0]
        );
    }

    // The time history against the oscillator by the same Newmark rule.
    let h = 2e-5;
    let steps = 10_000;
    let mut state = initial_state(&model, vec![0.0], vec![0.0]).unwrap();
    let mut integrator = Integrator::new(&model, Method::Newmark, h, &state).unwrap();
    let force = |t: f64| -loaded * amplitude * (2.0 * PI * hz * t).sin();
    let (mut x, mut v) = (0.0, 0.0);
    let mut a = force(0.0) / total;
    let keff = total + 0.5 * h * r.c_eff + 0.25 * h * h * k;
    let (mut xs, mut hand) = (vec![], vec![]);
    for step in 1..=steps {
        integrator.step(&model, &mut state).unwrap();
        let t = step as f64 * h;
        let (xh, vh) = (x + h * v + 0.25 * h * h * a, v + 0.5 * h * a);
        a = (force(t) - r.c_eff * vh - k * xh) / keff;
        (x, v) = (xh + 0.25 * h * h * a, vh + 0.5 * h * a);
        xs.push(state.q[0]);
        hand.push(x);
    }
    let amp = hand.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(amp > 5e-8, "the node moves: {amp}");
    let err = xs
        .iter()
        .zip(&hand)
        .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
    assert!(err <= 1e-4 * amp, "{err:e} of {amp:e}");

    // Along y the node is held (r = 0 on its only equation): the double bar's y momentum
    // per unit node velocity, the crank's centre's -cot/4 and the coupler's -cot/4.
    let along_y = lin.force_vector(&ExcitationTarget::BASE_Y);
    close(along_y[0].abs(), r.m_base_y, 1e-10, "load along y");
}
