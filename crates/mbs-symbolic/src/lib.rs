//! Symbolic multibody modelling of rigid tree mechanisms.

pub mod constraints;
pub mod dynamics;
pub mod emit;
pub mod expr;
pub mod model;
pub mod numeric;
pub mod runtime;
pub mod samples;
