//! The coupled system: an elastic beam (`fem-beam`) joined through constraint equations to a
//! symbolically generated mechanism (`mbs-symbolic`), with a DC generator as the damper
//! (paper section 4, THEORY.md sections 5–7). Physics only: the file formats (scenarios,
//! CSV, JSON, plots) live in `codegen-cli`.
//!
//! - [`coupling`]: the pin between a beam point and the mechanism point, eqs. (45)–(54), and
//!   the reduction to beam coordinates (55)–(58) as a rank-one term;
//! - [`hybrid`]: hybrid systems of any shape (any mechanisms, attachments, force elements
//!   and excitations), partitioned and integrated in O(n) per step;
//! - [`generator`]: the DC generator (THEORY.md section 7);
//! - [`damper`]: the coupled model and its Newmark / HHT-alpha integration, O(n) per step;
//! - [`study`]: a damper run from a checked setup, the damping ratio from the free decay
//!   and the energy account;
//! - [`closed_loop`], [`partition`]: rigid closed-loop mechanisms and coordinate
//!   partitioning (eqs. 18–25);

pub mod closed_loop;
pub mod coupling;
pub mod damper;
pub mod generator;
pub mod hybrid;
pub mod partition;
pub mod study;
