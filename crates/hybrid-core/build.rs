//! Generates the bundled double-bar mechanism from `models/double_bar.toml` into `OUT_DIR`
//! (rewritten only when the generated source changes). Editing the model file and running
//! `cargo build` regenerates and recompiles the equations.

use std::path::PathBuf;

use mbs_symbolic::emit::{EmitOptions, compile_model};

fn main() {
    let manifest =
        PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR"));
    let model = manifest.join("../../models/double_bar.toml");
    if let Err(e) = compile_model(&model, &out, "double_bar.rs", &EmitOptions::default()) {
        eprintln!("{e}");
        std::process::exit(1);
    }
}
