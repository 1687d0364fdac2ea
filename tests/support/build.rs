//! Generates the test fixture mechanisms at build time, exactly as a user's `build.rs` would
//! (prost-build style): each fixture model file becomes `OUT_DIR/<name>.rs`, rewritten only
//! when its content changes, with `cargo:rerun-if-changed` on the model. The 16-body spatial
//! chain of the benchmarks is built in code (`mbs_symbolic::samples::spatial_chain(16)`) and
//! emitted into `OUT_DIR/chain16.rs` the same way.
//!
//! The models under `models/` are NOT generated here: the one model registry
//! (`crates/model-registry/build.rs`) generates them, and the tests reach their generated
//! types only through `model_registry::Visitor`.

use std::path::PathBuf;

use mbs_symbolic::emit::{EmitOptions, compile_model, generate, write_if_changed};

fn main() {
    let root = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR"));
    let (file, out_name) = ("tests/fixtures/spatial_arm.toml", "spatial_arm.rs");
    if let Err(e) = compile_model(&root.join(file), &out, out_name, &EmitOptions::default()) {
        // A build script reports errors by failing with the message.
        eprintln!("{e}");
        std::process::exit(1);
    }
    let chain = mbs_symbolic::samples::spatial_chain(16);
    let opts = EmitOptions {
        struct_name: Some("Chain16".into()),
        ..EmitOptions::default()
    };
    let written =
        generate(&chain, &opts).and_then(|g| write_if_changed(&out.join("chain16.rs"), &g.source));
    if let Err(e) = written {
        eprintln!("spatial_chain(16): {e}");
        std::process::exit(1);
    }
}
