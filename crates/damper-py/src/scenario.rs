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
use codegen_cli::report::frf::NonlinearColumn;
use codegen_cli::scenario::{self, Loaded, Override, Scenario};
use hybrid_core::hybrid::EigenMethod;
use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyList;

use crate::convert::{array1, array2, axis_spec, json, matrix, overrides, to_python};
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

/// Named columns: a list of `(name, array)`.
type Columns<'py> = Vec<(String, Bound<'py, PyArray1<f64>>)>;

fn columns(py: Python<'_>, rows: codegen_cli::report::rows::ColumnRows) -> Columns<'_> {
    rows.into_columns()
        .into_iter()
        .map(|(n, c)| (n, array1(py, c)))
        .collect()
}

/// Runs a scenario as `damper simulate` does, in memory: `(summary.json bytes, columns of
/// the time history, [(comparison key, its columns)])`.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn simulate<'py>(
    py: Python<'py>,
    text: String,
    file: String,
    base: String,
    sets: Vec<(String, Bound<'py, PyAny>)>,
    allow_long: bool,
) -> PyResult<(Bound<'py, PyAny>, Columns<'py>, Vec<(String, Columns<'py>)>)> {
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
    Ok((summary, columns(py, out.rows), comparisons))
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
        .map(|m| shapes(py, m))
        .transpose()?;
    let dense = dense
        .map(|(m, c, k)| Ok::<_, PyErr>((matrix(py, m)?, matrix(py, c)?, matrix(py, k)?)))
        .transpose()?;
    Ok((to_python(py, &report)?, with, off, bare, dense))
}

/// The frequency response as `damper frf` writes it: the columns of `frf.csv` under the
/// same headers and, with `nonlinear` (`--nonlinear M`), those of `frf_nonlinear.csv`:
/// numbers as float arrays (NaN for an empty cell), `periods` an int64 array, `settled` a
/// bool array, `error` a list of `str` or `None`. The runs release the GIL and stop at
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
) -> PyResult<(Columns<'py>, Option<Vec<(String, Bound<'py, PyAny>)>>)> {
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
        Ok((frf.columns(), frf.nonlinear_columns(), frf.warnings))
    })?
    .map_err(|e| to_py(py, e, Input::Scenario))?;
    warn(py, &warnings)?;
    let nl = nl
        .map(|cols| {
            cols.into_iter()
                .map(|(n, c)| Ok((n, nonlinear_column(py, c)?)))
                .collect::<PyResult<Vec<_>>>()
        })
        .transpose()?;
    Ok((
        cols.into_iter().map(|(n, c)| (n, array1(py, c))).collect(),
        nl,
    ))
}

/// A column of `frf_nonlinear.csv` as Python holds it (see [`frf`]).
fn nonlinear_column(py: Python<'_>, column: NonlinearColumn) -> PyResult<Bound<'_, PyAny>> {
    use NonlinearColumn as C;
    Ok(match column {
        C::Numbers(v) => {
            array1(py, v.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect()).into_any()
        }
        C::Counts(v) => {
            PyArray1::from_vec(py, v.into_iter().map(|n| n as i64).collect::<Vec<i64>>()).into_any()
        }
        C::Flags(v) => PyArray1::from_vec(py, v).into_any(),
        C::Texts(v) => PyList::new(py, v)?.into_any(),
        _ => {
            return Err(pyo3::exceptions::PyRuntimeError::new_err(
                "an unknown column kind of frf_nonlinear.csv (a bug: please report it)",
            ));
        }
    })
}

/// A sweep as `damper sweep` computes it (`axes`: `(path, values)` pairs, the values a list
/// or a VALUES string): the columns of `sweep.csv` in order — `index`, each axis (a list of
/// its values), each figure `name [unit]` (NaN where the point does not give it), `error`
/// and, in the time domain, `time_domain_error` (lists of `str` or `None`).
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
) -> PyResult<Vec<(String, Bound<'py, PyAny>)>> {
    if threads == Some(0) {
        return Err(PyValueError::new_err("threads must be at least 1"));
    }
    let src = Source::new(text, file, base, sets)?;
    let specs: Vec<String> = axes
        .iter()
        .map(|(p, v)| axis_spec(p, v))
        .collect::<PyResult<_>>()?;
    let request = SweepRequest {
        scenario: src.path(),
        text: Some(src.text.clone()),
        fixed: src.overrides.clone(),
        sets: specs,
        shard: None,
        t_end: None,
        time_domain,
        constraints: vec![],
        map: "linear.zeta1".into(),
        minimize: false,
        threads,
        method: codegen_cli::random::RandomMethod::Auto,
        allow_long,
    };
    let (sweep::Sweep { grid, results, .. }, warnings) = interruptible(py, || {
        // The scenario and the fixed overrides must load before any point.
        src.check()?;
        let plan = sweep::plan(&request)?;
        Ok((sweep::evaluate(&request, &plan, &|| {})?, plan.warnings))
    })?
    .map_err(|e| to_py(py, e, Input::Scenario))?;
    warn(py, &warnings)?;
    let rows: Vec<&sweep::PointResult> = results.iter().collect();
    let heads = sweep::figure_heads(&rows);
    let mut out: Vec<(String, Bound<'py, PyAny>)> = vec![];
    let index: Vec<f64> = results.iter().map(|r| r.index as f64).collect();
    out.push((
        "index".into(),
        array1(py, index).call_method1("astype", ("int64",))?,
    ));
    for (k, axis) in grid.axes.iter().enumerate() {
        let values = PyList::empty(py);
        for r in &results {
            let v = grid.point(r.index)[k];
            values.append(toml_to_py(py, v)?)?;
        }
        out.push((axis.path.clone(), values.into_any()));
    }
    for (name, unit) in &heads {
        let column: Vec<f64> = results
            .iter()
            .map(|r| {
                r.figures
                    .iter()
                    .find(|f| f.name == *name)
                    .and_then(|f| f.value)
                    .unwrap_or(f64::NAN)
            })
            .collect();
        out.push((format!("{name} [{unit}]"), array1(py, column).into_any()));
    }
    let errors =
        |of: &dyn Fn(&sweep::PointResult) -> Option<String>| -> PyResult<Bound<'py, PyAny>> {
            let list = PyList::empty(py);
            for r in &results {
                list.append(of(r))?;
            }
            Ok(list.into_any())
        };
    out.push(("error".into(), errors(&|r| r.error.clone())?));
    if time_domain {
        out.push((
            "time_domain_error".into(),
            errors(&|r| r.time_domain_error.clone())?,
        ));
    }
    Ok(out)
}

/// A TOML value as the Python value it reads as.
fn toml_to_py<'py>(py: Python<'py>, v: &toml_edit::Value) -> PyResult<Bound<'py, PyAny>> {
    to_python(py, &codegen_cli::scenario::overrides::json_value(v))
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
/// constraint, the KKT residual, the history), as a JSON object.
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
) -> PyResult<Bound<'py, PyAny>> {
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
        .map(|(outcome, _)| outcome)
    })?
    .map_err(|e| to_py(py, e, Input::Scenario))?;
    to_python(py, &outcome)
}
