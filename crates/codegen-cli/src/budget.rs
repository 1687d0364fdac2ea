//! Work guards: before a run starts, its time steps, output rows and memory are estimated
//! and a run above the documented limits is refused with the estimate and the flag that
//! lifts the limits (`--allow-long`).
//!
//! | limit | value | a run of about |
//! | --- | --- | --- |
//! | time steps | 2e7 | a minute of the damper's Newmark steps (3.6e5 steps/s measured) |
//! | output rows | 2e6 | 2e6 CSV lines of one run |
//! | memory for samples and CSV text | 1 GiB | |
//!
//! Estimates: damper `ceil(t_end / dt)` steps per run (two runs with the comparison), one
//! row every `every` steps, a row held as one `Sample` plus its CSV text (25 bytes a cell);
//! mechanism rows `(t_end - t_start) / output_step + 1`, CSV text of `2 n + 6` cells a row,
//! steps `span / step` for RK4 and `span / max_step` for Dormand–Prince when `max_step` is
//! given (otherwise the adaptive step count is bounded by the scenario's `max_steps`).

use std::fmt;

use hybrid_core::closed_loop::Method;

use crate::Error;
use crate::scenario::{DamperScenario, MechanismScenario};

/// Largest estimated number of time steps of a run without `--allow-long`.
pub const MAX_STEPS: f64 = 2e7;
/// Largest estimated number of output rows without `--allow-long`.
pub const MAX_ROWS: f64 = 2e6;
/// Largest estimated memory for samples and output text without `--allow-long` (bytes).
pub const MAX_BYTES: f64 = 1024.0 * 1024.0 * 1024.0;

/// Bytes of one CSV cell (a number printed in full precision and its comma).
const CELL_BYTES: f64 = 25.0;

/// The estimated work of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Time steps, all runs together (`None`: not known before the run).
    pub steps: Option<f64>,
    /// Output rows, all files together.
    pub rows: f64,
    /// Memory for samples and output text (bytes).
    pub bytes: f64,
}

impl fmt::Display for Estimate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(s) = self.steps {
            write!(f, "{s:.2e} steps, ")?;
        }
        write!(
            f,
            "{:.2e} output rows and {:.1} MiB of samples",
            self.rows,
            self.bytes / (1024.0 * 1024.0)
        )
    }
}

impl Estimate {
    /// A damper scenario: both runs when the comparison without generator is asked for.
    pub fn damper(sc: &DamperScenario) -> Estimate {
        let runs = if sc.spec.output.compare_without_generator {
            2.0
        } else {
            1.0
        };
        let steps = (sc.setup.t_end / sc.setup.dt).ceil();
        let rows = runs * ((steps / sc.setup.every.max(1) as f64).floor() + 1.0);
        let sample = std::mem::size_of::<hybrid_core::study::Sample>() as f64;
        let cells = sample / 8.0;
        Estimate {
            steps: Some(runs * steps),
            rows,
            bytes: rows * (sample + cells * CELL_BYTES),
        }
    }

    /// A closed-loop mechanism scenario with `dof` coordinates.
    pub fn mechanism(sc: &MechanismScenario, dof: usize) -> Estimate {
        let s = &sc.settings;
        let span = s.t_end - s.t_start;
        let rows = (span / s.output_step).floor() + 1.0;
        let steps = match s.method {
            Method::Rk4 { step } => Some((span / step).ceil()),
            Method::Dopri5 { max_step, .. } => max_step.map(|h| (span / h).ceil()),
        };
        Estimate {
            steps,
            rows,
            bytes: rows * (2 * dof + 6) as f64 * CELL_BYTES,
        }
    }

    /// Whether the run is within the limits.
    pub fn within_limits(&self) -> bool {
        // `!(x <= max)` also refuses a NaN estimate.
        self.steps.is_none_or(|s| s <= MAX_STEPS)
            && self.rows <= MAX_ROWS
            && self.bytes <= MAX_BYTES
    }

    /// Refuses a run above the limits unless `allow_long`; `file` names the scenario.
    pub fn check(&self, file: &str, allow_long: bool) -> Result<(), Error> {
        if allow_long || self.within_limits() {
            return Ok(());
        }
        Err(Error::TooLong(format!(
            "{file}: the run is estimated at {self}, above the limits ({MAX_STEPS:.0e} steps, {MAX_ROWS:.0e} rows, {} MiB); shorten t_end or coarsen the output step, or pass --allow-long to run it anyway",
            MAX_BYTES / (1024.0 * 1024.0)
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn estimates_above_any_limit_are_refused_with_the_flag_named() {
        let ok = Estimate {
            steps: Some(5e4),
            rows: 1e4,
            bytes: 1e6,
        };
        assert!(ok.check("s.toml", false).is_ok());
        for bad in [
            Estimate {
                steps: Some(1e9),
                ..ok
            },
            Estimate { rows: 1e11, ..ok },
            Estimate { bytes: 2e9, ..ok },
            Estimate {
                steps: Some(f64::NAN),
                ..ok
            },
        ] {
            let e = bad.check("s.toml", false).unwrap_err().to_string();
            assert!(e.contains("--allow-long") && e.contains("s.toml"), "{e}");
            assert!(bad.check("s.toml", true).is_ok());
        }
    }
}
