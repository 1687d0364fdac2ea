//! The Dormand–Prince 5(4) pair (Dormand & Prince 1980; Hairer, Nørsett & Wanner,
//! *Solving ODEs I*, II.5): seven stages with the first-same-as-last property, an embedded
//! fourth-order error estimate, a PI step-size controller and the fourth-order continuous
//! extension used for dense output. Only the coefficients and the small formulas live here;
//! the driver is in `simulate.rs`.

/// Nodes `c_i`.
pub(crate) const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];

/// Coupling coefficients `a_ij` (row `i`, first `i` entries used); row 6 is the
/// fifth-order solution (FSAL).
pub(crate) const A: [[f64; 6]; 7] = [
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
pub(crate) const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];

/// Dense-output coefficients `d_i` of Hairer's `CONTD5`, applied to `k_1..k_7`.
pub(crate) const D: [f64; 7] = [
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
pub(crate) struct Controller {
    err_old: f64,
}

const BETA: f64 = 0.04;
const EXPO1: f64 = 0.2 - BETA * 0.75;
const SAFE: f64 = 0.9;
const FAC_MIN: f64 = 0.2;
const FAC_MAX: f64 = 10.0;

impl Controller {
    pub fn new() -> Controller {
        Controller { err_old: 1e-4 }
    }

    /// Forgets the error history (after a change of variables).
    pub fn reset(&mut self) {
        self.err_old = 1e-4;
    }

    /// New step after an accepted step with scaled error `err <= 1`.
    pub fn accept(&mut self, h: f64, err: f64) -> f64 {
        let fac11 = err.max(1e-300).powf(EXPO1);
        let fac = (fac11 / self.err_old.powf(BETA) / SAFE).clamp(1.0 / FAC_MAX, 1.0 / FAC_MIN);
        self.err_old = err.max(1e-4);
        h / fac
    }

    /// New step after a rejected step with scaled error `err > 1`.
    pub fn reject(&self, h: f64, err: f64) -> f64 {
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
pub(crate) fn dense(theta: f64, h: f64, y0: f64, y1: f64, k: &[f64; 7]) -> f64 {
    let ydiff = y1 - y0;
    let bspl = h * k[0] - ydiff;
    let r4 = ydiff - h * k[6] - bspl;
    let r5 = h * (0..7).map(|s| D[s] * k[s]).sum::<f64>();
    let t1 = 1.0 - theta;
    y0 + theta * (ydiff + t1 * (bspl + theta * (r4 + t1 * r5)))
}

/// Cubic Hermite interpolation between `(y0, f0)` and `(y1, f1)` over a step `h`
/// (dense output of the fixed-step RK4 option; local error O(h^4)).
pub(crate) fn hermite(theta: f64, h: f64, y0: f64, f0: f64, y1: f64, f1: f64) -> f64 {
    let t2 = theta * theta;
    let t3 = t2 * theta;
    (2.0 * t3 - 3.0 * t2 + 1.0) * y0
        + (t3 - 2.0 * t2 + theta) * h * f0
        + (-2.0 * t3 + 3.0 * t2) * y1
        + (t3 - t2) * h * f1
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
