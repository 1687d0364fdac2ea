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
//! The command is this module (arguments, checks, the order of the steps); the analysis
//! (`analysis.rs`: the output and excitation resolved against the model, the linear and
//! nonlinear responses) and the report (`report.rs`: the files, through the one CSV writer
//! [`crate::report::rows::CsvRows`] and [`crate::report::plot::plot_receptance_svg`]) are
//! its two halves.

mod analysis;
mod report;

use std::path::PathBuf;

use crate::Error;
use crate::budget::{self, Quantity};
use crate::report::{OutputLock, ReportError, commit_files};
use crate::scenario::{self, Scenario};
use crate::setup::{Linearizable, tangents_for};
use hybrid_core::hybrid::Linearization;

pub(crate) use analysis::parse_output;
pub use analysis::{LinearRow, NonlinearRow, Receptance, grid};
use analysis::{linear_rows, nonlinear_rows, resolve, usage};
pub use report::NonlinearColumn;
use report::outputs;

/// Arguments of `damper frf`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scenario file (`kind = "damper"` or `kind = "hybrid"`).
    pub scenario: PathBuf,
    /// The response: a beam abscissa in m (`1.0`), or `MECHANISM/COORDINATE`
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

/// The responses of a loaded scenario as [`run`] computes them before writing its files.
pub struct Analysis {
    lz: Linearizable,
    lin: Linearization,
    io: analysis::Io,
    /// The frequencies of the linear response (Hz).
    pub freqs: Vec<f64>,
    /// The linear response, one row per frequency.
    pub linear: Vec<LinearRow>,
    /// The nonlinear steady states (`--nonlinear`).
    pub nonlinear: Option<Vec<NonlinearRow>>,
}

impl Analysis {
    /// The response's unit per unit force (`m/N`, `rad/N`, ..).
    pub fn unit(&self) -> String {
        self.io.unit()
    }

    /// The columns of `frf.csv` (the same headers), one number per frequency.
    pub fn columns(&self) -> Vec<(String, Vec<f64>)> {
        report::linear_columns(&self.io, &self.linear)
    }

    /// With `--nonlinear`, the columns of `frf_nonlinear.csv` (the same headers, the same
    /// values; built by the code that writes the file), one cell per frequency, typed as
    /// the cells read ([`NonlinearColumn`]: numbers with `None` for an empty cell, `periods` as
    /// counts, `settled` as flags, `error` as text).
    pub fn nonlinear_columns(&self) -> Option<Vec<(String, NonlinearColumn)>> {
        let nl = self.nonlinear.as_deref()?;
        Some(report::nonlinear_columns(&self.io, &self.linear, nl))
    }
}

/// The linear (and with `args.nonlinear` the nonlinear) frequency response of `sc` as
/// `args` asks (its scenario path and output directory unused): what `damper frf` writes.
pub fn analyse(args: &Args, sc: &Scenario) -> Result<Analysis, Error> {
    let file = args.scenario.display().to_string();
    if matches!(sc, Scenario::Mechanism(_)) {
        return Err(usage(format!(
            "{file}: `damper frf` needs a `damper` or `hybrid` scenario (a beam to respond)"
        )));
    }
    let lz = tangents_for(sc)?;
    let linear_error = |what: &str, e: hybrid_core::hybrid::LinearError| {
        usage(format!("{file}: linearisation {what}: {e}"))
    };
    let lin = lz
        .linearize(&lz.model)
        .map_err(|e| linear_error("with generator", e))?;
    let io = resolve(args, &lz, &lin)?;
    if args.nonlinear.is_some() && io.scenario_excitation.is_none() && args.force.is_none() {
        return Err(usage(
            "--nonlinear: the scenario has no harmonic excitation: give the force amplitude at the output point with --force F (N, or N m on a revolute coordinate)",
        ));
    }
    let off_model = lz.model.generators_disconnected();
    let lin_off = lz
        .linearize(&off_model)
        .map_err(|e| linear_error("generator disconnected", e))?;
    let f_with = lin.force_vector(&io.excitation.target);
    let f_off = lin_off.force_vector(&io.excitation.target);
    let freqs = grid(args.from, args.to, args.points, args.log);
    let linear = linear_rows(&lz.model, &lin, &lin_off, &io, (&f_with, &f_off), &freqs)?;
    let nonlinear = match args.nonlinear {
        None => None,
        Some(m) => Some(nonlinear_rows(args, &lz, &lin, &io, &f_with, m)?),
    };
    Ok(Analysis {
        lz,
        lin,
        io,
        freqs,
        linear,
        nonlinear,
    })
}

/// Checks the options of `args` that do not need the scenario (the range, the counts, the
/// limits of [`crate::budget`]).
pub fn check(args: &Args) -> Result<(), Error> {
    let file = args.scenario.display().to_string();
    // Frequencies a structure can have: 1e-9 Hz (a period of 30 years) to 1e12 Hz; the
    // bounds keep the geometric spacing and the logarithmic axis finite.
    let (lo, hi) = (1e-9, 1e12);
    let ok_range = args.from.is_finite()
        && args.to.is_finite()
        && args.from >= lo
        && args.to <= hi
        && args.to > args.from;
    if !ok_range {
        return Err(usage(format!(
            "--from {} --to {}: give {lo:e} <= from < to <= {hi:e} (Hz)",
            args.from, args.to
        )));
    }
    if args.points < 2 {
        return Err(usage("--points: at least 2"));
    }
    if args.nonlinear == Some(0) {
        return Err(usage("--nonlinear: at least 1 frequency"));
    }
    if !(args.tolerance > 0.0 && args.tolerance < 1.0) {
        return Err(usage("--tolerance: between 0 and 1"));
    }
    if args.steps_per_period < 8 {
        return Err(usage("--steps-per-period: at least 8"));
    }
    let frequencies = args.points as f64 + args.nonlinear.unwrap_or(0) as f64;
    let mut work = vec![Quantity::bytes(
        "memory",
        frequencies * budget::FRF_BYTES_PER_FREQUENCY,
        budget::MAX_MEMORY,
    )];
    if let Some(m) = args.nonlinear {
        work.push(Quantity::count(
            "time steps",
            m as f64 * args.max_periods as f64 * args.steps_per_period as f64,
            budget::MAX_STEPS,
        ));
    }
    budget::refuse_above(
        &file,
        &work,
        "use fewer --points or --nonlinear frequencies, or a smaller --max-periods or --steps-per-period",
        args.allow_long,
    )?;
    Ok(())
}

/// Runs `damper frf`.
pub fn run(args: Args) -> Result<(), Error> {
    check(&args)?;
    let file = args.scenario.display().to_string();
    let loaded = scenario::load_with(&args.scenario, &args.set)?;
    crate::budget::structure(&loaded.scenario, &file, args.allow_long)?;
    let sc = loaded.scenario.clone();
    let stem = args
        .scenario
        .file_stem()
        .map_or_else(|| "frf".into(), |s| s.to_string_lossy().into_owned());
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&stem));
    if std::fs::metadata(&out).is_ok_and(|m| !m.is_dir()) {
        return Err(usage(format!(
            "output directory {} is not a directory",
            out.display()
        )));
    }
    // One run at a time into a directory; the files a killed run left are removed here.
    let _lock = OutputLock::acquire(&out).map_err(ReportError::from)?;
    let Analysis {
        lz,
        lin,
        io,
        freqs,
        linear,
        nonlinear,
    } = analyse(&args, &sc)?;
    let generators = lz
        .model
        .forces
        .iter()
        .filter(|f| f.generator().is_some())
        .count();
    let warnings = band_edge_warnings(&linear, &io.unit());
    let files = outputs(
        &args,
        &out,
        &file,
        (&lz, &lin, &io),
        &linear,
        nonlinear.as_deref(),
        generators,
        &warnings,
    )?;
    commit_files(&files).map_err(ReportError::from)?;
    for w in &warnings {
        eprintln!("warning: {file}: {w}");
    }
    let peak_of = |of: fn(&LinearRow) -> f64| {
        linear
            .iter()
            .max_by(|a, b| of(a).total_cmp(&of(b)))
            .expect("at least two frequencies")
    };
    let peak = peak_of(|r| r.with_generator.magnitude);
    let peak_off = peak_of(|r| r.generator_disconnected.magnitude);
    let unit = io.unit();
    let mut text = format!(
        "{file}: {} frequencies {}-{} Hz; peak |H| with generator {:.4e} {unit} at {:.4} Hz, generator disconnected {:.4e} {unit} at {:.4} Hz",
        freqs.len(),
        args.from,
        args.to,
        peak.with_generator.magnitude,
        peak.f_hz,
        peak_off.generator_disconnected.magnitude,
        peak_off.f_hz
    );
    for (k, l) in io.limits.iter().enumerate() {
        let (f, v) = report::smallest(&linear, k);
        text += &format!(
            "; smallest max force ({}, reach {:.4e} m) {v:.4e} {} at {f:.4} Hz",
            l.name, l.reach, io.force_unit
        );
    }
    if let Some(rows) = &nonlinear {
        let settled = rows.iter().filter(|r| r.settled).count();
        let failed = rows.iter().filter(|r| r.error.is_some()).count();
        text += &format!(
            "; nonlinear: {} frequencies, {settled} settled, {failed} stopped",
            rows.len()
        );
    }
    text += &format!("; outputs in {}\n", out.display());
    crate::print(&text)
}

/// A warning for each linear response (with the generator, generator disconnected) whose
/// largest magnitude over the band lies at its first or last frequency: the peak the user is
/// after may lie outside the band (below it when at the first, above when at the last).
fn band_edge_warnings(linear: &[LinearRow], unit: &str) -> Vec<String> {
    type Of = fn(&LinearRow) -> f64;
    let responses: [(&str, Of); 2] = [
        ("with generator", |r| r.with_generator.magnitude),
        ("generator disconnected", |r| {
            r.generator_disconnected.magnitude
        }),
    ];
    let n = linear.len();
    responses
        .iter()
        .filter_map(|(label, of)| {
            let k = (0..n).max_by(|&a, &b| of(&linear[a]).total_cmp(&of(&linear[b])))?;
            let side = if k == 0 {
                "first"
            } else if k + 1 == n {
                "last"
            } else {
                return None;
            };
            let (below, widen) = if k == 0 {
                ("below", "--from")
            } else {
                ("above", "--to")
            };
            Some(format!(
                "the largest |H| {label} ({:.4e} {unit}) is at the {side} frequency of the band, {} Hz: the peak may lie {below} the band (widen it with {widen})",
                of(&linear[k]),
                linear[k].f_hz
            ))
        })
        .collect()
}
