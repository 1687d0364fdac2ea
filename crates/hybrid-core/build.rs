//! Generates the bundled mechanisms into `OUT_DIR` (prost-build style): the paper's double
//! bar `models/double_bar.toml`, and the closed-loop examples `models/four_bar.toml` and
//! `models/slider_crank.toml`. Each file is rewritten only when the generated source changes,
//! and `cargo:rerun-if-changed` on the models means that editing a model and running
//! `cargo build` regenerates and recompiles its equations.
//!
//! The FNV-1a content hash of every model file is passed to the crate as
//! `HYBRID_CORE_<NAME>_HASH` (each module's `SOURCE_HASH`), so that a model file given at run
//! time can be matched to the compiled-in code.

use std::path::PathBuf;

use mbs_symbolic::emit::{EmitOptions, generate, write_if_changed};

fn main() {
    let manifest =
        PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR"));
    for name in ["double_bar", "four_bar", "slider_crank"] {
        let path = manifest.join(format!("../../models/{name}.toml"));
        // Announced before anything can fail, so that fixing the model reruns the script.
        println!("cargo:rerun-if-changed={}", path.display());
        let result = mbs_symbolic::model::load(&path)
            .map_err(|e| e.to_string())
            .and_then(|model| {
                let generated =
                    generate(&model, &EmitOptions::default()).map_err(|e| e.to_string())?;
                write_if_changed(&out.join(format!("{name}.rs")), &generated.source)
                    .map_err(|e| e.to_string())?;
                Ok(model.source.hash)
            });
        match result {
            Ok(hash) => println!(
                "cargo:rustc-env=HYBRID_CORE_{}_HASH={hash}",
                name.to_ascii_uppercase()
            ),
            Err(e) => {
                // A build script reports errors by failing with the message.
                eprintln!("{e}");
                std::process::exit(1);
            }
        }
    }
}
