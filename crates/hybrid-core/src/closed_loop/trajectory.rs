//! What a closed-loop run produces: output samples with energy and constraint residuals,
//! the log of partition changes, the counters, and the events an observer receives while
//! the run goes.

use std::fmt;

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
