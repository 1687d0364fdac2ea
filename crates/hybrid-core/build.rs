//! Generates the bundled double-bar mechanism from `models/double_bar.toml` into `OUT_DIR`
//! (rewritten only when the generated source changes). Editing the model file and running
//! `cargo build` regenerates and recompiles the equations.
//!
//! The closed-loop examples `models/four_bar.toml` and `models/slider_crank.toml` are
//! generated the same way, and the FNV-1a content hash of every model file is passed to the
//! crate as `HYBRID_CORE_<NAME>_HASH` (each module's `SOURCE_HASH`), so that a model file
//! given at run time can be matched to the compiled-in code.

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
    for name in ["double_bar", "four_bar", "slider_crank"] {
        let model = manifest.join(format!("../../models/{name}.toml"));
        if name != "double_bar" {
            let file = format!("{name}.rs");
            if let Err(e) = compile_model(&model, &out, &file, &EmitOptions::default()) {
                eprintln!("{e}");
                std::process::exit(1);
            }
        }
        match mbs_symbolic::model::load(&model) {
            Ok(m) => println!(
                "cargo:rustc-env=HYBRID_CORE_{}_HASH={}",
                name.to_ascii_uppercase(),
                m.source.hash
            ),
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        }
    }
}
