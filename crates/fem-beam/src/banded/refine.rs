//! Iterative refinement: the residual `b - A x` in double-double arithmetic
//! ([`BandedSym::residual_into`]) and refined solves with a [`BandedFactor`]
//! ([`BandedFactor::solve_refined`], or [`BandedFactor::refine_with`] for a residual the
//! caller computes, e.g. element by element).

use super::{BandedFactor, BandedSym};

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

impl BandedFactor {
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
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
