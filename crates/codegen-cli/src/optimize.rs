//! Constrained design optimisation over numeric scenario fields (`damper optimize`): the
//! objective and the constraints are figures of a sweep point ([`crate::sweep_point`]: the
//! linearised first mode with the generator(s), the reach to the toggle, the
//! amplification, ...), the design variables are `--set` paths within bounds.
//!
//! **Method.** The landscape is not convex (damping rises towards the toggle while the reach
//! falls), so the search is multi-start: a coarse grid over the bounds (every point
//! evaluated), then COBYLA (Powell 1994; the `cobyla` crate, a faithful port of NLopt's
//! implementation, no dependencies) from the best feasible grid points. COBYLA is chosen
//! because it needs no derivatives (each evaluation is a linearisation about a new static
//! equilibrium; central differences would cost 2d of them per gradient), honours bounds
//! exactly, and handles nonlinear inequality constraints by linear models of them — the
//! situation of 1–4 design variables and a few constraints. Variables are scaled to
//! `[0, 1]` by their bounds, the objective by its range over the grid, each constraint's
//! margin by its bound (or 1 for a zero bound).
//!
//! **Result.** The best feasible point found over all starts (a point feasible when every
//! margin is `>= 0`), every constraint's value and margin and whether it is active (margin
//! below `ACTIVE` of its scale, or a variable at a bound), the evaluations, and the KKT
//! residual at the optimum: the objective's gradient in the scaled variables (the adjoint of
//! the linear model where the figure has one, else differences: [`crate::sensitivity`])
//! minus its least-squares combination of the active constraints' and bounds' gradients,
//! relative to the gradient's norm (0 at a KKT point; the combination's multipliers are
//! reported, and must be `>= 0`). The gradients themselves are reported, with the method
//! each came from.

use rayon::prelude::*;

use crate::analysis::figures::{Bound, Constraint};
use crate::analysis::sweep::SpecError;
use crate::scenario::Override;
use crate::scenario::overrides::parse_value;
use crate::sweep_point::{self, Figure, PointError, PointOptions};

/// A margin below this fraction of its scale counts as active.
pub const ACTIVE: f64 = 1e-6;
/// Step of the gradients' difference formulas in the scaled variables (a fraction of each
/// variable's range, [`crate::sensitivity::stencil`]): it balances their truncation
/// (`O(step^2)`) against the linearisations' rounding divided by the step (the adjoint
/// gradients agree with extrapolated differences of the figures to about 1e-8 at 1e-4,
/// measured on the bundled scenarios; at 1e-5 the `rms:` adjoint's rounding reaches 1e-6).
pub const FD_STEP: f64 = 1e-4;
/// Largest number of points of the start grid.
pub const MAX_GRID: usize = 125;
/// Most COBYLA runs (from the best feasible grid points).
pub const MAX_STARTS: usize = 4;
/// Evaluations of one COBYLA run.
pub const MAX_EVALS: usize = 150;

/// A design variable: a `--set` path and its bounds.
#[derive(Clone, Debug, PartialEq)]
pub struct Variable {
    /// The path.
    pub path: String,
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
}

impl std::str::FromStr for Variable {
    type Err = SpecError;

    /// `PATH=LO:HI` with `LO < HI`, both finite.
    fn from_str(text: &str) -> Result<Variable, SpecError> {
        let bad = || SpecError::Vary {
            text: text.to_string(),
        };
        let (path, range) = text.split_once('=').ok_or_else(bad)?;
        let path = path.trim();
        crate::scenario::overrides::parse_path(path).map_err(|_| bad())?;
        let (lo, hi) = range.split_once(':').ok_or_else(bad)?;
        let (lo, hi): (f64, f64) = (
            lo.trim().parse().map_err(|_| bad())?,
            hi.trim().parse().map_err(|_| bad())?,
        );
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(bad());
        }
        Ok(Variable {
            path: path.to_string(),
            lo,
            hi,
        })
    }
}

/// The problem: maximise or minimise a figure over the variables, subject to constraints.
#[derive(Clone, Debug)]
pub struct Problem<'a> {
    /// The scenario file (messages, relative paths).
    pub path: &'a std::path::Path,
    /// Its text.
    pub text: &'a str,
    /// Fixed overrides applied before the variables.
    pub fixed: &'a [Override],
    /// The design variables.
    pub variables: &'a [Variable],
    /// The objective figure.
    pub objective: String,
    /// Maximise (else minimise).
    pub maximize: bool,
    /// The constraints (figure names already expanded).
    pub constraints: &'a [Constraint],
    /// Points per variable of the start grid.
    pub grid: usize,
}

/// One evaluation: the variables, the objective, every constraint's margin (`None`: the
/// point failed or lacks the figure), and the point's error if it failed.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Evaluation {
    /// Variable values.
    pub x: Vec<f64>,
    /// The objective figure.
    pub objective: Option<f64>,
    /// Per constraint: its figure's value.
    pub values: Vec<Option<f64>>,
    /// Per constraint: margin (`>= 0` satisfied).
    pub margins: Vec<Option<f64>>,
    /// Why the point failed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// `grid` or the start index of the COBYLA run.
    pub stage: String,
    /// Whether the first mode is overdamped there (`linear.overdamped1`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub overdamped: Option<bool>,
}

impl Evaluation {
    /// Every margin known and `>= 0`, and the objective known.
    pub fn feasible(&self) -> bool {
        self.objective.is_some() && self.margins.iter().all(|m| m.is_some_and(|m| m >= 0.0))
    }

    /// Sum of the constraint violations, each relative to its scale (a failed point or a
    /// missing figure counts 1e3).
    pub fn infeasibility(&self, scales: &[f64]) -> f64 {
        if self.objective.is_none() {
            return 1e3;
        }
        self.margins
            .iter()
            .zip(scales)
            .map(|(m, s)| match m {
                Some(m) => (-m / s).max(0.0),
                None => 1e3,
            })
            .sum()
    }
}

/// A constraint at the optimum.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ConstraintReport {
    /// As written.
    pub constraint: String,
    /// The figure's value.
    pub value: f64,
    /// The margin (`>= 0`).
    pub margin: f64,
    /// Whether it is active (margin below [`ACTIVE`] of its scale).
    pub active: bool,
    /// Its KKT multiplier when active.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub multiplier: Option<f64>,
}

/// The result of an optimisation.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Outcome {
    /// The optimum: variable path and value.
    pub optimum: Vec<(String, f64)>,
    /// Variables at a bound: path and `lower`/`upper`.
    pub at_bounds: Vec<(String, &'static str)>,
    /// The objective figure and its value.
    pub objective: (String, f64),
    /// Every constraint at the optimum.
    pub constraints: Vec<ConstraintReport>,
    /// The KKT residual (see the module documentation); `None` without the gradients
    /// (`gradient_error` says why).
    pub kkt_residual: Option<f64>,
    /// The gradients of the objective and of every constraint's figure at the optimum
    /// ([`crate::sensitivity::gradients`]), in the variables' units.
    pub gradients: Vec<crate::sensitivity::Gradient>,
    /// Why the gradients could not be computed (no KKT residual then).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gradient_error: Option<String>,
    /// Whether the first mode is overdamped at the optimum (its damping ratio reads 1).
    pub overdamped: bool,
    /// COBYLA runs that ended at this optimum (objective within 1e-6 relative).
    pub starts_agreeing: usize,
    /// COBYLA runs.
    pub starts: usize,
    /// Every evaluation, in order.
    pub history: Vec<Evaluation>,
}

/// Why no optimum was found.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OptimizeError {
    /// No variable to vary: the search would have nothing to move (the derivative-free
    /// search needs at least one dimension).
    #[error("no variable to vary: give at least one PATH=LO:HI")]
    NoVariables,
    /// No evaluated point satisfies the constraints.
    #[error(
        "no point satisfies the constraints ({evaluations} evaluated); the least infeasible: {point}"
    )]
    Infeasible {
        /// Evaluations made.
        evaluations: usize,
        /// The least infeasible point: variables, objective and every constraint's value.
        point: String,
    },
}

/// The fixed overrides followed by `path = value` of every pair (values written in their
/// shortest round-trip form); the paths are checked PATHs.
pub fn overrides_at<'a>(
    fixed: &[Override],
    values: impl Iterator<Item = (&'a str, &'a f64)>,
) -> Vec<Override> {
    let mut overrides = fixed.to_vec();
    for (path, &x) in values {
        let text = crate::report::csv::cell(Some(x));
        overrides.push(Override::new(path, parse_value(&text), &text).expect("PATH checked"));
    }
    overrides
}

/// Evaluates the figures of the problem at `x`.
pub fn evaluate(p: &Problem<'_>, x: &[f64], stage: &str) -> Evaluation {
    let overrides = overrides_at(p.fixed, p.variables.iter().map(|v| v.path.as_str()).zip(x));
    let mut names: Vec<&str> = vec![p.objective.as_str()];
    for c in p.constraints {
        if !names.contains(&c.figure.as_str()) {
            names.push(&c.figure);
        }
    }
    let names: Vec<String> = names.into_iter().map(str::to_string).collect();
    let point = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        sweep_point::evaluate_with(p.path, p.text, &overrides, &PointOptions::default(), &names)
    }))
    .unwrap_or(Err(PointError::Panicked));
    let figure = |figures: &[Figure], name: &str| {
        figures
            .iter()
            .find(|f| f.name == name)
            .and_then(|f| f.value)
    };
    match point {
        Ok(e) => {
            let values: Vec<Option<f64>> = p
                .constraints
                .iter()
                .map(|c| figure(&e.figures, &c.figure))
                .collect();
            let margins = p
                .constraints
                .iter()
                .zip(&values)
                .map(|(c, v)| v.map(|v| c.margin_of(v)))
                .collect();
            Evaluation {
                x: x.to_vec(),
                objective: figure(&e.figures, &p.objective),
                values,
                margins,
                error: None,
                stage: stage.to_string(),
                overdamped: figure(&e.figures, "linear.overdamped1").map(|v| v > 0.5),
            }
        }
        Err(e) => Evaluation {
            x: x.to_vec(),
            objective: None,
            values: vec![None; p.constraints.len()],
            margins: vec![None; p.constraints.len()],
            error: Some(e.to_string().replace('\n', "; ")),
            stage: stage.to_string(),
            overdamped: None,
        },
    }
}

/// The start grid: `n` points per variable (the bounds included), at most [`MAX_GRID`].
fn grid(p: &Problem<'_>) -> Vec<Vec<f64>> {
    let d = p.variables.len();
    let mut n = p.grid.max(2);
    while n > 2 && n.pow(d as u32) > MAX_GRID {
        n -= 1;
    }
    let total = n.pow(d as u32);
    (0..total)
        .map(|mut k| {
            let mut x = vec![0.0; d];
            for i in (0..d).rev() {
                let j = k % n;
                k /= n;
                let v = &p.variables[i];
                x[i] = v.lo + (v.hi - v.lo) * j as f64 / (n - 1) as f64;
            }
            x
        })
        .collect()
}

/// A function of the scaled variables, as COBYLA calls it.
type ScaledFn<'a> = dyn Fn(&[f64], &mut ()) -> f64 + 'a;

/// Solves the problem (see the module documentation).
pub fn optimize(p: &Problem<'_>) -> Result<Outcome, OptimizeError> {
    let d = p.variables.len();
    if d == 0 {
        return Err(OptimizeError::NoVariables);
    }
    let scales: Vec<f64> = p
        .constraints
        .iter()
        .map(|c| if c.value != 0.0 { c.value.abs() } else { 1.0 })
        .collect();
    // The grid, in parallel (collected in grid order: the same result on any thread count).
    // Each point on rayon's threads as work of this call (its stop token).
    let token = crate::interrupt::current();
    let mut history: Vec<Evaluation> = grid(p)
        .par_iter()
        .map(|x| crate::interrupt::with_current(token.clone(), || evaluate(p, x, "grid")))
        .collect();
    let sign = if p.maximize { -1.0 } else { 1.0 };
    let (omin, omax) = history
        .iter()
        .filter_map(|e| e.objective)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    let oscale = if omax > omin {
        omax - omin
    } else {
        omin.abs().max(1.0)
    };
    // Starts: the best feasible grid points.
    let mut ranked: Vec<&Evaluation> = history.iter().filter(|e| e.feasible()).collect();
    ranked.sort_by(|a, b| {
        let (fa, fb) = (
            sign * a.objective.unwrap_or(0.0),
            sign * b.objective.unwrap_or(0.0),
        );
        fa.total_cmp(&fb)
    });
    let starts: Vec<Vec<f64>> = ranked
        .iter()
        .take(MAX_STARTS)
        .map(|e| e.x.clone())
        .collect();
    let to_u = |x: &[f64]| -> Vec<f64> {
        x.iter()
            .zip(p.variables)
            .map(|(x, v)| (x - v.lo) / (v.hi - v.lo))
            .collect()
    };
    let to_x = |u: &[f64]| -> Vec<f64> {
        u.iter()
            .zip(p.variables)
            .map(|(u, v)| v.lo + (v.hi - v.lo) * u.clamp(0.0, 1.0))
            .collect()
    };
    let mut ends: Vec<Option<f64>> = vec![];
    for (s, x0) in starts.iter().enumerate() {
        let stage = format!("start {s}");
        let log = std::cell::RefCell::new(Vec::<Evaluation>::new());
        // One evaluation per distinct u: COBYLA asks the objective and then each constraint
        // at the same point.
        let at = |u: &[f64]| -> Evaluation {
            if let Some(e) = log.borrow().iter().rev().find(|e| e.x == to_x(u)) {
                return e.clone();
            }
            let e = evaluate(p, &to_x(u), &stage);
            log.borrow_mut().push(e.clone());
            e
        };
        let objective = |u: &[f64], _: &mut ()| -> f64 {
            let e = at(u);
            match e.objective {
                Some(v) => sign * v / oscale,
                None => 1e3,
            }
        };
        let cons: Vec<Box<ScaledFn<'_>>> = (0..p.constraints.len())
            .map(|k| {
                let scale = scales[k];
                let at = &at;
                Box::new(move |u: &[f64], _: &mut ()| -> f64 {
                    match at(u).margins[k] {
                        Some(m) => m / scale,
                        None => -1.0,
                    }
                }) as Box<ScaledFn<'_>>
            })
            .collect();
        let cons_ref: Vec<&ScaledFn<'_>> = cons.iter().map(|c| c.as_ref()).collect();
        let bounds = vec![(0.0, 1.0); d];
        let stop = cobyla::StopTols {
            xtol_rel: 1e-9,
            xtol_abs: vec![1e-9; d],
            ..Default::default()
        };
        let result = cobyla::minimize(
            objective,
            &to_u(x0),
            &bounds,
            &cons_ref,
            (),
            MAX_EVALS,
            cobyla::RhoBeg::All(0.1),
            Some(stop),
        );
        let end = match result {
            Ok((_, u, _)) | Err((_, u, _)) => at(&u),
        };
        // Where this search ended, if feasible to 1e-9 of each constraint's scale (COBYLA
        // ends on an active constraint to within its own tolerance).
        let nearly = end.objective.is_some()
            && end
                .margins
                .iter()
                .zip(&scales)
                .all(|(m, s)| m.is_some_and(|m| m >= -1e-9 * s));
        ends.push(end.objective.filter(|_| nearly));
        drop(cons_ref);
        drop(cons);
        history.extend(log.borrow_mut().drain(..));
    }
    let best = history
        .iter()
        .filter(|e| e.feasible())
        .min_by(|a, b| {
            let (fa, fb) = (
                sign * a.objective.unwrap_or(0.0),
                sign * b.objective.unwrap_or(0.0),
            );
            fa.total_cmp(&fb)
        })
        .cloned();
    let Some(best) = best else {
        let least = history
            .iter()
            .min_by(|a, b| {
                a.infeasibility(&scales)
                    .total_cmp(&b.infeasibility(&scales))
            })
            .map(|e| describe(p, e))
            .unwrap_or_default();
        return Err(OptimizeError::Infeasible {
            evaluations: history.len(),
            point: least,
        });
    };
    let value = best.objective.unwrap_or_default();
    let agreeing = ends
        .iter()
        .filter(|e| e.is_some_and(|v| (v - value).abs() <= 1e-6 * value.abs().max(1e-12)))
        .count();
    // KKT at the optimum (scaled variables).
    let u0 = to_u(&best.x);
    let active: Vec<bool> = best
        .margins
        .iter()
        .zip(&scales)
        .map(|(m, s)| m.is_some_and(|m| m / s <= ACTIVE))
        .collect();
    let mut at_bounds = vec![];
    for (i, v) in p.variables.iter().enumerate() {
        if u0[i] <= ACTIVE {
            at_bounds.push((v.path.clone(), "lower"));
        } else if u0[i] >= 1.0 - ACTIVE {
            at_bounds.push((v.path.clone(), "upper"));
        }
    }
    // The gradients at the optimum (the adjoint where the figure has one, else
    // differences: `crate::sensitivity`), in the scaled variables.
    let (gradients, gradient_error) = match crate::sensitivity::gradients(p, &best.x) {
        Ok(g) => (g, None),
        Err(e) => (vec![], Some(e.to_string())),
    };
    let scaled = |g: &crate::sensitivity::Gradient, factor: f64| -> Vec<f64> {
        g.gradient
            .iter()
            .zip(p.variables)
            .map(|(d, v)| factor * d * (v.hi - v.lo))
            .collect()
    };
    // The objective to minimise and the active constraints' margins (>= 0 feasible).
    let grad_f = gradients.first().map(|g| scaled(g, sign / oscale));
    let mut columns: Vec<Vec<f64>> = vec![];
    let mut which: Vec<Option<usize>> = vec![];
    for (k, a) in active.iter().enumerate() {
        if let (true, Some(g)) = (*a, gradients.get(k + 1)) {
            let side = match p.constraints[k].bound {
                Bound::AtLeast => 1.0,
                Bound::AtMost => -1.0,
            };
            columns.push(scaled(g, side / scales[k]));
            which.push(Some(k));
        }
    }
    for (i, _) in p.variables.iter().enumerate() {
        if u0[i] <= ACTIVE || u0[i] >= 1.0 - ACTIVE {
            let mut g = vec![0.0; d];
            g[i] = if u0[i] <= ACTIVE { 1.0 } else { -1.0 };
            columns.push(g);
            which.push(None);
        }
    }
    let (kkt, multipliers) = match grad_f {
        Some(g) => {
            let (r, m) = kkt_residual(&g, &columns);
            (Some(r), m)
        }
        None => (None, vec![]),
    };
    let mut mult_of = vec![None; p.constraints.len()];
    for (w, m) in which.iter().zip(&multipliers) {
        if let Some(k) = w {
            mult_of[*k] = Some(*m);
        }
    }
    let constraints = p
        .constraints
        .iter()
        .enumerate()
        .map(|(k, c)| ConstraintReport {
            constraint: c.text.clone(),
            value: best.values[k].unwrap_or(f64::NAN),
            margin: best.margins[k].unwrap_or(f64::NAN),
            active: active[k],
            multiplier: mult_of[k],
        })
        .collect();
    Ok(Outcome {
        optimum: p
            .variables
            .iter()
            .zip(&best.x)
            .map(|(v, x)| (v.path.clone(), *x))
            .collect(),
        at_bounds,
        objective: (p.objective.clone(), value),
        constraints,
        kkt_residual: kkt,
        gradients,
        gradient_error,
        overdamped: best.overdamped.unwrap_or(false),
        starts_agreeing: agreeing,
        starts: starts.len(),
        history,
    })
}

/// `grad f = A mu` in the least-squares sense (A's columns: the gradients of the active
/// constraints, `>= 0` feasible): `|grad f - A mu| / |grad f|` and `mu` (`mu >= 0` at a
/// KKT point of a minimisation).
pub fn kkt_residual(g: &[f64], columns: &[Vec<f64>]) -> (f64, Vec<f64>) {
    let d = g.len();
    let norm = g.iter().map(|x| x * x).sum::<f64>().sqrt();
    if columns.is_empty() {
        return (if norm > 0.0 { 1.0 } else { 0.0 }, vec![]);
    }
    let a = nalgebra::DMatrix::from_fn(d, columns.len(), |r, c| columns[c][r]);
    let b = nalgebra::DVector::from_column_slice(g);
    let svd = a.clone().svd(true, true);
    let mu = svd
        .solve(&b, 1e-12)
        .unwrap_or_else(|_| nalgebra::DVector::zeros(columns.len()));
    let r = &b - &a * &mu;
    let rel = if norm > 0.0 { r.norm() / norm } else { 0.0 };
    (rel, mu.iter().copied().collect())
}

/// A point in one line: its variables, objective and every constraint's value.
pub fn describe(p: &Problem<'_>, e: &Evaluation) -> String {
    let mut parts: Vec<String> = p
        .variables
        .iter()
        .zip(&e.x)
        .map(|(v, x)| format!("{} = {}", v.path, crate::report::csv::cell(Some(*x))))
        .collect();
    match (&e.error, e.objective) {
        (Some(err), _) => parts.push(format!("failed: {err}")),
        (None, Some(v)) => parts.push(format!(
            "{} = {}",
            p.objective,
            crate::report::csv::cell(Some(v))
        )),
        (None, None) => parts.push(format!("no {}", p.objective)),
    }
    for (c, v) in p.constraints.iter().zip(&e.values) {
        let shown = v.map_or("n/a".to_string(), |v| crate::report::csv::cell(Some(v)));
        parts.push(format!("{} = {shown} (needs {})", c.figure, c.text));
    }
    parts.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_kkt_residual_of_a_gradient_in_the_span_of_the_active_gradients_is_zero() {
        let (r, mu) = kkt_residual(&[2.0, 0.0], &[vec![1.0, 0.0]]);
        assert!(r < 1e-15 && (mu[0] - 2.0).abs() < 1e-15);
        let (r, _) = kkt_residual(&[1.0, 1.0], &[vec![1.0, 0.0]]);
        assert!((r - 0.5f64.sqrt()).abs() < 1e-15);
        assert_eq!(kkt_residual(&[0.0, 0.0], &[]).0, 0.0);
    }

    #[test]
    fn variables_parse_with_bounds() {
        let v: Variable = "mechanism.half_angle_deg=3:25".parse().unwrap();
        assert_eq!((v.lo, v.hi), (3.0, 25.0));
        for bad in ["x=3", "x=5:3", "x=a:b", "=1:2", "x=1:inf"] {
            assert!(bad.parse::<Variable>().is_err(), "{bad}");
        }
    }
}
