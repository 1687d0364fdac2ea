//! The Dormand–Prince 5(4) pair (Dormand & Prince 1980; Hairer, Nørsett & Wanner,
//! *Solving ODEs I*, II.5): seven stages with the first-same-as-last property, an embedded
//! fourth-order error estimate, a PI step-size controller and the fourth-order continuous
//! extension used for dense output; and the adaptive driver of the [`Simulator`] that uses
//! them ([`Method::Dopri5`](super::Method::Dopri5)): each stage evaluates the reduced
//! equations ([`super::rhs`]), a failed stage triggers the partition check before the step is
//! shrunk, and the outputs inside an accepted step come from the continuous extension.

use nalgebra::DVector;

use super::error::SimError;
use super::rhs::StageError;
use super::settings::Method;
use super::simulator::Simulator;
use super::trajectory::Event;
use mbs_symbolic::runtime::System;

/// Nodes `c_i`.
const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];

/// Coupling coefficients `a_ij` (row `i`, first `i` entries used); row 6 is the
/// fifth-order solution (FSAL).
const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];

/// Error coefficients `b_i - b*_i` (fifth minus fourth order), applied to `k_1..k_7`.
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];

/// Dense-output coefficients `d_i` of Hairer's `CONTD5`, applied to `k_1..k_7`.
const D: [f64; 7] = [
    -12715105075.0 / 11282082432.0,
    0.0,
    87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0,
    69997945.0 / 29380423.0,
];

/// The PI step-size controller of Hairer's `DOPRI5` (`beta = 0.04`, safety 0.9, step
/// ratio limited to [0.2, 10]).
#[derive(Clone, Copy, Debug)]
struct Controller {
    err_old: f64,
}

const BETA: f64 = 0.04;
const EXPO1: f64 = 0.2 - BETA * 0.75;
const SAFE: f64 = 0.9;
const FAC_MIN: f64 = 0.2;
const FAC_MAX: f64 = 10.0;

impl Controller {
    fn new() -> Controller {
        Controller { err_old: 1e-4 }
    }

    /// Forgets the error history (after a change of variables).
    fn reset(&mut self) {
        self.err_old = 1e-4;
    }

    /// New step after an accepted step with scaled error `err <= 1`.
    fn accept(&mut self, h: f64, err: f64) -> f64 {
        let fac11 = err.max(1e-300).powf(EXPO1);
        let fac = (fac11 / self.err_old.powf(BETA) / SAFE).clamp(1.0 / FAC_MAX, 1.0 / FAC_MIN);
        self.err_old = err.max(1e-4);
        h / fac
    }

    /// New step after a rejected step with scaled error `err > 1`.
    fn reject(&self, h: f64, err: f64) -> f64 {
        let fac11 = err.powf(EXPO1);
        let fac = if fac11.is_finite() {
            (fac11 / SAFE).min(1.0 / FAC_MIN)
        } else {
            1.0 / FAC_MIN
        };
        h / fac
    }
}

/// Value of the continuous extension at `theta in [0, 1]` of the step from `y0` to `y1` of
/// size `h`, component `i`, given the stage derivatives `k`.
fn dense(theta: f64, h: f64, y0: f64, y1: f64, k: &[f64; 7]) -> f64 {
    let ydiff = y1 - y0;
    let bspl = h * k[0] - ydiff;
    let r4 = ydiff - h * k[6] - bspl;
    let r5 = h * (0..7).map(|s| D[s] * k[s]).sum::<f64>();
    let t1 = 1.0 - theta;
    y0 + theta * (ydiff + t1 * (bspl + theta * (r4 + t1 * r5)))
}

impl<S: System + ?Sized> Simulator<'_, S> {
    /// Integrates to `t_end` from `(y, k1 = y'(y))` with PI step control and dense output.
    pub(super) fn run_dopri(
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
        let mut ctrl = Controller::new();
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
            self.check_stop()?;
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
                        let a = A[s][r];
                        if a != 0.0 {
                            ys.axpy(h * a, kr, 1.0);
                        }
                    }
                    let ts = self.t + C[s] * h;
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
                let e = h * (0..7).map(|s| E[s] * k[s][i]).sum::<f64>();
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
            self.accept_last(if final_step { t_end } else { t_old + h }, h);
            {
                let (y0, y1, ks) = (&*y, &y_new, &k);
                let interp = |theta: f64, out: &mut DVector<f64>| {
                    for i in 0..out.len() {
                        let kk = [
                            ks[0][i], ks[1][i], ks[2][i], ks[3][i], ks[4][i], ks[5][i], ks[6][i],
                        ];
                        out[i] = dense(theta, h, y0[i], y1[i], &kk);
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
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tableau_is_consistent() {
        for i in 1..7 {
            let s: f64 = A[i].iter().sum();
            assert!((s - C[i]).abs() < 1e-14, "row {i}");
        }
        assert!(E.iter().sum::<f64>().abs() < 1e-15);
        // The dense output reproduces both ends.
        let k = [1.0, 0.5, 0.2, -0.3, 0.7, 0.1, 0.9];
        assert!((dense(0.0, 0.1, 2.0, 3.0, &k) - 2.0).abs() < 1e-15);
        assert!((dense(1.0, 0.1, 2.0, 3.0, &k) - 3.0).abs() < 1e-15);
    }
}
