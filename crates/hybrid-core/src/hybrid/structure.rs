//! The structure interface: how the engine sees the linear host structure it couples the
//! mechanisms to (docs/theory.md section 13). Any structure whose equations are
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
//! Three implementations: the beam ([`BeamModel`], banded), an imported sparse model
//! ([`ImportedStructure`], faer's sparse Cholesky; one sparse solve per step) and its
//! Craig–Bampton reduction ([`Reduced`], small and dense; the reduced coordinates are the
//! interface displacements then the fixed-interface modal amplitudes, so a point on the
//! interface keeps its weight 1 on its own coordinate).
//!
//! The displacement of a point of the structure is a linear map of the coordinates,
//! `w = sum_k weight_k q_k` ([`super::BeamPoint`]), the same for every structure.
//!
//! The step calls these methods through generic code monomorphised for each structure, not
//! through a virtual call, so the interface costs the beam's step nothing.

use fem_beam::{BandedFactor, BandedSym, BeamError, BeamModel, Dof, LinalgError, NewmarkPredictor};
use fem_structure::{ImportedStructure, Reduced, SparseFactor, tables::NodeDof};
use nalgebra::DVector;

use super::dense::{self, DenseCholesky};

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
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StructureError {
    /// A banded factorisation or a shape check of the beam failed.
    #[error(transparent)]
    Linalg(#[from] LinalgError),
    /// A sparse or dense operation on an imported structure failed.
    #[error(transparent)]
    Imported(#[from] fem_structure::StructureError),
    /// The beam's modal analysis failed (its message).
    #[error("{0}")]
    Beam(String),
}

impl From<BeamError> for StructureError {
    fn from(e: BeamError) -> StructureError {
        StructureError::Beam(e.to_string())
    }
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

    /// `y = b + s C x`: the operations of `y = b` then
    /// [`stiffness_mul_add`](LinearStructure::stiffness_mul_add) (the beam: in one pass,
    /// bit-identical).
    fn stiffness_mul_add_to(&self, s: f64, x: &[f64], b: &[f64], y: &mut [f64]) {
        y.copy_from_slice(b);
        self.stiffness_mul_add(s, x, y);
    }

    /// The predictor of a step with the damping folded into the factorised matrix and its
    /// product: [`NewmarkPredictor::predict`] (`old = [q, v, a]` into
    /// `out = [q^, v^, x]`), then `y = b - C x`: by default the two one after the other
    /// (the beam: in one pass, bit-identical).
    fn predict_stiffness_mul_sub(
        &self,
        p: &NewmarkPredictor,
        old: [&[f64]; 3],
        out: [&mut [f64]; 3],
        b: &[f64],
        y: &mut [f64],
    ) {
        let [q_hat, v_hat, x] = out;
        p.predict(old, [q_hat, v_hat, &mut *x]);
        self.stiffness_mul_add_to(-1.0, x, b, y);
    }

    /// `x^T A x`.
    fn mass_quadratic_form(&self, x: &[f64]) -> f64;

    /// `x^T B x`.
    fn damping_quadratic_form(&self, x: &[f64]) -> f64;

    /// `x^T C x`.
    fn stiffness_quadratic_form(&self, x: &[f64]) -> f64;

    /// The Rayleigh coefficients `(a, b)` when the damping is `B = a A + b C` (assembled
    /// so, equal to rounding); `None` for any other damping (the default). The Newmark step
    /// then folds `B` into its factorised matrix (docs/theory.md section 13.5).
    fn rayleigh(&self) -> Option<(f64, f64)> {
        None
    }

    /// The structure's own loads `P(t)` into `out` (overwritten); by default none (an
    /// imported model's loads are excitations).
    fn load_into(&self, _t: f64, out: &mut [f64]) {
        out.fill(0.0);
    }

    /// Whether the structure has loads of its own; `false` when
    /// [`load_into`](LinearStructure::load_into) writes zeros at every `t` (the default).
    fn has_loads(&self) -> bool {
        false
    }

    /// Factorises the Newmark matrix `K = A + c_damping B + c_stiffness C`.
    fn factorize_newmark(
        &self,
        c_damping: f64,
        c_stiffness: f64,
    ) -> Result<Self::Factor, StructureError>;

    /// `x <- K^-1 x` with a factor from [`LinearStructure::factorize_newmark`].
    fn solve_in_place(factor: &Self::Factor, x: &mut [f64]);

    /// The rigid translation `r` of the structure by a unit displacement along `direction`
    /// (a unit vector in the plane of the mechanisms): the coordinates' values when every
    /// support moves by `direction` (1 on translations along it, 0 on rotations).
    fn rigid_translation(&self, direction: [f64; 2]) -> Vec<f64>;

    /// The lowest `count` natural modes.
    fn modes(&self, count: usize) -> Result<StructureModes, StructureError>;

    /// The load per unit support acceleration along `direction`, `-A r` with `r` the rigid
    /// translation ([`LinearStructure::rigid_translation`]) of the full model (N per
    /// m/s^2). Allocates: computed once at setup.
    fn base_load(&self, direction: [f64; 2]) -> Vec<f64> {
        let r = self.rigid_translation(direction);
        let mut out = vec![0.0; r.len()];
        self.mass_mul_add(-1.0, &r, &mut out);
        out
    }
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
    fn stiffness_mul_add_to(&self, s: f64, x: &[f64], b: &[f64], y: &mut [f64]) {
        BeamModel::stiffness_mul_add_to(self, s, x, b, y);
    }

    #[inline]
    fn predict_stiffness_mul_sub(
        &self,
        p: &NewmarkPredictor,
        old: [&[f64]; 3],
        out: [&mut [f64]; 3],
        b: &[f64],
        y: &mut [f64],
    ) {
        BeamModel::predict_stiffness_mul_sub(self, p, old, out, b, y);
    }

    #[inline]
    fn mass_quadratic_form(&self, x: &[f64]) -> f64 {
        self.mass().quadratic_form(x)
    }

    #[inline]
    fn damping_quadratic_form(&self, x: &[f64]) -> f64 {
        BeamModel::damping_quadratic_form(self, x)
    }

    #[inline]
    fn stiffness_quadratic_form(&self, x: &[f64]) -> f64 {
        self.stiffness().quadratic_form(x)
    }

    #[inline]
    fn rayleigh(&self) -> Option<(f64, f64)> {
        Some(self.rayleigh_coefficients())
    }

    #[inline]
    fn load_into(&self, t: f64, out: &mut [f64]) {
        BeamModel::load_into(self, t, out);
    }

    #[inline]
    fn has_loads(&self) -> bool {
        BeamModel::has_loads(self)
    }

    fn factorize_newmark(
        &self,
        c_damping: f64,
        c_stiffness: f64,
    ) -> Result<BandedFactor, StructureError> {
        let mut k: BandedSym = self.mass().clone();
        k.scaled_add(c_damping, self.damping())?;
        k.scaled_add(c_stiffness, self.stiffness())?;
        Ok(self.factorize(&k)?)
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

/// The host structure of a hybrid model: one of the three implementations of
/// [`LinearStructure`], chosen by the scenario. The engine calls the structure through this
/// enum: one predictable branch per call (a handful of calls per step), no virtual call, and
/// the beam's arithmetic is exactly [`BeamModel`]'s.
#[derive(Clone, Debug)]
pub enum Structure {
    /// The built-in Euler–Bernoulli beam (banded).
    Beam(BeamModel),
    /// An imported sparse model, unreduced (one sparse solve per iteration).
    Imported(ImportedStructure),
    /// An imported model reduced by Craig–Bampton: the reduced model runs; the full one is
    /// kept for the support load `T^T (-M r)` and to expand results to every node.
    Reduced {
        /// The full model.
        full: Box<ImportedStructure>,
        /// Its reduction.
        reduced: Box<Reduced>,
    },
}

/// The factorised Newmark matrix of a [`Structure`].
#[derive(Clone, Debug)]
pub enum StructureFactor {
    /// The beam's banded LDL^T.
    Banded(BandedFactor),
    /// An imported model's sparse Cholesky.
    Sparse(SparseFactor),
    /// A reduced model's dense Cholesky.
    Dense(DenseCholesky),
}

impl From<BeamModel> for Structure {
    fn from(beam: BeamModel) -> Structure {
        Structure::Beam(beam)
    }
}

impl Structure {
    /// The beam, when the structure is the built-in beam.
    pub fn beam(&self) -> Option<&BeamModel> {
        match self {
            Structure::Beam(b) => Some(b),
            _ => None,
        }
    }

    /// The imported model (the full one of a reduced structure), when imported.
    pub fn imported(&self) -> Option<&ImportedStructure> {
        match self {
            Structure::Beam(_) => None,
            Structure::Imported(s) => Some(s),
            Structure::Reduced { full, .. } => Some(full),
        }
    }

    /// `"beam"`, `"matrices"` or `"matrices, Craig–Bampton"`: what the host is, for reports.
    pub fn kind(&self) -> &'static str {
        match self {
            Structure::Beam(_) => "beam",
            Structure::Imported(_) => "matrices",
            Structure::Reduced { .. } => "matrices, Craig–Bampton",
        }
    }
}

/// Calls `$body` with `$s` bound to the implementation inside a [`Structure`].
macro_rules! each {
    ($self:expr, $s:ident => $body:expr) => {
        match $self {
            Structure::Beam($s) => $body,
            Structure::Imported($s) => $body,
            Structure::Reduced { reduced: $s, .. } => {
                let $s: &Reduced = $s;
                $body
            }
        }
    };
}

impl LinearStructure for Structure {
    type Factor = StructureFactor;

    #[inline]
    fn dof_count(&self) -> usize {
        each!(self, s => LinearStructure::dof_count(s))
    }

    #[inline]
    fn mass_mul_add(&self, k: f64, x: &[f64], y: &mut [f64]) {
        each!(self, s => s.mass_mul_add(k, x, y))
    }

    #[inline]
    fn damping_mul_add(&self, k: f64, x: &[f64], y: &mut [f64]) {
        each!(self, s => s.damping_mul_add(k, x, y))
    }

    #[inline]
    fn stiffness_mul_add(&self, k: f64, x: &[f64], y: &mut [f64]) {
        each!(self, s => s.stiffness_mul_add(k, x, y))
    }

    #[inline]
    fn stiffness_mul_add_to(&self, k: f64, x: &[f64], b: &[f64], y: &mut [f64]) {
        each!(self, s => s.stiffness_mul_add_to(k, x, b, y))
    }

    #[inline]
    fn predict_stiffness_mul_sub(
        &self,
        p: &NewmarkPredictor,
        old: [&[f64]; 3],
        out: [&mut [f64]; 3],
        b: &[f64],
        y: &mut [f64],
    ) {
        each!(self, s => s.predict_stiffness_mul_sub(p, old, out, b, y))
    }

    #[inline]
    fn mass_quadratic_form(&self, x: &[f64]) -> f64 {
        each!(self, s => s.mass_quadratic_form(x))
    }

    #[inline]
    fn damping_quadratic_form(&self, x: &[f64]) -> f64 {
        each!(self, s => s.damping_quadratic_form(x))
    }

    /// A reduced model's damping `T^T B T` is Rayleigh when the full model's `B = a M + b K`
    /// is: `T^T (a M + b K) T = a M_r + b K_r`, equal to rounding.
    #[inline]
    fn rayleigh(&self) -> Option<(f64, f64)> {
        match self {
            Structure::Reduced { full, .. } => LinearStructure::rayleigh(&**full),
            _ => each!(self, s => s.rayleigh()),
        }
    }

    #[inline]
    fn stiffness_quadratic_form(&self, x: &[f64]) -> f64 {
        each!(self, s => s.stiffness_quadratic_form(x))
    }

    #[inline]
    fn load_into(&self, t: f64, out: &mut [f64]) {
        each!(self, s => LinearStructure::load_into(s, t, out))
    }

    #[inline]
    fn has_loads(&self) -> bool {
        each!(self, s => LinearStructure::has_loads(s))
    }

    fn factorize_newmark(
        &self,
        c_damping: f64,
        c_stiffness: f64,
    ) -> Result<StructureFactor, StructureError> {
        Ok(match self {
            Structure::Beam(b) => {
                StructureFactor::Banded(b.factorize_newmark(c_damping, c_stiffness)?)
            }
            Structure::Imported(s) => {
                StructureFactor::Sparse(s.factorize_newmark(c_damping, c_stiffness)?)
            }
            Structure::Reduced { reduced, .. } => {
                StructureFactor::Dense(reduced.factorize_newmark(c_damping, c_stiffness)?)
            }
        })
    }

    #[inline]
    fn solve_in_place(factor: &StructureFactor, x: &mut [f64]) {
        match factor {
            StructureFactor::Banded(f) => BeamModel::solve_in_place(f, x),
            StructureFactor::Sparse(f) => ImportedStructure::solve_in_place(f, x),
            StructureFactor::Dense(f) => Reduced::solve_in_place(f, x),
        }
    }

    fn rigid_translation(&self, direction: [f64; 2]) -> Vec<f64> {
        match self {
            Structure::Beam(b) => b.rigid_translation(direction),
            Structure::Imported(s) => s.rigid_translation(direction),
            // The reduced coordinates of the full model's rigid translation are not a
            // translation of the reduced model: only its load is defined (`base_load`).
            Structure::Reduced { reduced, .. } => reduced.rigid_translation(direction),
        }
    }

    fn base_load(&self, direction: [f64; 2]) -> Vec<f64> {
        match self {
            Structure::Beam(b) => b.base_load(direction),
            Structure::Imported(s) => s.base_load(direction),
            Structure::Reduced { full, reduced } => reduced_base_load(full, reduced, direction),
        }
    }

    fn modes(&self, count: usize) -> Result<StructureModes, StructureError> {
        each!(self, s => LinearStructure::modes(s, count))
    }
}

/// The rigid translation of an imported model: `d . e_k` on each translational DOF along
/// the unit axis `e_k` (its `x`, `y` components: the mechanisms' plane), 0 on rotations.
fn imported_translation(s: &ImportedStructure, direction: [f64; 2]) -> Vec<f64> {
    s.dofs
        .of_equation
        .iter()
        .map(|&(_, dof)| match dof {
            NodeDof::Ux => direction[0],
            NodeDof::Uy => direction[1],
            _ => 0.0,
        })
        .collect()
}

/// An imported sparse model: products by its sparse matrices, the Newmark matrix
/// factorised by faer's sparse Cholesky. Without loads of its own (its loads are
/// excitations).
impl LinearStructure for ImportedStructure {
    type Factor = SparseFactor;

    fn dof_count(&self) -> usize {
        ImportedStructure::dof_count(self)
    }

    fn mass_mul_add(&self, s: f64, x: &[f64], y: &mut [f64]) {
        self.mass.mul_add_into(s, x, y);
    }

    fn damping_mul_add(&self, s: f64, x: &[f64], y: &mut [f64]) {
        if let Some(b) = &self.damping {
            b.mul_add_into(s, x, y);
        }
    }

    fn stiffness_mul_add(&self, s: f64, x: &[f64], y: &mut [f64]) {
        self.stiffness.mul_add_into(s, x, y);
    }

    fn mass_quadratic_form(&self, x: &[f64]) -> f64 {
        self.mass.quadratic_form(x)
    }

    fn damping_quadratic_form(&self, x: &[f64]) -> f64 {
        self.damping.as_ref().map_or(0.0, |b| b.quadratic_form(x))
    }

    fn rayleigh(&self) -> Option<(f64, f64)> {
        match self.damping {
            Some(_) => self.rayleigh,
            None => Some((0.0, 0.0)),
        }
    }

    fn stiffness_quadratic_form(&self, x: &[f64]) -> f64 {
        self.stiffness.quadratic_form(x)
    }

    fn factorize_newmark(
        &self,
        c_damping: f64,
        c_stiffness: f64,
    ) -> Result<SparseFactor, StructureError> {
        let mut k = self.mass.combination(1.0, &self.stiffness, c_stiffness);
        if let Some(b) = &self.damping {
            k = k.combination(1.0, b, c_damping);
        }
        Ok(k.factorize("Newmark matrix")?)
    }

    fn solve_in_place(factor: &SparseFactor, x: &mut [f64]) {
        factor.solve_in_place(x);
    }

    fn rigid_translation(&self, direction: [f64; 2]) -> Vec<f64> {
        imported_translation(self, direction)
    }

    fn modes(&self, count: usize) -> Result<StructureModes, StructureError> {
        let m = fem_structure::lowest_modes(&self.stiffness, &self.mass, count)?;
        Ok(StructureModes {
            eigenvalues: m.eigenvalues.clone(),
            shapes: m
                .shapes
                .column_iter()
                .map(|c| c.iter().copied().collect())
                .collect(),
        })
    }
}

/// A Craig–Bampton reduced model: dense `T^T M T`, `T^T B T`, `T^T K T` and a dense
/// Cholesky factorisation ([`DenseCholesky`]), through column-wise kernels that the
/// compiler vectorises. Its support load is `T^T (-M r)`, which needs the full model:
/// [`Reduced`] alone has no rigid translation (see [`reduced_base_load`]).
impl LinearStructure for Reduced {
    type Factor = DenseCholesky;

    fn dof_count(&self) -> usize {
        Reduced::dof_count(self)
    }

    fn mass_mul_add(&self, s: f64, x: &[f64], y: &mut [f64]) {
        dense::mul_add(&self.mass, s, x, y);
    }

    fn damping_mul_add(&self, s: f64, x: &[f64], y: &mut [f64]) {
        dense::mul_add(&self.damping, s, x, y);
    }

    fn stiffness_mul_add(&self, s: f64, x: &[f64], y: &mut [f64]) {
        dense::mul_add(&self.stiffness, s, x, y);
    }

    fn mass_quadratic_form(&self, x: &[f64]) -> f64 {
        dense::quadratic(&self.mass, x)
    }

    fn damping_quadratic_form(&self, x: &[f64]) -> f64 {
        dense::quadratic(&self.damping, x)
    }

    fn stiffness_quadratic_form(&self, x: &[f64]) -> f64 {
        dense::quadratic(&self.stiffness, x)
    }

    fn factorize_newmark(
        &self,
        c_damping: f64,
        c_stiffness: f64,
    ) -> Result<DenseCholesky, StructureError> {
        let k = &self.mass + &self.damping * c_damping + &self.stiffness * c_stiffness;
        DenseCholesky::new(k).ok_or_else(|| {
            StructureError::Imported(fem_structure::StructureError::NotPositiveDefinite {
                what: "reduced Newmark matrix".into(),
            })
        })
    }

    fn solve_in_place(factor: &DenseCholesky, x: &mut [f64]) {
        factor.solve_in_place(x);
    }

    fn rigid_translation(&self, _direction: [f64; 2]) -> Vec<f64> {
        vec![0.0; Reduced::dof_count(self)]
    }

    fn base_load(&self, _direction: [f64; 2]) -> Vec<f64> {
        vec![0.0; Reduced::dof_count(self)]
    }

    fn modes(&self, count: usize) -> Result<StructureModes, StructureError> {
        let n = Reduced::dof_count(self);
        if count > n {
            return Err(fem_structure::StructureError::TooManyModes { count, n }.into());
        }
        let (lambda, q) =
            fem_structure::generalized_eigen(self.stiffness.clone(), self.mass.clone())?;
        Ok(StructureModes {
            eigenvalues: lambda[..count].to_vec(),
            shapes: (0..count)
                .map(|i| {
                    let c = q.column(i);
                    let big = c
                        .iter()
                        .fold(0.0f64, |a, &v| if v.abs() > a.abs() { v } else { a });
                    c.iter().map(|v| v * big.signum()).collect()
                })
                .collect(),
        })
    }
}

/// The support load of a reduced model, `T^T (-M r)` with `r` the full model's rigid
/// translation along `direction` (N per m/s^2, reduced coordinates).
pub fn reduced_base_load(
    full: &ImportedStructure,
    reduced: &Reduced,
    direction: [f64; 2],
) -> Vec<f64> {
    let p = full.base_load(direction);
    (reduced.transform.transpose() * DVector::from_column_slice(&p))
        .as_slice()
        .to_vec()
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

    /// The beam's dissipation form is infinite or NaN whenever one entry of the vector is
    /// (the integrator leaves the finiteness of a folded step's update to it): each entry
    /// in turn set to +inf, -inf and NaN among finite ones, on beams with the paired
    /// kernel and without (fewer than 8 DOFs), an even and an odd DOF count, with Rayleigh
    /// damping and without any (`B = 0`).
    #[test]
    fn the_beam_dissipation_form_is_non_finite_with_any_non_finite_entry() {
        let spec = |elements: usize, kind: &str, damping: &str| {
            format!(
                "[[segment]]\nlength = 1.0\nyoungs_modulus = 210e9\ndensity = 7850.0\n\
                 width = 0.04\nheight = 0.008\nelements = {elements}\n[[support]]\nx = 0.0\n\
                 kind = \"{kind}\"\n{damping}"
            )
        };
        let mut sizes = vec![];
        for elements in [2, 3, 6, 9] {
            for kind in ["clamped", "pinned"] {
                for damping in ["[damping]\nalpha = 0.3\nbeta = 2e-5\n", ""] {
                    let text = spec(elements, kind, damping);
                    let b = BeamModel::new(&Beam::from_toml_str(&text, "c.toml").unwrap()).unwrap();
                    let n = LinearStructure::dof_count(&b);
                    sizes.push(n);
                    let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin() * 1e-2).collect();
                    assert!(b.damping_quadratic_form(&x).is_finite());
                    for i in 0..n {
                        for bad in [f64::INFINITY, f64::NEG_INFINITY, f64::NAN] {
                            let mut y = x.clone();
                            y[i] = bad;
                            let form = LinearStructure::damping_quadratic_form(&b, &y);
                            assert!(!form.is_finite(), "n = {n}, entry {i} = {bad}: {form}");
                        }
                    }
                }
            }
        }
        // Both kernels, both parities.
        assert!(sizes.iter().any(|&n| n < 8) && sizes.iter().any(|&n| n >= 8));
        assert!(sizes.iter().any(|&n| n % 2 == 1) && sizes.iter().any(|&n| n % 2 == 0));
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
