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
//! - invalid arguments (`ValueError`; `TypeError` for a wrong type), every other failure
//!   `DamperError`.
//!
//! - a warning of an analysis (a result still computed: a peak at an edge of the frf band)
//!   is issued through `warnings.warn` as a `DamperWarning` (a subclass of `UserWarning`)
//!   carrying `file` and `entity` (`None` where not known) ([`warn`]).
//!
//! The exceptions belong to the public module `damper` (their `__module__`), so that they
//! pickle: `multiprocessing` and `concurrent.futures` bring a worker's exception to the
//! parent as it was raised, with its attributes.

use codegen_cli::Error;
use diagnostic::Diagnostics;
use hybrid_core::hybrid::HybridError;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;

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

/// The Python exception of a library error (`input`: what a diagnostic is about).
pub fn to_py(py: Python<'_>, e: Error, input: Input) -> PyErr {
    match e {
        Error::Input(d) => diagnostics(py, &d, input),
        Error::Usage(m) => PyValueError::new_err(m),
        Error::Interrupted => pyo3::exceptions::PyKeyboardInterrupt::new_err("interrupted"),
        Error::Hybrid { file, error } | Error::Damper { file, error } => match &error {
            HybridError::Singular {
                t,
                mechanism,
                displacement,
                reach,
                ..
            } => {
                let err = SingularPosition::new_err(format!("{file}: {error}"));
                let value = err.value(py);
                let set = || -> PyResult<()> {
                    value.setattr("time", *t)?;
                    value.setattr("distance", *displacement)?;
                    value.setattr("reach", *reach)?;
                    value.setattr("mechanism", mechanism.clone())?;
                    Ok(())
                };
                match set() {
                    Ok(()) => err,
                    Err(e) => e,
                }
            }
            _ => DamperError::new_err(format!("{file}: {error}")),
        },
        e => DamperError::new_err(e.to_string()),
    }
}
