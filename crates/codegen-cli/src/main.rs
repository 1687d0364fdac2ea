//! `damper`: the command-line front end of the damper design tool.
//!
//! A thin binary over the `codegen_cli` library: it parses arguments (clap) and calls the
//! command. Every error is reported as one line on standard error with exit code 2 (bad
//! input); standard output closed early by the reader exits quietly with 141; SIGINT and
//! SIGTERM end the run with 130 / 143 without writing anything half-way
//! (`codegen_cli::interrupt`).

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use codegen_cli::commands::{eval, frf, generate, linearize, merge, modes, simulate, sweep};

/// Design and verification of electromagnetic vibration dampers with a mechanism near its
/// singular position.
#[derive(Parser, Debug)]
#[command(name = "damper", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Emit the Rust module of a mechanism model (the equations as generated code).
    Generate(generate::Args),
    /// Evaluate M, F, Q, h, J, A and point kinematics of a mechanism model at one state and
    /// print them as JSON.
    Eval(eval::Args),
    /// Natural frequencies of a finite-element beam, with analytic values where known.
    Modes(modes::Args),
    /// Static equilibrium and linearised modes of a damper or hybrid scenario: frequencies,
    /// damping ratios, mode shapes, with and without the generator and for the bare beam.
    Linearize(linearize::Args),
    /// Run a scenario: the damper (beam + mechanism + generator) or a closed-loop mechanism.
    Simulate(simulate::Args),
    /// Evaluate a scenario over a grid of `--set PATH=VALUES` (parallel; `--shard I/N` for
    /// cluster job arrays).
    Sweep(sweep::Args),
    /// Join the parts of a sharded sweep into the files of the unsharded run.
    Merge(merge::Args),
    /// Frequency response of a damper or hybrid scenario: the linear receptance with and
    /// without the generator, and the nonlinear steady state from time-domain runs.
    Frf(frf::Args),
}

/// Exit status when standard output was closed by the reader (128 + SIGPIPE).
const BROKEN_PIPE: u8 = 141;

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Generate(args) => generate::run(args)?,
        Command::Eval(args) => eval::run(args)?,
        Command::Modes(args) => modes::run(args)?,
        Command::Linearize(args) => linearize::run(args)?,
        Command::Simulate(args) => simulate::run(args)?,
        Command::Sweep(args) => sweep::run(args)?,
        Command::Merge(args) => merge::run(args)?,
        Command::Frf(args) => frf::run(args)?,
    }
    Ok(())
}

/// Whether the error is standard output closed by the reader.
fn broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<codegen_cli::Error>()
            .is_some_and(codegen_cli::Error::is_broken_pipe)
            || c.downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // Help and version go to stdout with success; usage errors exit with 2.
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    if let Err(e) = codegen_cli::interrupt::install() {
        eprintln!(
            "warning: cannot handle SIGINT/SIGTERM ({e}); an interrupted run may leave temporary files"
        );
    }
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if broken_pipe(&e) => ExitCode::from(BROKEN_PIPE),
        Err(e) => {
            // One line naming what is wrong (the chain of causes joined with ": ").
            eprintln!("error: {}", format!("{e:#}").replace('\n', "; "));
            ExitCode::from(2)
        }
    }
}
