//! The factorisation `A = L D L^T` of a banded symmetric matrix without pivoting
//! ([`BandedFactor`]), forwards or with the elimination order reversed over groups of rows,
//! its `O(n kd)` allocation-free solves, and the Sturm count of negative pivots, which runs
//! the same elimination kernel on an indefinite matrix.

use std::cell::Cell;

use super::{BandedSym, slot};
use crate::error::LinalgError;

impl BandedSym {
    /// The LDL^T factorisation (allocates the factor; see
    /// [`factorize_into`](Self::factorize_into) to reuse one).
    pub fn factorize(&self) -> Result<BandedFactor, LinalgError> {
        self.check_finite()?;
        let mut f = BandedFactor {
            n: self.n,
            kd: self.kd,
            data: Vec::new(),
            groups: None,
            uniform_group: 0,
        };
        self.factorize_into(&mut f)?;
        Ok(f)
    }

    /// [`LinalgError::NotFinite`] at the first (row-major) band entry that is not a finite
    /// number.
    pub fn check_finite(&self) -> Result<(), LinalgError> {
        let (n, kd) = (self.n, self.kd);
        for i in 0..n {
            for j in i.saturating_sub(kd)..=i {
                let value = self.data[slot(kd, i, j)];
                if !value.is_finite() {
                    return Err(LinalgError::NotFinite {
                        row: i,
                        column: j,
                        value,
                    });
                }
            }
        }
        Ok(())
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
        // A non-finite entry is its own error (a NaN in a slot outside the nodes' coupling
        // used to read as "does not fit the band", a shape mismatch of equal shapes).
        self.check_finite()?;
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
        f.uniform_group = match groups.first() {
            Some(&m) if groups.iter().all(|&g| g == m) => m,
            _ => 0,
        };
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
        f.uniform_group = 0;
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

/// [`solve_kernel`] for the half-bandwidth 3 of the beam, with the same operations in the
/// same order (so bit-identical results), the last three entries of each sweep held in
/// registers and the rows as fixed-size chunks, three at a time (the window of three
/// entries then stays in the same registers): no bounds checks in the loops, and `D z = y`
/// folded into the forward sweep.
fn solve_kernel_kd3(data: &[f64], b: &mut [f64]) {
    let n = b.len();
    if n < 4 || data.len() != 4 * n {
        solve_kernel(3, data, b);
        return;
    }
    let (r0, r1, r2) = (&data[..4], &data[4..8], &data[8..12]);
    // L y = b and z = D^-1 y; `y` holds y_{i-3}, y_{i-2}, y_{i-1}. Row i (`r`, with b_i):
    // y_i, and z_i returned.
    let mut y = [b[0], 0.0, 0.0];
    y[1] = b[1] - r1[2] * y[0];
    y[2] = b[2] - (r2[1] * y[0] + r2[2] * y[1]);
    b[0] = y[0] / r0[3];
    b[1] = y[1] / r1[3];
    b[2] = y[2] / r2[3];
    let mut forward = |r: &[f64], bi: f64| -> f64 {
        let yi = bi - (r[0] * y[0] + r[1] * y[1] + r[2] * y[2]);
        y = [y[1], y[2], yi];
        yi / r[3]
    };
    let rows = data[12..].chunks_exact(12);
    let done = 3 + 3 * rows.len();
    for (r, bs) in rows.zip(b[3..].chunks_exact_mut(3)) {
        bs[0] = forward(&r[..4], bs[0]);
        bs[1] = forward(&r[4..8], bs[1]);
        bs[2] = forward(&r[8..], bs[2]);
    }
    for (r, bi) in data[4 * done..].chunks_exact(4).zip(&mut b[done..]) {
        *bi = forward(r, *bi);
    }
    // L^T x = z, the column sweep: row i subtracts L_ij x_i from x_j, j = i-3 .. i-1, rows
    // from the last up; `u` holds the partial x_i, x_{i-1}, x_{i-2}. Row i (`r`, with the
    // entry i - 3 of z): x_i returned.
    let mut u = [b[n - 1], b[n - 2], b[n - 3]];
    let mut backward = |r: &[f64], z: f64| -> f64 {
        let x = u[0];
        u = [u[1] - r[2] * x, u[2] - r[1] * x, z - r[0] * x];
        x
    };
    let b = Cell::from_mut(b).as_slice_of_cells();
    let rows = data[12..].rchunks_exact(12);
    let front = rows.remainder().len() / 4;
    for (r, (xs, zs)) in rows.zip(b[3..].rchunks_exact(3).zip(b[..n - 3].rchunks_exact(3))) {
        xs[2].set(backward(&r[8..], zs[2].get()));
        xs[1].set(backward(&r[4..8], zs[1].get()));
        xs[0].set(backward(&r[..4], zs[0].get()));
    }
    for i in (3..3 + front).rev() {
        b[i].set(backward(&data[4 * i..4 * i + 4], b[i - 3].get()));
    }
    // Rows 2 and 1 (row 0 has no strict lower part).
    let x2 = u[0];
    b[2].set(x2);
    let (u2, u3) = (u[1] - r2[2] * x2, u[2] - r2[1] * x2);
    b[1].set(u2);
    b[0].set(u3 - r1[2] * u2);
}

/// [`solve_kernel_kd3`] for a factor eliminated node pair by node pair from the far end
/// ([`BandedSym::factorize_reversed`] with groups of two, `n = 2 m`), with the pair
/// reversal `P` of [`BandedFactor::permute`] folded into the sweeps instead of two passes of
/// its own: row `i` of the elimination is entry `2 (m - 1 - i / 2) + i % 2` of `b`, so the
/// forward sweep `L D z = P b` runs over `b`'s pairs from the last to the first and writes
/// each `z_i` where it read `b_i`, and the backward sweep `L^T P x = z` runs over them from
/// the first to the last. The same operations on every entry in the same order as the two
/// permutations around [`solve_kernel_kd3`] (equal results): its first three rows,
/// which have fewer lower entries, are the general rows with a window of zeros against the
/// band's unused zero slots.
fn solve_pairs_kd3(data: &[f64], b: &mut [f64]) {
    let n = b.len();
    if n < 10 || n % 2 != 0 || data.len() != 4 * n {
        return;
    }
    // L y = P b and z = D^-1 y, two rows (`l`, pair `m - 1 - k`) for pair `k` of `b`; `y`
    // holds y_{i-3}, y_{i-2}, y_{i-1}.
    // Three pairs per round, the window's values renamed instead of moved.
    // Whole rounds on exact chunks (no end test per pair), then the one or two pairs left.
    let full = n / 6;
    let (b_rest, b3) = b.split_at_mut(n - 6 * full);
    let (d3, d_rest) = data.split_at(24 * full);
    let (mut y0, mut y1, mut y2) = (0.0, 0.0, 0.0);
    for (bs, l) in b3.rchunks_exact_mut(6).zip(d3.chunks_exact(24)) {
        let (lo, hi) = bs.split_at_mut(4);
        let (first, second) = lo.split_at_mut(2);
        let (y3, y4) = forward_pair(hi, &l[..8], [y0, y1, y2]);
        let (y5, y6) = forward_pair(second, &l[8..16], [y2, y3, y4]);
        let (y7, y8) = forward_pair(first, &l[16..], [y4, y5, y6]);
        (y0, y1, y2) = (y6, y7, y8);
    }
    for (bs, l) in b_rest.rchunks_exact_mut(2).zip(d_rest.chunks_exact(8)) {
        let (y3, y4) = forward_pair(bs, l, [y0, y1, y2]);
        (y0, y1, y2) = (y2, y3, y4);
    }
    // L^T P x = z: pair `k` of `b` holds the rows 2 (m-1-k) + 1 and + 0, taken in that
    // order; row `i` takes z_{i-3}, the entry `2k + 2` (row + 1) or `2k + 5` (row + 0),
    // neither written yet. `u` holds the partial x_i, x_{i-1}, x_{i-2}.
    let mut u = [b[1], b[0], b[3]];
    let mut backward = |r: &[f64], z: f64| -> f64 {
        let x = u[0];
        u = [u[1] - r[2] * x, u[2] - r[1] * x, z - r[0] * x];
        x
    };
    let b = Cell::from_mut(b).as_slice_of_cells();
    for ((out, (next, after)), r) in b
        .chunks_exact(2)
        .zip(b[2..].chunks_exact(2).zip(b[4..].chunks_exact(2)))
        .zip(data.rchunks_exact(8))
    {
        out[1].set(backward(&r[4..], next[0].get()));
        out[0].set(backward(&r[..4], after[1].get()));
    }
    // The last two pairs, the elimination's rows 3 .. 0: z_{i-3} lies before the start
    // (zero, against an unused zero slot) except row 3's.
    let (r, r0) = (&data[8..16], &data[..8]);
    b[n - 3].set(backward(&r[4..], b[n - 2].get()));
    b[n - 4].set(backward(&r[..4], 0.0));
    b[n - 1].set(backward(&r0[4..], 0.0));
    b[n - 2].set(backward(&r0[..4], 0.0));
}

/// One pair of [`solve_pairs_kd3`]'s forward sweep: rows `l` (two of the factor) on the
/// pair `bs` of `b`, with `y_{i-3}, y_{i-2}, y_{i-1}`; `z` into `bs`, the new `y` returned.
#[inline(always)]
fn forward_pair(bs: &mut [f64], l: &[f64], [ym3, ym2, ym1]: [f64; 3]) -> (f64, f64) {
    let y0 = bs[0] - (l[0] * ym3 + l[1] * ym2 + l[2] * ym1);
    let y1 = bs[1] - (l[4] * ym2 + l[5] * ym1 + l[6] * y0);
    bs[0] = y0 / l[3];
    bs[1] = y1 / l[7];
    (y0, y1)
}

/// The factorisation `A = L D L^T` of a [`BandedSym`]; solves are `O(n kd)` and allocate
/// nothing.
#[derive(Clone, Debug, PartialEq)]
pub struct BandedFactor {
    pub(super) n: usize,
    pub(super) kd: usize,
    /// `L` (strict lower band, unit diagonal implied) and `D` (on the diagonal slots), in
    /// the storage of [`BandedSym`].
    data: Vec<f64>,
    /// The groups of [`BandedSym::factorize_reversed`], when the factor is of the
    /// group-reversed matrix.
    groups: Option<Vec<usize>>,
    /// The size of every group when they all have one (0 otherwise).
    uniform_group: usize,
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
        if self.kd == 3 && self.uniform_group == 2 && self.n >= 10 {
            solve_pairs_kd3(&self.data, b);
            return;
        }
        self.permute(b, true);
        if self.kd == 3 {
            solve_kernel_kd3(&self.data, b);
        } else {
            solve_kernel(self.kd, &self.data, b);
        }
        self.permute(b, false);
    }

    /// The group reversal `P` (`forward`) or `P^-1` of [`BandedSym::factorize_reversed`],
    /// in place: reverse everything, then restore the order inside each group at its new
    /// place (`P`) or at its original place (`P^-1`). Groups of one size (a beam's nodes
    /// with the same free DOFs) are fixed-size chunks of the reversed vector, either way.
    fn permute(&self, b: &mut [f64], forward: bool) {
        let Some(groups) = &self.groups else {
            return;
        };
        if self.uniform_group == 2 {
            Self::permute_pairs(b);
            return;
        }
        b.reverse();
        match self.uniform_group {
            0 => {
                let mut start = 0;
                let mut restore = |m: usize| {
                    b[start..start + m].reverse();
                    start += m;
                };
                if forward {
                    groups.iter().rev().for_each(|&m| restore(m));
                } else {
                    groups.iter().for_each(|&m| restore(m));
                }
            }
            m => b.chunks_exact_mut(m).for_each(<[f64]>::reverse),
        }
    }

    /// [`BandedFactor::permute`] for groups of two (a beam's nodes `(w, theta)`), either
    /// way: the pairs exchanged end for end in one pass, each keeping its order.
    fn permute_pairs(b: &mut [f64]) {
        let half = b.len() / 4 * 2;
        let (lo, rest) = b.split_at_mut(half);
        let hi_start = rest.len() - half;
        for (x, y) in lo
            .chunks_exact_mut(2)
            .zip(rest[hi_start..].rchunks_exact_mut(2))
        {
            let (x0, x1) = (x[0], x[1]);
            x[0] = y[0];
            x[1] = y[1];
            y[0] = x0;
            y[1] = x1;
        }
    }

    /// Solves `A x = b` into a new vector (convenience wrapper of
    /// [`solve_in_place`](Self::solve_in_place)).
    pub fn solve(&self, b: &[f64]) -> Vec<f64> {
        let mut x = b.to_vec();
        self.solve_in_place(&mut x);
        x
    }
}

#[cfg(test)]
mod tests {
    use super::super::sample;
    use super::*;

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

    /// The one-pass exchange of node pairs is the group reversal's definition (reverse
    /// everything, then each pair back in order), for odd and even node counts.
    #[test]
    fn pair_exchange_is_the_group_reversal() {
        for nodes in 0..7 {
            let b: Vec<f64> = (0..2 * nodes).map(|i| i as f64).collect();
            let mut by_definition = b.clone();
            by_definition.reverse();
            by_definition.chunks_exact_mut(2).for_each(<[f64]>::reverse);
            let mut fast = b.clone();
            BandedFactor::permute_pairs(&mut fast);
            assert_eq!(fast, by_definition, "{nodes} nodes");
            BandedFactor::permute_pairs(&mut fast);
            assert_eq!(fast, b, "{nodes} nodes: an involution");
        }
    }

    /// Issue 23: a NaN where the beam couples no DOFs (`inf * 0` from an overflowed
    /// coefficient) was reported as "shape mismatch: expected size 40 / half-bandwidth 3,
    /// got 40 / 3"; both factorisations now name the entry.
    #[test]
    fn a_non_finite_entry_is_named_not_a_shape_mismatch() {
        let mut a = sample(8, 3);
        a.set(5, 2, f64::NAN);
        for r in [
            a.factorize().map(|_| ()),
            a.factorize_reversed(&[2; 4]).map(|_| ()),
        ] {
            assert_eq!(
                r.unwrap_err().to_string(),
                "entry (5, 2) of the matrix is NaN (not a finite number)"
            );
        }
        a.set(5, 2, 0.0);
        a.set(0, 0, f64::INFINITY);
        assert!(matches!(
            a.factorize(),
            Err(LinalgError::NotFinite {
                row: 0,
                column: 0,
                ..
            })
        ));
    }

    #[test]
    fn kd3_kernel_is_bit_identical_to_the_generic_one() {
        for n in 1..14 {
            let f = sample(n, 3).factorize().unwrap();
            let b: Vec<f64> = (0..n).map(|i| (i as f64 * 1.3).sin() - 0.2).collect();
            let (mut x3, mut x) = (b.clone(), b.clone());
            solve_kernel_kd3(&f.data, &mut x3);
            solve_kernel(f.kd, &f.data, &mut x);
            assert_eq!(x3, x, "n = {n}");
            // And it solves: A x = b to rounding.
            let mut r = vec![0.0; n];
            sample(n, 3).mul_vec_into(&x, &mut r);
            for i in 0..n {
                assert!((r[i] - b[i]).abs() < 1e-14, "n = {n}, row {i}");
            }
        }
    }

    /// The pair reversal folded into the sweeps gives the results of the two permutations
    /// around the kernel, for odd and even pair counts around the size where it starts.
    #[test]
    fn pair_sweeps_equal_the_permuted_kernel() {
        for n in (2..40).step_by(2) {
            let mut a = sample(n, 3);
            for i in 0..n {
                for j in i.saturating_sub(3)..i {
                    if i / 2 - j / 2 > 1 {
                        a.set(i, j, 0.0);
                    }
                }
            }
            let f = a.factorize_reversed(&vec![2; n / 2]).unwrap();
            let b: Vec<f64> = (0..n).map(|i| (i as f64 * 1.3).sin() - 0.2).collect();
            let mut expected = b.clone();
            f.permute(&mut expected, true);
            solve_kernel_kd3(&f.data, &mut expected);
            f.permute(&mut expected, false);
            let mut x = b.clone();
            f.solve_in_place(&mut x);
            assert_eq!(x, expected, "n = {n}");
            if n >= 10 {
                let mut x = b.clone();
                solve_pairs_kd3(&f.data, &mut x);
                assert_eq!(x, expected, "n = {n}, the pair sweeps themselves");
            }
            let mut r = vec![0.0; n];
            a.mul_vec_into(&x, &mut r);
            for i in 0..n {
                assert!((r[i] - b[i]).abs() < 1e-13, "n = {n}, row {i}");
            }
        }
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
        // Groups of 1 (plain reversal: the fixed-size chunk path of groups of one size) and
        // node-like groups of 2 with one single at the start (the general path).
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
}
