//! Python values to the library's and back: `set` overrides, JSON, numpy arrays, and the
//! report's tables ([`table`]).
//!
//! Arrays are handed to numpy without a copy per element: a `Vec<f64>` the library filled is
//! moved into the array (`PyArray1::from_vec` keeps the allocation), a matrix is that buffer
//! reshaped (a view, no copy).

use codegen_cli::report::rows::{Cells, Table};
use codegen_cli::scenario::Override;
use codegen_cli::scenario::overrides::{json_value, parse_value, value_text};
use numpy::npyffi::NPY_ORDER;
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyFloat, PyInt, PyList, PyRange, PyString, PyTuple};
use toml_edit::{Array, Value};

/// How deep lists may nest in a scenario value (the scenario's deepest values are lists of
/// pairs: depth 2); deeper is refused before the conversion can exhaust the stack.
pub const MAX_DEPTH: usize = 32;

/// A Python value as the TOML value of a `--set`: `bool`, `int` (numpy integers too),
/// `float`, a list, tuple or 1-D numpy array of those, or a `str` read as the command line
/// reads VALUE (a TOML value, a bare word a string). `TypeError` for any other type
/// (`bytes`, complex numbers, mappings, sets); `ValueError` for lists nested deeper than
/// [`MAX_DEPTH`] or containing themselves.
pub fn toml_value(v: &Bound<'_, PyAny>) -> PyResult<Value> {
    toml_value_in(v, &mut vec![])
}

/// [`toml_value`] inside the containers `open` (their addresses, outermost first).
fn toml_value_in(v: &Bound<'_, PyAny>, open: &mut Vec<usize>) -> PyResult<Value> {
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
        let id = v.as_ptr() as usize;
        if open.contains(&id) {
            return Err(PyValueError::new_err(
                "set: a list that contains itself cannot be a scenario value",
            ));
        }
        if open.len() >= MAX_DEPTH {
            return Err(PyValueError::new_err(format!(
                "set: lists nested more than {MAX_DEPTH} deep cannot be a scenario value"
            )));
        }
        open.push(id);
        let mut array = Array::new();
        let items: Vec<Bound<'_, PyAny>> = v.try_iter()?.collect::<PyResult<_>>()?;
        for item in &items {
            array.push(toml_value_in(item, open)?);
        }
        open.pop();
        return Ok(Value::Array(array));
    }
    // numpy scalars and arrays by their dtype's kind: b(ool), i/u (integers), f(loat).
    if let Ok(kind) = v.getattr("dtype").and_then(|d| d.getattr("kind")) {
        let kind: String = kind.extract().unwrap_or_default();
        let ndim: usize = v.getattr("ndim").and_then(|n| n.extract()).unwrap_or(0);
        if ndim > 0 && matches!(kind.as_str(), "b" | "i" | "u" | "f") {
            return toml_value_in(&v.call_method0("tolist")?, open);
        }
        match kind.as_str() {
            "b" => return Ok(Value::from(v.is_truthy()?)),
            "i" | "u" => {
                let n = v.call_method0("__index__")?.extract::<i64>().map_err(|_| {
                    PyValueError::new_err(format!(
                        "set: {} does not fit a 64-bit integer",
                        v.repr().map(|r| r.to_string()).unwrap_or_default()
                    ))
                })?;
                return Ok(Value::from(n));
            }
            "f" => return Ok(Value::from(v.extract::<f64>()?)),
            _ => {}
        }
    }
    Err(PyTypeError::new_err(format!(
        "set: cannot use {} of type {} as a scenario value (bool, int, float, str or a list of them)",
        short_repr(v),
        v.get_type()
            .name()
            .map(|n| n.to_string())
            .unwrap_or_default()
    )))
}

/// `repr(v)`, cut to 60 characters.
fn short_repr(v: &Bound<'_, PyAny>) -> String {
    let r = v.repr().map(|r| r.to_string()).unwrap_or_default();
    match r.char_indices().nth(60) {
        Some((at, _)) => format!("{}...", &r[..at]),
        None => r,
    }
}

/// The overrides of `(path, value)` pairs, in order.
pub fn overrides(sets: &[(String, Bound<'_, PyAny>)]) -> PyResult<Vec<Override>> {
    sets.iter()
        .map(|(path, v)| {
            if let Ok(s) = v.cast::<crate::structure::PyStructure>() {
                if path != "structure" {
                    return Err(PyValueError::new_err(format!(
                        "set {path}: a given structure replaces `structure`, not `{path}`"
                    )));
                }
                return s.get().to_override();
            }
            let value = toml_value(v)?;
            let text = value_text(&value);
            Override::new(path, value, &text)
                .map_err(|e| PyValueError::new_err(format!("set {path}={text}: {e}")))
        })
        .collect()
}

/// The VALUES text of a sweep axis (`PATH=VALUES`): the values' TOML texts, comma
/// separated, or a string as written (`"0.1:0.5:5"`). The values: a list, tuple, range or
/// 1-D numpy array (`TypeError` for `bytes`, mappings, sets and other types).
pub fn axis_spec(path: &str, values: &Bound<'_, PyAny>) -> PyResult<String> {
    if values.is_instance_of::<PyString>() {
        return Ok(format!("{path}={}", values.extract::<String>()?));
    }
    let list = if values.hasattr("tolist")? && values.hasattr("dtype")? {
        values.call_method0("tolist")?
    } else {
        values.clone()
    };
    if !(list.is_instance_of::<PyList>()
        || list.is_instance_of::<PyTuple>()
        || list.is_instance_of::<PyRange>())
    {
        return Err(PyTypeError::new_err(format!(
            "sweep axis {path}: the values must be a list, tuple, range, numpy array or a VALUES string, not {}",
            list.get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_default()
        )));
    }
    let items: Vec<Bound<'_, PyAny>> = list.try_iter()?.collect::<PyResult<_>>()?;
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

/// One column of a table as Python receives it: `(name, unit or None, values)`.
pub type PyColumn<'py> = (String, Option<String>, Bound<'py, PyAny>);

/// A table of the report ([`Table`]: the columns of a CSV the command writes) as Python's
/// columns, each `(name, unit, values)`: numbers a float array (NaN for an empty cell),
/// counts an int64 array, flags a bool array, texts a list of `str` or `None`, scenario
/// values (a sweep's axis) a list of the Python values they read as.
pub fn table<'py>(py: Python<'py>, table: Table) -> PyResult<Vec<PyColumn<'py>>> {
    table
        .columns
        .into_iter()
        .map(|c| {
            let values = match c.cells {
                Cells::Numbers(v) => {
                    array1(py, v.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect()).into_any()
                }
                Cells::Counts(v) => {
                    PyArray1::from_vec(py, v.into_iter().map(|n| n as i64).collect::<Vec<i64>>())
                        .into_any()
                }
                Cells::Flags(v) => PyArray1::from_vec(py, v).into_any(),
                Cells::Texts(v) => PyList::new(py, v)?.into_any(),
                Cells::Values(v) => {
                    let list = PyList::empty(py);
                    for x in &v {
                        list.append(to_python(py, &json_value(x))?)?;
                    }
                    list.into_any()
                }
                _ => {
                    return Err(pyo3::exceptions::PyRuntimeError::new_err(
                        "an unknown column kind of a table (a bug: please report it)",
                    ));
                }
            };
            Ok((c.name, c.unit, values))
        })
        .collect()
}
