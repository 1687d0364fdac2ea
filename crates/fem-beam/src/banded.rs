//! Banded symmetric matrices, their LDL^T factorisation and a Sherman–Morrison rank-one
//! solve (THEORY.md section 4: the beam matrices are banded, half-bandwidth 3 with nodal
//! ordering, so storage, products and solves are O(n)).
//!
//! Storage: the lower band, row by row. Row `i` holds `A[i, i-kd ..= i]` in
//! `data[i*(kd+1) .. (i+1)*(kd+1)]`, the diagonal last; the leading slots of the first `kd`
//! rows are unused (kept zero).
//!
//! ```text
//!   A[i, j] (j <= i, i - j <= kd)  ->  data[i*(kd+1) + kd - (i - j)]
//! ```
//!
//! The factorisation `A = L D L^T` (unit lower-triangular `L` with the same band, diagonal
//! `D`) is computed without pivoting and requires every pivot to be positive, i.e. `A`
//! symmetric positive definite. Because nothing is pivoted the band does not grow, and the
//! work is `O(n kd^2)`.

use nalgebra::DMatrix;

use crate::error::LinalgError;

/// A symmetric matrix stored as its lower band (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct BandedSym {
    n: usize,
    kd: usize,
    data: Vec<f64>,
}

#[inline]
fn slot(kd: usize, i: usize, j: usize) -> usize {
    // j <= i, i - j <= kd
    i * (kd + 1) + kd + j - i
}

/// Dekker's error-free product: `p + e = a b` exactly (barring over/underflow), with
/// Veltkamp's splitting.
#[inline(always)]
fn two_product(a: f64, b: f64) -> (f64, f64) {
    const SPLIT: f64 = 134_217_729.0; // 2^27 + 1
    let p = a * b;
    let (ta, tb) = (SPLIT * a, SPLIT * b);
    let (ah, bh) = (ta - (ta - a), tb - (tb - b));
    let (al, bl) = (a - ah, b - bh);
    let e = al * bl - (((p - ah * bh) - al * bh) - ah * bl);
    (p, e)
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

    /// `r = b - A x` accumulated in double-double arithmetic (Dekker's error-free product,
    /// Knuth's error-free sum: Ogita–Rump–Oishi "Dot2") and rounded once: accurate to about
    /// one rounding even when `b` and `A x` cancel to many digits, which is what iterative
    /// refinement needs. Portable (no FMA needed); no allocation.
    ///
    /// # Panics
    /// If `x`, `b` or `r` does not have length [`size`](Self::size).
    pub fn residual_into(&self, x: &[f64], b: &[f64], r: &mut [f64]) {
        assert_eq!(
            x.len(),
            self.n,
            "BandedSym::residual_into: x has the wrong length"
        );
        assert_eq!(
            b.len(),
            self.n,
            "BandedSym::residual_into: b has the wrong length"
        );
        assert_eq!(
            r.len(),
            self.n,
            "BandedSym::residual_into: r has the wrong length"
        );
        if self.kd == 3 {
            residual_kernel(3, &self.data, x, b, r);
        } else {
            residual_kernel(self.kd, &self.data, x, b, r);
        }
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

    /// The LDL^T factorisation (allocates the factor; see
    /// [`factorize_into`](Self::factorize_into) to reuse one).
    pub fn factorize(&self) -> Result<BandedFactor, LinalgError> {
        let mut f = BandedFactor {
            n: self.n,
            kd: self.kd,
            data: Vec::new(),
            groups: None,
        };
        self.factorize_into(&mut f)?;
        Ok(f)
    }

    /// The symmetric permutation `B = P A P^T`, `B[perm[i], perm[j]] = A[i, j]`, or `None`
    /// when a nonzero entry would fall outside the band.
    fn permuted(&self, perm: &[usize]) -> Option<BandedSym> {
        let (n, kd) = (self.n, self.kd);
        let mut r = BandedSym::zeros(n, kd);
        for i in 0..n {
            for j in i.saturating_sub(kd)..=i {
                let v = self.data[slot(kd, i, j)];
                if v != 0.0 {
                    let (a, b) = (perm[i].max(perm[j]), perm[i].min(perm[j]));
                    if a - b > kd {
                        return None;
                    }
                    r.data[slot(kd, a, b)] = v;
                }
            }
        }
        Some(r)
    }

    /// The factorisation with the elimination running backwards over groups of rows:
    /// `groups` are the sizes of consecutive index groups (for the beam: the free DOFs of
    /// each node), which are taken last to first, each keeping its internal order. The
    /// solves are the same, the rounding is not: eliminating towards a support subtracts
    /// large element stiffnesses to leave a small one, so a beam stiffness is best eliminated
    /// starting at its free end. For a cantilever clamped at x = 0 this order leaves a
    /// relative error 4e-8 at 10,000 elements where the forward order leaves 2e-2 (plain
    /// row reversal, which also swaps `w` and `theta` inside each node, leaves 1.6e-2).
    /// [`crate::BeamModel::factorize`] chooses the order from the supports.
    ///
    /// Errors: [`LinalgError::ShapeMismatch`] when the groups do not add up to the size or
    /// the reordered matrix does not fit the band; [`LinalgError::NotPositiveDefinite`] with
    /// the index in the original ordering.
    pub fn factorize_reversed(&self, groups: &[usize]) -> Result<BandedFactor, LinalgError> {
        let mismatch = LinalgError::ShapeMismatch {
            expected_size: self.n,
            expected_band: self.kd,
            got_size: groups.iter().sum(),
            got_band: self.kd,
        };
        if groups.iter().sum::<usize>() != self.n {
            return Err(mismatch);
        }
        // perm[old] = new: group g (start s, size m) moves to start n - s - m.
        let mut perm = vec![0; self.n];
        let mut start = 0;
        for &m in groups {
            for k in 0..m {
                perm[start + k] = self.n - start - m + k;
            }
            start += m;
        }
        let mut f = self
            .permuted(&perm)
            .ok_or(mismatch)?
            .factorize()
            .map_err(|e| match e {
                LinalgError::NotPositiveDefinite { index, pivot } => {
                    LinalgError::NotPositiveDefinite {
                        // Back to the original numbering.
                        index: perm.iter().position(|&p| p == index).unwrap_or(index),
                        pivot,
                    }
                }
                other => other,
            })?;
        f.groups = Some(groups.to_vec());
        Ok(f)
    }

    /// The LDL^T factorisation into an existing factor, reusing its storage (no allocation
    /// when the factor already has this size and band).
    ///
    /// Fails with [`LinalgError::NotPositiveDefinite`] at the first pivot that is not a
    /// positive finite number.
    pub fn factorize_into(&self, f: &mut BandedFactor) -> Result<(), LinalgError> {
        let (n, kd) = (self.n, self.kd);
        f.n = n;
        f.kd = kd;
        f.groups = None;
        f.data.clear();
        f.data.extend_from_slice(&self.data);
        ldlt_in_place(n, kd, &mut f.data, |index, pivot| {
            if pivot > 0.0 && pivot.is_finite() {
                Ok(())
            } else {
                Err(LinalgError::NotPositiveDefinite { index, pivot })
            }
        })
    }

    /// Number of negative pivots of an LDL^T factorisation without pivoting of this
    /// (possibly indefinite) matrix: by Sylvester's law of inertia (the Sturm sequence
    /// property) it is the number of negative eigenvalues. Used with `C - sigma A` to count
    /// the eigenvalues below `sigma`. `None` when a pivot is exactly zero or not finite.
    pub fn negative_pivot_count(&self) -> Option<usize> {
        let mut d = self.data.clone();
        let mut count = 0;
        ldlt_in_place(self.n, self.kd, &mut d, |_, pivot| {
            if pivot == 0.0 || !pivot.is_finite() {
                return Err(());
            }
            count += usize::from(pivot < 0.0);
            Ok(())
        })
        .ok()?;
        Some(count)
    }
}

/// Banded LDL^T without pivoting, in place in the storage of [`BandedSym`]: on return the
/// strict lower band holds `L` and the diagonal slots `D`. `pivot(i, d_i)` is called on
/// every pivot before it is stored and can stop the elimination with an error.
fn ldlt_in_place<E>(
    n: usize,
    kd: usize,
    d: &mut [f64],
    mut pivot: impl FnMut(usize, f64) -> Result<(), E>,
) -> Result<(), E> {
    for i in 0..n {
        let j0 = i.saturating_sub(kd);
        // Unscaled t_ij = L_ij d_j = a_ij - sum_{k<j} t_ik L_jk  (row j is final).
        for j in j0..i {
            let mut s = d[slot(kd, i, j)];
            for k in j0..j {
                s -= d[slot(kd, i, k)] * d[slot(kd, j, k)];
            }
            d[slot(kd, i, j)] = s;
        }
        // d_i = a_ii - sum_k t_ik^2 / d_k, then L_ik = t_ik / d_k.
        let mut piv = d[slot(kd, i, i)];
        for k in j0..i {
            let t = d[slot(kd, i, k)];
            let l = t / d[slot(kd, k, k)];
            piv -= t * l;
            d[slot(kd, i, k)] = l;
        }
        pivot(i, piv)?;
        d[slot(kd, i, i)] = piv;
    }
    Ok(())
}

// Kernels. `#[inline(always)]` with a literal `kd` at the call site gives a specialised
// copy for the beam's half-bandwidth 3; row `i` of `data` is `data[i*w .. (i+1)*w]`, its
// strict lower part (columns `i - len .. i`, `len = min(i, kd)`) is `row[kd - len .. kd]`.

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

/// Error-free `s + c += -a x` (Dot2 step).
#[inline(always)]
fn dot2_step(s: &mut f64, c: &mut f64, a: f64, x: f64) {
    let (p, e) = two_product(-a, x);
    let t = *s + p;
    let z = t - *s;
    let f = (*s - (t - z)) + (p - z);
    *s = t;
    *c += f + e;
}

/// `r = b - A x` in double-double.
#[inline(always)]
fn residual_kernel(kd: usize, data: &[f64], x: &[f64], b: &[f64], r: &mut [f64]) {
    let w = kd + 1;
    let n = x.len();
    for i in 0..n {
        let (mut s, mut c) = (b[i], 0.0);
        let len = i.min(kd);
        let row = &data[i * w..(i + 1) * w];
        for (a, xj) in row[kd - len..].iter().zip(&x[i - len..=i]) {
            dot2_step(&mut s, &mut c, *a, *xj);
        }
        // Upper part: A[i, i+t] is stored in row i+t at column offset kd - t.
        for t in 1..=kd.min(n - 1 - i) {
            dot2_step(&mut s, &mut c, data[(i + t) * w + kd - t], x[i + t]);
        }
        r[i] = s + c;
    }
}

/// Solves `L D L^T x = b` in place.
#[inline(always)]
fn solve_kernel(kd: usize, data: &[f64], b: &mut [f64]) {
    let w = kd + 1;
    // L y = b
    for (i, row) in data.chunks_exact(w).enumerate() {
        let len = i.min(kd);
        let dot: f64 = row[kd - len..kd]
            .iter()
            .zip(&b[i - len..i])
            .map(|(l, v)| l * v)
            .sum();
        b[i] -= dot;
    }
    // D z = y
    for (bi, row) in b.iter_mut().zip(data.chunks_exact(w)) {
        *bi /= row[kd];
    }
    // L^T x = z (column sweep over the stored rows)
    for (i, row) in data.chunks_exact(w).enumerate().rev() {
        let len = i.min(kd);
        let xi = b[i];
        for (l, v) in row[kd - len..kd].iter().zip(&mut b[i - len..i]) {
            *v -= l * xi;
        }
    }
}

/// The factorisation `A = L D L^T` of a [`BandedSym`]; solves are `O(n kd)` and allocate
/// nothing.
#[derive(Clone, Debug, PartialEq)]
pub struct BandedFactor {
    n: usize,
    kd: usize,
    /// `L` (strict lower band, unit diagonal implied) and `D` (on the diagonal slots), in
    /// the storage of [`BandedSym`].
    data: Vec<f64>,
    /// The groups of [`BandedSym::factorize_reversed`], when the factor is of the
    /// group-reversed matrix.
    groups: Option<Vec<usize>>,
}

impl BandedFactor {
    /// Size of the factorised matrix.
    pub fn size(&self) -> usize {
        self.n
    }

    /// Half-bandwidth of the factorised matrix.
    pub fn half_bandwidth(&self) -> usize {
        self.kd
    }

    /// Whether the elimination ran from the last row up.
    pub fn is_reversed(&self) -> bool {
        self.groups.is_some()
    }

    /// The pivots `D` (all positive), in elimination order.
    pub fn pivots(&self) -> impl ExactSizeIterator<Item = f64> + '_ {
        (0..self.n).map(move |i| self.data[slot(self.kd, i, i)])
    }

    /// Solves `A x = b` in place (`b` becomes `x`); no allocation.
    ///
    /// # Panics
    /// If `b` does not have length [`size`](Self::size).
    pub fn solve_in_place(&self, b: &mut [f64]) {
        assert_eq!(
            b.len(),
            self.n,
            "BandedFactor::solve_in_place: right-hand side has the wrong length"
        );
        // Group reversal P, in place: reverse everything, then restore the order inside
        // each group (at its new place); P^-1: reverse everything, then restore each group
        // at its original place.
        if let Some(groups) = &self.groups {
            b.reverse();
            let mut start = 0;
            for &m in groups.iter().rev() {
                b[start..start + m].reverse();
                start += m;
            }
        }
        if self.kd == 3 {
            solve_kernel(3, &self.data, b);
        } else {
            solve_kernel(self.kd, &self.data, b);
        }
        if let Some(groups) = &self.groups {
            b.reverse();
            let mut start = 0;
            for &m in groups {
                b[start..start + m].reverse();
                start += m;
            }
        }
    }

    /// Solves `A x = b` with iterative refinement: after the plain solve, the residual
    /// `b - A x` is computed in double-double arithmetic ([`BandedSym::residual_into`]) and
    /// the correction solved with this factor, until the correction stops shrinking or falls
    /// to rounding level (at most 10 steps). `a` must be the matrix this factor came from.
    /// Returns the number of refinement steps.
    ///
    /// Why: the beam stiffness is ill-conditioned (`cond ~ n^4`), and eliminating towards a
    /// support subtracts large element stiffnesses (`E J / h^3`) to leave a small one
    /// (`E J / x^3`), so a plain solve loses about `log10(n^3)` digits (2e-10 for a 50-element
    /// cantilever). Refinement recovers the solution of the stored matrix to rounding level
    /// while `n^3 eps << 1`. No allocation: `work` is scratch of the same length.
    ///
    /// # Panics
    /// If `b`, `x` or `work` does not have length [`size`](Self::size), or `a` has another size.
    pub fn solve_refined(
        &self,
        a: &BandedSym,
        b: &[f64],
        x: &mut [f64],
        work: &mut [f64],
    ) -> usize {
        assert_eq!(
            a.n, self.n,
            "BandedFactor::solve_refined: matrix and factor sizes differ"
        );
        self.refine_with(b, x, work, |x, b, r| a.residual_into(x, b, r))
    }

    /// Iterative refinement with a caller-supplied residual `residual(x, b, r)`:
    /// `r = b - K x` for the operator `K` this factor approximates. The factor only has to be
    /// close to `K` (refinement converges while `||I - F^-1 K|| < 1`): the accuracy is that
    /// of the residual. [`crate::BeamModel`] passes the element-wise stiffness residual,
    /// which is exact for rigid-body motions, so the solution is that of the exact element
    /// matrices rather than of their rounded assembly. Returns the number of refinement
    /// steps; no allocation (`work` is scratch).
    ///
    /// # Panics
    /// If `b`, `x` or `work` does not have length [`size`](Self::size).
    pub fn refine_with(
        &self,
        b: &[f64],
        x: &mut [f64],
        work: &mut [f64],
        mut residual: impl FnMut(&[f64], &[f64], &mut [f64]),
    ) -> usize {
        assert_eq!(
            x.len(),
            self.n,
            "BandedFactor::refine_with: x has the wrong length"
        );
        assert_eq!(
            work.len(),
            self.n,
            "BandedFactor::refine_with: work has the wrong length"
        );
        x.copy_from_slice(b);
        self.solve_in_place(x);
        let inf_norm = |v: &[f64]| v.iter().fold(0.0f64, |m, t| m.max(t.abs()));
        // d_0: the size of x itself (the first correction is compared with it).
        let mut last = inf_norm(x);
        for step in 1..=10 {
            residual(x, b, work);
            self.solve_in_place(work);
            let d = inf_norm(work);
            if !d.is_finite() || d >= 0.5 * last {
                // The correction no longer shrinks: x is as good as it gets.
                return step - 1;
            }
            for (xi, di) in x.iter_mut().zip(work.iter()) {
                *xi += di;
            }
            // Refinement converges linearly with ratio d / last; the error left in x is about
            // d * (d / last). Stop when that is below rounding.
            if d * (d / last) <= f64::EPSILON * inf_norm(x) {
                return step;
            }
            last = d;
        }
        10
    }

    /// Solves `A x = b` into a new vector (convenience wrapper of
    /// [`solve_in_place`](Self::solve_in_place)).
    pub fn solve(&self, b: &[f64]) -> Vec<f64> {
        let mut x = b.to_vec();
        self.solve_in_place(&mut x);
        x
    }
}

/// Solves `(K + alpha e_k e_k^T) x = b` with the factorisation of `K` (Sherman–Morrison),
/// without refactorising: `x = y - (alpha y_k / (1 + alpha z_k)) z` with `y = K^-1 b`,
/// `z = K^-1 e_k`. `rhs` holds `b` on entry and `x` on return; `work` (same length) receives
/// `z`. Allocation-free. When the same `k` is used many times, [`RankOneUpdate`] computes
/// `z` once.
///
/// # Panics
/// If `rhs` or `work` does not have the size of the factor.
pub fn solve_rank_one_update(
    factor: &BandedFactor,
    k: usize,
    alpha: f64,
    rhs: &mut [f64],
    work: &mut [f64],
) -> Result<(), LinalgError> {
    if k >= factor.n {
        return Err(LinalgError::IndexOutOfRange {
            index: k,
            size: factor.n,
        });
    }
    assert_eq!(
        work.len(),
        factor.n,
        "solve_rank_one_update: work has the wrong length"
    );
    work.fill(0.0);
    work[k] = 1.0;
    factor.solve_in_place(work);
    factor.solve_in_place(rhs);
    sherman_morrison_apply(k, alpha, work, rhs)
}

fn sherman_morrison_apply(
    k: usize,
    alpha: f64,
    z: &[f64],
    x: &mut [f64],
) -> Result<(), LinalgError> {
    let denom = 1.0 + alpha * z[k];
    // z_k > 0 for an SPD K, so alpha >= 0 is always safe; a negative alpha may cancel the 1.
    // Relative threshold: below ~eps * |alpha z_k| the denominator is pure rounding noise.
    if !denom.is_finite() || denom.abs() <= 4.0 * f64::EPSILON * (1.0 + (alpha * z[k]).abs()) {
        return Err(LinalgError::SingularUpdate { k, alpha });
    }
    let c = alpha * x[k] / denom;
    for (xi, zi) in x.iter_mut().zip(z) {
        *xi -= c * zi;
    }
    Ok(())
}

/// A factorisation of `K` plus the column `K^-1 e_k`, for repeated solves of
/// `(K + alpha e_k e_k^T) x = b` with a varying `alpha` (e.g. the reflected mass of a
/// mechanism attached at one DOF, THEORY.md section 6) at `O(n)` each, allocation-free.
#[derive(Clone, Debug)]
pub struct RankOneUpdate {
    factor: BandedFactor,
    k: usize,
    z: Vec<f64>,
}

impl RankOneUpdate {
    /// Prepares the update of DOF `k` (computes `z = K^-1 e_k` once).
    pub fn new(factor: BandedFactor, k: usize) -> Result<Self, LinalgError> {
        if k >= factor.n {
            return Err(LinalgError::IndexOutOfRange {
                index: k,
                size: factor.n,
            });
        }
        let mut z = vec![0.0; factor.n];
        z[k] = 1.0;
        factor.solve_in_place(&mut z);
        Ok(Self { factor, k, z })
    }

    /// The factorisation of `K`.
    pub fn factor(&self) -> &BandedFactor {
        &self.factor
    }

    /// The updated DOF.
    pub fn dof(&self) -> usize {
        self.k
    }

    /// Solves `(K + alpha e_k e_k^T) x = b` in place; no allocation.
    ///
    /// # Panics
    /// If `rhs` does not have the size of the factor.
    pub fn solve_in_place(&self, alpha: f64, rhs: &mut [f64]) -> Result<(), LinalgError> {
        self.factor.solve_in_place(rhs);
        sherman_morrison_apply(self.k, alpha, &self.z, rhs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(n: usize, kd: usize) -> BandedSym {
        // Diagonally dominant, hence SPD.
        let mut a = BandedSym::zeros(n, kd);
        for i in 0..n {
            for j in i.saturating_sub(kd)..i {
                a.set(i, j, ((i * 7 + j * 3) % 5) as f64 * 0.1 - 0.2);
            }
            a.set(i, i, 2.0 + kd as f64);
        }
        a
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
    fn factor_solve_matches_dense_lu() {
        let a = sample(9, 3);
        let b: Vec<f64> = (0..9).map(|i| (i as f64).sin()).collect();
        let x = a.factorize().unwrap().solve(&b);
        let xd = a
            .to_dense()
            .lu()
            .solve(&nalgebra::DVector::from_vec(b))
            .unwrap();
        for i in 0..9 {
            // Well-conditioned 9x9 matrix: both solutions agree to a few ulps.
            assert!((x[i] - xd[i]).abs() < 1e-14, "{i}: {} vs {}", x[i], xd[i]);
        }
    }

    #[test]
    fn compensated_residual_is_exact_for_exact_solutions() {
        // Integer data: A x and b are exact, so the residual must be exactly zero even with
        // huge cancelling terms.
        let mut a = BandedSym::zeros(3, 1);
        a.set(0, 0, 1e16);
        a.set(1, 0, -1e16 + 2.0);
        a.set(1, 1, 1e16);
        a.set(2, 1, 3.0);
        a.set(2, 2, 5.0);
        let x = [1.0, 1.0, 1.0];
        let b = [2.0, 5.0, 8.0];
        let mut r = [9.0; 3];
        a.residual_into(&x, &b, &mut r);
        assert_eq!(r, [0.0, 0.0, 0.0]);
    }

    #[test]
    fn reversed_factor_solves_the_same_system() {
        // Block-tridiagonal in the groups below (like a beam: a node couples only with its
        // neighbours), so the group reversal keeps the band.
        let group = |i: usize| i.div_ceil(2);
        let mut a = sample(11, 3);
        for i in 0..11usize {
            for j in i.saturating_sub(3)..i {
                if group(i) - group(j) > 1 {
                    a.set(i, j, 0.0);
                }
            }
        }
        let b: Vec<f64> = (0..11).map(|i| (i as f64 * 0.7).cos()).collect();
        let x = a.factorize().unwrap().solve(&b);
        // Groups of 1 (plain reversal) and node-like groups of 2 (one single at the start).
        for groups in [vec![1; 11], vec![1, 2, 2, 2, 2, 2]] {
            let f = a.factorize_reversed(&groups).unwrap();
            assert!(f.is_reversed());
            let xr = f.solve(&b);
            for i in 0..11 {
                assert!((x[i] - xr[i]).abs() < 1e-14, "{groups:?} {i}");
            }
        }
        assert!(matches!(
            a.factorize_reversed(&[5, 5]),
            Err(LinalgError::ShapeMismatch { .. })
        ));
        // Groups of 5 with kd = 3 push entries out of the band.
        assert!(matches!(
            sample(11, 3).factorize_reversed(&[5, 5, 1]),
            Err(LinalgError::ShapeMismatch { .. })
        ));
        let mut bad = sample(5, 1);
        bad.set(1, 1, -3.0);
        assert!(matches!(
            bad.factorize_reversed(&[1; 5]),
            Err(LinalgError::NotPositiveDefinite { index: 1, .. })
        ));
    }

    #[test]
    fn indefinite_matrix_is_rejected_with_index() {
        let mut a = sample(4, 1);
        a.set(2, 2, -1.0);
        assert!(matches!(
            a.factorize(),
            Err(LinalgError::NotPositiveDefinite { index: 2, .. })
        ));
        assert_eq!(a.negative_pivot_count(), Some(1));
    }

    #[test]
    fn singular_rank_one_update_is_an_error() {
        let a = sample(5, 1);
        let f = a.factorize().unwrap();
        let z = f.solve(&[0.0, 0.0, 1.0, 0.0, 0.0]);
        let mut rhs = vec![1.0; 5];
        let mut work = vec![0.0; 5];
        let r = solve_rank_one_update(&f, 2, -1.0 / z[2], &mut rhs, &mut work);
        assert!(matches!(r, Err(LinalgError::SingularUpdate { k: 2, .. })));
        let r = solve_rank_one_update(&f, 5, 1.0, &mut rhs, &mut work);
        assert!(matches!(
            r,
            Err(LinalgError::IndexOutOfRange { index: 5, size: 5 })
        ));
    }

    #[test]
    fn shape_mismatch_is_an_error() {
        let mut a = sample(5, 1);
        assert!(a.scaled_add(1.0, &sample(5, 2)).is_err());
        assert!(BandedSym::from_dense(&DMatrix::zeros(2, 3), 1).is_err());
    }
}
