//! `damper sweep SCENARIO --set PATH=VALUES ... -o OUT [--shard I/N] [--threads T]
//! [--time-domain] [--t-end T]`: a cartesian grid over scenario fields.
//!
//! VALUES is `a:b:n` (n points from a to b inclusive, `a + (b - a) k / (n - 1)`, the
//! endpoints exact; integers when a and b are integers and the step is a whole number),
//! `a:b:n:log` (n points in geometric progression, `a (b / a)^(k / (n - 1))`, a, b > 0) or
//! a comma list of TOML values (`0.5,1,2,5`; one value is a fixed override). The grid is the
//! product of the options in command-line order, the last one varying fastest. The sweep is
//! [`crate::analysis::sweep`] (its limits too); a point that fails is recorded with its
//! message and the sweep goes on.
//!
//! OUT receives `sweep.csv` (one row per point in grid order: `index`, each swept PATH, the
//! figures with their units, `error`) and `sweep.json` (the same with the scenario, the
//! specs and the grid size), committed together by the one writer
//! ([`crate::report::sweep`]). With `--shard I/N` only the points with `index % N == I` are
//! evaluated and `OUT/sweep.part-I-of-N.json` is written; `damper merge` ([`super::merge`])
//! joins the N parts into exactly the files of the unsharded run, byte for byte.
//!
//! Numbers are written in one form everywhere: the shortest representation that reads back
//! to the same `f64` (`crate::report::csv` cells; `serde_json` in the JSON).

use std::path::PathBuf;
use std::time::Instant;

use crate::Error;
use crate::analysis::sweep::{self, Design, Part, PointResult, SweepRequest, part_name};
use crate::report::sweep::{outputs, pretty};
use crate::report::{OutputFile, OutputLock, ReportError, commit_files};

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

impl Args {
    /// The sweep these arguments ask for (`--shard` read).
    pub fn request(&self) -> Result<SweepRequest, Error> {
        Ok(SweepRequest {
            scenario: self.scenario.clone(),
            text: None,
            fixed: vec![],
            sets: self.set.clone(),
            shard: self.shard.as_deref().map(sweep::parse_shard).transpose()?,
            t_end: self.t_end,
            time_domain: self.time_domain,
            constraints: self.constraints.clone(),
            map: self.map.clone(),
            minimize: self.minimize,
            threads: self.threads,
            method: parse_method(&self.method)?,
            allow_long: self.allow_long,
        })
    }
}

/// The random figures' `--method` (`auto`, `dense`, `modal`, `quadrature`).
pub fn parse_method(name: &str) -> Result<crate::random::RandomMethod, Error> {
    crate::random::RandomMethod::parse(name).ok_or_else(|| {
        Error::Usage(format!(
            "--method {name:?}: expected auto, dense, modal or quadrature"
        ))
    })
}

/// Runs `damper sweep`.
pub fn run(args: Args) -> Result<(), Error> {
    let started = Instant::now();
    let req = args.request()?;
    let plan = sweep::plan(&req)?;
    for w in &plan.warnings {
        eprintln!("{w}");
    }
    if std::fs::metadata(&args.out).is_ok_and(|m| !m.is_dir()) {
        return Err(Error::Usage(format!(
            "output directory {} is not a directory",
            args.out.display()
        )));
    }
    // One unsharded sweep at a time into a directory (the shards of one sweep write
    // distinct part files into a shared directory at once, by design: not locked).
    let _lock = match req.shard {
        None => Some(OutputLock::acquire(&args.out).map_err(ReportError::from)?),
        Some(_) => None,
    };
    let bar = crate::progress::bar_or_hidden(
        !args.quiet,
        plan.points as u64,
        "sweep [{bar:40}] {pos}/{len} ETA {eta}",
    );
    let sweep::Sweep {
        spec,
        grid,
        results,
    } = sweep::evaluate(&req, &plan, &|| bar.inc(1))?;
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
    let files = match req.shard {
        Some((i, n)) => vec![OutputFile {
            path: args.out.join(part_name(i, n)),
            bytes: pretty(&Part::new(&spec, i, n, &results))?,
        }],
        None => outputs(&args.out, &spec, &grid, &results)?,
    };
    commit_files(&files).map_err(ReportError::from)?;
    if req.shard.is_none() {
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
            "{}: every one of the {failed} point(s) failed (the files record each error); the first: {first}",
            spec.scenario
        ))),
        _ => Ok(()),
    }
}
