//! The `build.rs` entry point (prost-build style): model file in, generated module in
//! `OUT_DIR` out, rewritten only when its content changes.

use std::path::{Path, PathBuf};

use super::{EmitError, EmitOptions, generate, write_if_changed};

/// What [`compile_model`] produced: enough for a build script to include the module and to
/// pass the model's identity on to the crate.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Compiled {
    /// Path of the generated file (`out_dir/<file_name>`).
    pub path: PathBuf,
    /// Content hash of the model file (FNV-1a 64, `SourceInfo::hash`), as written into the
    /// `@generated` header.
    pub hash: String,
    /// Name of the generated struct.
    pub struct_name: String,
}

/// `build.rs` entry point (prost-build style): reads the model at `model_path`, generates its
/// module into `out_dir/<file_name>` if the content changed, and prints
/// `cargo:rerun-if-changed` for the model (before anything can fail, so that fixing the
/// model reruns the script). The module is included with
/// `include!(concat!(env!("OUT_DIR"), "/<file_name>"))`.
///
/// ```no_run
/// // build.rs
/// use std::path::{Path, PathBuf};
/// use mbs_symbolic::emit::{EmitOptions, compile_model};
///
/// let out = PathBuf::from(std::env::var_os("OUT_DIR").unwrap());
/// let compiled = compile_model(
///     Path::new("models/double_bar.toml"),
///     &out,
///     "double_bar.rs",
///     &EmitOptions::default(),
/// )
/// .unwrap_or_else(|e| panic!("{e}"));
/// println!("cargo:rustc-env=DOUBLE_BAR_HASH={}", compiled.hash);
/// ```
pub fn compile_model(
    model_path: &Path,
    out_dir: &Path,
    file_name: &str,
    opts: &EmitOptions,
) -> Result<Compiled, EmitError> {
    println!("cargo:rerun-if-changed={}", model_path.display());
    let model = crate::model::load(model_path)?;
    let generated = generate(&model, opts)?;
    let path = out_dir.join(file_name);
    write_if_changed(&path, &generated.source)?;
    Ok(Compiled {
        path,
        hash: model.source.hash,
        struct_name: generated.struct_name,
    })
}
