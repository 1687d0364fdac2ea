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
//! - [`coupling`], [`damper`]: the paper's damper in its specialised form — one double bar
//!   pinned to one beam point, reduced to a rank-one term (eqs. 55–58) and integrated with a
//!   scalar secant iteration. Kept as a second, independent formulation of the same
//!   equations that the general engine is checked against (same trajectory to 1e-9), and
//!   for the double-bar geometry [`study::build_model`] reads off;
//! - [`decay`]: damping from a free decay (modal filter, damping vs amplitude, over- and
//!   critically damped decays): the one estimator;
//! - [`study`]: a damper run from a checked setup on the general engine, the damping ratio
//!   from the free decay and the energy account;
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
