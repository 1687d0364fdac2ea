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

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::Error;
use crate::budget::{self, Quantity};
use crate::report::{OutputLock, ReportError, commit_files};

use super::sweep::{Grid, Part, PointResult, Shape, outputs, part_name, shard_points};

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

/// The part files in a directory (`sweep.part-*-of-*.json`), sorted by name.
fn parts_in(dir: &Path) -> Result<Vec<PathBuf>, Error> {
    let entries = std::fs::read_dir(dir)
        .map_err(|e| Error::Usage(format!("cannot read the directory {}: {e}", dir.display())))?;
    let mut parts: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("sweep.part-") && n.ends_with(".json"))
        })
        .collect();
    parts.sort();
    if parts.is_empty() {
        return Err(Error::Usage(format!(
            "no sweep.part-I-of-N.json in {}",
            dir.display()
        )));
    }
    Ok(parts)
}

/// The size of a part file, checked to be a regular file before it is opened (a fifo or a
/// device would block or never end).
fn part_size(path: &Path) -> Result<u64, Error> {
    let meta = std::fs::metadata(path)
        .map_err(|e| Error::Usage(format!("cannot read {}: {e}", path.display())))?;
    if !meta.is_file() {
        return Err(Error::Usage(format!(
            "{}: not a regular file (merge reads sweep part files only)",
            path.display()
        )));
    }
    Ok(meta.len())
}

fn read_part(path: &Path) -> Result<Part, Error> {
    let bytes = std::fs::read(path)
        .map_err(|e| Error::Usage(format!("cannot read {}: {e}", path.display())))?;
    let part: Part = serde_json::from_slice(&bytes).map_err(|e| {
        Error::Usage(format!(
            "{}: not a complete sweep part file: {e}",
            path.display()
        ))
    })?;
    // The figures first (the more precise message), then the checksum.
    part.results()
        .map_err(|e| Error::Usage(format!("{}: {e}", path.display())))?;
    if part.checksum() != part.checksum {
        return Err(Error::Usage(format!(
            "{}: the content does not match its checksum (the part was edited or damaged after it was written): run its shard again",
            path.display()
        )));
    }
    Ok(part)
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
    let (first_path, first) = (&parts[0].0, &parts[0].1);
    let shape = Shape::of(&first.sweep.sets)
        .map_err(|e| Error::Usage(format!("{}: {e}", first_path.display())))?;
    if shape.points != first.sweep.grid_size {
        return Err(Error::Usage(format!(
            "{}: grid size {} does not match its specs ({} points)",
            first_path.display(),
            first.sweep.grid_size,
            shape.points
        )));
    }
    budget::refuse_above(
        "merge",
        &[
            Quantity::count("grid points", shape.points as f64, budget::MAX_MERGE_POINTS),
            Quantity::bytes("memory", shape.memory(shape.points), budget::MAX_MEMORY),
        ],
        "merge a smaller sweep",
        args.allow_long,
    )?;
    let results = check(&parts)?;
    let grid = Grid::parse(&first.sweep.sets)?;
    let files = outputs(&out, &first.sweep, &grid, &results)?;
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

/// Checks that the parts are the N shards of one sweep, each once, and returns their rows.
fn check(parts: &[(PathBuf, Part)]) -> Result<Vec<PointResult>, Error> {
    let (first_path, first) = &parts[0];
    let n = first.shards;
    let mut seen: BTreeMap<usize, &Path> = BTreeMap::new();
    let mut results = vec![];
    for (path, p) in parts {
        let differ = |what: &str| {
            Error::Usage(format!(
                "{} and {} are parts of different sweeps (different {what})",
                first_path.display(),
                path.display()
            ))
        };
        if p.sweep.scenario_hash != first.sweep.scenario_hash {
            return Err(differ("scenario content"));
        }
        if p.sweep.sets != first.sweep.sets {
            return Err(differ("--set specs"));
        }
        if p.sweep != first.sweep {
            return Err(differ("options"));
        }
        if p.shards != n {
            return Err(differ("shard counts"));
        }
        if p.shard >= n {
            return Err(Error::Usage(format!(
                "{}: shard {} of {n} is out of range",
                path.display(),
                p.shard
            )));
        }
        if let Some(other) = seen.insert(p.shard, path) {
            return Err(Error::Usage(format!(
                "shard {} of {n} given twice ({} and {})",
                p.shard,
                other.display(),
                path.display()
            )));
        }
        if p.rows
            .iter()
            .any(|r| r.index % n != p.shard || r.index >= p.sweep.grid_size)
        {
            return Err(Error::Usage(format!(
                "{}: holds points that are not in shard {} of {n}",
                path.display(),
                p.shard
            )));
        }
        let expected = shard_points(p.sweep.grid_size, p.shard, n);
        if p.rows.len() != expected {
            return Err(Error::Usage(format!(
                "{}: holds {} of the {expected} point(s) of shard {} of {n}",
                path.display(),
                p.rows.len(),
                p.shard
            )));
        }
        let rows = p
            .results()
            .map_err(|e| Error::Usage(format!("{}: {e}", path.display())))?;
        results.extend(rows);
    }
    // At most `seen.len()` shards are present, so the first few missing ones are found
    // within that many more (never a walk over N).
    let absent = n - seen.len();
    if absent > 0 {
        let first: Vec<String> = (0..n)
            .filter(|i| !seen.contains_key(i))
            .take(budget::LISTED)
            .map(|i| part_name(i, n))
            .collect();
        let more = absent - first.len();
        let tail = if more > 0 {
            format!(" and {more} more")
        } else {
            String::new()
        };
        return Err(Error::Usage(format!(
            "missing shard(s) of {n}: {}{tail}",
            first.join(", ")
        )));
    }
    Ok(results)
}
