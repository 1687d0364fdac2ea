//! The generated chains (`build.rs`): one module per size, the dispatcher and the counts.

include!(concat!(env!("OUT_DIR"), "/chains.rs"));
