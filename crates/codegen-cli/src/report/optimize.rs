//! The optimiser's history table, `optimize_history.csv` (what Python's `Optimum.history`
//! holds): one row per evaluation, in the order the search made them.

use crate::analysis::figures::Constraint;
use crate::optimize::Outcome;
use crate::report::rows::{Cells, Table, TableColumn};

/// The history of `outcome` (its `constraints`, their figure names expanded): `stage`
/// (`grid` or the start of a local search), every variable (its PATH), the objective and
/// every constraint's figure (their names), the right-hand figure of every constraint
/// between figures, and `error` (why the point failed; empty otherwise).
pub fn history_table(outcome: &Outcome, constraints: &[Constraint]) -> Table {
    let history = &outcome.history;
    let numbers = |name: &str, of: &dyn Fn(&crate::optimize::Evaluation) -> Option<f64>| {
        TableColumn::new(name, None, Cells::Numbers(history.iter().map(of).collect()))
    };
    let mut columns = vec![TableColumn::new(
        "stage",
        None,
        Cells::Texts(history.iter().map(|e| Some(e.stage.clone())).collect()),
    )];
    for (k, (path, _)) in outcome.optimum.iter().enumerate() {
        columns.push(numbers(path, &|e| Some(e.x[k])));
    }
    columns.push(numbers(&outcome.objective.0, &|e| e.objective));
    for (k, c) in constraints.iter().enumerate() {
        columns.push(numbers(&c.figure, &|e| e.values[k]));
    }
    for (k, c) in constraints.iter().enumerate() {
        if let Some(other) = &c.other {
            columns.push(numbers(other, &|e| e.others[k]));
        }
    }
    columns.push(TableColumn::new(
        "error",
        None,
        Cells::Texts(history.iter().map(|e| e.error.clone()).collect()),
    ));
    Table::new(columns)
}
