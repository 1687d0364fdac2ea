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
pub(crate) fn resize(m: &mut DMatrix<f64>, r: usize, c: usize) {
    if m.shape() != (r, c) {
        *m = DMatrix::zeros(r, c);
    }
}

pub(crate) fn resize_v(v: &mut DVector<f64>, n: usize) {
    if v.len() != n {
        *v = DVector::zeros(n);
    }
}

/// `dst.copy_from_slice(src)` for the short vectors of the step's hot path (a mechanism's
/// constraint rows, a column of `J_d`, a whole 2 x 2 `J_d`, its coordinates): up to four
/// entries one by one,
/// longer ones through the library copy. A copy of one or two numbers through libc's
/// `memcpy` (what `copy_from_slice` of a length unknown at compile time becomes) costs
/// several times the copy itself. The same values either way. Panics like
/// `copy_from_slice` when the lengths differ.
#[inline(always)]
pub(crate) fn copy_short(dst: &mut [f64], src: &[f64]) {
    match (dst, src) {
        ([], []) => {}
        ([d0], [s0]) => *d0 = *s0,
        ([d0, d1], [s0, s1]) => {
            *d0 = *s0;
            *d1 = *s1;
        }
        ([d0, d1, d2], [s0, s1, s2]) => {
            *d0 = *s0;
            *d1 = *s1;
            *d2 = *s2;
        }
        ([d0, d1, d2, d3], [s0, s1, s2, s3]) => {
            *d0 = *s0;
            *d1 = *s1;
            *d2 = *s2;
            *d3 = *s3;
        }
        (d, s) => d.copy_from_slice(s),
    }
}

/// `dst.fill(0.0)` for the short vectors of the step's hot path, without libc's `memset`
/// for up to three entries (see [`copy_short`]).
#[inline(always)]
pub(crate) fn zero_short(dst: &mut [f64]) {
    match dst {
        [] => {}
        [d0] => *d0 = 0.0,
        [d0, d1] => {
            *d0 = 0.0;
            *d1 = 0.0;
        }
        [d0, d1, d2] => {
            *d0 = 0.0;
            *d1 = 0.0;
            *d2 = 0.0;
        }
        d => d.fill(0.0),
    }
}

/// 1-norm of a matrix: the largest column sum of absolute values.
pub(crate) fn norm1(a: &DMatrix<f64>) -> f64 {
    a.column_iter()
        .map(|c| c.iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// LU factorisation with partial (row) pivoting in place: `P a = L U`, unit lower `L`
/// below the diagonal, `U` on and above. Returns `false` on an exactly zero pivot. Inlined:
/// the 1 x 1 and 2 x 2 paths of the step's hot path cost fewer instructions than a call.
#[inline(always)]
pub(crate) fn lu_in_place(a: &mut DMatrix<f64>, piv: &mut Vec<usize>) -> bool {
    let n = a.nrows();
    piv.clear();
    if n <= 2 && a.ncols() == n {
        return lu_small(a.as_mut_slice(), piv);
    }
    lu_general(a, piv)
}

/// The loops of [`lu_in_place`] for any size (`piv` empty on entry).
fn lu_general(a: &mut DMatrix<f64>, piv: &mut Vec<usize>) -> bool {
    let n = a.nrows();
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

/// [`lu_in_place`] written out for the 1 x 1 and 2 x 2 blocks of the step's hot path
/// (`J_d` of a double bar pinned to the beam, the scalar Jacobian of its quasi-Newton
/// iteration) on the column-major storage `a` of a square matrix (0, 1 or 4 entries): the
/// same comparisons and operations in the same order as the general loops (so the same
/// factors bit for bit), without their index arithmetic and bounds checks. `piv` is empty
/// on entry.
#[inline(always)]
pub(crate) fn lu_small(a: &mut [f64], piv: &mut Vec<usize>) -> bool {
    let ok = |best: f64| best != 0.0 && best.is_finite();
    match a {
        [a0] => {
            piv.push(0);
            ok(a0.abs())
        }
        [a0, a1, a2, a3] => {
            // Column 0: the pivot row, then the elimination of row 1.
            let (mut p, mut best) = (0, a0.abs());
            if a1.abs() > best {
                best = a1.abs();
                p = 1;
            }
            piv.push(p);
            if !ok(best) {
                return false;
            }
            if p != 0 {
                std::mem::swap(a0, a1);
                std::mem::swap(a2, a3);
            }
            let l = *a1 / *a0;
            *a1 = l;
            *a3 -= l * *a2;
            // Column 1: its only candidate pivot.
            piv.push(1);
            ok(a3.abs())
        }
        // 0 x 0 (nothing to factor).
        _ => true,
    }
}

/// Solves `A x = b` in place with the factors of [`lu_in_place`]. Inlined: its 1 x 1 and
/// 2 x 2 paths are a few operations, fewer than a call's own instructions.
#[inline(always)]
pub(crate) fn lu_solve(lu: &DMatrix<f64>, piv: &[usize], b: &mut DVector<f64>) {
    if !lu_solve_small(lu.as_slice(), piv, b.as_mut_slice()) {
        lu_solve_sweeps(lu, piv, b);
    }
}

/// The 1 x 1 and 2 x 2 paths of [`lu_solve`] on the column-major factors `lu` (1 or 4
/// entries) and `b`: `false`, with nothing done, for any other size. On slices cut to a
/// length known at compile time the size test folds away.
#[inline(always)]
pub(crate) fn lu_solve_small(lu: &[f64], piv: &[usize], b: &mut [f64]) -> bool {
    match (lu, piv, b) {
        // The sweeps below for one unknown: `x = b / u`.
        (&[u], _, [x]) => *x /= u,
        // The general sweeps below written out for the 2 x 2 blocks of the damper's hot
        // path (the same operations in the same order: the same results bit for bit).
        (&[a0, a1, a2, a3], &[p0, _], [x0, x1]) => {
            let mut x = [*x0, *x1];
            solve_2x2(&[a0, a1, a2, a3], p0, &mut x);
            [*x0, *x1] = x;
        }
        _ => return false,
    }
    true
}

/// [`lu_solve_small`]'s 2 x 2 path on arrays: `b = A^-1 b` with the column-major factors
/// `lu` of [`lu_small`] and the pivot row `p0` of its first column (the second is 1).
#[inline(always)]
pub(crate) fn solve_2x2(lu: &[f64; 4], p0: usize, b: &mut [f64; 2]) {
    let [a0, a1, a2, a3] = *lu;
    let [x0, x1] = b;
    if p0 != 0 {
        std::mem::swap(x0, x1);
    }
    *x1 -= a1 * *x0;
    *x1 /= a3;
    *x0 = (*x0 - a2 * *x1) / a0;
}

/// [`lu_solve_transpose_small`]'s 2 x 2 path on arrays: `b = A^-T b` (see [`solve_2x2`]).
#[inline(always)]
pub(crate) fn solve_transpose_2x2(lu: &[f64; 4], p0: usize, b: &mut [f64; 2]) {
    let [a0, a1, a2, a3] = *lu;
    let [x0, x1] = b;
    *x0 /= a0;
    *x1 = (*x1 - a2 * *x0) / a3;
    *x0 -= a1 * *x1;
    if p0 != 0 {
        std::mem::swap(x0, x1);
    }
}

/// The forward and backward sweeps of [`lu_solve`] for any size.
fn lu_solve_sweeps(lu: &DMatrix<f64>, piv: &[usize], b: &mut DVector<f64>) {
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
pub(crate) fn cholesky_in_place(a: &mut DMatrix<f64>) -> Result<(), PartitionError> {
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
pub(crate) fn cholesky_solve(l: &DMatrix<f64>, b: &mut DVector<f64>) {
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

/// Solves `A^T x = b` in place with the factors of [`lu_in_place`] (`P A = L U`, so
/// `A^T = U^T L^T P`). Inlined like [`lu_solve`].
#[inline(always)]
pub(crate) fn lu_solve_transpose(lu: &DMatrix<f64>, piv: &[usize], b: &mut DVector<f64>) {
    if !lu_solve_transpose_small(lu.as_slice(), piv, b.as_mut_slice()) {
        lu_solve_transpose_sweeps(lu, piv, b);
    }
}

/// The 2 x 2 path of [`lu_solve_transpose`] (`lu` of 4 entries, column-major): `false`,
/// with nothing done, for any other size (see [`lu_solve_small`]).
#[inline(always)]
pub(crate) fn lu_solve_transpose_small(lu: &[f64], piv: &[usize], b: &mut [f64]) -> bool {
    if let (&[a0, a1, a2, a3], &[p0, _], [x0, x1]) = (lu, piv, b) {
        // Written out for 2 x 2 (same operations, same order as the sweeps below).
        let mut x = [*x0, *x1];
        solve_transpose_2x2(&[a0, a1, a2, a3], p0, &mut x);
        [*x0, *x1] = x;
        return true;
    }
    false
}

/// The sweeps of [`lu_solve_transpose`] for any size.
fn lu_solve_transpose_sweeps(lu: &DMatrix<f64>, piv: &[usize], b: &mut DVector<f64>) {
    let n = lu.nrows();
    for i in 0..n {
        let mut s = b[i];
        for j in 0..i {
            s -= lu[(j, i)] * b[j];
        }
        b[i] = s / lu[(i, i)];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for j in i + 1..n {
            s -= lu[(j, i)] * b[j];
        }
        b[i] = s;
    }
    for (k, &p) in piv.iter().enumerate().rev() {
        if p != k {
            b.swap_rows(k, p);
        }
    }
}

/// [`singular_range`] of a 2 x 2 matrix given column-major (`[a00, a10, a01, a11]`), in
/// closed form: `s_max^2 + s_min^2 = |a|_F^2`, `s_max s_min = |det a|`. The one place these
/// operations are written: [`singular_range`]'s 2 x 2 case and the follower's condition
/// measurement of a 2 x 2 `J_d` (no copy into a matrix buffer) give the same numbers.
#[inline(always)]
pub(crate) fn singular_range_2(a: [f64; 4]) -> (f64, f64) {
    let [a00, a10, a01, a11] = a;
    let fro2 = a.iter().map(|x| x * x).sum::<f64>();
    let d = (a00 * a11 - a01 * a10).abs();
    let disc = (fro2 * fro2 - 4.0 * d * d).max(0.0).sqrt();
    let smax = ((fro2 + disc) / 2.0).sqrt();
    let smin = if smax > 0.0 { d / smax } else { 0.0 };
    (smin, smax)
}

/// Extreme singular values `(smallest, largest)` of the square matrix `a`, from the
/// eigenvalues of `a^T a` by cyclic Jacobi rotations in the caller's buffer `w` (no
/// allocation once `w` has the shape; closed forms for sizes 1 and 2).
pub(crate) fn singular_range(a: &DMatrix<f64>, w: &mut DMatrix<f64>) -> (f64, f64) {
    let n = a.nrows();
    match n {
        0 => return (0.0, 0.0),
        1 => return (a[(0, 0)].abs(), a[(0, 0)].abs()),
        2 => {
            let s = a.as_slice();
            return singular_range_2([s[0], s[1], s[2], s[3]]);
        }
        _ => {}
    }
    resize(w, n, n);
    a.tr_mul_to(a, w);
    for _sweep in 0..30 {
        let mut off = 0.0;
        for p in 0..n {
            for q in p + 1..n {
                off += w[(p, q)] * w[(p, q)];
            }
        }
        let diag = (0..n).map(|i| w[(i, i)] * w[(i, i)]).sum::<f64>();
        if off <= 1e-30 * diag {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = w[(p, q)];
                if apq == 0.0 {
                    continue;
                }
                let theta = (w[(q, q)] - w[(p, p)]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (wkp, wkq) = (w[(k, p)], w[(k, q)]);
                    w[(k, p)] = c * wkp - s * wkq;
                    w[(k, q)] = s * wkp + c * wkq;
                }
                for k in 0..n {
                    let (wpk, wqk) = (w[(p, k)], w[(q, k)]);
                    w[(p, k)] = c * wpk - s * wqk;
                    w[(q, k)] = s * wpk + c * wqk;
                }
            }
        }
    }
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for i in 0..n {
        let e = w[(i, i)].max(0.0).sqrt();
        lo = lo.min(e);
        hi = hi.max(e);
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_short_copy_and_zero_equal_the_library_ones_at_every_length() {
        for n in 0..7 {
            let src: Vec<f64> = (0..n).map(|i| -1.5 * i as f64 + 0.25).collect();
            let (mut a, mut b) = (vec![f64::NAN; n], vec![f64::NAN; n]);
            copy_short(&mut a, &src);
            b.copy_from_slice(&src);
            assert_eq!(a, b, "copy, n = {n}");
            zero_short(&mut a);
            assert!(a.iter().all(|x| x.to_bits() == 0), "zero, n = {n}: {a:?}");
        }
    }

    #[test]
    fn the_two_by_two_solves_equal_the_general_sweeps_bit_for_bit() {
        let mut rng = mbs_symbolic::samples::SplitMix64::new(7);
        for _ in 0..200 {
            let a = DMatrix::from_fn(2, 2, |_, _| rng.symmetric(2.0));
            let b = DVector::from_fn(2, |_, _| rng.symmetric(1.0));
            let mut lu = a.clone();
            let mut piv = Vec::new();
            if !lu_in_place(&mut lu, &mut piv) {
                continue;
            }
            let (mut x, mut y) = (b.clone(), b.clone());
            lu_solve(&lu, &piv, &mut x);
            lu_solve_transpose(&lu, &piv, &mut y);
            let (mut gx, mut gy) = (b.clone(), b.clone());
            lu_solve_sweeps(&lu, &piv, &mut gx);
            lu_solve_transpose_sweeps(&lu, &piv, &mut gy);
            assert_eq!(x, gx);
            assert_eq!(y, gy);
        }
    }

    #[test]
    fn the_small_factorisations_equal_the_general_loops_bit_for_bit() {
        let mut rng = mbs_symbolic::samples::SplitMix64::new(11);
        for n in 1..=2 {
            for case in 0..300 {
                let mut a = DMatrix::from_fn(n, n, |_, _| rng.symmetric(2.0));
                // Exactly zero and non-finite pivots take the failure paths.
                match case % 50 {
                    0 => a.fill(0.0),
                    1 => a[(0, 0)] = f64::NAN,
                    2 => a[(n - 1, n - 1)] = f64::INFINITY,
                    3 if n == 2 => a.set_column(1, &(a.column(0) * 2.0)),
                    // A subnormal pivot is a pivot; a negative infinite one is not.
                    4 => {
                        a.fill(0.0);
                        a[(0, 0)] = -5e-324;
                        a[(n - 1, n - 1)] += 1.0;
                    }
                    5 => a[(n - 1, 0)] = f64::NEG_INFINITY,
                    _ => {}
                }
                let (mut small, mut general) = (a.clone(), a.clone());
                let (mut ps, mut pg) = (Vec::new(), Vec::new());
                let ok_small = lu_in_place(&mut small, &mut ps);
                let ok_general = lu_general(&mut general, &mut pg);
                assert_eq!(ok_small, ok_general, "n = {n}, case {case}");
                assert_eq!(ps, pg, "n = {n}, case {case}");
                if ok_small {
                    assert_eq!(small, general, "n = {n}, case {case}");
                    let b = DVector::from_fn(n, |_, _| rng.symmetric(1.0));
                    let (mut x, mut gx) = (b.clone(), b.clone());
                    lu_solve(&small, &ps, &mut x);
                    lu_solve_sweeps(&general, &pg, &mut gx);
                    assert_eq!(x, gx, "n = {n}, case {case}");
                    // And it solves: A x = b to round-off (but for the subnormal pivot,
                    // whose solution overflows).
                    if case % 50 != 4 {
                        let r = (&a * &x - &b).amax();
                        assert!(r <= 1e-12 * (1.0 + a.amax() * x.amax()));
                    }
                }
            }
        }
    }

    #[test]
    fn transpose_solve_and_singular_values_match_nalgebra() {
        let a = DMatrix::from_row_slice(
            4,
            4,
            &[
                0.3, -1.2, 2.0, 0.1, 1.5, 0.2, -0.7, 0.9, -0.4, 0.8, 0.6, -1.1, 2.2, -0.3, 0.5, 0.4,
            ],
        );
        let mut lu = a.clone();
        let mut piv = Vec::new();
        assert!(lu_in_place(&mut lu, &mut piv));
        let b = DVector::from_vec(vec![1.0, -2.0, 0.5, 3.0]);
        let mut x = b.clone();
        lu_solve_transpose(&lu, &piv, &mut x);
        let r = a.transpose() * &x - &b;
        assert!(r.amax() < 1e-13, "{r}");
        let s = a.clone().svd(false, false).singular_values;
        let mut w = DMatrix::zeros(0, 0);
        let (lo, hi) = singular_range(&a, &mut w);
        assert!((lo - s.min()).abs() < 1e-12 * s.max(), "{lo} {s}");
        assert!((hi - s.max()).abs() < 1e-12 * s.max(), "{hi} {s}");
        let a2 = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, -0.5, 0.3]);
        let s2 = a2.clone().svd(false, false).singular_values;
        let (lo, hi) = singular_range(&a2, &mut w);
        assert!((lo - s2.min()).abs() < 1e-14 && (hi - s2.max()).abs() < 1e-14);
    }

    #[test]
    fn the_two_by_two_singular_range_equals_the_matrix_form_bit_for_bit() {
        // The 2 x 2 case as written on the matrix before `singular_range_2`.
        let reference = |a: &DMatrix<f64>| {
            let fro2 = a.iter().map(|x| x * x).sum::<f64>();
            let d = (a[(0, 0)] * a[(1, 1)] - a[(0, 1)] * a[(1, 0)]).abs();
            let disc = (fro2 * fro2 - 4.0 * d * d).max(0.0).sqrt();
            let smax = ((fro2 + disc) / 2.0).sqrt();
            let smin = if smax > 0.0 { d / smax } else { 0.0 };
            (smin, smax)
        };
        let cases: [[f64; 4]; 6] = [
            [1.0, 2.0, -0.5, 0.3],
            [0.0, 0.0, 0.0, 0.0],
            [-0.0, 0.0, -0.0, 0.0],
            [1e-300, 3.0, -2e150, 0.7],
            [0.31, -1.7e-3, 2.9, 1.3e2],
            [1.0, 2.0, 2.0, 4.0],
        ];
        let mut w = DMatrix::zeros(0, 0);
        for c in cases {
            let a = DMatrix::from_column_slice(2, 2, &c);
            let (lo, hi) = singular_range_2(c);
            let (rlo, rhi) = reference(&a);
            assert_eq!(
                (lo.to_bits(), hi.to_bits()),
                (rlo.to_bits(), rhi.to_bits()),
                "{c:?}"
            );
            let (mlo, mhi) = singular_range(&a, &mut w);
            assert_eq!(
                (mlo.to_bits(), mhi.to_bits()),
                (rlo.to_bits(), rhi.to_bits()),
                "{c:?}"
            );
        }
    }
}
