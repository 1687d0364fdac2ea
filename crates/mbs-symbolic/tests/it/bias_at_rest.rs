//! `A = J' q'` (eq. 16) and the point biases `J_k' q'` (eq. 50) are exactly zero at rest.
//!
//! Every term of `J' q' = d(J q')/dq q'` is a product with a joint rate, so at `q' = 0` the
//! bias is `0.0` in floating point too — not a small residue — whatever the gravity, the
//! joint frames or the configuration. A formulation that adds the base acceleration `-g`
//! in the body frames and takes `g` back off in the ground frame is equal in exact
//! arithmetic but leaves rounding residues (about 1e-14, growing with `|g|`) on spatial
//! trees with rotated joint frames; this test fails on it.
//!
//! Checked for every backend that computes the bias from the model alone: the interpreter
//! (the symbolic rows every generated function is emitted from) and the numeric reference.
//! The generated backend of the compiled models is checked in `model-registry`.

use crate::common;

use common::{RandomOpts, random_model, random_state};
use mbs_symbolic::runtime::{InterpretedSystem, NumericSystem, System};

/// Asserts every entry is `+0.0` (bitwise: a `-0.0` would still compare equal to `0.0`).
fn assert_exact_zero(what: &str, values: &[f64]) {
    for (k, v) in values.iter().enumerate() {
        assert!(
            v.to_bits() == 0,
            "{what}[{k}] = {v:e} at q' = 0 (bits {:#x}): J'q' must be exactly zero",
            v.to_bits()
        );
    }
}

fn check(what: &str, sys: &dyn System, q: &[f64]) {
    let n = sys.dof();
    let zero = vec![0.0; n];
    let mut ws = sys.workspace();
    sys.evaluate(q, &zero, 0.3, &mut ws);
    assert_exact_zero(&format!("{what}: A"), ws.a.as_slice());
    for k in 0..sys.names().points.len() {
        assert!(sys.point_kinematics(k, q, &zero, &mut ws));
        assert_exact_zero(&format!("{what}: point {k} A"), ws.point_a.as_slice());
        assert!(sys.evaluate_with_point(k, q, &zero, 0.3, &mut ws));
        assert_exact_zero(
            &format!("{what}: point {k} (fused) A"),
            ws.point_a.as_slice(),
        );
        assert_exact_zero(
            &format!("{what}: A (fused with point {k})"),
            ws.a.as_slice(),
        );
    }
}

/// 30 random trees: spatial (rotated joint frames about every axis), branching and chains,
/// revolute and prismatic joints, gravity scaled up to 1e3 so a residue proportional to `g`
/// could not hide below the test's resolution; loop, fixed and angle constraints and one
/// named point per body.
#[test]
fn bias_is_exactly_zero_at_rest_on_random_spatial_trees() {
    let mut constrained = 0;
    for seed in 0..30u64 {
        let opts = RandomOpts {
            bodies: 2 + (seed as usize % 5),
            branching: seed % 3 != 0,
            ..RandomOpts::default()
        };
        let mut model = random_model(seed, &opts);
        constrained += usize::from(!model.constraints.is_empty());
        let n = model.dof();
        let g_index = model.param_index("g").unwrap();
        for g in [9.81, 1e3] {
            model.parameters[g_index].value = g;
            let interpreted = InterpretedSystem::new(&model);
            let numeric = NumericSystem::new(&model);
            for s in 0..3 {
                let (q, _, _) = random_state(seed * 131 + s, n);
                let what = format!("seed {seed} ({opts:?}), g = {g}, state {s}");
                check(&format!("interpreter, {what}"), &interpreted, &q);
                check(&format!("numeric, {what}"), &numeric, &q);
            }
        }
    }
    assert!(constrained >= 20, "only {constrained} constrained trees");
}
