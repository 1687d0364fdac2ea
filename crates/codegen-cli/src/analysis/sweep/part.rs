//! The record of a sweep: its settings ([`SweepSpec`]) and the part files of a sharded
//! sweep ([`Part`]: the points `index % N == I`, every value as the text that reads back to
//! the same `f64`, with a checksum), read back and checked for `damper merge` ([`read_part`],
//! [`check_parts`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::grid::{Grid, Shape, shard_points};
use super::point::PointResult;
use crate::Error;
use crate::analysis::AnalysisError;
use crate::analysis::figures;
use crate::budget::{self, Quantity};
use crate::report::csv::cell;
use crate::sweep_point::Figure;

/// What identifies a sweep: equal in every part of one sweep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepSpec {
    /// The scenario file, as given.
    pub scenario: String,
    /// FNV-1a hash of the scenario file's text.
    pub scenario_hash: String,
    /// The `--set` specs, in command-line order.
    pub sets: Vec<String>,
    /// The overrides applied to every point before the grid's, `PATH=VALUE` (a library
    /// caller's, e.g. Python's `Scenario.with_set`; the command line's single values are
    /// axes of one value, in `sets`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fixed: Vec<String>,
    /// `--t-end` (s), when given, as the text that reads back to the same number.
    pub t_end: Option<String>,
    /// `--time-domain`.
    pub time_domain: bool,
    /// Number of grid points.
    pub grid_size: usize,
    /// The `--constraint`s, as written.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub constraints: Vec<String>,
    /// The figure of the design map and of the best point (`--map`).
    #[serde(default = "default_map")]
    pub map: String,
    /// `--minimize`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub minimize: bool,
    /// `--method` of the random figures when not `auto`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
}

fn default_map() -> String {
    "linear.zeta1".into()
}

/// FNV-1a (64 bit) of `bytes`, in hex.
pub fn fnv1a_hex(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// The name of part I of N.
pub fn part_name(i: usize, n: usize) -> String {
    format!("sweep.part-{i}-of-{n}.json")
}

/// A figure as stored in a part file: its value as the text that reads back to the same
/// `f64`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PartFigure {
    /// Name.
    pub name: String,
    /// Unit.
    pub unit: String,
    /// Value (shortest round-trip text), `None` when absent.
    pub value: Option<String>,
}

/// Why a row of a part file cannot be read back (the part was edited or is not one).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum PartRowError {
    /// A failed point with figures.
    #[error("point {point} has both figures and an error")]
    FiguresAndError {
        /// Grid index.
        point: usize,
    },
    /// A figure named twice.
    #[error("point {point}: figure {name} given twice")]
    Twice {
        /// Grid index.
        point: usize,
        /// The figure (truncated).
        name: String,
    },
    /// A figure the catalogue does not know, or a unit it cannot have
    /// ([`crate::analysis::figures`]).
    #[error("point {point}: unknown unit `{unit}` of figure {name}")]
    Unit {
        /// Grid index.
        point: usize,
        /// The figure (truncated).
        name: String,
        /// The unit (truncated).
        unit: String,
    },
    /// A value that is not a finite number.
    #[error("point {point}: figure {name} is not a finite number")]
    NotFinite {
        /// Grid index.
        point: usize,
        /// The figure (truncated).
        name: String,
    },
}

/// A point as stored in a part file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PartRow {
    /// Grid index.
    pub index: usize,
    /// Figures.
    pub figures: Vec<PartFigure>,
    /// Why the point failed.
    pub error: Option<String>,
    /// Why its time-domain run failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_domain_error: Option<String>,
}

/// `sweep.part-I-of-N.json`: the rows of shard I of N, what identifies the sweep, and the
/// checksum of both (so that `damper merge` refuses a part edited or cut after it was
/// written).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Part {
    /// The sweep.
    pub sweep: SweepSpec,
    /// I.
    pub shard: usize,
    /// N.
    pub shards: usize,
    /// The rows computed, in index order.
    pub rows: Vec<PartRow>,
    /// FNV-1a of the compact JSON of `[sweep, shard, shards, rows]` ([`Part::checksum`]).
    pub checksum: String,
}

impl Part {
    /// The part `shard` of `shards` holding `results`, with its checksum.
    pub fn new(spec: &SweepSpec, shard: usize, shards: usize, results: &[PointResult]) -> Part {
        let mut part = Part {
            sweep: spec.clone(),
            shard,
            shards,
            rows: results
                .iter()
                .map(|r| PartRow {
                    index: r.index,
                    figures: r
                        .figures
                        .iter()
                        .map(|f| PartFigure {
                            name: f.name.clone(),
                            unit: f.unit.to_string(),
                            value: f.value.map(|v| cell(Some(v))),
                        })
                        .collect(),
                    error: r.error.clone(),
                    time_domain_error: r.time_domain_error.clone(),
                })
                .collect(),
            checksum: String::new(),
        };
        part.checksum = part.checksum();
        part
    }

    /// The checksum of the part's content: FNV-1a of the compact JSON of `[sweep, shard,
    /// shards, rows]`.
    pub fn checksum(&self) -> String {
        let content = (&self.sweep, self.shard, self.shards, &self.rows);
        fnv1a_hex(&serde_json::to_vec(&content).unwrap_or_default())
    }

    /// The rows back as results (values read back exactly), every figure checked: a
    /// known unit, a finite value or none, each name once in a point, and a failed point
    /// without figures.
    pub fn results(&self) -> Result<Vec<PointResult>, PartRowError> {
        self.rows
            .iter()
            .map(|r| {
                let point = r.index;
                if r.error.is_some() && !r.figures.is_empty() {
                    return Err(PartRowError::FiguresAndError { point });
                }
                let mut names = std::collections::BTreeSet::new();
                let figures = r
                    .figures
                    .iter()
                    .map(|f| {
                        let name = || diagnostic::truncate(&f.name, 60);
                        if !names.insert(f.name.as_str()) {
                            return Err(PartRowError::Twice {
                                point,
                                name: name(),
                            });
                        }
                        let unit = figures::unit_of(&f.name, &f.unit).ok_or_else(|| {
                            PartRowError::Unit {
                                point,
                                name: name(),
                                unit: diagnostic::truncate(&f.unit, 20),
                            }
                        })?;
                        let value = match &f.value {
                            Some(v) => {
                                Some(v.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(
                                    || PartRowError::NotFinite {
                                        point,
                                        name: name(),
                                    },
                                )?)
                            }
                            None => None,
                        };
                        Ok(Figure {
                            name: f.name.clone(),
                            unit,
                            value,
                        })
                    })
                    .collect::<Result<_, PartRowError>>()?;
                Ok(PointResult {
                    index: r.index,
                    figures,
                    error: r.error.clone(),
                    time_domain_error: r.time_domain_error.clone(),
                })
            })
            .collect()
    }
}

/// A merge error about `path` (a part file or the directory).
fn merge_error(path: &Path, message: String) -> Error {
    AnalysisError::merge(path, message).into()
}

/// The part files in a directory (`sweep.part-*-of-*.json`), sorted by name.
pub fn parts_in(dir: &Path) -> Result<Vec<PathBuf>, Error> {
    let entries = std::fs::read_dir(dir).map_err(|e| {
        merge_error(
            dir,
            format!("cannot read the directory {}: {e}", dir.display()),
        )
    })?;
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
        return Err(merge_error(
            dir,
            format!("no sweep.part-I-of-N.json in {}", dir.display()),
        ));
    }
    Ok(parts)
}

/// The size of a part file, checked to be a regular file before it is opened (a fifo or a
/// device would block or never end).
pub fn part_size(path: &Path) -> Result<u64, Error> {
    let meta = std::fs::metadata(path)
        .map_err(|e| merge_error(path, format!("cannot read {}: {e}", path.display())))?;
    if !meta.is_file() {
        return Err(merge_error(
            path,
            format!(
                "{}: not a regular file (merge reads sweep part files only)",
                path.display()
            ),
        ));
    }
    Ok(meta.len())
}

/// A part file read and checked: complete, its figures known and finite, its checksum
/// matching its content ([`parse_part`]).
pub fn read_part(path: &Path) -> Result<Part, Error> {
    let bytes = std::fs::read(path)
        .map_err(|e| merge_error(path, format!("cannot read {}: {e}", path.display())))?;
    parse_part(&bytes, &path.display().to_string())
}

/// The text of a part file (`name` in messages) read and checked: complete, its figures
/// known and finite, its checksum matching its content.
pub fn parse_part(bytes: &[u8], name: &str) -> Result<Part, Error> {
    let at = Path::new(name);
    let part: Part = serde_json::from_slice(bytes)
        .map_err(|e| merge_error(at, format!("{name}: not a complete sweep part file: {e}")))?;
    // The figures first (the more precise message), then the checksum.
    part.results()
        .map_err(|e| merge_error(at, format!("{name}: {e}")))?;
    if part.checksum() != part.checksum {
        return Err(merge_error(
            at,
            format!(
                "{name}: the content does not match its checksum (the part was edited or damaged after it was written): run its shard again"
            ),
        ));
    }
    Ok(part)
}

/// Checks that the parts are the N shards of one sweep, each once, and returns their rows.
pub fn check_parts(parts: &[(PathBuf, Part)]) -> Result<Vec<PointResult>, Error> {
    let (first_path, first) = &parts[0];
    let n = first.shards;
    let mut seen: BTreeMap<usize, &Path> = BTreeMap::new();
    let mut results = vec![];
    for (path, p) in parts {
        let differ = |what: &str| {
            merge_error(
                path,
                format!(
                    "{} and {} are parts of different sweeps (different {what})",
                    first_path.display(),
                    path.display()
                ),
            )
        };
        if p.sweep.scenario_hash != first.sweep.scenario_hash {
            return Err(differ("scenario content"));
        }
        if p.sweep.sets != first.sweep.sets {
            return Err(differ("--set specs"));
        }
        if p.sweep.fixed != first.sweep.fixed {
            return Err(differ("fixed overrides"));
        }
        if p.sweep != first.sweep {
            return Err(differ("options"));
        }
        if p.shards != n {
            return Err(differ("shard counts"));
        }
        if p.shard >= n {
            return Err(merge_error(
                path,
                format!(
                    "{}: shard {} of {n} is out of range",
                    path.display(),
                    p.shard
                ),
            ));
        }
        if let Some(other) = seen.insert(p.shard, path) {
            return Err(merge_error(
                path,
                format!(
                    "shard {} of {n} given twice ({} and {})",
                    p.shard,
                    other.display(),
                    path.display()
                ),
            ));
        }
        if p.rows
            .iter()
            .any(|r| r.index % n != p.shard || r.index >= p.sweep.grid_size)
        {
            return Err(merge_error(
                path,
                format!(
                    "{}: holds points that are not in shard {} of {n}",
                    path.display(),
                    p.shard
                ),
            ));
        }
        let expected = shard_points(p.sweep.grid_size, p.shard, n);
        if p.rows.len() != expected {
            return Err(merge_error(
                path,
                format!(
                    "{}: holds {} of the {expected} point(s) of shard {} of {n}",
                    path.display(),
                    p.rows.len(),
                    p.shard
                ),
            ));
        }
        let rows = p
            .results()
            .map_err(|e| merge_error(path, format!("{}: {e}", path.display())))?;
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
        return Err(merge_error(
            first_path.parent().unwrap_or(first_path),
            format!("missing shard(s) of {n}: {}{tail}", first.join(", ")),
        ));
    }
    Ok(results)
}

/// The parts of one sweep (each read and checked, [`read_part`] / [`parse_part`]) joined:
/// the grid's size counted from the specs (overflow-checked) and equal to the recorded one,
/// the grid and its memory within the merge's limits unless `allow_long`, every shard there
/// once ([`check_parts`]). Returns the sweep's record, its grid and every point's result —
/// what [`crate::report::sweep::outputs`] writes as the files of the unsharded sweep.
pub fn merge(
    parts: &[(PathBuf, Part)],
    allow_long: bool,
) -> Result<(SweepSpec, Grid, Vec<PointResult>), Error> {
    let Some((first_path, first)) = parts.first() else {
        return Err(merge_error(
            Path::new("."),
            "merge: no sweep part given".into(),
        ));
    };
    let shape = Shape::of(&first.sweep.sets)
        .map_err(|e| merge_error(first_path, format!("{}: {e}", first_path.display())))?;
    if shape.points != first.sweep.grid_size {
        return Err(merge_error(
            first_path,
            format!(
                "{}: grid size {} does not match its specs ({} points)",
                first_path.display(),
                first.sweep.grid_size,
                shape.points
            ),
        ));
    }
    budget::refuse_above(
        "merge",
        &[
            Quantity::count("grid points", shape.points as f64, budget::MAX_MERGE_POINTS),
            Quantity::bytes("memory", shape.memory(shape.points), budget::MAX_MEMORY),
        ],
        "merge a smaller sweep",
        allow_long,
    )?;
    let results = check_parts(parts)?;
    let grid = Grid::parse(&first.sweep.sets)?;
    Ok((first.sweep.clone(), grid, results))
}
