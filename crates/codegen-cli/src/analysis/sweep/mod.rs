//! A sweep ([`SweepRequest`] → [`plan`] → [`evaluate`] → [`Sweep`]), what `damper sweep`
//! writes and Python's `Scenario.sweep` returns: a cartesian grid over scenario fields
//! ([`grid`]), every point [`crate::sweep_point::evaluate`]d — linearised about its static
//! equilibrium, and with `time_domain` also run in the time domain — in parallel (rayon;
//! results collected by index, so identical whatever the thread count), a point that fails
//! recorded with its message ([`point`]); the record of the sweep and its shards
//! ([`part`]) and its design reading ([`design`]). The files are [`crate::report::sweep`].
//!
//! **Limits** (`crate::budget`): before any point runs, the grid's size is counted without
//! building it (overflow-checked: a grid of more points than a machine word holds is
//! refused), and the points of the shard, their memory and with `time_domain` the steps of
//! one point and of all of them are estimated; above the limits the sweep is refused unless
//! `allow_long`. The worker threads are capped to the machine's available parallelism.

pub mod design;
pub mod grid;
pub mod part;
pub mod point;

use std::path::PathBuf;

use toml_edit::Value;

pub use design::Design;
pub use grid::{
    Axis, Grid, Shape, SpecError, ValuesError, parse_shard, parse_values, shard_points,
};
pub use part::{Part, PartFigure, PartRow, PartRowError, SweepSpec, fnv1a_hex, part_name};
pub use point::{
    PointResult, check_paths, evaluate_points_requesting, figure_heads, margin, threads,
};

use crate::Error;
use crate::analysis::AnalysisError;
use crate::analysis::Warning;
use crate::analysis::figures::{self, Constraint, Entities};
use crate::budget::{self, Quantity};
use crate::report::csv::cell;
use crate::scenario::{self, Override};
use crate::sweep_point::PointOptions;

/// What to compute: a sweep of a scenario file over the grid of `sets`.
#[derive(Clone, Debug)]
pub struct SweepRequest {
    /// The scenario file (its directory the base of relative paths; messages name it).
    pub scenario: PathBuf,
    /// The scenario's text; `None`: read from `scenario` (after the grid is parsed).
    pub text: Option<String>,
    /// Overrides applied to every point before the grid's.
    pub fixed: Vec<Override>,
    /// The `--set PATH=VALUES` specs, in order.
    pub sets: Vec<String>,
    /// Only the points `index % N == I` of `(I, N)`.
    pub shard: Option<(usize, usize)>,
    /// `integrator.t_end` of every point (s).
    pub t_end: Option<f64>,
    /// Also run each point in the time domain.
    pub time_domain: bool,
    /// The constraints `FIGURE>=VALUE`, as written.
    pub constraints: Vec<String>,
    /// The figure of the design map and of the best point.
    pub map: String,
    /// The best point minimises `map` (else maximises).
    pub minimize: bool,
    /// Worker threads (`None`: every core).
    pub threads: Option<usize>,
    /// How the random figures are computed (`damper random --method`).
    pub method: crate::random::RandomMethod,
    /// Run even above the limits of [`crate::budget`].
    pub allow_long: bool,
}

/// The checks of a sweep before any file is read: its grid's size, its memory, its threads.
pub struct Plan {
    /// The grid's shape.
    pub shape: Shape,
    /// The points of the shard.
    pub points: usize,
    /// The worker threads (0: every core).
    pub threads: usize,
    /// Notes (the threads capped to the machine's).
    pub warnings: Vec<Warning>,
}

/// A sweep evaluated: its record, its grid and the results of the points of its shard in
/// grid order.
pub struct Sweep {
    /// The settings as the files record them.
    pub spec: SweepSpec,
    /// The grid.
    pub grid: Grid,
    /// One result per point of the shard.
    pub results: Vec<PointResult>,
}

/// Checks `req` before any file is read: the grid's specs, `t_end`, the threads, the count
/// and memory of the shard's points (refused above the limits unless `allow_long`).
pub fn plan(req: &SweepRequest) -> Result<Plan, Error> {
    let shape = Shape::of(&req.sets)?;
    if let Some(t) = req.t_end
        && !(t.is_finite() && t > 0.0)
    {
        return Err(AnalysisError::argument(
            "--t-end",
            format!("--t-end {t}: must be a positive time"),
        )
        .into());
    }
    if req.threads == Some(0) {
        return Err(AnalysisError::argument("--threads", "--threads must be at least 1").into());
    }
    let file = req.scenario.display().to_string();
    let (shard_i, shards) = req.shard.unwrap_or((0, 1));
    let points = shape.shard_points(shard_i, shards);
    budget::refuse_above(
        &format!("sweep of {file}"),
        &[
            Quantity::count("grid points", points as f64, budget::MAX_SWEEP_POINTS),
            Quantity::bytes("memory", shape.memory(points), budget::MAX_MEMORY),
        ],
        "use fewer values per --set or split the sweep with --shard I/N",
        req.allow_long,
    )?;
    let (threads, note) = threads(req.threads);
    Ok(Plan {
        shape,
        points,
        threads,
        warnings: note.into_iter().collect(),
    })
}

/// Evaluates the sweep `req` ([`plan`]ned): the grid, the PATHs and figures checked before
/// any work, the first point's structure and time steps within the limits, then every point
/// of the shard; `done` is called after each.
pub fn evaluate(req: &SweepRequest, plan: &Plan, done: &(dyn Fn() + Sync)) -> Result<Sweep, Error> {
    let file = req.scenario.display().to_string();
    let (shard_i, shards) = req.shard.unwrap_or((0, 1));
    let points = plan.points;
    let grid = Grid::parse(&req.sets)?;
    let text = match &req.text {
        Some(t) => t.clone(),
        None => scenario::read(&req.scenario)?,
    };
    let path = &req.scenario;
    let fixed = &req.fixed[..];
    // Before any work: every PATH a field the scenario takes, every figure one it offers.
    check_paths(
        path,
        &text,
        fixed,
        grid.axes
            .iter()
            .map(|a| (a.path.as_str(), a.values[0].clone())),
    )?;
    let entities = scenario::parse_with(&text, path, fixed)
        .ok()
        .map(|l| Entities::of(&l.scenario));
    let map = figures::resolve(&req.map, entities.as_ref())
        .map_err(SpecError::Map)?
        .name;
    let constraints: Vec<Constraint> = req
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
    let t_end = req.t_end.map(|t| {
        Override::new("integrator.t_end", Value::from(t), &cell(Some(t))).expect("a valid PATH")
    });
    // The first point stands for the others (its structure, its time steps); a point
    // whose own settings are above the limits records that as its error (`sweep_point`).
    let first = (points > 0)
        .then(|| {
            let mut overrides = fixed.to_vec();
            overrides.extend(grid.overrides(0));
            overrides.extend(t_end.clone());
            scenario::parse_with(&text, path, &overrides).ok()
        })
        .flatten();
    budget::sweep(
        &format!("sweep of {file}"),
        points as f64,
        plan.shape.memory(points),
        first
            .as_ref()
            .filter(|_| req.time_domain)
            .and_then(|l| budget::steps_per_run(&l.scenario)),
        first.as_ref().map(|l| &l.scenario),
        req.allow_long,
    )?;
    let spec = SweepSpec {
        scenario: file,
        scenario_hash: fnv1a_hex(text.as_bytes()),
        sets: req.sets.clone(),
        fixed: fixed.iter().map(ToString::to_string).collect(),
        t_end: req.t_end.map(|t| cell(Some(t))),
        time_domain: req.time_domain,
        grid_size: grid.len(),
        constraints: constraints.iter().map(|c| c.text.clone()).collect(),
        map,
        minimize: req.minimize,
        method: (req.method != crate::random::RandomMethod::Auto)
            .then(|| req.method.name().to_string()),
    };
    let mut indices: Vec<usize> = Vec::new();
    indices
        .try_reserve_exact(points)
        .map_err(|_| AnalysisError::Resources {
            message: format!("sweep: {points} points do not fit in memory"),
        })?;
    indices.extend((shard_i..grid.len()).step_by(shards));
    let options = PointOptions {
        time_domain: req.time_domain,
        allow_long: req.allow_long,
        method: req.method,
        only_requested: false,
    };
    let results = evaluate_points_requesting(
        path,
        &text,
        fixed,
        &grid,
        &indices,
        t_end.as_ref(),
        &options,
        &requested,
        plan.threads,
        done,
    )?;
    Ok(Sweep {
        spec,
        grid,
        results,
    })
}
