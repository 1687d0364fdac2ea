//! Shared support for the workspace-level end-to-end tests in `tests/` and the benchmarks in
//! `benches/`: the test fixture mechanisms generated at build time by
//! `tests/support/build.rs`, the one seeded test generator ([`rng::SplitMix64`]) and a
//! counting global allocator for allocation-free checks.

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

/// The one deterministic generator of the end-to-end tests and benchmarks: seeded test
/// states, no external RNG crate.
pub mod rng {
    /// SplitMix64 (Steele, Lea, Flood 2014): a tiny, fast, well-mixed 64-bit generator.
    #[derive(Clone, Debug)]
    pub struct SplitMix64(u64);

    impl SplitMix64 {
        /// A generator with the given seed.
        pub fn new(seed: u64) -> Self {
            SplitMix64(seed)
        }

        /// The next 64 random bits.
        pub fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }

        /// Uniform in `[0, 1)` (53 random bits).
        pub fn unit(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
        }

        /// Uniform in `[-1, 1)`.
        pub fn signed(&mut self) -> f64 {
            self.unit() * 2.0 - 1.0
        }

        /// `N` values uniform in `[-scale, scale)`.
        pub fn array<const N: usize>(&mut self, scale: f64) -> [f64; N] {
            std::array::from_fn(|_| scale * self.signed())
        }

        /// `n` values uniform in `[-scale, scale)`.
        pub fn vec(&mut self, n: usize, scale: f64) -> Vec<f64> {
            (0..n).map(|_| scale * self.signed()).collect()
        }
    }

    #[cfg(test)]
    mod tests {
        use super::SplitMix64;

        /// The reference sequence of SplitMix64 for seed 0 (Vigna's `splitmix64.c`).
        #[test]
        fn splitmix64_matches_the_reference_sequence() {
            let mut r = SplitMix64::new(0);
            assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
            assert_eq!(r.next_u64(), 0x6E78_9E6A_A1B9_65F4);
            assert_eq!(r.next_u64(), 0x06C4_5D18_8009_454F);
        }

        #[test]
        fn signed_values_stay_in_range() {
            let mut r = SplitMix64::new(42);
            for v in r.vec(1000, 3.0) {
                assert!((-3.0..3.0).contains(&v), "{v}");
            }
        }
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
