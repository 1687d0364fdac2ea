//! Shared support for the workspace-level end-to-end tests in `tests/`: the fixture
//! mechanisms generated at build time by `tests/support/build.rs`.

use std::path::PathBuf;

/// Absolute path of the workspace root (where `models/`, `beams/` and `scenarios/` live).
pub fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Mechanisms generated from their model files at build time.
pub mod fixtures {
    /// `models/double_bar.toml`
    pub mod double_bar {
        include!(concat!(env!("OUT_DIR"), "/double_bar.rs"));
    }
    /// `models/four_bar.toml`
    pub mod four_bar {
        include!(concat!(env!("OUT_DIR"), "/four_bar.rs"));
    }
    /// `models/slider_crank.toml`
    pub mod slider_crank {
        include!(concat!(env!("OUT_DIR"), "/slider_crank.rs"));
    }
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
    use std::sync::atomic::{AtomicUsize, Ordering};

    static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

    /// Forwards to [`System`] and counts `alloc` and `realloc` calls.
    pub struct CountingAllocator;

    // SAFETY: every call is forwarded unchanged to the system allocator; only a counter is
    // added.
    unsafe impl GlobalAlloc for CountingAllocator {
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

    /// Allocations (and reallocations) counted so far in this process.
    pub fn allocations() -> usize {
        ALLOCATIONS.load(Ordering::SeqCst)
    }
}
