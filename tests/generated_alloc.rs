//! The generated evaluators allocate nothing: a counting global allocator observes a loop of
//! evaluations of every generated function. (This test binary has its own global allocator.)

use damper_e2e::alloc_counter::{CountingAllocator, allocations};
use damper_e2e::fixtures::{double_bar::DoubleBar, four_bar::FourBar, spatial_arm::SpatialArm};
use mbs_symbolic::runtime::{Mechanism, PointKinematics};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

fn exercise<const N: usize, const NC: usize>(m: &impl Mechanism<N, NC>) -> f64 {
    let mut acc = 0.0;
    let (mut mm, mut f, mut qv) = ([[0.0; N]; N], [0.0; N], [0.0; N]);
    let (mut h, mut j, mut a) = ([0.0; NC], [[0.0; N]; NC], [0.0; NC]);
    let mut pk = PointKinematics::<N>::default();
    for step in 0..1000 {
        let s = step as f64 * 1e-3;
        let q: [f64; N] = std::array::from_fn(|i| s + i as f64 * 0.3);
        let qd: [f64; N] = std::array::from_fn(|i| 1.0 - s * i as f64);
        m.mass_matrix(&q, &mut mm);
        m.f_vector(&q, &qd, &mut f);
        m.q_vector(&q, &qd, s, &mut qv);
        m.constraints(&q, &mut h);
        m.constraint_jacobian(&q, &mut j);
        m.constraint_bias(&q, &qd, &mut a);
        for k in 0..m.point_names().len() {
            m.point_kinematics(k, &q, &qd, &mut pk);
            acc += pk.p[0];
        }
        acc += mm[0][0] + f[0] + qv[0];
    }
    acc
}

#[test]
fn generated_evaluations_do_not_allocate() {
    let (db, fb, arm) = (
        DoubleBar::default(),
        FourBar::default(),
        SpatialArm::default(),
    );
    let before = allocations();
    let acc = exercise(&db) + exercise(&fb) + exercise(&arm);
    let after = allocations();
    assert!(acc.is_finite());
    assert_eq!(
        after - before,
        0,
        "generated evaluators allocated {} times",
        after - before
    );
}
