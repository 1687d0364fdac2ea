//! The structure interface: how the engine sees the linear host structure it couples the
//! mechanisms to (docs/theory.md section 12). Any structure whose equations are
//!
//! ```text
//! A q'' + B q' + C q = P(t) - J^c^T lambda                                          (44)
//! ```
//!
//! over its own coordinates `q` (supports already eliminated) is one implementation of
//! [`LinearStructure`]: the built-in Euler–Bernoulli beam (`fem-beam`, banded storage) is
//! the first. The engine touches the structure only through
//!
//! - the products `A x`, `B x`, `C x` and the quadratic forms `x^T A x`, `x^T B x`,
//!   `x^T C x` (residuals, energies);
//! - its own loads `P(t)` as a vector;
//! - the factorisation of the Newmark matrix `A + c_B B + c_C C` and solves with it (the
//!   step's low-rank updates `Z = K^-1 N`, `S = N^T Z` are built from these solves by the
//!   integrator);
//! - the rigid translation `r` of the supports along a direction (the inertial load
//!   `-A r a(t)` of a support motion);
//! - the lowest natural modes `C phi = omega^2 A phi`.
//!
//! The displacement of a point of the structure is a linear map of the coordinates,
//! `w = sum_k weight_k q_k` ([`super::BeamPoint`]), the same for every structure.
//!
//! The step calls these methods through generic code monomorphised for each structure, not
//! through a virtual call, so the interface costs the beam's step nothing.

use fem_beam::{BandedFactor, BandedSym, BeamError, BeamModel, Dof, LinalgError};

/// The lowest natural modes of a structure: `C phi_i = omega_i^2 A phi_i`, ascending, shapes
/// with unit modal mass `phi_i^T A phi_i = 1`.
#[derive(Clone, Debug, PartialEq)]
pub struct StructureModes {
    /// The eigenvalues `omega_i^2` (rad^2/s^2), ascending.
    pub eigenvalues: Vec<f64>,
    /// The shapes, one vector of the structure's coordinates per mode.
    pub shapes: Vec<Vec<f64>>,
}

/// Why a structure operation failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StructureError {
    /// A factorisation or a shape check failed.
    #[error(transparent)]
    Linalg(#[from] LinalgError),
    /// The beam's modal analysis failed.
    #[error(transparent)]
    Beam(#[from] BeamError),
}

/// A linear structure `A q'' + B q' + C q = P(t)` as the engine sees it (see the module
/// documentation). Products add into caller buffers and allocate nothing.
pub trait LinearStructure {
    /// A factorisation of a symmetric positive definite combination of the structure's
    /// matrices (the Newmark matrix), able to solve in place.
    type Factor: Clone + std::fmt::Debug + Send + Sync;

    /// Number of coordinates `n`.
    fn dof_count(&self) -> usize;

    /// `y += s A x`.
    fn mass_mul_add(&self, s: f64, x: &[f64], y: &mut [f64]);

    /// `y += s B x`.
    fn damping_mul_add(&self, s: f64, x: &[f64], y: &mut [f64]);

    /// `y += s C x`.
    fn stiffness_mul_add(&self, s: f64, x: &[f64], y: &mut [f64]);

    /// `x^T A x`.
    fn mass_quadratic_form(&self, x: &[f64]) -> f64;

    /// `x^T B x`.
    fn damping_quadratic_form(&self, x: &[f64]) -> f64;

    /// `x^T C x`.
    fn stiffness_quadratic_form(&self, x: &[f64]) -> f64;

    /// The structure's own loads `P(t)` into `out` (overwritten).
    fn load_into(&self, t: f64, out: &mut [f64]);

    /// Factorises the Newmark matrix `K = A + c_damping B + c_stiffness C`.
    fn factorize_newmark(
        &self,
        c_damping: f64,
        c_stiffness: f64,
    ) -> Result<Self::Factor, LinalgError>;

    /// `x <- K^-1 x` with a factor from [`LinearStructure::factorize_newmark`].
    fn solve_in_place(factor: &Self::Factor, x: &mut [f64]);

    /// The rigid translation `r` of the structure by a unit displacement along `direction`
    /// (a unit vector in the plane of the mechanisms): the coordinates' values when every
    /// support moves by `direction` (1 on translations along it, 0 on rotations).
    fn rigid_translation(&self, direction: [f64; 2]) -> Vec<f64>;

    /// The lowest `count` natural modes.
    fn modes(&self, count: usize) -> Result<StructureModes, StructureError>;
}

/// The built-in beam (`fem-beam`): banded matrices, banded LDL^T eliminating from the end
/// farther from the supports ([`BeamModel::factorize`]). The beam moves transversely only:
/// its rigid translation takes the `y` component of a direction.
impl LinearStructure for BeamModel {
    type Factor = BandedFactor;

    fn dof_count(&self) -> usize {
        BeamModel::dof_count(self)
    }

    #[inline]
    fn mass_mul_add(&self, s: f64, x: &[f64], y: &mut [f64]) {
        self.mass().mul_add_into(s, x, y);
    }

    #[inline]
    fn damping_mul_add(&self, s: f64, x: &[f64], y: &mut [f64]) {
        self.damping().mul_add_into(s, x, y);
    }

    #[inline]
    fn stiffness_mul_add(&self, s: f64, x: &[f64], y: &mut [f64]) {
        self.stiffness().mul_add_into(s, x, y);
    }

    #[inline]
    fn mass_quadratic_form(&self, x: &[f64]) -> f64 {
        self.mass().quadratic_form(x)
    }

    #[inline]
    fn damping_quadratic_form(&self, x: &[f64]) -> f64 {
        self.damping().quadratic_form(x)
    }

    #[inline]
    fn stiffness_quadratic_form(&self, x: &[f64]) -> f64 {
        self.stiffness().quadratic_form(x)
    }

    #[inline]
    fn load_into(&self, t: f64, out: &mut [f64]) {
        BeamModel::load_into(self, t, out);
    }

    fn factorize_newmark(
        &self,
        c_damping: f64,
        c_stiffness: f64,
    ) -> Result<BandedFactor, LinalgError> {
        let mut k: BandedSym = self.mass().clone();
        k.scaled_add(c_damping, self.damping())?;
        k.scaled_add(c_stiffness, self.stiffness())?;
        self.factorize(&k)
    }

    #[inline]
    fn solve_in_place(factor: &BandedFactor, x: &mut [f64]) {
        factor.solve_in_place(x);
    }

    fn rigid_translation(&self, direction: [f64; 2]) -> Vec<f64> {
        (0..BeamModel::dof_count(self))
            .map(|k| match self.dofs().node_dof(k) {
                Some((_, Dof::Transverse)) => direction[1],
                _ => 0.0,
            })
            .collect()
    }

    fn modes(&self, count: usize) -> Result<StructureModes, StructureError> {
        let m = BeamModel::modes(self, count)?;
        Ok(StructureModes {
            eigenvalues: m.eigenvalues().to_vec(),
            shapes: (0..m.len()).map(|i| m.shape(i).to_vec()).collect(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fem_beam::Beam;
    use nalgebra::{DMatrix, DVector};

    fn beam() -> BeamModel {
        let text = r#"
[[segment]]
length = 1.0
youngs_modulus = 210e9
density = 7850.0
width = 0.04
height = 0.008
elements = 6
[[support]]
x = 0.0
kind = "clamped"
[damping]
ratios = [{ mode = 1, ratio = 0.01 }, { mode = 2, ratio = 0.02 }]
"#;
        BeamModel::new(&Beam::from_toml_str(text, "c.toml").unwrap()).unwrap()
    }

    /// The Newmark solve against a dense solve of `A + c_B B + c_C C` assembled from the
    /// products (an independent formulation), to round-off scaled by the condition.
    #[test]
    fn newmark_solve_matches_a_dense_solve() {
        let b = beam();
        let n = LinearStructure::dof_count(&b);
        let (cb, cc) = (3e-4, 2.5e-9);
        let mut k = DMatrix::zeros(n, n);
        for j in 0..n {
            let mut e = vec![0.0; n];
            e[j] = 1.0;
            let mut col = vec![0.0; n];
            b.mass_mul_add(1.0, &e, &mut col);
            b.damping_mul_add(cb, &e, &mut col);
            b.stiffness_mul_add(cc, &e, &mut col);
            k.set_column(j, &DVector::from_vec(col));
        }
        let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin() + 0.1).collect();
        let dense = k
            .clone()
            .lu()
            .solve(&DVector::from_column_slice(&rhs))
            .unwrap();
        let f = b.factorize_newmark(cb, cc).unwrap();
        let mut x = rhs.clone();
        BeamModel::solve_in_place(&f, &mut x);
        let scale = dense.amax();
        for (a, d) in x.iter().zip(dense.iter()) {
            assert!((a - d).abs() <= 1e-10 * scale, "{a} vs {d}");
        }
        // Quadratic forms agree with the products.
        let mut ax = vec![0.0; n];
        b.stiffness_mul_add(1.0, &rhs, &mut ax);
        let q: f64 = ax.iter().zip(&rhs).map(|(a, r)| a * r).sum();
        assert!((b.stiffness_quadratic_form(&rhs) - q).abs() <= 1e-12 * q.abs());
    }

    /// The rigid translation of a clamped beam along y: 1 on each free transverse DOF (6),
    /// 0 on the rotations; along x the beam (transverse only) does not move.
    #[test]
    fn rigid_translation_of_the_beam() {
        let b = beam();
        let r = b.rigid_translation([0.0, 1.0]);
        assert_eq!(r.iter().filter(|&&x| x == 1.0).count(), 6);
        assert_eq!(r.iter().filter(|&&x| x == 0.0).count(), 6);
        assert!(b.rigid_translation([1.0, 0.0]).iter().all(|&x| x == 0.0));
    }

    /// The interface's modes are the beam's, unit modal mass.
    #[test]
    fn modes_are_the_beams() {
        let b = beam();
        let m = LinearStructure::modes(&b, 3).unwrap();
        let own = BeamModel::modes(&b, 3).unwrap();
        assert_eq!(m.eigenvalues, own.eigenvalues());
        for phi in &m.shapes {
            assert!((b.mass_quadratic_form(phi) - 1.0).abs() < 1e-12);
        }
    }
}
