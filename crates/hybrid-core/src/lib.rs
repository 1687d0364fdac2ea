//! The coupled system: an elastic beam (`fem-beam`) joined through constraint equations to a
//! symbolically generated mechanism (`mbs-symbolic`), with a DC generator as the damper
//! (paper section 4, THEORY.md sections 5–7).
//!
//! - [`coupling`]: the pin between a beam point and the mechanism point, eqs. (45)–(54), and
//!   the reduction to beam coordinates (55)–(58) as a rank-one term;
//! - [`generator`]: the DC generator (THEORY.md section 7);
//! - [`damper`]: the coupled model and its Newmark / HHT-alpha integration, O(n) per step;

pub mod closed_loop;
pub mod coupling;
pub mod damper;
pub mod generator;
pub mod output;
pub mod partition;
pub mod scenario;
pub mod study;
