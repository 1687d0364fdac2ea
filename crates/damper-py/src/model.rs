//! The mechanism model functions: what `damper eval` and `damper generate` compute, for a
//! model file. The file is read by the one safe reader (a regular file within the size
//! limit) without the GIL and interruptibly ([`interruptible`]).

use std::path::PathBuf;

use codegen_cli::Error;
use codegen_cli::analysis::eval::{self, Backend, EvalRequest};
use mbs_symbolic::emit::{EmitOptions, generate};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::convert::to_python;
use crate::errors::{Input, to_py};
use crate::watch::interruptible;

fn load(py: Python<'_>, path: &std::path::Path) -> PyResult<mbs_symbolic::model::Model> {
    interruptible(py, || mbs_symbolic::model::load(path).map_err(Error::Input))?
        .map_err(|e| to_py(py, e, Input::Model))
}

/// A model's name, its coordinate names and its parameters `(name, value, derived,
/// runtime)`.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn model_info(
    py: Python<'_>,
    path: PathBuf,
) -> PyResult<(String, Vec<String>, Vec<(String, f64, bool, bool)>)> {
    let model = load(py, &path)?;
    let params = model
        .parameters
        .iter()
        .map(|p| (p.name.clone(), p.value, p.derived, p.runtime))
        .collect();
    Ok((
        model.name.clone(),
        mbs_symbolic::runtime::coordinate_names(&model),
        params,
    ))
}

/// The JSON object `damper eval` prints for this state, backend and parameter overrides
/// (`NAME=VALUE`).
#[pyfunction]
pub fn model_eval<'py>(
    py: Python<'py>,
    path: PathBuf,
    q: Vec<f64>,
    qd: Vec<f64>,
    t: f64,
    backend: &str,
    params: Vec<String>,
) -> PyResult<Bound<'py, PyAny>> {
    if q.is_empty() || qd.is_empty() {
        return Err(PyValueError::new_err(
            "q and qd: give one value per coordinate of the model (an empty vector is not a state)",
        ));
    }
    let backend = Backend::parse(backend).ok_or_else(|| {
        PyValueError::new_err(format!(
            "backend {backend:?}: expected \"interp\", \"numeric\" or \"generated\""
        ))
    })?;
    let request = EvalRequest {
        model: path,
        q,
        qd,
        t,
        params,
        backend,
    };
    let value = interruptible(py, || eval::evaluation(&request))?
        .map_err(|e| to_py(py, e, Input::Model))?;
    to_python(py, &value)
}

/// The generated Rust source of a model (`damper generate`), and the operation count of
/// every generated function `(name, adds, muls, divs, funcs, negs, total)`.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn model_generate(
    py: Python<'_>,
    path: PathBuf,
    struct_name: Option<String>,
) -> PyResult<(String, Vec<(String, [usize; 6])>)> {
    let model = load(py, &path)?;
    let opts = EmitOptions {
        struct_name,
        ..EmitOptions::default()
    };
    let generated = py
        .detach(|| generate(&model, &opts))
        .map_err(|e| to_py(py, Error::Emit(e), Input::Model))?;
    let stats = generated
        .stats
        .iter()
        .map(|(n, c)| {
            (
                n.clone(),
                [c.adds, c.muls, c.divs, c.funcs, c.negs, c.total()],
            )
        })
        .collect();
    Ok((generated.source, stats))
}
