//! `damper sweep SCENARIO --set PATH=VALUES ... -o OUT [--shard I/N] [--threads T]
//! [--time-domain] [--t-end T]`: a cartesian grid over scenario fields.
//!
//! VALUES is `a:b:n` (n points from a to b inclusive, `a + (b - a) k / (n - 1)`, the
//! endpoints exact; integers when a and b are integers and the step is a whole number),
//! `a:b:n:log` (n points in geometric progression, `a (b / a)^(k / (n - 1))`, a, b > 0) or
//! a comma list of TOML values (`0.5,1,2,5`; one value is a fixed override). The grid is the
//! product of the options in command-line order, the last one varying fastest. Each point
//! is [`crate::sweep_point::evaluate`]d — linearised about its static equilibrium, and with
//! `--time-domain` also run in the time domain — (in parallel, rayon; results collected by index, so
//! identical whatever the thread count); a point that fails is recorded with its message
//! and the sweep goes on.
//!
//! OUT receives `sweep.csv` (one row per point in grid order: `index`, each swept PATH, the
//! figures with their units, `error`) and `sweep.json` (the same with the scenario, the
//! specs and the grid size), committed together by the one writer. With `--shard I/N` only
//! the points with `index % N == I` are evaluated and `OUT/sweep.part-I-of-N.json` is
//! written; `damper merge` ([`super::merge`]) joins the N parts into exactly the files of
//! the unsharded run, byte for byte.
//!
//! **Limits** (`crate::budget`): before any point runs, the grid's size is counted without
//! building it (overflow-checked: a grid of more points than a machine word holds is
//! refused), and the points of the shard, their memory and with `--time-domain` the steps of
//! one point and of all of them are estimated; above the limits the sweep is refused unless
//! `--allow-long`. `--threads` is capped to the machine's available parallelism.
//!
//! Numbers are written in one form everywhere: the shortest representation that reads back
//! to the same `f64` (`crate::report::csv` cells; `serde_json` in the JSON).

use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::ProgressBar;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use toml_edit::Value;

use crate::Error;
use crate::analysis::figures::{self, Constraint, ConstraintError, Entities, UnknownFigure};
use crate::budget::{self, Quantity};
use crate::random::RandomMethod;
use crate::report::csv::cell;
use crate::report::{OutputFile, OutputLock, ReportError, commit_files};
use crate::scenario::overrides::PathError;
use crate::scenario::overrides::{json_value, parse_value, value_text};
use crate::scenario::{self, Override};
use crate::sweep_point::{self, Figure, PointOptions};

/// Arguments of `damper sweep`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scenario file (`kind = "damper"` or `kind = "hybrid"`).
    pub scenario: PathBuf,
    /// A swept field: `PATH=a:b:n` or `PATH=v1,v2,...` (repeatable; the grid is their
    /// product, the last option varying fastest).
    #[arg(long = "set", value_name = "PATH=VALUES", required = true)]
    pub set: Vec<String>,
    /// Output directory.
    #[arg(short = 'o', long = "out")]
    pub out: PathBuf,
    /// Evaluate only the points with index % N == I and write `sweep.part-I-of-N.json`.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    /// Worker threads (default: all cores; more than the machine's available parallelism
    /// are capped to it).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Also evaluate each point by a time-domain run of the scenario (its summary figures);
    /// the linearised figures (equilibrium, first modes) are always computed.
    #[arg(long)]
    pub time_domain: bool,
    /// Override the integrator's end time (s) of every point (keeps sweeps cheap).
    #[arg(long, value_name = "T")]
    pub t_end: Option<f64>,
    /// No progress bar even on a terminal.
    #[arg(long)]
    pub quiet: bool,
    /// A design constraint on a figure, `FIGURE>=VALUE` or `FIGURE<=VALUE`, or between two
    /// figures, `FIGURE>=K*FIGURE` or `FIGURE<=K*FIGURE` (repeatable; e.g.
    /// `linear.zeta1>=0.08`, `linear.reach>=4*random.rms:1.0`): the best feasible point is reported and,
    /// on a two-axis sweep, the constraint's contour drawn on the design map, the points
    /// that break it hatched.
    #[arg(long = "constraint", value_name = "FIGURE>=VALUE")]
    pub constraints: Vec<String>,
    /// The figure of the design map of a two-axis sweep (`sweep_map_<FIGURE>.svg`) and of
    /// the best feasible point.
    #[arg(long, value_name = "FIGURE", default_value = "linear.zeta1")]
    pub map: String,
    /// The best feasible point has the smallest value of the map's figure (default: the
    /// largest).
    #[arg(long)]
    pub minimize: bool,
    /// How the random figures are computed: `auto` (PSD tables by quadrature, white noise
    /// by the Lyapunov equation, dense up to 600 first-order states, modal above), `dense`,
    /// `modal` or `quadrature`, as `damper random --method`.
    #[arg(long, default_value = "auto")]
    pub method: String,
    /// Run even when the estimated grid points (1e5 a shard), memory (1 GiB), time steps
    /// (2e7 a point), core time (an hour a shard) or beam elements (1e5) are above the
    /// limits (`codegen_cli::budget`).
    #[arg(long)]
    pub allow_long: bool,
}

/// Why VALUES (`a:b:n` or a comma list) cannot be read.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ValuesError {
    /// An item of the comma list is empty.
    #[error("empty value in the list `{text}`")]
    EmptyItem {
        /// VALUES.
        text: String,
    },
    /// `n` of `a:b:n` is not a whole number.
    #[error(
        "`{text}`: n in a:b:n must be a whole number of points (at most {})",
        usize::MAX
    )]
    Count {
        /// VALUES.
        text: String,
    },
    /// `n < 2`.
    #[error("`{text}`: a:b:n needs n >= 2 points")]
    TooFew {
        /// VALUES.
        text: String,
    },
    /// `a` or `b` is not finite.
    #[error("`{text}`: a and b must be finite")]
    NotFinite {
        /// VALUES.
        text: String,
    },
    /// `a:b:n:log` with `a` or `b` not positive.
    #[error("`{text}`: a:b:n:log needs a > 0 and b > 0")]
    LogNotPositive {
        /// VALUES.
        text: String,
    },
    /// The values do not fit in memory.
    #[error("`{text}`: {n} values do not fit in memory")]
    Memory {
        /// VALUES.
        text: String,
        /// The number of values.
        n: usize,
    },
}

/// Why the `--set PATH=VALUES` or `--shard I/N` options of a sweep cannot be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SpecError {
    /// No `=`.
    #[error("--set {spec}: expected PATH=VALUES")]
    NoValues {
        /// The option's text.
        spec: String,
    },
    /// A bad PATH.
    #[error("--set {spec}: {source}")]
    Path {
        /// The option's text.
        spec: String,
        /// What is wrong with it.
        source: PathError,
    },
    /// Bad VALUES.
    #[error("--set {spec}: {source}")]
    Values {
        /// The option's text.
        spec: String,
        /// What is wrong with them.
        source: ValuesError,
    },
    /// More points than a machine word counts.
    #[error(
        "--set: the grid has {factors} = {product:.2e} points, more than a machine word counts ({})",
        usize::MAX
    )]
    Overflow {
        /// The factors (or their number).
        factors: String,
        /// Their product.
        product: f64,
    },
    /// A `--vary` that is not `PATH=LO:HI` with finite `LO < HI`.
    #[error("--vary {text}: expected PATH=LO:HI with finite LO < HI")]
    Vary {
        /// The option's value.
        text: String,
    },
    /// A `--constraint` that cannot be read, or a figure the catalogue does not know.
    #[error(transparent)]
    Constraint(#[from] ConstraintError),
    /// A `--map` figure the catalogue does not know.
    #[error("--map: {0}")]
    Map(UnknownFigure),
    /// `--shard` is not `I/N` with `0 <= I < N`.
    #[error("--shard {text}: expected I/N with 0 <= I < N")]
    Shard {
        /// The option's value.
        text: String,
    },
}

/// One swept field: its PATH and its values.
#[derive(Clone, Debug)]
pub struct Axis {
    /// PATH.
    pub path: String,
    /// The values, in order.
    pub values: Vec<Value>,
}

impl Axis {
    /// `PATH=VALUES`.
    pub fn parse(spec: &str) -> Result<Axis, SpecError> {
        let (path, values) = split_spec(spec)?;
        let values = parse_values(values).map_err(|source| SpecError::Values {
            spec: spec.to_string(),
            source,
        })?;
        Ok(Axis {
            path: path.to_string(),
            values,
        })
    }

    /// The number of values of `PATH=VALUES`, without building them.
    pub fn count(spec: &str) -> Result<usize, SpecError> {
        let (_, values) = split_spec(spec)?;
        count_values(values).map_err(|source| SpecError::Values {
            spec: spec.to_string(),
            source,
        })
    }
}

/// `PATH=VALUES` split, PATH checked.
fn split_spec(spec: &str) -> Result<(&str, &str), SpecError> {
    let (path, values) = spec.split_once('=').ok_or_else(|| SpecError::NoValues {
        spec: spec.to_string(),
    })?;
    let path = path.trim();
    scenario::overrides::parse_path(path).map_err(|source| SpecError::Path {
        spec: spec.to_string(),
        source,
    })?;
    Ok((path, values.trim()))
}

/// VALUES: `a:b:n` or a comma list of TOML values.
pub fn parse_values(text: &str) -> Result<Vec<Value>, ValuesError> {
    if let Some(range) = parse_range(text)? {
        return range.values(text);
    }
    let items = list_items(text)?;
    Ok(items.iter().map(|i| parse_value(i.trim())).collect())
}

/// The number of values of VALUES (`a:b:n`: n), without building them.
pub fn count_values(text: &str) -> Result<usize, ValuesError> {
    match parse_range(text)? {
        Some(range) => Ok(range.n),
        None => Ok(list_items(text)?.len()),
    }
}

/// The items of a comma list.
fn list_items(text: &str) -> Result<Vec<&str>, ValuesError> {
    let items = split_top_level(text);
    if items.iter().any(|i| i.trim().is_empty()) {
        return Err(ValuesError::EmptyItem {
            text: text.to_string(),
        });
    }
    Ok(items)
}

/// `a:b:n`, checked, not yet expanded.
struct Range {
    a: Value,
    b: Value,
    fa: f64,
    fb: f64,
    n: usize,
    /// `a:b:n:log`: a geometric progression.
    log: bool,
}

impl Range {
    /// The `n` values (memory reserved first: a range too large for it is an error, not an
    /// abort).
    fn values(&self, text: &str) -> Result<Vec<Value>, ValuesError> {
        let n = self.n;
        let mut out: Vec<Value> = Vec::new();
        out.try_reserve_exact(n).map_err(|_| ValuesError::Memory {
            text: text.to_string(),
            n,
        })?;
        if self.log {
            let (la, lb) = (self.fa.ln(), self.fb.ln());
            out.extend((0..n).map(|k| {
                let x = match k {
                    0 => self.fa,
                    k if k + 1 == n => self.fb,
                    k => (la + (lb - la) * k as f64 / (n - 1) as f64).exp(),
                };
                Value::from(x)
            }));
            return Ok(out);
        }
        if let (Value::Integer(ia), Value::Integer(ib), Ok(steps)) =
            (&self.a, &self.b, i64::try_from(n - 1))
        {
            let (ia, ib) = (*ia.value(), *ib.value());
            if let Some(d) = ib.checked_sub(ia).filter(|d| d % steps == 0) {
                let step = d / steps;
                out.extend((0..=steps).map(|k| Value::from(ia + step * k)));
                return Ok(out);
            }
        }
        let (fa, fb) = (self.fa, self.fb);
        out.extend((0..n).map(|k| {
            let x = if k + 1 == n {
                fb
            } else {
                fa + (fb - fa) * k as f64 / (n - 1) as f64
            };
            Value::from(x)
        }));
        Ok(out)
    }
}

/// A TOML value as a number (an integer or a float), `None` otherwise.
fn number(v: &Value) -> Option<f64> {
    match v {
        Value::Integer(i) => Some(*i.value() as f64),
        Value::Float(f) => Some(*f.value()),
        _ => None,
    }
}

/// `a:b:n` when the text is three numbers separated by colons.
fn parse_range(text: &str) -> Result<Option<Range>, ValuesError> {
    let parts: Vec<&str> = text.split(':').map(str::trim).collect();
    let (a, b, n, log) = match parts[..] {
        [a, b, n] => (a, b, n, false),
        [a, b, n, "log"] => (a, b, n, true),
        [a, b, n, "lin"] => (a, b, n, false),
        _ => return Ok(None),
    };
    let (a, b) = (parse_value(a), parse_value(b));
    let (Some(fa), Some(fb)) = (number(&a), number(&b)) else {
        return Ok(None);
    };
    let text = || text.to_string();
    let n: usize = n.parse().map_err(|_| ValuesError::Count { text: text() })?;
    if n < 2 {
        return Err(ValuesError::TooFew { text: text() });
    }
    if !(fa.is_finite() && fb.is_finite()) {
        return Err(ValuesError::NotFinite { text: text() });
    }
    if log && !(fa > 0.0 && fb > 0.0) {
        return Err(ValuesError::LogNotPositive { text: text() });
    }
    Ok(Some(Range {
        a,
        b,
        fa,
        fb,
        n,
        log,
    }))
}

/// Splits at the commas outside brackets, braces and quotes.
fn split_top_level(text: &str) -> Vec<&str> {
    let (mut depth, mut quote, mut start) = (0i32, None::<char>, 0);
    let mut items = vec![];
    let mut escaped = false;
    for (i, c) in text.char_indices() {
        match quote {
            Some(q) => {
                if escaped {
                    escaped = false;
                } else if c == '\\' && q == '"' {
                    escaped = true;
                } else if c == q {
                    quote = None;
                }
            }
            None => match c {
                '"' | '\'' => quote = Some(c),
                '[' | '{' => depth += 1,
                ']' | '}' => depth -= 1,
                ',' if depth == 0 => {
                    items.push(&text[start..i]);
                    start = i + 1;
                }
                _ => {}
            },
        }
    }
    items.push(&text[start..]);
    items
}

/// The cartesian grid of the swept fields (the last axis fastest).
#[derive(Clone, Debug)]
pub struct Grid {
    /// The axes, in command-line order.
    pub axes: Vec<Axis>,
}

/// The size of a grid, counted without building it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Shape {
    /// The number of values of each axis.
    pub counts: Vec<usize>,
    /// Their product: the number of points.
    pub points: usize,
}

impl Shape {
    /// The shape of the `--set` specs; a grid of more points than a machine word holds is
    /// refused (with or without `--allow-long`: it cannot be indexed).
    pub fn of(specs: &[String]) -> Result<Shape, SpecError> {
        let counts = specs
            .iter()
            .map(|s| Axis::count(s))
            .collect::<Result<Vec<_>, _>>()?;
        let points = counts
            .iter()
            .try_fold(1usize, |p, &c| p.checked_mul(c))
            .ok_or_else(|| {
                let product: f64 = counts.iter().map(|&c| c as f64).product();
                // The factors, or only their number when there are many (a short line).
                let factors = if counts.len() <= budget::LISTED {
                    let c: Vec<String> = counts.iter().map(usize::to_string).collect();
                    c.join(" x ")
                } else {
                    format!("the product of {} axes", counts.len())
                };
                SpecError::Overflow { factors, product }
            })?;
        Ok(Shape { counts, points })
    }

    /// The points of shard `i` of `n` ([`shard_points`]).
    pub fn shard_points(&self, i: usize, n: usize) -> usize {
        shard_points(self.points, i, n)
    }

    /// The estimated memory of a sweep of `points` of this grid (bytes): every value of
    /// every axis and the points' results ([`budget::SWEEP_BYTES_PER_POINT`]).
    pub fn memory(&self, points: usize) -> f64 {
        let values: f64 = self.counts.iter().map(|&c| c as f64).sum();
        values * std::mem::size_of::<Value>() as f64 + points as f64 * budget::SWEEP_BYTES_PER_POINT
    }
}

impl Grid {
    /// The grid of `--set` specs (its size checked first: [`Shape::of`]).
    pub fn parse(specs: &[String]) -> Result<Grid, SpecError> {
        Shape::of(specs)?;
        let axes = specs
            .iter()
            .map(|s| Axis::parse(s))
            .collect::<Result<_, _>>()?;
        Ok(Grid { axes })
    }

    /// Number of points (never overflows: checked by [`Grid::parse`]).
    pub fn len(&self) -> usize {
        self.axes.iter().map(|a| a.values.len()).product()
    }

    /// Whether the grid has no point (never: every axis has a value).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The values of point `index` (one per axis).
    pub fn point(&self, index: usize) -> Vec<&Value> {
        let mut rest = index;
        let mut values: Vec<&Value> = self
            .axes
            .iter()
            .rev()
            .map(|a| {
                let v = &a.values[rest % a.values.len()];
                rest /= a.values.len();
                v
            })
            .collect();
        values.reverse();
        values
    }

    /// The overrides of point `index`.
    pub fn overrides(&self, index: usize) -> Vec<Override> {
        self.axes
            .iter()
            .zip(self.point(index))
            .map(|(a, v)| Override::new(&a.path, v.clone(), &value_text(v)).expect("PATH checked"))
            .collect()
    }
}

/// The number of the `points` grid indices in shard `i` of `n` (`index % n == i`, `n > 0`).
pub fn shard_points(points: usize, i: usize, n: usize) -> usize {
    if points > i {
        (points - i - 1) / n + 1
    } else {
        0
    }
}

/// `--shard I/N`.
pub fn parse_shard(text: &str) -> Result<(usize, usize), SpecError> {
    let bad = || SpecError::Shard {
        text: text.to_string(),
    };
    let (i, n) = text.split_once('/').ok_or_else(bad)?;
    let (i, n): (usize, usize) = (
        i.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if n == 0 || i >= n {
        return Err(bad());
    }
    Ok((i, n))
}

/// What identifies a sweep: equal in every part of one sweep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepSpec {
    /// The scenario file, as given.
    pub scenario: String,
    /// FNV-1a hash of the scenario file's text.
    pub scenario_hash: String,
    /// The `--set` specs, in command-line order.
    pub sets: Vec<String>,
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

/// The random figures' `--method` (`auto`, `dense`, `modal`, `quadrature`).
pub fn parse_method(name: &str) -> Result<RandomMethod, Error> {
    RandomMethod::parse(name).ok_or_else(|| {
        Error::Usage(format!(
            "--method {name:?}: expected auto, dense, modal or quadrature"
        ))
    })
}

/// How far the point `r` is inside the constraint `c` (`>= 0`: satisfied; in the figure's
/// unit); `None` when the point does not give the figure.
pub fn margin(c: &Constraint, r: &PointResult) -> Option<f64> {
    c.margin(|name| {
        r.figures
            .iter()
            .find(|f| f.name == name)
            .and_then(|f| f.value)
    })
}

/// The result of one point.
#[derive(Clone, Debug, PartialEq)]
pub struct PointResult {
    /// Grid index.
    pub index: usize,
    /// The figures (empty when the point failed; the linearised ones only when its
    /// time-domain run failed).
    pub figures: Vec<Figure>,
    /// Why the point failed.
    pub error: Option<String>,
    /// Why its time-domain run failed (the linearised figures are kept).
    pub time_domain_error: Option<String>,
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

/// Runs `damper sweep`.
pub fn run(args: Args) -> Result<(), Error> {
    let started = Instant::now();
    let shape = Shape::of(&args.set)?;
    let shard = args.shard.as_deref().map(parse_shard).transpose()?;
    if let Some(t) = args.t_end {
        if !(t.is_finite() && t > 0.0) {
            return Err(Error::Usage(format!(
                "--t-end {t}: must be a positive time"
            )));
        }
    }
    if args.threads == Some(0) {
        return Err(Error::Usage("--threads must be at least 1".into()));
    }
    let method = parse_method(&args.method)?;
    let file = args.scenario.display().to_string();
    let (shard_i, shards) = shard.unwrap_or((0, 1));
    let points = shape.shard_points(shard_i, shards);
    budget::refuse_above(
        &format!("sweep of {file}"),
        &[
            Quantity::count("grid points", points as f64, budget::MAX_SWEEP_POINTS),
            Quantity::bytes("memory", shape.memory(points), budget::MAX_MEMORY),
        ],
        "use fewer values per --set or split the sweep with --shard I/N",
        args.allow_long,
    )?;
    let threads = threads(args.threads);
    if std::fs::metadata(&args.out).is_ok_and(|m| !m.is_dir()) {
        return Err(Error::Usage(format!(
            "output directory {} is not a directory",
            args.out.display()
        )));
    }
    // One unsharded sweep at a time into a directory (the shards of one sweep write
    // distinct part files into a shared directory at once, by design: not locked).
    let _lock = match shard {
        None => Some(OutputLock::acquire(&args.out).map_err(ReportError::from)?),
        Some(_) => None,
    };
    let grid = Grid::parse(&args.set)?;
    let text = scenario::read(&args.scenario)?;
    // Before any work: every PATH a field the scenario takes, every figure one it offers.
    check_paths(
        &args.scenario,
        &text,
        &[],
        grid.axes
            .iter()
            .map(|a| (a.path.as_str(), a.values[0].clone())),
    )?;
    let entities = scenario::parse_with(&text, &args.scenario, &[])
        .ok()
        .map(|l| Entities::of(&l.scenario));
    let map = figures::resolve(&args.map, entities.as_ref())
        .map_err(SpecError::Map)?
        .name;
    let constraints: Vec<Constraint> = args
        .constraints
        .iter()
        .map(|c| c.parse::<Constraint>()?.resolve(entities.as_ref()))
        .collect::<Result<_, _>>()
        .map_err(SpecError::from)?;
    let mut requested = vec![map.clone()];
    requested.extend(
        constraints
            .iter()
            .flat_map(|c| c.figures().map(str::to_string)),
    );
    let t_end = args.t_end.map(|t| {
        Override::new("integrator.t_end", Value::from(t), &cell(Some(t))).expect("a valid PATH")
    });
    // The first point stands for the others (its structure, its time steps); a point
    // whose own settings are above the limits records that as its error (`sweep_point`).
    let first = (points > 0)
        .then(|| {
            let mut overrides = grid.overrides(0);
            overrides.extend(t_end.clone());
            scenario::parse_with(&text, &args.scenario, &overrides).ok()
        })
        .flatten();
    budget::sweep(
        &format!("sweep of {file}"),
        points as f64,
        shape.memory(points),
        first
            .as_ref()
            .filter(|_| args.time_domain)
            .and_then(|l| budget::steps_per_run(&l.scenario)),
        first.as_ref().map(|l| &l.scenario),
        args.allow_long,
    )?;
    let spec = SweepSpec {
        scenario: args.scenario.display().to_string(),
        scenario_hash: fnv1a_hex(text.as_bytes()),
        sets: args.set.clone(),
        t_end: args.t_end.map(|t| cell(Some(t))),
        time_domain: args.time_domain,
        grid_size: grid.len(),
        constraints: constraints.iter().map(|c| c.text.clone()).collect(),
        map,
        minimize: args.minimize,
        method: (method != RandomMethod::Auto).then(|| args.method.clone()),
    };
    let mut indices: Vec<usize> = Vec::new();
    indices
        .try_reserve_exact(points)
        .map_err(|_| Error::Usage(format!("sweep: {points} points do not fit in memory")))?;
    indices.extend((shard_i..grid.len()).step_by(shards));
    let options = PointOptions {
        time_domain: args.time_domain,
        allow_long: args.allow_long,
        method,
        only_requested: false,
    };
    let bar = progress_bar(!args.quiet, indices.len());
    let results = evaluate_points_requesting(
        &args.scenario,
        &text,
        &[],
        &grid,
        &indices,
        t_end.as_ref(),
        &options,
        &requested,
        threads,
        &|| bar.inc(1),
    )?;
    bar.finish_and_clear();
    let failed = results.iter().filter(|r| r.error.is_some()).count();
    let td_failed = results
        .iter()
        .filter(|r| r.time_domain_error.is_some())
        .count();
    let td_note = if args.time_domain {
        format!(" ({td_failed} time-domain run(s) failed, their linear figures kept)")
    } else {
        String::new()
    };
    let files = match shard {
        Some((i, n)) => vec![OutputFile {
            path: args.out.join(part_name(i, n)),
            bytes: pretty(&Part::new(&spec, i, n, &results))?,
        }],
        None => outputs(&args.out, &spec, &grid, &results)?,
    };
    commit_files(&files).map_err(ReportError::from)?;
    if shard.is_none() {
        let rows: Vec<&PointResult> = results.iter().collect();
        let design = Design::of(&spec, &rows)?;
        eprintln!("{}", design.describe(&spec, &grid));
    }
    let written: Vec<String> = files.iter().map(|f| f.path.display().to_string()).collect();
    eprintln!(
        "sweep: {} of {} point(s) evaluated in {:.1} s, {failed} failed{td_note}; wrote {}",
        results.len(),
        grid.len(),
        started.elapsed().as_secs_f64(),
        written.join(", ")
    );
    match results.first().and_then(|r| r.error.as_deref()) {
        Some(first) if failed == results.len() => Err(Error::Usage(format!(
            "{file}: every one of the {failed} point(s) failed (the files record each error); the first: {first}"
        ))),
        _ => Ok(()),
    }
}

/// Checks the `--set` / `--vary` PATHs before any work: each override (`path = value`, the
/// first value of an axis) applied alone after the `fixed` ones; a PATH the scenario cannot
/// take (an unknown field, no such table or index) is an error naming it and the valid
/// fields. A value the loader refuses is not an error here (it is the point's).
pub fn check_paths<'a, V: Into<Value>>(
    path: &Path,
    text: &str,
    fixed: &[Override],
    paths: impl Iterator<Item = (&'a str, V)>,
) -> Result<(), Error> {
    for (p, value) in paths {
        let value: Value = value.into();
        let o = Override::new(p, value.clone(), &value_text(&value)).map_err(|source| {
            SpecError::Path {
                spec: p.to_string(),
                source,
            }
        })?;
        let mut overrides = fixed.to_vec();
        overrides.push(o.clone());
        let Err(d) = scenario::parse_with(text, path, &overrides) else {
            continue;
        };
        let option = o.option();
        let named = |x: &diagnostic::Diagnostic| {
            x.entity.as_deref().is_some_and(|e| e.starts_with(&option))
        };
        let bad: Vec<diagnostic::Diagnostic> =
            d.0.into_iter()
                .filter(|x| {
                    named(x)
                        && (matches!(
                            x.kind,
                            diagnostic::Kind::UnknownField | diagnostic::Kind::UnknownName
                        ) || x.message.contains("unknown field"))
                })
                .collect();
        if !bad.is_empty() {
            let bad: Vec<diagnostic::Diagnostic> = bad.into_iter().map(nearest_field).collect();
            return Err(Error::Input(bad.into()));
        }
    }
    Ok(())
}

/// An unknown field's problem ("unknown field `x`, expected one of `a`, `b`") with the
/// nearest valid field by edit distance appended ("did you mean `a`?").
fn nearest_field(mut d: diagnostic::Diagnostic) -> diagnostic::Diagnostic {
    let Some((head, list)) = d.message.split_once("expected one of ") else {
        return d;
    };
    let Some(field) = head.split('`').nth(1) else {
        return d;
    };
    let best = list
        .split('`')
        .skip(1)
        .step_by(2)
        .min_by_key(|c| figures::levenshtein(field, c));
    if let Some(best) = best.filter(|b| figures::levenshtein(field, b) <= field.len() / 2 + 1) {
        d.message = format!("{} (did you mean `{best}`?)", d.message);
    }
    d
}

/// [`evaluate_points_requesting`] without figures on request.
pub fn evaluate_points(
    path: &Path,
    text: &str,
    fixed: &[Override],
    grid: &Grid,
    indices: &[usize],
    t_end: Option<&Override>,
    options: &PointOptions,
    threads: usize,
    done: &(dyn Fn() + Sync),
) -> Result<Vec<PointResult>, Error> {
    evaluate_points_requesting(
        path,
        text,
        fixed,
        grid,
        indices,
        t_end,
        options,
        &[],
        threads,
        done,
    )
}

/// Evaluates the points `indices` of `grid` on `threads` worker threads (0: every core), each
/// point the scenario `text` (the file `path`) with the `fixed` overrides, the point's and
/// `t_end`'s applied in that order ([`sweep_point::evaluate`]); the results in the order of
/// `indices` (never in completion order), a failed or panicking point recorded as its
/// one-line error. `done` is called after every point. [`Error::Interrupted`] when
/// [`crate::interrupt::StopToken::stop`] was called (the points not started then fail at once,
/// [`sweep_point::evaluate`]). The figures `requested` (canonical names) are computed beside
/// the default ones when they are on request only ([`sweep_point::evaluate_with`]).
pub fn evaluate_points_requesting(
    path: &Path,
    text: &str,
    fixed: &[Override],
    grid: &Grid,
    indices: &[usize],
    t_end: Option<&Override>,
    options: &PointOptions,
    requested: &[String],
    threads: usize,
    done: &(dyn Fn() + Sync),
) -> Result<Vec<PointResult>, Error> {
    let evaluate = |index: usize| {
        let mut overrides = fixed.to_vec();
        overrides.extend(grid.overrides(index));
        overrides.extend(t_end.cloned());
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            sweep_point::evaluate_with(path, text, &overrides, options, requested)
        }))
        .unwrap_or(Err(sweep_point::PointError::Panicked));
        done();
        let line = |e: &dyn std::fmt::Display| e.to_string().replace('\n', "; ");
        match result {
            Ok(p) => PointResult {
                index,
                figures: p.figures,
                error: None,
                time_domain_error: p.time_domain_error.map(|e| line(&e)),
            },
            Err(e) => PointResult {
                index,
                figures: vec![],
                error: Some(line(&e)),
                time_domain_error: None,
            },
        }
    };
    // The pool's threads work for this call: they see its stop token only.
    let token = crate::interrupt::current();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .start_handler(move |_| crate::interrupt::adopt(token.clone()))
        .build()
        .map_err(|e| Error::Usage(format!("cannot start the worker threads: {e}")))?;
    let results: Vec<PointResult> =
        pool.install(|| indices.par_iter().map(|&i| evaluate(i)).collect());
    if crate::interrupt::stop_requested() {
        return Err(Error::Interrupted);
    }
    Ok(results)
}

/// The figure columns of a sweep: every figure's name and unit in order of first
/// appearance over `rows` (in grid order), as `sweep.csv` has them.
pub fn figure_heads<'r>(rows: &[&'r PointResult]) -> Vec<(&'r str, &'static str)> {
    let mut heads: Vec<(&str, &'static str)> = vec![];
    for r in rows {
        for f in &r.figures {
            if !heads.iter().any(|(n, _)| *n == f.name) {
                heads.push((&f.name, f.unit));
            }
        }
    }
    heads
}

/// The worker threads of `--threads`: at most the machine's available parallelism (a note
/// says so when capped); 0, rayon's default (every core), without it.
pub fn threads(asked: Option<usize>) -> usize {
    let machine = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    match asked {
        Some(t) if t > machine => {
            eprintln!(
                "note: --threads {t} capped to {machine}, the machine's available parallelism"
            );
            machine
        }
        Some(t) => t,
        None => 0,
    }
}

fn progress_bar(show: bool, len: usize) -> ProgressBar {
    crate::progress::bar_or_hidden(show, len as u64, "sweep [{bar:40}] {pos}/{len} ETA {eta}")
}

/// Pretty-printed JSON with a final newline (`null` for an absent figure or no error).
fn pretty<T: Serialize>(value: &T) -> Result<Vec<u8>, Error> {
    let mut v = serde_json::to_vec_pretty(value).map_err(ReportError::from)?;
    v.push(b'\n');
    Ok(v)
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
    fn new(spec: &SweepSpec, shard: usize, shards: usize, results: &[PointResult]) -> Part {
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

/// `sweep.json`.
#[derive(Serialize)]
struct SweepJson<'a> {
    #[serde(flatten)]
    spec: &'a SweepSpec,
    parameters: Vec<&'a str>,
    figures: Vec<FigureHead<'a>>,
    failed: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    time_domain_failed: Option<usize>,
    /// The best feasible point (`null` when no point satisfies the constraints).
    best: Option<BestJson>,
    points: Vec<PointJson<'a>>,
}

/// The best feasible point of a sweep.
#[derive(Serialize)]
struct BestJson {
    index: usize,
    parameters: Vec<serde_json::Value>,
    figure: String,
    value: f64,
}

/// The design reading of a sweep: which points satisfy every constraint, and the best of
/// them by the map's figure (the lowest index among equals).
pub struct Design {
    /// The constraints.
    pub constraints: Vec<Constraint>,
    /// Per point (in grid order): whether it satisfies every constraint (a failed point, or
    /// one without a constrained figure, does not).
    pub feasible: Vec<bool>,
    /// The best feasible point and its value of the map's figure.
    pub best: Option<(usize, f64)>,
}

impl Design {
    /// Reads `rows` (every point, in grid order) against the spec's constraints and map.
    pub fn of(spec: &SweepSpec, rows: &[&PointResult]) -> Result<Design, Error> {
        let constraints = spec
            .constraints
            .iter()
            .map(|c| c.parse::<Constraint>()?.resolve(None))
            .collect::<Result<Vec<_>, _>>()
            .map_err(SpecError::from)?;
        let feasible: Vec<bool> = rows
            .iter()
            .map(|r| {
                r.error.is_none()
                    && constraints
                        .iter()
                        .all(|c| margin(c, r).is_some_and(|m| m >= 0.0))
            })
            .collect();
        let mut best: Option<(usize, f64)> = None;
        for (r, ok) in rows.iter().zip(&feasible) {
            let value = r
                .figures
                .iter()
                .find(|f| f.name == spec.map)
                .and_then(|f| f.value);
            if let (true, Some(v)) = (*ok, value) {
                let better = match best {
                    None => true,
                    Some((_, b)) if spec.minimize => v < b,
                    Some((_, b)) => v > b,
                };
                if better {
                    best = Some((r.index, v));
                }
            }
        }
        Ok(Design {
            constraints,
            feasible,
            best,
        })
    }

    /// One line: the best feasible point with its fields and figure, or that no point
    /// satisfies the constraints.
    pub fn describe(&self, spec: &SweepSpec, grid: &Grid) -> String {
        let feasible = self.feasible.iter().filter(|f| **f).count();
        let of = if self.constraints.is_empty() {
            String::new()
        } else {
            let c: Vec<&str> = self.constraints.iter().map(|c| c.text.as_str()).collect();
            format!(" ({feasible} point(s) satisfy {})", c.join(", "))
        };
        match self.best {
            Some((index, value)) => {
                let at: Vec<String> = grid
                    .axes
                    .iter()
                    .zip(grid.point(index))
                    .map(|(a, v)| format!("{}={}", a.path, value_text(v)))
                    .collect();
                let which = if spec.minimize { "lowest" } else { "highest" };
                format!(
                    "best feasible point{of}: #{index} {}: {} = {} ({which})",
                    at.join(" "),
                    spec.map,
                    cell(Some(value))
                )
            }
            None if !self.constraints.is_empty() && feasible == 0 => {
                format!("no grid point satisfies the constraints{of}")
            }
            None => format!("no point gives {}{of}", spec.map),
        }
    }
}

#[derive(Serialize)]
struct FigureHead<'a> {
    name: &'a str,
    unit: &'a str,
}

#[derive(Serialize)]
struct PointJson<'a> {
    index: usize,
    parameters: Vec<serde_json::Value>,
    figures: Vec<Option<f64>>,
    error: Option<&'a str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    time_domain_error: Option<&'a str>,
}

/// The files of a complete sweep (`sweep.csv`, `sweep.json`) from the results of every point
/// (in any order); the same bytes whether the results come from one run or merged parts.
pub fn outputs(
    out: &Path,
    spec: &SweepSpec,
    grid: &Grid,
    results: &[PointResult],
) -> Result<Vec<OutputFile>, Error> {
    let mut rows: Vec<&PointResult> = results.iter().collect();
    rows.sort_by_key(|r| r.index);
    if rows.len() != grid.len() || rows.iter().enumerate().any(|(i, r)| r.index != i) {
        return Err(Error::Usage(format!(
            "the results do not cover the grid of {} point(s) exactly once",
            grid.len()
        )));
    }
    // The figure columns: every figure name in order of first appearance, in grid order.
    let heads = figure_heads(&rows);
    let value_of = |r: &PointResult, name: &str| {
        r.figures
            .iter()
            .find(|f| f.name == name)
            .and_then(|f| f.value)
    };
    let param_cell = |v: &Value| match v {
        Value::Float(f) => cell(Some(*f.value())),
        Value::Integer(i) => i.value().to_string(),
        Value::String(s) => s.value().clone(),
        v => value_text(v),
    };
    let design = Design::of(spec, &rows)?;
    let mut csv = ::csv::Writer::from_writer(vec![]);
    let mut header = vec!["index".to_string()];
    header.extend(grid.axes.iter().map(|a| a.path.clone()));
    header.extend(heads.iter().map(|(n, u)| format!("{n} [{u}]")));
    header.push("error".into());
    if spec.time_domain {
        header.push("time_domain_error".into());
    }
    let csv_err = |e: ::csv::Error| Error::from(ReportError::from(e));
    csv.write_record(&header).map_err(csv_err)?;
    let mut points = vec![];
    for r in &rows {
        let values = grid.point(r.index);
        let mut record = vec![r.index.to_string()];
        record.extend(values.iter().map(|v| param_cell(v)));
        record.extend(heads.iter().map(|(n, _)| cell(value_of(r, n))));
        record.push(r.error.clone().unwrap_or_default());
        if spec.time_domain {
            record.push(r.time_domain_error.clone().unwrap_or_default());
        }
        csv.write_record(&record).map_err(csv_err)?;
        points.push(PointJson {
            index: r.index,
            parameters: values.iter().map(|v| json_value(v)).collect(),
            figures: heads.iter().map(|(n, _)| value_of(r, n)).collect(),
            error: r.error.as_deref(),
            time_domain_error: r.time_domain_error.as_deref(),
        });
    }
    let csv = csv
        .into_inner()
        .map_err(|e| csv_err(e.into_error().into()))?;
    let json = SweepJson {
        spec,
        parameters: grid.axes.iter().map(|a| a.path.as_str()).collect(),
        figures: heads
            .iter()
            .map(|(name, unit)| FigureHead { name, unit })
            .collect(),
        failed: rows.iter().filter(|r| r.error.is_some()).count(),
        best: design.best.map(|(index, value)| BestJson {
            index,
            parameters: grid.point(index).iter().map(|v| json_value(v)).collect(),
            figure: spec.map.clone(),
            value,
        }),
        time_domain_failed: spec.time_domain.then(|| {
            rows.iter()
                .filter(|r| r.time_domain_error.is_some())
                .count()
        }),
        points,
    };
    let mut files = vec![
        OutputFile {
            path: out.join("sweep.csv"),
            bytes: csv,
        },
        OutputFile {
            path: out.join("sweep.json"),
            bytes: pretty(&json)?,
        },
    ];
    files.extend(plots(out, spec, grid, &rows)?);
    files.extend(design_map(out, spec, grid, &rows, &design)?);
    Ok(files)
}

/// `sweep_map_<FIGURE>.svg` of a sweep with exactly two swept fields of more than one
/// numeric, monotonic value ([`crate::report::map`]): the map's figure over the grid, the
/// contour of every constraint, the infeasible points hatched, the best feasible point
/// marked. None otherwise.
fn design_map(
    out: &Path,
    spec: &SweepSpec,
    grid: &Grid,
    rows: &[&PointResult],
    design: &Design,
) -> Result<Option<OutputFile>, Error> {
    use crate::report::map::{DesignMap, MapAxis, is_monotonic, plot_map_svg};
    let varying: Vec<usize> = (0..grid.axes.len())
        .filter(|&a| grid.axes[a].values.len() > 1)
        .collect();
    let [ax, ay] = varying[..] else {
        return Ok(None);
    };
    let values = |a: usize| -> Option<Vec<f64>> {
        grid.axes[a]
            .values
            .iter()
            .map(number)
            .collect::<Option<Vec<f64>>>()
    };
    let (Some(xs), Some(ys)) = (values(ax), values(ay)) else {
        return Ok(None);
    };
    if !(is_monotonic(&xs) && is_monotonic(&ys)) {
        return Ok(None);
    }
    // Grid index of (i, j): the other axes have one value each.
    let stride =
        |a: usize| -> usize { grid.axes[a + 1..].iter().map(|x| x.values.len()).product() };
    let (sx, sy) = (stride(ax), stride(ay));
    let at = |i: usize, j: usize| i * sx + j * sy;
    let (nx, ny) = (xs.len(), ys.len());
    let per_point = |f: &dyn Fn(&PointResult) -> Option<f64>| -> Vec<Option<f64>> {
        (0..nx)
            .flat_map(|i| (0..ny).map(move |j| (i, j)))
            .map(|(i, j)| f(rows[at(i, j)]))
            .collect()
    };
    let map_values = per_point(&|r| {
        r.figures
            .iter()
            .find(|f| f.name == spec.map)
            .and_then(|f| f.value)
    });
    if map_values.iter().all(Option::is_none) {
        return Ok(None);
    }
    let feasible: Vec<bool> = (0..nx)
        .flat_map(|i| (0..ny).map(move |j| (i, j)))
        .map(|(i, j)| design.feasible[at(i, j)])
        .collect();
    let contours: Vec<(String, Vec<Option<f64>>)> = design
        .constraints
        .iter()
        .map(|c| (c.text.clone(), per_point(&|r| margin(c, r))))
        .collect();
    let best_label;
    let best = match design.best {
        Some((index, value)) => {
            let p = grid.point(index);
            let (bx, by) = (number(p[ax]), number(p[ay]));
            best_label = format!(
                "{} = {}, {} = {}: {} = {}",
                grid.axes[ax].path,
                value_text(p[ax]),
                grid.axes[ay].path,
                value_text(p[ay]),
                spec.map,
                cell(Some(value))
            );
            bx.zip(by).map(|b| (b, best_label.as_str()))
        }
        None => None,
    };
    let title = format!(
        "{} over {} and {}: {}",
        spec.map, grid.axes[ax].path, grid.axes[ay].path, spec.scenario
    );
    let bytes = plot_map_svg(&DesignMap {
        title: &title,
        x: MapAxis {
            label: &grid.axes[ax].path,
            values: &xs,
        },
        y: MapAxis {
            label: &grid.axes[ay].path,
            values: &ys,
        },
        figure: &spec.map,
        values: &map_values,
        feasible: &feasible,
        contours: &contours,
        best,
    })
    .map_err(ReportError::from)?;
    Ok(Some(OutputFile {
        path: out.join(format!("sweep_map_{}.svg", spec.map)),
        bytes,
    }))
}

/// Most lines of a sweep's line plots: a sweep with more combinations of its other varying
/// fields draws its design map instead (two fields) or no line plot.
const MAX_LINES: usize = 10;

/// A figure read from a point's results.
type FigureOf<'a> = dyn Fn(&PointResult) -> Option<f64> + 'a;

/// The plots of a sweep against its first swept parameter (when its values are numbers),
/// one line per combination of the other parameters: `sweep_damping.svg` (first-mode damping
/// ratio with the generator, disconnected, and from the time domain when run),
/// `sweep_frequency.svg` (first-mode frequency, the same variants and the bare beam) and,
/// with `--time-domain`, `sweep_harvested.svg` (the fraction of the dissipated energy
/// harvested in the load). Failed points are left out of the lines.
fn plots(
    out: &Path,
    spec: &SweepSpec,
    grid: &Grid,
    rows: &[&PointResult],
) -> Result<Vec<OutputFile>, Error> {
    // The x axis: the first swept field with more than one value (a fixed `--set` is
    // never an axis); one line per combination of the other varying fields.
    let varying: Vec<usize> = (0..grid.axes.len())
        .filter(|&a| grid.axes[a].values.len() > 1)
        .collect();
    let Some((&x_axis, others)) = varying.split_first() else {
        return Ok(vec![]);
    };
    let axis = &grid.axes[x_axis];
    if axis.values.iter().any(|v| number(v).is_none()) {
        return Ok(vec![]);
    }
    let lines: usize = others.iter().map(|&a| grid.axes[a].values.len()).product();
    if lines > MAX_LINES {
        return Ok(vec![]);
    }
    let value = |r: &PointResult, name: &str| {
        r.figures
            .iter()
            .find(|f| f.name == name)
            .and_then(|f| f.value)
    };
    // Groups: the values of the other axes, in grid order.
    let mut groups: Vec<(String, Vec<&PointResult>)> = vec![];
    for r in rows {
        let values = grid.point(r.index);
        let key: Vec<String> = others
            .iter()
            .map(|&a| format!("{}={}", grid.axes[a].path, value_text(values[a])))
            .collect();
        let key = key.join(", ");
        match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, g)) => g.push(r),
            None => groups.push((key, vec![r])),
        }
    }
    let x_of = |r: &PointResult| number(grid.point(r.index)[x_axis]).expect("checked numeric");
    let line = |g: &[&PointResult], f: &dyn Fn(&PointResult) -> Option<f64>| -> Vec<(f64, f64)> {
        g.iter()
            .filter_map(|r| f(r).map(|y| (x_of(r), y)))
            .collect()
    };
    let label = |key: &str, what: &str| {
        if key.is_empty() {
            what.to_string()
        } else {
            format!("{key}: {what}")
        }
    };
    let log_x = axis.path.ends_with("resistance");
    let title = |what: &str| format!("{what} vs {}: {}", axis.path, spec.scenario);
    let mut files = vec![];
    let mut draw = |file: &str,
                    what: &str,
                    y_desc: &str,
                    variants: &[(&str, &FigureOf<'_>)]|
     -> Result<(), Error> {
        let mut series: Vec<(String, Vec<(f64, f64)>)> = vec![];
        for (key, g) in &groups {
            for (name, f) in variants {
                let pts = line(g, *f);
                if !pts.is_empty() {
                    series.push((label(key, name), pts));
                }
            }
        }
        if series.is_empty() {
            return Ok(());
        }
        let refs: Vec<(&str, &[(f64, f64)])> =
            series.iter().map(|(l, p)| (l.as_str(), &p[..])).collect();
        let bytes = crate::report::plot::plot_xy_svg(
            &title(what),
            &axis.path,
            y_desc,
            &refs,
            (log_x, false),
        )
        .map_err(ReportError::from)?;
        files.push(OutputFile {
            path: out.join(file),
            bytes,
        });
        Ok(())
    };
    let pct = |name: &'static str| move |r: &PointResult| value(r, name).map(|z| 100.0 * z);
    let (zw, zd, zt) = (
        pct("linear.zeta1"),
        pct("linear.zeta1_generator_disconnected"),
        pct("damping_ratio"),
    );
    draw(
        "sweep_damping.svg",
        "First-mode damping ratio",
        "damping ratio [%]",
        &[
            ("with generator (linearised)", &zw),
            ("generator disconnected (linearised)", &zd),
            ("with generator (time domain, filtered decay)", &zt),
        ],
    )?;
    let hz = |name: &'static str| move |r: &PointResult| value(r, name);
    let (fw, fd, fb) = (
        hz("linear.f1"),
        hz("linear.f1_generator_disconnected"),
        hz("linear.f1_bare_beam"),
    );
    draw(
        "sweep_frequency.svg",
        "First-mode natural frequency",
        "frequency [Hz]",
        &[
            ("with generator", &fw),
            ("generator disconnected (mechanism + rotor attached)", &fd),
            ("bare beam (no mechanism)", &fb),
        ],
    )?;
    let harvested = |r: &PointResult| {
        let h = value(r, "energy.harvested_in_load")?;
        let d =
            value(r, "energy.dissipated_generators")? + value(r, "energy.dissipated_structure")?;
        (d > 0.0).then(|| 100.0 * h / d)
    };
    draw(
        "sweep_harvested.svg",
        "Energy harvested in the load / energy dissipated (time domain)",
        "harvested fraction [%]",
        &[("harvested in the load", &harvested)],
    )?;
    Ok(files)
}
