//! Symbolic multibody modelling of rigid tree mechanisms.

pub mod model;
