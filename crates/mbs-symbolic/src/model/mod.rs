//! The mechanism description: file format (TOML or JSON), parameter expressions and
//! validation into the typed tree of [`types`].

pub mod types;

pub use types::*;
