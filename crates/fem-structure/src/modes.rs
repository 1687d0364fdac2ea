//! The lowest natural modes `K phi = omega^2 M phi` of a sparse model by shift-invert
//! subspace iteration with Rayleigh–Ritz projection (docs/theory.md section 13.1):
//!
//! ```text
//! K Y = M X,   K_p = Y^T (M X),   M_p = Y^T (M Y),   K_p Q = M_p Q Lambda,   X <- Y Q,  M X <- (M Y) Q
//! ```
//!
//! with a block of `p = min(n, max(2 k, k + 8))` vectors from a deterministic start. The
//! projected stiffness uses `Y^T K Y = Y^T M X`: no product with the ill-conditioned `K`,
//! whose rounding (`eps |K|` absolute) would swamp the low eigenvalues. One product with
//! `M` per iteration, on the whole block at once ([`SparseSym::mul_rows_add_into`]); the
//! block's columns are scaled to unit `M`-norm for the small Cholesky of `M_p`.
//! Converged when every wanted mode's inverse-iteration residual is below [`MODE_TOL`],
//! or when the residuals have stalled at the solves' rounding floor with each mode's
//! eigenvalue error (the residual squared) within its [`rounding_floor`]; capped at
//! [`MAX_ITERATIONS`]. With `p = n` the block spans the space: the dense pencil is solved
//! at once.

use nalgebra::{DMatrix, DVector, SymmetricEigen};

use crate::error::StructureError;
use crate::sparse::SparseSym;

/// Most subspace iterations.
pub const MAX_ITERATIONS: usize = 500;

/// Convergence tolerance: the `M`-norm residual of the inverse iteration
/// `|lambda K^-1 M x - x|_M` of a unit-modal-mass vector (eigenvalues then exact to about
/// its square, i.e. to rounding).
pub const MODE_TOL: f64 = 1e-10;

/// Iterations over which a residual above [`MODE_TOL`] that has not halved counts as
/// stalled at the rounding floor of the solves.
pub const STALL_WINDOW: usize = 10;

/// The relative change of a unit-modal-mass mode's eigenvalue `lambda = x^T K x` that a
/// rounding of every stored entry of `K` and `M` by one part in `1 / eps` can cause (to
/// first order): `eps (|x|^T |K| |x| + lambda |x|^T |M| |x|) / lambda`, the mode's
/// componentwise condition number times `eps`. The data define the eigenvalue no better,
/// and the solves with `K` cannot reach an inverse-iteration residual much below it.
pub fn rounding_floor(k: &SparseSym, m: &SparseSym, lambda: f64, x: &[f64]) -> f64 {
    f64::EPSILON * (k.abs_quadratic_form(x) / lambda + m.abs_quadratic_form(x))
}

/// Modes of a sparse model: eigenvalues `omega^2` ascending and shapes with unit modal
/// mass (column `i` of `shapes`, `n x k`), sign: the largest component positive.
#[derive(Clone, Debug)]
pub struct SparseModes {
    /// `omega_i^2` (rad^2/s^2), ascending.
    pub eigenvalues: Vec<f64>,
    /// Shapes, one column per mode.
    pub shapes: DMatrix<f64>,
    /// Iterations used.
    pub iterations: usize,
}

impl SparseModes {
    /// Natural frequencies (Hz).
    pub fn frequencies_hz(&self) -> Vec<f64> {
        self.eigenvalues
            .iter()
            .map(|l| l.max(0.0).sqrt() / (2.0 * std::f64::consts::PI))
            .collect()
    }
}

/// The `count` lowest modes of `(K, M)`; `K` (here with no shift) must be positive
/// definite (supports eliminated).
pub fn lowest_modes(
    k: &SparseSym,
    m: &SparseSym,
    count: usize,
) -> Result<SparseModes, StructureError> {
    let n = k.n();
    if count > n {
        return Err(StructureError::TooManyModes { count, n });
    }
    if count == 0 {
        return Ok(SparseModes {
            eigenvalues: vec![],
            shapes: DMatrix::zeros(n, 0),
            iterations: 0,
        });
    }
    let factor = k.factorize("stiffness matrix")?;
    let p = n.min((2 * count).max(count + 8));
    if p == n {
        // The block spans everything: Rayleigh–Ritz on the unit vectors, the dense pencil.
        let (lambda, x) = generalized_eigen(dense(k), dense(m))?;
        return Ok(finish(x, &lambda, count, 1));
    }
    // Deterministic start: a linear congruential sequence.
    let mut seed: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut x = DMatrix::from_fn(n, p, |_, _| {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    });
    // R = M X (blocks by rows for the sparse products: a p x n column-major matrix is the
    // n x p block stored by rows).
    let mut rows = vec![0.0; n * p];
    m.mul_rows_add_into(x.transpose().as_slice(), &mut rows, p);
    let mut mx = DMatrix::from_row_slice(n, p, &rows);
    let mut lambda: Vec<f64> = Vec::new();
    let mut history: Vec<f64> = Vec::new();
    for it in 1..=MAX_ITERATIONS {
        // Y = K^-1 M X, and M Y.
        let mut y = mx.clone();
        factor.solve_columns_in_place(y.as_mut_slice());
        let yt = y.transpose();
        rows.fill(0.0);
        m.mul_rows_add_into(yt.as_slice(), &mut rows, p);
        let my = DMatrix::from_row_slice(n, p, &rows);
        // Converged when each wanted Ritz pair (unit modal mass) is a fixed point of the
        // inverse iteration, rho = |lambda K^-1 M x - x|_M <= MODE_TOL; or, at the solves'
        // rounding floor (rho has not halved over STALL_WINDOW iterations), when the
        // eigenvalue's error from the residual (about rho^2 lambda) is within what the
        // rounding of the matrices' entries already makes of it: rho^2 <= rounding_floor.
        if it > 1 {
            let rho: Vec<f64> = (0..count)
                .map(|i| {
                    let r = y.column(i) * lambda[i] - x.column(i);
                    let mr = my.column(i) * lambda[i] - mx.column(i);
                    r.dot(&mr).max(0.0).sqrt()
                })
                .collect();
            let worst = rho
                .iter()
                .copied()
                .filter(|&r| r > MODE_TOL)
                .fold(0.0, f64::max);
            history.push(worst);
            let stalled = history.len() > STALL_WINDOW
                && worst > 0.5 * history[history.len() - 1 - STALL_WINDOW];
            let at_floor = || {
                rho.iter().enumerate().all(|(i, &r)| {
                    r <= MODE_TOL
                        || r * r <= rounding_floor(k, m, lambda[i], x.column(i).as_slice())
                })
            };
            if worst == 0.0 || (stalled && at_floor()) {
                return Ok(finish(x, &lambda, count, it - 1));
            }
        }
        // Rayleigh–Ritz on span Y with K Y = M X: Y^T K Y = Y^T (M X), no product with the
        // ill-conditioned K. Columns scaled to unit M-norm for the small Cholesky. The
        // first block (from the random start) can be too close to dependent for that
        // Cholesky; it, and any block whose projected mass is not numerically positive
        // definite, is orthonormalised instead.
        let ritz = if it == 1 {
            None
        } else {
            ritz_from_solves(&yt, &mx, &my)?
        };
        let (l, dq, basis, m_basis) = match ritz {
            Some((l, dq)) => (l, dq, y, my),
            None => ritz_orthonormal(k, m, y)?,
        };
        lambda = l;
        x = &basis * &dq;
        mx = &m_basis * &dq;
    }
    Err(StructureError::NoConvergence {
        what: "shift-invert subspace iteration",
        iterations: MAX_ITERATIONS,
    })
}

/// The Ritz pairs of span `Y` with `K Y = M X` from `Y^T (M X)` and `Y^T (M Y)` (`yt` is
/// `Y^T`): eigenvalues and the combination `D Q` of the columns of `Y`; `None` when the
/// projected mass is not numerically positive definite.
#[allow(clippy::type_complexity)]
fn ritz_from_solves(
    yt: &DMatrix<f64>,
    mx: &DMatrix<f64>,
    my: &DMatrix<f64>,
) -> Result<Option<(Vec<f64>, DMatrix<f64>)>, StructureError> {
    // (Products as GEMMs with Y^T: nalgebra's `tr_mul` is a loop of dot products.)
    let kp = symmetrize(yt * mx);
    let mp = symmetrize(yt * my);
    let p = mp.nrows();
    let d = DVector::from_fn(p, |j, _| 1.0 / mp[(j, j)].sqrt());
    if d.iter().any(|v| !v.is_finite()) {
        return Ok(None);
    }
    let scale = |a: DMatrix<f64>| DMatrix::from_fn(p, p, |i, j| a[(i, j)] * d[i] * d[j]);
    match generalized_eigen(scale(kp), scale(mp)) {
        Ok((l, q)) => Ok(Some((l, DMatrix::from_fn(p, p, |i, j| d[i] * q[(i, j)])))),
        Err(StructureError::NotPositiveDefinite { .. }) => Ok(None),
        Err(e) => Err(e),
    }
}

/// The Ritz pairs of span `Y` from an orthonormal basis `Q` of it and products with `K`
/// and `M`: eigenvalues, the combination of the columns of `Q`, `Q` and `M Q`.
#[allow(clippy::type_complexity)]
fn ritz_orthonormal(
    k: &SparseSym,
    m: &SparseSym,
    y: DMatrix<f64>,
) -> Result<(Vec<f64>, DMatrix<f64>, DMatrix<f64>, DMatrix<f64>), StructureError> {
    let (n, p) = y.shape();
    let q = y.qr().q();
    let qt = q.transpose();
    let product = |a: &SparseSym| {
        let mut rows = vec![0.0; n * p];
        a.mul_rows_add_into(qt.as_slice(), &mut rows, p);
        DMatrix::from_row_slice(n, p, &rows)
    };
    let (kq, mq) = (product(k), product(m));
    let (l, u) = generalized_eigen(symmetrize(&qt * kq), symmetrize(&qt * &mq))?;
    Ok((l, u, q, mq))
}

/// The first `count` Ritz pairs, each shape's largest component positive.
fn finish(x: DMatrix<f64>, lambda: &[f64], count: usize, iterations: usize) -> SparseModes {
    let mut shapes = x.columns(0, count).into_owned();
    for mut c in shapes.column_iter_mut() {
        let big = c
            .iter()
            .fold(0.0f64, |a, &v| if v.abs() > a.abs() { v } else { a });
        if big < 0.0 {
            c.neg_mut();
        }
    }
    SparseModes {
        eigenvalues: lambda[..count].to_vec(),
        shapes,
        iterations,
    }
}

fn dense(a: &SparseSym) -> DMatrix<f64> {
    let mut d = DMatrix::zeros(a.n(), a.n());
    for j in 0..a.n() {
        for (i, v) in a.column(j) {
            d[(i, j)] = v;
        }
    }
    d
}

fn symmetrize(a: DMatrix<f64>) -> DMatrix<f64> {
    (&a + a.transpose()) * 0.5
}

/// `K Q = M Q Lambda` for small dense symmetric `K`, positive definite `M`: eigenvalues
/// ascending, `Q^T M Q = I`.
pub fn generalized_eigen(
    k: DMatrix<f64>,
    m: DMatrix<f64>,
) -> Result<(Vec<f64>, DMatrix<f64>), StructureError> {
    let l = m
        .cholesky()
        .ok_or_else(|| StructureError::NotPositiveDefinite {
            what: "projected mass matrix".into(),
        })?;
    let linv = l
        .l()
        .solve_lower_triangular(&DMatrix::identity(k.nrows(), k.nrows()))
        .ok_or_else(|| StructureError::NotPositiveDefinite {
            what: "projected mass matrix".into(),
        })?;
    let n = k.nrows();
    let a = symmetrize(&linv * k * linv.transpose());
    let e = SymmetricEigen::new(a);
    let mut order: Vec<usize> = (0..e.eigenvalues.len()).collect();
    order.sort_by(|&i, &j| e.eigenvalues[i].total_cmp(&e.eigenvalues[j]));
    let lambda = order.iter().map(|&i| e.eigenvalues[i]).collect();
    let v = DMatrix::from_fn(n, order.len(), |r, c| e.eigenvectors[(r, order[c])]);
    Ok((lambda, linv.transpose() * v))
}
