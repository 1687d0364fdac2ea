//! The points of a sweep: the PATHs checked against the scenario before any work
//! ([`check_paths`]), every point evaluated on a pool of worker threads in grid order
//! whatever the thread count ([`evaluate_points_requesting`], [`crate::sweep_point`]),
//! and the one result of a point ([`PointResult`]).

use std::path::Path;

use rayon::prelude::*;
use toml_edit::Value;

use super::grid::{Grid, SpecError};
use crate::Error;
use crate::analysis::AnalysisError;
use crate::analysis::Warning;
use crate::analysis::figures::Constraint;
use crate::scenario::overrides::value_text;
use crate::scenario::{self, Override};
use crate::sweep_point::{self, Figure, PointOptions};

/// How far the point `r` is inside the constraint `c` (`>= 0`: satisfied; in the figure's
/// unit); `None` when the point does not give the figure.
pub fn margin(c: &Constraint, r: &PointResult) -> Option<f64> {
    c.margin(|name| {
        r.figures
            .iter()
            .find(|f| f.name == name)
            .and_then(|f| f.value)
    })
}

/// The result of one point.
#[derive(Clone, Debug, PartialEq)]
pub struct PointResult {
    /// Grid index.
    pub index: usize,
    /// The figures (empty when the point failed; the linearised ones only when its
    /// time-domain run failed).
    pub figures: Vec<Figure>,
    /// Why the point failed.
    pub error: Option<String>,
    /// Why its time-domain run failed (the linearised figures are kept).
    pub time_domain_error: Option<String>,
}

/// Checks the `--set` / `--vary` PATHs before any work: each override (`path = value`, the
/// first value of an axis) applied alone after the `fixed` ones; a PATH the scenario cannot
/// take (an unknown field, no such table or index) is an error naming it and the valid
/// fields. A value the loader refuses is not an error here (it is the point's).
pub fn check_paths<'a, V: Into<Value>>(
    path: &Path,
    text: &str,
    fixed: &[Override],
    paths: impl Iterator<Item = (&'a str, V)>,
) -> Result<(), Error> {
    for (p, value) in paths {
        let value: Value = value.into();
        let o = Override::new(p, value.clone(), &value_text(&value)).map_err(|source| {
            SpecError::Path {
                spec: p.to_string(),
                source,
            }
        })?;
        let mut overrides = fixed.to_vec();
        overrides.push(o.clone());
        let Err(d) = scenario::parse_with(text, path, &overrides) else {
            continue;
        };
        let option = o.option();
        let named = |x: &diagnostic::Diagnostic| {
            x.entity.as_deref().is_some_and(|e| e.starts_with(&option))
        };
        let bad: Vec<diagnostic::Diagnostic> =
            d.0.into_iter()
                .filter(|x| {
                    named(x)
                        && (matches!(
                            x.kind,
                            diagnostic::Kind::UnknownField | diagnostic::Kind::UnknownName
                        ) || x.message.contains("unknown field"))
                })
                .collect();
        if !bad.is_empty() {
            // The loader's problem names the nearest valid field already.
            return Err(Error::Input(bad.into()));
        }
    }
    Ok(())
}

/// Evaluates the points `indices` of `grid` on `threads` worker threads (0: every core), each
/// point the scenario `text` (the file `path`) with the `fixed` overrides, the point's and
/// `t_end`'s applied in that order ([`sweep_point::evaluate`]); the results in the order of
/// `indices` (never in completion order), a failed or panicking point recorded as its
/// one-line error. `done` is called after every point. [`Error::Interrupted`] when
/// [`crate::interrupt::StopToken::stop`] was called (the points not started then fail at once,
/// [`sweep_point::evaluate`]). The figures `requested` (canonical names) are computed beside
/// the default ones when they are on request only ([`sweep_point::evaluate_with`]).
pub fn evaluate_points_requesting(
    path: &Path,
    text: &str,
    fixed: &[Override],
    grid: &Grid,
    indices: &[usize],
    t_end: Option<&Override>,
    options: &PointOptions,
    requested: &[String],
    threads: usize,
    done: &(dyn Fn() + Sync),
) -> Result<Vec<PointResult>, Error> {
    let evaluate = |index: usize| {
        let mut overrides = fixed.to_vec();
        overrides.extend(grid.overrides(index));
        overrides.extend(t_end.cloned());
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            sweep_point::evaluate_with(path, text, &overrides, options, requested)
        }))
        .unwrap_or(Err(sweep_point::PointError::Panicked));
        done();
        let line = |e: &dyn std::fmt::Display| e.to_string().replace('\n', "; ");
        match result {
            Ok(p) => PointResult {
                index,
                figures: p.figures,
                error: None,
                time_domain_error: p.time_domain_error.map(|e| line(&e)),
            },
            Err(e) => PointResult {
                index,
                figures: vec![],
                error: Some(line(&e)),
                time_domain_error: None,
            },
        }
    };
    // The pool's threads work for this call: they see its stop token only.
    let token = crate::interrupt::current();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .start_handler(move |_| crate::interrupt::adopt(token.clone()))
        .build()
        .map_err(|e| AnalysisError::Resources {
            message: format!("cannot start the worker threads: {e}"),
        })?;
    let results: Vec<PointResult> =
        pool.install(|| indices.par_iter().map(|&i| evaluate(i)).collect());
    if crate::interrupt::stop_requested() {
        return Err(Error::Interrupted);
    }
    Ok(results)
}

/// The figure columns of a sweep: every figure's name and unit in order of first
/// appearance over `rows` (in grid order), as `sweep.csv` has them.
pub fn figure_heads<'r>(rows: &[&'r PointResult]) -> Vec<(&'r str, &'static str)> {
    let mut heads: Vec<(&str, &'static str)> = vec![];
    for r in rows {
        for f in &r.figures {
            if !heads.iter().any(|(n, _)| *n == f.name) {
                heads.push((&f.name, f.unit));
            }
        }
    }
    heads
}

/// The worker threads of `--threads`: at most the machine's available parallelism (with a
/// note saying so when capped); 0, rayon's default (every core), without it.
pub fn threads(asked: Option<usize>) -> (usize, Option<Warning>) {
    let machine = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    match asked {
        Some(t) if t > machine => (
            machine,
            Some(Warning::note(format!(
                "--threads {t} capped to {machine}, the machine's available parallelism"
            ))),
        ),
        Some(t) => (t, None),
        None => (0, None),
    }
}
