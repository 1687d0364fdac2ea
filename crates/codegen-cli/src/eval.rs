//! `damper eval` (work in progress).

/// Arguments of `damper eval`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`eval` is not implemented yet")
}
