//! `damper frf SCENARIO --output POINT --from F1 --to F2 [--points N] [--log]
//! [--nonlinear M] [--excitation NAME] [--force F] [-o DIR]`: the frequency response of a
//! damper or hybrid scenario (issue #11, item 4).
//!
//! - **Linear**: the receptance `H(f)` (response per unit force) at the output, from the
//!   linearisation about the static equilibrium
//!   ([`hybrid_core::hybrid::Linearization::harmonic_response`]), with the generator and with
//!   it disconnected (`connected = false`: no current, the rotor inertia still attached; the
//!   inductance plays no part), on `--points` frequencies from `--from` to `--to` Hz (evenly
//!   spaced, or geometrically with `--log`).
//! - **Nonlinear** (`--nonlinear M`): the steady-state amplitude and phase of the fundamental
//!   from time-domain runs of the full nonlinear system under the harmonic excitation
//!   ([`hybrid_core::hybrid::steady_states`]: exact Fourier fit per period, settle test on
//!   the change per period and its geometric tail), on `M` frequencies over the same range
//!   and spacing, with the generator connected, in parallel; `|H| = A / |F|`.
//!
//! **The output** (`--output`): a beam abscissa in m (`1.0`: the transverse displacement
//! there), or `MECHANISM/COORDINATE` (`absorber/theta`, `damper/q1`: a mechanism
//! coordinate; the mechanism of a damper scenario is called `damper`).
//!
//! **The excitation**: `--excitation NAME` picks one of the scenario's excitations (its
//! target, and its amplitude for the nonlinear runs, unless `--force` replaces it); without
//! it, the scenario's only harmonic excitation; a scenario without one (every damper
//! scenario) is excited by a force (or a torque, on a coordinate) at the output point, of
//! amplitude `--force F` (N or N m), which `--nonlinear` then requires (the linear receptance
//! does not depend on it). The nonlinear runs keep the scenario's constant excitations and
//! leave out its other time-dependent ones.
//!
//! Outputs in DIR (default `out/<scenario name>`), committed together by the one atomic
//! writer (complete or absent): `frf.csv` (`f [Hz]`, `|H| with generator [m/N]`,
//! `phase with generator [deg]`, `|H| generator disconnected [m/N]`,
//! `phase generator disconnected [deg]`, real and imaginary parts), `frf_nonlinear.csv`
//! (with `--nonlinear`: amplitude, `|H|`, phase, the linear values at the same frequency,
//! periods, settled, distortion, time step, error), `frf.json` (settings and every value) and
//! `frf.svg` (|H| on a log axis: the linear responses as lines, the nonlinear one as
//! markers). Phases follow `response = |H| F sin(omega t + phi_e + phase)`.
//!
//! **Admissible load** (issue #22, item 3; [`crate::linear::LoadLimit`]): for every
//! mechanism with a reach (the remaining distance of its first attached beam point to the
//! toggle, as `damper linearize` reports it), at every frequency, the largest force
//! amplitude of the excitation it can take, `max_force = reach / |H_att|`, with `H_att`
//! the receptance (with the generator) from the excitation to that beam point, read from
//! the same solve as the output's: a column `max_force [F]` of `frf.csv`
//! (`<mechanism>.max_force [F]` with several), `load_limits` and each row's `max_force` in
//! `frf.json`, `frf_max_force.svg` (the curves and the excitation's own amplitude as a
//! horizontal line) and the smallest value over the band in the summary line. It is the
//! linear bound: near the toggle the mechanism's growing amplification raises the
//! generator's damping, so the nonlinear amplitude stays below the linear one.
//!
//! **Limits** (`crate::budget`), checked before the scenario is loaded: the memory of the
//! `--points` (and `--nonlinear`) frequencies, 4 kB each, at most 1 GiB, and the time steps
//! the nonlinear runs can take, `M * max_periods * steps_per_period`, at most 2e7; above
//! them the command is refused unless `--allow-long`.
//!
//! The command is this module (arguments → [`FrfRequest`], the result → files and the
//! summary line); the analysis is [`crate::analysis::frf`], the files
//! [`crate::report::frf`] (through the one CSV writer and the plots).

use std::path::PathBuf;

use crate::Error;
use crate::analysis::frf::{FrfRequest, analyse, check};
use crate::report::frf::{outputs, summary};
use crate::report::{OutputLock, ReportError, commit_files};
use crate::scenario;

/// Arguments of `damper frf`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scenario file (`kind = "damper"` or `kind = "hybrid"`).
    pub scenario: PathBuf,
    /// The response: a beam abscissa in m (`1.0`), `NODE:DOF` on an imported structure
    /// (`613:ux`), or `MECHANISM/COORDINATE`
    /// (`absorber/theta`; a damper scenario's mechanism is `damper`).
    #[arg(long)]
    pub output: String,
    /// Lowest frequency (Hz).
    #[arg(long)]
    pub from: f64,
    /// Highest frequency (Hz).
    #[arg(long)]
    pub to: f64,
    /// Frequencies of the linear response.
    #[arg(long, default_value_t = 400)]
    pub points: usize,
    /// Geometric spacing of the frequencies (and a log frequency axis).
    #[arg(long)]
    pub log: bool,
    /// Also the nonlinear steady state from time-domain runs at this many frequencies.
    #[arg(long, value_name = "M")]
    pub nonlinear: Option<usize>,
    /// The scenario excitation that drives the system (default: its only harmonic one).
    #[arg(long, value_name = "NAME")]
    pub excitation: Option<String>,
    /// Force amplitude (N, or N m on a revolute coordinate) at the output point when the
    /// scenario has no harmonic excitation; replaces the amplitude of `--excitation`.
    #[arg(long, value_name = "F")]
    pub force: Option<f64>,
    /// Override a field of the scenario file: `--set PATH=VALUE` (repeatable).
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub set: Vec<scenario::Override>,
    /// Time steps per excitation period of the nonlinear runs.
    #[arg(long, default_value_t = 200)]
    pub steps_per_period: usize,
    /// Settle tolerance of the nonlinear runs (relative change of the fundamental per
    /// period, and its geometric tail).
    #[arg(long, default_value_t = 1e-3)]
    pub tolerance: f64,
    /// Periods run at most per frequency before reporting `settled = false`.
    #[arg(long, default_value_t = 1000)]
    pub max_periods: usize,
    /// Output directory (default: `out/<scenario name>`).
    #[arg(short = 'o', long = "out")]
    pub out: Option<PathBuf>,
    /// No progress bar for the nonlinear runs even on a terminal.
    #[arg(long)]
    pub quiet: bool,
    /// Run even when the estimated memory (1 GiB: about 260,000 frequencies) or the time
    /// steps of the nonlinear runs (`M * max_periods * steps_per_period`, 2e7) are above the
    /// limits (`codegen_cli::budget`).
    #[arg(long)]
    pub allow_long: bool,
}

impl Args {
    /// The analysis these arguments ask for.
    pub fn request(&self) -> FrfRequest {
        FrfRequest {
            file: self.scenario.display().to_string(),
            output: self.output.clone(),
            from: self.from,
            to: self.to,
            points: self.points,
            log: self.log,
            nonlinear: self.nonlinear,
            excitation: self.excitation.clone(),
            force: self.force,
            steps_per_period: self.steps_per_period,
            tolerance: self.tolerance,
            max_periods: self.max_periods,
            progress: !self.quiet,
            allow_long: self.allow_long,
        }
    }
}

/// Runs `damper frf`.
pub fn run(args: Args) -> Result<(), Error> {
    let req = args.request();
    check(&req)?;
    let file = req.file.clone();
    let loaded = scenario::load_with(&args.scenario, &args.set)?;
    crate::budget::structure(&loaded.scenario, &file, args.allow_long)?;
    let stem = args
        .scenario
        .file_stem()
        .map_or_else(|| "frf".into(), |s| s.to_string_lossy().into_owned());
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&stem));
    if std::fs::metadata(&out).is_ok_and(|m| !m.is_dir()) {
        return Err(Error::Usage(format!(
            "output directory {} is not a directory",
            out.display()
        )));
    }
    // One run at a time into a directory; the files a killed run left are removed here.
    let _lock = OutputLock::acquire(&out).map_err(ReportError::from)?;
    let frf = analyse(&req, &loaded.scenario)?;
    let overrides = args.set.iter().map(scenario::Override::record).collect();
    let files = outputs(&req, overrides, &out, &frf)?;
    for w in frf.warnings.iter().filter(|w| w.note) {
        eprintln!("{w}");
    }
    commit_files(&files).map_err(ReportError::from)?;
    for w in frf.warnings.iter().filter(|w| !w.note) {
        eprintln!("{w}");
    }
    crate::print(&summary(&req, &out, &frf))
}
