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
//! margin is `>= 0`; a constraint between figures `A>=k*B` has the margin `A - k B`), every
//! constraint's value, right-hand side and margin, and the certificate of the optimum
//! (`docs/theory.md`, "The certificate of an optimum"):
//!
//! - the **active set**: a constraint whose margin is below [`ACTIVE`] of its scale, a
//!   variable within [`ACTIVE`] of its range from a bound;
//! - the **KKT residual** on that set: with `g` the objective's gradient (to minimise) in the
//!   scaled variables, `a_j` the gradients of the active margins (each over its scale) and
//!   the bounds' normals (`+e_i` at a lower bound, `-e_i` at an upper one), the multipliers
//!   `mu` of the least-squares `g ~ sum mu_j a_j` and `r = |g - sum mu_j a_j|`: the part of
//!   the objective's change per range of the variables that the active set does not
//!   balance, in units of the objective's spread over the start grid (0 at a KKT point);
//!   a KKT point also has every `mu_j >= 0` (checked to [`SIGN_TOL`]);
//! - the **starts that reached it**: the COBYLA runs whose best point feasible to [`ACTIVE`]
//!   is no worse than the optimum by more than [`AGREE`] of the objective's spread over the
//!   start grid.
//!
//! The gradients are the adjoint of the linear model where the figure has one, else
//! differences ([`crate::sensitivity`]), reported with the method each came from; the
//! margin of `A>=k*B` has the gradient `dA - k dB`.

use rayon::prelude::*;

use crate::analysis::figures::Constraint;
use crate::analysis::sweep::SpecError;
use crate::scenario::Override;
use crate::scenario::overrides::parse_value;
use crate::sweep_point::{self, Figure, PointError, PointOptions};

/// A margin below this fraction of its scale counts as active, and a variable within this
/// fraction of its range from a bound is at the bound: COBYLA ends within about 1e-6 to 1e-5
/// of an active constraint when it stops on its evaluation cap (measured), far below any
/// margin that matters to a design; a constraint counted active that does not bind gets a
/// multiplier of about 0, not a wrong certificate.
pub const ACTIVE: f64 = 1e-4;
/// A KKT multiplier above `-SIGN_TOL` (relative to the largest one, at least 1) counts as
/// non-negative.
pub const SIGN_TOL: f64 = 1e-6;
/// A start reached the optimum when its best point feasible to [`ACTIVE`] is no worse than
/// the optimum by more than this fraction of the objective's spread over the start grid (a
/// point on an active constraint to within `ACTIVE` may be slightly better than the best
/// strictly feasible one).
pub const AGREE: f64 = 1e-5;
/// A KKT residual below this is called stationary in the report's sentence (the gradients'
/// difference formulas are good to about 1e-8 of the gradient; COBYLA's end to 1e-6).
pub const KKT_STATIONARY: f64 = 1e-4;
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
    /// How the random figures are computed.
    pub method: crate::random::RandomMethod,
}

impl Problem<'_> {
    /// The figures whose gradients the certificate needs, each once, in order: the
    /// objective, every constraint's figure, then the right-hand figures of the constraints
    /// between figures ([`crate::sensitivity::gradients`] gives them in this order).
    pub fn gradient_figures(&self) -> Vec<String> {
        let mut names = vec![self.objective.clone()];
        names.extend(self.constraints.iter().map(|c| c.figure.clone()));
        for b in self.constraints.iter().filter_map(|c| c.other.as_ref()) {
            if !names.contains(b) {
                names.push(b.clone());
            }
        }
        names
    }
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
    /// Per constraint: the value of its right-hand figure `B` (`A>=k*B`), `None` for a
    /// constraint against a number.
    #[serde(skip)]
    pub others: Vec<Option<f64>>,
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
    /// The value of the figure `name` of the problem `p` at this point (the objective or a
    /// constraint's figure).
    pub fn value_of(&self, p: &Problem<'_>, name: &str) -> Option<f64> {
        if name == p.objective {
            return self.objective;
        }
        let k = p.constraints.iter().position(|c| c.figure == name);
        if let Some(k) = k {
            return self.values[k];
        }
        let k = p
            .constraints
            .iter()
            .position(|c| c.other.as_deref() == Some(name))?;
        self.others[k]
    }

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
    /// The right-hand side: the bound, or `k B` of a constraint between figures.
    pub rhs: f64,
    /// The margin (`>= 0`).
    pub margin: f64,
    /// The scale the margin is measured against (the bound's magnitude, or the largest
    /// `|k B|` over the start grid; 1 for a zero bound).
    pub scale: f64,
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
    /// Variables at a bound (within [`ACTIVE`] of the range): path and `lower`/`upper`.
    pub at_bounds: Vec<(String, &'static str)>,
    /// The KKT multiplier of each variable at a bound (as `at_bounds`), when the gradients
    /// are known.
    pub bound_multipliers: Vec<f64>,
    /// The objective figure and its value.
    pub objective: (String, f64),
    /// Every constraint at the optimum.
    pub constraints: Vec<ConstraintReport>,
    /// The KKT residual (see the module documentation); `None` without the gradients
    /// (`gradient_error` says why).
    pub kkt_residual: Option<f64>,
    /// Whether every multiplier of the active set is `>= 0` (to [`SIGN_TOL`]); `None`
    /// without the gradients.
    pub multipliers_nonnegative: Option<bool>,
    /// The certificate in one or two plain sentences (what the residual and the
    /// multipliers' signs say).
    pub certificate: String,
    /// The tolerances of the certificate: `active` ([`ACTIVE`]), `agree` ([`AGREE`]),
    /// `sign` ([`SIGN_TOL`]).
    pub tolerances: Tolerances,
    /// The gradients of the objective and of every constraint's figure at the optimum
    /// ([`crate::sensitivity::gradients`]), in the variables' units.
    pub gradients: Vec<crate::sensitivity::Gradient>,
    /// Why the gradients could not be computed (no KKT residual then).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gradient_error: Option<String>,
    /// Whether the first mode is overdamped at the optimum (its damping ratio reads 1).
    pub overdamped: bool,
    /// COBYLA runs that reached this optimum (their best point feasible to [`ACTIVE`] no
    /// worse by more than [`AGREE`] of the objective's spread over the grid).
    pub starts_agreeing: usize,
    /// COBYLA runs.
    pub starts: usize,
    /// Every evaluation, in order.
    pub history: Vec<Evaluation>,
}

/// The tolerances the certificate is decided with (module documentation).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Tolerances {
    /// [`ACTIVE`].
    pub active: f64,
    /// [`AGREE`].
    pub agree: f64,
    /// [`SIGN_TOL`].
    pub sign: f64,
}

/// Why no optimum was found.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
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

/// Evaluates the figures of the problem at `x` (only these: the random figures only when
/// one of them is random).
pub fn evaluate(p: &Problem<'_>, x: &[f64], stage: &str) -> Evaluation {
    let overrides = overrides_at(p.fixed, p.variables.iter().map(|v| v.path.as_str()).zip(x));
    let mut names: Vec<&str> = vec![p.objective.as_str()];
    for name in p.constraints.iter().flat_map(Constraint::figures) {
        if !names.contains(&name) {
            names.push(name);
        }
    }
    let names: Vec<String> = names.into_iter().map(str::to_string).collect();
    let options = PointOptions {
        method: p.method,
        only_requested: true,
        ..PointOptions::default()
    };
    let point = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        sweep_point::evaluate_with(p.path, p.text, &overrides, &options, &names)
    }))
    .unwrap_or(Err(PointError::Panicked));
    let figure = |figures: &[Figure], name: &str| {
        figures
            .iter()
            .find(|f| f.name == name)
            .and_then(|f| f.value)
    };
    let nc = p.constraints.len();
    match point {
        Ok(e) => {
            let value = |name: &str| figure(&e.figures, name);
            Evaluation {
                x: x.to_vec(),
                objective: value(&p.objective),
                values: p.constraints.iter().map(|c| value(&c.figure)).collect(),
                others: p
                    .constraints
                    .iter()
                    .map(|c| c.other.as_deref().and_then(value))
                    .collect(),
                margins: p.constraints.iter().map(|c| c.margin(value)).collect(),
                error: None,
                stage: stage.to_string(),
                overdamped: value("linear.overdamped1").map(|v| v > 0.5),
            }
        }
        Err(e) => Evaluation {
            x: x.to_vec(),
            objective: None,
            values: vec![None; nc],
            others: vec![None; nc],
            margins: vec![None; nc],
            error: Some(e.to_string().replace('\n', "; ")),
            stage: stage.to_string(),
            overdamped: None,
        },
    }
}

/// The scale of each constraint's margin: the bound's magnitude (1 for a zero bound); for
/// `A>=k*B`, the largest `|k B|` over the evaluations `grid` (else the largest `|A|`, else 1).
fn scales_of(constraints: &[Constraint], grid: &[Evaluation]) -> Vec<f64> {
    let positive = |v: f64| (v.is_finite() && v > 0.0).then_some(v);
    constraints
        .iter()
        .enumerate()
        .map(|(k, c)| match c.other {
            None => positive(c.value.abs()).unwrap_or(1.0),
            Some(_) => {
                let largest = |f: &dyn Fn(&Evaluation) -> Option<f64>| {
                    grid.iter().filter_map(f).map(f64::abs).fold(0.0, f64::max)
                };
                positive(largest(&|e| e.others[k].map(|b| c.value * b)))
                    .or_else(|| positive(largest(&|e| e.values[k])))
                    .unwrap_or(1.0)
            }
        })
        .collect()
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
    // The grid, in parallel (collected in grid order: the same result on any thread count).
    // Each point on rayon's threads as work of this call (its stop token).
    let token = crate::interrupt::current();
    let mut history: Vec<Evaluation> = grid(p)
        .par_iter()
        .map(|x| crate::interrupt::with_current(token.clone(), || evaluate(p, x, "grid")))
        .collect();
    let scales = scales_of(p.constraints, &history);
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
    // Per start: the best objective (to minimise: `sign f`) among its points feasible to
    // `ACTIVE` of each constraint's scale.
    let mut reached: Vec<Option<f64>> = vec![];
    let nearly = |e: &Evaluation| {
        e.objective.is_some()
            && e.margins
                .iter()
                .zip(&scales)
                .all(|(m, s)| m.is_some_and(|m| m >= -ACTIVE * s))
    };
    for (s, x0) in starts.iter().enumerate() {
        let stage = format!("start {s}");
        let log = std::cell::RefCell::new(Vec::<Evaluation>::new());
        // One evaluation per distinct u: COBYLA asks the objective and then each constraint
        // at the same point.
        let grid_points = &history;
        let at = |u: &[f64]| -> Evaluation {
            let x = to_x(u);
            if let Some(e) = log.borrow().iter().rev().find(|e| e.x == x) {
                return e.clone();
            }
            // The start itself is a grid point, already evaluated.
            if let Some(e) = grid_points.iter().find(|e| e.x == x) {
                return Evaluation {
                    stage: stage.clone(),
                    ..e.clone()
                };
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
        match result {
            Ok((_, u, _)) | Err((_, u, _)) => at(&u),
        };
        // (The search's own points and its start, a grid point.)
        let start = history.iter().find(|e| e.x == *x0);
        reached.push(
            log.borrow()
                .iter()
                .chain(start)
                .filter(|e| nearly(e))
                .filter_map(|e| e.objective.map(|v| sign * v))
                .reduce(f64::min),
        );
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
    let agreeing = reached
        .iter()
        .filter(|r| r.is_some_and(|v| v <= sign * value + AGREE * oscale))
        .count();
    // The active set at the optimum (scaled variables).
    let u0 = to_u(&best.x);
    let active: Vec<bool> = best
        .margins
        .iter()
        .zip(&scales)
        .map(|(m, s)| m.is_some_and(|m| m <= ACTIVE * s))
        .collect();
    let bound_side = |u: f64| {
        if u <= ACTIVE {
            Some(("lower", 1.0))
        } else if u >= 1.0 - ACTIVE {
            Some(("upper", -1.0))
        } else {
            None
        }
    };
    let at_bounds: Vec<(String, &'static str)> = p
        .variables
        .iter()
        .zip(&u0)
        .filter_map(|(v, &u)| bound_side(u).map(|(side, _)| (v.path.clone(), side)))
        .collect();
    // The gradients at the optimum (the adjoint where the figure has one, else
    // differences: `crate::sensitivity`), in the order of `Problem::gradient_figures`.
    let (gradients, gradient_error) = match crate::sensitivity::gradients(p, &best.x) {
        Ok(g) => (g, None),
        Err(e) => (vec![], Some(e.to_string())),
    };
    let of = |name: &str| {
        gradients
            .iter()
            .find(|g| g.figure == name)
            .map(|g| g.gradient.as_slice())
    };
    // In the scaled variables: d/du = (hi - lo) d/dx.
    let scaled = |g: &[f64], factor: f64| -> Vec<f64> {
        g.iter()
            .zip(p.variables)
            .map(|(d, v)| factor * d * (v.hi - v.lo))
            .collect()
    };
    // The objective to minimise and the active constraints' margins (>= 0 feasible).
    let grad_f = of(&p.objective).map(|g| scaled(g, sign / oscale));
    let mut columns: Vec<Vec<f64>> = vec![];
    let mut names: Vec<String> = vec![];
    let mut which: Vec<Option<usize>> = vec![];
    for (k, c) in p.constraints.iter().enumerate() {
        let db = c.other.as_deref().map(of);
        if let (true, Some(da), false) = (active[k], of(&c.figure), db == Some(None)) {
            columns.push(scaled(
                &c.margin_gradient(da, db.flatten()),
                1.0 / scales[k],
            ));
            names.push(c.text.clone());
            which.push(Some(k));
        }
    }
    for (i, (v, &u)) in p.variables.iter().zip(&u0).enumerate() {
        if let Some((side, normal)) = bound_side(u) {
            let mut g = vec![0.0; d];
            g[i] = normal;
            columns.push(g);
            names.push(format!("{} at its {side} bound", v.path));
            which.push(None);
        }
    }
    let (kkt, multipliers) = match &grad_f {
        Some(g) => {
            let (r, m) = kkt_residual(g, &columns);
            (Some(r), m)
        }
        None => (None, vec![]),
    };
    let largest = multipliers.iter().map(|m| m.abs()).fold(1.0, f64::max);
    let negative: Vec<&str> = names
        .iter()
        .zip(&multipliers)
        .filter(|(_, m)| **m < -SIGN_TOL * largest)
        .map(|(n, _)| n.as_str())
        .collect();
    let multipliers_nonnegative = kkt.map(|_| negative.is_empty());
    let certificate = certificate_text(kkt, &names, &negative, gradient_error.is_some());
    let mut mult_of = vec![None; p.constraints.len()];
    let mut bound_multipliers = vec![];
    for (w, m) in which.iter().zip(&multipliers) {
        match w {
            Some(k) => mult_of[*k] = Some(*m),
            None => bound_multipliers.push(*m),
        }
    }
    let constraints = p
        .constraints
        .iter()
        .enumerate()
        .map(|(k, c)| ConstraintReport {
            constraint: c.text.clone(),
            value: best.values[k].unwrap_or(f64::NAN),
            rhs: c.rhs(best.others[k]).unwrap_or(f64::NAN),
            margin: best.margins[k].unwrap_or(f64::NAN),
            scale: scales[k],
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
        bound_multipliers,
        objective: (p.objective.clone(), value),
        constraints,
        kkt_residual: kkt,
        multipliers_nonnegative,
        certificate,
        tolerances: Tolerances {
            active: ACTIVE,
            agree: AGREE,
            sign: SIGN_TOL,
        },
        gradients,
        gradient_error,
        overdamped: best.overdamped.unwrap_or(false),
        starts_agreeing: agreeing,
        starts: starts.len(),
        history,
    })
}

/// The certificate in plain sentences: the residual `kkt` on the active set `active` (its
/// members' names), the members whose multipliers are negative.
fn certificate_text(
    kkt: Option<f64>,
    active: &[String],
    negative: &[&str],
    no_gradients: bool,
) -> String {
    let Some(r) = kkt else {
        return if no_gradients {
            "No certificate: the gradients at the optimum could not be computed.".into()
        } else {
            "No certificate: the objective has no gradient at the optimum.".into()
        };
    };
    let mut text = if active.is_empty() {
        format!(
            "KKT residual {r:.1e} (nothing active): the objective's gradient, per range of the variables, is {r:.1e} of the objective's spread over the start grid."
        )
    } else {
        format!(
            "KKT residual {r:.1e} on the active set ({}): the active gradients balance the objective's gradient up to {r:.1e} of the objective's spread over the start grid per range of the variables.",
            active.join("; ")
        )
    };
    if r > KKT_STATIONARY {
        text.push_str(
            " That is not small: not a stationary point (a kink, a plateau or a search cut short).",
        );
    } else if !negative.is_empty() {
        text.push_str(&format!(
            " But the multiplier of {} is negative: leaving it improves the objective, so this is not a local optimum.",
            negative.join(", ")
        ));
    } else if active.is_empty() {
        text.push_str(" Stationary: a local optimum inside the bounds.");
    } else {
        text.push_str(" Every multiplier is >= 0: no feasible move improves the objective to first order, a local optimum.");
    }
    text
}

/// `grad f = A mu` in the least-squares sense (A's columns: the gradients of the active
/// constraints, `>= 0` feasible): `|grad f - A mu|` and `mu` (`mu >= 0` at a KKT point of a
/// minimisation).
pub fn kkt_residual(g: &[f64], columns: &[Vec<f64>]) -> (f64, Vec<f64>) {
    let d = g.len();
    let norm = g.iter().map(|x| x * x).sum::<f64>().sqrt();
    if columns.is_empty() {
        return (norm, vec![]);
    }
    let a = nalgebra::DMatrix::from_fn(d, columns.len(), |r, c| columns[c][r]);
    let b = nalgebra::DVector::from_column_slice(g);
    let svd = a.clone().svd(true, true);
    let mu = svd
        .solve(&b, 1e-12)
        .unwrap_or_else(|_| nalgebra::DVector::zeros(columns.len()));
    let r = &b - &a * &mu;
    (r.norm(), mu.iter().copied().collect())
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
    let shown =
        |v: &Option<f64>| v.map_or("n/a".to_string(), |v| crate::report::csv::cell(Some(v)));
    for ((c, v), b) in p.constraints.iter().zip(&e.values).zip(&e.others) {
        let rhs = match &c.other {
            Some(other) => format!(", {other} = {}", shown(b)),
            None => String::new(),
        };
        parts.push(format!(
            "{} = {}{rhs} (needs {})",
            c.figure,
            shown(v),
            c.text
        ));
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
        assert!((r - 1.0).abs() < 1e-15);
        assert_eq!(kkt_residual(&[0.0, 0.0], &[]).0, 0.0);
        assert_eq!(kkt_residual(&[3.0, 4.0], &[]).0, 5.0);
        // A gradient pointing out of the feasible side: a negative multiplier.
        let (r, mu) = kkt_residual(&[-2.0, 0.0], &[vec![1.0, 0.0]]);
        assert!(r < 1e-15 && (mu[0] + 2.0).abs() < 1e-15);
    }

    #[test]
    fn the_certificate_says_what_the_residual_and_the_signs_mean() {
        let active = ["reach>=0.002".to_string()];
        let ok = certificate_text(Some(1e-9), &active, &[], false);
        assert!(
            ok.contains("on the active set (reach>=0.002)") && ok.contains("a local optimum"),
            "{ok}"
        );
        let neg = certificate_text(Some(1e-9), &active, &["reach>=0.002"], false);
        assert!(
            neg.contains("multiplier of reach>=0.002 is negative"),
            "{neg}"
        );
        let big = certificate_text(Some(0.3), &[], &[], false);
        assert!(
            big.contains("(nothing active)") && big.contains("not a stationary point"),
            "{big}"
        );
        let none = certificate_text(None, &[], &[], true);
        assert!(none.starts_with("No certificate"), "{none}");
    }

    #[test]
    fn margins_of_a_constraint_between_figures_are_scaled_by_the_largest_right_hand_side() {
        let c: Constraint = "linear.reach>=4*random.rms:1.0".parse().unwrap();
        let n: Constraint = "linear.zeta1>=0".parse().unwrap();
        let point = |b: Option<f64>| Evaluation {
            x: vec![],
            objective: Some(1.0),
            values: vec![Some(1.0), Some(1.0)],
            others: vec![b, None],
            margins: vec![None, None],
            error: None,
            stage: "grid".into(),
            overdamped: None,
        };
        let scales = scales_of(&[c, n], &[point(Some(-3.0)), point(Some(2.0)), point(None)]);
        assert_eq!(scales, vec![12.0, 1.0]);
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
