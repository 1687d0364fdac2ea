//! Small dense kernels of the reduction, in place on caller-owned buffers (no allocation):
//! LU with partial pivoting for `J_v`, Cholesky for `M^R`, and the 1-norm.
//!
//! Why not `nalgebra::linalg::{LU, Cholesky}`: tried in place of these kernels (LU::new on
//! the workspace's `J_v` then `solve_mut` per inverse column; `Cholesky::new` on the
//! workspace's `M^R`, `solve_mut`, `unpack_dirty` back into the workspace), the
//! four-bar bench `closed_loop_reduce/reduce_and_solve` went from 380 ns to 572 ns
//! (+48 %) and `closed_loop_rhs/generated` from 573 ns to 697 ns (+33 %), same machine, same
//! session (`cargo bench -p hybrid-core --bench closed_loop`). Besides: `LU::new` consumes
//! the matrix and allocates its permutation sequence on every call (the per-stage hot path
//! must not allocate), and it multiplies by the reciprocal of the pivot where these kernels
//! divide, which changes results by round-off; `Cholesky::new` returns `None` without the
//! failing row and pivot that [`PartitionError::NotPositiveDefinite`] reports.

use nalgebra::{DMatrix, DVector};

use super::PartitionError;

/// Resizes a matrix buffer only when its shape differs (contents are then unspecified).
pub(super) fn resize(m: &mut DMatrix<f64>, r: usize, c: usize) {
    if m.shape() != (r, c) {
        *m = DMatrix::zeros(r, c);
    }
}

pub(super) fn resize_v(v: &mut DVector<f64>, n: usize) {
    if v.len() != n {
        *v = DVector::zeros(n);
    }
}

/// 1-norm of a matrix: the largest column sum of absolute values.
pub(super) fn norm1(a: &DMatrix<f64>) -> f64 {
    a.column_iter()
        .map(|c| c.iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// LU factorisation with partial (row) pivoting in place: `P a = L U`, unit lower `L`
/// below the diagonal, `U` on and above. Returns `false` on an exactly zero pivot.
pub(super) fn lu_in_place(a: &mut DMatrix<f64>, piv: &mut Vec<usize>) -> bool {
    let n = a.nrows();
    piv.clear();
    for k in 0..n {
        let mut p = k;
        let mut best = a[(k, k)].abs();
        for i in k + 1..n {
            if a[(i, k)].abs() > best {
                best = a[(i, k)].abs();
                p = i;
            }
        }
        piv.push(p);
        if best == 0.0 || !best.is_finite() {
            return false;
        }
        if p != k {
            a.swap_rows(k, p);
        }
        let d = a[(k, k)];
        for i in k + 1..n {
            let l = a[(i, k)] / d;
            a[(i, k)] = l;
            for j in k + 1..n {
                a[(i, j)] -= l * a[(k, j)];
            }
        }
    }
    true
}

/// Solves `A x = b` in place with the factors of [`lu_in_place`].
pub(super) fn lu_solve(lu: &DMatrix<f64>, piv: &[usize], b: &mut DVector<f64>) {
    let n = lu.nrows();
    for (k, &p) in piv.iter().enumerate() {
        if p != k {
            b.swap_rows(k, p);
        }
    }
    for i in 0..n {
        let mut s = b[i];
        for j in 0..i {
            s -= lu[(i, j)] * b[j];
        }
        b[i] = s;
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for j in i + 1..n {
            s -= lu[(i, j)] * b[j];
        }
        b[i] = s / lu[(i, i)];
    }
}

/// Cholesky factorisation in place (lower triangle; the upper one is left untouched and
/// ignored). Fails on a non-positive pivot.
pub(super) fn cholesky_in_place(a: &mut DMatrix<f64>) -> Result<(), PartitionError> {
    let n = a.nrows();
    for j in 0..n {
        let mut d = a[(j, j)];
        for k in 0..j {
            d -= a[(j, k)] * a[(j, k)];
        }
        if d.is_nan() || d <= 0.0 {
            return Err(PartitionError::NotPositiveDefinite { row: j, pivot: d });
        }
        let d = d.sqrt();
        a[(j, j)] = d;
        for i in j + 1..n {
            let mut s = a[(i, j)];
            for k in 0..j {
                s -= a[(i, k)] * a[(j, k)];
            }
            a[(i, j)] = s / d;
        }
    }
    Ok(())
}

/// Solves `L L^T x = b` in place with the factor of [`cholesky_in_place`].
pub(super) fn cholesky_solve(l: &DMatrix<f64>, b: &mut DVector<f64>) {
    let n = l.nrows();
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[(i, k)] * b[k];
        }
        b[i] = s / l[(i, i)];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[(k, i)] * b[k];
        }
        b[i] = s / l[(i, i)];
    }
}
