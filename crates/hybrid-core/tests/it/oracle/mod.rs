//! The trajectory oracle of the general engine: the paper's damper (one double bar pinned
//! to one beam point, the generator on its crank) in its specialised rank-one form
//! (eqs. 55–58) integrated with a scalar secant iteration ([`damper`], [`coupling`]), and
//! the full constrained system solved with its multipliers ([`full`], eqs. 51–54).
//!
//! A second, independent formulation of the equations [`hybrid_core::hybrid`] integrates:
//! the engine follows it step for step (to 1e-9, `damper_oracle.rs`). Test code only; it
//! uses nothing but hybrid-core's public API. `PaperDamper::oracle` (`build.rs`)
//! builds it.

mod build;
pub mod coupling;
pub mod damper;
pub mod full;

pub use coupling::{Attachment, KinematicError, MechanismLink};
pub use damper::{DamperModel, Integrator, State};
