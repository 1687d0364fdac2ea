//! The one integration-test binary of `codegen-cli` (STYLE.md rule 7): one module per
//! area, built and linked once.

// Allocation counting (per thread) for the tests that prove hot paths allocation-free.
#[global_allocator]
static GLOBAL: damper_e2e::alloc_counter::CountingAllocator =
    damper_e2e::alloc_counter::CountingAllocator;

mod admissible_load;
mod amplification_cli;
mod bad_values_cli;
mod base_cli;
mod bundled_hybrid;
mod common;
mod eval_cli;
mod figures_cli;
mod frf;
mod fuzz;
mod generate_cli;
mod generator_datasheet;
mod hybrid_cli;
mod layout;
mod linear_vs_time_domain;
mod linearize_cli;
mod modes_cli;
mod optimize_cli;
mod output_dir_cli;
mod plots;
mod preset;
mod random_cli;
mod readme_cli;
mod reliability_cli;
mod scenario_loader;
mod sensitivity;
mod shape_plot_cli;
mod simulate_cli;
mod simulate_mechanism_cli;
mod special_files_cli;
mod stale_model_cli;
mod structure_cli;
mod structure_linear_cli;
mod sweep_cli;
