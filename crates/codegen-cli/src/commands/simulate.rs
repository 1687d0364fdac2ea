//! `damper simulate SCENARIO [-o DIR]`: the main job.
//!
//! A `kind = "damper"` scenario is a preset of the hybrid scenario (the loader rewrites it,
//! [`crate::scenario::preset`]); it and every `kind = "hybrid"` scenario run through
//! [`crate::run_hybrid`]: the system as described and the comparison runs of `[output]
//! compare` (`generator_disconnected`: every generator's circuit open, the mechanism and
//! rotor inertia still attached; `bare_beam`/`bare_structure`: the host alone, read at the
//! attachments' points), writing `time_history.csv` and `time_history_<comparison>.csv` (entity-prefixed
//! columns, units in every header: [`crate::report::hybrid::Columns`]), `summary.json`
//! ([`crate::report::hybrid::HybridSummary`], with a `comparisons` block per comparison
//! run), `beam_displacement.svg` and `damping_vs_amplitude.svg`.
//!
//! A `kind = "mechanism"` scenario is a plain closed-loop mechanism (paper section 2.2,
//! eqs. 14–25): it writes `<stem>.csv` (`t`, every coordinate, every velocity
//! `<name>_dot`, `kinetic_energy`, `potential_energy`, `total_energy`,
//! `constraint_residual_norm`, `cond_jv`, units in brackets), `<stem>_summary.json` and
//! `<stem>.svg` (the coordinates against time, at most 20,000 rows plotted) (backend, settings,
//! energy drift, largest constraint residual, partition changes, steps, wall time, status).
//! When such a run stops (a singular configuration, a step size too small, the step limit)
//! nothing is written, as for every kind: the command fails with that error, naming the
//! scenario file and the time reached.
//!
//! The CSV time histories are streamed row by row to temporary files next to their final
//! names while the runs go ([`crate::report::stream`]); a run keeps only running figures
//! and its plot points decimated to at most 20,000 a series ([`crate::report::digest`]),
//! so memory does not grow with `t_end`. All
//! files of a run are committed together by the one atomic writer, or none; a run that
//! fails (or errors before the integration starts) leaves no file, no temporary file and
//! no output directory it created.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::Error;
use crate::report::{OutputLock, ReportError};
use crate::scenario::{self, Override, Scenario};

/// Arguments of `damper simulate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scenario file (`kind = "damper"`, `"hybrid"` or `"mechanism"`).
    pub scenario: PathBuf,
    /// Output directory (default: `out/<scenario name>`).
    #[arg(short = 'o', long = "out")]
    pub out: Option<PathBuf>,
    /// No progress bar even on a terminal.
    #[arg(long)]
    pub quiet: bool,
    /// Run even when the estimated steps, output rows or memory are above the limits
    /// (`codegen_cli::budget`: 2e7 steps, 2e6 rows, 1 GiB).
    #[arg(long)]
    pub allow_long: bool,
    /// Override a field of the scenario file: `--set PATH=VALUE` (repeatable, applied in
    /// order), PATH with dots and indices (`mechanism.half_angle_deg`,
    /// `beam.segment[0].elements`), VALUE a TOML value (a bare word is a string).
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub set: Vec<Override>,
}

/// Runs `damper simulate`.
pub fn run(args: Args) -> Result<(), Error> {
    let started = Instant::now();
    let loaded = scenario::load_with(&args.scenario, &args.set)?;
    crate::budget::structure(
        &loaded.scenario,
        &args.scenario.display().to_string(),
        args.allow_long,
    )?;
    let overrides = loaded.applied.records();
    let stem = args
        .scenario
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned());
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(stem.clone().unwrap_or_else(|| "run".into())));
    let progress = !args.quiet;
    check_out_dir(&out)?;
    // One run at a time into a directory; the files a killed run left are removed here.
    let _lock = OutputLock::acquire(&out).map_err(ReportError::from)?;
    // Problems found later (checks against the model) name the `--set` they come from.
    let remap = |e: Error| match e {
        Error::Input(d) => Error::Input(loaded.remap(d)),
        e => e,
    };
    match &loaded.scenario {
        Scenario::Mechanism(sc) => {
            let stem = stem.unwrap_or_else(|| "mechanism".into());
            crate::report::mechanism::simulate(
                sc,
                &out,
                &stem,
                progress,
                started,
                args.allow_long,
                overrides,
            )
        }
        Scenario::Hybrid(sc) => {
            crate::run_hybrid::simulate(sc, &out, progress, args.allow_long, overrides)
        }
    }
    .map_err(remap)
}

/// Checks before any work that the output directory can be used: it is a directory or does
/// not exist yet (it is created by the commit, when the run has its outputs).
fn check_out_dir(out: &Path) -> Result<(), Error> {
    match std::fs::metadata(out) {
        Ok(m) if !m.is_dir() => Err(Error::Usage(format!(
            "output directory {} is not a directory",
            out.display()
        ))),
        _ => Ok(()),
    }
}
