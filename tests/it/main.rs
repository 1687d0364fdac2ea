//! The one integration-test binary of `damper-e2e` (STYLE.md rule 7): one module per
//! area, built and linked once.

// Allocation counting (per thread) for the tests that prove hot paths allocation-free.
#[global_allocator]
static GLOBAL: damper_e2e::alloc_counter::CountingAllocator =
    damper_e2e::alloc_counter::CountingAllocator;

mod docs;
mod generated_alloc;
mod generated_code;
mod tangent_alloc;
