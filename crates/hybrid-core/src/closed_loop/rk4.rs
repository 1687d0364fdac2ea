//! Classical fourth-order Runge–Kutta with a fixed step ([`Method::Rk4`](super::Method::Rk4)):
//! the tableau
//!
//! ```text
//!   0  |
//!  1/2 | 1/2
//!  1/2 |  0   1/2
//!   1  |  0    0    1
//! -----+--------------------
//!      | 1/6  1/3  1/3  1/6
//! ```
//!
//! and its driver for the [`Simulator`], with cubic Hermite dense output between the
//! accepted steps (the derivative at the new point is one extra evaluation, which is also
//! the first stage of the next step). The step is rounded so that an integer number of
//! steps spans the interval; a failed stage triggers one partition check and retry, then
//! stops the run.

use nalgebra::DVector;

use super::error::SimError;
use super::rhs::StageError;
use super::simulator::Simulator;
use super::trajectory::Event;
use mbs_symbolic::runtime::System;

/// Cubic Hermite interpolation between `(y0, f0)` and `(y1, f1)` over a step `h`
/// (dense output of the fixed-step RK4 option; local error O(h^4)).
fn hermite(theta: f64, h: f64, y0: f64, f0: f64, y1: f64, f1: f64) -> f64 {
    let t2 = theta * theta;
    let t3 = t2 * theta;
    (2.0 * t3 - 3.0 * t2 + 1.0) * y0
        + (t3 - 2.0 * t2 + theta) * h * f0
        + (-2.0 * t3 + 3.0 * t2) * y1
        + (t3 - t2) * h * f1
}

impl<S: System + ?Sized> Simulator<'_, S> {
    /// Integrates to `t_end` from `(y, k1 = y'(y))` with the fixed step `step` (rounded).
    pub(super) fn run_rk4(
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
            self.check_stop()?;
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
            self.accept_last(t_new, h);
            {
                let (y0, f0, y1, f1) = (&*y, &*k1, &y_new, &f_new);
                let interp = |theta: f64, out: &mut DVector<f64>| {
                    for i in 0..out.len() {
                        out[i] = hermite(theta, h, y0[i], f0[i], y1[i], f1[i]);
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
