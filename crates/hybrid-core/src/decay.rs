//! Damping of a mode from a free decay (docs/theory.md section 11, the damping estimate of a run): the one
//! estimator of the code base.
//!
//! - [`ModalFilter`]: the modal coordinate of one mode shape `phi` of the beam,
//!
//!   ```text
//!   eta(t) = phi^T A x(t) / (phi^T A phi)        (A: the beam mass matrix)
//!   ```
//!
//!   which removes every other mode that is `A`-orthogonal to `phi` exactly, so the decay
//!   of `eta` is the decay of that mode alone; for a complex mode of a linearised hybrid
//!   system, the state-space projection on its left eigenvector
//!   ([`ModalFilter::of_mode`]), exact for close, non-proportionally damped modes too;
//! - [`DecayTracker`]: the estimator, fed one sample at a time (memory: a few numbers per
//!   half-cycle, independent of the number of samples), and [`estimate`], its batch form
//!   (the same code, bit for bit).
//!
//! What the estimator does with a signal `y(t)`:
//!
//! 1. **Half-cycles.** The signal is cut into half-cycles of one sign by zero crossings with
//!    hysteresis: a half-cycle ends when the signal goes past `-hysteresis` times the last
//!    peak on the other side (default 5 %), so ripple of higher modes near zero does not split
//!    one. The peak of a half-cycle is its largest `|y|` sample, refined by the parabola
//!    through it and its neighbours (vertex of the interpolating parabola). A peak is kept
//!    once the next half-cycle has started, and not when it is the record's first sample
//!    (the start of a record is not an extremum in general: a decay released from rest
//!    loses its first half-cycle peak rather than every other signal being biased).
//! 2. **Noise floor.** Peaks are used while they are above `floor` times the largest peak
//!    before them (default `floor = 1e-3`: the decay is read over three decades; below
//!    that, numerical noise, higher-mode ripple or a static offset of the order of 1e-3 of the
//!    amplitude would dominate the ratios).
//! 3. **Oscillatory** (at least three peaks, i.e. one full cycle): for every pair of peaks of
//!    the same sign one period apart, `p_i` and `p_{i+2}` (positive and negative peaks both
//!    used, so a cycle starts at every half-cycle), one [`Cycle`]:
//!
//!    ```text
//!    delta_i = ln(p_i / p_{i+2}),  zeta_i = delta_i / sqrt(4 pi^2 + delta_i^2)
//!    amplitude_i = sqrt(p_i p_{i+2}),  frequency_i = 1 / (t_{i+2} - t_i)
//!    ```
//!
//!    (for a linear mode, `p_{i+2} / p_i = exp(-zeta omega T_d)` exactly, whatever the
//!    sampling phase, since the extrema of `exp(-s t) cos(w t + phi)` are `T_d / 2` apart).
//!    The overall `zeta` is the least-squares fit `ln p_i = c - i delta / 2` over all used
//!    peaks, the overall frequency the fit `t_i = t_0 + i T_d / 2`.
//! 4. **Not oscillatory** (fewer than three peaks above the floor):
//!    - with at least one zero crossing: [`DecayEstimate::Decaying`], the decay rate from
//!      the log-linear least-squares fit `ln |y| = c - rate t` through the extrema of `|y|`
//!      (its peaks, two or more) — or, with a single peak, from the two-exponential model
//!      below (the modulus of its roots) — and the number of zero crossings;
//!    - without a zero crossing: the samples are fitted (least squares, Prony's method over
//!      equally spaced triples above the floor) by the linear recurrence of a sum of two
//!      exponentials, `y_{k+2} = c1 y_{k+1} + c0 y_k`, whose characteristic roots are
//!      `z = exp(-s h)`. Real roots: the decay is the sum `a e^{-s1 t} + b e^{-s2 t}`;
//!      the double root `s1 = s2` is the critically damped `(a + b t) e^{-s t}`. **Criterion:**
//!      [`DecayEstimate::CriticallyDamped`] when the two rates differ by less than
//!      [`CRITICAL_SPLIT`] (1 %) of their mean (for a linear oscillator, `|zeta - 1| <
//!      1.25e-5`; the split of a double root under rounding is ~1e-5 of the rate at
//!      `s h = 0.03`), with `rate` their mean; otherwise [`DecayEstimate::Overdamped`] with
//!      the slow rate (the one that dominates the tail) and the fast one. Complex roots:
//!      a decaying oscillation slower than the record, [`DecayEstimate::Decaying`] with
//!      `rate = -ln|z| / h` and no crossing;
//!    - a signal that does not decay (roots on or outside the unit circle, a zero signal,
//!      fewer than three samples): [`DecayEstimate::NotDecaying`] — never a missing value.

use fem_beam::BandedSym;
use serde::Serialize;

/// Two rates closer than this fraction of their mean are one double root (critical damping).
pub const CRITICAL_SPLIT: f64 = 0.01;

/// The modal coordinate of one mode, a linear functional of the state: for a real mode
/// shape ([`ModalFilter::new`]) `eta = phi^T A x / (phi^T A phi)` of the displacements; for
/// a (complex) mode of a linearised hybrid system ([`ModalFilter::of_mode`]) the exact
/// state-space projection, which also reads the velocities and the generators' currents.
#[derive(Clone, Debug, PartialEq)]
pub struct ModalFilter {
    /// Weights of the displacements: `A phi / (phi^T A phi)`, or those of the state-space
    /// projection.
    weights: Vec<f64>,
    /// Weights of the velocities (empty: none).
    velocity: Vec<f64>,
    /// Weights of the currents: (index into the model's forces, weight).
    currents: Vec<(usize, f64)>,
}

/// Above this many reduced coordinates [`ModalFilter::of_mode`] takes the left eigenvector
/// equal to the right one (exact when `K_R`, `C_R`, `M_R` are symmetric and every generator
/// has `k_t = k_e`, as in the bundled scenarios: the absorber test reads the same damping
/// ratio to seven digits either way), instead of the left null vector of the dense pencil: `O(d^3)`, 1.6 s
/// and 116 MB at `d = 1401` (a 700-element beam), well under 0.1 s at 600.
pub const DENSE_LEFT_LIMIT: usize = 600;

/// A mode shape that cannot make a modal filter.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ModalFilterError {
    /// `phi` and the mass matrix have different sizes.
    #[error("mode shape of length {shape} for a mass matrix of size {mass}")]
    Size {
        /// Length of the mode shape.
        shape: usize,
        /// Size of the mass matrix.
        mass: usize,
    },
    /// `phi^T A phi` is not positive and finite (a zero or non-finite shape).
    #[error("the mode shape has no positive finite modal mass (phi^T A phi = {0})")]
    ModalMass(f64),
    /// The mode does not move the point the filter is scaled to (or its shape is not
    /// finite).
    #[error("the mode shape is {0} at the filter's point (zero or not finite)")]
    AtPoint(f64),
    /// The state-space normalisation `W^T E Y` of the mode is zero or not finite (a
    /// defective eigenvalue or a failed left eigenvector).
    #[error("the mode's projection on its left eigenvector is {0} (zero or not finite)")]
    Projection(f64),
}

/// Why the first mode of a hybrid system gives no modal filter.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FirstModeError {
    /// A run-time parameter of a tangent model was refused.
    #[error("tangent model: {0}")]
    Parameter(#[from] mbs_symbolic::runtime::ParamError),
    /// The system cannot be linearised or its modes computed.
    #[error("{0}")]
    Linear(#[from] crate::hybrid::LinearError),
    /// The linearised system has no mode (no state).
    #[error("the linearised system has no mode")]
    NoMode,
    /// The first mode makes no filter.
    #[error("{0}")]
    Filter(#[from] ModalFilterError),
}

impl ModalFilter {
    /// The filter of the mode shape `phi` (over the beam's reduced DOFs) with the beam mass
    /// matrix `mass` ([`fem_beam::BeamModel::mass`]).
    pub fn new(phi: &[f64], mass: &BandedSym) -> Result<ModalFilter, ModalFilterError> {
        if phi.len() != mass.size() {
            return Err(ModalFilterError::Size {
                shape: phi.len(),
                mass: mass.size(),
            });
        }
        let mut weights = vec![0.0; phi.len()];
        mass.mul_vec_into(phi, &mut weights);
        let m: f64 = weights.iter().zip(phi).map(|(w, p)| w * p).sum();
        if !(m.is_finite() && m > 0.0) {
            return Err(ModalFilterError::ModalMass(m));
        }
        weights.iter_mut().for_each(|w| *w /= m);
        Ok(ModalFilter {
            weights,
            velocity: vec![],
            currents: vec![],
        })
    }

    /// The filter of a mode `(lambda, phi)` of a linearised hybrid system
    /// ([`crate::hybrid::modes`]): the exact modal coordinate of the first-order form (the
    /// equations of [`crate::hybrid::modes`]),
    ///
    /// ```text
    /// E y' = F y,  y = (z, z', i),  E = diag(I, M_R, L),
    /// F = [0 I 0; -K_R -C_R -U; 0 W^T -R],   U = [P^T b_e],  W = [P^T g_e],
    /// ```
    ///
    /// whose right eigenvector is `Y = (phi, lambda phi, e)`, `e_e = lambda g_e^T P phi /
    /// (R_e + lambda L_e)`, and whose left eigenvector `X` has the middle block `psi`, the
    /// left null vector of the pencil, `psi^T S(lambda) = 0`, and the others
    /// `-K_R^T psi / lambda` and `-(R + lambda L)^-1 U^T psi`. With `X_j^T E Y_k = 0` for
    /// `lambda_j != lambda_k` and `d/dt X^T E y = X^T F y = lambda X^T E y`, the coordinate
    ///
    /// ```text
    /// eta = X^T E y / X^T E Y
    ///     = (psi^T K_R z - lambda psi^T M_R z' + lambda sum_e psi^T u_e L_e i_e / (R_e + lambda L_e))
    ///       / (psi^T K_R phi - lambda^2 psi^T M_R phi + lambda sum_e psi^T u_e L_e e_e / (R_e + lambda L_e))
    /// ```
    ///
    /// removes every other mode and decays exactly as `exp(lambda t)` in the linear regime,
    /// for real or complex, close or non-proportionally damped modes alike. With `phi`
    /// scaled to 1 at `point`, the filter's output `2 Re(eta)` is the mode's share of that
    /// point's displacement (m), a real linear functional of `(z, z', i)`. For an undamped
    /// mode of symmetric matrices it is the displacement filter `phi^T M_R z / (phi^T M_R
    /// phi)`. `psi` is the left null vector of the dense `S(lambda)^T` (three steps of
    /// inverse iteration at `lambda (1 + 1e-10)`), or `phi` itself above
    /// [`DENSE_LEFT_LIMIT`] coordinates. The filter reads the reduced coordinates `z = (beam
    /// DOFs, free mechanism coordinates)` ([`crate::hybrid::Linearization::dim`]) and their
    /// velocities ([`ModalFilter::apply_state`]).
    pub fn of_mode(
        lin: &crate::hybrid::Linearization,
        mode: &crate::hybrid::Mode,
        point: &crate::hybrid::BeamPoint,
    ) -> Result<ModalFilter, ModalFilterError> {
        use crate::hybrid::Matrix;
        use nalgebra::{Complex, DMatrix, DVector};
        type C64 = Complex<f64>;
        let (n, d) = (lin.structure_dofs(), lin.dim());
        let l = mode.lambda();
        let mut phi = mode.shape_complex();
        if phi.len() != d {
            return Err(ModalFilterError::Size {
                shape: phi.len(),
                mass: d,
            });
        }
        let at: C64 = point.weights.iter().map(|&(k, w)| phi[k] * w).sum();
        if !(at.norm().is_finite() && at.norm() > 0.0) || point.weights.iter().any(|&(k, _)| k >= n)
        {
            return Err(ModalFilterError::AtPoint(at.norm()));
        }
        phi.iter_mut().for_each(|p| *p /= at);
        // Dense K_R, C_R, M_R (column j = X e_j) and the generators' u_e = P^T b_e,
        // w_e = P^T g_e.
        let dense = |which: Matrix| {
            let mut m = DMatrix::<f64>::zeros(d, d);
            let (mut e, mut y) = (vec![0.0; d], vec![0.0; d]);
            for j in 0..d {
                e[j] = 1.0;
                lin.mul(which, &e, &mut y);
                e[j] = 0.0;
                m.column_mut(j).copy_from_slice(&y);
            }
            m
        };
        let lift = |s: &DVector<f64>| {
            let mut z = vec![0.0; d];
            lin.add_from_small(s.as_slice(), &mut z);
            DVector::from_vec(z)
        };
        let cplx = |m: &DMatrix<f64>| m.map(|v| C64::new(v, 0.0));
        // Dense matrices (d^2 memory) only where the dense left eigenvector is computed;
        // above the limit the products go through the operator, O(n) each.
        let small = d <= DENSE_LEFT_LIMIT;
        let (k, c, m) = if small {
            (
                dense(Matrix::Stiffness),
                dense(Matrix::Damping),
                dense(Matrix::Mass),
            )
        } else {
            let none = || DMatrix::<f64>::zeros(0, 0);
            (none(), none(), none())
        };
        // X^T v for a dense transpose, or X v through the operator above the limit (where
        // psi = phi stands for a symmetric system's left eigenvector).
        let apply_t = |which: Matrix, dense: &DMatrix<f64>, v: &DVector<C64>| -> DVector<C64> {
            if small {
                return cplx(&dense.transpose()) * v;
            }
            let (re, im): (Vec<f64>, Vec<f64>) = v.iter().map(|z| (z.re, z.im)).unzip();
            let (mut yr, mut yi) = (vec![0.0; d], vec![0.0; d]);
            lin.mul(which, &re, &mut yr);
            lin.mul(which, &im, &mut yi);
            DVector::from_iterator(d, yr.into_iter().zip(yi).map(|(a, b)| C64::new(a, b)))
        };
        /// One generator of the first-order form: force index, `R`, `L`, `u = P^T b`,
        /// `w = P^T g`.
        struct Gen {
            force: usize,
            r: f64,
            l: f64,
            u: DVector<f64>,
            w: DVector<f64>,
        }
        let gens: Vec<Gen> = lin
            .electrical
            .iter()
            .map(|e| Gen {
                force: e.force,
                r: e.resistance,
                l: e.inductance,
                u: lift(&e.torque),
                w: lift(&e.emf),
            })
            .collect();
        let phiv = DVector::from_vec(phi.clone());
        let psi = if small {
            let mu = l * (1.0 + 1e-10) + C64::new(if l.norm() == 0.0 { 1e-10 } else { 0.0 }, 0.0);
            let mut s = cplx(&k) + cplx(&c) * mu + cplx(&m) * (mu * mu);
            for g in &gens {
                let f = mu / (C64::new(g.r, 0.0) + mu * g.l);
                s += cplx(&(&g.u * g.w.transpose())) * f;
            }
            let lu = s.transpose().lu();
            let mut x = phiv.clone();
            for _ in 0..3 {
                match lu.solve(&x) {
                    Some(y) if y.iter().all(|v| v.norm().is_finite()) => {
                        let ny = y.norm();
                        x = if ny > 0.0 { y / C64::new(ny, 0.0) } else { y };
                    }
                    _ => break,
                }
            }
            x
        } else {
            phiv.clone()
        };
        // Numerator weights: a_z = K^T psi, a_v = -lambda M^T psi, a_i,e = lambda (u_e .
        // psi) L_e / (R_e + lambda L_e); denominator with Y = (phi, lambda phi, e).
        let az = apply_t(Matrix::Stiffness, &k, &psi);
        let av = apply_t(Matrix::Mass, &m, &psi) * (-l);
        let mut denominator = az.dot(&phiv) + av.dot(&phiv) * l;
        let mut currents = vec![];
        for g in &gens {
            if g.l == 0.0 {
                continue;
            }
            let den = C64::new(g.r, 0.0) + l * g.l;
            let up: C64 = g.u.iter().zip(psi.iter()).map(|(a, b)| *b * *a).sum();
            let ai = l * up * g.l / den;
            let wphi: C64 = g.w.iter().zip(phiv.iter()).map(|(a, b)| *b * *a).sum();
            denominator += ai * (l * wphi / den);
            currents.push((g.force, ai));
        }
        if !(denominator.norm().is_finite() && denominator.norm() > 0.0) {
            return Err(ModalFilterError::Projection(denominator.norm()));
        }
        let real = |a: C64| (a * 2.0 / denominator).re;
        Ok(ModalFilter {
            weights: az.iter().map(|&a| real(a)).collect(),
            velocity: av.iter().map(|&a| real(a)).collect(),
            currents: currents.into_iter().map(|(f, a)| (f, real(a))).collect(),
        })
    }

    /// The filter of the first mode (nearest zero) of `model` linearised about its static
    /// equilibrium ([`crate::hybrid::Linearization`] with one tangent model per mechanism),
    /// scaled to 1 at `point` ([`ModalFilter::of_mode`]), with the free coordinates of each
    /// mechanism it reads after the beam DOFs (the linearisation's partition). `Err` with the
    /// reason when the model cannot be linearised.
    pub fn first_mode(
        model: &crate::hybrid::HybridModel,
        tangents: &[&mbs_symbolic::runtime::TangentSystem],
        point: &crate::hybrid::BeamPoint,
    ) -> Result<(ModalFilter, Vec<Vec<usize>>), FirstModeError> {
        use crate::hybrid::{EquilibriumOptions, Linearization};
        let lin = Linearization::new(model, tangents, EquilibriumOptions::default())?;
        let first = crate::hybrid::first_mode(&lin)?.ok_or(FirstModeError::NoMode)?;
        let filter = ModalFilter::of_mode(&lin, &first, point)?;
        Ok((filter, lin.equilibrium.free))
    }

    /// The modal coordinate of the displacement `x` alone (the beam DOFs) — the whole
    /// coordinate for a filter made by [`ModalFilter::new`]; a filter made by
    /// [`ModalFilter::of_mode`] reads the state with [`ModalFilter::apply_state`]
    /// (no allocation).
    ///
    /// # Panics
    ///
    /// When `x` does not have the length of the mode shape.
    pub fn apply(&self, x: &[f64]) -> f64 {
        assert_eq!(
            x.len(),
            self.weights.len(),
            "ModalFilter::apply: x has the wrong length"
        );
        self.weights.iter().zip(x).map(|(w, x)| w * x).sum()
    }

    /// The modal coordinate of the state: displacements `z` and velocities `zd` (the
    /// reduced coordinates for a filter made by [`ModalFilter::of_mode`], the beam DOFs
    /// for one made by [`ModalFilter::new`], which ignores the velocities) and the
    /// currents of the model's forces (indexed as the forces; only inductive generators
    /// are read). No allocation.
    ///
    /// # Panics
    ///
    /// When `z` (or, for a filter that reads them, `zd`) does not have the length of the
    /// mode shape, or `currents` is shorter than a generator's force index.
    pub fn apply_state(&self, z: &[f64], zd: &[f64], currents: &[f64]) -> f64 {
        let mut eta = self.apply(z);
        if !self.velocity.is_empty() {
            assert_eq!(
                zd.len(),
                self.velocity.len(),
                "ModalFilter::apply_state: zd has the wrong length"
            );
            eta += self
                .velocity
                .iter()
                .zip(zd)
                .map(|(w, v)| w * v)
                .sum::<f64>();
        }
        for &(force, w) in &self.currents {
            eta += w * currents[force];
        }
        eta
    }
}

/// Settings of the estimator (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DecayOptions {
    /// Peaks below this fraction of the largest peak before them end the decay.
    pub floor: f64,
    /// A half-cycle ends when the signal goes past this fraction of the last peak on the
    /// other side of zero.
    pub hysteresis: f64,
}

impl Default for DecayOptions {
    fn default() -> DecayOptions {
        DecayOptions {
            floor: 1e-3,
            hysteresis: 0.05,
        }
    }
}

/// One cycle of an oscillatory decay: from a peak to the next peak of the same sign.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Cycle {
    /// Time of the cycle's middle peak (s).
    pub t: f64,
    /// Geometric mean of the bounding peaks (units of the signal).
    pub amplitude: f64,
    /// `delta / sqrt(4 pi^2 + delta^2)`, `delta = ln(p_i / p_{i+2})`.
    pub zeta: f64,
    /// `1 / (t_{i+2} - t_i)` (Hz).
    pub frequency_hz: f64,
}

/// How a signal decays (see the module documentation).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum DecayEstimate {
    /// At least one full cycle above the noise floor.
    Oscillatory {
        /// Damped frequency (Hz), least squares over the peaks.
        frequency_hz: f64,
        /// Equivalent viscous damping ratio, least squares over the peaks.
        zeta: f64,
        /// Damping and frequency cycle by cycle (damping vs amplitude).
        cycles: Vec<Cycle>,
    },
    /// Fewer than one full cycle, with zero crossings (or an oscillation slower than the
    /// record, without): only the decay rate can be read.
    Decaying {
        /// Decay rate `s` of `|y| ~ exp(-s t)` (1/s).
        rate: f64,
        /// Zero crossings seen.
        zero_crossings: usize,
    },
    /// No zero crossing, two distinct real exponential rates.
    Overdamped {
        /// The slow rate (1/s), which dominates the tail.
        rate: f64,
        /// The fast rate (1/s).
        fast_rate: f64,
    },
    /// No zero crossing, a double real rate: `(a + b t) exp(-rate t)`.
    CriticallyDamped {
        /// The rate (1/s).
        rate: f64,
    },
    /// The signal does not decay (or is too short or zero to tell).
    NotDecaying {
        /// Zero crossings seen.
        zero_crossings: usize,
    },
}

impl DecayEstimate {
    /// The overall damping ratio of an oscillatory decay.
    pub fn zeta(&self) -> Option<f64> {
        match self {
            DecayEstimate::Oscillatory { zeta, .. } => Some(*zeta),
            _ => None,
        }
    }

    /// The damped frequency of an oscillatory decay (Hz).
    pub fn frequency_hz(&self) -> Option<f64> {
        match self {
            DecayEstimate::Oscillatory { frequency_hz, .. } => Some(*frequency_hz),
            _ => None,
        }
    }

    /// The cycles of an oscillatory decay (empty otherwise).
    pub fn cycles(&self) -> &[Cycle] {
        match self {
            DecayEstimate::Oscillatory { cycles, .. } => cycles,
            _ => &[],
        }
    }

    /// A short human-readable form (`zeta 4.085 % at 6.52 Hz`, `overdamped, rate 3.1 1/s`).
    pub fn describe(&self) -> String {
        match self {
            DecayEstimate::Oscillatory {
                frequency_hz, zeta, ..
            } => format!("zeta {:.3} % at {frequency_hz:.3} Hz", zeta * 100.0),
            DecayEstimate::Decaying {
                rate,
                zero_crossings,
            } => format!(
                "decay rate {rate:.4} 1/s ({zero_crossings} zero crossing(s), under one cycle)"
            ),
            DecayEstimate::Overdamped { rate, .. } => format!("overdamped, rate {rate:.4} 1/s"),
            DecayEstimate::CriticallyDamped { rate } => {
                format!("critically damped, rate {rate:.4} 1/s")
            }
            DecayEstimate::NotDecaying { .. } => "not decaying".to_string(),
        }
    }
}

/// A peak of a half-cycle: time and `|y|`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Peak {
    t: f64,
    value: f64,
}

/// The largest-|y| sample of the current half-cycle with its neighbours (`sign * y`).
#[derive(Clone, Copy, Debug)]
struct Candidate {
    index: u64,
    at: (f64, f64),
    before: Option<(f64, f64)>,
    after: Option<(f64, f64)>,
}

impl Candidate {
    /// The vertex of the parabola through the candidate and its neighbours (the sample
    /// itself at the ends of the record or when the parabola does not open downwards).
    fn refine(&self) -> Peak {
        let (t1, y1) = self.at;
        let plain = Peak { t: t1, value: y1 };
        let (Some((t0, y0)), Some((t2, y2))) = (self.before, self.after) else {
            return plain;
        };
        let (u0, u2) = (t0 - t1, t2 - t1);
        let (d0, d2) = ((y0 - y1) / u0, (y2 - y1) / u2);
        let c = (d2 - d0) / (u2 - u0);
        if c.is_nan() || c >= 0.0 {
            return plain;
        }
        let b = d0 - c * u0;
        let u = -b / (2.0 * c);
        if !(u0..=u2).contains(&u) {
            return plain;
        }
        Peak {
            t: t1 + u,
            value: y1 - b * b / (4.0 * c),
        }
    }
}

/// Least-squares sums of Prony's two-exponential recurrence over equally spaced triples.
#[derive(Clone, Copy, Debug, Default)]
struct Prony {
    h: Option<f64>,
    /// `sum y1 y1, y1 y0, y0 y0, y2 y1, y2 y0`.
    sums: [f64; 5],
    triples: u64,
}

impl Prony {
    fn push(&mut self, [(t0, y0), (t1, y1), (t2, y2)]: [(f64, f64); 3]) {
        let h = *self.h.get_or_insert(t1 - t0);
        let close = |d: f64| (d - h).abs() <= 1e-6 * h;
        if !(h > 0.0 && close(t1 - t0) && close(t2 - t1)) {
            return;
        }
        let s = &mut self.sums;
        s[0] += y1 * y1;
        s[1] += y1 * y0;
        s[2] += y0 * y0;
        s[3] += y2 * y1;
        s[4] += y2 * y0;
        self.triples += 1;
    }

    /// The characteristic roots as rates: `Real(s1, s2)` (s1 <= s2) or `Complex(rate)`.
    fn rates(&self) -> Option<Roots> {
        let h = self.h?;
        if self.triples < 2 {
            return None;
        }
        let [a, b, c, r1, r0] = self.sums;
        let det = a * c - b * b;
        if det.is_nan() || det == 0.0 {
            // One exponential: y_{k+1} = z y_k.
            let z = b / c;
            return (z > 0.0).then(|| Roots::Real(-z.ln() / h, -z.ln() / h));
        }
        let c1 = (r1 * c - r0 * b) / det;
        let c0 = (a * r0 - b * r1) / det;
        // z^2 - c1 z - c0 = 0.
        let disc = 0.25 * c1 * c1 + c0;
        if disc >= 0.0 {
            let m = 0.5 * c1;
            // The root of larger modulus directly, the other from the product `-c0` (no
            // cancellation).
            let z1 = m + disc.sqrt().copysign(m);
            let z2 = if z1 != 0.0 { -c0 / z1 } else { 0.0 };
            let (zs, zb) = (z1.min(z2), z1.max(z2));
            if zs <= 0.0 {
                // A non-positive real root is no decay of this model: the larger root alone.
                return (zb > 0.0).then(|| Roots::Real(-zb.ln() / h, -zb.ln() / h));
            }
            Some(Roots::Real(-zb.ln() / h, -zs.ln() / h))
        } else {
            // |z|^2 = -c0.
            Some(Roots::Complex(-0.5 * (-c0).ln() / h))
        }
    }
}

#[derive(Clone, Copy, Debug)]
enum Roots {
    Real(f64, f64),
    Complex(f64),
}

/// The estimator, one sample at a time (see the module documentation).
#[derive(Clone, Debug)]
pub struct DecayTracker {
    options: DecayOptions,
    count: u64,
    last: [Option<(f64, f64)>; 2],
    sign: f64,
    candidate: Option<Candidate>,
    threshold: f64,
    peaks: Vec<Peak>,
    crossings: usize,
    max_abs: f64,
    prony: Prony,
}

impl Default for DecayTracker {
    fn default() -> DecayTracker {
        DecayTracker::new(DecayOptions::default())
    }
}

impl DecayTracker {
    /// An empty tracker.
    pub fn new(options: DecayOptions) -> DecayTracker {
        DecayTracker {
            options,
            count: 0,
            last: [None; 2],
            sign: 0.0,
            candidate: None,
            threshold: 0.0,
            peaks: vec![],
            crossings: 0,
            max_abs: 0.0,
            prony: Prony::default(),
        }
    }

    /// Takes the next sample `y(t)` (times increasing).
    pub fn push(&mut self, t: f64, y: f64) {
        let index = self.count;
        self.count += 1;
        if !y.is_finite() {
            return;
        }
        self.max_abs = self.max_abs.max(y.abs());
        if let [Some(p0), Some(p1)] = self.last {
            let level = self.options.floor * self.max_abs;
            if [p0.1, p1.1, y].iter().all(|v| v.abs() >= level) {
                self.prony.push([p0, p1, (t, y)]);
            }
        }
        if let Some(c) = &mut self.candidate {
            if c.index + 1 == index {
                c.after = Some((t, self.sign * y));
            }
        }
        let prev = self.last[1];
        self.last = [self.last[1], Some((t, y))];
        if self.sign == 0.0 {
            if y != 0.0 {
                self.sign = y.signum();
                self.start(index, t, y, prev);
            }
            return;
        }
        let v = self.sign * y;
        if v < -self.threshold {
            if let Some(c) = self.candidate.take() {
                let peak = c.refine();
                self.threshold = self.options.hysteresis * peak.value;
                // The first sample of the record is where the record starts, not
                // necessarily an extremum (a decay released from rest has y'(0) = 0, but
                // `exp(-s t) cos(w t)` does not): not a peak.
                if c.before.is_some() {
                    self.peaks.push(peak);
                }
            }
            self.crossings += 1;
            self.sign = -self.sign;
            self.start(index, t, y, prev);
        } else if self.candidate.is_none_or(|c| v > c.at.1) {
            self.start(index, t, y, prev);
        }
    }

    fn start(&mut self, index: u64, t: f64, y: f64, prev: Option<(f64, f64)>) {
        let s = self.sign;
        self.candidate = Some(Candidate {
            index,
            at: (t, s * y),
            before: prev.map(|(t, y)| (t, s * y)),
            after: None,
        });
    }

    /// The peaks used: while above the floor times the largest before them.
    fn used(&self) -> &[Peak] {
        let mut top = 0.0f64;
        let n = self
            .peaks
            .iter()
            .take_while(|p| {
                top = top.max(p.value);
                p.value > self.options.floor * top
            })
            .count();
        &self.peaks[..n]
    }

    /// The estimate from the samples so far.
    pub fn estimate(&self) -> DecayEstimate {
        let used = self.used();
        let not = DecayEstimate::NotDecaying {
            zero_crossings: self.crossings,
        };
        if used.len() >= 3 {
            return oscillatory(used);
        }
        let positive = |r: f64| r.is_finite() && r > 0.0;
        if self.crossings > 0 {
            let rate = if used.len() >= 2 {
                let x: Vec<f64> = used.iter().map(|p| p.t).collect();
                let y: Vec<f64> = used.iter().map(|p| p.value.ln()).collect();
                -line(&x, &y)
            } else {
                match self.prony.rates() {
                    Some(Roots::Complex(r)) => r,
                    Some(Roots::Real(s1, _)) => s1,
                    None => f64::NAN,
                }
            };
            return if positive(rate) {
                DecayEstimate::Decaying {
                    rate,
                    zero_crossings: self.crossings,
                }
            } else {
                not
            };
        }
        match self.prony.rates() {
            Some(Roots::Real(s1, s2)) if positive(s1) && s2.is_finite() => {
                if (s2 - s1) <= CRITICAL_SPLIT * 0.5 * (s1 + s2) {
                    DecayEstimate::CriticallyDamped {
                        rate: 0.5 * (s1 + s2),
                    }
                } else {
                    DecayEstimate::Overdamped {
                        rate: s1,
                        fast_rate: s2,
                    }
                }
            }
            Some(Roots::Complex(rate)) if positive(rate) => DecayEstimate::Decaying {
                rate,
                zero_crossings: 0,
            },
            _ => not,
        }
    }
}

/// The slope of the least-squares line through `(x, y)`.
fn line(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (x, y) in x.iter().zip(y) {
        sxy += (x - mx) * (y - my);
        sxx += (x - mx) * (x - mx);
    }
    sxy / sxx
}

/// `delta / sqrt(4 pi^2 + delta^2)`.
fn zeta_of(delta: f64) -> f64 {
    delta / (4.0 * std::f64::consts::PI.powi(2) + delta * delta).sqrt()
}

fn oscillatory(used: &[Peak]) -> DecayEstimate {
    let cycles = used
        .windows(3)
        .map(|w| Cycle {
            t: w[1].t,
            amplitude: (w[0].value * w[2].value).sqrt(),
            zeta: zeta_of((w[0].value / w[2].value).ln()),
            frequency_hz: 1.0 / (w[2].t - w[0].t),
        })
        .collect();
    let k: Vec<f64> = (0..used.len()).map(|k| k as f64).collect();
    let ln: Vec<f64> = used.iter().map(|p| p.value.ln()).collect();
    let t: Vec<f64> = used.iter().map(|p| p.t).collect();
    DecayEstimate::Oscillatory {
        frequency_hz: 1.0 / (2.0 * line(&k, &t)),
        zeta: zeta_of(-2.0 * line(&k, &ln)),
        cycles,
    }
}

/// The decay of a sampled signal `y(t)` with the default options (the batch form of
/// [`DecayTracker`], bit for bit).
pub fn estimate(t: &[f64], y: &[f64]) -> DecayEstimate {
    estimate_with(t, y, DecayOptions::default())
}

/// [`estimate`] with given options.
///
/// # Panics
///
/// When `t` and `y` have different lengths.
pub fn estimate_with(t: &[f64], y: &[f64], options: DecayOptions) -> DecayEstimate {
    assert_eq!(t.len(), y.len(), "decay::estimate: t and y lengths differ");
    let mut d = DecayTracker::new(options);
    t.iter().zip(y).for_each(|(t, y)| d.push(*t, *y));
    d.estimate()
}
