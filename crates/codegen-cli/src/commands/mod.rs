//! The subcommands of `damper`, one module each: arguments (clap) and the command.

pub mod eval;
pub mod frf;
pub mod generate;
pub mod modes;
pub mod simulate;
