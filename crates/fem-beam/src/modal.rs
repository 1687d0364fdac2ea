//! Modal analysis: the lowest eigenpairs of `C phi = omega^2 A phi` (reduced stiffness `C`
//! and mass `A` of eq. 44), mode shapes normalised to unit modal mass (`phi^T A phi = 1`).
//!
//! Both methods work with the shift-and-invert operator `(C + s A)^-1 A`, whose largest
//! eigenvalues `1 / (omega^2 + s)` are the wanted ones. Its norm is `1 / (omega_1^2 + s)`, so
//! the low frequencies come out with nearly full relative precision, whereas working with `C`
//! directly would give them an absolute error `eps * omega_max^2` (the beam's stiffness is
//! badly conditioned, `omega_max^2 / omega_1^2 ~ n^4`).
//!
//! - Dense (small problems, and the reference in tests): Cholesky `C + s A = L L^T`, full
//!   symmetric eigen-decomposition of `L^-1 A L^-T` with nalgebra.
//! - Subspace iteration (Bathe) with Rayleigh–Ritz on the banded factorisation: `O(n p^2)`
//!   per iteration for `p = max(2k, k + 8)` vectors; the iteration stops when every wanted
//!   Ritz vector satisfies `|| nu S^-1 A x - x ||_A <= 1e-10` (`nu = omega^2 + s`). Once
//!   close, the solves are refined with the element-wise stiffness residual
//!   (`BeamModel::stiffness_residual_into`): a plain solve of the ill-conditioned beam
//!   stiffness would carry a relative error ~ `n^3 eps` into the Ritz values (7e-7 on the
//!   first mode of a 2,000-element cantilever; refined: 1e-15).
//!
//! Rigid-body modes (a beam whose supports leave it free to translate or rotate) are known
//! in closed form: the stiffness of a continuous beam with positive `E J` vanishes exactly on
//! rigid motions `w = a + b x`, `theta = b`. They are taken as exact (frequency 0, mass-
//! orthonormalised) and the elastic modes are computed in their `A`-orthogonal complement;
//! the shift `s > 0` then keeps `C + s A` positive definite.

use nalgebra::{DMatrix, SymmetricEigen};

use crate::banded::BandedSym;
use crate::error::{BeamError, LinalgError};

/// How [`crate::BeamModel::modes_with`] computes the modes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ModalMethod {
    /// Dense up to [`DENSE_LIMIT`] free DOFs, subspace iteration above.
    #[default]
    Auto,
    /// Dense generalised eigen-decomposition (`O(n^3)`: small problems only).
    Dense,
    /// Subspace iteration on the banded factorisation.
    Subspace,
}

/// Largest number of free DOFs for which [`ModalMethod::Auto`] uses the dense method.
///
/// The dense method works with the rounded assembled matrices, whose relative error in the
/// low eigenvalues grows like `n^3 eps`: about 1e-11 at this size.
pub const DENSE_LIMIT: usize = 100;

/// Convergence tolerance of the subspace iteration (A-norm residual of the inverse
/// iteration for a unit-modal-mass vector). Eigenvalues are then exact to ~tol^2, i.e. to
/// rounding.
const SUBSPACE_TOL: f64 = 1e-10;
const MAX_ITERATIONS: usize = 300;

/// The lowest natural modes of a beam model.
#[derive(Clone, Debug, PartialEq)]
pub struct Modes {
    n: usize,
    eigenvalues: Vec<f64>,
    shapes: Vec<f64>,
    rigid: usize,
    iterations: usize,
}

impl Modes {
    /// Number of modes.
    pub fn len(&self) -> usize {
        self.eigenvalues.len()
    }

    /// True when there are no modes.
    pub fn is_empty(&self) -> bool {
        self.eigenvalues.is_empty()
    }

    /// The eigenvalues `omega^2`, rad^2/s^2, ascending (exactly 0 for rigid-body modes).
    pub fn eigenvalues(&self) -> &[f64] {
        &self.eigenvalues
    }

    /// Angular frequencies `omega`, rad/s.
    pub fn angular_frequencies(&self) -> Vec<f64> {
        self.eigenvalues
            .iter()
            .map(|&l| l.max(0.0).sqrt())
            .collect()
    }

    /// Natural frequencies `omega / (2 pi)`, Hz.
    pub fn frequencies_hz(&self) -> Vec<f64> {
        self.eigenvalues
            .iter()
            .map(|&l| l.max(0.0).sqrt() / (2.0 * std::f64::consts::PI))
            .collect()
    }

    /// Mode shape `i` (0-based) over the free DOFs (reduced ordering), with unit modal
    /// mass. Sign: its largest component is positive.
    ///
    /// # Panics
    /// If `i >= len()`.
    pub fn shape(&self, i: usize) -> &[f64] {
        &self.shapes[i * self.n..(i + 1) * self.n]
    }

    /// Number of rigid-body modes among them (listed first).
    pub fn rigid_body_count(&self) -> usize {
        self.rigid
    }

    /// Subspace iterations used (0 for the dense method).
    pub fn iterations(&self) -> usize {
        self.iterations
    }
}

/// `residual(x, b, r)`: `r = b - S x` for the shifted stiffness `S = C + s A`, computed
/// accurately (see `BeamModel::stiffness_residual_into`).
pub(crate) type Residual<'a> = &'a dyn Fn(&[f64], &[f64], &mut [f64]);

/// Shifted eigenvalues `nu = omega^2 + s` and unit-modal-mass vectors of elastic modes.
type ElasticModes = (Vec<f64>, Vec<Vec<f64>>);

/// Orthonormalises `vectors` in the `A` inner product (modified Gram–Schmidt, twice for
/// safety).
pub(crate) fn a_orthonormalise(mass: &BandedSym, vectors: &mut [Vec<f64>]) {
    let mut av = vec![0.0; mass.size()];
    for _ in 0..2 {
        for i in 0..vectors.len() {
            for j in 0..i {
                mass.mul_vec_into(&vectors[j], &mut av);
                let c = dot(&vectors[i], &av);
                let (head, tail) = vectors.split_at_mut(i);
                axpy(-c, &head[j], &mut tail[0]);
            }
            let norm = mass.quadratic_form(&vectors[i]).sqrt();
            vectors[i].iter_mut().for_each(|v| *v /= norm);
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

/// Makes the largest-magnitude component positive (deterministic signs).
fn fix_sign(v: &mut [f64]) {
    let mut best = 0.0f64;
    let mut sign = 1.0;
    for &x in v.iter() {
        // Ties within rounding go to the first component.
        if x.abs() > best * (1.0 + 1e-9) {
            best = x.abs();
            sign = x.signum();
        }
    }
    if sign < 0.0 {
        v.iter_mut().for_each(|x| *x = -*x);
    }
}

/// Lowest `k` modes. `rigid` holds the rigid-body modes (reduced, `A`-orthonormal);
/// `shift > 0` is required when there are any.
pub(crate) fn lowest_modes(
    mass: &BandedSym,
    stiffness: &BandedSym,
    rigid: &[Vec<f64>],
    k: usize,
    method: ModalMethod,
    shift: f64,
    reverse: Option<&[usize]>,
    residual: Residual<'_>,
) -> Result<Modes, BeamError> {
    let n = mass.size();
    if k == 0 || k > n {
        return Err(BeamError::ModeCount {
            requested: k,
            available: n,
        });
    }
    let r = rigid.len().min(k);
    let m = k - r;
    let mut eigenvalues = vec![0.0; r];
    let mut shapes: Vec<f64> = Vec::with_capacity(n * k);
    for v in &rigid[..r] {
        shapes.extend_from_slice(v);
    }
    let mut iterations = 0;
    if m > 0 {
        let use_dense = match method {
            ModalMethod::Dense => true,
            ModalMethod::Subspace => false,
            ModalMethod::Auto => n <= DENSE_LIMIT,
        };
        let mut s = stiffness.clone();
        s.scaled_add(shift, mass)?;
        let (vals, vecs) = if use_dense {
            dense_elastic(mass, &s, rigid.len(), m)?
        } else {
            let ((vals, vecs), its) = subspace_elastic(mass, &s, rigid, m, reverse, residual)?;
            iterations = its;
            (vals, vecs)
        };
        for (nu, mut v) in vals.into_iter().zip(vecs) {
            eigenvalues.push((nu - shift).max(0.0));
            fix_sign(&mut v);
            shapes.extend_from_slice(&v);
        }
    }
    for i in 0..r {
        fix_sign(&mut shapes[i * n..(i + 1) * n]);
    }
    Ok(Modes {
        n,
        eigenvalues,
        shapes,
        rigid: r,
        iterations,
    })
}

/// Dense: eigenpairs of `L^-1 A L^-T` with `S = C + s A = L L^T`; returns the `m` smallest
/// shifted eigenvalues `nu = omega^2 + s` above the `n_rigid` rigid ones, and their
/// unit-modal-mass vectors.
///
/// The symmetric eigen-decomposition of a dense matrix by nalgebra's implicit QR, with at
/// most `30 max(10, n)` sweeps (LAPACK `dsteqr`'s cap; `SymmetricEigen::new` has none and
/// never converges on a NaN), after refusing a non-finite entry. The sweeps and their
/// deflation test are those of `SymmetricEigen::new`.
fn symmetric_eigen(m: DMatrix<f64>) -> Result<SymmetricEigen<f64, nalgebra::Dyn>, BeamError> {
    let n = m.nrows();
    if let Some(i) = m.iter().position(|v| !v.is_finite()) {
        return Err(LinalgError::NotFinite {
            row: i % n,
            column: i / n,
            value: m[i],
        }
        .into());
    }
    let cap = 30 * n.max(10);
    SymmetricEigen::try_new(m, f64::EPSILON, cap).ok_or(BeamError::EigenNotConverged {
        iterations: cap,
        size: n,
    })
}

fn dense_elastic(
    mass: &BandedSym,
    s: &BandedSym,
    n_rigid: usize,
    m: usize,
) -> Result<(Vec<f64>, Vec<Vec<f64>>), BeamError> {
    // The banded factorisation reports a failing pivot with its index; nalgebra's Cholesky
    // would only say "no".
    s.factorize()?;
    let n = mass.size();
    let chol = nalgebra::Cholesky::new(s.to_dense()).ok_or(LinalgError::NotPositiveDefinite {
        index: 0,
        pivot: f64::NAN,
    })?;
    let l = chol.l();
    let a = mass.to_dense();
    let not_pd = LinalgError::NotPositiveDefinite {
        index: 0,
        pivot: f64::NAN,
    };
    let w = l.solve_lower_triangular(&a).ok_or(not_pd)?;
    let b = l.solve_lower_triangular(&w.transpose()).ok_or(not_pd)?;
    let b = (&b + b.transpose()) * 0.5;
    let eig = symmetric_eigen(b)?;
    let mut order: Vec<usize> = (0..n).collect();
    // Largest mu = 1 / nu first.
    order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
    let lt = l.transpose();
    let mut vals = Vec::with_capacity(m);
    let mut vecs = Vec::with_capacity(m);
    for &i in order.iter().skip(n_rigid).take(m) {
        let mu = eig.eigenvalues[i];
        let y = eig.eigenvectors.column(i).into_owned();
        let phi = lt.solve_upper_triangular(&y).ok_or(not_pd)? / mu.sqrt();
        vals.push(1.0 / mu);
        vecs.push(phi.as_slice().to_vec());
    }
    Ok((vals, vecs))
}

/// Deterministic pseudo-random numbers in [-1, 1) (xorshift64*), for start vectors.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let v = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        (v >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// Removes the rigid-body components of `v` (A-orthogonal projection); `ar[i] = A r_i`.
fn deflate(v: &mut [f64], rigid: &[Vec<f64>], ar: &[Vec<f64>]) {
    for (ri, ari) in rigid.iter().zip(ar) {
        let c = dot(ari, v);
        axpy(-c, ri, v);
    }
}

/// Subspace iteration with Rayleigh–Ritz (Bathe, "Finite Element Procedures", 11.6).
///
/// Blocks of `p` vectors are stored as `n x p` column-major matrices, so the projections
/// `X^T Y` and the update `X Q` are matrix products.
fn subspace_elastic(
    mass: &BandedSym,
    s: &BandedSym,
    rigid: &[Vec<f64>],
    m: usize,
    reverse: Option<&[usize]>,
    residual: Residual<'_>,
) -> Result<(ElasticModes, usize), BeamError> {
    let n = mass.size();
    let nf = n - rigid.len();
    if m > nf {
        return Err(BeamError::ModeCount {
            requested: m + rigid.len(),
            available: n,
        });
    }
    let p = nf.min((2 * m).max(m + 8));
    // Elimination order chosen by the model (see `BeamModel::factorize`).
    let factor = match reverse {
        Some(groups) => s.factorize_reversed(groups)?,
        None => s.factorize()?,
    };
    let ar: Vec<Vec<f64>> = rigid
        .iter()
        .map(|r| {
            let mut v = vec![0.0; n];
            mass.mul_vec_into(r, &mut v);
            v
        })
        .collect();
    let not_pd = LinalgError::NotPositiveDefinite {
        index: 0,
        pivot: f64::NAN,
    };

    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut x = DMatrix::<f64>::from_fn(n, p, |_, _| rng.next());
    for col in x.as_mut_slice().chunks_mut(n) {
        deflate(col, rigid, &ar);
    }
    let mut y = DMatrix::<f64>::zeros(n, p);
    let mut xb = DMatrix::<f64>::zeros(n, p);
    let mut yb = DMatrix::<f64>::zeros(n, p);
    let mut nu = vec![0.0; p];
    let mut last_residual = f64::INFINITY;
    let mut last_refined_residual = f64::INFINITY;
    let mut work = vec![0.0; n];
    // Plain solves while the subspace is far from converged, refined ones (with the exact
    // element-wise residual, see `BeamModel::stiffness_residual_into`) for the last
    // iterations: a plain solve carries a relative error ~ n^3 eps into the Ritz values
    // (7e-7 on the first mode of a 2,000-element cantilever).
    let mut refine = false;

    for it in 1..=MAX_ITERATIONS {
        let refined_now = refine;
        for (((xc, yc), xbc), ybc) in x
            .as_slice()
            .chunks(n)
            .zip(y.as_mut_slice().chunks_mut(n))
            .zip(xb.as_mut_slice().chunks_mut(n))
            .zip(yb.as_mut_slice().chunks_mut(n))
        {
            mass.mul_vec_into(xc, yc);
            if refined_now {
                factor.refine_with(yc, xbc, &mut work, residual);
            } else {
                xbc.copy_from_slice(yc);
                factor.solve_in_place(xbc);
            }
            deflate(xbc, rigid, &ar);
            mass.mul_vec_into(xbc, ybc);
        }
        // Residual of the previous Ritz pairs: || nu x_bar - x ||_A, with A d = nu y_bar - y.
        let mut converged = false;
        if it > 1 {
            let mut worst = 0.0f64;
            for i in 0..m {
                let (xc, yc) = (&x.as_slice()[i * n..][..n], &y.as_slice()[i * n..][..n]);
                let (xbc, ybc) = (&xb.as_slice()[i * n..][..n], &yb.as_slice()[i * n..][..n]);
                let mut r2 = 0.0;
                for t in 0..n {
                    r2 += (nu[i] * xbc[t] - xc[t]) * (nu[i] * ybc[t] - yc[t]);
                }
                worst = worst.max(r2.abs().sqrt());
            }
            if refined_now {
                // Converged, or stuck at the rounding floor (no longer improving).
                converged = worst <= SUBSPACE_TOL
                    || (worst <= 1e-6 && worst >= 0.9 * last_refined_residual);
                last_refined_residual = worst;
            } else if worst <= 1e-6 || worst >= 0.5 * last_residual {
                // Close, or plain solves no longer improve: switch to refined solves.
                refine = true;
            }
            last_residual = worst;
        }

        // Rayleigh–Ritz on span(X_bar) with columns scaled to unit A-norm (X_bar, Y_bar and
        // Y scaled alike): K_r = X^T S X = X^T Y (S X_bar = Y; the deflation keeps this, as
        // X_bar is A-orthogonal to the rigid modes), M_r = X^T A X.
        for j in 0..p {
            let c = 1.0 / xb.column(j).dot(&yb.column(j)).sqrt();
            xb.column_mut(j).scale_mut(c);
            yb.column_mut(j).scale_mut(c);
            y.column_mut(j).scale_mut(c);
        }
        // X^T as a p x n matrix so the products are GEMMs (nalgebra's `tr_mul` is a loop of
        // dot products, several times slower here).
        let xbt = xb.transpose();
        let kr = &xbt * &y;
        let kr = (&kr + kr.transpose()) * 0.5;
        let mr = &xbt * &yb;
        let mr = (&mr + mr.transpose()) * 0.5;
        let l = nalgebra::Cholesky::new(mr).ok_or(not_pd)?.l();
        let w = l.solve_lower_triangular(&kr).ok_or(not_pd)?;
        let g = l.solve_lower_triangular(&w.transpose()).ok_or(not_pd)?;
        let g = (&g + g.transpose()) * 0.5;
        let eig = symmetric_eigen(g)?;
        let mut order: Vec<usize> = (0..p).collect();
        order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
        let q = l
            .transpose()
            .solve_upper_triangular(&eig.eigenvectors)
            .ok_or(not_pd)?;
        // X = X_bar Q, columns in ascending Ritz value.
        let q_sorted = DMatrix::from_fn(p, p, |i, c| q[(i, order[c])]);
        xb.mul_to(&q_sorted, &mut x);
        for (c, &oi) in order.iter().enumerate() {
            nu[c] = eig.eigenvalues[oi];
        }
        if converged || (p == nf && refined_now) {
            let vals = nu[..m].to_vec();
            let vecs = x
                .as_slice()
                .chunks(n)
                .take(m)
                .map(<[f64]>::to_vec)
                .collect();
            return Ok(((vals, vecs), it));
        }
    }
    Err(BeamError::NotConverged {
        iterations: MAX_ITERATIONS,
        residual: last_residual.min(last_refined_residual),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rng_is_uniform_in_range() {
        let mut r = Rng(1);
        let v: Vec<f64> = (0..1000).map(|_| r.next()).collect();
        assert!(v.iter().all(|&x| (-1.0..1.0).contains(&x)));
        let mean = v.iter().sum::<f64>() / 1000.0;
        assert!(mean.abs() < 0.1);
    }

    #[test]
    fn sign_is_fixed_by_the_largest_component() {
        let mut v = vec![0.1, -0.5, 0.3];
        fix_sign(&mut v);
        assert_eq!(v, vec![-0.1, 0.5, -0.3]);
    }

    #[test]
    fn diagonal_problem_both_methods() {
        // C = diag(1..=40), A = I: eigenvalues 1..=40, eigenvectors unit vectors.
        let n = 40;
        let mut c = BandedSym::zeros(n, 1);
        let mut a = BandedSym::zeros(n, 1);
        for i in 0..n {
            c.set(i, i, (n - i) as f64);
            a.set(i, i, 1.0);
        }
        let res = |x: &[f64], b: &[f64], r: &mut [f64]| c.residual_into(x, b, r);
        for method in [ModalMethod::Dense, ModalMethod::Subspace] {
            let modes = lowest_modes(&a, &c, &[], 5, method, 0.0, None, &res).unwrap();
            for i in 0..5 {
                assert!(
                    (modes.eigenvalues()[i] - (i + 1) as f64).abs() < 1e-12,
                    "{method:?} {i}"
                );
                assert!(
                    (modes.shape(i)[n - 1 - i] - 1.0).abs() < 1e-9,
                    "{method:?} {i}"
                );
            }
        }
        assert!(matches!(
            lowest_modes(&a, &c, &[], 0, ModalMethod::Auto, 0.0, None, &res),
            Err(BeamError::ModeCount { .. })
        ));
        assert!(matches!(
            lowest_modes(&a, &c, &[], 41, ModalMethod::Auto, 0.0, None, &res),
            Err(BeamError::ModeCount { .. })
        ));
    }
}
