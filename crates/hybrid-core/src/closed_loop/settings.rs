//! Settings of a closed-loop run: the integration method and its tolerances or step, the
//! output grid, and how the independent coordinates are chosen and monitored (eqs. 18–25;
//! docs/theory.md §3).

use super::error::{SettingsError, SimError};

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
    /// Classical fourth-order Runge–Kutta with a fixed step (rounded down so that an
    /// integer number of steps spans the interval). The output step must be at least the
    /// step: output rows are never closer than the integration steps (rows between steps
    /// would only be interpolated, cubic Hermite, not integrated).
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
    /// Spacing of the output times (`t_start + k * output_step`, plus `t_end`); with
    /// [`Method::Rk4`] at least its step.
    pub output_step: f64,
    /// Partition choice and monitoring.
    pub partition: PartitionSettings,
    /// Tolerance of the position projection on `max |h_i|` (model length units; default
    /// 1e-10). Newton is iterated to rounding level; this only decides failure.
    pub projection_tol: f64,
    /// Step limit (default 10 000 000).
    pub max_steps: usize,
    /// Unused: the library prints nothing. Partition changes reach the run's observer as
    /// [`super::Event::PartitionChanged`] as they happen, and the redundant rows dropped at
    /// the start are [`super::Simulator::dropped_rows`]; a caller that wants them on
    /// standard error prints them there (the `damper` binary does). Kept so that existing
    /// settings still build.
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

    /// Checks every setting; names the first one out of range.
    pub(super) fn validate(&self) -> Result<(), SimError> {
        let bad = |e: SettingsError| Err(SimError::Settings(e));
        let pos = |x: f64| x.is_finite() && x > 0.0;
        if !(self.t_start.is_finite() && self.t_end.is_finite() && self.t_end > self.t_start) {
            return bad(SettingsError::Span {
                t_start: self.t_start,
                t_end: self.t_end,
            });
        }
        if !pos(self.output_step) {
            return bad(SettingsError::NotPositive {
                name: "output_step",
                value: self.output_step,
            });
        }
        match self.method {
            Method::Dopri5 {
                rtol,
                atol,
                initial_step,
                max_step,
            } => {
                if !(1e-15..1.0).contains(&rtol) {
                    return bad(SettingsError::Rtol(rtol));
                }
                if !(atol.is_finite() && atol >= 0.0) {
                    return bad(SettingsError::Atol(atol));
                }
                if let Some(h) = initial_step.filter(|h| !pos(*h)) {
                    return bad(SettingsError::NotPositive {
                        name: "initial_step",
                        value: h,
                    });
                }
                if let Some(h) = max_step.filter(|h| !pos(*h)) {
                    return bad(SettingsError::NotPositive {
                        name: "max_step",
                        value: h,
                    });
                }
            }
            Method::Rk4 { step } => {
                if !pos(step) {
                    return bad(SettingsError::NotPositive {
                        name: "step",
                        value: step,
                    });
                }
                if self.output_step < step {
                    return bad(SettingsError::OutputBelowStep {
                        output_step: self.output_step,
                        step,
                    });
                }
                if (self.t_end - self.t_start) / step > self.max_steps as f64 {
                    return bad(SettingsError::StepLimit {
                        step,
                        max_steps: self.max_steps,
                    });
                }
            }
        }
        let p = &self.partition;
        if !(p.switch_ratio.is_finite() && p.switch_ratio >= 1.0) {
            return bad(SettingsError::SwitchRatio(p.switch_ratio));
        }
        if !(pos(p.max_condition) && pos(p.singular_condition) && pos(self.projection_tol)) {
            return bad(SettingsError::Tolerances);
        }
        if !(p.rank_tol.is_finite() && p.rank_tol > 0.0 && p.rank_tol < 1.0) {
            return bad(SettingsError::RankTol(p.rank_tol));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rk4_output_step_below_the_step_is_refused() {
        let e = Settings::rk4(1.0, 1e-2, 1e-3).validate().unwrap_err();
        assert!(
            e.to_string()
                .contains("output_step (0.001) must be at least the step (0.01)"),
            "{e}"
        );
        assert!(Settings::rk4(1.0, 1e-2, 1e-2).validate().is_ok());
        assert!(Settings::rk4(1.0, 1e-3, 1e-2).validate().is_ok());
        // Dormand–Prince has dense output of its own order: any output step.
        assert!(Settings::dopri5(1.0, 1e-8, 1e-10, 1e-6).validate().is_ok());
    }
}
