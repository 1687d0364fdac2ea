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

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use mbs_symbolic::emit::{EmitOptions, generate, write_if_changed};
use mbs_symbolic::expr::OpCount;
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

/// Longest function name shown in the `--stats` table; longer ones (point names can be
/// arbitrarily long) are truncated with an ellipsis.
pub const STATS_NAME_WIDTH: usize = 60;

/// The `--stats` table: one row per function and a final `all` row with the sums.
pub fn stats_table(stats: &[(String, OpCount)]) -> String {
    let shown = |name: &str| diagnostic::truncate(name, STATS_NAME_WIDTH);
    let width = stats
        .iter()
        .map(|(name, _)| shown(name).chars().count())
        .chain([8])
        .max()
        .unwrap_or(8);
    let mut out = String::new();
    let mut row = |name: &str, c: &OpCount| {
        let name = shown(name);
        let _ = writeln!(
            out,
            "{name:<width$}  {:>6} {:>6} {:>6} {:>6} {:>6} {:>6}",
            c.adds,
            c.muls,
            c.divs,
            c.funcs,
            c.negs,
            c.total()
        );
    };
    let mut all = OpCount::default();
    for (name, c) in stats {
        row(name, c);
        all = all + *c;
    }
    row("all", &all);
    format!(
        "{:<width$}  {:>6} {:>6} {:>6} {:>6} {:>6} {:>6}\n{out}",
        "function", "adds", "muls", "divs", "funcs", "negs", "total"
    )
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
        crate::print(&stats_table(&generated.stats))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_table_has_a_header_one_row_per_function_and_the_sums() {
        let c = |adds, muls| OpCount {
            adds,
            muls,
            divs: 1,
            funcs: 2,
            negs: 0,
        };
        let t = stats_table(&[("mass_matrix".into(), c(6, 13)), ("f".into(), c(1, 2))]);
        let lines: Vec<Vec<&str>> = t.lines().map(|l| l.split_whitespace().collect()).collect();
        assert_eq!(
            lines,
            vec![
                vec!["function", "adds", "muls", "divs", "funcs", "negs", "total"],
                vec!["mass_matrix", "6", "13", "1", "2", "0", "22"],
                vec!["f", "1", "2", "1", "2", "0", "6"],
                vec!["all", "7", "15", "2", "4", "0", "28"],
            ]
        );
    }

    /// `{name:<width$}` panics ("Formatting argument out of range") for widths over 65,535:
    /// a point name of 70,000 characters must give a truncated row, not a panic.
    #[test]
    fn stats_table_with_a_name_over_65535_chars_truncates_instead_of_panicking() {
        let long = format!("point_{}", "x".repeat(70_000));
        let t = stats_table(&[(long.clone(), OpCount::default())]);
        let row = t.lines().nth(1).unwrap();
        let name = row.split_whitespace().next().unwrap();
        assert_eq!(name.chars().count(), STATS_NAME_WIDTH + 1, "{name}"); // and the ellipsis
        assert!(long.starts_with(name.trim_end_matches('…')));
        assert!(t.len() < 1000);
    }
}
