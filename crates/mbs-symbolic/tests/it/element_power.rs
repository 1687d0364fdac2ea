//! The force elements' dissipation and input power (`System::element_power`, docs/theory.md
//! section 8): the symbolic expressions (DAG interpreter) against the numeric reference on
//! random trees with every kind of force element, and both against the power identity
//!
//! ```text
//! -q'^T Q_nc = P - D        (Q_nc: the part of Q that is not the springs' gradient)
//! ```
//!
//! computed from the numeric reference's own, independent `q_nonconservative`; for a
//! model whose only force elements are dampers, `D = q'^T Q` (paper sign) and `P = 0`.
//!
//! Tolerance 1e-12 relative to the size of the compared terms (the largest of `|D|`, `|P|`
//! and `sum_i |q'_i Q_nc,i|`): exact formulations in double precision.

use crate::common;

use common::{RandomOpts, random_model, random_state};
use mbs_symbolic::model::{ForceElement, Model, Scalar};
use mbs_symbolic::numeric::NumericModel;
use mbs_symbolic::runtime::{InterpretedSystem, NumericSystem, System};

const REL: f64 = 1e-12;

fn models() -> Vec<(u64, Model)> {
    let mut out = Vec::new();
    for planar in [true, false] {
        for bodies in [2, 4, 6] {
            for seed in 0..3u64 {
                let opts = RandomOpts {
                    bodies,
                    planar,
                    prismatic: true,
                    branching: seed % 2 == 1,
                    gravity: true,
                    force_elements: true,
                    runtime_params: seed == 2,
                };
                let seed = seed * 131 + bodies as u64 + if planar { 0 } else { 1000 };
                out.push((seed, random_model(seed, &opts)));
            }
        }
    }
    out
}

/// The model with every force element reduced to its damper: no spring, no constant joint
/// force, no external load.
fn dampers_only(m: &Model) -> Model {
    let mut m = m.clone();
    m.forces
        .retain(|f| !matches!(f, ForceElement::External { .. }));
    for f in &mut m.forces {
        match f {
            ForceElement::Joint {
                stiffness,
                constant,
                ..
            } => {
                *stiffness = Scalar::ZERO;
                *constant = Scalar::ZERO;
            }
            ForceElement::PointSpring { stiffness, .. } => *stiffness = Scalar::ZERO,
            ForceElement::External { .. } => unreachable!(),
        }
    }
    m
}

#[test]
fn element_power_agrees_on_every_backend_and_closes_the_power_identity() {
    let (mut worst_backend, mut worst_identity) = (0.0f64, 0.0f64);
    let mut dissipating = 0;
    let mut working = 0;
    for (seed, model) in models() {
        let n = model.dof();
        let interp = InterpretedSystem::new(&model);
        let numeric = NumericSystem::new(&model);
        let nm = NumericModel::with_default_params(&model);
        let (mut wi, mut wn) = (interp.workspace(), numeric.workspace());
        for s in 0..4 {
            let (q, qd, _) = random_state(seed * 17 + s, n);
            let pi = interp.element_power(&q, &qd, &mut wi);
            let pn = numeric.element_power(&q, &qd, &mut wn);
            let qnc = nm.q_nonconservative(&q, &qd, 0.0);
            let power: f64 = -qd.iter().zip(qnc.iter()).map(|(a, b)| a * b).sum::<f64>();
            let terms: f64 = qd.iter().zip(qnc.iter()).map(|(a, b)| (a * b).abs()).sum();
            let scale = pi
                .dissipated
                .abs()
                .max(pi.input.abs())
                .max(terms)
                .max(1e-300);
            let backend = (pi.dissipated - pn.dissipated)
                .abs()
                .max((pi.input - pn.input).abs())
                / scale;
            let identity = (power - (pn.input - pn.dissipated)).abs() / scale;
            let identity_sym = (power - (pi.input - pi.dissipated)).abs() / scale;
            assert!(
                backend <= REL,
                "seed {seed}: interpreter {pi:?} vs numeric {pn:?}"
            );
            assert!(
                identity.max(identity_sym) <= REL,
                "seed {seed}: -q'.Q_nc = {power} vs P - D = {} (interpreter {})",
                pn.input - pn.dissipated,
                pi.input - pi.dissipated
            );
            assert!(pi.dissipated >= 0.0, "seed {seed}: D = {}", pi.dissipated);
            worst_backend = worst_backend.max(backend);
            worst_identity = worst_identity.max(identity).max(identity_sym);
            dissipating += usize::from(pi.dissipated > 1e-6);
            working += usize::from(pi.input.abs() > 1e-6);
        }
    }
    println!(
        "element power: worst interpreter vs numeric {worst_backend:.1e}, worst power identity {worst_identity:.1e} ({dissipating} states dissipate, {working} have input power)"
    );
    assert!(
        dissipating > 20 && working > 20,
        "the random models exercise D and P"
    );
}

#[test]
fn dampers_alone_dissipate_q_dot_transpose_q() {
    let mut worst = 0.0f64;
    for (seed, model) in models() {
        let model = dampers_only(&model);
        let n = model.dof();
        let mut model_no_gravity = model.clone();
        model_no_gravity.gravity = [Scalar::ZERO, Scalar::ZERO, Scalar::ZERO];
        let sys = InterpretedSystem::new(&model_no_gravity);
        let mut ws = sys.workspace();
        for s in 0..4 {
            let (q, qd, _) = random_state(seed * 29 + s, n);
            let p = sys.element_power(&q, &qd, &mut ws);
            sys.evaluate(&q, &qd, 0.0, &mut ws);
            // Paper sign: a damper enters Q as +c q', so q'^T Q = D.
            let qq: f64 = qd.iter().zip(ws.q.iter()).map(|(a, b)| a * b).sum();
            let scale = p.dissipated.abs().max(1e-300);
            let err = (qq - p.dissipated).abs() / scale;
            assert!(
                err <= REL,
                "seed {seed}: q'.Q = {qq} vs D = {}",
                p.dissipated
            );
            assert_eq!(p.input, 0.0, "seed {seed}: dampers put no power in");
            worst = worst.max(err);
        }
    }
    println!("dampers only: worst |q'.Q - D| / D = {worst:.1e}");
}
