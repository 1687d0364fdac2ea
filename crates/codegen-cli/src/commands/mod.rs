//! The subcommands of `damper`, one module each: arguments (clap) and the command.

pub mod eval;
pub mod figures;
pub mod frf;
pub mod generate;
pub mod linearize;
pub mod merge;
pub mod modes;
pub mod optimize;
pub mod random;
pub mod simulate;
pub mod sweep;
