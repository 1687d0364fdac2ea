//! Sensitivities of the linearised system to a parameter `p` (issue #22): the derivatives
//! of its eigenvalues and of its harmonic responses, exact given the derivative of the
//! pencil.
//!
//! # The pencil and its derivatives
//!
//! With the pencil of [`super::pencil`],
//!
//! ```text
//! S(sigma) = K_R + sigma C_R + sigma^2 M_R + sigma sum_e P^T b_e g_e^T P / (R_e + sigma L_e)
//! S'(sigma) = C_R + 2 sigma M_R + sum_e P^T b_e g_e^T P R_e / (R_e + sigma L_e)^2
//! ```
//!
//! ([`Linearization::pencil_mul`], [`Linearization::pencil_rate_mul`]). The derivative
//! `dS/dp` with respect to a model parameter is taken from the two linearisations at
//! `p - h` and `p + h` ([`pencil_derivative`]): `(S_+(sigma) v - S_-(sigma) v) / 2h` applied
//! to the one vector the formulas below need (the model's dependence on a scenario field
//! goes through its builder and its static equilibrium, which have no derivative of their
//! own: this is the semi-analytic method, Adelman & Haftka 1986 — the expensive
//! eigen-solution, frequency search or Lyapunov solution is done once, at `p`).
//!
//! # Eigenvalues
//!
//! For a simple eigenvalue `lambda` with right and left null vectors, `S(lambda) phi = 0`
//! and `psi^T S(lambda) = 0`, differentiating `S(lambda(p), p) phi(p) = 0` and multiplying
//! by `psi^T` gives
//!
//! ```text
//! d lambda / dp = - psi^T (dS/dp)(lambda) phi / psi^T S'(lambda) phi
//! ```
//!
//! which is `psi^H (dA - lambda dB) phi / psi^H B phi` of the first-order form `A y =
//! lambda B y` written on the pencil (its left and right vectors restricted to the
//! positions), without forming the first-order matrices. `psi` is the null vector of the
//! transposed pencil ([`Linearization::transposed`]), found by inverse iteration at a shift
//! near `lambda` ([`super::eigen`]), started from `phi` (exact for a symmetric pencil).
//!
//! # Harmonic responses
//!
//! `S(i omega) z = f` gives `dz/dp = S(i omega)^-1 (df/dp - (dS/dp)(i omega) z)`: one more
//! solve with the factorised pencil ([`response_derivative`]).

use nalgebra::Complex;

use super::eigen::{Mode, pencil_near};
use super::linear::{LinearError, Linearization};
use super::pencil::Pencil;

type C64 = Complex<f64>;

/// Inverse-iteration steps for the left vector.
const LEFT_STEPS: usize = 3;

/// The unconjugated product `a^T b`.
fn dot(a: &[C64], b: &[C64]) -> C64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// A difference formula for the derivative of the pencil applied to `v`:
/// `sum_j w_j S_j(sigma_j) v` over `terms = [(w_j, linearisation j, sigma_j)]`, e.g. the
/// central difference `[(1/2h, lin(p+h), sigma), (-1/2h, lin(p-h), sigma)]` (the shift may
/// move with the parameter, e.g. an excitation frequency). Refused when the linearisations
/// have different coordinates.
pub fn pencil_derivative(
    terms: &[(f64, &Linearization, C64)],
    v: &[C64],
) -> Result<Vec<C64>, LinearError> {
    let mut out = vec![C64::new(0.0, 0.0); v.len()];
    for (j, &(w, lin, sigma)) in terms.iter().enumerate() {
        if j > 0 {
            same_layout(terms[0].1, lin)?;
        }
        if lin.dim() != v.len() {
            return Err(LinearError::LayoutChanged { what: "size" });
        }
        for (o, x) in out.iter_mut().zip(lin.pencil_mul(sigma, v)) {
            *o += x * w;
        }
    }
    Ok(out)
}

/// Refuses two linearisations whose coordinates differ.
pub fn same_layout(a: &Linearization, b: &Linearization) -> Result<(), LinearError> {
    let what = if a.structure_dofs() != b.structure_dofs() {
        Some("beam DOFs")
    } else if a.couplings() != b.couplings() {
        Some("attachments")
    } else if a.equilibrium.free != b.equilibrium.free {
        Some("free coordinates")
    } else if a.electrical.len() != b.electrical.len() {
        Some("inductive generators")
    } else {
        None
    };
    match what {
        Some(what) => Err(LinearError::LayoutChanged { what }),
        None => Ok(()),
    }
}

/// A simple eigenvalue with its right and left null vectors and the denominator
/// `psi^T S'(lambda) phi` of its derivative (see the module documentation).
#[derive(Clone, Debug)]
pub struct EigenSensitivity {
    lambda: C64,
    right: Vec<C64>,
    left: Vec<C64>,
    denominator: C64,
}

impl EigenSensitivity {
    /// The sensitivity of `mode`, a mode of `lin` ([`super::modes`]).
    pub fn new(lin: &Linearization, mode: &Mode) -> Result<EigenSensitivity, LinearError> {
        let lambda = mode.lambda();
        let right = mode.shape_complex();
        let transposed = lin.transposed();
        let pencil = pencil_near(&transposed, lambda)?;
        let mut left = right.clone();
        for _ in 0..LEFT_STEPS {
            pencil.solve_in_place(&mut left);
            let norm = left.iter().map(|x| x.norm_sqr()).sum::<f64>().sqrt();
            if norm > 0.0 && norm.is_finite() {
                left.iter_mut().for_each(|x| *x /= norm);
            }
        }
        let rate = lin.pencil_rate_mul(lambda, &right);
        let denominator = dot(&left, &rate);
        let norm = |v: &[C64]| v.iter().map(|x| x.norm_sqr()).sum::<f64>().sqrt();
        // |psi| = 1: the denominator against the sizes it is made of.
        let simple = denominator.norm() > 1e-12 * norm(&rate);
        if !simple {
            return Err(LinearError::NotSimple {
                eigenvalue: mode.eigenvalue,
            });
        }
        Ok(EigenSensitivity {
            lambda,
            right,
            left,
            denominator,
        })
    }

    /// The eigenvalue.
    pub fn lambda(&self) -> C64 {
        self.lambda
    }

    /// The right null vector `phi` (the mode's shape).
    pub fn right(&self) -> &[C64] {
        &self.right
    }

    /// The left null vector `psi` (unit 2-norm).
    pub fn left(&self) -> &[C64] {
        &self.left
    }

    /// `d lambda / dp` for `dS_phi = (dS/dp)(lambda) phi` (e.g.
    /// [`EigenSensitivity::lambda`] applied to [`EigenSensitivity::right`], [`pencil_derivative`]).
    pub fn derivative(&self, ds_phi: &[C64]) -> C64 {
        -dot(&self.left, ds_phi) / self.denominator
    }

    /// `d lambda / dp` for the difference formula `terms = [(w_j, linearisation j)]` of the
    /// pencil's derivative ([`pencil_derivative`] at `lambda`).
    pub fn derivative_over(&self, terms: &[(f64, &Linearization)]) -> Result<C64, LinearError> {
        let terms: Vec<_> = terms.iter().map(|&(w, l)| (w, l, self.lambda)).collect();
        let ds_phi = pencil_derivative(&terms, &self.right)?;
        Ok(self.derivative(&ds_phi))
    }
}

/// `dz/dp = S(sigma)^-1 (df - dS_z)` for the response `z` of `S(sigma) z = f`, with
/// `dS_z = (dS/dp)(sigma) z` and `df = df/dp` ([`pencil_derivative`]); `pencil` is `S(sigma)`
/// factorised.
pub fn response_derivative(pencil: &Pencil, ds_z: &[C64], df: &[f64]) -> Vec<C64> {
    let mut rhs: Vec<C64> = df
        .iter()
        .zip(ds_z)
        .map(|(&f, s)| C64::new(f, 0.0) - s)
        .collect();
    pencil.solve_in_place(&mut rhs);
    rhs
}
