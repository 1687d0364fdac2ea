//! The simulation step allocates nothing: a counting global allocator observes 2,000 steps of
//! the default damper scenario (generated double bar, generator with and without inductance).

// The counting allocator forwards to `System`; it is the only unsafe code of this test.
#![allow(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use hybrid_core::damper::Integrator;
use hybrid_core::generated::double_bar::DoubleBar;
use hybrid_core::scenario::Scenario;
use hybrid_core::study::build_model;

struct Counting;
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards every call to the system allocator unchanged; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: the caller upholds `GlobalAlloc::alloc`'s contract.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller upholds `GlobalAlloc::dealloc`'s contract.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: the caller upholds `GlobalAlloc::realloc`'s contract.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn damper_step_does_not_allocate() {
    let path = std::path::PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/damper.toml"
    ));
    let text = std::fs::read_to_string(&path).unwrap();
    for (inductance, method) in [("0.0", "\"newmark\""), ("1e-4", "\"hht\"")] {
        let text = text
            .replace("inductance = 0.0", &format!("inductance = {inductance}"))
            .replace("\"newmark\"", method);
        let sc = Scenario::from_str(&text, &path).unwrap();
        let (model, guess) = build_model(&sc, DoubleBar::default(), true).unwrap();
        let mut state = model.initial_state(1e-3, guess).unwrap();
        let mut integ = Integrator::new(&model, sc.method, 1e-4).unwrap();
        integ.step(&model, &mut state).unwrap();
        let before = ALLOCATIONS.load(Ordering::SeqCst);
        for _ in 0..2000 {
            integ.step(&model, &mut state).unwrap();
        }
        let after = ALLOCATIONS.load(Ordering::SeqCst);
        assert!(state.q.iter().all(|x| x.is_finite()));
        assert_eq!(
            after - before,
            0,
            "{} allocations in 2000 steps (inductance {inductance}, {method})",
            after - before
        );
    }
}
