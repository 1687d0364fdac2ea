//! Errors and diagnoses of a closed-loop simulation: each carries the data that explains it
//! (time, coordinates by name, singular values, constraint rows by name).

use std::fmt;

use super::assembly::AssemblyError;

/// A redundant constraint row and the rows it is a combination of.
#[derive(Clone, Debug, PartialEq)]
pub struct RedundantRow {
    /// Name of the redundant row (`"pin2.x"`).
    pub name: String,
    /// `J_row = sum c_k J_k` over the kept rows: `(name, c_k)` for the non-negligible
    /// coefficients, in row order.
    pub combination: Vec<(String, f64)>,
}

/// The named diagnosis of redundant constraints.
#[derive(Clone, Debug, PartialEq)]
pub struct RedundancyReport {
    /// Rank of `J` at the configuration examined.
    pub rank: usize,
    /// Number of constraint rows.
    pub rows: usize,
    /// The rows found redundant.
    pub redundant: Vec<RedundantRow>,
}

impl fmt::Display for RedundancyReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "redundant constraints: J has rank {} for {} constraint rows",
            self.rank, self.rows
        )?;
        for r in &self.redundant {
            let terms: Vec<String> = r
                .combination
                .iter()
                .map(|(n, c)| format!("{c:+.6}*{n}"))
                .collect();
            if terms.is_empty() {
                write!(f, "; row `{}` is identically zero", r.name)?;
            } else {
                write!(f, "; row `{}` = {}", r.name, terms.join(" "))?;
            }
        }
        Ok(())
    }
}

/// A configuration where `J` loses rank: every choice of independent coordinates is
/// degenerate.
#[derive(Clone, Debug, PartialEq)]
pub struct SingularReport {
    /// Time.
    pub t: f64,
    /// The coordinates, by name.
    pub coordinates: Vec<(String, f64)>,
    /// Smallest singular value of `J` (active rows).
    pub sigma_min: f64,
    /// Largest singular value of `J`.
    pub sigma_max: f64,
    /// Numerical rank found.
    pub rank: usize,
    /// Rank expected (the number of independent constraint rows).
    pub expected_rank: usize,
    /// Condition number of the best `J_v` available (infinite when `J` has lost rank).
    pub best_condition: f64,
}

impl fmt::Display for SingularReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let coords: Vec<String> = self
            .coordinates
            .iter()
            .map(|(n, v)| format!("{n} = {v:.9}"))
            .collect();
        write!(
            f,
            "singular configuration at t = {:.9} s: the constraint Jacobian J loses rank \
             ({} of {}; smallest singular value {:.3e}, largest {:.3e}; best cond(J_v) {:.3e}) \
             — every choice of independent coordinates is degenerate; {}",
            self.t,
            self.rank,
            self.expected_rank,
            self.sigma_min,
            self.sigma_max,
            self.best_condition,
            coords.join(", ")
        )
    }
}

/// A setting of a closed-loop simulation out of its range, with the value.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SettingsError {
    /// `t_end` not after `t_start`.
    #[error("t_end ({t_end}) must be finite and greater than t_start ({t_start})")]
    Span {
        /// Start time.
        t_start: f64,
        /// End time.
        t_end: f64,
    },
    /// A step or tolerance that must be positive.
    #[error("{name} ({value}) must be positive")]
    NotPositive {
        /// The setting.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// `rtol` outside `[1e-15, 1)`.
    #[error("rtol ({0}) must be in [1e-15, 1)")]
    Rtol(f64),
    /// `atol` negative or not finite.
    #[error("atol ({0}) must be finite and non-negative")]
    Atol(f64),
    /// RK4 rows between steps.
    #[error(
        "output_step ({output_step}) must be at least the step ({step}): rows between steps would only be interpolated"
    )]
    OutputBelowStep {
        /// The output step.
        output_step: f64,
        /// The RK4 step.
        step: f64,
    },
    /// RK4 steps above the step limit.
    #[error("step ({step}) needs more than max_steps ({max_steps}) steps")]
    StepLimit {
        /// The RK4 step.
        step: f64,
        /// The step limit.
        max_steps: usize,
    },
    /// `switch_ratio < 1`.
    #[error("switch_ratio ({0}) must be >= 1")]
    SwitchRatio(f64),
    /// A partition tolerance that is not positive.
    #[error("max_condition, singular_condition and projection_tol must be positive")]
    Tolerances,
    /// `rank_tol` outside `(0, 1)`.
    #[error("rank_tol ({0}) must be in (0, 1)")]
    RankTol(f64),
    /// Initial coordinates or velocities of the wrong count.
    #[error("{coordinates} coordinates and {velocities} velocities given, the mechanism has {dof}")]
    StateSize {
        /// Coordinates given.
        coordinates: usize,
        /// Velocities given.
        velocities: usize,
        /// Coordinates of the mechanism.
        dof: usize,
    },
}

/// Why the independent coordinates the user chose cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PartitionChoiceError {
    /// Not a valid set of coordinate indices.
    #[error(transparent)]
    Indices(#[from] crate::partition::PartitionError),
    /// As many independent coordinates as degrees of freedom are needed.
    #[error(
        "{chosen} independent coordinates chosen ([{names}]), but the mechanism has {dof} degrees of freedom (n = {n}, rank of J = {rank})"
    )]
    Count {
        /// Coordinates chosen.
        chosen: usize,
        /// Their names, comma-separated.
        names: String,
        /// Degrees of freedom.
        dof: usize,
        /// Coordinates.
        n: usize,
        /// Rank of `J`.
        rank: usize,
    },
    /// They make `J_v` singular at the start and re-partitioning is off.
    #[error(
        "the chosen independent coordinates [{names}] make J_v singular at the initial configuration (cond {cond:.3e}); choose others or enable repartitioning"
    )]
    Singular {
        /// Their names, comma-separated.
        names: String,
        /// cond(J_v).
        cond: f64,
    },
    /// The velocity projection failed.
    #[error(transparent)]
    Projection(#[from] super::projection::ProjectionError),
}

/// Errors of a closed-loop simulation.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// Invalid settings (names the setting).
    #[error("invalid settings: {0}")]
    Settings(SettingsError),
    /// The initial state could not be made consistent.
    #[error(transparent)]
    Assembly(#[from] AssemblyError),
    /// Redundant constraints (and the user did not allow dropping them).
    #[error("{0} (set `allow_redundant = true` to drop the redundant rows)")]
    Redundant(RedundancyReport),
    /// The requested partition is unusable.
    #[error("partition: {0}")]
    Partition(PartitionChoiceError),
    /// `J` loses rank: the run stops.
    #[error("{0}")]
    Singular(SingularReport),
    /// The step size fell below what double precision can resolve.
    #[error(
        "step size too small at t = {t:.9} s (h = {h:.3e}): {cause}; cond(J_v) = {cond:.3e}, \
         smallest singular value of J = {sigma_min:.3e}; {coordinates}"
    )]
    StepSizeTooSmall {
        /// Time.
        t: f64,
        /// The step size.
        h: f64,
        /// The last failure or the error estimate.
        cause: String,
        /// Condition number of `J_v` of the current partition.
        cond: f64,
        /// Smallest singular value of `J`.
        sigma_min: f64,
        /// `name = value` of every coordinate.
        coordinates: String,
    },
    /// The solution left the finite numbers or a projection failed beyond recovery.
    #[error("the integration diverged at t = {t:.9} s: {cause}; {coordinates}")]
    Diverged {
        /// Time.
        t: f64,
        /// What failed.
        cause: String,
        /// `name = value` of every coordinate.
        coordinates: String,
    },
    /// The step limit was reached.
    #[error("step limit of {max_steps} steps reached at t = {t:.9} s")]
    TooManySteps {
        /// Time.
        t: f64,
        /// The limit.
        max_steps: usize,
    },
    /// The stop polled before every step asked to stop ([`super::Simulator::set_stop`]).
    #[error("stopped on request at t = {t:.9} s")]
    Stopped {
        /// Time.
        t: f64,
    },
}

impl SimError {
    /// `true` for the errors that stop a run on a singular or near-singular configuration.
    pub fn is_singular(&self) -> bool {
        matches!(
            self,
            SimError::Singular(_) | SimError::StepSizeTooSmall { .. }
        )
    }
}
