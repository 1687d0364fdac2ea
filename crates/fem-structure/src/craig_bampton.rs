//! Craig–Bampton reduction (docs/theory.md section 13). The coordinates split into the
//! interface `b` (attachment and load DOFs, kept) and the interior `i`. With the
//! constraint modes `Psi = -K_ii^-1 K_ib` (one sparse solve per interface DOF) and the
//! fixed-interface modes `K_ii Phi = M_ii Phi Omega^2` (the lowest `k`, shift-invert),
//!
//! ```text
//! q = T (u_b, eta),   T = [ I    0   ]   (rows b)
//!                         [ Psi  Phi ]   (rows i)
//! M_r = T^T M T,   K_r = T^T K T,   B_r = T^T B T        (dense, (n_b + k) square)
//! ```
//!
//! Static loads on the interface are exact for any `k` (the constraint modes are the
//! static response); with all `n_i` modes `T` is square and the reduced model has the full
//! model's eigenvalues.

use nalgebra::DMatrix;

use crate::error::StructureError;
use crate::modes::{SparseModes, lowest_modes};
use crate::sparse::SparseSym;

/// A Craig–Bampton reduced model.
#[derive(Clone, Debug)]
pub struct Reduced {
    /// The interface DOFs (indices of the full model), sorted: the first `interface.len()`
    /// reduced coordinates are their displacements.
    pub interface: Vec<usize>,
    /// `T`, `n x (n_b + k)`.
    pub transform: DMatrix<f64>,
    /// `T^T M T`.
    pub mass: DMatrix<f64>,
    /// `T^T K T`.
    pub stiffness: DMatrix<f64>,
    /// `T^T B T` (zero when the full model is undamped).
    pub damping: DMatrix<f64>,
    /// The fixed-interface modes kept.
    pub fixed_interface: SparseModes,
}

impl Reduced {
    /// Number of reduced coordinates.
    pub fn dof_count(&self) -> usize {
        self.transform.ncols()
    }

    /// `T^T A T` of another matrix of the full model (its damping).
    pub fn project(&self, a: &SparseSym) -> DMatrix<f64> {
        project(&self.transform, a)
    }

    /// The full model's coordinates from reduced ones, `q = T z`.
    pub fn expand(&self, z: &[f64]) -> Vec<f64> {
        (&self.transform * nalgebra::DVector::from_column_slice(z))
            .as_slice()
            .to_vec()
    }
}

/// `T^T A T` (dense).
fn project(t: &DMatrix<f64>, a: &SparseSym) -> DMatrix<f64> {
    let (n, c) = t.shape();
    let mut at = DMatrix::zeros(n, c);
    for j in 0..c {
        a.mul_add_into(1.0, t.column(j).as_slice(), at.column_mut(j).as_mut_slice());
    }
    let r = t.transpose() * at;
    (&r + r.transpose()) * 0.5
}

/// Reduces `(K, M, B)` to the interface DOFs `interface` and `modes` fixed-interface modes
/// (`modes` is capped at the number of interior DOFs); `damping` is `B` (`None`:
/// undamped).
pub fn craig_bampton(
    k: &SparseSym,
    m: &SparseSym,
    damping: Option<&SparseSym>,
    interface: &[usize],
    modes: usize,
) -> Result<Reduced, StructureError> {
    let n = k.n();
    let mut b: Vec<usize> = interface.to_vec();
    b.sort_unstable();
    b.dedup();
    let mut is_b = vec![false; n];
    for &i in &b {
        is_b[i] = true;
    }
    let interior: Vec<usize> = (0..n).filter(|&i| !is_b[i]).collect();
    let ni = interior.len();
    let kii = k.principal(&interior);
    let mii = m.principal(&interior);
    let mut pos = vec![usize::MAX; n];
    for (p, &i) in interior.iter().enumerate() {
        pos[i] = p;
    }
    // Constraint modes: K_ii Psi = -K_ib.
    let mut psi = vec![0.0; ni * b.len()];
    for (c, &j) in b.iter().enumerate() {
        for (i, v) in k.column(j) {
            if pos[i] != usize::MAX {
                psi[c * ni + pos[i]] = -v;
            }
        }
    }
    if ni > 0 && !b.is_empty() {
        let f = kii.factorize("stiffness matrix with the interface held")?;
        f.solve_columns_in_place(&mut psi);
    }
    let fixed = lowest_modes(&kii, &mii, modes.min(ni))?;
    let nr = b.len() + fixed.eigenvalues.len();
    let mut t = DMatrix::zeros(n, nr);
    for (c, &j) in b.iter().enumerate() {
        t[(j, c)] = 1.0;
        for p in 0..ni {
            t[(interior[p], c)] = psi[c * ni + p];
        }
    }
    for q in 0..fixed.eigenvalues.len() {
        for p in 0..ni {
            t[(interior[p], b.len() + q)] = fixed.shapes[(p, q)];
        }
    }
    let mass = project(&t, m);
    let stiffness = project(&t, k);
    let damping = damping.map_or_else(|| DMatrix::zeros(nr, nr), |b| project(&t, b));
    Ok(Reduced {
        interface: b,
        transform: t,
        mass,
        stiffness,
        damping,
        fixed_interface: fixed,
    })
}
