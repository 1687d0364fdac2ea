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

/// Errors of a closed-loop simulation.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SimError {
    /// Invalid settings (names the setting).
    #[error("invalid settings: {0}")]
    Settings(String),
    /// The initial state could not be made consistent.
    #[error(transparent)]
    Assembly(#[from] AssemblyError),
    /// Redundant constraints (and the user did not allow dropping them).
    #[error("{0} (set `allow_redundant = true` to drop the redundant rows)")]
    Redundant(RedundancyReport),
    /// The requested partition is unusable.
    #[error("partition: {0}")]
    Partition(String),
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
