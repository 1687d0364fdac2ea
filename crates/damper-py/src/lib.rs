//! `damper._damper`: the Python bindings of the damper design application
//! ([`codegen_cli`], the library behind the `damper` command; not the command line).
//!
//! The module is thin: each function loads its input through the library's one loader and
//! calls the library's function of the matching command, and hands the results to Python —
//! summaries and reports as the JSON objects the command writes (`json.loads` of the same
//! bytes), tables as the report builds them for its CSVs (`codegen_cli::report::rows::Table`:
//! `(name, unit, values)` columns), time histories, mode shapes and matrices as numpy arrays
//! that take over the library's buffers; a sweep's shards as the text of their part files.
//! The Python package `damper` (`python/damper/__init__.py`, the typed results in
//! `results.py`) wraps these functions into its classes (`Scenario`, `Run`, `FrfResult`,
//! `SweepResult`, `RandomResult`, `Optimum`, `Linearization`, `SweepPart`, `Model`); the
//! type stub `_damper.pyi` describes them.
//!
//! Long calls release the GIL and honour Ctrl-C (the `watch` module).

mod convert;
mod errors;
mod model;
mod scenario;
mod structure;
mod watch;

use pyo3::prelude::*;

/// The native module.
#[pymodule]
fn _damper(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("ScenarioError", py.get_type::<errors::ScenarioError>())?;
    m.add("ModelError", py.get_type::<errors::ModelError>())?;
    m.add("DamperError", py.get_type::<errors::DamperError>())?;
    m.add("DamperWarning", py.get_type::<errors::DamperWarning>())?;
    m.add(
        "SingularPosition",
        py.get_type::<errors::SingularPosition>(),
    )?;
    errors::register(m)?;
    m.add_function(wrap_pyfunction!(scenario::read_scenario, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::check, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::linearize, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::frf, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::sweep_grid, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::sweep_shard, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::sweep_merge, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::sweep_points, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::optimize, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::random, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::figures, m)?)?;
    m.add_function(wrap_pyfunction!(structure::structure_from_matrices, m)?)?;
    m.add_class::<structure::PyStructure>()?;
    m.add_function(wrap_pyfunction!(model::model_info, m)?)?;
    m.add_function(wrap_pyfunction!(model::model_eval, m)?)?;
    m.add_function(wrap_pyfunction!(model::model_generate, m)?)?;
    Ok(())
}
