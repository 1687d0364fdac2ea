//! The one integration-test binary of `mbs-symbolic` (STYLE.md rule 7): one module per
//! area, built and linked once.

mod bias_at_rest;
mod common;
mod element_power;
mod emit_snapshot;
mod model_validation;
mod numeric_reference;
mod op_counts;
mod symbolic_vs_numeric;
mod tangents;
