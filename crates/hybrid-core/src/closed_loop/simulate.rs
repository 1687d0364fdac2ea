//! The settings under their former path, for the plain-mechanism scenario loader
//! ([`super::scenario`]), which imports them from here until it moves to the CLI; everything
//! else uses the re-exports of [`super`].

pub(super) use super::settings::{Method, PartitionSettings, Settings};
