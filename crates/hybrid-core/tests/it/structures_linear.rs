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

use hybrid_core::hybrid::{
    AttachmentKind, BeamPoint, EigenMethod, EquilibriumOptions, ExcitationTarget, HybridModel,
    Linearization, Mode, ModeKind, Mount, StateOutput, StateSpace, Structure, modes,
};

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
        at(&ExcitationTarget::Base),
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

#[test]
fn a_node_on_a_spring_carries_the_double_bars_reflected_mass_and_damping() {
    let paper = weightless_paper();
    let (m, k) = (2.0, 4e4);
    // The double bar turned by 90 degrees so that its ground pivot lies on the x axis.
    let mount = |g: &Geometry| Mount {
        origin: [g.target[1], -g.target[0]],
        angle: FRAC_PI_2,
    };
    let (model, g) = double_bar_on(
        &paper,
        node_on_springs(m, &[("ux", k)]),
        mount,
        AttachmentKind::Pin,
        BeamPoint::node([0.0, 0.0], Some(0), None),
    );
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
    let c_eff = c_joint * g1 * g1;
    close(lin.amplification(0, g.joint, 1).abs(), g1, 1e-10, "g1");

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
