//! The generated evaluators allocate nothing: a counting global allocator observes a loop of
//! evaluations of every generated function. (This test binary has its own global allocator.)

// The counting allocator is the only unsafe code in the workspace: it forwards to `System`.
#![allow(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use damper_e2e::fixtures::{double_bar::DoubleBar, four_bar::FourBar, spatial_arm::SpatialArm};
use mbs_symbolic::runtime::{Mechanism, PointKinematics};

struct Counting;
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator unchanged; only counts calls.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

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
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    let acc = exercise(&db) + exercise(&fb) + exercise(&arm);
    let after = ALLOCATIONS.load(Ordering::SeqCst);
    assert!(acc.is_finite());
    assert_eq!(
        after - before,
        0,
        "generated evaluators allocated {} times",
        after - before
    );
}
