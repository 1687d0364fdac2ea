//! The scenario functions: every call receives the scenario as its text, the file name its
//! messages name, the directory of its relative paths and its `set` overrides, and loads it
//! through the one loader ([`codegen_cli::scenario::parse_with_in`]) — exactly what the
//! command line does with a file and its `--set` options. The directory is made absolute
//! (a call after `os.chdir`, or in another process, finds the same files); every call
//! refuses a structure above the work budget before any work ([`Source::load`]).

use std::path::{Path, PathBuf};

use codegen_cli::Error;
use codegen_cli::analysis::frf::{self as frf_analysis, FrfRequest};
use codegen_cli::analysis::linearize::{self as linearize_analysis, LinearizeRequest, Linearized};
use codegen_cli::analysis::optimization::OptimizeRequest;
use codegen_cli::analysis::stationary::{self, RandomRequest};
use codegen_cli::analysis::sweep::{self, SweepRequest};
use codegen_cli::report::rows::split_header;
use codegen_cli::report::sweep as sweep_report;
use codegen_cli::scenario::overrides::json_value;
use codegen_cli::scenario::{self, Loaded, Override, Scenario};
use hybrid_core::hybrid::EigenMethod;
use numpy::PyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::convert::{
    PyColumn, array1, array2, axis_spec, json, matrix, overrides, table, to_python,
};
use crate::errors::{Input, to_py, warn};
use crate::watch::interruptible;

/// A scenario as the Python side holds it.
struct Source {
    text: String,
    file: String,
    base: PathBuf,
    overrides: Vec<Override>,
}

impl Source {
    fn new(
        text: String,
        file: String,
        base: String,
        sets: Vec<(String, Bound<'_, PyAny>)>,
    ) -> PyResult<Source> {
        let base = std::path::absolute(PathBuf::from(&base))
            .map_err(|e| PyValueError::new_err(format!("base directory {base:?}: {e}")))?;
        Ok(Source {
            text,
            file,
            base,
            overrides: overrides(&sets)?,
        })
    }

    /// The scenario loaded and checked (model files included), without any work.
    fn check(&self) -> Result<Loaded, Error> {
        Ok(scenario::parse_with_in(
            &self.text,
            &self.file,
            &self.base,
            &self.overrides,
        )?)
    }

    /// [`Source::check`], then its structure within the work budget unless `allow_long`.
    fn load(&self, allow_long: bool) -> Result<Loaded, Error> {
        let loaded = self.check()?;
        codegen_cli::budget::structure(&loaded.scenario, &self.file, allow_long)?;
        Ok(loaded)
    }

    /// The path that names the file and whose directory is the base of relative paths
    /// (what the sweep and the optimiser take).
    fn path(&self) -> PathBuf {
        let name = Path::new(&self.file)
            .file_name()
            .map_or_else(|| PathBuf::from(&self.file), PathBuf::from);
        self.base.join(name)
    }
}

/// A later error of a loaded scenario about the file and the options the user wrote.
fn remapped(loaded: &Loaded, e: Error) -> Error {
    match e {
        Error::Input(d) => Error::Input(loaded.remap(d)),
        e => e,
    }
}

/// The text of a scenario file (`ScenarioError` when it cannot be read: not a regular
/// file, too large), read without the GIL and interruptible.
#[pyfunction]
pub fn read_scenario(py: Python<'_>, path: PathBuf) -> PyResult<String> {
    interruptible(py, || Ok(scenario::read(&path)?))?.map_err(|e| to_py(py, e, Input::Scenario))
}

/// Loads and checks a scenario; returns its kind (`"hybrid"` for a damper scenario, or
/// `"mechanism"`).
#[pyfunction]
pub fn check(
    py: Python<'_>,
    text: String,
    file: String,
    base: String,
    sets: Vec<(String, Bound<'_, PyAny>)>,
) -> PyResult<&'static str> {
    let src = Source::new(text, file, base, sets)?;
    let loaded = interruptible(py, || src.check())?.map_err(|e| to_py(py, e, Input::Scenario))?;
    Ok(match loaded.scenario {
        Scenario::Hybrid(_) => "hybrid",
        Scenario::Mechanism(_) => "mechanism",
    })
}

/// Named columns: a list of `(name, unit, values)` ([`crate::convert::table`]).
type Columns<'py> = Vec<PyColumn<'py>>;

/// A time history's columns, each header (`t [s]`) split into its name and unit.
fn columns(py: Python<'_>, rows: codegen_cli::report::rows::ColumnRows) -> Columns<'_> {
    rows.into_columns()
        .into_iter()
        .map(|(h, c)| {
            let (name, unit) = split_header(&h);
            (
                name.to_string(),
                unit.map(str::to_string),
                array1(py, c).into_any(),
            )
        })
        .collect()
}

/// The warnings' messages, as Python's results list them (each is also issued with
/// `warnings.warn`, [`warn`]).
fn messages(warnings: &[codegen_cli::analysis::Warning]) -> Vec<String> {
    warnings.iter().map(|w| w.message.clone()).collect()
}

/// Runs a scenario as `damper simulate` does, in memory: `(summary.json bytes, columns of
/// the time history, [(comparison key, its columns)], columns of random_psd.csv or None)`,
/// each column `(name, unit, array)`.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn simulate<'py>(
    py: Python<'py>,
    text: String,
    file: String,
    base: String,
    sets: Vec<(String, Bound<'py, PyAny>)>,
    allow_long: bool,
) -> PyResult<(
    Bound<'py, PyAny>,
    Columns<'py>,
    Vec<(String, Columns<'py>)>,
    Option<Vec<crate::convert::PyColumn<'py>>>,
)> {
    let src = Source::new(text, file, base, sets)?;
    let request = codegen_cli::run::SimulateRequest { allow_long };
    let out = interruptible(py, || {
        let loaded = src.load(allow_long)?;
        codegen_cli::run::simulate_in_memory(&request, &loaded)
    })?
    .map_err(|e| to_py(py, e, Input::Scenario))?;
    let summary = json(py, &out.summary)?;
    let comparisons = out
        .comparisons
        .into_iter()
        .map(|(k, rows)| (k.to_string(), columns(py, rows)))
        .collect();
    let psd = out.psd.map(|t| crate::convert::table(py, t)).transpose()?;
    Ok((summary, columns(py, out.rows), comparisons, psd))
}

/// One mode's shapes: the beam's `(nodes, 3)` array `[x, re, im]` and the mechanisms'
/// `(coordinates, 2)` array `[re, im]`, with the coordinates' `mechanism/coordinate` names.
type Shapes<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Vec<String>,
);

fn shapes<'py>(
    py: Python<'py>,
    modes: &[codegen_cli::linear::ModeReport],
) -> PyResult<Vec<Shapes<'py>>> {
    modes
        .iter()
        .map(|m| {
            let beam: Vec<f64> = m.beam_shape.iter().flatten().copied().collect();
            let coords = m.mechanism_shape.iter().flat_map(|s| {
                s.coordinates
                    .iter()
                    .map(move |(c, z)| (format!("{}/{c}", s.mechanism), *z))
            });
            let (names, values): (Vec<String>, Vec<[f64; 2]>) = coords.unzip();
            let n = values.len();
            let mech: Vec<f64> = values.into_iter().flatten().collect();
            Ok((
                array2(py, beam, m.beam_shape.len(), 3)?,
                array2(py, mech, n, 2)?,
                names,
            ))
        })
        .collect()
}

/// The dense reduced matrices `M_R`, `C_R`, `K_R`.
type Dense<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
);

/// The linearisation as `damper linearize --json` reports it (`modes` modes of each
/// variant, eigen-solver `method`): `(report JSON, shapes of the modes with the generator,
/// disconnected, of the bare beam, (M_R, C_R, K_R) or None)`. The dense matrices (`3 d^2`
/// numbers of `d` reduced coordinates) only with `matrices`, within the memory budget
/// unless `allow_long` (refused before they are allocated); the work of `damper linearize`
/// is refused above its limits unless `allow_long`.
#[pyfunction]
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub fn linearize<'py>(
    py: Python<'py>,
    text: String,
    file: String,
    base: String,
    sets: Vec<(String, Bound<'py, PyAny>)>,
    modes: usize,
    method: String,
    matrices: bool,
    allow_long: bool,
) -> PyResult<(
    Bound<'py, PyAny>,
    Vec<Shapes<'py>>,
    Option<Vec<Shapes<'py>>>,
    Option<Vec<Shapes<'py>>>,
    Option<Dense<'py>>,
)> {
    let method: EigenMethod = codegen_cli::analysis::linearize::parse_method(&method)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let src = Source::new(text, file, base, sets)?;
    let request = LinearizeRequest {
        file: src.file.clone(),
        modes,
        method,
        matrices,
        allow_long,
    };
    linearize_analysis::check(&request).map_err(|e| to_py(py, e, Input::Scenario))?;
    let Linearized {
        report,
        matrices: dense,
    } = interruptible(py, || {
        let loaded = src.load(allow_long)?;
        linearize_analysis::linearize(&request, &loaded)
    })?
    .map_err(|e| to_py(py, e, Input::Scenario))?;
    let with = shapes(py, &report.modes)?;
    let off = report
        .generator_disconnected
        .as_deref()
        .map(|m| shapes(py, m))
        .transpose()?;
    let bare = report
        .bare_beam
        .as_deref()
        .or(report.bare_structure.as_deref())
        .map(|m| shapes(py, m))
        .transpose()?;
    let dense = dense
        .map(|(m, c, k)| Ok::<_, PyErr>((matrix(py, m)?, matrix(py, c)?, matrix(py, k)?)))
        .transpose()?;
    Ok((to_python(py, &report)?, with, off, bare, dense))
}

/// The frequency response as `damper frf` writes it: the table of `frf.csv` (the report's
/// own, [`codegen_cli::analysis::frf::Frf::table`]) and, with `nonlinear` (`--nonlinear
/// M`), that of `frf_nonlinear.csv` ([`crate::convert::table`]: numbers as float arrays,
/// NaN for an empty cell, `periods` an int64 array, `settled` a bool array, `error` a list
/// of `str` or `None`), and the warnings' messages (also issued, [`warn`]). The runs release the GIL and stop at
/// Ctrl-C ([`interruptible`]); the limits of `damper frf` apply unless `allow_long`.
#[pyfunction]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn frf<'py>(
    py: Python<'py>,
    text: String,
    file: String,
    base: String,
    sets: Vec<(String, Bound<'py, PyAny>)>,
    output: String,
    f_from: f64,
    f_to: f64,
    points: usize,
    log: bool,
    excitation: Option<String>,
    force: Option<f64>,
    nonlinear: Option<usize>,
    steps_per_period: usize,
    tolerance: f64,
    max_periods: usize,
    allow_long: bool,
) -> PyResult<(Columns<'py>, Option<Columns<'py>>, Vec<String>)> {
    let src = Source::new(text, file, base, sets)?;
    let request = FrfRequest {
        file: src.file.clone(),
        output,
        from: f_from,
        to: f_to,
        points,
        log,
        nonlinear,
        excitation,
        force,
        steps_per_period,
        tolerance,
        max_periods,
        progress: false,
        allow_long,
    };
    let (cols, nl, warnings) = interruptible(py, || {
        frf_analysis::check(&request)?;
        let loaded = src.load(allow_long)?;
        let frf =
            frf_analysis::analyse(&request, &loaded.scenario).map_err(|e| remapped(&loaded, e))?;
        Ok((frf.table(), frf.nonlinear_table(), frf.warnings))
    })?
    .map_err(|e| to_py(py, e, Input::Scenario))?;
    warn(py, &warnings)?;
    Ok((
        table(py, cols)?,
        nl.map(|t| table(py, t)).transpose()?,
        messages(&warnings),
    ))
}

/// The sweep request of a scenario's `axes` (`(path, values)` pairs, the values a list or
/// a VALUES string), of shard `shard` (`(I, N)`) or of the whole grid.
fn sweep_request(
    src: &Source,
    axes: &[(String, Bound<'_, PyAny>)],
    shard: Option<(usize, usize)>,
    time_domain: bool,
    threads: Option<usize>,
    allow_long: bool,
) -> PyResult<SweepRequest> {
    if threads == Some(0) {
        return Err(PyValueError::new_err("threads must be at least 1"));
    }
    let specs: Vec<String> = axes
        .iter()
        .map(|(p, v)| axis_spec(p, v))
        .collect::<PyResult<_>>()?;
    Ok(SweepRequest {
        scenario: src.path(),
        text: Some(src.text.clone()),
        fixed: src.overrides.clone(),
        sets: specs,
        shard,
        t_end: None,
        time_domain,
        constraints: vec![],
        map: "linear.zeta1".into(),
        minimize: false,
        threads,
        method: codegen_cli::random::RandomMethod::Auto,
        allow_long,
    })
}

/// The sweep (or its shard) `request` asks for, evaluated without the GIL (interruptible),
/// its warnings issued.
fn run_sweep(py: Python<'_>, src: &Source, request: &SweepRequest) -> PyResult<sweep::Sweep> {
    let (done, warnings) = interruptible(py, || {
        // The scenario and the fixed overrides must load before any point.
        src.check()?;
        let plan = sweep::plan(request)?;
        Ok((sweep::evaluate(request, &plan, &|| {})?, plan.warnings))
    })?
    .map_err(|e| to_py(py, e, Input::Scenario))?;
    warn(py, &warnings)?;
    Ok(done)
}

/// A sweep as `damper sweep` computes it (`axes`: `(path, values)` pairs, the values a list
/// or a VALUES string): the table of `sweep.csv` (the report's own,
/// [`codegen_cli::report::sweep::table`]) — `index`, each axis (a list of its values), each
/// figure with its unit (NaN where the point does not give it), `error` and, in the time
/// domain, `time_domain_error` (lists of `str` or `None`).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn sweep_grid<'py>(
    py: Python<'py>,
    text: String,
    file: String,
    base: String,
    sets: Vec<(String, Bound<'py, PyAny>)>,
    axes: Vec<(String, Bound<'py, PyAny>)>,
    time_domain: bool,
    threads: Option<usize>,
    allow_long: bool,
) -> PyResult<Columns<'py>> {
    let src = Source::new(text, file, base, sets)?;
    let request = sweep_request(&src, &axes, None, time_domain, threads, allow_long)?;
    let done = run_sweep(py, &src, &request)?;
    let rows: Vec<&sweep::PointResult> = done.results.iter().collect();
    table(py, sweep_report::table(&done.grid, time_domain, &rows))
}

/// Shard `shard` of `shards` of a sweep (`damper sweep --shard I/N`): the text of its part
/// file `sweep.part-I-of-N.json` (the points `index % N == I`, with the sweep's record and
/// checksum), for [`sweep_merge`].
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn sweep_shard<'py>(
    py: Python<'py>,
    text: String,
    file: String,
    base: String,
    sets: Vec<(String, Bound<'py, PyAny>)>,
    axes: Vec<(String, Bound<'py, PyAny>)>,
    shard: usize,
    shards: usize,
    time_domain: bool,
    threads: Option<usize>,
    allow_long: bool,
) -> PyResult<String> {
    let src = Source::new(text, file, base, sets)?;
    let spec = format!("{shard}/{shards}");
    let shard = sweep::parse_shard(&spec).map_err(|e| to_py(py, e.into(), Input::Scenario))?;
    let request = sweep_request(&src, &axes, Some(shard), time_domain, threads, allow_long)?;
    let done = run_sweep(py, &src, &request)?;
    let part = sweep::Part::new(&done.spec, shard.0, shard.1, &done.results);
    let bytes = sweep_report::pretty(&part).map_err(|e| to_py(py, e, Input::Scenario))?;
    String::from_utf8(bytes).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// The part files' texts of the N shards of one sweep joined as `damper merge` joins them
/// (each checked: complete, its checksum, every shard once): the table of the `sweep.csv`
/// the unsharded sweep writes, as [`sweep_grid`] returns it.
#[pyfunction]
pub fn sweep_merge(py: Python<'_>, parts: Vec<String>, allow_long: bool) -> PyResult<Columns<'_>> {
    let merged = interruptible(py, || {
        let parts = parts
            .iter()
            .enumerate()
            .map(|(k, text)| {
                let part = sweep::part::parse_part(text.as_bytes(), &format!("part {k}"))?;
                Ok((
                    PathBuf::from(sweep::part_name(part.shard, part.shards)),
                    part,
                ))
            })
            .collect::<Result<Vec<_>, Error>>()?;
        sweep::part::merge(&parts, allow_long)
    })?
    .map_err(|e| to_py(py, e, Input::Scenario))?;
    let (spec, grid, mut results) = merged;
    results.sort_by_key(|r| r.index);
    let rows: Vec<&sweep::PointResult> = results.iter().collect();
    table(py, sweep_report::table(&grid, spec.time_domain, &rows))
}

/// The points of the grid of `axes` (as [`sweep_grid`] takes them), in grid order: the
/// swept paths and, per point, its values; refused above the sweep's limit of points
/// unless `allow_long`.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn sweep_points<'py>(
    py: Python<'py>,
    axes: Vec<(String, Bound<'py, PyAny>)>,
    allow_long: bool,
) -> PyResult<(Vec<String>, Vec<Vec<Bound<'py, PyAny>>>)> {
    let specs: Vec<String> = axes
        .iter()
        .map(|(p, v)| axis_spec(p, v))
        .collect::<PyResult<_>>()?;
    let grid = (|| -> Result<sweep::Grid, Error> {
        let shape = sweep::Shape::of(&specs)?;
        codegen_cli::budget::refuse_above(
            "sweep points",
            &[codegen_cli::budget::Quantity::count(
                "grid points",
                shape.points as f64,
                codegen_cli::budget::MAX_SWEEP_POINTS,
            )],
            "use fewer values per axis",
            allow_long,
        )?;
        Ok(sweep::Grid::parse(&specs)?)
    })()
    .map_err(|e| to_py(py, e, Input::Scenario))?;
    let paths = grid.axes.iter().map(|a| a.path.clone()).collect();
    let points = (0..grid.len())
        .map(|i| {
            grid.point(i)
                .iter()
                .map(|v| to_python(py, &json_value(v)))
                .collect()
        })
        .collect::<PyResult<_>>()?;
    Ok((paths, points))
}

/// The linear stationary response to the scenario's random excitations as `damper random
/// --json` prints it (`outputs`, `generators`, `method`, ...), as a JSON object; refused
/// above the limits of `damper random` unless `allow_long`.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn random<'py>(
    py: Python<'py>,
    text: String,
    file: String,
    base: String,
    sets: Vec<(String, Bound<'py, PyAny>)>,
    outputs: Vec<String>,
    method: String,
    modes: usize,
    allow_long: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let method = codegen_cli::random::RandomMethod::parse(&method).ok_or_else(|| {
        PyValueError::new_err(format!(
            "method {method:?}: expected auto, dense, modal or quadrature"
        ))
    })?;
    let src = Source::new(text, file, base, sets)?;
    let request = RandomRequest {
        file: src.file.clone(),
        options: codegen_cli::random::RandomOptions {
            method,
            modes,
            outputs,
            points: vec![],
        },
        allow_long,
    };
    stationary::check(&request).map_err(|e| to_py(py, e, Input::Scenario))?;
    let report = interruptible(py, || {
        let loaded = src.load(allow_long)?;
        stationary::random(&request, &loaded)
    })?
    .map_err(|e| to_py(py, e, Input::Scenario))?;
    to_python(py, &report)
}

/// The figures the scenario offers to `sweep` and `optimize` (`damper figures --json`): a
/// list of `{name, unit, producer, gradient, on_request, meaning}`.
#[pyfunction]
pub fn figures<'py>(
    py: Python<'py>,
    text: String,
    file: String,
    base: String,
    sets: Vec<(String, Bound<'py, PyAny>)>,
) -> PyResult<Bound<'py, PyAny>> {
    let src = Source::new(text, file, base, sets)?;
    let listed = interruptible(py, || {
        src.check()
            .map(|l| codegen_cli::analysis::figures::listing(&l.scenario))
    })?
    .map_err(|e| to_py(py, e, Input::Scenario))?;
    to_python(py, &listed)
}

/// The best design as `damper optimize --json` prints it (the optimum, the objective, every
/// constraint, the KKT residual, the history), as a JSON object, and the table of
/// `optimize_history.csv` ([`codegen_cli::report::optimize::history_table`]).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn optimize<'py>(
    py: Python<'py>,
    text: String,
    file: String,
    base: String,
    sets: Vec<(String, Bound<'py, PyAny>)>,
    vary: Vec<String>,
    objective: String,
    maximize: bool,
    constraints: Vec<String>,
    grid: usize,
    allow_long: bool,
) -> PyResult<(Bound<'py, PyAny>, Columns<'py>)> {
    let src = Source::new(text, file, base, sets)?;
    let path = src.path();
    let outcome = interruptible(py, || {
        codegen_cli::analysis::optimization::solve(&OptimizeRequest {
            scenario: path.clone(),
            text: src.text.clone(),
            fixed: src.overrides.clone(),
            vary: vary.clone(),
            objective: objective.clone(),
            maximize,
            constraints: constraints.clone(),
            grid,
            method: codegen_cli::random::RandomMethod::Auto,
            allow_long,
        })
    })?
    .map_err(|e| to_py(py, e, Input::Scenario))?;
    let (outcome, constraints) = outcome;
    let history = codegen_cli::report::optimize::history_table(&outcome, &constraints);
    Ok((to_python(py, &outcome)?, table(py, history)?))
}
