//! `damper modes` (work in progress).

/// Arguments of `damper modes`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`modes` is not implemented yet")
}
