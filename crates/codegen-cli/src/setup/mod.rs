//! The one lowering of the application: a scenario as read ([`crate::scenario`], files
//! only) → the engine's model (`hybrid_core::hybrid::HybridModel`), what runs and analyses
//! take.
//!
//! - [`build()`] / [`build_model`] ([`mod@build`]): the mechanism models loaded (generated code
//!   when compiled in, the interpreter otherwise), every name resolved against them, the
//!   two-bar chains placed, the attachments checked, the hybrid system and (for [`build()`])
//!   its initial state; every problem reported at once as [`diagnostic::Diagnostics`] at
//!   the scenario file's line;
//! - [`tangents`]: the same system with one exact tangent model per mechanism, for
//!   linearisation ([`tangents_for`], [`Linearizable`]);
//! - [`structures`]: the imported structures read and reduced once per distinct input
//!   (files, damping, reduction settings, interface) and reused by every evaluation;
//! - [`variants`]: the comparison runs of a built scenario (generators disconnected, the
//!   bare beam with its probes).

pub mod build;
pub mod structures;
pub mod tangents;
pub mod variants;

pub use build::{Built, build, build_model};
pub use tangents::{Linearizable, hybrid_tangents, tangent_derivations, tangents_for};
pub use variants::{Probes, comparison};
