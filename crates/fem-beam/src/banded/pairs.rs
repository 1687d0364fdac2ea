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

/// The Newmark predictor of a step with the Rayleigh damping folded into the factorised
/// matrix (docs/theory.md section 13.5): from the last step's `q, v, a`,
/// `q^ = q + h v + ca a`, `v^ = v + cv a` and the mixed vector `x = q^ + mu v^` whose
/// product with the stiffness the step needs (`ca = h^2 (1/2 - beta)`,
/// `cv = h (1 - gamma)`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewmarkPredictor {
    /// The step `h`.
    pub h: f64,
    /// `h^2 (1/2 - beta)`.
    pub ca: f64,
    /// `h (1 - gamma)`.
    pub cv: f64,
    /// The factor `mu` of `v^` in `x`.
    pub mu: f64,
}

impl NewmarkPredictor {
    /// One entry: `(q^, v^, x)` from `(q, v, a)`, in this order of operations.
    #[inline(always)]
    pub fn entry(&self, q: f64, v: f64, a: f64) -> (f64, f64, f64) {
        let qh = q + self.h * v + self.ca * a;
        let vh = v + self.cv * a;
        (qh, vh, qh + self.mu * vh)
    }

    /// Every entry: `old = [q, v, a]` into `out = [q^, v^, x]` (the shortest length).
    pub fn predict(&self, old: [&[f64]; 3], out: [&mut [f64]; 3]) {
        let [q, v, a] = old;
        let [q_hat, v_hat, x] = out;
        for ((qh, vh), (((q, v), a), m)) in q_hat
            .iter_mut()
            .zip(v_hat.iter_mut())
            .zip(q.iter().zip(v).zip(a).zip(x.iter_mut()))
        {
            (*qh, *vh, *m) = self.entry(*q, *v, *a);
        }
    }
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
            self.edge_rows(alpha, x, b, y);
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.band.mul_add_to(alpha, x, b, y);
    }

    /// The Newmark predictor and the step's product in one pass: `p.predict(old, out)`
    /// (`out = [q^, v^, x]`, see [`NewmarkPredictor::predict`]) and then
    /// `y = b - A x` ([`PairedKd3::mul_add_to`] with `alpha = -1`), bit-identical to the
    /// two calls one after the other. Each pair of rows forms the two entries of `x` it is
    /// the first to need (two SSE2 lanes, each lane the operations of
    /// [`NewmarkPredictor::entry`]) and keeps the seven entries it reads in registers
    /// instead of reading them back; no allocation.
    ///
    /// # Panics
    /// If a vector does not have length [`BandedSym::size`].
    pub fn predict_mul_sub(
        &self,
        p: &NewmarkPredictor,
        old: [&[f64]; 3],
        out: [&mut [f64]; 3],
        b: &[f64],
        y: &mut [f64],
    ) {
        let n = self.band.n;
        assert!(
            old.iter().all(|s| s.len() == n)
                && out.iter().all(|s| s.len() == n)
                && b.len() == n
                && y.len() == n,
            "PairedKd3::predict_mul_sub: a vector has the wrong length"
        );
        let [q, v, a] = old;
        let [q_hat, v_hat, x] = out;
        #[cfg(target_arch = "x86_64")]
        {
            let done = sse2::predict_pairs(
                &self.coef,
                p,
                [q, v, a],
                [&mut *q_hat, &mut *v_hat, &mut *x],
                b,
                y,
            );
            if done > 0 {
                // The entries past the last pair's (none or one), then the rows the pairs
                // leave out.
                p.predict(
                    [&q[done..], &v[done..], &a[done..]],
                    [&mut q_hat[done..], &mut v_hat[done..], &mut x[done..]],
                );
                self.edge_rows(-1.0, x, b, y);
                return;
            }
        }
        p.predict([q, v, a], [q_hat, v_hat, &mut *x]);
        self.mul_add_to(-1.0, x, b, y);
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

    /// The rows the pairs leave out — `0 .. 3` and `3 + 2m .. n` (three or four) — of
    /// `y = b + alpha A x`, each with the operations of the module documentation in its order,
    /// written out on fixed-size windows of `x` and the band (no bounds tests, the loops
    /// unrolled): about 12 instructions a row where a row's general loops took about 70.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    #[inline(always)]
    fn edge_rows(&self, alpha: f64, x: &[f64], b: &[f64], y: &mut [f64]) {
        let (n, d) = (self.band.n, &self.band.data);
        // Rows 0 .. 2: their lower terms from column 0, every transposed term inside
        // (n >= 8).
        let xs: &[f64; 6] = x[..6].try_into().expect("n >= 8");
        let ds: &[f64; 24] = d[..24].try_into().expect("n >= 8");
        for i in 0..3 {
            let r = &ds[4 * i..4 * i + 4];
            let mut acc = r[3] * xs[i];
            for k in 3 - i..3 {
                acc += r[k] * xs[i + k - 3];
            }
            let mut v = b[i] + alpha * acc;
            for k in 1..=3 {
                v += ds[4 * (i + k) + 3 - k] * (alpha * xs[i + k]);
            }
            y[i] = v;
        }
        // The last rows on the window of the last seven entries (local row `l` is row
        // `n - 7 + l`): every lower term inside, the transposed ones up to row n - 1.
        let first = 7 - (n - 3 - 2 * (self.coef.len() / PER_PAIR));
        let base = n - 7;
        let xs: &[f64; 7] = x[base..].try_into().expect("seven entries");
        let ds: &[f64; 28] = d[4 * base..].try_into().expect("seven rows");
        let (bs, ys) = (&b[base..], &mut y[base..]);
        for l in 3..7 {
            if l < first {
                continue;
            }
            let r = &ds[4 * l..4 * l + 4];
            let mut acc = r[3] * xs[l];
            for k in 0..3 {
                acc += r[k] * xs[l + k - 3];
            }
            let mut v = bs[l] + alpha * acc;
            for k in 1..=3 {
                if l + k < 7 {
                    v += ds[4 * (l + k) + 3 - k] * (alpha * xs[l + k]);
                }
            }
            ys[l] = v;
        }
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
        __m128d, _mm_add_pd, _mm_cvtsd_f64, _mm_mul_pd, _mm_set_pd, _mm_set1_pd, _mm_shuffle_pd,
        _mm_sub_pd, _mm_unpackhi_pd,
    };

    use super::{NewmarkPredictor, PER_PAIR};

    /// `[lo[1], hi[0]]`: the two entries between two adjacent even-start pairs.
    #[inline(always)]
    fn middle(lo: __m128d, hi: __m128d) -> __m128d {
        // SAFETY: SSE2 is in the x86-64 baseline.
        unsafe { _mm_shuffle_pd::<0b01>(lo, hi) }
    }

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

    /// [`pairs`] with `alpha = -1` on `x = p`'s mixed predictor, formed here: the entries
    /// `0 .. 6` before the first pair, entries `i + 3, i + 4` for the pair of rows `i, i + 1`
    /// (`[q^, v^, x]` into `out`, each lane the operations of
    /// [`NewmarkPredictor::entry`]). The pair's seven `x` registers are those of the last
    /// pair moved by one (the even-start ones `[x_{2k}, x_{2k+1}]`, ...) or the middle of
    /// two even-start ones (the odd-start ones), not read back from memory. Returns the
    /// number of leading entries predicted (0, nothing written, when `n < 8` or the lengths
    /// differ).
    #[inline(always)]
    pub(super) fn predict_pairs(
        coef: &[[f64; 2]],
        p: &NewmarkPredictor,
        old: [&[f64]; 3],
        out: [&mut [f64]; 3],
        b: &[f64],
        y: &mut [f64],
    ) -> usize {
        let [q, v, a] = old;
        let [q_hat, v_hat, x] = out;
        let n = q.len();
        if n < 8
            || [
                v.len(),
                a.len(),
                q_hat.len(),
                v_hat.len(),
                x.len(),
                b.len(),
                y.len(),
            ]
            .iter()
            .any(|&len| len != n)
        {
            return 0;
        }
        // SAFETY: SSE2 is in the x86-64 baseline.
        let (h, ca, cv, mu) = unsafe {
            (
                _mm_set1_pd(p.h),
                _mm_set1_pd(p.ca),
                _mm_set1_pd(p.cv),
                _mm_set1_pd(p.mu),
            )
        };
        let k = [h, ca, cv, mu];
        // Pair k (rows 2k + 3, 2k + 4): `e0, e1, e2` = x from entries 2k, 2k + 2, 2k + 4;
        // `om2, o0` from 2k + 1, 2k + 3.
        let mut first = [0.0; 3].map(|_| None);
        for (j, e) in first.iter_mut().enumerate() {
            let Some(c) = chunk_at([q, v, a], [&mut *q_hat, &mut *v_hat, &mut *x], 2 * j) else {
                return 0;
            };
            let ((((q, v), a), qh), (vh, xs)) = c;
            *e = Some(entries(k, q, v, a, [qh, vh, xs]));
        }
        let [Some(mut e0), Some(mut e1), Some(mut e2)] = first else {
            return 0;
        };
        let (mut om2, mut o0) = (middle(e0, e1), middle(e1, e2));
        let m = (coef.len() / PER_PAIR).min((n - 6) / 2);
        let done = 6 + 2 * m;
        // Six pairs per round on exact chunks of 12 entries (no end test per pair), the
        // registers renamed instead of moved (the even-start ones repeat every three pairs,
        // the odd-start ones every two); then the pairs left one by one.
        let full = m / 6;
        let end = 12 * full;
        let rounds = coef[..PER_PAIR * 6 * full]
            .chunks_exact(6 * PER_PAIR)
            .zip(
                q[6..6 + end]
                    .chunks_exact(12)
                    .zip(v[6..6 + end].chunks_exact(12))
                    .zip(a[6..6 + end].chunks_exact(12))
                    .zip(q_hat[6..6 + end].chunks_exact_mut(12))
                    .zip(
                        v_hat[6..6 + end]
                            .chunks_exact_mut(12)
                            .zip(x[6..6 + end].chunks_exact_mut(12)),
                    ),
            )
            .zip(
                b[3..3 + end]
                    .chunks_exact(12)
                    .zip(y[3..3 + end].chunks_exact_mut(12)),
            );
        for ((c, ((((q, v), a), qh), (vh, xs))), (bs, ys)) in rounds {
            // Pair `j` of the round: its coefficients and its two entries of each vector.
            macro_rules! p {
                ($j:expr) => {{
                    let r = 2 * $j..2 * $j + 2;
                    (
                        (
                            &c[PER_PAIR * $j..PER_PAIR * ($j + 1)],
                            (
                                (
                                    ((&q[r.clone()], &v[r.clone()]), &a[r.clone()]),
                                    &mut qh[r.clone()],
                                ),
                                (&mut vh[r.clone()], &mut xs[r.clone()]),
                            ),
                        ),
                        (&bs[r.clone()], &mut ys[r]),
                    )
                }};
            }
            let (e3, o2) = pair(k, p!(0), [e0, om2, e1, o0, e2]);
            let (e4, o3) = pair(k, p!(1), [e1, o0, e2, o2, e3]);
            let (e5, o4) = pair(k, p!(2), [e2, o2, e3, o3, e4]);
            let (e6, o5) = pair(k, p!(3), [e3, o3, e4, o4, e5]);
            let (e7, o6) = pair(k, p!(4), [e4, o4, e5, o5, e6]);
            let (e8, o7) = pair(k, p!(5), [e5, o5, e6, o6, e7]);
            (e0, e1, e2, om2, o0) = (e6, e7, e8, o6, o7);
        }
        let chunks = q[6 + end..]
            .chunks_exact(2)
            .zip(v[6 + end..].chunks_exact(2))
            .zip(a[6 + end..].chunks_exact(2))
            .zip(q_hat[6 + end..].chunks_exact_mut(2))
            .zip(
                v_hat[6 + end..]
                    .chunks_exact_mut(2)
                    .zip(x[6 + end..].chunks_exact_mut(2)),
            );
        let vectors = b[3 + end..]
            .chunks_exact(2)
            .zip(y[3 + end..].chunks_exact_mut(2));
        let rest = coef[PER_PAIR * 6 * full..PER_PAIR * m]
            .chunks_exact(PER_PAIR)
            .zip(chunks)
            .zip(vectors);
        for p in rest {
            let (e3, o2) = pair(k, p, [e0, om2, e1, o0, e2]);
            (e0, e1, e2, om2, o0) = (e1, e2, e3, o0, o2);
        }
        done
    }

    /// The chunk of two entries from `i` of `[q, v, a]` and `[q^, v^, x]` (`None` past
    /// the end).
    #[inline(always)]
    fn chunk_at<'a>(
        [q, v, a]: [&'a [f64]; 3],
        [qh, vh, xs]: [&'a mut [f64]; 3],
        i: usize,
    ) -> Option<Chunk<'a>> {
        let r = i..i + 2;
        Some((
            (
                ((q.get(r.clone())?, v.get(r.clone())?), a.get(r.clone())?),
                qh.get_mut(r.clone())?,
            ),
            (vh.get_mut(r.clone())?, xs.get_mut(r)?),
        ))
    }

    /// The chunks of two entries of `[q, v, a]` and `[q^, (v^, x)]`.
    type Chunk<'a> = (
        (((&'a [f64], &'a [f64]), &'a [f64]), &'a mut [f64]),
        (&'a mut [f64], &'a mut [f64]),
    );

    /// One pair's coefficients, its predictor chunks and its entries of `b` and `y`.
    type Pair<'a> = ((&'a [[f64; 2]], Chunk<'a>), (&'a [f64], &'a mut [f64]));

    /// One pair of rows `i, i + 1` of [`predict_pairs`] (`k = [h, ca, cv, mu]`): its
    /// `x_{i+3}, x_{i+4}` predicted from `next`, its rows of `b - A x` stored; from the
    /// registers `[x_{i-3}, x_{i-2}, x_{i-1}, x_i, x_{i+1}]` (even, odd, even, odd, even
    /// start), the two new ones `(x_{i+3} (even), x_{i+2} (odd))` returned.
    #[inline(always)]
    fn pair(
        k: [__m128d; 4],
        ((c, next), (bs, ys)): Pair<'_>,
        [xm3, xm2, xm1, x0, x1]: [__m128d; 5],
    ) -> (__m128d, __m128d) {
        let ((((q, v), a), qh), (vh, xs)) = next;
        let x3 = entries(k, q, v, a, [qh, vh, xs]);
        let x2 = middle(x1, x3);
        let mut acc = mul(lanes_in(c[0]), x0);
        acc = add(acc, mul(lanes_in(c[1]), xm3));
        acc = add(acc, mul(lanes_in(c[2]), xm2));
        acc = add(acc, mul(lanes_in(c[3]), xm1));
        let mut w = sub(load(bs), acc);
        w = sub(w, mul(lanes_in(c[4]), x1));
        w = sub(w, mul(lanes_in(c[5]), x2));
        w = sub(w, mul(lanes_in(c[6]), x3));
        store(w, ys);
        (x3, x2)
    }

    /// Two entries of the predictor (`c = [h, ca, cv, mu]` in both lanes): `q^, v^, x`
    /// stored into `out`, `x` returned.
    #[inline(always)]
    fn entries(c: [__m128d; 4], q: &[f64], v: &[f64], a: &[f64], out: [&mut [f64]; 3]) -> __m128d {
        let [h, ca, cv, mu] = c;
        let (qv, vv, av) = (load(q), load(v), load(a));
        let qhat = add(add(qv, mul(h, vv)), mul(ca, av));
        let vhat = add(vv, mul(cv, av));
        let xv = add(qhat, mul(mu, vhat));
        let [qh, vh, xs] = out;
        store(qhat, qh);
        store(vhat, vh);
        store(xv, xs);
        xv
    }

    /// One pair's two terms `x_i (A_ii x_i + 2 (A_{i,i-3} x_{i-3} + A_{i,i-2} x_{i-2} +
    /// A_{i,i-1} x_{i-1}))` from the registers `[x_{i-3}, x_{i-2}, x_{i-1}, x_i]`.
    #[inline(always)]
    fn form_pair(two: __m128d, c: &[[f64; 2]], [xm3, xm2, xm1, x0]: [__m128d; 4]) -> __m128d {
        let mut off = mul(lanes_in(c[1]), xm3);
        off = add(off, mul(lanes_in(c[2]), xm2));
        off = add(off, mul(lanes_in(c[3]), xm1));
        mul(x0, add(mul(lanes_in(c[0]), x0), mul(two, off)))
    }

    /// `s + t[0] + t[1]`, left to right.
    #[inline(always)]
    fn add_lanes(s: f64, t: __m128d) -> f64 {
        // SAFETY: SSE2 is in the x86-64 baseline.
        let (lo, hi) = unsafe { (_mm_cvtsd_f64(t), _mm_cvtsd_f64(_mm_unpackhi_pd(t, t))) };
        s + lo + hi
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
        // Pair k (rows 2k + 3, 2k + 4) reads x from entries 2k, 2k + 1, 2k + 2, 2k + 3: the
        // even-start registers 2k, 2k + 2 and the new 2k + 4, the odd-start ones between
        // them; three pairs per round, the registers renamed instead of moved.
        // Whole rounds on exact chunks (no test per pair), then the one or two left.
        let full = coef.len() / PER_PAIR / 3;
        let (c3, c_rest) = coef.split_at(3 * PER_PAIR * full);
        let (x3, x_rest) = x[4..].split_at(6 * full);
        let (mut e0, mut e1) = (load(&x[..2]), load(&x[2..4]));
        let mut om2 = middle(e0, e1);
        for (c, e) in c3.chunks_exact(3 * PER_PAIR).zip(x3.chunks_exact(6)) {
            let (c0, c1, c2) = (
                &c[..PER_PAIR],
                &c[PER_PAIR..2 * PER_PAIR],
                &c[2 * PER_PAIR..],
            );
            let e2 = load(&e[..2]);
            let o0 = middle(e1, e2);
            s = add_lanes(s, form_pair(two, c0, [e0, om2, e1, o0]));
            let e3 = load(&e[2..4]);
            let o1 = middle(e2, e3);
            s = add_lanes(s, form_pair(two, c1, [e1, o0, e2, o1]));
            let e4 = load(&e[4..]);
            let o2 = middle(e3, e4);
            s = add_lanes(s, form_pair(two, c2, [e2, o1, e3, o2]));
            (e0, e1, om2) = (e3, e4, o2);
        }
        for (c, e) in c_rest.chunks_exact(PER_PAIR).zip(x_rest.chunks_exact(2)) {
            let e2 = load(e);
            let o0 = middle(e1, e2);
            s = add_lanes(s, form_pair(two, c, [e0, om2, e1, o0]));
            (e0, e1, om2) = (e1, e2, o0);
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
            // The predictor fused into the product: the separate predictor pass then the
            // product, bit for bit (q^, v^, x and y).
            let pred = NewmarkPredictor {
                h: 1e-4,
                ca: 0.25e-8 * 0.9,
                cv: 0.5e-4 * 1.1,
                mu: 3.7e-3,
            };
            let old: Vec<Vec<f64>> = (0..3)
                .map(|k| {
                    (0..n)
                        .map(|i| ((i + 7 * k) as f64 * 0.37).sin() * (1.0 + k as f64))
                        .collect()
                })
                .collect();
            let mut want = vec![vec![f64::NAN; n]; 4];
            let [wq, wv, wx, wy] = &mut want[..] else {
                unreachable!()
            };
            pred.predict([&old[0], &old[1], &old[2]], [wq, wv, &mut *wx]);
            p.mul_add_to(-1.0, wx, &b, wy);
            let mut got = vec![vec![f64::NAN; n]; 4];
            let [gq, gv, gx, gy] = &mut got[..] else {
                unreachable!()
            };
            p.predict_mul_sub(&pred, [&old[0], &old[1], &old[2]], [gq, gv, gx], &b, gy);
            assert_eq!(got, want, "n = {n}: fused predictor");
            for i in 0..n {
                let (qh, vh, xm) = pred.entry(old[0][i], old[1][i], old[2][i]);
                assert_eq!(
                    [got[0][i], got[1][i], got[2][i]],
                    [qh, vh, xm],
                    "n = {n}, {i}"
                );
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
