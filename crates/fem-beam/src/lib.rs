//! Planar Euler–Bernoulli finite-element beam: the vibrating structure of the damper
//! (K. Lipinski 2011, section 3, eqs. 26–44; docs/theory.md section 4).
//!
//! A straight beam along x is made of prismatic segments, each meshed into equal two-node
//! elements with two DOFs per node, the transverse displacement `q_2` and the rotation
//! `q_6` (26). The crate implements
//!
//! - the cubic Hermite shape functions (35) ([`element::shape_functions`], interpolation at
//!   any `x` with [`BeamModel::shape_at`] / [`BeamModel::deflection_at`]);
//! - the element consistent mass (38), stiffness (39) and Rayleigh damping
//!   `B_e = alpha A_e + beta C_e` (40) ([`element`]);
//! - assembly (42)–(43) with nodal ordering, which makes the matrices banded with
//!   half-bandwidth 3, and elimination of the locked DOFs (44) with a map between full and
//!   reduced indices ([`DofMap`]), giving
//!
//!   ```text
//!   A^c q'' + B^c q' + C^c q = P^c(t)                                            (44)
//!   ```
//!
//!   in banded symmetric storage ([`BandedSym`]);
//! - an allocation-free banded LDL^T factorisation and solve ([`BandedFactor`]), banded
//!   products into caller buffers, and iteratively refined solves
//!   ([`BandedFactor::refine_with`]);
//! - loads: nodal forces and moments (27), consistent nodal loads of uniformly distributed
//!   loads, time functions (constant, harmonic, step), assembled at time `t` into a caller
//!   buffer ([`BeamModel::load_into`]);
//! - static deflection and modal analysis `C phi = omega^2 A phi` (dense for small models,
//!   shift-invert subspace iteration on the banded factorisation for large ones; rigid-body
//!   modes exact) ([`BeamModel::static_deflection`], [`BeamModel::modes`]);
//! - closed-form Euler–Bernoulli frequencies for the classical end conditions
//!   ([`analytic`]).
//!
//! Everything the coupled simulation calls per time step is `O(n)` in the number of
//! elements and allocates nothing.
//!
//! # Accuracy
//!
//! The beam stiffness is ill-conditioned (`cond ~ n^4`), so a plain banded solve loses
//! about `log10(n^3)` digits (2e-10 relative on a 50-element cantilever, 2e-2 at 10,000).
//! Two measures keep static and modal results at rounding level, so the tests can hold
//! closed forms to 1e-12:
//!
//! - static and modal solves are iteratively refined with a residual computed element by
//!   element in deformation form ([`BeamModel::stiffness_residual_into`]), which is exact
//!   for rigid-body motions, unlike the rounded entries of the assembled matrix;
//! - factorisations start at the end of the beam farther from the supports, node by node
//!   ([`BeamModel::factorize`], [`BandedSym::factorize_reversed`]), where elimination
//!   cancels least (plain error 4e-8 instead of 2e-2 for a 10,000-element cantilever), so
//!   refinement needs one or two steps.
//!
//! ```
//! use fem_beam::{Beam, BeamModel, Dof};
//!
//! let beam = Beam::from_toml_str(
//!     r#"
//!     [[segment]]
//!     length = 1.0
//!     youngs_modulus = 210e9
//!     density = 7850.0
//!     width = 0.04
//!     height = 0.008
//!     elements = 20
//!
//!     [[support]]
//!     x = 0.0
//!     kind = "clamped"
//!
//!     [[load]]
//!     x = 1.0
//!     force = -10.0
//!     "#,
//!     "example.toml",
//! )?;
//! let model = BeamModel::new(&beam)?;
//!
//! // Static tip deflection, exact: P L^3 / (3 E I).
//! let q = model.static_deflection_at(0.0)?;
//! let tip = q[model.dof_index(20, Dof::Transverse).unwrap()];
//! let ei = 210e9 * 0.04 * 0.008f64.powi(3) / 12.0;
//! assert!((tip - (-10.0 / (3.0 * ei))).abs() < 1e-12 * tip.abs());
//!
//! // Natural frequencies.
//! let modes = model.modes(3)?;
//! assert!((modes.frequencies_hz()[0] - 6.684).abs() < 1e-3);
//!
//! // Per time step: A v into a buffer, a solve with a reused factorisation.
//! let factor = model.mass().factorize()?;
//! let mut rhs = vec![0.0; model.dof_count()];
//! model.load_into(0.0, &mut rhs);
//! factor.solve_in_place(&mut rhs);
//! # Ok::<(), fem_beam::BeamError>(())
//! ```

#![warn(missing_docs)]

pub mod analytic;
mod banded;
mod beam;
mod dofs;
pub mod element;
mod error;
mod modal;
mod model;
pub mod random;
mod source;
mod spec;

pub use banded::{BandedFactor, BandedSym, NewmarkPredictor, PairedKd3};
pub use beam::{
    Beam, Damping, DistributedLoad, Element, MAX_ELEMENTS, NodalLoad, PHYSICAL_RANGES, Segment,
    physical_range_problems,
};
pub use dofs::DofMap;
pub use error::{BeamError, Entity, InputError, LinalgError};
pub use modal::{DENSE_LIMIT, ModalMethod, Modes};
pub use model::{BeamModel, HALF_BANDWIDTH, ShapeAt, rayleigh_from_ratios};
pub use source::input_diagnostics;
pub use spec::{
    BeamSpec, DampingSpec, DistributedLoadSpec, Dof, ModalRatioSpec, NodalLoadSpec, SegmentSpec,
    SupportKind, SupportSpec, TimeFunction, TimeFunctionError,
};
