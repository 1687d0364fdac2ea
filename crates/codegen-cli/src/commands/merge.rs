//! `damper merge OUT` or `damper merge PART... -o OUT`: joins the partial results of a
//! sharded sweep (`damper sweep --shard I/N`) into exactly the `sweep.csv` and `sweep.json`
//! the unsharded run writes, byte for byte.
//!
//! The parts must be of one sweep (same scenario text hash, same `--set` specs, same
//! options, same N) and every shard 0..N must be there exactly once; anything else is one
//! line naming the problem, and nothing is written.

use std::path::{Path, PathBuf};

use crate::Error;
use crate::report::{ReportError, commit_files};

use super::sweep::{Grid, Part, PointResult, outputs, part_name};

/// Arguments of `damper merge`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Part files (`sweep.part-I-of-N.json`), or one directory holding them.
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// Output directory (default: the directory given as the only input).
    #[arg(short = 'o', long = "out")]
    pub out: Option<PathBuf>,
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

fn read_part(path: &Path) -> Result<Part, Error> {
    let bytes = std::fs::read(path)
        .map_err(|e| Error::Usage(format!("cannot read {}: {e}", path.display())))?;
    serde_json::from_slice(&bytes)
        .map_err(|e| Error::Usage(format!("{}: not a sweep part file: {e}", path.display())))
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
    let parts: Vec<(PathBuf, Part)> = files
        .into_iter()
        .map(|f| read_part(&f).map(|p| (f, p)))
        .collect::<Result<_, _>>()?;
    let results = check(&parts)?;
    let first = &parts[0].1;
    let grid = Grid::parse(&first.sweep.sets).map_err(Error::Usage)?;
    if grid.len() != first.sweep.grid_size {
        return Err(Error::Usage(format!(
            "{}: grid size {} does not match its specs ({} points)",
            parts[0].0.display(),
            first.sweep.grid_size,
            grid.len()
        )));
    }
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
    let mut seen: Vec<Option<&Path>> = vec![None; n];
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
        if let Some(other) = seen[p.shard] {
            return Err(Error::Usage(format!(
                "shard {} of {n} given twice ({} and {})",
                p.shard,
                other.display(),
                path.display()
            )));
        }
        seen[p.shard] = Some(path);
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
        let rows = p
            .results()
            .map_err(|e| Error::Usage(format!("{}: {e}", path.display())))?;
        results.extend(rows);
    }
    let missing: Vec<String> = (0..n)
        .filter(|&i| seen[i].is_none())
        .map(|i| part_name(i, n))
        .collect();
    if !missing.is_empty() {
        return Err(Error::Usage(format!(
            "missing shard(s) of {n}: {}",
            missing.join(", ")
        )));
    }
    Ok(results)
}
