//! `damper merge OUT` or `damper merge PART... -o OUT`: joins the partial results of a
//! sharded sweep (`damper sweep --shard I/N`) into exactly the `sweep.csv` and `sweep.json`
//! the unsharded run writes, byte for byte.
//!
//! The parts must be of one sweep (same scenario text hash, same `--set` specs, same
//! options, same N) and every shard 0..N must be there exactly once; anything else is one
//! line naming the problem, and nothing is written.
//!
//! Every part is checked before anything is written: it is a regular file (checked before
//! it is opened: a fifo is never read), within the size limit, a complete part file whose
//! checksum matches its content (an edited, deleted or truncated figure is refused, naming
//! the file), every figure a known unit and a finite number, every point in its shard and
//! the shard complete; the grid's size is counted from the specs (overflow-checked) and
//! must be the recorded one. The size of the parts and of the grid are bounded
//! (`crate::budget`: 1 GiB, 1e6 points) unless `--allow-long`. A list of missing shards
//! names the first few and the count.

use std::path::PathBuf;

use crate::Error;
use crate::budget::{self, Quantity};
use crate::report::{OutputLock, ReportError, commit_files};

use crate::analysis::sweep::Part;
use crate::analysis::sweep::part::{merge, part_size, parts_in, read_part};
use crate::report::sweep::outputs;

/// Arguments of `damper merge`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Part files (`sweep.part-I-of-N.json`), or one directory holding them.
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// Output directory (default: the directory given as the only input).
    #[arg(short = 'o', long = "out")]
    pub out: Option<PathBuf>,
    /// Merge even when the part files (1 GiB in all) or the grid (1e6 points) are above the
    /// limits (`codegen_cli::budget`).
    #[arg(long)]
    pub allow_long: bool,
}

/// Runs `damper merge`.
pub fn run(args: Args) -> Result<(), Error> {
    let (files, out) = match (&args.parts[..], &args.out) {
        ([dir], out) if dir.is_dir() => (parts_in(dir)?, out.clone().unwrap_or(dir.clone())),
        (files, Some(out)) => {
            let mut all = vec![];
            for f in files {
                match f.is_dir() {
                    true => all.extend(parts_in(f)?),
                    false => all.push(f.clone()),
                }
            }
            (all, out.clone())
        }
        (_, None) => {
            return Err(Error::Usage(
                "merge: give the output directory with -o OUT (or one directory of parts)".into(),
            ));
        }
    };
    // One merge (or unsharded sweep) at a time into a directory.
    let _lock = OutputLock::acquire(&out).map_err(ReportError::from)?;
    let mut bytes = 0.0;
    for f in &files {
        bytes += part_size(f)? as f64;
    }
    budget::refuse_above(
        "merge",
        &[Quantity::bytes("part files", bytes, budget::MAX_BYTES)],
        "merge fewer, smaller parts",
        args.allow_long,
    )?;
    let parts: Vec<(PathBuf, Part)> = files
        .into_iter()
        .map(|f| read_part(&f).map(|p| (f, p)))
        .collect::<Result<_, _>>()?;
    let (spec, grid, results) = merge(&parts, args.allow_long)?;
    let files = outputs(&out, &spec, &grid, &results)?;
    commit_files(&files).map_err(ReportError::from)?;
    let failed = results.iter().filter(|r| r.error.is_some()).count();
    eprintln!(
        "merge: {} part(s), {} point(s), {failed} failed; wrote {}",
        parts.len(),
        results.len(),
        files
            .iter()
            .map(|f| f.path.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(())
}
