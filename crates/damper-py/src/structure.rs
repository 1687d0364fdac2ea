//! A structure given in memory: `damper.Structure.from_matrices` (the matrices as 0-based
//! `(row, column, value)` entries the Python side extracts from numpy or scipy.sparse, the
//! node and DOF tables as rows of texts) checked by the library's one validator
//! ([`fem_structure::StructureParts::new`]: what the files' readers check, with the argument
//! and row in each message), then carried to every call as the override
//! [`Override::structure`] (`structure = { kind = "given", ... }`), which the loader reads in
//! place of `[structure]`'s files.

use std::sync::Arc;

use codegen_cli::Error;
use codegen_cli::scenario::Override;
use fem_structure::StructureParts;
use numpy::{PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use toml_edit::{Array, InlineTable, Value};

use crate::errors::{Input, to_py};
use crate::watch::interruptible;

/// A structure given in memory, checked; what `Scenario.load(..., structure=...)` carries.
#[pyclass(frozen, module = "damper._damper", name = "StructureParts")]
pub struct PyStructure {
    parts: Arc<StructureParts>,
    /// The table's other entries (`damping` ratios, `reduction`), as TOML text.
    table: String,
}

impl PyStructure {
    /// The override that replaces a scenario's host structure by this one.
    pub fn to_override(&self) -> PyResult<Override> {
        let table = match self.table.parse::<Value>() {
            Ok(Value::InlineTable(t)) => t,
            _ => return Err(PyValueError::new_err("structure: malformed table")),
        };
        Ok(Override::structure(self.parts.clone(), table))
    }
}

#[pymethods]
impl PyStructure {
    /// Number of equations.
    #[getter]
    fn equations(&self) -> usize {
        self.parts.mass.n
    }

    /// Number of nodes.
    #[getter]
    fn nodes(&self) -> usize {
        self.parts.nodes.len()
    }

    /// Stored entries of the lower triangles of `M` and `K`.
    #[getter]
    fn nonzeros(&self) -> (usize, usize) {
        (
            self.parts.mass.lower.len(),
            self.parts.stiffness.lower.len(),
        )
    }

    /// The `[structure]` table it stands for (`kind = "given"` and its damping ratios and
    /// reduction), as TOML.
    #[getter]
    fn table(&self) -> PyResult<String> {
        Ok(self.to_override()?.text)
    }

    /// The name messages use.
    #[getter]
    fn name(&self) -> String {
        self.parts.name.clone()
    }
}

/// A matrix's `(n, rows, columns, values)` as entries.
type Coo<'py> = (
    usize,
    PyReadonlyArray1<'py, i64>,
    PyReadonlyArray1<'py, i64>,
    PyReadonlyArray1<'py, f64>,
);

/// The `[structure]` entries besides the matrices: Rayleigh `damping` from two modal ratios
/// `(mode, ratio)` and a Craig–Bampton `reduction` to `modes` fixed-interface modes (checked
/// by the loader as the file's are).
fn table_of(ratios: Option<Vec<(i64, f64)>>, modes: Option<i64>) -> InlineTable {
    let mut t = InlineTable::new();
    if let Some(ratios) = ratios {
        let mut a = Array::new();
        for (mode, ratio) in ratios {
            let mut r = InlineTable::new();
            r.insert("mode", Value::from(mode));
            r.insert("ratio", Value::from(ratio));
            a.push(Value::InlineTable(r));
        }
        let mut d = InlineTable::new();
        d.insert("ratios", Value::Array(a));
        t.insert("damping", Value::InlineTable(d));
    }
    if let Some(modes) = modes {
        let mut r = InlineTable::new();
        r.insert("kind", Value::from("craig_bampton"));
        r.insert("modes", Value::from(modes));
        t.insert("reduction", Value::InlineTable(r));
    }
    t
}

/// A matrix's rows and entries, owned.
type Owned = (usize, Vec<(usize, usize, f64)>);

/// `(n, entries)` of a matrix given as index and value arrays (`ValueError` for arrays of
/// different lengths or a negative index).
fn entries(what: &str, m: &Coo<'_>) -> PyResult<Owned> {
    let (n, r, c, v) = m;
    if r.len() != c.len() || r.len() != v.len() {
        return Err(PyValueError::new_err(format!(
            "{what}: {} rows, {} columns and {} values given: expected as many of each",
            r.len(),
            c.len(),
            v.len()
        )));
    }
    let (r, c, v) = (r.as_slice()?, c.as_slice()?, v.as_slice()?);
    let index = |k: i64| {
        usize::try_from(k).map_err(|_| {
            PyValueError::new_err(format!("{what}: index {k} (indices are 0-based, >= 0)"))
        })
    };
    let out = (0..r.len())
        .map(|k| Ok((index(r[k])?, index(c[k])?, v[k])))
        .collect::<PyResult<_>>()?;
    Ok((*n, out))
}

/// Checks a structure given in memory (see the module's doc): `name` names it in messages,
/// `m`, `k` and `c` (optional) are `(n, rows, columns, values)`, `nodes` rows `[id, x, y]`
/// or `[id, x, y, z]` and `dofs` rows `[eq, node, dof]` (texts), `ratios` the Rayleigh
/// damping's `(mode, ratio)` pairs (without `c`), `modes` the Craig–Bampton reduction's.
/// `ScenarioError` naming the argument (and row) for anything the files' readers refuse.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn structure_from_matrices(
    py: Python<'_>,
    name: String,
    m: Coo<'_>,
    k: Coo<'_>,
    c: Option<Coo<'_>>,
    nodes: Vec<Vec<String>>,
    dofs: Vec<Vec<String>>,
    ratios: Option<Vec<(i64, f64)>>,
    modes: Option<i64>,
) -> PyResult<PyStructure> {
    let table = table_of(ratios, modes);
    let m = entries(&format!("{name}: M"), &m)?;
    let k = entries(&format!("{name}: K"), &k)?;
    let c = c.map(|c| entries(&format!("{name}: C"), &c)).transpose()?;
    let parts = interruptible(py, || {
        StructureParts::new(
            &name,
            (m.0, &m.1),
            (k.0, &k.1),
            c.as_ref().map(|c| (c.0, c.1.as_slice())),
            nodes,
            dofs,
        )
        .map_err(Error::Input)
    })?
    .map_err(|e| to_py(py, e, Input::Scenario))?;
    Ok(PyStructure {
        parts: Arc::new(parts),
        table: Value::InlineTable(table).to_string(),
    })
}
