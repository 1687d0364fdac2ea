//! The band of a half-bandwidth-3 matrix rearranged for products two rows at a time
//! ([`PairedKd3`]): the product `y = b + alpha A x` with both rows of a pair in the two
//! lanes of one SSE2 register, each entry's operations those of
//! [`BandedSym::mul_add_to`] in the same order (bit-identical); and the quadratic form
//! `x^T A x` with the interior rows' terms two at a time, bit-identical to
//! [`BandedSym::quadratic_form`].
//!
//! Row `i` of `y = b + alpha A x` (the order of [`BandedSym::mul_add_to`]'s kernel, which
//! takes the band row by row and adds each row's transposed entries to the three rows above
//! it) is
//!
//! ```text
//!   acc = A[i,i] x_i + A[i,i-3] x_{i-3} + A[i,i-2] x_{i-2} + A[i,i-1] x_{i-1}   (left to right)
//!   y_i = b_i + alpha acc + A[i+1,i] (alpha x_{i+1}) + A[i+2,i] (alpha x_{i+2})
//!             + A[i+3,i] (alpha x_{i+3})                                       (left to right)
//! ```
//!
//! (the terms whose column is outside the matrix left out). For the rows with all seven
//! terms (`3 <= i <= n - 4`) rows `i` and `i + 1` have the same operations on different
//! numbers: the pair's seven coefficients are stored lane by lane (`[A[i,i], A[i+1,i+1]]`,
//! ...), and `[x_{i+k}, x_{i+1+k}]` are two adjacent entries of `x`. The first three rows
//! and the last three or four are taken one by one.

use super::BandedSym;

/// The coefficients of one pair of rows: the diagonal, the three lower entries, the three
/// transposed entries from the rows below, each `[row i, row i + 1]`.
const PER_PAIR: usize = 7;

/// A half-bandwidth-3 [`BandedSym`] (`n >= 8`) with its interior rows' coefficients
/// stored two rows at a time for [`PairedKd3::mul_add_to`] (7/4 of the band's storage
/// besides a copy of the band).
#[derive(Clone, Debug, PartialEq)]
pub struct PairedKd3 {
    band: BandedSym,
    /// Pair `k` (rows `3 + 2k`, `4 + 2k`): `PER_PAIR` lane pairs.
    coef: Vec<[f64; 2]>,
}

impl PairedKd3 {
    /// The paired form of `a`; `None` unless `a` has half-bandwidth 3 and at least 8 rows.
    pub fn new(a: &BandedSym) -> Option<PairedKd3> {
        let n = a.n;
        if a.kd != 3 || n < 8 || a.data.len() != 4 * n {
            return None;
        }
        let d = |r: usize, k: usize| a.data[4 * r + k];
        let pairs = (n - 6) / 2;
        let mut coef = Vec::with_capacity(PER_PAIR * pairs);
        for p in 0..pairs {
            let i = 3 + 2 * p;
            coef.extend_from_slice(&[
                [d(i, 3), d(i + 1, 3)],
                [d(i, 0), d(i + 1, 0)],
                [d(i, 1), d(i + 1, 1)],
                [d(i, 2), d(i + 1, 2)],
                [d(i + 1, 2), d(i + 2, 2)],
                [d(i + 2, 1), d(i + 3, 1)],
                [d(i + 3, 0), d(i + 4, 0)],
            ]);
        }
        Some(PairedKd3 {
            band: a.clone(),
            coef,
        })
    }

    /// The matrix.
    pub fn band(&self) -> &BandedSym {
        &self.band
    }

    /// `y = b + alpha A x`, bit-identical to [`BandedSym::mul_add_to`]; no allocation.
    ///
    /// # Panics
    /// If `x`, `b` or `y` does not have length [`BandedSym::size`].
    pub fn mul_add_to(&self, alpha: f64, x: &[f64], b: &[f64], y: &mut [f64]) {
        let n = self.band.n;
        assert!(
            x.len() == n && b.len() == n && y.len() == n,
            "PairedKd3::mul_add_to: a vector has the wrong length"
        );
        #[cfg(target_arch = "x86_64")]
        {
            if alpha == -1.0 {
                sse2::pairs::<true>(&self.coef, -1.0, x, b, y);
            } else {
                sse2::pairs::<false>(&self.coef, alpha, x, b, y);
            }
            let tail = 3 + 2 * (self.coef.len() / PER_PAIR);
            for i in (0..3).chain(tail..n) {
                y[i] = self.row(alpha, x, b, i);
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.band.mul_add_to(alpha, x, b, y);
    }

    /// `x^T A x`, bit-identical to [`BandedSym::quadratic_form`]: the rows' terms
    /// `x_i (A_ii x_i + 2 sum_j A_ij x_j)` of the interior pairs computed two at a time
    /// (each with its operations in the same order), added to the sum one by one in row
    /// order.
    ///
    /// # Panics
    /// If `x` does not have length [`BandedSym::size`].
    pub fn quadratic_form(&self, x: &[f64]) -> f64 {
        let n = self.band.n;
        assert_eq!(
            x.len(),
            n,
            "PairedKd3::quadratic_form: x has the wrong length"
        );
        #[cfg(target_arch = "x86_64")]
        {
            let d = &self.band.data;
            let (r1, r2) = (&d[4..8], &d[8..12]);
            // Rows 0 .. 2 as in the band's own kernel.
            let mut s = 0.0;
            s += x[0] * (d[3] * x[0] + 2.0 * 0.0);
            s += x[1] * (r1[3] * x[1] + 2.0 * (0.0 + r1[2] * x[0]));
            s += x[2] * (r2[3] * x[2] + 2.0 * (0.0 + r2[1] * x[0] + r2[2] * x[1]));
            s = sse2::quadratic_pairs(&self.coef, x, s);
            let tail = 3 + 2 * (self.coef.len() / PER_PAIR);
            for ((r, xi), w) in d[4 * tail..]
                .chunks_exact(4)
                .zip(&x[tail..])
                .zip(x[tail - 3..].windows(3))
            {
                let off = r[0] * w[0] + r[1] * w[1] + r[2] * w[2];
                s += xi * (r[3] * xi + 2.0 * off);
            }
            s
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.band.quadratic_form(x)
    }

    /// Row `i` of `b + alpha A x` alone (the order of the module documentation).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    fn row(&self, alpha: f64, x: &[f64], b: &[f64], i: usize) -> f64 {
        let (n, d) = (self.band.n, &self.band.data);
        let r = &d[4 * i..4 * i + 4];
        let mut acc = r[3] * x[i];
        for k in 3 - i.min(3)..3 {
            acc += r[k] * x[i + k - 3];
        }
        let mut v = b[i] + alpha * acc;
        for k in 1..=3 {
            if i + k < n {
                v += d[4 * (i + k) + 3 - k] * (alpha * x[i + k]);
            }
        }
        v
    }
}

/// The pairs' kernel on SSE2 registers.
///
/// SSE2 is part of the x86-64 baseline: the intrinsics are always available (the numbers go
/// in with `_mm_set_pd` and come out with `_mm_cvtsd_f64`, no pointer is involved).
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod sse2 {
    use std::arch::x86_64::{
        __m128d, _mm_add_pd, _mm_cvtsd_f64, _mm_mul_pd, _mm_set_pd, _mm_set1_pd, _mm_sub_pd,
        _mm_unpackhi_pd,
    };

    use super::PER_PAIR;

    #[inline(always)]
    fn add(a: __m128d, b: __m128d) -> __m128d {
        // SAFETY: SSE2 is in the x86-64 baseline.
        unsafe { _mm_add_pd(a, b) }
    }

    #[inline(always)]
    fn sub(a: __m128d, b: __m128d) -> __m128d {
        // SAFETY: SSE2 is in the x86-64 baseline.
        unsafe { _mm_sub_pd(a, b) }
    }

    #[inline(always)]
    fn mul(a: __m128d, b: __m128d) -> __m128d {
        // SAFETY: SSE2 is in the x86-64 baseline.
        unsafe { _mm_mul_pd(a, b) }
    }

    /// The register `[s[0], s[1]]` (`s` of two entries).
    #[inline(always)]
    fn load(s: &[f64]) -> __m128d {
        // SAFETY: SSE2 is in the x86-64 baseline.
        unsafe { _mm_set_pd(s[1], s[0]) }
    }

    /// The register `c`.
    #[inline(always)]
    fn lanes_in(c: [f64; 2]) -> __m128d {
        // SAFETY: SSE2 is in the x86-64 baseline.
        unsafe { _mm_set_pd(c[1], c[0]) }
    }

    /// Both lanes into `out` (two entries).
    #[inline(always)]
    fn store(v: __m128d, out: &mut [f64]) {
        // SAFETY: SSE2 is in the x86-64 baseline.
        let (lo, hi) = unsafe { (_mm_cvtsd_f64(v), _mm_cvtsd_f64(_mm_unpackhi_pd(v, v))) };
        out[0] = lo;
        out[1] = hi;
    }

    /// Rows `3 .. 3 + 2 m` of `y = b + alpha A x` (`m` pairs in `coef`), each pair's two
    /// rows in the two lanes. `MINUS_ONE` (`alpha = -1`): `b + (-1) acc` is `b - acc` and
    /// `v + c ((-1) x)` is `v - c x`, exactly, without the products with `alpha`.
    #[inline(always)]
    pub(super) fn pairs<const MINUS_ONE: bool>(
        coef: &[[f64; 2]],
        alpha: f64,
        x: &[f64],
        b: &[f64],
        y: &mut [f64],
    ) {
        if x.len() < 8 || b.len() < 3 || y.len() < 3 {
            return;
        }
        // SAFETY: SSE2 is in the x86-64 baseline.
        let al = unsafe { _mm_set1_pd(alpha) };
        // Pair k, rows i = 3 + 2k and i + 1: `[x_{i+j}, x_{i+1+j}]` starts at entry
        // 2k + 3 + j, even (`e`) for j = -3, -1, 1, 3 and odd (`o`) for j = -2, 0, 2.
        let even = x
            .chunks_exact(2)
            .zip(x[2..].chunks_exact(2))
            .zip(x[4..].chunks_exact(2).zip(x[6..].chunks_exact(2)));
        let odd = x[1..]
            .chunks_exact(2)
            .zip(x[3..].chunks_exact(2))
            .zip(x[5..].chunks_exact(2));
        let vectors = b[3..].chunks_exact(2).zip(y[3..].chunks_exact_mut(2));
        for (((c, ((xm3, xm1), (x1, x3))), ((xm2, x0), x2)), (bs, ys)) in
            coef.chunks_exact(PER_PAIR).zip(even).zip(odd).zip(vectors)
        {
            let mut acc = mul(lanes_in(c[0]), load(x0));
            acc = add(acc, mul(lanes_in(c[1]), load(xm3)));
            acc = add(acc, mul(lanes_in(c[2]), load(xm2)));
            acc = add(acc, mul(lanes_in(c[3]), load(xm1)));
            let v = if MINUS_ONE {
                let mut v = sub(load(bs), acc);
                v = sub(v, mul(lanes_in(c[4]), load(x1)));
                v = sub(v, mul(lanes_in(c[5]), load(x2)));
                sub(v, mul(lanes_in(c[6]), load(x3)))
            } else {
                let mut v = add(load(bs), mul(al, acc));
                v = add(v, mul(lanes_in(c[4]), mul(al, load(x1))));
                v = add(v, mul(lanes_in(c[5]), mul(al, load(x2))));
                add(v, mul(lanes_in(c[6]), mul(al, load(x3))))
            };
            store(v, ys);
        }
    }

    /// `s` plus the terms `x_i (A_ii x_i + 2 (A_{i,i-3} x_{i-3} + A_{i,i-2} x_{i-2} +
    /// A_{i,i-1} x_{i-1}))` of rows `3 .. 3 + 2 m`, each pair's two terms in the two lanes,
    /// added to `s` in row order.
    #[inline(always)]
    pub(super) fn quadratic_pairs(coef: &[[f64; 2]], x: &[f64], mut s: f64) -> f64 {
        if x.len() < 8 {
            return s;
        }
        // SAFETY: SSE2 is in the x86-64 baseline.
        let two = unsafe { _mm_set1_pd(2.0) };
        let even = x.chunks_exact(2).zip(x[2..].chunks_exact(2));
        let odd = x[1..].chunks_exact(2).zip(x[3..].chunks_exact(2));
        for ((c, (xm3, xm1)), (xm2, x0)) in coef.chunks_exact(PER_PAIR).zip(even).zip(odd) {
            let x0 = load(x0);
            let mut off = mul(lanes_in(c[1]), load(xm3));
            off = add(off, mul(lanes_in(c[2]), load(xm2)));
            off = add(off, mul(lanes_in(c[3]), load(xm1)));
            let t = mul(x0, add(mul(lanes_in(c[0]), x0), mul(two, off)));
            // SAFETY: SSE2 is in the x86-64 baseline.
            let (lo, hi) = unsafe { (_mm_cvtsd_f64(t), _mm_cvtsd_f64(_mm_unpackhi_pd(t, t))) };
            s += lo;
            s += hi;
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::super::sample;
    use super::*;

    #[test]
    fn pairs_are_bit_identical_to_the_band_product() {
        assert!(PairedKd3::new(&sample(7, 3)).is_none());
        assert!(PairedKd3::new(&sample(20, 2)).is_none());
        for n in 8..41 {
            let a = sample(n, 3);
            let p = PairedKd3::new(&a).expect("kd = 3, n >= 8");
            assert_eq!(p.band(), &a);
            let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.9).cos() + 0.1).collect();
            let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.4).sin()).collect();
            for alpha in [-1.0, -0.7, 2.5] {
                let (mut want, mut got) = (vec![f64::NAN; n], vec![f64::NAN; n]);
                a.mul_add_to(alpha, &x, &b, &mut want);
                p.mul_add_to(alpha, &x, &b, &mut got);
                assert_eq!(got, want, "n = {n}, alpha = {alpha}");
                let mut general = b.clone();
                super::super::storage::mul_add_kernel(3, &a.data, alpha, &x, &mut general);
                assert_eq!(got, general, "n = {n}, alpha = {alpha}");
            }
            assert_eq!(p.quadratic_form(&x), a.quadratic_form(&x), "n = {n}");
            let mut general = 0.0;
            for i in 0..n {
                let row = &a.data[i * 4..(i + 1) * 4];
                let mut off = 0.0;
                for j in i.saturating_sub(3)..i {
                    off += row[3 + j - i] * x[j];
                }
                general += x[i] * (row[3] * x[i] + 2.0 * off);
            }
            assert_eq!(p.quadratic_form(&x), general, "n = {n}");
        }
    }
}
