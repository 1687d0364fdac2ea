//! Modes of a linearised hybrid system: the eigenvalues nearest a shift of the first-order
//! form of the linearised equations (see [`super::linear`]),
//!
//! ```text
//! y = (z, z', i_e):   z' = v,   M_R v' = -K_R z - C_R v - sum_e P^T b_e i_e,
//!                     L_e i_e' = g_e^T P v - R_e i_e,          y' = A y,
//! ```
//!
//! computed on the shift-inverted operator `(A - sigma I)^-1` (`sigma = 0`, or a small
//! negative shift when `K_R` is singular), whose largest eigenvalues `theta` are the modes
//! nearest `sigma`: `lambda = sigma + 1/theta`. Applying it costs one solve with the pencil
//! `S(sigma)` ([`super::Pencil`], `O(n)`):
//!
//! ```text
//! (A - sigma I)^-1 (c, d, g) = (a, c + sigma a, e),
//! S(sigma) a = -M_R d - (C_R + sigma M_R) c - sum_e P^T b_e (g_e^T P c - L_e g_e) / (R_e + sigma L_e)
//! e_e = (g_e^T P (c + sigma a) - L_e g_e) / (R_e + sigma L_e)
//! ```
//!
//! Working on the inverse keeps the low modes accurate to rounding relative to themselves
//! (the state matrix `A` itself spans `omega_1` to `omega_max^2` and an eigen-solver on it
//! would give `omega_1` only to `eps omega_max^2`).
//!
//! - [`EigenMethod::Dense`]: the operator as a dense matrix (one solve per column) and all
//!   its eigenvalues by the real Schur form — for small systems.
//! - [`EigenMethod::ShiftInvert`]: Arnoldi's method on the operator with full
//!   re-orthogonalisation, growing the Krylov space until the wanted Ritz values converge —
//!   no dense `n x n` matrix, `O(n m^2)` for `m` Krylov vectors.
//!
//! Either way each mode's vector is then refined by inverse iteration with the pencil at
//! the computed eigenvalue (`S(lambda) z ~ 0`, three solves) and its normwise backward
//! error `|S(lambda) z| / ((|K_R| + |lambda| |C_R| + |lambda|^2 |M_R|) |z|)` is reported
//! (rounding level, about 1e-16, for a converged pair; the relative residual against
//! `|K_R z|` would instead carry the beam's `omega_max^2 / omega_1^2` of cancellation).

use nalgebra::{Complex, DMatrix, DVector};
use serde::Serialize;

use super::linear::{LinearError, Linearization, Matrix};
use super::pencil::Pencil;

type C64 = Complex<f64>;

/// How the eigenvalues are computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EigenMethod {
    /// Dense up to [`DENSE_STATES`] states, shift-invert Arnoldi above.
    #[default]
    Auto,
    /// The dense operator and its real Schur form.
    Dense,
    /// Arnoldi on the shift-inverted operator.
    ShiftInvert,
}

/// The most first-order states [`EigenMethod::Auto`] solves densely.
pub const DENSE_STATES: usize = 600;

impl EigenMethod {
    /// Whether the method computes every eigenvalue of the dense operator for a system of
    /// `states` first-order states.
    pub fn is_dense(self, states: usize) -> bool {
        match self {
            EigenMethod::Auto => states <= DENSE_STATES,
            EigenMethod::Dense => true,
            EigenMethod::ShiftInvert => false,
        }
    }
}

/// What a mode is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ModeKind {
    /// A complex pair `lambda = -zeta omega +- i omega sqrt(1 - zeta^2)` (reported with
    /// `Im lambda > 0`).
    Oscillatory,
    /// A real negative eigenvalue: an overdamped (or electrical) motion decaying at rate
    /// `-lambda`, without oscillation.
    Overdamped,
    /// A zero eigenvalue (a free coordinate without stiffness: rigid motion).
    Rigid,
    /// An eigenvalue with positive real part: the equilibrium is unstable.
    Unstable,
}

/// One mode of the linearised system.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Mode {
    /// What it is.
    pub kind: ModeKind,
    /// The eigenvalue `lambda` (1/s): real and imaginary parts.
    pub eigenvalue: [f64; 2],
    /// `|lambda| / 2 pi` (Hz): the undamped natural frequency of the mode.
    pub natural_frequency_hz: f64,
    /// `|Im lambda| / 2 pi` (Hz): the damped frequency (0 when not oscillatory).
    pub damped_frequency_hz: f64,
    /// `-Re lambda / |lambda|` (0 for a rigid mode).
    pub damping_ratio: f64,
    /// `-Re lambda` (1/s): the decay rate of the mode's amplitude.
    pub decay_rate: f64,
    /// The shape in `z = (q^c, u)`, normalised so that its largest beam transverse entry
    /// (or, without a beam, its largest entry) is 1: real and imaginary parts.
    pub shape: Vec<[f64; 2]>,
    /// Relative residual of the refined pair (see the module documentation).
    pub residual: f64,
}

impl Mode {
    /// The shape as complex numbers.
    pub fn shape_complex(&self) -> Vec<C64> {
        self.shape
            .iter()
            .map(|&[re, im]| C64::new(re, im))
            .collect()
    }

    /// The eigenvalue as a complex number.
    pub fn lambda(&self) -> C64 {
        C64::new(self.eigenvalue[0], self.eigenvalue[1])
    }
}

/// The shift-inverted operator `(A - sigma I)^-1` (see the module documentation).
struct Operator<'a> {
    lin: &'a Linearization,
    pencil: Pencil,
    d: usize,
    /// The positions enter scaled by `omega` (a frequency of the low modes): the similarity
    /// `(omega z, z', i)` gives positions and velocities of one scale, so the Krylov basis
    /// and the Ritz values are not dominated by one block.
    omega: f64,
    /// Work vectors of [`Operator::apply`], allocated once.
    work: std::cell::RefCell<Work>,
}

/// Work vectors of one application of the operator.
struct Work {
    unscaled: Vec<f64>,
    t: Vec<f64>,
    rhs: Vec<f64>,
    small: Vec<f64>,
    force: Vec<f64>,
    a: Vec<C64>,
}

impl Work {
    fn new(lin: &Linearization) -> Work {
        let (d, ns) = (lin.dim(), lin.small_dim());
        Work {
            unscaled: vec![0.0; d],
            t: vec![0.0; d],
            rhs: vec![0.0; d],
            small: vec![0.0; ns],
            force: vec![0.0; ns],
            a: vec![C64::new(0.0, 0.0); d],
        }
    }
}

impl<'a> Operator<'a> {
    /// The operator at the pencil nearest zero ([`Pencil::near_zero`]).
    fn new(lin: &'a Linearization) -> Result<Operator<'a>, LinearError> {
        let pencil = Pencil::near_zero(lin)?;
        let omega = low_frequency(lin, &pencil);
        Ok(Operator {
            lin,
            pencil,
            d: lin.dim(),
            omega,
            work: std::cell::RefCell::new(Work::new(lin)),
        })
    }

    fn sigma(&self) -> f64 {
        self.pencil.sigma().re
    }

    fn states(&self) -> usize {
        2 * self.d + self.lin.electrical.len()
    }

    fn apply(&self, y: &[f64], out: &mut [f64]) {
        let (lin, d, s) = (self.lin, self.d, self.sigma());
        let mut work = self.work.borrow_mut();
        let Work {
            unscaled,
            t,
            rhs,
            small: sm,
            force,
            a,
        } = &mut *work;
        for (u, x) in unscaled.iter_mut().zip(&y[..d]) {
            *u = x / self.omega;
        }
        let (c, dd, g) = (&unscaled[..], &y[d..2 * d], &y[2 * d..]);
        rhs.fill(0.0);
        lin.mul(Matrix::Mass, dd, t);
        rhs.iter_mut().zip(t.iter()).for_each(|(r, x)| *r -= x);
        lin.mul(Matrix::Damping, c, t);
        rhs.iter_mut().zip(t.iter()).for_each(|(r, x)| *r -= x);
        lin.mul(Matrix::Mass, c, t);
        rhs.iter_mut().zip(t.iter()).for_each(|(r, x)| *r -= s * x);
        lin.to_small(c, sm);
        force.fill(0.0);
        for (k, e) in lin.electrical.iter().enumerate() {
            let gc: f64 = e.emf.iter().zip(sm.iter()).map(|(a, b)| a * b).sum();
            let f = (gc - e.inductance * g[k]) / (e.resistance + s * e.inductance);
            for (fi, b) in force.iter_mut().zip(e.torque.iter()) {
                *fi -= b * f;
            }
        }
        lin.add_from_small(force, rhs);
        for (ai, &x) in a.iter_mut().zip(rhs.iter()) {
            *ai = C64::new(x, 0.0);
        }
        self.pencil.solve_in_place(a);
        for i in 0..d {
            out[i] = self.omega * a[i].re;
            out[d + i] = c[i] + s * a[i].re;
        }
        lin.to_small(&out[d..2 * d], sm);
        for (k, e) in lin.electrical.iter().enumerate() {
            let gb: f64 = e.emf.iter().zip(sm.iter()).map(|(a, b)| a * b).sum();
            out[2 * d + k] = (gb - e.inductance * g[k]) / (e.resistance + s * e.inductance);
        }
    }
}

/// The first `k` modes of `lin` (nearest zero: lowest `|lambda|`), one per conjugate pair,
/// in increasing `|lambda|`.
pub fn modes(lin: &Linearization, k: usize, method: EigenMethod) -> Result<Vec<Mode>, LinearError> {
    let op = Operator::new(lin)?;
    let dense = method.is_dense(op.states());
    nearest_zero(&op, k, dense)
}

/// The first mode of `lin` (nearest zero), `None` when the system has no state. Arnoldi's
/// method when the shift is zero (no rigid-body mode): the eigenvalue nearest zero is then
/// the operator's dominant one, which a Krylov space of a few tens of solves resolves
/// (`O(n)` each), where the dense operator costs a solve per state and a Schur form of
/// `O(n^3)`; when a rigid-body mode moved the shift, the eigenvalue nearest the shift need
/// not be the one nearest zero, and [`EigenMethod::Auto`] decides. The mode of
/// `modes(lin, 1, EigenMethod::Auto)`, its eigenvalue equal to about 1e-12 (both refined by
/// inverse iteration: the test `first_mode_is_the_dense_solvers_first_mode`).
pub fn first_mode(lin: &Linearization) -> Result<Option<Mode>, LinearError> {
    let op = Operator::new(lin)?;
    let dense = op.sigma() != 0.0 && EigenMethod::Auto.is_dense(op.states());
    Ok(nearest_zero(&op, 1, dense)?.into_iter().next())
}

/// The `k` modes nearest zero from the eigenvalues of the shift-inverted operator, all of
/// them (`dense`) or Arnoldi's converged ones.
fn nearest_zero(op: &Operator<'_>, k: usize, dense: bool) -> Result<Vec<Mode>, LinearError> {
    let n = op.states();
    if n == 0 || k == 0 {
        return Ok(vec![]);
    }
    let thetas = if dense {
        dense_thetas(op)?
    } else {
        arnoldi_thetas(op, k)?
    };
    let sigma = op.sigma();
    let mut lambdas: Vec<C64> = thetas
        .iter()
        .filter(|t| t.norm() > 0.0 && t.im <= 0.0)
        .map(|t| C64::new(sigma, 0.0) + t.inv())
        .collect();
    lambdas.sort_by(|a, b| {
        a.norm()
            .total_cmp(&b.norm())
            .then(a.im.total_cmp(&b.im))
            .then(a.re.total_cmp(&b.re))
    });
    lambdas.truncate(k);
    lambdas
        .into_iter()
        .map(|l| refine(op.lin, l))
        .collect::<Result<Vec<_>, _>>()
}

/// A frequency of the low modes (rad/s): the Rayleigh quotient `sqrt(u^T K u / u^T M u)`
/// of `u = S(sigma)^-1 M 1`, one step of inverse iteration from a uniform vector; 1 when
/// it is not usable (no mass, no stiffness).
fn low_frequency(lin: &Linearization, pencil: &Pencil) -> f64 {
    let d = lin.dim();
    let mut t = vec![0.0; d];
    lin.mul(Matrix::Mass, &vec![1.0; d], &mut t);
    let mut u: Vec<C64> = t.iter().map(|&x| C64::new(x, 0.0)).collect();
    pencil.solve_in_place(&mut u);
    let ur: Vec<f64> = u.iter().map(|x| x.re).collect();
    let (mut ku, mut mu) = (vec![0.0; d], vec![0.0; d]);
    lin.mul(Matrix::Stiffness, &ur, &mut ku);
    lin.mul(Matrix::Mass, &ur, &mut mu);
    let num: f64 = ur.iter().zip(&ku).map(|(a, b)| a * b).sum();
    let den: f64 = ur.iter().zip(&mu).map(|(a, b)| a * b).sum();
    let w = (num / den).abs().sqrt();
    if w.is_finite() && w > 0.0 { w } else { 1.0 }
}

/// Every eigenvalue of the dense operator.
fn dense_thetas(op: &Operator<'_>) -> Result<Vec<C64>, LinearError> {
    let n = op.states();
    let mut b = DMatrix::zeros(n, n);
    let mut e = vec![0.0; n];
    let mut out = vec![0.0; n];
    for c in 0..n {
        e[c] = 1.0;
        op.apply(&e, &mut out);
        e[c] = 0.0;
        b.column_mut(c).copy_from_slice(&out);
    }
    check_finite(&b, "shift-inverted state matrix")?;
    balance(&mut b);
    schur_eigenvalues(b, "real Schur form of the shift-inverted state matrix")
}

/// The first non-finite entry of `a`, as an error naming `matrix`.
fn check_finite(a: &DMatrix<f64>, matrix: &'static str) -> Result<(), LinearError> {
    match a.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(LinearError::NonFinite {
            matrix,
            row: i % a.nrows(),
            column: i / a.nrows(),
            value: a[i],
        }),
    }
}

/// Every eigenvalue of the finite square matrix `a` from its real Schur form (Francis'
/// implicit double-shift QR), with at most `30 max(10, n)` QR sweeps in all (LAPACK
/// `dhseqr`'s cap, `ITMAX`): a matrix on which the iteration does not converge (nalgebra's
/// `complex_eigenvalues` has no cap) is an error naming `what`, not a hang. The sweeps and
/// their deflation test (`eps`) are those of `complex_eigenvalues`, so a converging
/// matrix gives the same eigenvalues.
fn schur_eigenvalues(a: DMatrix<f64>, what: &'static str) -> Result<Vec<C64>, LinearError> {
    let n = a.nrows();
    let cap = 30 * n.max(10);
    nalgebra::Schur::try_new(a, f64::EPSILON, cap)
        .map(|s| s.complex_eigenvalues().iter().copied().collect())
        .ok_or(LinearError::NoEigenConvergence {
            what,
            iterations: cap,
            size: n,
        })
}

/// Balances `a` in place by a diagonal similarity with powers of two (Parlett and Reinsch
/// 1969, as LAPACK's `gebal` without permutations): rows and columns of comparable norms, so
/// that the Schur form's rounding is relative to each eigenvalue's own scale rather than to
/// the largest entry. `a` must be finite; the sweeps stop after 100 (each sweep that changes
/// a scale reduces the row plus column norm by 5 %, so a finite matrix converges well
/// before; the balance is an accuracy aid and an unfinished one is still a similarity).
fn balance(a: &mut DMatrix<f64>) {
    let n = a.nrows();
    let radix = 2.0f64;
    let mut converged = false;
    for _ in 0..100 {
        if converged {
            break;
        }
        converged = true;
        for i in 0..n {
            let (mut c, mut r) = (0.0, 0.0);
            for j in 0..n {
                if j != i {
                    c += a[(j, i)].abs();
                    r += a[(i, j)].abs();
                }
            }
            if c == 0.0 || r == 0.0 || !(c + r).is_finite() {
                continue;
            }
            let s = c + r;
            let mut f = 1.0;
            let (mut cc, mut rr) = (c, r);
            while cc < rr / radix {
                cc *= radix;
                rr /= radix;
                f *= radix;
            }
            while cc >= rr * radix {
                cc /= radix;
                rr *= radix;
                f /= radix;
            }
            if (cc + rr) < 0.95 * s {
                converged = false;
                for j in 0..n {
                    a[(i, j)] /= f;
                    a[(j, i)] *= f;
                }
            }
        }
    }
}

/// Ritz values of Arnoldi's method on the operator, the Krylov space grown until the `k`
/// wanted ones (largest `|theta|`, one per pair) have converged (the space doubles each
/// time, so at most `log2(n)` rounds before it is the whole space).
fn arnoldi_thetas(op: &Operator<'_>, k: usize) -> Result<Vec<C64>, LinearError> {
    let n = op.states();
    let mut m = (2 * k + 20).max(30).min(n);
    loop {
        let (h, beta_last) = arnoldi(op, m);
        let mm = h.nrows();
        check_finite(
            &h,
            "Arnoldi Hessenberg matrix of the shift-inverted state matrix",
        )?;
        let thetas = schur_eigenvalues(
            h.clone(),
            "real Schur form of the Arnoldi Hessenberg matrix",
        )?;
        if mm >= n || beta_last == 0.0 {
            return Ok(thetas);
        }
        // Residual estimate of each Ritz pair: beta |e_m^T s| / |theta| (s a unit eigenvector
        // of H), relative to theta.
        let mut wanted: Vec<C64> = thetas.iter().copied().filter(|t| t.im <= 0.0).collect();
        wanted.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
        wanted.truncate(k);
        let hc = h.map(|v| C64::new(v, 0.0));
        let converged = wanted.iter().all(|&t| {
            let s = inverse_vector(&hc, t);
            beta_last * s[mm - 1].norm() <= 1e-14 * t.norm()
        });
        if converged {
            return Ok(thetas);
        }
        m = (2 * m).min(n);
    }
}

/// `m` steps of Arnoldi (classical Gram–Schmidt applied twice) from a fixed start vector:
/// the Hessenberg matrix and the last subdiagonal `beta` (0 when the space is invariant).
fn arnoldi(op: &Operator<'_>, m: usize) -> (DMatrix<f64>, f64) {
    let n = op.states();
    let mut v: Vec<Vec<f64>> = Vec::with_capacity(m + 1);
    // Deterministic start: all ones on the positions, zero velocities and currents, so
    // that every mode with a displacement is excited.
    let mut v0 = vec![0.0; n];
    for (i, x) in v0.iter_mut().enumerate() {
        *x = 1.0 + (i % 7) as f64 * 0.1;
    }
    let nrm = norm(&v0);
    v0.iter_mut().for_each(|x| *x /= nrm);
    v.push(v0);
    let mut h = DMatrix::zeros(m + 1, m);
    let mut w = vec![0.0; n];
    let mut beta = 0.0;
    let mut steps = 0;
    for j in 0..m {
        op.apply(&v[j], &mut w);
        for _ in 0..2 {
            for (i, vi) in v.iter().enumerate() {
                let c: f64 = vi.iter().zip(&w).map(|(a, b)| a * b).sum();
                h[(i, j)] += c;
                w.iter_mut().zip(vi).for_each(|(x, y)| *x -= c * y);
            }
        }
        beta = norm(&w);
        h[(j + 1, j)] = beta;
        steps = j + 1;
        if beta <= 1e-14 * h.column(j).norm() {
            beta = 0.0;
            break;
        }
        v.push(w.iter().map(|x| x / beta).collect());
    }
    (h.view((0, 0), (steps, steps)).into_owned(), beta)
}

fn norm(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// A unit eigenvector of the small complex matrix `h` for its eigenvalue `t` (inverse
/// iteration, two steps, from a fixed start).
fn inverse_vector(h: &DMatrix<C64>, t: C64) -> DVector<C64> {
    let m = h.nrows();
    let shift = t + C64::new(1e-13 * t.norm().max(1e-300), 0.0);
    let a = h - DMatrix::<C64>::identity(m, m) * shift;
    let lu = a.lu();
    let mut x = DVector::from_element(m, C64::new(1.0, 0.0));
    for _ in 0..2 {
        x = lu.solve(&x).unwrap_or(x);
        let nx = x.norm();
        if nx > 0.0 {
            x /= C64::new(nx, 0.0);
        }
    }
    x
}

/// The pencil at a shift `mu` near the eigenvalue `l`, for inverse iteration. For a
/// quadratic (rational) eigenproblem repeated solves with `S(mu)` converge to the null
/// vector of the matrix `S(mu)`, which differs from the eigenvector by `O(|mu - l|)`: the
/// offset is kept at 1e-10 of `|l|` (backward errors 1e-16 measured), larger only when the
/// beam part alone is singular there (a mode with nodes at every attachment, whose
/// factorisation then fails).
pub(crate) fn pencil_near(lin: &Linearization, l: C64) -> Result<Pencil, LinearError> {
    let scale = if l.norm() > 0.0 { l.norm() } else { 1.0 };
    let mut last = None;
    for offset in [1e-10, 1e-8, 1e-6, 1e-4] {
        match Pencil::new(lin, l + C64::new(offset * scale, 0.0)) {
            Ok(p) => return Ok(p),
            Err(e) => last = Some(e),
        }
    }
    Err(last.expect("a shift was tried"))
}

/// The mode at eigenvalue estimate `l`: inverse iteration with the pencil `S(l(1+eps))`,
/// normalisation, classification and residual.
fn refine(lin: &Linearization, l: C64) -> Result<Mode, LinearError> {
    let d = lin.dim();
    let p = pencil_near(lin, l)?;
    // Start: M_R times a fixed vector (a force pattern exciting every coordinate).
    let start: Vec<f64> = (0..d).map(|i| 1.0 + (i % 5) as f64 * 0.2).collect();
    let mut t = vec![0.0; d];
    lin.mul(Matrix::Mass, &start, &mut t);
    let mut z: Vec<C64> = t.iter().map(|&x| C64::new(x, 0.0)).collect();
    for _ in 0..3 {
        p.solve_in_place(&mut z);
        let nz = z.iter().map(|x| x.norm_sqr()).sum::<f64>().sqrt();
        if nz > 0.0 && nz.is_finite() {
            z.iter_mut().for_each(|x| *x /= nz);
        }
    }
    // Normalise: the structure's largest displacement entry (or the largest entry) real
    // and 1.
    let candidates: Vec<usize> = if lin.translation_dofs().is_empty() {
        (0..d).collect()
    } else {
        lin.translation_dofs().to_vec()
    };
    let big = candidates
        .iter()
        .copied()
        .max_by(|&a, &b| z[a].norm().total_cmp(&z[b].norm()).then(b.cmp(&a)))
        .unwrap_or(0);
    let pivot = z[big];
    if pivot.norm() > 0.0 {
        z.iter_mut().for_each(|x| *x /= pivot);
    }
    let residual = residual(lin, l, &z);
    let an = l.norm();
    let scale = 1e-9 * an.max(1e-300);
    let kind = if an == 0.0 || an < 1e-12 {
        ModeKind::Rigid
    } else if l.re > scale {
        ModeKind::Unstable
    } else if l.im.abs() <= 1e-12 * an {
        ModeKind::Overdamped
    } else {
        ModeKind::Oscillatory
    };
    let (l, z) = if kind == ModeKind::Overdamped {
        (
            C64::new(l.re, 0.0),
            z.iter().map(|x| C64::new(x.re, 0.0)).collect::<Vec<_>>(),
        )
    } else {
        (l, z)
    };
    Ok(Mode {
        kind,
        eigenvalue: [l.re, l.im],
        natural_frequency_hz: an / (2.0 * std::f64::consts::PI),
        damped_frequency_hz: if kind == ModeKind::Oscillatory {
            l.im.abs() / (2.0 * std::f64::consts::PI)
        } else {
            0.0
        },
        damping_ratio: if an > 0.0 { -l.re / an } else { 0.0 },
        decay_rate: -l.re,
        shape: z.iter().map(|x| [x.re, x.im]).collect(),
        residual,
    })
}

/// The normwise backward error of the pair (Tisseur 2000): `|S(l) z|_inf / ((|K_R| +
/// |l| |C_R| + |l|^2 |M_R|) |z|_inf)`, with the electrical term in `S` and the matrix norms
/// bounded by [`Linearization::norm_bound`].
fn residual(lin: &Linearization, l: C64, z: &[C64]) -> f64 {
    let r = lin.pencil_mul(l, z);
    let inf = |v: &[C64]| v.iter().fold(0.0f64, |m, x| m.max(x.norm()));
    let scale = (lin.norm_bound(Matrix::Stiffness)
        + l.norm() * lin.norm_bound(Matrix::Damping)
        + l.norm_sqr() * lin.norm_bound(Matrix::Mass))
        * inf(z);
    if scale > 0.0 { inf(&r) / scale } else { 0.0 }
}
