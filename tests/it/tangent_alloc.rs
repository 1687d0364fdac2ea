//! The tangent matrices of `mbs_symbolic::runtime::TangentSystem` are evaluated without
//! allocating once the workspace exists: a counting global allocator observes loops of
//! evaluations on every bundled model. (This test binary has its own global allocator.)

use damper_e2e::alloc_counter::allocations;
use damper_e2e::workspace_root;
use mbs_symbolic::runtime::TangentSystem;

#[test]
fn tangent_evaluation_does_not_allocate() {
    let dir = workspace_root().join("models");
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml" || x == "json"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 6, "{paths:?}");
    for path in paths {
        let model = mbs_symbolic::model::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let mut tan = TangentSystem::new(&model);
        if let Some(p) = tan.names().params.first().cloned() {
            tan.set_param(&p, 1.25).unwrap();
        }
        let (n, rows, points) = (tan.dof(), tan.rows(), tan.names().points.len());
        let mut ws = tan.workspace();
        let (mut q, mut qd, qdd) = (vec![0.3; n], vec![-0.4; n], vec![0.7; n]);
        let lambda = vec![2.0; rows];
        let mut acc = 0.0;
        let before = allocations();
        for step in 0..500 {
            let s = step as f64 * 1e-3;
            for i in 0..n {
                q[i] = s + 0.3 * i as f64;
                qd[i] = 1.0 - s * i as f64;
            }
            tan.evaluate_dynamics(&q, &qd, &qdd, s, &mut ws);
            tan.evaluate_constraints(&q, &lambda, &mut ws);
            for k in 0..points {
                assert!(tan.evaluate_point(k, &q, [1.0, -2.0, 0.5], &mut ws));
                acc += ws.point_curvature[(0, 0)];
            }
            acc += ws.k[(0, 0)] + ws.c[(0, 0)] + ws.m[(0, 0)] + ws.constraint_curvature[(0, 0)];
        }
        let after = allocations();
        assert!(acc.is_finite(), "{}", path.display());
        assert_eq!(
            after - before,
            0,
            "{}: {} allocations in 500 evaluations",
            path.display(),
            after - before
        );
    }
}
