//! The symbolic equations (evaluated by the DAG interpreter) against the independent numeric
//! recursive reference, on randomly generated trees: planar and spatial, chains and branching
//! trees, mixed revolute/prismatic joints, off-axis centres of mass, full inertia tensors,
//! gravity, every kind of force element, run-time and folded parameters.
//!
//! Tolerance: 1e-12 relative to the largest entry of the compared quantity. Both sides are
//! exact formulations evaluated in double precision with O(10^2) operations per entry, so
//! their rounding differences stay within a few hundred ulps of the largest term.

mod common;

use common::{RandomOpts, random_model, random_state};
use mbs_symbolic::constraints;
use mbs_symbolic::dynamics::Symbolic;
use mbs_symbolic::expr::{EvalInput, Id, Tape};
use mbs_symbolic::numeric::NumericModel;
use proptest::prelude::*;

fn assert_close(what: &str, got: &[f64], want: &[f64], seed: u64) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    let scale = want.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= 1e-12 * scale,
            "seed {seed}: {what}[{k}]: symbolic {g} vs numeric {w} (scale {scale}, diff {})",
            (g - w).abs()
        );
    }
}

fn check(seed: u64, opts: &RandomOpts) {
    let model = random_model(seed, opts);
    let n = model.dof();
    let mut sym = Symbolic::derive(&model);
    let pts = constraints::points(&model, &mut sym);
    let cons = constraints::constraints(&model, &mut sym);
    // Perturb the run-time parameters away from their defaults: the symbolic side must read
    // them at evaluation time, the numeric side is rebuilt with the same values.
    let mut params = model.default_params();
    for (k, p) in model.parameters.iter().enumerate() {
        if p.runtime {
            params[k] *= 1.0 + 0.01 * (k as f64 + 1.0);
        }
    }
    let num = NumericModel::new(&model, &params);
    for s in 0..3 {
        let (q, qd, _) = random_state(seed * 31 + s, n);
        let t = 0.37;
        let input = EvalInput {
            q: &q,
            qd: &qd,
            qdd: &[],
            t,
            params: &params,
        };
        let eval = |roots: &[Id]| Tape::new(&sym.dag, roots).eval_vec(&input);
        let m = num.mass_matrix(&q);
        let m_rows: Vec<f64> = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .map(|(i, j)| m[(i, j)])
            .collect();
        assert_close("M", &eval(&sym.mass), &m_rows, seed);
        assert_close("F", &eval(&sym.f), num.f_vector(&q, &qd).as_slice(), seed);
        assert_close(
            "Q",
            &eval(&sym.q),
            num.q_vector(&q, &qd, t).as_slice(),
            seed,
        );
        for (k, p) in pts.iter().enumerate() {
            assert_close(
                "point p",
                &eval(&p.p),
                num.point_position(k, &q).as_slice(),
                seed,
            );
            let jn = num.point_jacobian(k, &q);
            let jrows: Vec<f64> = (0..3)
                .flat_map(|r| (0..n).map(move |c| (r, c)))
                .map(|(r, c)| jn[(r, c)])
                .collect();
            let js: Vec<Id> = p.j.iter().flatten().copied().collect();
            assert_close("point J", &eval(&js), &jrows, seed);
            assert_close(
                "point A",
                &eval(&p.a),
                num.point_bias(k, &q, &qd).as_slice(),
                seed,
            );
        }
        if !cons.h.is_empty() {
            assert_close("h", &eval(&cons.h), num.constraints(&q).as_slice(), seed);
            let jn = num.constraint_jacobian(&q);
            let rows = cons.h.len();
            let jrows: Vec<f64> = (0..rows)
                .flat_map(|r| (0..n).map(move |c| (r, c)))
                .map(|(r, c)| jn[(r, c)])
                .collect();
            let js: Vec<Id> = cons.j.iter().flatten().copied().collect();
            assert_close("J", &eval(&js), &jrows, seed);
            assert_close(
                "A",
                &eval(&cons.a),
                num.constraint_bias(&q, &qd).as_slice(),
                seed,
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, failure_persistence: None, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5EED), ..ProptestConfig::default() })]

    #[test]
    fn spatial_branching_trees(seed in 0u64..1_000_000, bodies in 1usize..7) {
        check(seed, &RandomOpts { bodies, ..RandomOpts::default() });
    }

    #[test]
    fn planar_chains(seed in 0u64..1_000_000, bodies in 1usize..8, prismatic in any::<bool>()) {
        check(seed, &RandomOpts { bodies, planar: true, branching: false, prismatic, ..RandomOpts::default() });
    }

    #[test]
    fn planar_trees_folded_parameters(seed in 0u64..1_000_000, bodies in 2usize..7) {
        check(seed, &RandomOpts { bodies, planar: true, runtime_params: false, ..RandomOpts::default() });
    }

    #[test]
    fn spatial_chains_without_gravity_or_forces(seed in 0u64..1_000_000, bodies in 1usize..7) {
        check(seed, &RandomOpts { bodies, branching: false, gravity: false, force_elements: false, ..RandomOpts::default() });
    }
}
