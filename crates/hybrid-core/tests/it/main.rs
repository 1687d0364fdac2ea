//! The one integration-test binary of `hybrid-core` (STYLE.md rule 7): one module per
//! area, built and linked once.

mod closed_loop;
mod common;
mod decay;
mod forced;
mod hybrid_absorber;
mod hybrid_reference;
mod linearize;
mod variants;
