//! `damper`: the command-line front end of the damper design tool.
//!
//! A thin binary over the `codegen_cli` library: it parses arguments (clap) and calls the
//! command. Every error is reported as one line on standard error with exit code 2 (bad
//! input); standard output closed early by the reader exits quietly with 141; SIGINT and
//! SIGTERM end the run with 130 / 143 without writing anything half-way
//! (`codegen_cli::interrupt`).

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use codegen_cli::commands::{
    eval, figures, frf, generate, linearize, merge, modes, optimize, random, simulate, sweep,
};

/// Design and verification of electromagnetic vibration dampers (beam + mechanism + generator)
///
/// A mechanism near its singular position drives a DC generator from a vibrating beam. Every
/// command is described in README.md (section "Commands"); `damper COMMAND --help` gives its
/// arguments and options.
#[derive(Parser, Debug)]
#[command(name = "damper", version)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

// The first line of each command's documentation is its one-line summary in `damper --help`
// and in README.md's command table (`crates/codegen-cli/tests/readme_cli.rs` compares them).
#[derive(Subcommand, Debug)]
enum Command {
    /// Emit the Rust module of a mechanism model (its equations as generated code)
    ///
    /// Writes a struct with the model's run-time parameters and the methods that evaluate
    /// M, F, Q, h, J, A and the named points into caller-owned arrays (completely or not at
    /// all, only when the content changes).
    Generate(generate::Args),
    /// Evaluate M, F, Q, h, J, A and point kinematics of a model at one state (JSON)
    ///
    /// With the DAG interpreter (default), the numeric reference or the code generated at
    /// build time.
    Eval(eval::Args),
    /// Natural frequencies of a finite-element beam, with analytic values where known
    Modes(modes::Args),
    /// Static equilibrium and linearised modes of a damper or hybrid scenario
    ///
    /// Frequencies, damping ratios and mode shapes with the generator, disconnected and for
    /// the bare beam, and each generator's amplification dq/dw at the equilibrium.
    Linearize(linearize::Args),
    /// Run a scenario: a damper, a hybrid system or a closed-loop mechanism
    ///
    /// `kind = "damper"` (beam + double bar + generator, with its comparison runs),
    /// `kind = "hybrid"` (a beam and any mechanisms, attachments, forces and excitations) or
    /// `kind = "mechanism"` (a rigid closed-loop mechanism); every output file or none.
    Simulate(simulate::Args),
    /// Evaluate a scenario over a grid of `--set PATH=VALUES` (parallel, shardable)
    ///
    /// Linearised figures at every point, time-domain figures with `--time-domain`;
    /// `--shard I/N` for cluster job arrays, joined by `damper merge`.
    Sweep(sweep::Args),
    /// Join the parts of a sharded sweep into the files of the unsharded run
    Merge(merge::Args),
    /// The figures a scenario offers to sweep and optimize: name, unit, meaning
    ///
    /// From the one figure catalogue; the names `--map`, `--constraint`, `--maximize` and
    /// `--minimize` accept, and their earlier short spellings (aliases).
    Figures(figures::Args),
    /// Frequency response of a damper or hybrid scenario, linear and nonlinear
    ///
    /// The linear receptance with and without the generator, and with `--nonlinear` the
    /// steady state of the full system from time-domain runs.
    Frf(frf::Args),
    /// Best design within bounds under constraints, from the linearised system
    ///
    /// Multi-start (a coarse grid, then COBYLA from its best feasible points) over numeric
    /// scenario fields; the optimum, its active constraints and the KKT residual.
    Optimize(optimize::Args),
    /// Stationary random response under the scenario's white-noise or PSD excitations
    ///
    /// RMS of beam points and mechanism coordinates, generator currents and rotor speeds,
    /// mean generator and load power: Lyapunov equation (dense or modal) or PSD integration.
    Random(random::Args),
}

/// The longest error line printed (characters): past it the remaining problems are counted,
/// not shown.
const MAX_LINE: usize = 1000;

/// `text`'s lines joined with "; " into one line of at most about [`MAX_LINE`] characters:
/// the first problems in full (the first one cut at [`MAX_LINE`] characters,
/// [`diagnostic::truncate`]), then "... and
/// N more problems" counting the rest (a trailing "... and N more problems" line of the
/// list itself included).
fn one_line(text: &str) -> String {
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    let more_of = |l: &str| -> Option<usize> {
        l.strip_prefix("... and ")?
            .split_whitespace()
            .next()?
            .parse()
            .ok()
    };
    let mut out = String::new();
    let mut shown = 0;
    for l in &lines {
        if more_of(l).is_some() {
            break;
        }
        if shown > 0 && out.len() + 2 + l.len() > MAX_LINE {
            break;
        }
        if shown > 0 {
            out.push_str("; ");
        }
        out.push_str(&diagnostic::truncate(l, MAX_LINE));
        shown += 1;
    }
    let rest: usize = lines[shown..].iter().map(|l| more_of(l).unwrap_or(1)).sum();
    if rest > 0 {
        let s = if rest == 1 { "" } else { "s" };
        out.push_str(&format!("; ... and {rest} more problem{s}"));
    }
    out
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
        Command::Figures(args) => figures::run(args)?,
        Command::Frf(args) => frf::run(args)?,
        Command::Optimize(args) => optimize::run(args)?,
        Command::Random(args) => random::run(args)?,
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
            // One short line naming what is wrong (the chain of causes joined with ": ",
            // the problems of a file with "; ", a long list summarised).
            eprintln!("error: {}", one_line(&format!("{e:#}")));
            ExitCode::from(2)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{MAX_LINE, one_line};

    #[test]
    fn an_error_is_one_short_line() {
        assert_eq!(one_line("a: b"), "a: b");
        assert_eq!(one_line("f:1: x\nf:2: y"), "f:1: x; f:2: y");
        let many: Vec<String> = (0..20)
            .map(|k| format!("f:{k}: {}", "z".repeat(200)))
            .collect();
        let text = many.join("\n") + "\n... and 980 more problems";
        let line = one_line(&text);
        assert!(line.len() <= MAX_LINE + 60, "{}", line.len());
        assert!(line.starts_with("f:0: "));
        assert!(!line.contains('\n'));
        // 20 listed, 4 fit: 16 not shown + 980 counted by the list.
        assert!(line.ends_with("; ... and 996 more problems"), "{line}");
        let long = "é".repeat(2 * MAX_LINE);
        let line = one_line(&long);
        assert!(line.ends_with('…') && line.chars().count() == MAX_LINE + 1);
    }
}
