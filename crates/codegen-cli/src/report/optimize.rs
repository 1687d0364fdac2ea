//! The files and the text of an optimisation (`damper optimize`): `optimize.json` (the
//! outcome as one object, with the time-domain check of `--verify`), the optimiser's history
//! table `optimize_history.csv` (what Python's `Optimum.history` holds: one row per
//! evaluation, in the order the search made them) and the text report (the optimum, the
//! variables at their bounds, every constraint with its value, margin, state and multiplier,
//! the gradients, the certificate, the searches that agreed).

use std::path::Path;

use crate::Error;
use crate::analysis::figures::Constraint;
use crate::analysis::optimization::Verified;
use crate::optimize::Outcome;
use crate::report::csv::cell;
use crate::report::rows::{Cells, Table, TableColumn};
use crate::report::{OutputFile, ReportError};

/// What `--json` prints and `optimize.json` holds.
#[derive(serde::Serialize)]
pub struct Report<'a> {
    /// The outcome.
    #[serde(flatten)]
    pub outcome: &'a Outcome,
    /// The time-domain run of the optimum (`--verify`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub verify: Option<&'a Verified>,
}

impl Report<'_> {
    /// The JSON object, pretty-printed (no final newline).
    pub fn json(&self) -> Result<Vec<u8>, Error> {
        Ok(serde_json::to_vec_pretty(self).map_err(ReportError::from)?)
    }
}

/// `optimize.json` (the `json` of [`Report::json`]) and `optimize_history.csv`
/// ([`history_table`]) in `out`.
pub fn files(
    out: &Path,
    json: &[u8],
    outcome: &Outcome,
    constraints: &[Constraint],
) -> Result<Vec<OutputFile>, Error> {
    let csv = history_table(outcome, constraints)
        .csv(&|x| cell(Some(x)))
        .map_err(|e| Error::from(ReportError::from(e)))?;
    let mut json_file = json.to_vec();
    json_file.push(b'\n');
    Ok(vec![
        OutputFile {
            path: out.join("optimize.json"),
            bytes: json_file,
        },
        OutputFile {
            path: out.join("optimize_history.csv"),
            bytes: csv,
        },
    ])
}

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

/// The text report of the optimum of `file` (`seconds`: the search's wall time).
pub fn text(
    file: &str,
    outcome: &Outcome,
    constraints: &[Constraint],
    maximize: bool,
    verified: Option<&Verified>,
    seconds: f64,
) -> String {
    let mut text = format!("{file}: optimum ");
    let xs: Vec<String> = outcome
        .optimum
        .iter()
        .map(|(p, x)| format!("{p} = {}", cell(Some(*x))))
        .collect();
    text.push_str(&xs.join(", "));
    text.push_str(&format!(
        "; {} = {} ({})\n",
        outcome.objective.0,
        cell(Some(outcome.objective.1)),
        if maximize { "maximised" } else { "minimised" }
    ));
    if outcome.overdamped {
        text.push_str("  the first mode is overdamped at the optimum (zeta1 reads 1 there: maximise decay1 for the fastest decay)\n");
    }
    for (k, (p, side)) in outcome.at_bounds.iter().enumerate() {
        let mult = outcome
            .bound_multipliers
            .get(k)
            .map_or(String::new(), |m| format!(", multiplier {m:.3e}"));
        text.push_str(&format!("  {p} at its {side} bound{mult}\n"));
    }
    for (c, spec) in outcome.constraints.iter().zip(constraints) {
        let state = if c.active { "active" } else { "inactive" };
        let mult = c
            .multiplier
            .map_or(String::new(), |m| format!(", multiplier {m:.3e}"));
        let rhs = match &spec.other {
            Some(b) => format!(
                " against {} * {b} = {}",
                cell(Some(spec.value)),
                cell(Some(c.rhs))
            ),
            None => String::new(),
        };
        text.push_str(&format!(
            "  {}: value {}{rhs}, margin {:.3e}, {state}{mult}\n",
            c.constraint,
            cell(Some(c.value)),
            c.margin
        ));
    }
    for g in &outcome.gradients {
        let parts: Vec<String> = outcome
            .optimum
            .iter()
            .zip(&g.gradient)
            .map(|((path, _), d)| format!("d/d {path} = {d:.6e}"))
            .collect();
        let method = match g.method {
            crate::sensitivity::Method::Adjoint => "adjoint",
            crate::sensitivity::Method::Differences => "differences",
        };
        text.push_str(&format!(
            "  gradient of {}: {} ({method})\n",
            g.figure,
            parts.join(", ")
        ));
    }
    if let Some(e) = &outcome.gradient_error {
        text.push_str(&format!("  no gradients at the optimum: {e}\n"));
    }
    if let Some(v) = verified {
        text.push_str(&verified_text(outcome, v));
    }
    text.push_str(&format!("  {}\n", outcome.certificate));
    text.push_str(&format!(
        "  {} of {} local search(es) reached this optimum; {} evaluations in {seconds:.1} s\n",
        outcome.starts_agreeing,
        outcome.starts,
        outcome.history.len(),
    ));
    text
}

/// The line of the time-domain check (`--verify`).
fn verified_text(outcome: &Outcome, v: &Verified) -> String {
    let mut text = format!("  time domain ({}): ", v.run);
    match &v.error {
        Some(e) => {
            text.push_str(&format!("failed: {e}\n"));
            let reach_active = outcome
                .constraints
                .iter()
                .any(|c| c.active && c.constraint.starts_with("reach"));
            if reach_active && e.contains("singular position") {
                text.push_str("  (the reach constraint is active: the optimum reaches the toggle at exactly that amplitude; ask for a margin, e.g. reach>=1.1 A, or verify from a smaller amplitude with --verify-amplitude)\n");
            }
        }
        None => {
            let shown: Vec<String> = v
                .figures
                .iter()
                .filter(|(n, _)| !n.starts_with("linear."))
                .map(|(n, x)| format!("{n} = {}", x.map_or("n/a".into(), |x| cell(Some(x)))))
                .collect();
            text.push_str(&shown.join(", "));
            text.push('\n');
        }
    }
    text
}
