//! The coupled system: an elastic beam (`fem-beam`) joined through constraint equations to a
//! symbolically generated mechanism (`mbs-symbolic`), with a DC generator as the damper
//! (paper section 4, docs/theory.md sections 5–7). Physics only: the file formats (scenarios,
//! CSV, JSON, plots) live in `codegen-cli`.
//!
//! - [`hybrid`]: **the engine** — hybrid systems of any shape (an optional beam, any
//!   mechanisms, pin and roller attachments, force elements on joints, excitations),
//!   partitioned (eqs. 18–25 applied to 51–54) and integrated in O(n) per step; every run
//!   of the product goes through it;
//! - [`generator`]: the DC generator (docs/theory.md section 7);
//! - [`decay`]: damping from a free decay (modal filter, damping vs amplitude, over- and
//!   critically damped decays): the one estimator;
//! - the paper's damper in its specialised rank-one form (eqs. 55–58, one double bar pinned
//!   to one beam point, a scalar secant iteration) and the full system with multipliers
//!   (eqs. 51–54) live in this crate's tests (`tests/it/oracle`) as the step-by-step
//!   trajectory oracles of the engine (same trajectory to 1e-9), built by
//!   `tests/it/common/damper.rs`;
//! - [`closed_loop`], [`partition`]: rigid closed-loop mechanisms and coordinate
//!   partitioning (eqs. 18–25);

pub mod closed_loop;
pub mod decay;
pub mod generator;
pub mod hybrid;
pub mod partition;
