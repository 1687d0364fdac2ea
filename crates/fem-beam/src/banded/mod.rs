//! Banded symmetric matrices and their LDL^T factorisation (docs/theory.md section 4: the beam
//! matrices are banded, half-bandwidth 3 with nodal ordering, so storage, products and
//! solves are O(n)). One file per operation:
//!
//! - [`storage`]: the band storage [`BandedSym`], element access and products;
//! - [`ldlt`]: the factorisation `A = L D L^T` ([`BandedFactor`]), its solves, and the
//!   Sturm count of negative pivots (same elimination kernel);
//! - [`pairs`]: [`PairedKd3`], the half-bandwidth-3 band two rows at a time for the
//!   step's product (SSE2 lanes, bit-identical to [`BandedSym::mul_add_to`]), with the
//!   Newmark predictor ([`NewmarkPredictor`]) formed in the same pass;
//! - [`refine`]: the double-double residual `b - A x` and iteratively refined solves.
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
//!
//! Kernels are `#[inline(always)]` and called with a literal `kd` for the beam's
//! half-bandwidth 3, which gives a specialised copy; row `i` of `data` is
//! `data[i*w .. (i+1)*w]` (`w = kd + 1`), its strict lower part (columns `i - len .. i`,
//! `len = min(i, kd)`) is `row[kd - len .. kd]`.

mod ldlt;
mod pairs;
mod refine;
mod storage;

pub use ldlt::BandedFactor;
pub use pairs::{NewmarkPredictor, PairedKd3};
pub use storage::BandedSym;

/// Index of `A[i, j]` (`j <= i`, `i - j <= kd`) in the band storage.
#[inline]
fn slot(kd: usize, i: usize, j: usize) -> usize {
    i * (kd + 1) + kd + j - i
}

/// A diagonally dominant (hence SPD) banded test matrix.
#[cfg(test)]
fn sample(n: usize, kd: usize) -> BandedSym {
    let mut a = BandedSym::zeros(n, kd);
    for i in 0..n {
        for j in i.saturating_sub(kd)..i {
            a.set(i, j, ((i * 7 + j * 3) % 5) as f64 * 0.1 - 0.2);
        }
        a.set(i, i, 2.0 + kd as f64);
    }
    a
}
