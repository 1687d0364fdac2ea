//! `damper`: the command-line front end of the damper design tool.
//!
//! A thin binary over the library crates: it parses arguments, reads files, calls
//! `mbs-symbolic`, `fem-beam` and `hybrid-core`, and writes results. Every error is reported
//! as one line on standard error with a non-zero exit code (2 for bad input).

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod eval;
mod generate;
mod modes;
mod simulate;
mod simulate_mechanism;

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
    /// Run a scenario: the damper (beam + mechanism + generator) or a closed-loop mechanism.
    Simulate(simulate::Args),
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
    let result = match cli.command {
        Command::Generate(args) => generate::run(args),
        Command::Eval(args) => eval::run(args),
        Command::Modes(args) => modes::run(args),
        Command::Simulate(args) => simulate::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line naming what is wrong (the chain of causes joined with ": ").
            eprintln!("error: {}", format!("{e:#}").replace('\n', "; "));
            ExitCode::from(2)
        }
    }
}
