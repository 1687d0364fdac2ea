//! Time integration of a closed-loop mechanism in independent coordinates (eqs. 18–25).
//!
//! The state is `y = (u, u')`. One evaluation of `y' = (u', u'')`:
//!
//! 1. dependent coordinates `v` from `h(u, v) = 0` by Newton iterations with `J_v`,
//!    warm-started from the last accepted configuration plus the first-order prediction
//!    `B (u - u_accepted)`;
//! 2. dependent velocities from eq. (18), `J_v v' = -J_u u'`;
//! 3. `M`, `F`, `Q`, `J`, `A` at `(q, q', t)` from the [`System`];
//! 4. `M^R`, `F^R`, `Q^R` from eqs. (23)–(25) ([`crate::partition::reduce_into`]) and
//!    `u''` from eq. (22) by Cholesky.
//!
//! So `v(u)` is solved to rounding level at every stage and every accepted step: the
//! constraint residual never drifts, and the integrated ODE is smooth in `u`, which keeps
//! the error estimates and the order of the method intact.
//!
//! Methods: Dormand–Prince 5(4) with PI step control, FSAL and 4th-order dense output for
//! evenly spaced output times ([`Method::Dopri5`]); or classical RK4 with a fixed step and
//! cubic Hermite output ([`Method::Rk4`]).
//!
//! After every accepted step the partition is checked: `cond(J_v)` of the current choice
//! (1-norm) is compared with the best choice by LU with full pivoting
//! ([`crate::partition::choose_partition`]); when it exceeds
//! [`PartitionSettings::switch_ratio`] times the best, or [`PartitionSettings::max_condition`],
//! the independent coordinates change (logged as a [`PartitionChange`]). A stage whose
//! projection or reduction fails triggers the same check before the step is shrunk. When
//! `J` itself loses rank (or the best `J_v` is worse than
//! [`PartitionSettings::singular_condition`]) no partition can help: the run stops with
//! [`SimError::Singular`], naming time, coordinates and the smallest singular value. The
//! state is checked for finiteness everywhere: a run never returns NaN.

use std::fmt;

use nalgebra::{DMatrix, DVector};

use crate::partition::{
    self, Partition, PartitionChoice, ReduceWorkspace, Reduced, choose_partition,
};

use super::dopri;
use super::error::{RedundancyReport, RedundantRow, SimError, SingularReport};
use super::projection::{ProjectionError, Projector};
use mbs_symbolic::runtime::{System, Workspace};

/// The integration method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// Dormand–Prince 5(4), adaptive.
    Dopri5 {
        /// Relative tolerance.
        rtol: f64,
        /// Absolute tolerance.
        atol: f64,
        /// First step (`None`: Hairer's starting-step heuristic).
        initial_step: Option<f64>,
        /// Largest step (`None`: unlimited).
        max_step: Option<f64>,
    },
    /// Classical fourth-order Runge–Kutta with a fixed step (rounded so that an integer
    /// number of steps spans the interval).
    Rk4 {
        /// The step.
        step: f64,
    },
}

/// How the independent coordinates are chosen and monitored.
#[derive(Clone, Debug, PartialEq)]
pub struct PartitionSettings {
    /// User-chosen independent coordinates (indices); `None`: automatic (LU with full
    /// pivoting of `J`).
    pub independent: Option<Vec<usize>>,
    /// Drop redundant constraint rows instead of stopping with a diagnosis.
    pub allow_redundant: bool,
    /// Change the partition automatically when `J_v` degrades.
    pub repartition: bool,
    /// Change when `cond(J_v) > switch_ratio * cond(best J_v)` (default 10).
    pub switch_ratio: f64,
    /// Change when `cond(J_v) > max_condition` whatever the best (default 1e8).
    pub max_condition: f64,
    /// Stop when even the best `J_v` is worse than this (default 1e12).
    pub singular_condition: f64,
    /// Relative pivot tolerance of the rank decision (default 1e-9).
    pub rank_tol: f64,
}

impl Default for PartitionSettings {
    fn default() -> Self {
        PartitionSettings {
            independent: None,
            allow_redundant: false,
            repartition: true,
            switch_ratio: 10.0,
            max_condition: 1e8,
            singular_condition: 1e12,
            rank_tol: 1e-9,
        }
    }
}

/// Settings of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Integration method and its tolerances or step.
    pub method: Method,
    /// Start time.
    pub t_start: f64,
    /// End time.
    pub t_end: f64,
    /// Spacing of the output times (`t_start + k * output_step`, plus `t_end`).
    pub output_step: f64,
    /// Partition choice and monitoring.
    pub partition: PartitionSettings,
    /// Tolerance of the position projection on `max |h_i|` (model length units; default
    /// 1e-10). Newton is iterated to rounding level; this only decides failure.
    pub projection_tol: f64,
    /// Step limit (default 10 000 000).
    pub max_steps: usize,
    /// Print partition changes on standard error as they happen.
    pub log: bool,
}

impl Settings {
    /// Dormand–Prince settings with the given tolerances and defaults elsewhere.
    pub fn dopri5(t_end: f64, rtol: f64, atol: f64, output_step: f64) -> Settings {
        Settings {
            method: Method::Dopri5 {
                rtol,
                atol,
                initial_step: None,
                max_step: None,
            },
            t_start: 0.0,
            t_end,
            output_step,
            partition: PartitionSettings::default(),
            projection_tol: 1e-10,
            max_steps: 10_000_000,
            log: false,
        }
    }

    /// Fixed-step RK4 settings with defaults elsewhere.
    pub fn rk4(t_end: f64, step: f64, output_step: f64) -> Settings {
        Settings {
            method: Method::Rk4 { step },
            ..Settings::dopri5(t_end, 1e-8, 1e-10, output_step)
        }
    }

    fn validate(&self) -> Result<(), SimError> {
        let bad = |m: String| Err(SimError::Settings(m));
        let pos = |x: f64| x.is_finite() && x > 0.0;
        if !(self.t_start.is_finite() && self.t_end.is_finite() && self.t_end > self.t_start) {
            return bad(format!(
                "t_end ({}) must be finite and greater than t_start ({})",
                self.t_end, self.t_start
            ));
        }
        if !pos(self.output_step) {
            return bad(format!(
                "output_step ({}) must be positive",
                self.output_step
            ));
        }
        match self.method {
            Method::Dopri5 {
                rtol,
                atol,
                initial_step,
                max_step,
            } => {
                if !(1e-15..1.0).contains(&rtol) {
                    return bad(format!("rtol ({rtol}) must be in [1e-15, 1)"));
                }
                if !(atol.is_finite() && atol >= 0.0) {
                    return bad(format!("atol ({atol}) must be finite and non-negative"));
                }
                if let Some(h) = initial_step.filter(|h| !pos(*h)) {
                    return bad(format!("initial_step ({h}) must be positive"));
                }
                if let Some(h) = max_step.filter(|h| !pos(*h)) {
                    return bad(format!("max_step ({h}) must be positive"));
                }
            }
            Method::Rk4 { step } => {
                if !pos(step) {
                    return bad(format!("step ({step}) must be positive"));
                }
                if (self.t_end - self.t_start) / step > self.max_steps as f64 {
                    return bad(format!(
                        "step ({step}) needs more than max_steps ({}) steps",
                        self.max_steps
                    ));
                }
            }
        }
        let p = &self.partition;
        if !(p.switch_ratio.is_finite() && p.switch_ratio >= 1.0) {
            return bad(format!("switch_ratio ({}) must be >= 1", p.switch_ratio));
        }
        if !(pos(p.max_condition) && pos(p.singular_condition) && pos(self.projection_tol)) {
            return bad(
                "max_condition, singular_condition and projection_tol must be positive".into(),
            );
        }
        if !(p.rank_tol.is_finite() && p.rank_tol > 0.0 && p.rank_tol < 1.0) {
            return bad(format!("rank_tol ({}) must be in (0, 1)", p.rank_tol));
        }
        Ok(())
    }
}

/// One output sample.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputRow {
    /// Time.
    pub t: f64,
    /// All coordinates `q`.
    pub q: Vec<f64>,
    /// All velocities `q'`.
    pub qd: Vec<f64>,
    /// `T = 1/2 q'^T M q'`.
    pub kinetic_energy: f64,
    /// `V(q)` when the system knows it.
    pub potential_energy: Option<f64>,
    /// `|h(q)|_2` over all constraint rows.
    pub residual_norm: f64,
    /// 1-norm condition number of `J_v` of the partition in use.
    pub cond_jv: f64,
}

impl OutputRow {
    /// `T + V` when `V` is known.
    pub fn total_energy(&self) -> Option<f64> {
        self.potential_energy.map(|v| v + self.kinetic_energy)
    }
}

/// A change of independent coordinates during a run.
#[derive(Clone, Debug, PartialEq)]
pub struct PartitionChange {
    /// Time of the change.
    pub t: f64,
    /// Independent coordinates before, by name.
    pub from: Vec<String>,
    /// Independent coordinates after, by name.
    pub to: Vec<String>,
    /// `cond(J_v)` before.
    pub cond_before: f64,
    /// `cond(J_v)` after.
    pub cond_after: f64,
}

impl fmt::Display for PartitionChange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "t={:.6}: partition changed: independent [{}] -> [{}] (cond(J_v) {:.3e} -> {:.3e})",
            self.t,
            self.from.join(", "),
            self.to.join(", "),
            self.cond_before,
            self.cond_after
        )
    }
}

/// Counters and extremes of a run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stats {
    /// Accepted steps.
    pub steps_accepted: usize,
    /// Rejected steps (error too large or a failed stage).
    pub steps_rejected: usize,
    /// Evaluations of the reduced equations.
    pub rhs_evaluations: usize,
    /// Newton iterations of the position projection, in total.
    pub newton_iterations: usize,
    /// Largest `|h|_2` seen at accepted steps and output times.
    pub max_residual: f64,
    /// Total energy at the first output time (when known).
    pub initial_energy: Option<f64>,
    /// Largest `|E(t) - E(t_start)|` over the output times (when known).
    pub max_energy_error: Option<f64>,
    /// Largest kinetic energy over the output times.
    pub max_kinetic_energy: f64,
    /// Time reached.
    pub final_time: f64,
    /// Smallest accepted step.
    pub min_step: f64,
    /// Largest accepted step.
    pub max_step: f64,
}

/// What a run reports while it goes.
#[derive(Debug)]
pub enum Event<'a> {
    /// An output sample.
    Output(&'a OutputRow),
    /// The independent coordinates changed.
    PartitionChanged(&'a PartitionChange),
    /// A step was accepted; the run has reached `t`.
    Step {
        /// Time reached.
        t: f64,
    },
}

/// Everything a finished run produced.
#[derive(Clone, Debug, PartialEq)]
pub struct Trajectory {
    /// Output samples.
    pub rows: Vec<OutputRow>,
    /// Partition changes, in time order.
    pub changes: Vec<PartitionChange>,
    /// Counters.
    pub stats: Stats,
    /// The independent coordinates at the start, by name.
    pub initial_independent: Vec<String>,
    /// The independent coordinates at the end, by name.
    pub final_independent: Vec<String>,
    /// Constraint rows dropped as redundant, by name.
    pub dropped_rows: Vec<String>,
}

/// Runs a simulation from a consistent state and collects the output.
///
/// `q0`, `qd0` must satisfy the constraints (use [`super::assembly`] first); the dependent
/// coordinates are re-projected to rounding level before the start.
pub fn simulate<S: System + ?Sized>(
    sys: &S,
    settings: Settings,
    q0: &[f64],
    qd0: &[f64],
) -> Result<Trajectory, SimError> {
    let mut sim = Simulator::new(sys, settings, q0, qd0)?;
    let mut rows = Vec::new();
    sim.run(&mut |e| {
        if let Event::Output(r) = e {
            rows.push(r.clone());
        }
    })?;
    Ok(Trajectory {
        rows,
        changes: sim.changes().to_vec(),
        stats: sim.stats().clone(),
        initial_independent: sim.initial_independent.clone(),
        final_independent: sim.independent_names(),
        dropped_rows: sim.dropped_rows().to_vec(),
    })
}

/// Why one evaluation of the reduced equations failed (the step is retried smaller).
#[derive(Clone, Debug)]
enum StageError {
    Projection(ProjectionError),
    Reduction(partition::PartitionError),
    NonFinite,
}

impl fmt::Display for StageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StageError::Projection(e) => write!(f, "{e}"),
            StageError::Reduction(e) => write!(f, "{e}"),
            StageError::NonFinite => f.write_str("non-finite state or derivative"),
        }
    }
}

/// A closed-loop simulation in progress: the accepted state, the partition and the
/// scratch buffers. [`simulate`] is the one-call form.
pub struct Simulator<'s, S: System + ?Sized> {
    sys: &'s S,
    settings: Settings,
    ws: Workspace,
    proj: Projector,
    red: Reduced,
    rws: ReduceWorkspace,
    jr: DMatrix<f64>,
    ar: DVector<f64>,
    partition: Partition,
    expected_rank: usize,
    dropped: Vec<String>,
    initial_independent: Vec<String>,
    // Accepted state.
    t: f64,
    q: Vec<f64>,
    qd: Vec<f64>,
    b_acc: DMatrix<f64>,
    cond: f64,
    // Scratch of the last evaluation.
    qt: Vec<f64>,
    qdt: Vec<f64>,
    udd: DVector<f64>,
    last_cond: f64,
    stats: Stats,
    changes: Vec<PartitionChange>,
    next_output: usize,
    output_count: usize,
}

fn fmt_coords(names: &[String], q: &[f64]) -> String {
    names
        .iter()
        .zip(q)
        .map(|(n, v)| format!("{n} = {v:.9}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Smallest and largest singular values of `j` (1, 1 for an empty matrix).
fn singular_range(j: &DMatrix<f64>) -> (f64, f64) {
    if j.nrows() == 0 || j.ncols() == 0 || j.iter().any(|x| !x.is_finite()) {
        return (0.0, 0.0);
    }
    let s = j.clone().svd(false, false).singular_values;
    let lo = s.iter().fold(f64::INFINITY, |m, x| m.min(*x));
    let hi = s.iter().fold(0.0f64, |m, x| m.max(*x));
    (lo, hi)
}

/// The name of constraint row `r` (a placeholder if the system names fewer rows).
fn row_name(names: &[String], r: usize) -> String {
    names.get(r).cloned().unwrap_or_else(|| format!("row {r}"))
}

/// Names the redundant rows of `j` and the combinations of kept rows they equal.
fn redundancy_report(
    j: &DMatrix<f64>,
    choice: &PartitionChoice,
    names: &[String],
) -> RedundancyReport {
    let kept = choice.independent_rows(j.nrows());
    let jk = DMatrix::from_fn(kept.len(), j.ncols(), |r, c| j[(kept[r], c)]);
    let redundant = choice
        .redundant_rows
        .iter()
        .map(|&r| {
            // J_r^T = Jk^T c in the least-squares sense.
            let target = DVector::from_fn(j.ncols(), |c, _| j[(r, c)]);
            let scale = target.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let combination = if kept.is_empty() || scale == 0.0 {
                vec![]
            } else {
                let svd = jk.transpose().svd(true, true);
                match svd.solve(&target, 1e-12) {
                    Ok(c) => kept
                        .iter()
                        .zip(c.iter())
                        .filter(|(_, c)| c.abs() > 1e-8)
                        .map(|(&k, &c)| (row_name(names, k), c))
                        .collect(),
                    Err(_) => vec![],
                }
            };
            RedundantRow {
                name: row_name(names, r),
                combination,
            }
        })
        .collect();
    RedundancyReport {
        rank: choice.rank,
        rows: j.nrows(),
        redundant,
    }
}

impl<'s, S: System + ?Sized> Simulator<'s, S> {
    /// Prepares a run from a consistent state: checks the settings, examines the rank of
    /// `J` (redundant rows are diagnosed by name, or dropped when allowed; a rank drop
    /// that disappears nearby is a singular configuration), chooses the partition and
    /// projects the dependent coordinates and velocities (eq. 18) to rounding level.
    pub fn new(sys: &'s S, settings: Settings, q0: &[f64], qd0: &[f64]) -> Result<Self, SimError> {
        settings.validate()?;
        let n = sys.dof();
        let rows = sys.rows();
        if q0.len() != n || qd0.len() != n {
            return Err(SimError::Settings(format!(
                "{} coordinates and {} velocities given, the mechanism has {n}",
                q0.len(),
                qd0.len()
            )));
        }
        let names = sys.coordinate_names().to_vec();
        if q0.iter().chain(qd0).any(|x| !x.is_finite()) {
            return Err(SimError::Diverged {
                t: settings.t_start,
                cause: "non-finite initial state".into(),
                coordinates: fmt_coords(&names, q0),
            });
        }
        let mut ws = sys.workspace();
        let ps = settings.partition.clone();
        sys.evaluate_positions(q0, &mut ws);
        let choice = choose_partition(&ws.j, ps.rank_tol);
        let mut active: Vec<usize> = (0..rows).collect();
        let mut dropped = vec![];
        if choice.rank < rows {
            // Structural redundancy persists at a nearby (not assembled) configuration; a
            // rank drop that disappears there is a singular configuration.
            let qp: Vec<f64> = q0
                .iter()
                .enumerate()
                .map(|(i, x)| {
                    x + 1e-3 * (1.0 + 0.37 * i as f64) * if i % 2 == 0 { 1.0 } else { -1.0 }
                })
                .collect();
            let mut wp = sys.workspace();
            sys.evaluate_positions(&qp, &mut wp);
            let near = choose_partition(&wp.j, ps.rank_tol);
            if near.rank > choice.rank {
                let (lo, hi) = singular_range(&ws.j);
                return Err(SimError::Singular(SingularReport {
                    t: settings.t_start,
                    coordinates: names.iter().cloned().zip(q0.iter().copied()).collect(),
                    sigma_min: lo,
                    sigma_max: hi,
                    rank: choice.rank,
                    expected_rank: near.rank,
                    best_condition: f64::INFINITY,
                }));
            }
            let report = redundancy_report(&ws.j, &choice, sys.constraint_names());
            if !ps.allow_redundant {
                return Err(SimError::Redundant(report));
            }
            if settings.log {
                eprintln!("{report}: dropping the redundant rows");
            }
            active = choice.independent_rows(rows);
            dropped = choice
                .redundant_rows
                .iter()
                .map(|&r| row_name(sys.constraint_names(), r))
                .collect();
        }
        let rank = choice.rank;
        let mut sim = Simulator {
            sys,
            ws,
            proj: Projector::new(n, active.clone(), settings.projection_tol),
            red: Reduced::empty(),
            rws: ReduceWorkspace::new(),
            jr: DMatrix::zeros(rank, n),
            ar: DVector::zeros(rank),
            partition: choice.partition.clone(),
            expected_rank: rank,
            dropped,
            initial_independent: vec![],
            t: settings.t_start,
            q: q0.to_vec(),
            qd: qd0.to_vec(),
            b_acc: DMatrix::zeros(rank, n - rank),
            cond: choice.condition,
            qt: q0.to_vec(),
            qdt: qd0.to_vec(),
            udd: DVector::zeros(n - rank),
            last_cond: choice.condition,
            stats: Stats {
                final_time: settings.t_start,
                min_step: f64::INFINITY,
                ..Stats::default()
            },
            changes: vec![],
            next_output: 0,
            output_count: 0,
            settings,
        };
        let auto = choice.partition;
        if let Some(ind) = &ps.independent {
            let user = Partition::from_independent(n, ind)
                .map_err(|e| SimError::Partition(e.to_string()))?;
            if user.independent.len() != n - rank {
                return Err(SimError::Partition(format!(
                    "{} independent coordinates chosen ([{}]), but the mechanism has {} degrees \
                     of freedom (n = {n}, rank of J = {rank})",
                    user.independent.len(),
                    sim.names_of(&user.independent).join(", "),
                    n - rank
                )));
            }
            sim.partition = user;
            sim.proj.load_active_jacobian(&sim.ws);
            let cond = sim.jv_condition(&sim.partition.clone());
            sim.cond = cond;
            if cond > sim.settings.partition.singular_condition {
                if !ps.repartition {
                    return Err(SimError::Partition(format!(
                        "the chosen independent coordinates [{}] make J_v singular at the \
                         initial configuration (cond {cond:.3e}); choose others or enable \
                         repartitioning",
                        sim.independent_names().join(", ")
                    )));
                }
                sim.switch_to(auto, &mut |_| {});
            }
        }
        sim.initial_independent = sim.independent_names();
        // Project to rounding level and make the velocities satisfy eq. (18) exactly.
        sim.b_acc = DMatrix::zeros(rank, n - rank);
        // (Skipped when the residual is already at rounding level, so that the coordinates
        // the user held keep their exact values.)
        sim.sys.evaluate_positions(&sim.q, &mut sim.ws);
        sim.proj.load_active_jacobian(&sim.ws);
        let initial_residual = sim.ws.h.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let mut qt = std::mem::take(&mut sim.qt);
        qt.copy_from_slice(&sim.q);
        let projected = if initial_residual <= 1e-15 {
            Ok(None)
        } else {
            sim.proj
                .project(sim.sys, &mut sim.ws, &sim.partition, &mut qt)
                .map(Some)
        };
        sim.qt = qt;
        match projected {
            Ok(p) => sim.stats.newton_iterations += p.map_or(0, |p| p.iterations),
            Err(e) => {
                return Err(SimError::Diverged {
                    t: sim.t,
                    cause: format!(
                        "the initial configuration does not satisfy the constraints ({e}); \
                         assemble it first"
                    ),
                    coordinates: fmt_coords(&names, q0),
                });
            }
        }
        sim.q.copy_from_slice(&sim.qt);
        let vel_res = {
            let qdv = DVector::from_column_slice(&sim.qd);
            let r = &sim.proj.j * qdv;
            r.iter().fold(0.0f64, |m, x| m.max(x.abs()))
        };
        let vel_scale = sim.proj.j.iter().fold(0.0f64, |m, x| m.max(x.abs()))
            * sim.qd.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if vel_res > 1e-6 * vel_scale.max(f64::MIN_POSITIVE) {
            return Err(SimError::Diverged {
                t: sim.t,
                cause: format!(
                    "the initial velocities violate J q' = 0 (max |J q'| = {vel_res:.3e}); \
                     assemble them first"
                ),
                coordinates: fmt_coords(&names, q0),
            });
        }
        let mut qd = std::mem::take(&mut sim.qd);
        let part = sim.partition.clone();
        let cond = sim
            .proj
            .velocities(&part, &mut qd)
            .map_err(|e| SimError::Partition(e.to_string()))?;
        sim.qd = qd;
        sim.cond = cond;
        Ok(sim)
    }

    /// The counters so far (also valid after a failed run).
    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// Partition changes so far.
    pub fn changes(&self) -> &[PartitionChange] {
        &self.changes
    }

    /// Constraint rows dropped as redundant.
    pub fn dropped_rows(&self) -> &[String] {
        &self.dropped
    }

    /// The current independent coordinates, by name.
    pub fn independent_names(&self) -> Vec<String> {
        self.names_of(&self.partition.independent)
    }

    /// The independent coordinates at the start, by name.
    pub fn initial_independent(&self) -> &[String] {
        &self.initial_independent
    }

    /// The current partition.
    pub fn partition(&self) -> &Partition {
        &self.partition
    }

    /// Time and state of the last accepted step.
    pub fn state(&self) -> (f64, &[f64], &[f64]) {
        (self.t, &self.q, &self.qd)
    }

    fn names_of(&self, idx: &[usize]) -> Vec<String> {
        let names = self.sys.coordinate_names();
        idx.iter()
            .map(|&i| names.get(i).cloned().unwrap_or_else(|| format!("q[{i}]")))
            .collect()
    }

    /// `cond(J_v)` of partition `p` from the active rows in `self.proj.j`.
    fn jv_condition(&self, p: &Partition) -> f64 {
        let r = self.proj.rows.len();
        let jv = DMatrix::from_fn(r, p.dependent.len(), |i, k| {
            self.proj.j[(i, p.dependent[k])]
        });
        if jv.nrows() != jv.ncols() {
            return f64::INFINITY;
        }
        partition::condition_number(&jv)
    }

    fn y_of_state(&self) -> DVector<f64> {
        let nu = self.partition.independent.len();
        DVector::from_fn(2 * nu, |i, _| {
            if i < nu {
                self.q[self.partition.independent[i]]
            } else {
                self.qd[self.partition.independent[i - nu]]
            }
        })
    }

    /// One evaluation of the reduced equations at `(t, y)`; leaves the full state in
    /// `qt`, `qdt` and the evaluation in `ws`, `red`.
    fn rhs(&mut self, t: f64, y: &DVector<f64>, dy: &mut DVector<f64>) -> Result<(), StageError> {
        self.stats.rhs_evaluations += 1;
        let nu = self.partition.independent.len();
        if y.iter().any(|x| !x.is_finite()) {
            return Err(StageError::NonFinite);
        }
        // Warm start: accepted configuration + B (u - u_accepted).
        self.qt.copy_from_slice(&self.q);
        for (l, &i) in self.partition.independent.iter().enumerate() {
            self.qt[i] = y[l];
        }
        if self.b_acc.shape() == (self.partition.dependent.len(), nu) {
            for (k, &d) in self.partition.dependent.iter().enumerate() {
                let mut s = 0.0;
                for (l, &i) in self.partition.independent.iter().enumerate() {
                    s += self.b_acc[(k, l)] * (y[l] - self.q[i]);
                }
                self.qt[d] += s;
            }
        }
        let mut qt = std::mem::take(&mut self.qt);
        let res = self
            .proj
            .project(self.sys, &mut self.ws, &self.partition, &mut qt);
        self.qt = qt;
        let p = res.map_err(StageError::Projection)?;
        self.stats.newton_iterations += p.iterations;
        for (l, &i) in self.partition.independent.iter().enumerate() {
            self.qdt[i] = y[nu + l];
        }
        let mut qdt = std::mem::take(&mut self.qdt);
        let vres = self.proj.velocities(&self.partition, &mut qdt);
        self.qdt = qdt;
        vres.map_err(StageError::Reduction)?;
        self.sys.evaluate(&self.qt, &self.qdt, t, &mut self.ws);
        for (k, &r) in self.proj.rows.iter().enumerate() {
            for c in 0..self.ws.j.ncols() {
                self.jr[(k, c)] = self.ws.j[(r, c)];
            }
            self.ar[k] = self.ws.a[r];
        }
        partition::reduce_into(
            &self.ws.m,
            &self.ws.f,
            &self.ws.q,
            &self.jr,
            &self.ar,
            &self.partition,
            &mut self.rws,
            &mut self.red,
        )
        .map_err(StageError::Reduction)?;
        self.red
            .accelerations_into(&mut self.rws, &mut self.udd)
            .map_err(StageError::Reduction)?;
        for l in 0..nu {
            dy[l] = y[nu + l];
            dy[nu + l] = self.udd[l];
        }
        self.last_cond = self.red.jv_condition;
        if dy.iter().any(|x| !x.is_finite()) {
            return Err(StageError::NonFinite);
        }
        Ok(())
    }

    /// Makes the last evaluated state the accepted one.
    fn accept_last(&mut self, t: f64) {
        self.t = t;
        self.q.copy_from_slice(&self.qt);
        self.qd.copy_from_slice(&self.qdt);
        self.b_acc.clone_from(&self.red.b);
        self.cond = self.last_cond;
        let res = self.ws.h.norm();
        self.stats.max_residual = self.stats.max_residual.max(res);
        self.stats.final_time = t;
    }

    /// Builds the output row of the last evaluated state.
    fn output_row(&mut self, t: f64) -> OutputRow {
        let qd = DVector::from_column_slice(&self.qdt);
        let kinetic_energy = 0.5 * qd.dot(&(&self.ws.m * &qd));
        let potential_energy = Some(self.sys.potential_energy(&self.qt, &mut self.ws));
        OutputRow {
            t,
            q: self.qt.clone(),
            qd: self.qdt.clone(),
            kinetic_energy,
            potential_energy,
            residual_norm: self.ws.h.norm(),
            cond_jv: self.last_cond,
        }
    }

    fn output_time(&self, k: usize) -> f64 {
        let s = &self.settings;
        (s.t_start + k as f64 * s.output_step).min(s.t_end)
    }

    /// Number of output times: the grid `t_start + k * output_step` up to `t_end`, plus
    /// `t_end` itself when it is not on the grid.
    fn output_total(&self) -> usize {
        let s = &self.settings;
        let span = (s.t_end - s.t_start) / s.output_step;
        let k = (span + 1e-9).floor() as usize;
        if (s.t_start + k as f64 * s.output_step) < s.t_end - 1e-9 * s.output_step {
            k + 2
        } else {
            k + 1
        }
    }

    fn emit(&mut self, t: f64, observer: &mut dyn FnMut(Event<'_>)) {
        let row = self.output_row(t);
        self.stats.max_residual = self.stats.max_residual.max(row.residual_norm);
        self.stats.max_kinetic_energy = self.stats.max_kinetic_energy.max(row.kinetic_energy);
        if let Some(e) = row.total_energy() {
            match self.stats.initial_energy {
                None => {
                    self.stats.initial_energy = Some(e);
                    self.stats.max_energy_error = Some(0.0);
                }
                Some(e0) => {
                    let d = (e - e0).abs();
                    self.stats.max_energy_error =
                        Some(self.stats.max_energy_error.unwrap_or(0.0).max(d));
                }
            }
        }
        observer(Event::Output(&row));
    }

    fn error_coords(&self) -> String {
        fmt_coords(self.sys.coordinate_names(), &self.q)
    }

    fn diverged(&self, cause: String) -> SimError {
        SimError::Diverged {
            t: self.t,
            cause,
            coordinates: self.error_coords(),
        }
    }

    /// Changes to partition `p` at the accepted state and logs it.
    fn switch_to(&mut self, p: Partition, observer: &mut dyn FnMut(Event<'_>)) {
        let cond_after = self.jv_condition(&p);
        let change = PartitionChange {
            t: self.t,
            from: self.independent_names(),
            to: self.names_of(&p.independent),
            cond_before: self.cond,
            cond_after,
        };
        if self.settings.log {
            eprintln!("{change}");
        }
        observer(Event::PartitionChanged(&change));
        self.changes.push(change);
        self.partition = p;
        self.cond = cond_after;
        self.b_acc = DMatrix::zeros(0, 0);
    }

    /// Examines the partition at the accepted state: stops on a rank drop, switches when
    /// the current `J_v` is much worse than the best. Returns whether it switched.
    fn monitor(&mut self, observer: &mut dyn FnMut(Event<'_>)) -> Result<bool, SimError> {
        self.sys.evaluate_positions(&self.q, &mut self.ws);
        self.proj.load_active_jacobian(&self.ws);
        let choice = choose_partition(&self.proj.j, self.settings.partition.rank_tol);
        let ps = &self.settings.partition;
        if choice.rank < self.expected_rank || choice.condition > ps.singular_condition {
            let (lo, hi) = singular_range(&self.proj.j);
            return Err(SimError::Singular(SingularReport {
                t: self.t,
                coordinates: self
                    .sys
                    .coordinate_names()
                    .iter()
                    .cloned()
                    .zip(self.q.iter().copied())
                    .collect(),
                sigma_min: lo,
                sigma_max: hi,
                rank: choice.rank,
                expected_rank: self.expected_rank,
                best_condition: if choice.rank < self.expected_rank {
                    f64::INFINITY
                } else {
                    choice.condition
                },
            }));
        }
        if !ps.repartition || choice.partition == self.partition {
            return Ok(false);
        }
        let degraded =
            self.cond > ps.switch_ratio * choice.condition || self.cond > ps.max_condition;
        if degraded {
            self.switch_to(choice.partition, observer);
            return Ok(true);
        }
        Ok(false)
    }

    /// Evaluates `y'` at the accepted state after a change of partition (new FSAL stage)
    /// and refreshes `B` for the warm start.
    fn restart(&mut self, k1: &mut DVector<f64>) -> Result<DVector<f64>, SimError> {
        let y = self.y_of_state();
        if k1.len() != y.len() {
            *k1 = DVector::zeros(y.len());
        }
        let t = self.t;
        self.rhs(t, &y, k1)
            .map_err(|e| self.diverged(format!("evaluation at the accepted state failed: {e}")))?;
        self.b_acc.clone_from(&self.red.b);
        self.cond = self.last_cond;
        Ok(y)
    }

    /// Runs to `t_end`, reporting outputs, partition changes and progress to `observer`.
    pub fn run(&mut self, observer: &mut dyn FnMut(Event<'_>)) -> Result<(), SimError> {
        let mut k1 = DVector::zeros(0);
        let mut y = self.restart(&mut k1)?;
        if self.next_output == 0 {
            let t0 = self.t;
            self.emit(t0, observer);
            self.next_output = 1;
        }
        self.output_count = self.output_total();
        match self.settings.method {
            Method::Dopri5 { .. } => self.run_dopri(&mut y, &mut k1, observer),
            Method::Rk4 { step } => self.run_rk4(step, &mut y, &mut k1, observer),
        }
    }

    /// Emits the outputs with times in `(t_old, t_new]` using `interp(theta)` for `y`.
    fn outputs_in_step(
        &mut self,
        t_old: f64,
        h: f64,
        interp: &dyn Fn(f64, &mut DVector<f64>),
        observer: &mut dyn FnMut(Event<'_>),
    ) -> Result<(), SimError> {
        let t_new = t_old + h;
        let last =
            (t_new - self.settings.t_end).abs() <= 1e-12 * self.settings.t_end.abs().max(1.0);
        let mut yo = DVector::zeros(2 * self.partition.independent.len());
        let mut dy = yo.clone();
        while self.next_output < self.output_count {
            let to = self.output_time(self.next_output);
            let within = to <= t_new + 1e-12 * t_new.abs().max(1.0);
            if !(within || last) {
                break;
            }
            let theta = ((to - t_old) / h).clamp(0.0, 1.0);
            interp(theta, &mut yo);
            if let Err(e) = self.rhs(to, &yo, &mut dy) {
                return Err(self.diverged(format!("evaluation at output time {to} failed: {e}")));
            }
            self.emit(to, observer);
            self.next_output += 1;
        }
        Ok(())
    }

    fn step_too_small(&self, h: f64, cause: String) -> SimError {
        let (lo, _) = singular_range(&self.proj.j);
        SimError::StepSizeTooSmall {
            t: self.t,
            h,
            cause,
            cond: self.cond,
            sigma_min: lo,
            coordinates: self.error_coords(),
        }
    }

    fn run_dopri(
        &mut self,
        y: &mut DVector<f64>,
        k1: &mut DVector<f64>,
        observer: &mut dyn FnMut(Event<'_>),
    ) -> Result<(), SimError> {
        let Method::Dopri5 {
            rtol,
            atol,
            initial_step,
            max_step,
        } = self.settings.method
        else {
            unreachable!("run_dopri is only called for Dopri5")
        };
        let t_end = self.settings.t_end;
        let h_max = max_step
            .unwrap_or(f64::INFINITY)
            .min(t_end - self.settings.t_start);
        let mut ctrl = dopri::Controller::new();
        let mut h = match initial_step {
            Some(h) => h,
            None => self.initial_step(y, k1, rtol, atol),
        }
        .min(h_max);
        let dim = y.len();
        let mut k: Vec<DVector<f64>> = vec![DVector::zeros(dim); 7];
        let mut ys = DVector::zeros(dim);
        let mut y_new = DVector::zeros(dim);
        let mut last_rejected = false;
        let mut last_cause = String::from("error estimate");
        while self.t < t_end {
            if self.stats.steps_accepted + self.stats.steps_rejected >= self.settings.max_steps {
                return Err(SimError::TooManySteps {
                    t: self.t,
                    max_steps: self.settings.max_steps,
                });
            }
            if dim != y.len() {
                // The partition changed size (cannot happen with a constant rank).
                return Err(self.diverged("state size changed".into()));
            }
            let remaining = t_end - self.t;
            let final_step = self.t + 1.01 * h >= t_end;
            if final_step {
                h = remaining;
            }
            let h_min = 1e-14 * self.t.abs().max(1.0) * 16.0;
            if h < h_min {
                return Err(self.step_too_small(h, last_cause));
            }
            k[0].copy_from(k1);
            let attempt = (|| -> Result<(), StageError> {
                for s in 1..7 {
                    ys.copy_from(y);
                    for (r, kr) in k.iter().enumerate().take(s) {
                        let a = dopri::A[s][r];
                        if a != 0.0 {
                            ys.axpy(h * a, kr, 1.0);
                        }
                    }
                    let ts = self.t + dopri::C[s] * h;
                    let mut ks = std::mem::replace(&mut k[s], DVector::zeros(0));
                    let r = self.rhs(ts, &ys, &mut ks);
                    k[s] = ks;
                    r?;
                }
                Ok(())
            })();
            if let Err(e) = attempt {
                last_cause = format!("stage failed: {e}");
                self.stats.steps_rejected += 1;
                // A degenerating partition shows up here first: re-choose at the accepted
                // state, and retry the same step when it changed.
                if self.settings.partition.repartition && self.monitor(observer)? {
                    *y = self.restart(k1)?;
                    ctrl.reset();
                } else {
                    h *= 0.25;
                    last_rejected = true;
                }
                continue;
            }
            // ys holds the fifth-order solution (the stage-7 point), k[6] its slope.
            y_new.copy_from(&ys);
            let mut err2 = 0.0;
            for i in 0..dim {
                let e = h * (0..7).map(|s| dopri::E[s] * k[s][i]).sum::<f64>();
                let sc = atol + rtol * y[i].abs().max(y_new[i].abs());
                err2 += (e / sc).powi(2);
            }
            let err = (err2 / dim.max(1) as f64).sqrt();
            if !(err.is_finite() && err <= 1.0) {
                last_cause = format!("error estimate {err:.3e} with rtol {rtol:.1e}");
                h = ctrl.reject(h, if err.is_finite() { err } else { 1e10 });
                last_rejected = true;
                self.stats.steps_rejected += 1;
                continue;
            }
            // Accepted: the last evaluation (stage 7) is the projected state at t + h.
            let t_old = self.t;
            self.accept_last(if final_step { t_end } else { t_old + h });
            self.stats.steps_accepted += 1;
            self.stats.min_step = self.stats.min_step.min(h);
            self.stats.max_step = self.stats.max_step.max(h);
            {
                let (y0, y1, ks) = (&*y, &y_new, &k);
                let interp = |theta: f64, out: &mut DVector<f64>| {
                    for i in 0..out.len() {
                        let kk = [
                            ks[0][i], ks[1][i], ks[2][i], ks[3][i], ks[4][i], ks[5][i], ks[6][i],
                        ];
                        out[i] = dopri::dense(theta, h, y0[i], y1[i], &kk);
                    }
                };
                self.outputs_in_step(t_old, h, &interp, observer)?;
            }
            y.copy_from(&y_new);
            k1.copy_from(&k[6]);
            let mut h_new = ctrl.accept(h, err);
            if last_rejected {
                h_new = h_new.min(h);
            }
            last_rejected = false;
            h = h_new.min(h_max);
            observer(Event::Step { t: self.t });
            if self.t < t_end && self.monitor(observer)? {
                *y = self.restart(k1)?;
                ctrl.reset();
            }
        }
        Ok(())
    }

    /// Hairer's starting step (`HINIT` of DOPRI5).
    fn initial_step(&mut self, y: &DVector<f64>, f0: &DVector<f64>, rtol: f64, atol: f64) -> f64 {
        let dim = y.len().max(1) as f64;
        let sc = |i: usize| atol + rtol * y[i].abs();
        let norm = |v: &DVector<f64>| {
            (v.iter()
                .enumerate()
                .map(|(i, x)| (x / sc(i)).powi(2))
                .sum::<f64>()
                / dim)
                .sqrt()
        };
        let (d0, d1) = (norm(y), norm(f0));
        let mut h0 = if d0 < 1e-5 || d1 < 1e-5 {
            1e-6
        } else {
            0.01 * d0 / d1
        };
        h0 = h0.min(self.settings.t_end - self.settings.t_start);
        let y1 = y + f0 * h0;
        let mut f1 = DVector::zeros(y.len());
        let t = self.t;
        if self.rhs(t + h0, &y1, &mut f1).is_err() {
            return h0 * 0.1;
        }
        let d2 = norm(&(&f1 - f0)) / h0;
        let m = d1.max(d2);
        let h1 = if m <= 1e-15 {
            (h0 * 1e-3).max(1e-6)
        } else {
            (0.01 / m).powf(0.2)
        };
        (100.0 * h0).min(h1)
    }

    fn run_rk4(
        &mut self,
        step: f64,
        y: &mut DVector<f64>,
        k1: &mut DVector<f64>,
        observer: &mut dyn FnMut(Event<'_>),
    ) -> Result<(), SimError> {
        let (t0, t_end) = (self.settings.t_start, self.settings.t_end);
        let nsteps = ((t_end - t0) / step - 1e-9).ceil().max(1.0) as usize;
        let h = (t_end - t0) / nsteps as f64;
        let dim = y.len();
        let mut k2 = DVector::zeros(dim);
        let mut k3 = DVector::zeros(dim);
        let mut k4 = DVector::zeros(dim);
        let mut f_new = DVector::zeros(dim);
        let mut s = 0;
        let mut retried = false;
        while s < nsteps {
            let t = self.t;
            let attempt = (|| -> Result<DVector<f64>, StageError> {
                self.rhs(t + 0.5 * h, &(&*y + &*k1 * (0.5 * h)), &mut k2)?;
                self.rhs(t + 0.5 * h, &(&*y + &k2 * (0.5 * h)), &mut k3)?;
                self.rhs(t + h, &(&*y + &k3 * h), &mut k4)?;
                let y_new = &*y + (&*k1 + &k2 * 2.0 + &k3 * 2.0 + &k4) * (h / 6.0);
                self.rhs(t + h, &y_new, &mut f_new)?;
                Ok(y_new)
            })();
            let y_new = match attempt {
                Ok(v) => v,
                Err(e) => {
                    self.stats.steps_rejected += 1;
                    if !retried && self.settings.partition.repartition && self.monitor(observer)? {
                        *y = self.restart(k1)?;
                        retried = true;
                        continue;
                    }
                    return Err(self.diverged(format!(
                        "fixed step {h:.3e} failed ({e}); use a smaller step or dopri5"
                    )));
                }
            };
            retried = false;
            let t_new = t0 + (s + 1) as f64 * h;
            self.accept_last(t_new);
            self.stats.steps_accepted += 1;
            self.stats.min_step = self.stats.min_step.min(h);
            self.stats.max_step = self.stats.max_step.max(h);
            {
                let (y0, f0, y1, f1) = (&*y, &*k1, &y_new, &f_new);
                let interp = |theta: f64, out: &mut DVector<f64>| {
                    for i in 0..out.len() {
                        out[i] = dopri::hermite(theta, h, y0[i], f0[i], y1[i], f1[i]);
                    }
                };
                self.outputs_in_step(t, h, &interp, observer)?;
            }
            y.copy_from(&y_new);
            k1.copy_from(&f_new);
            s += 1;
            observer(Event::Step { t: self.t });
            if s < nsteps && self.monitor(observer)? {
                *y = self.restart(k1)?;
            }
        }
        Ok(())
    }
}
