//! The coupled system: an elastic beam (`fem-beam`) joined through constraint equations to a
//! symbolically generated mechanism (`mbs-symbolic`), with a DC generator as the damper
//! (paper section 4, THEORY.md sections 5–7). Physics only: the file formats (scenarios,
//! CSV, JSON, plots) live in `codegen-cli`.
//!
//! - [`hybrid`]: **the engine** — hybrid systems of any shape (an optional beam, any
//!   mechanisms, pin and roller attachments, force elements on joints, excitations),
//!   partitioned (eqs. 18–25 applied to 51–54) and integrated in O(n) per step; every run
//!   of the product goes through it;
//! - [`generator`]: the DC generator (THEORY.md section 7);
//! - [`decay`]: damping from a free decay (modal filter, damping vs amplitude, over- and
//!   critically damped decays): the one estimator;
//! - [`coupling`], [`damper`], [`study`]: the paper's damper in its specialised rank-one
//!   form (eqs. 55–58) and the application's damper preset — still used by `codegen-cli`,
//!   nothing else, and on their way out: the rank-one form now lives in this crate's tests
//!   (`tests/it/oracle`) as the step-by-step trajectory oracle of the engine (same
//!   trajectory to 1e-9), built by `tests/it/common/damper.rs` without the application;
//! - [`closed_loop`], [`partition`]: rigid closed-loop mechanisms and coordinate
//!   partitioning (eqs. 18–25);

pub mod closed_loop;
pub mod coupling;
pub mod damper;
pub mod decay;
pub mod generator;
pub mod hybrid;
pub mod partition;
pub mod study;
