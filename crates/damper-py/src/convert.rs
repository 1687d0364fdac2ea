//! Python values to the library's and back: `set` overrides, JSON, numpy arrays.
//!
//! Arrays are handed to numpy without a copy per element: a `Vec<f64>` the library filled is
//! moved into the array (`PyArray1::from_vec` keeps the allocation), a matrix is that buffer
//! reshaped (a view, no copy).

use codegen_cli::scenario::Override;
use codegen_cli::scenario::overrides::{parse_value, value_text};
use numpy::npyffi::NPY_ORDER;
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyFloat, PyInt, PyList, PyString, PyTuple};
use toml_edit::{Array, Value};

/// A Python value as the TOML value of a `--set`: `bool`, `int`, `float`, a list or tuple of
/// those, or a `str` read as the command line reads VALUE (a TOML value, a bare word a
/// string).
pub fn toml_value(v: &Bound<'_, PyAny>) -> PyResult<Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(Value::from(v.extract::<bool>()?));
    }
    if v.is_instance_of::<PyInt>() {
        return Ok(Value::from(v.extract::<i64>()?));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(Value::from(v.extract::<f64>()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(parse_value(v.extract::<String>()?.trim()));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items: Vec<Bound<'_, PyAny>> = v.try_iter()?.collect::<PyResult<_>>()?;
        let mut array = Array::new();
        for item in &items {
            array.push(toml_value(item)?);
        }
        return Ok(Value::Array(array));
    }
    // numpy scalars and other numbers: as a float.
    match v.extract::<f64>() {
        Ok(x) => Ok(Value::from(x)),
        Err(_) => Err(PyValueError::new_err(format!(
            "set: cannot use {} as a scenario value (bool, int, float, str or a list of them)",
            v.repr()?
        ))),
    }
}

/// The overrides of `(path, value)` pairs, in order.
pub fn overrides(sets: &[(String, Bound<'_, PyAny>)]) -> PyResult<Vec<Override>> {
    sets.iter()
        .map(|(path, v)| {
            let value = toml_value(v)?;
            let text = value_text(&value);
            Override::new(path, value, &text)
                .map_err(|e| PyValueError::new_err(format!("set {path}={text}: {e}")))
        })
        .collect()
}

/// The VALUES text of a sweep axis (`PATH=VALUES`): the values' TOML texts, comma
/// separated, or a string as written (`"0.1:0.5:5"`).
pub fn axis_spec(path: &str, values: &Bound<'_, PyAny>) -> PyResult<String> {
    if values.is_instance_of::<PyString>() {
        return Ok(format!("{path}={}", values.extract::<String>()?));
    }
    let items: Vec<Bound<'_, PyAny>> = values.try_iter()?.collect::<PyResult<_>>()?;
    let texts: Vec<String> = items
        .iter()
        .map(|v| toml_value(v).map(|v| value_text(&v)))
        .collect::<PyResult<_>>()?;
    Ok(format!("{path}={}", texts.join(",")))
}

/// `json.loads(text)`.
pub fn json<'py>(py: Python<'py>, text: &[u8]) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?
        .call_method1("loads", (std::str::from_utf8(text).unwrap_or_default(),))
}

/// A serialisable value as the Python objects of its JSON form (the same content as the
/// command's `--json` output).
pub fn to_python<'py, T: serde::Serialize + ?Sized>(
    py: Python<'py>,
    value: &T,
) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_vec(value)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    json(py, &text)
}

/// A buffer moved into a 1-D array.
pub fn array1(py: Python<'_>, v: Vec<f64>) -> Bound<'_, PyArray1<f64>> {
    PyArray1::from_vec(py, v)
}

/// A row-major buffer of `rows x cols` moved into a 2-D array.
pub fn array2(
    py: Python<'_>,
    v: Vec<f64>,
    rows: usize,
    cols: usize,
) -> PyResult<Bound<'_, PyArray2<f64>>> {
    PyArray1::from_vec(py, v).reshape([rows, cols])
}

/// A column-major matrix (nalgebra's layout) moved into a 2-D array (Fortran order).
pub fn matrix(py: Python<'_>, m: nalgebra::DMatrix<f64>) -> PyResult<Bound<'_, PyArray2<f64>>> {
    let (r, c) = m.shape();
    PyArray1::from_vec(py, m.data.into()).reshape_with_order([r, c], NPY_ORDER::NPY_FORTRANORDER)
}
