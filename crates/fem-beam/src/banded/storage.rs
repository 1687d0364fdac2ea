//! The band storage of a symmetric matrix ([`BandedSym`], layout in the parent module's
//! documentation): construction, element access, scaling, and the products `A x`,
//! `y += alpha A x` and `x^T A x` into caller buffers.

use std::cell::Cell;

use nalgebra::DMatrix;

use super::slot;
use crate::error::LinalgError;

/// A symmetric matrix stored as its lower band (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct BandedSym {
    pub(super) n: usize,
    pub(super) kd: usize,
    pub(super) data: Vec<f64>,
}

impl BandedSym {
    /// The `n x n` zero matrix with half-bandwidth `kd` (`kd = 3` for the beam).
    pub fn zeros(n: usize, kd: usize) -> Self {
        Self {
            n,
            kd,
            data: vec![0.0; n * (kd + 1)],
        }
    }

    /// Reads the lower band of a dense square matrix (entries outside the band and the
    /// strict upper triangle are ignored).
    pub fn from_dense(m: &DMatrix<f64>, kd: usize) -> Result<Self, LinalgError> {
        if m.nrows() != m.ncols() {
            return Err(LinalgError::ShapeMismatch {
                expected_size: m.nrows(),
                expected_band: m.nrows(),
                got_size: m.nrows(),
                got_band: m.ncols(),
            });
        }
        let n = m.nrows();
        let mut b = Self::zeros(n, kd);
        for i in 0..n {
            for j in i.saturating_sub(kd)..=i {
                b.data[slot(kd, i, j)] = m[(i, j)];
            }
        }
        Ok(b)
    }

    /// The stored non-zero entries of the lower triangle, `(row, column, value)` 0-based,
    /// sorted by column then row: the export of a beam matrix (e.g. as a Matrix Market
    /// file for the `matrices` structure).
    pub fn lower_triplets(&self) -> Vec<(usize, usize, f64)> {
        let mut out = Vec::new();
        for j in 0..self.n {
            for i in j..self.n.min(j + self.kd + 1) {
                let v = self.get(i, j);
                if v != 0.0 {
                    out.push((i, j, v));
                }
            }
        }
        out
    }

    /// The dense symmetric matrix (for small problems and tests only: `O(n^2)` memory).
    pub fn to_dense(&self) -> DMatrix<f64> {
        let mut m = DMatrix::zeros(self.n, self.n);
        for i in 0..self.n {
            for j in i.saturating_sub(self.kd)..=i {
                let v = self.data[slot(self.kd, i, j)];
                m[(i, j)] = v;
                m[(j, i)] = v;
            }
        }
        m
    }

    /// Number of rows (= columns).
    pub fn size(&self) -> usize {
        self.n
    }

    /// Half-bandwidth `kd`: `A[i, j] = 0` when `|i - j| > kd`.
    pub fn half_bandwidth(&self) -> usize {
        self.kd
    }

    /// `A[i, j]` (zero outside the band).
    ///
    /// # Panics
    /// If `i` or `j` is not below [`size`](Self::size).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        assert!(
            i < self.n && j < self.n,
            "BandedSym::get({i}, {j}) on a {0}x{0} matrix",
            self.n
        );
        let (i, j) = if j <= i { (i, j) } else { (j, i) };
        if i - j > self.kd {
            0.0
        } else {
            self.data[slot(self.kd, i, j)]
        }
    }

    /// Adds `v` to `A[i, j]` (and so to `A[j, i]`: one stored entry).
    ///
    /// # Panics
    /// If `(i, j)` is outside the matrix or the band (programming error of the caller).
    pub fn add(&mut self, i: usize, j: usize, v: f64) {
        let (i, j) = if j <= i { (i, j) } else { (j, i) };
        assert!(
            i < self.n && i - j <= self.kd,
            "BandedSym::add({i}, {j}) outside a {}x{} matrix with half-bandwidth {}",
            self.n,
            self.n,
            self.kd
        );
        self.data[slot(self.kd, i, j)] += v;
    }

    /// Sets `A[i, j]` (and so `A[j, i]`).
    ///
    /// # Panics
    /// If `(i, j)` is outside the matrix or the band.
    pub fn set(&mut self, i: usize, j: usize, v: f64) {
        let (i, j) = if j <= i { (i, j) } else { (j, i) };
        assert!(
            i < self.n && i - j <= self.kd,
            "BandedSym::set({i}, {j}) outside a {}x{} matrix with half-bandwidth {}",
            self.n,
            self.n,
            self.kd
        );
        self.data[slot(self.kd, i, j)] = v;
    }

    /// The diagonal entries.
    pub fn diagonal(&self) -> impl ExactSizeIterator<Item = f64> + '_ {
        (0..self.n).map(move |i| self.data[slot(self.kd, i, i)])
    }

    /// `y = A x`, into the caller's buffer; no allocation.
    ///
    /// # Panics
    /// If `x` or `y` does not have length [`size`](Self::size).
    pub fn mul_vec_into(&self, x: &[f64], y: &mut [f64]) {
        y.fill(0.0);
        self.mul_add_into(1.0, x, y);
    }

    /// `y += alpha A x`, into the caller's buffer; no allocation.
    ///
    /// # Panics
    /// If `x` or `y` does not have length [`size`](Self::size).
    pub fn mul_add_into(&self, alpha: f64, x: &[f64], y: &mut [f64]) {
        assert_eq!(
            x.len(),
            self.n,
            "BandedSym::mul_add_into: x has the wrong length"
        );
        assert_eq!(
            y.len(),
            self.n,
            "BandedSym::mul_add_into: y has the wrong length"
        );
        // The half-bandwidth of the beam (3) gets its own inlined copy of the kernel.
        if self.kd == 3 && self.n >= 3 && self.data.len() == 4 * self.n {
            // In place: the kernel reads `y_i` before it writes it (the writes lag 3 rows).
            let y = Cell::from_mut(y).as_slice_of_cells();
            mul_add_kd3_dispatch(&self.data, alpha, x, y, y);
        } else {
            mul_add_kernel(self.kd, &self.data, alpha, x, y);
        }
    }

    /// `y = b + alpha A x`, into the caller's buffer (the operations of `y = b` followed by
    /// [`mul_add_into`](Self::mul_add_into), in the same order: bit-identical); no
    /// allocation, and one pass instead of a copy and a product.
    ///
    /// # Panics
    /// If `x`, `b` or `y` does not have length [`size`](Self::size).
    pub fn mul_add_to(&self, alpha: f64, x: &[f64], b: &[f64], y: &mut [f64]) {
        assert!(
            x.len() == self.n && b.len() == self.n && y.len() == self.n,
            "BandedSym::mul_add_to: a vector has the wrong length"
        );
        if self.kd == 3 && self.n >= 3 && self.data.len() == 4 * self.n {
            let y = Cell::from_mut(y).as_slice_of_cells();
            mul_add_kd3_dispatch(&self.data, alpha, x, b, y);
        } else {
            y.copy_from_slice(b);
            mul_add_kernel(self.kd, &self.data, alpha, x, y);
        }
    }

    /// `x^T A x`.
    ///
    /// # Panics
    /// If `x` does not have length [`size`](Self::size).
    pub fn quadratic_form(&self, x: &[f64]) -> f64 {
        assert_eq!(
            x.len(),
            self.n,
            "BandedSym::quadratic_form: x has the wrong length"
        );
        if self.kd == 3 && self.n >= 3 && self.data.len() == 4 * self.n {
            return quadratic_form_kd3(&self.data, x);
        }
        let w = self.kd + 1;
        let mut s = 0.0;
        for i in 0..self.n {
            let row = &self.data[i * w..(i + 1) * w];
            let mut off = 0.0;
            for j in i.saturating_sub(self.kd)..i {
                off += row[self.kd + j - i] * x[j];
            }
            s += x[i] * (row[self.kd] * x[i] + 2.0 * off);
        }
        s
    }

    /// `self += alpha other` (same size and half-bandwidth).
    pub fn scaled_add(&mut self, alpha: f64, other: &BandedSym) -> Result<(), LinalgError> {
        if other.n != self.n || other.kd != self.kd {
            return Err(LinalgError::ShapeMismatch {
                expected_size: self.n,
                expected_band: self.kd,
                got_size: other.n,
                got_band: other.kd,
            });
        }
        for (a, b) in self.data.iter_mut().zip(&other.data) {
            *a += alpha * b;
        }
        Ok(())
    }

    /// `self *= alpha`.
    pub fn scale(&mut self, alpha: f64) {
        self.data.iter_mut().for_each(|a| *a *= alpha);
    }
}

/// `y += alpha A x`.
#[inline(always)]
pub(super) fn mul_add_kernel(kd: usize, data: &[f64], alpha: f64, x: &[f64], y: &mut [f64]) {
    let w = kd + 1;
    for (i, row) in data.chunks_exact(w).enumerate() {
        let len = i.min(kd);
        let lower = &row[kd - len..kd];
        let xi = x[i];
        let mut acc = row[kd] * xi;
        let axi = alpha * xi;
        for ((a, xj), yj) in lower.iter().zip(&x[i - len..i]).zip(&mut y[i - len..i]) {
            acc += a * xj;
            *yj += a * axi;
        }
        y[i] += alpha * acc;
    }
}

/// `x^T A x` for the half-bandwidth 3 (`n >= 3`), the operations of
/// [`BandedSym::quadratic_form`] in the same order (bit-identical), the rows as fixed-size
/// chunks, three at a time, and `x_{i-3} .. x_{i-1}` in registers.
fn quadratic_form_kd3(data: &[f64], x: &[f64]) -> f64 {
    let n = x.len();
    if n < 3 || data.len() != 4 * n {
        return f64::NAN;
    }
    let (r1, r2) = (&data[4..8], &data[8..12]);
    let mut s = 0.0;
    s += x[0] * (data[3] * x[0] + 2.0 * 0.0);
    s += x[1] * (r1[3] * x[1] + 2.0 * (0.0 + r1[2] * x[0]));
    s += x[2] * (r2[3] * x[2] + 2.0 * (0.0 + r2[1] * x[0] + r2[2] * x[1]));
    let mut w = [x[0], x[1], x[2]];
    // Row i (`r`) adds its term x_i (A_ii x_i + 2 sum_j A_ij x_j) to `s`.
    // (The general kernel's sum starts at 0.0; `0.0 + p` is `p` for every `p` but -0.0, so
    // starting at the first product changes at most the sign of a zero total.)
    let mut row = |r: &[f64], xi: f64| {
        let off = r[0] * w[0] + r[1] * w[1] + r[2] * w[2];
        s += xi * (r[3] * xi + 2.0 * off);
        w = [w[1], w[2], xi];
    };
    let rows = data[12..].chunks_exact(12);
    let done = 3 + 3 * rows.len();
    for (r, xs) in rows.zip(x[3..].chunks_exact(3)) {
        row(&r[..4], xs[0]);
        row(&r[4..8], xs[1]);
        row(&r[8..], xs[2]);
    }
    for (r, &xi) in data[4 * done..].chunks_exact(4).zip(&x[done..]) {
        row(r, xi);
    }
    s
}

/// A vector entry read by value: a plain `f64` or a [`Cell`] (a vector the kernel also
/// writes, read ahead of the writes).
trait Entry {
    fn get(&self) -> f64;
}

impl Entry for f64 {
    #[inline(always)]
    fn get(&self) -> f64 {
        *self
    }
}

impl Entry for Cell<f64> {
    #[inline(always)]
    fn get(&self) -> f64 {
        Cell::get(self)
    }
}

/// [`mul_add_kd3`] with `alpha = -1` (the step's residual `P - C x`) as its own copy: the
/// products with `-1` are negations, which the compiler folds into subtractions (exact:
/// `v + l (-x) = v - l x` in IEEE arithmetic), so the results are the general kernel's.
#[inline(always)]
fn mul_add_kd3_dispatch(data: &[f64], alpha: f64, x: &[f64], b: &[impl Entry], y: &[Cell<f64>]) {
    if alpha == -1.0 {
        mul_add_kd3(data, -1.0, x, b, y);
    } else {
        mul_add_kd3(data, alpha, x, b, y);
    }
}

/// The running state of [`mul_add_kd3`] before row `i`: the partial sums of
/// `y_{i-3} .. y_{i-1}` (`v`) and `x_{i-3} .. x_{i-1}` (`x`).
struct Window {
    v: [f64; 3],
    x: [f64; 3],
}

impl Window {
    /// Row `i` (`r`: its band, `A[i, i-3 ..= i]`): completes and returns `y_{i-3}`, takes
    /// `b_i + alpha (A x)_i` (its lower part and diagonal) as the partial `y_i`.
    #[inline(always)]
    fn row(&mut self, alpha: f64, r: &[f64], xi: f64, bi: f64) -> f64 {
        let Window { v, x } = self;
        let axi = alpha * xi;
        let mut acc = r[3] * xi;
        acc += r[0] * x[0];
        let done = v[0] + r[0] * axi;
        acc += r[1] * x[1];
        let v1 = v[1] + r[1] * axi;
        acc += r[2] * x[2];
        let v2 = v[2] + r[2] * axi;
        *v = [v1, v2, bi + alpha * acc];
        *x = [x[1], x[2], xi];
        done
    }
}

/// `y = b + alpha A x` for the half-bandwidth 3 (`n >= 3`, `data` of `4 n` entries), the
/// operations of `y = b` and [`mul_add_kernel`] in the same order (bit-identical): the rows
/// as fixed-size chunks, three at a time (so that the window of partial sums stays in the
/// same registers), `x_{i-3} .. x_{i-1}` and the partial sums of `y_{i-3} .. y_{i-1}` in
/// registers, the vectors read and written through chunked iterators. `b` may be `y`'s own
/// cells (the product in place): `y_i` is written three rows after `b_i` is read.
#[inline(always)]
fn mul_add_kd3(data: &[f64], alpha: f64, x: &[f64], b: &[impl Entry], y: &[Cell<f64>]) {
    let n = x.len();
    if n < 3 || data.len() != 4 * n || b.len() != n || y.len() != n {
        return;
    }
    let (r0, r1, r2) = (&data[..4], &data[4..8], &data[8..12]);
    let (x0, x1, x2) = (x[0], x[1], x[2]);
    // Rows 0 .. 2 (fewer than 3 lower entries) in the order of the general kernel.
    let mut v0 = b[0].get() + alpha * (r0[3] * x0);
    let (mut acc, axi) = (r1[3] * x1, alpha * x1);
    acc += r1[2] * x0;
    v0 += r1[2] * axi;
    let mut v1 = b[1].get() + alpha * acc;
    let (mut acc, axi) = (r2[3] * x2, alpha * x2);
    acc += r2[1] * x0;
    v0 += r2[1] * axi;
    acc += r2[2] * x1;
    v1 += r2[2] * axi;
    let v2 = b[2].get() + alpha * acc;
    let mut w = Window {
        v: [v0, v1, v2],
        x: [x0, x1, x2],
    };
    let rows = data[12..].chunks_exact(12);
    let done = 3 + 3 * rows.len();
    for ((r, xs), (bs, out)) in rows
        .zip(x[3..].chunks_exact(3))
        .zip(b[3..].chunks_exact(3).zip(y.chunks_exact(3)))
    {
        out[0].set(w.row(alpha, &r[..4], xs[0], bs[0].get()));
        out[1].set(w.row(alpha, &r[4..8], xs[1], bs[1].get()));
        out[2].set(w.row(alpha, &r[8..], xs[2], bs[2].get()));
    }
    for i in done..n {
        y[i - 3].set(w.row(alpha, &data[4 * i..4 * i + 4], x[i], b[i].get()));
    }
    for (out, v) in y[n - 3..].iter().zip(w.v) {
        out.set(v);
    }
}

#[cfg(test)]
mod tests {
    use super::super::sample;
    use super::*;

    #[test]
    fn lower_triplets_are_the_dense_lower_triangle() {
        let a = sample(7, 2);
        let d = a.to_dense();
        let t = a.lower_triplets();
        for j in 0..7 {
            for i in j..7 {
                let v = t.iter().find(|e| e.0 == i && e.1 == j).map_or(0.0, |e| e.2);
                assert_eq!(v, d[(i, j)]);
            }
        }
        assert!(t.windows(2).all(|w| (w[0].1, w[0].0) < (w[1].1, w[1].0)));
    }

    #[test]
    fn storage_round_trips_through_dense() {
        let a = sample(7, 2);
        let d = a.to_dense();
        assert_eq!(d, d.transpose());
        assert_eq!(d[(0, 3)], 0.0);
        assert_eq!(BandedSym::from_dense(&d, 2).unwrap(), a);
        assert_eq!(a.get(1, 3), d[(1, 3)]);
    }

    #[test]
    fn kd3_kernels_are_bit_identical_to_the_general_ones() {
        for n in 3..14 {
            let a = sample(n, 3);
            let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.9).cos() + 0.1).collect();
            let y0: Vec<f64> = (0..n).map(|i| (i as f64 * 0.4).sin()).collect();
            // In place and into another buffer, with the general alpha and the copy of
            // alpha = -1 (the step's).
            for alpha in [-0.7, -1.0] {
                let (mut y3, mut y, mut to) = (y0.clone(), y0.clone(), vec![f64::NAN; n]);
                a.mul_add_into(alpha, &x, &mut y3);
                a.mul_add_to(alpha, &x, &y0, &mut to);
                mul_add_kernel(3, &a.data, alpha, &x, &mut y);
                assert_eq!(y3, y, "n = {n}, alpha = {alpha}");
                assert_eq!(to, y, "n = {n}, alpha = {alpha}");
            }
            let mut y = y0.clone();
            mul_add_kernel(3, &a.data, -0.7, &x, &mut y);
            // Against the dense product.
            let d = a.to_dense() * nalgebra::DVector::from_column_slice(&x);
            for i in 0..n {
                assert!(
                    (y[i] - (y0[i] - 0.7 * d[i])).abs() < 1e-14,
                    "n = {n}, row {i}"
                );
            }
            let mut general = 0.0;
            for i in 0..n {
                let row = &a.data[i * 4..(i + 1) * 4];
                let mut off = 0.0;
                for j in i.saturating_sub(3)..i {
                    off += row[3 + j - i] * x[j];
                }
                general += x[i] * (row[3] * x[i] + 2.0 * off);
            }
            assert_eq!(quadratic_form_kd3(&a.data, &x), general, "n = {n}");
            let dense: f64 = x.iter().zip(d.iter()).map(|(a, b)| a * b).sum();
            assert!(
                (general - dense).abs() < 1e-13 * dense.abs().max(1.0),
                "n = {n}"
            );
        }
    }

    #[test]
    fn shape_mismatch_is_an_error() {
        let mut a = sample(5, 1);
        assert!(a.scaled_add(1.0, &sample(5, 2)).is_err());
        assert!(BandedSym::from_dense(&DMatrix::zeros(2, 3), 1).is_err());
    }
}
