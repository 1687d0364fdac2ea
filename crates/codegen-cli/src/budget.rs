//! Work guards: before a run starts, its time steps, output rows and output size are
//! estimated and a run above the documented limits is refused with the estimate and the
//! flag that lifts the limits (`--allow-long`). Memory is not limited by these: time
//! histories are streamed to disk and a damper run keeps a bounded digest of its samples
//! (`report::stream`, `report::digest`), so memory does not grow with `t_end`.
//!
//! | limit | value | a run of about |
//! | --- | --- | --- |
//! | time steps | 2e7 | a minute of the damper's Newmark steps (3.6e5 steps/s measured) |
//! | output rows | 2e6 | 2e6 CSV lines of one run |
//! | CSV text written | 1 GiB | |
//!
//! Estimates: damper `ceil(t_end / dt)` steps per run (two runs with the comparison), one
//! row every `every` steps, a row of one cell per `Sample` field (25 bytes a cell);
//! mechanism rows `(t_end - t_start) / output_step + 1`, CSV text of `2 n + 6` cells a row,
//! steps `span / step` for RK4, and for Dormand–Prince `span / h` with the typical step
//! (see [`dopri_typical_step`])
//!
//! ```text
//!   h = min(max_step, output_step * (rtol / 1e-7)^(1/5), span)
//! ```
//!
//! A fifth-order method's step grows like `rtol^(1/5)` times the time scale of the motion;
//! the output step stands for that scale (the user asks for rows fine enough to see the
//! motion). The constant 1e-7 is calibrated on the bundled scenarios (rtol 1e-10, output
//! step 0.01 s: estimate 1991 steps; measured 2279 for the four-bar, 3133 for the
//! slider-crank). The estimate cannot see a motion much faster than the output grid (a
//! huge initial velocity); such a run is stopped by its step limit, `max_steps`, which
//! without `--allow-long` is at most [`MAX_STEPS`] ([`capped_max_steps`]).

use std::fmt;

use hybrid_core::closed_loop::Method;

use crate::Error;
use crate::scenario::{DamperScenario, MechanismScenario};

/// Largest estimated number of time steps of a run without `--allow-long`.
pub const MAX_STEPS: f64 = 2e7;
/// Largest estimated number of output rows without `--allow-long`.
pub const MAX_ROWS: f64 = 2e6;
/// Largest estimated CSV text of a run without `--allow-long` (bytes).
pub const MAX_BYTES: f64 = 1024.0 * 1024.0 * 1024.0;

/// Bytes of one CSV cell (a number printed in full precision and its comma).
const CELL_BYTES: f64 = 25.0;

/// The typical step of Dormand–Prince 5(4) for a run of length `span` with this output step,
/// relative tolerance and optional largest step: `min(max_step, output_step * (rtol /
/// 1e-7)^(1/5), span)` (module documentation).
pub fn dopri_typical_step(span: f64, output_step: f64, rtol: f64, max_step: Option<f64>) -> f64 {
    (output_step * (rtol / 1e-7).powf(0.2))
        .min(max_step.unwrap_or(f64::INFINITY))
        .min(span)
}

/// The step limit a run gets: the scenario's `max_steps`, at most [`MAX_STEPS`] unless
/// `allow_long` — the guard for adaptive runs whose step count the estimate cannot see.
pub fn capped_max_steps(max_steps: usize, allow_long: bool) -> usize {
    if allow_long {
        max_steps
    } else {
        max_steps.min(MAX_STEPS as usize)
    }
}

/// The estimated work of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Time steps, all runs together (`None`: not known before the run).
    pub steps: Option<f64>,
    /// Output rows, all files together.
    pub rows: f64,
    /// CSV text written (bytes).
    pub bytes: f64,
}

impl fmt::Display for Estimate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(s) = self.steps {
            write!(f, "{s:.2e} steps, ")?;
        }
        write!(
            f,
            "{:.2e} output rows and {:.1} MiB of CSV",
            self.rows,
            self.bytes / (1024.0 * 1024.0)
        )
    }
}

impl Estimate {
    /// A damper scenario: the run with the generator and every comparison run (counted as
    /// full runs: the bare beam's is cheaper).
    pub fn damper(sc: &DamperScenario) -> Estimate {
        let runs = 1.0 + sc.spec.output.compare.len() as f64;
        let steps = (sc.setup.t_end / sc.setup.dt).ceil();
        let rows = runs * ((steps / sc.setup.every.max(1) as f64).floor() + 1.0);
        let sample = std::mem::size_of::<hybrid_core::study::Sample>() as f64;
        let cells = sample / 8.0;
        Estimate {
            steps: Some(runs * steps),
            rows,
            bytes: rows * cells * CELL_BYTES,
        }
    }

    /// A closed-loop mechanism scenario with `dof` coordinates.
    pub fn mechanism(sc: &MechanismScenario, dof: usize) -> Estimate {
        let s = &sc.settings;
        let span = s.t_end - s.t_start;
        let rows = (span / s.output_step).floor() + 1.0;
        let steps = match s.method {
            Method::Rk4 { step } => (span / step).ceil(),
            Method::Dopri5 { rtol, max_step, .. } => {
                (span / dopri_typical_step(span, s.output_step, rtol, max_step)).ceil()
            }
        };
        Estimate {
            steps: Some(steps),
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
    fn dopri_typical_step_follows_tolerance_output_step_and_max_step() {
        // rtol = 1e-7: the output step itself; each decade of rtol is 10^(1/5) smaller.
        assert_eq!(dopri_typical_step(5.0, 0.01, 1e-7, None), 0.01);
        let h = dopri_typical_step(5.0, 0.01, 1e-10, None);
        assert!((h - 0.01 * 1e-3f64.powf(0.2)).abs() < 1e-15, "{h}");
        assert!((5.0 / h).ceil() == 1991.0, "{}", 5.0 / h);
        assert_eq!(dopri_typical_step(5.0, 0.01, 1e-7, Some(1e-3)), 1e-3);
        assert_eq!(dopri_typical_step(0.001, 0.01, 1e-7, None), 0.001);
        assert_eq!(capped_max_steps(usize::MAX, false), 20_000_000);
        assert_eq!(capped_max_steps(usize::MAX, true), usize::MAX);
        assert_eq!(capped_max_steps(1000, false), 1000);
    }

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
