//! The damper design application behind the `damper` binary: scenario files in, simulations
//! through `hybrid-core`, result files out.
//!
//! The data flows in one direction:
//!
//! - [`scenario`]: the one loader of scenario files (`kind = "damper"`, the default, or
//!   `kind = "mechanism"` or `kind = "hybrid"`), every problem reported at once with
//!   file:line:column;
//! - [`setup`]: the one lowering, a hybrid scenario → the engine's model (mechanism models
//!   loaded, names resolved, placements, initial state, tangent models, comparison
//!   variants);
//! - [`run`]: scenario → model (compiled-in generated code, numeric reference or DAG
//!   interpreter) → `hybrid-core` → observer; [`run_hybrid`] for hybrid systems;
//! - [`report`]: CSV time histories, typed JSON summaries, the SVG plot, and the one atomic
//!   writer that commits all files of a run together;
//! - [`commands`]: `generate`, `eval`, `modes`, `simulate`, `linearize`, `frf`, `random`,
//!   `sweep`, `optimize`, `merge` (the binary parses arguments and calls these);
//!   [`sweep_point`] evaluates one point of a sweep, [`linear`] and [`random`] the linearised
//!   figures (modes, receptance peak, harvested power, admissible load; stationary random
//!   response), [`optimize`] the constrained design optimisation and [`sensitivity`] its
//!   gradients (the adjoint of the linear model); [`analysis::figures`] is the catalogue of
//!   every figure they yield (names, units, producers, gradients) and the constraints on them.
//!
//! Standard output closed early (`damper modes .. | head -1`) is [`Error::Stdout`] with
//! [`std::io::ErrorKind::BrokenPipe`]; the binary exits quietly with status 141
//! (128 + SIGPIPE).
//!
//! SIGINT and SIGTERM follow one policy for every command ([`interrupt`]): an interrupted
//! run writes nothing (outputs are committed as a set at the end by the one writer,
//! [`report::writer`], which follows symbolic links and writes devices and fifos directly)
//! and exits with 128 + signal.

#![warn(missing_docs)]

pub mod analysis;
pub mod budget;
pub mod commands;
pub mod interrupt;
pub mod linear;
pub mod optimize;
pub mod progress;
pub mod random;
pub mod report;
pub mod run;
pub mod run_hybrid;
pub mod scenario;
pub mod sensitivity;
pub mod setup;
pub mod sweep_point;

use std::io::Write;

use diagnostic::Diagnostics;

/// What can go wrong in a command.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Problems in user files (a scenario, a mechanism model), every one with its position.
    #[error(transparent)]
    Input(#[from] Diagnostics),
    /// A beam description that cannot be used.
    #[error(transparent)]
    Beam(#[from] fem_beam::BeamError),
    /// Code generation failed.
    #[error(transparent)]
    Emit(#[from] mbs_symbolic::emit::EmitError),
    /// The damper simulation stopped (singular position, divergence); nothing was written.
    #[error("{file}: {error}")]
    Damper {
        /// The scenario file.
        file: String,
        /// Why.
        error: hybrid_core::hybrid::HybridError,
    },
    /// A hybrid run stopped (singular position, no convergence, divergence); nothing was
    /// written.
    #[error("{file}: {error}")]
    Hybrid {
        /// The scenario file.
        file: String,
        /// Why.
        error: hybrid_core::hybrid::HybridError,
    },
    /// A scenario cannot be linearised (no static equilibrium, singular stiffness, a
    /// tangent model that does not match).
    #[error("{file}: linearisation: {error}")]
    Linear {
        /// The scenario file.
        file: String,
        /// Why.
        error: hybrid_core::hybrid::LinearError,
    },
    /// The comparison run without generator panicked.
    #[error("the comparison run without generator panicked")]
    ComparisonPanicked,
    /// The model registry cannot provide the backend asked for.
    #[error(transparent)]
    Registry(#[from] model_registry::RegistryError),
    /// The initial conditions of a mechanism cannot be assembled.
    #[error("{file}: initial conditions: {error}")]
    Assembly {
        /// The scenario file.
        file: String,
        /// Why.
        error: hybrid_core::closed_loop::AssemblyError,
    },
    /// The mechanism simulation cannot start.
    #[error("{file}: cannot start the simulation: {error}")]
    Start {
        /// The scenario file.
        file: String,
        /// Why.
        error: hybrid_core::closed_loop::SimError,
    },
    /// The mechanism simulation stopped at `t`; nothing was written (a failed run commits
    /// no file).
    #[error("{file}: simulation stopped at t = {t} (nothing written): {error}")]
    Stopped {
        /// The scenario file.
        file: String,
        /// The last output time reached.
        t: f64,
        /// Why.
        error: hybrid_core::closed_loop::SimError,
    },
    /// An output file cannot be produced or written.
    #[error(transparent)]
    Report(#[from] report::ReportError),
    /// The estimated work of a run is above the limits of [`budget`] (lifted by
    /// `--allow-long`).
    #[error("{0}")]
    TooLong(String),
    /// Invalid command-line input (the command layer's own checks; the analyses say why
    /// they refuse a request with [`Error::Analysis`]).
    #[error("{0}")]
    Usage(String),
    /// An analysis refuses the request or cannot give its result (typed: the argument, the
    /// name and its nearest valid names, the file).
    #[error(transparent)]
    Analysis(#[from] analysis::AnalysisError),
    /// Invalid `--set PATH=VALUES` or `--shard` options of a sweep.
    #[error(transparent)]
    Sweep(#[from] analysis::sweep::SpecError),
    /// The run was asked to stop ([`interrupt::StopToken::stop`]); nothing was written.
    #[error("interrupted")]
    Interrupted,
    /// Writing to standard output failed (a closed pipe: `BrokenPipe`).
    #[error("cannot write to standard output: {0}")]
    Stdout(std::io::Error),
}

impl Error {
    /// Whether this is standard output closed by the reader (`damper .. | head -1`).
    pub fn is_broken_pipe(&self) -> bool {
        matches!(self, Error::Stdout(e) if e.kind() == std::io::ErrorKind::BrokenPipe)
    }
}

/// The model registry's backend for `model` ([`model_registry::system_for`]); a stale model
/// (a compiled-in model's file edited since the build) is announced on stderr the first
/// time this process meets it, before the interpreter stands in for the generated code.
pub fn system_for(
    model: &mbs_symbolic::model::Model,
    backend: Option<mbs_symbolic::runtime::Backend>,
) -> Result<model_registry::Resolved, model_registry::RegistryError> {
    let resolved = model_registry::system_for(model, backend)?;
    if let Some(stale) = resolved.stale.as_ref().filter(|s| s.first_notice()) {
        eprintln!("{stale}");
    }
    Ok(resolved)
}

/// Writes `text` to standard output and flushes it; a closed pipe is [`Error::Stdout`]
/// (never a panic, unlike `print!`).
pub fn print(text: &str) -> Result<(), Error> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .map_err(Error::Stdout)
}
