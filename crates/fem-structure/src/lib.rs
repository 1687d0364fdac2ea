//! Structures from other finite-element programs (docs/theory.md section 13): the mass and
//! stiffness matrices of a model built elsewhere (OpenSees, Code_Aster, Abaqus, FEniCS,
//! scikit-fem), with supports already eliminated, and where its nodes are.
//!
//! - [`mtx`]: the Matrix Market reader (coordinate real, symmetric one-triangle or
//!   general, 1-based) with file:line errors and an entry budget checked from the size
//!   line ([`mtx::MAX_ENTRIES`]), and the writer;
//! - [`tables`]: `nodes.csv` (`id,x,y[,z]`) and `dofs.csv` (`eq,node,dof`);
//! - [`SparseSym`], [`SparseFactor`]: symmetric sparse storage (faer), products, and the
//!   sparse Cholesky factorisation with a fill-reducing ordering (faer);
//! - [`lowest_modes`]: shift-invert subspace iteration for `K phi = omega^2 M phi`;
//! - [`craig_bampton`]: the Craig–Bampton reduction to interface DOFs plus fixed-interface
//!   modes, a small dense model;
//! - [`ImportedStructure`]: the files read and checked (sizes, tables, positive
//!   definiteness) before any work, Rayleigh damping from two modal ratios or a damping
//!   matrix;
//! - [`beam_structure_files`]: the built-in beam (`fem_beam::BeamModel`) written as such
//!   files ([`StructureFiles`]), to run the same structure both ways.

#![warn(missing_docs)]

mod craig_bampton;
mod error;
mod export;
mod model;
mod modes;
pub mod mtx;
mod sparse;
pub mod tables;

pub use craig_bampton::{Reduced, craig_bampton};
pub use error::StructureError;
pub use export::{StructureFiles, beam_structure_files};
pub use model::{DampingInput, Entries, ImportedStructure, MatrixFiles, StructureParts};
pub use modes::{
    MAX_ITERATIONS, MODE_TOL, STALL_WINDOW, SparseModes, generalized_eigen, lowest_modes,
    rounding_floor,
};
pub use sparse::{ComplexFactor, SparseFactor, SparseSym};
