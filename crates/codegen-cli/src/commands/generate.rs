//! `damper generate MODEL -o FILE [--stats] [--struct-name NAME]`: emit the Rust module of a
//! mechanism model for standalone use (the same source a `build.rs` gets from
//! [`mbs_symbolic::emit::compile_model`]).
//!
//! The output file is written completely or not at all (temporary file + rename), and only
//! when its content changes, so an unchanged model does not trigger rebuilds. A status line
//! goes to standard error; `--stats` prints a table of the operation count of every
//! generated function to standard output:
//!
//! ```text
//! function                adds   muls   divs  funcs   negs  total
//! mass_matrix                6     13      4      1      0     24
//! ...
//! all                      ...
//! ```
//!
//! **Limit** (`crate::budget`): the generated source grows with the square of the model
//! (`400 ((n + n_c)^2 + 3 p n)` bytes for `n` coordinates, `n_c` constraint rows and `p`
//! points; about four times that in memory while generating); a model estimated above
//! 32 MiB of source (about 290 coordinates) is refused after loading, before generating,
//! unless `--allow-long`.

use std::path::{Path, PathBuf};

use mbs_symbolic::emit::{EmitOptions, generate, write_if_changed};
use mbs_symbolic::model;

use crate::Error;
use crate::budget::{self, Quantity};

/// Arguments of `damper generate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Mechanism model file (.toml or .json).
    pub model: PathBuf,
    /// Output Rust source file (its directory must exist).
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: PathBuf,
    /// Print the operation count of every generated function (adds, muls, divs, funcs,
    /// negs, total) to standard output.
    #[arg(long)]
    pub stats: bool,
    /// Name of the generated struct (default: the model name in UpperCamelCase).
    #[arg(long, value_name = "NAME")]
    pub struct_name: Option<String>,
    /// Generate even when the estimated source is above the limit (32 MiB, about 290
    /// coordinates; `codegen_cli::budget`).
    #[arg(long)]
    pub allow_long: bool,
}

/// Checks before any work that the output can be created: its directory exists and the
/// path is not a directory itself (clearer messages than the operating system's).
fn check_output(path: &Path) -> Result<(), Error> {
    if path.is_dir() {
        return Err(Error::Usage(format!(
            "output {} is a directory, not a file",
            path.display()
        )));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if dir.exists() && !dir.is_dir() {
        return Err(Error::Usage(format!(
            "cannot write {}: {} is not a directory",
            path.display(),
            dir.display()
        )));
    }
    if !dir.is_dir() {
        return Err(Error::Usage(format!(
            "cannot write {}: directory {} does not exist",
            path.display(),
            dir.display()
        )));
    }
    Ok(())
}

/// Runs `damper generate`.
pub fn run(args: Args) -> Result<(), Error> {
    check_output(&args.output)?;
    // Model errors already name the file, the line and the entity.
    let model = model::load(&args.model)?;
    let source =
        budget::generated_source_bytes(model.dof(), model.constraint_rows(), model.points.len());
    budget::refuse_above(
        &args.model.display().to_string(),
        &[Quantity::bytes(
            "generated source",
            source,
            budget::MAX_SOURCE_BYTES,
        )],
        &format!(
            "the model has {} coordinates and {} constraint rows; split it",
            model.dof(),
            model.constraint_rows()
        ),
        args.allow_long,
    )?;
    let opts = EmitOptions {
        struct_name: args.struct_name.clone(),
        ..EmitOptions::default()
    };
    let generated = generate(&model, &opts)?;
    let wrote = {
        // A signal while the file is being replaced is handled after it (crate::interrupt).
        let _commit = crate::interrupt::commit_section();
        write_if_changed(&args.output, &generated.source)?
    };
    eprintln!(
        "{}: {} (struct {}, {} coordinates, {} constraint rows)",
        args.output.display(),
        if wrote { "written" } else { "unchanged" },
        generated.struct_name,
        model.dof(),
        model.constraint_rows()
    );
    if args.stats {
        crate::print(&crate::report::op_counts::stats_table(&generated.stats))?;
    }
    Ok(())
}
