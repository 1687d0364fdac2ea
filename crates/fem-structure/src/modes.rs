//! The lowest natural modes `K phi = omega^2 M phi` of a sparse model by shift-invert
//! subspace iteration with Rayleigh–Ritz projection (docs/theory.md section 13):
//!
//! ```text
//! Y = (K - sigma M)^-1 M X,   K_p = Y^T K Y,   M_p = Y^T M Y,   K_p Q = M_p Q Lambda,   X <- Y Q
//! ```
//!
//! with a block of `p = min(n, max(2 k, k + 8))` vectors from a deterministic start, until
//! every wanted mode's residual `|K x - lambda M x| <= tol lambda |M x|` (capped at
//! [`MAX_ITERATIONS`]), or until the residuals stall at the rounding floor below
//! [`FLOOR_TOL`]. With `p = n` one projection is exact.

use nalgebra::{DMatrix, SymmetricEigen};

use crate::error::StructureError;
use crate::sparse::SparseSym;

/// Most subspace iterations.
pub const MAX_ITERATIONS: usize = 500;

/// Convergence tolerance: the `M`-norm residual of the inverse iteration
/// `|lambda K^-1 M x - x|_M` of a unit-modal-mass vector (eigenvalues then exact to about
/// its square, i.e. to rounding).
pub const MODE_TOL: f64 = 1e-10;

/// The residual accepted when it stops decreasing (the rounding floor of the solves of an
/// ill-conditioned `K`: about 2e-10 on the bundled 1990-equation frame). The eigenvalues'
/// error is of the order of the residual's square, so still at rounding; the shapes' of
/// the order of the residual over the relative gap to the next eigenvalue.
pub const FLOOR_TOL: f64 = 1e-8;

/// Iterations over which a residual below [`FLOOR_TOL`] that has not halved counts as
/// stalled at the rounding floor.
pub const STALL_WINDOW: usize = 10;

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
    // Deterministic start: a linear congruential sequence.
    let mut seed: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut x = DMatrix::from_fn(n, p, |_, _| {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    });
    let mut y = vec![0.0; n * p];
    let mut ky = DMatrix::zeros(n, p);
    let mut my = DMatrix::zeros(n, p);
    let mut lambda: Vec<f64> = Vec::new();
    let mut r = vec![0.0; n];
    let mut mr = vec![0.0; n];
    let mut history: Vec<f64> = Vec::new();
    for it in 1..=MAX_ITERATIONS {
        // Y = K^-1 M X
        y.fill(0.0);
        for j in 0..p {
            m.mul_add_into(1.0, x.column(j).as_slice(), &mut y[j * n..(j + 1) * n]);
        }
        factor.solve_columns_in_place(&mut y);
        // Converged when each wanted Ritz pair (unit modal mass) is a fixed point of the
        // inverse iteration, |lambda K^-1 M x - x|_M <= MODE_TOL, or when the largest of
        // these residuals has reached the rounding floor of the solves: below
        // FLOOR_TOL and not halved over the last STALL_WINDOW iterations.
        if it > 1 {
            let mut worst = 0.0f64;
            for i in 0..count {
                for (ri, (yi, xi)) in r
                    .iter_mut()
                    .zip(y[i * n..(i + 1) * n].iter().zip(x.column(i).iter()))
                {
                    *ri = lambda[i] * yi - xi;
                }
                mr.fill(0.0);
                m.mul_add_into(1.0, &r, &mut mr);
                let norm2: f64 = r.iter().zip(&mr).map(|(a, b)| a * b).sum();
                worst = worst.max(norm2.max(0.0).sqrt());
            }
            history.push(worst);
            let stalled = history.len() > STALL_WINDOW
                && worst <= FLOOR_TOL
                && worst > 0.5 * history[history.len() - 1 - STALL_WINDOW];
            if worst <= MODE_TOL || stalled {
                return Ok(finish(x, &lambda, count, it - 1));
            }
        }
        // Orthonormal basis of the block: keeps the projected matrices well conditioned.
        let ym = DMatrix::from_column_slice(n, p, &y).qr().q();
        ky.fill(0.0);
        my.fill(0.0);
        for j in 0..p {
            k.mul_add_into(
                1.0,
                ym.column(j).as_slice(),
                ky.column_mut(j).as_mut_slice(),
            );
            m.mul_add_into(
                1.0,
                ym.column(j).as_slice(),
                my.column_mut(j).as_mut_slice(),
            );
        }
        let kp = symmetrize(ym.transpose() * &ky);
        let mp = symmetrize(ym.transpose() * &my);
        let (l, q) = generalized_eigen(kp, mp)?;
        lambda = l;
        x = &ym * &q;
        if p == n {
            return Ok(finish(x, &lambda, count, it));
        }
    }
    Err(StructureError::NoConvergence {
        what: "shift-invert subspace iteration",
        iterations: MAX_ITERATIONS,
    })
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
