//! Shared support for the workspace-level end-to-end tests in `tests/` and the benchmarks in
//! `benches/`: the test fixture mechanisms generated at build time by
//! `tests/support/build.rs`, the one seeded test generator
//! (`mbs_symbolic::samples::SplitMix64`) and a counting global allocator for
//! allocation-free checks.

use std::path::PathBuf;

/// Absolute path of the workspace root (where `models/`, `beams/` and `scenarios/` live).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Test fixture mechanisms generated at build time by `tests/support/build.rs`. The models
/// under `models/` are not here: the one model registry (`model-registry`) compiles them in,
/// and tests reach their fixed-size generated types only through `model_registry::Visitor`.
pub mod fixtures {
    /// `tests/fixtures/spatial_arm.toml`
    pub mod spatial_arm {
        include!(concat!(env!("OUT_DIR"), "/spatial_arm.rs"));
    }
    /// `mbs_symbolic::samples::spatial_chain(16)` (struct `Chain16`): the 16-body spatial
    /// chain of the benchmarks.
    pub mod chain16 {
        include!(concat!(env!("OUT_DIR"), "/chain16.rs"));
    }
}

/// A global allocator that counts allocations, for the tests that prove hot paths
/// allocation-free. A test binary installs it with
/// `#[global_allocator] static GLOBAL: CountingAllocator = CountingAllocator;` and compares
/// [`alloc_counter::allocations`] before and after the loop under test.
pub mod alloc_counter {
    // The only unsafe code of the workspace: forwarding to the system allocator.
    #![allow(unsafe_code)]

    use std::alloc::{GlobalAlloc, Layout, System};
    use std::cell::Cell;

    thread_local! {
        // Per thread, so that the test harness's own threads (which may allocate while a
        // test runs) are not counted. Const-initialised and without destructor: reading it
        // never allocates.
        static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
    }

    fn count() {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
    }

    /// Forwards to [`System`] and counts `alloc` and `realloc` calls of each thread.
    pub struct CountingAllocator;

    // SAFETY: every call is forwarded unchanged to the system allocator; only a counter is
    // added.
    unsafe impl GlobalAlloc for CountingAllocator {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            count();
            // SAFETY: the caller upholds `GlobalAlloc::alloc`'s contract.
            unsafe { System.alloc(layout) }
        }
        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            // SAFETY: the caller upholds `GlobalAlloc::dealloc`'s contract.
            unsafe { System.dealloc(ptr, layout) }
        }
        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            count();
            // SAFETY: the caller upholds `GlobalAlloc::realloc`'s contract.
            unsafe { System.realloc(ptr, layout, new_size) }
        }
    }

    /// Allocations (and reallocations) counted so far on the calling thread.
    pub fn allocations() -> usize {
        ALLOCATIONS.with(Cell::get)
    }
}
