//! The band storage of a symmetric matrix ([`BandedSym`], layout in the parent module's
//! documentation): construction, element access, scaling, and the products `A x`,
//! `y += alpha A x` and `x^T A x` into caller buffers.

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
        if self.kd == 3 {
            mul_add_kernel(3, &self.data, alpha, x, y);
        } else {
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
fn mul_add_kernel(kd: usize, data: &[f64], alpha: f64, x: &[f64], y: &mut [f64]) {
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

#[cfg(test)]
mod tests {
    use super::super::sample;
    use super::*;

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
    fn shape_mismatch_is_an_error() {
        let mut a = sample(5, 1);
        assert!(a.scaled_add(1.0, &sample(5, 2)).is_err());
        assert!(BandedSym::from_dense(&DMatrix::zeros(2, 3), 1).is_err());
    }
}
