//! The one integration-test binary of `hybrid-core` (STYLE.md rule 7): one module per
//! area, built and linked once.

// Allocation counting (per thread, so the other tests running in parallel are not counted)
// for the tests that prove hot paths allocation-free (`step_alloc`).
#[global_allocator]
static GLOBAL: damper_e2e::alloc_counter::CountingAllocator =
    damper_e2e::alloc_counter::CountingAllocator;

mod base;
mod closed_loop;
mod common;
mod damper_oracle;
mod damper_physics;
mod decay;
mod forced;
mod hybrid_absorber;
mod hybrid_reference;
mod linear_vs_time_domain;
mod linearize;
mod oracle;
mod sensitivity;
mod step_alloc;
mod structures;
mod structures_linear;
mod variants;
