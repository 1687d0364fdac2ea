//! The Python exceptions of the package and the mapping of the library's errors onto them.
//!
//! - problems in a scenario file (or a `set` override) raise `ScenarioError`, in a mechanism
//!   model file `ModelError`, both subclasses of `ValueError` carrying `file`, `line`,
//!   `column`, `entity` and `message` of the first problem (the exception's text lists
//!   every problem, one a line, as the command line prints them);
//! - a run stopped at a singular (toggle) position raises `SingularPosition` with `time`,
//!   `distance` (the displacement of the mechanism's first attached beam point there),
//!   `reach` and `mechanism`;
//! - an interrupted run raises `KeyboardInterrupt` (the one Python raised);
//! - an analysis that refuses the request or cannot give its result
//!   ([`codegen_cli::analysis::AnalysisError`]) raises the `DamperError` subclass of its kind
//!   with its fields ([`ANALYSIS`]): `ArgumentError` (`argument`, `option`; also a
//!   `ValueError`), `UnknownName` (`what`, `name`, `nearest`, `file`; also a `ValueError`),
//!   `NotAvailable` and `NumericalError` (`file`), `OptimizationError` (`file`,
//!   `evaluations`, `least_infeasible`), `MergeError` (`path`), `ResourceError`; a run
//!   above the work limits `WorkLimitError`; a simulation that stopped `SimulationError`
//!   (`file`, `time`), a failed linearisation `NumericalError` (`file`); every one carries
//!   `message`, the line the command line prints;
//! - invalid arguments the package checks itself (`ValueError`; `TypeError` for a wrong
//!   type), every other failure `DamperError`.
//!
//! - a warning of an analysis (a result still computed: a peak at an edge of the frf band)
//!   is issued through `warnings.warn` as a `DamperWarning` (a subclass of `UserWarning`)
//!   carrying `file` and `entity` (`None` where not known) ([`warn`]).
//!
//! The exceptions belong to the public module `damper` (their `__module__`), so that they
//! pickle: `multiprocessing` and `concurrent.futures` bring a worker's exception to the
//! parent as it was raised, with its attributes.

use codegen_cli::Error;
use codegen_cli::analysis::AnalysisError;
use codegen_cli::analysis::figures::ConstraintError;
use codegen_cli::analysis::sweep::SpecError;
use codegen_cli::optimize::OptimizeError;
use diagnostic::Diagnostics;
use hybrid_core::hybrid::HybridError;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple, PyType};

pyo3::create_exception!(
    damper,
    ScenarioError,
    PyValueError,
    "A scenario file (or an override of it) that cannot be used: `file`, `line`, `column`, `entity`, `message` of the first problem."
);
pyo3::create_exception!(
    damper,
    ModelError,
    PyValueError,
    "A mechanism model file that cannot be used: `file`, `line`, `column`, `entity`, `message` of the first problem."
);
pyo3::create_exception!(
    damper,
    DamperError,
    PyException,
    "A computation that failed (no equilibrium, a run that diverged, an output limit)."
);
pyo3::create_exception!(
    damper,
    SingularPosition,
    DamperError,
    "A run stopped at a singular (toggle) position: `time` (s), `distance` (m, the displacement of the mechanism's first attached beam point), `reach` (m or None), `mechanism`."
);

pyo3::create_exception!(
    damper,
    DamperWarning,
    pyo3::exceptions::PyUserWarning,
    "A warning of an analysis whose result is still computed (a peak at an edge of the band): `file`, `entity` (None where not known)."
);

/// A `DamperError` subclass of a typed failure: its name in the module `damper`, whether it
/// is also a `ValueError` (a refused argument), its documentation.
pub struct Class {
    /// The class name (`damper.NAME`).
    pub name: &'static str,
    /// Also a subclass of `ValueError`.
    pub value_error: bool,
    /// The docstring.
    pub doc: &'static str,
}

/// The `DamperError` subclasses of the typed failures, in the order of [`Kind`].
pub const ANALYSIS: [Class; 8] = [
    Class {
        name: "ArgumentError",
        value_error: true,
        doc: "An argument outside its range or of the wrong form: `argument` (the keyword, `points`), `option` (the command line's `--points`), `message`.",
    },
    Class {
        name: "UnknownName",
        value_error: true,
        doc: "A name the scenario or model does not have: `what` (`figure`, `output`, `mechanism`, `coordinate`, `excitation`, `parameter`), `name`, `nearest` (the valid names to suggest, closest first), `file` (or None), `message`.",
    },
    Class {
        name: "NotAvailable",
        value_error: false,
        doc: "The scenario cannot give what was asked (no excitation, no beam, no mode, a figure missing at a design point): `file` (or None), `message`.",
    },
    Class {
        name: "NumericalError",
        value_error: false,
        doc: "A computation failed on this scenario (no static equilibrium, a singular dynamic stiffness): `file` (or None), `message`.",
    },
    Class {
        name: "OptimizationError",
        value_error: false,
        doc: "The optimisation cannot be posed or found no feasible point: `file`, `evaluations` and `least_infeasible` (None when nothing was evaluated), `message`.",
    },
    Class {
        name: "MergeError",
        value_error: false,
        doc: "Sweep part files that cannot be joined: `path` (the part file or directory at fault), `message`.",
    },
    Class {
        name: "ResourceError",
        value_error: false,
        doc: "The machine cannot provide what a call needs to start (worker threads, memory): `message`.",
    },
    Class {
        name: "WorkLimitError",
        value_error: false,
        doc: "The estimated work is above the limits of the command line (pass allow_long=True to insist): `message`.",
    },
];

/// Index into [`ANALYSIS`] (and the extra classes of run failures).
#[derive(Clone, Copy)]
enum Kind {
    Argument = 0,
    Unknown = 1,
    NotAvailable = 2,
    Numerical = 3,
    Optimization = 4,
    Merge = 5,
    Resource = 6,
    WorkLimit = 7,
}

pyo3::create_exception!(
    damper,
    SimulationError,
    DamperError,
    "A simulation that stopped before its end (no convergence, divergence; nothing written): `file`, `time` (s, or None), `message`."
);

/// The classes of [`ANALYSIS`], created once per interpreter (`type(name, (DamperError[,
/// ValueError]), {...})`, their `__module__` `damper` so that they pickle).
fn classes(py: Python<'_>) -> PyResult<&'static [Py<PyType>]> {
    static CLASSES: PyOnceLock<Vec<Py<PyType>>> = PyOnceLock::new();
    CLASSES
        .get_or_try_init(py, || {
            let make = py.import("builtins")?.getattr("type")?;
            ANALYSIS
                .iter()
                .map(|c| {
                    let base = py.get_type::<DamperError>().into_any();
                    let bases = if c.value_error {
                        PyTuple::new(py, [base, py.get_type::<PyValueError>().into_any()])?
                    } else {
                        PyTuple::new(py, [base])?
                    };
                    let dict = PyDict::new(py);
                    dict.set_item("__module__", "damper")?;
                    dict.set_item("__doc__", c.doc)?;
                    Ok(make
                        .call1((c.name, bases, dict))?
                        .cast_into::<PyType>()?
                        .unbind())
                })
                .collect()
        })
        .map(|v| v.as_slice())
}

/// Adds the classes of [`ANALYSIS`] and `SimulationError` to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    for (class, ty) in ANALYSIS.iter().zip(classes(py)?) {
        m.add(class.name, ty.bind(py))?;
    }
    m.add("SimulationError", py.get_type::<SimulationError>())
}

/// An exception of `kind` with text `message` (also its `message` attribute) and `fields`.
fn raise<'py>(
    py: Python<'py>,
    kind: Kind,
    message: String,
    fields: &[(&str, Bound<'py, PyAny>)],
) -> PyErr {
    let make = || -> PyResult<PyErr> {
        let value = classes(py)?[kind as usize]
            .bind(py)
            .call1((message.clone(),))?;
        value.setattr("message", &message)?;
        for (name, v) in fields {
            value.setattr(*name, v)?;
        }
        Ok(PyErr::from_value(value))
    };
    make().unwrap_or_else(|e| e)
}

/// `v` as a Python object (`None` if it cannot be converted, which a string, a number or a
/// list of strings always can).
fn value<'py>(py: Python<'py>, v: impl pyo3::IntoPyObject<'py>) -> Bound<'py, PyAny> {
    use pyo3::IntoPyObjectExt;
    v.into_bound_py_any(py)
        .unwrap_or_else(|_| py.None().into_bound(py))
}

/// The keyword of a command-line option (`--steps-per-period` → `steps_per_period`; a
/// sweep's `--set` is `axes`, `--constraint` is `constraints`).
fn keyword(option: &str) -> String {
    match option {
        "--set" => "axes".into(),
        "--constraint" => "constraints".into(),
        _ => option.trim_start_matches('-').replace('-', "_"),
    }
}

/// The Python exception of an analysis error, with its fields.
pub fn analysis(py: Python<'_>, e: AnalysisError) -> PyErr {
    let message = e.to_string();
    let obj = |v: Option<&str>| value(py, v);
    match e {
        AnalysisError::Argument { argument, .. } => raise(
            py,
            Kind::Argument,
            message,
            &[
                ("argument", obj(Some(&keyword(&argument)))),
                ("option", obj(Some(&argument))),
            ],
        ),
        AnalysisError::UnknownName {
            what,
            name,
            nearest,
            file,
            ..
        } => {
            let nearest = value(py, nearest);
            raise(
                py,
                Kind::Unknown,
                message,
                &[
                    ("what", obj(Some(what))),
                    ("name", obj(Some(&name))),
                    ("nearest", nearest),
                    ("file", obj(file.as_deref())),
                ],
            )
        }
        AnalysisError::Unavailable { file, .. } => raise(
            py,
            Kind::NotAvailable,
            message,
            &[("file", obj(file.as_deref()))],
        ),
        AnalysisError::Numerical { file, .. } => raise(
            py,
            Kind::Numerical,
            message,
            &[("file", obj(file.as_deref()))],
        ),
        AnalysisError::Optimization { file, error } => {
            let (evaluations, point) = match error {
                OptimizeError::Infeasible { evaluations, point } => {
                    (Some(evaluations), Some(point))
                }
                _ => (None, None),
            };
            let evaluations = value(py, evaluations);
            raise(
                py,
                Kind::Optimization,
                message,
                &[
                    ("file", obj(Some(&file))),
                    ("evaluations", evaluations),
                    ("least_infeasible", obj(point.as_deref())),
                ],
            )
        }
        AnalysisError::Merge { path, .. } => {
            raise(py, Kind::Merge, message, &[("path", obj(Some(&path)))])
        }
        AnalysisError::Resources { .. } => raise(py, Kind::Resource, message, &[]),
        _ => DamperError::new_err(message),
    }
}

/// The Python exception of a refused grid or constraint specification: an unknown figure
/// is `UnknownName`, every other problem `ArgumentError` (of `axes`, `vary`, `constraints`).
fn spec(py: Python<'_>, e: SpecError) -> PyErr {
    let (option, unknown) = match &e {
        SpecError::Map(u) => ("--map", Some(u.clone())),
        SpecError::Constraint(ConstraintError::Figure { unknown, .. }) => {
            ("--constraint", Some(unknown.clone()))
        }
        SpecError::Constraint(ConstraintError::Syntax { .. }) => ("--constraint", None),
        SpecError::Vary { .. } => ("--vary", None),
        SpecError::Shard { .. } => ("--shard", None),
        _ => ("--set", None),
    };
    let message = e.to_string();
    match unknown {
        Some(u) => analysis(
            py,
            AnalysisError::UnknownName {
                what: "figure",
                name: u.name,
                nearest: u.nearest,
                file: None,
                message,
            },
        ),
        None => analysis(py, AnalysisError::argument(option, message)),
    }
}

/// Issues every warning of a result through Python's `warnings.warn`, as a `DamperWarning`
/// with `file` and `entity`, attributed to the caller of the public function (`stacklevel`
/// 2: the user's code, not the package's wrapper).
pub fn warn(py: Python<'_>, warnings: &[codegen_cli::analysis::Warning]) -> PyResult<()> {
    let module = py.import("warnings")?;
    for w in warnings {
        let message = match (&w.file, w.note) {
            (Some(file), false) => format!("{file}: {}", w.message),
            _ => w.message.clone(),
        };
        let value = py.get_type::<DamperWarning>().call1((message,))?;
        value.setattr("file", w.file.clone())?;
        value.setattr("entity", w.entity.clone())?;
        let kwargs = pyo3::types::PyDict::new(py);
        kwargs.set_item("stacklevel", 2)?;
        module.call_method("warn", (value,), Some(&kwargs))?;
    }
    Ok(())
}

/// Which kind of input file a diagnostic is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Input {
    /// A scenario file.
    Scenario,
    /// A mechanism model file.
    Model,
}

/// `ScenarioError` or `ModelError` with the first problem's position as attributes.
pub fn diagnostics(py: Python<'_>, d: &Diagnostics, input: Input) -> PyErr {
    let err = match input {
        Input::Scenario => ScenarioError::new_err(d.to_string()),
        Input::Model => ModelError::new_err(d.to_string()),
    };
    let first = d.iter().next();
    let value = err.value(py);
    let set = || -> PyResult<()> {
        value.setattr("file", first.map(|f| f.file.clone()))?;
        value.setattr("line", first.and_then(|f| f.line))?;
        value.setattr("column", first.and_then(|f| f.column))?;
        value.setattr("entity", first.and_then(|f| f.entity.clone()))?;
        value.setattr("message", first.map(|f| f.message.clone()))?;
        Ok(())
    };
    match set() {
        Ok(()) => err,
        Err(e) => e,
    }
}

/// A `SimulationError` with `file` and `time` (None where the run did not start).
fn simulation(py: Python<'_>, message: String, file: String, time: Option<f64>) -> PyErr {
    let err = SimulationError::new_err(message.clone());
    let value = err.value(py);
    let set = || -> PyResult<()> {
        value.setattr("message", &message)?;
        value.setattr("file", file)?;
        value.setattr("time", time)?;
        Ok(())
    };
    match set() {
        Ok(()) => err,
        Err(e) => e,
    }
}

/// The Python exception of a library error (`input`: what a diagnostic is about).
pub fn to_py(py: Python<'_>, e: Error, input: Input) -> PyErr {
    let text = e.to_string();
    match e {
        Error::Input(d) => diagnostics(py, &d, input),
        Error::Usage(m) => PyValueError::new_err(m),
        Error::Analysis(e) => analysis(py, e),
        Error::Sweep(e) => spec(py, e),
        Error::TooLong(m) => raise(py, Kind::WorkLimit, m, &[]),
        Error::Interrupted => pyo3::exceptions::PyKeyboardInterrupt::new_err("interrupted"),
        Error::Linear { file, .. } => {
            raise(py, Kind::Numerical, text, &[("file", value(py, file))])
        }
        Error::Stopped { file, t, .. } => simulation(py, text, file, Some(t)),
        Error::Start { file, .. } => simulation(py, text, file, None),
        Error::Hybrid { file, error } | Error::Damper { file, error } => match &error {
            HybridError::Singular {
                t,
                mechanism,
                displacement,
                reach,
                ..
            } => {
                let err = SingularPosition::new_err(text);
                let value = err.value(py);
                let set = || -> PyResult<()> {
                    value.setattr("time", *t)?;
                    value.setattr("distance", *displacement)?;
                    value.setattr("reach", *reach)?;
                    value.setattr("mechanism", mechanism.clone())?;
                    value.setattr("file", file.clone())?;
                    Ok(())
                };
                match set() {
                    Ok(()) => err,
                    Err(e) => e,
                }
            }
            _ => simulation(py, text, file, None),
        },
        _ => DamperError::new_err(text),
    }
}
