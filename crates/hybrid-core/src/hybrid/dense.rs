//! The kernels of a small dense structure (a Craig–Bampton reduced model, docs/theory.md
//! section 13.2) on the step's hot path: the product `y += s A x`, the quadratic form
//! `x^T A x` and the Cholesky solve `x <- (L L^T)^-1 x`, on column-major slices.
//!
//! Each inner loop runs down one contiguous column (an `axpy` or a dot product with four
//! partial sums), so that the compiler vectorises it; nalgebra's generic column iterators
//! cost about 20 instructions per matrix entry here, these about one. Only the order of
//! the additions differs from the textbook loops (results equal to rounding).

use nalgebra::{Cholesky, DMatrix};

/// `y += a x` over the common length.
#[inline]
fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

/// `x . y` with four partial sums (their order fixed: deterministic).
#[inline]
fn dot(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len().min(y.len());
    let (x, y) = (&x[..n], &y[..n]);
    let mut s = [0.0; 4];
    let (xc, yc) = (x.chunks_exact(4), y.chunks_exact(4));
    let (xr, yr) = (xc.remainder(), yc.remainder());
    for (a, b) in xc.zip(yc) {
        for k in 0..4 {
            s[k] += a[k] * b[k];
        }
    }
    let tail: f64 = xr.iter().zip(yr).map(|(a, b)| a * b).sum();
    (s[0] + s[2]) + (s[1] + s[3]) + tail
}

/// `y += s A x` for a dense square `A` (column-major): one `axpy` per column.
pub(crate) fn mul_add(a: &DMatrix<f64>, s: f64, x: &[f64], y: &mut [f64]) {
    let n = a.nrows();
    if n == 0 {
        return;
    }
    for (col, &xj) in a.as_slice().chunks_exact(n).zip(x) {
        axpy(s * xj, col, y);
    }
}

/// `x^T A x` for a dense square `A` (column-major): `sum_j x_j (a_j . x)`.
pub(crate) fn quadratic(a: &DMatrix<f64>, x: &[f64]) -> f64 {
    let n = a.nrows();
    if n == 0 {
        return 0.0;
    }
    a.as_slice()
        .chunks_exact(n)
        .zip(x)
        .map(|(col, &xj)| xj * dot(col, x))
        .sum()
}

/// A dense Cholesky factor `K = L L^T` of a symmetric positive definite matrix, with `L`'s
/// columns contiguous below the diagonal and the diagonal's reciprocals, solved in place
/// by its `solve_in_place` (the reduced model's Newmark solve).
#[derive(Clone, Debug)]
pub struct DenseCholesky {
    /// `L`, column-major (entries above the diagonal zero).
    l: DMatrix<f64>,
    /// `1 / L_jj`.
    inv_diag: Vec<f64>,
}

impl DenseCholesky {
    /// Factorises `k` (nalgebra's Cholesky); `None` when it is not positive definite.
    pub(crate) fn new(k: DMatrix<f64>) -> Option<DenseCholesky> {
        let l = Cholesky::new(k)?.l();
        let inv_diag = l.diagonal().iter().map(|d| 1.0 / d).collect();
        Some(DenseCholesky { l, inv_diag })
    }

    /// `x <- K^-1 x`: the forward solve `L y = x` column by column (an `axpy` down each
    /// column), then `L^T x = y` from the last row up (a dot product with each column).
    pub(crate) fn solve_in_place(&self, x: &mut [f64]) {
        let n = self.inv_diag.len();
        if n == 0 {
            return;
        }
        let l = self.l.as_slice();
        for j in 0..n {
            let xj = x[j] * self.inv_diag[j];
            x[j] = xj;
            let (_, below) = x.split_at_mut(j + 1);
            axpy(-xj, &l[j * n + j + 1..(j + 1) * n], below);
        }
        for j in (0..n).rev() {
            let s = dot(&l[j * n + j + 1..(j + 1) * n], &x[j + 1..]);
            x[j] = (x[j] - s) * self.inv_diag[j];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DVector;

    /// A symmetric positive definite test matrix of size `n` (diagonally dominant).
    fn spd(n: usize) -> DMatrix<f64> {
        let b = DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 3) as f64 * 0.37).sin());
        &b * b.transpose() + DMatrix::identity(n, n) * n as f64
    }

    /// The kernels against nalgebra's own products and solve (an independent
    /// implementation), for sizes around the four-wide chunks: equal to `n eps` of the
    /// scale.
    #[test]
    fn kernels_match_nalgebra() {
        for n in [0, 1, 2, 3, 4, 5, 7, 8, 9, 34] {
            let a = spd(n);
            let x: Vec<f64> = (0..n).map(|i| (i as f64 * 1.3).cos() - 0.2).collect();
            let xv = DVector::from_column_slice(&x);
            let scale = a.amax().max(1.0) * xv.amax().max(1.0) * n.max(1) as f64;
            let tol = 8.0 * n.max(1) as f64 * f64::EPSILON * scale;

            let mut y: Vec<f64> = (0..n).map(|i| i as f64).collect();
            mul_add(&a, -0.5, &x, &mut y);
            let want = DVector::from_fn(n, |i, _| i as f64) - &a * &xv * 0.5;
            for (u, v) in y.iter().zip(want.iter()) {
                assert!((u - v).abs() <= tol, "n = {n}: {u} vs {v}");
            }

            let q = quadratic(&a, &x);
            let want = xv.dot(&(&a * &xv));
            assert!(
                (q - want).abs() <= tol * xv.amax().max(1.0),
                "n = {n}: {q} vs {want}"
            );

            let f = DenseCholesky::new(a.clone()).unwrap();
            let mut s = x.clone();
            f.solve_in_place(&mut s);
            let want = a.clone().cholesky().unwrap().solve(&xv);
            let big = want.amax().max(f64::MIN_POSITIVE);
            for (u, v) in s.iter().zip(want.iter()) {
                assert!((u - v).abs() <= 1e-13 * big, "n = {n}: {u} vs {v}");
            }
        }
    }

    /// An indefinite matrix has no factor.
    #[test]
    fn an_indefinite_matrix_is_refused() {
        let mut a = spd(5);
        a[(2, 2)] = -100.0;
        assert!(DenseCholesky::new(a).is_none());
    }
}
