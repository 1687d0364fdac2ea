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
//! **Limits** (`crate::budget`), checked before the scenario is loaded: the memory of the
//! `--points` (and `--nonlinear`) frequencies, 4 kB each, at most 1 GiB, and the time steps
//! the nonlinear runs can take, `M * max_periods * steps_per_period`, at most 2e7; above
//! them the command is refused unless `--allow-long`.

use std::path::{Path, PathBuf};

use fem_beam::TimeFunction;
use hybrid_core::hybrid::{
    BeamPoint, Excitation, ExcitationTarget, HybridModel, Linearization, SteadyOptions, rest_state,
    steady_states,
};
use nalgebra::Complex;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use serde::Serialize;

use crate::Error;
use crate::budget::{self, Quantity};
use crate::report::summary::json_bytes;
use crate::report::{OutputFile, OutputLock, ReportError, commit_files};
use crate::scenario::{self, Scenario};
use crate::setup::{Linearizable, tangents_for};

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

/// The response and the force, resolved against the model.
struct Io {
    output: ExcitationTarget,
    output_label: String,
    response_unit: &'static str,
    force_unit: &'static str,
    excitation: Excitation,
    /// Index of a scenario excitation, `None` for the force at the output point.
    scenario_excitation: Option<usize>,
}

impl Io {
    /// The receptance's unit: `m/N`, `rad/(N m)`, ...
    fn unit(&self) -> String {
        if self.force_unit.contains(' ') {
            format!("{}/({})", self.response_unit, self.force_unit)
        } else {
            format!("{}/{}", self.response_unit, self.force_unit)
        }
    }
}

/// One linear value: `|H|`, phase (deg), real and imaginary parts.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Receptance {
    /// `|H|`.
    pub magnitude: f64,
    /// `arg H` (deg).
    pub phase_deg: f64,
    /// `Re H`.
    pub re: f64,
    /// `Im H`.
    pub im: f64,
}

impl From<Complex<f64>> for Receptance {
    fn from(h: Complex<f64>) -> Self {
        Receptance {
            magnitude: h.norm(),
            phase_deg: h.arg().to_degrees(),
            re: h.re,
            im: h.im,
        }
    }
}

/// One row of the linear response.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct LinearRow {
    /// Frequency (Hz).
    pub f_hz: f64,
    /// With the generator.
    pub with_generator: Receptance,
    /// Generator disconnected.
    pub generator_disconnected: Receptance,
}

/// One nonlinear steady state.
#[derive(Clone, Debug, Serialize)]
pub struct NonlinearRow {
    /// Frequency (Hz).
    pub f_hz: f64,
    /// Amplitude of the fundamental (response unit).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub amplitude: Option<f64>,
    /// `A / |F|`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub magnitude: Option<f64>,
    /// Phase relative to the excitation (deg).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub phase_deg: Option<f64>,
    /// RMS of the fit's residual relative to the amplitude.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub distortion: Option<f64>,
    /// Periods run (up to the stop when there is an error).
    pub periods: usize,
    /// Whether the settle criterion was met.
    pub settled: bool,
    /// Time step (s).
    pub dt: f64,
    /// The linear receptance (with generator) at the same frequency.
    pub linear: Receptance,
    /// Why the run stopped (singular position, no convergence), if it did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// `frf.json`.
#[derive(Serialize)]
struct FrfJson<'a> {
    scenario: String,
    overrides: Vec<scenario::OverrideRecord>,
    output: &'a str,
    response_unit: &'a str,
    force_unit: &'a str,
    excitation: &'a str,
    force_amplitude: f64,
    phase_convention: &'static str,
    from_hz: f64,
    to_hz: f64,
    points: usize,
    log: bool,
    equilibrium_newton_iterations: usize,
    generators: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    nonlinear_settings: Option<NonlinearSettings>,
    linear: &'a [LinearRow],
    #[serde(skip_serializing_if = "Option::is_none")]
    nonlinear: Option<&'a [NonlinearRow]>,
}

#[derive(Serialize)]
struct NonlinearSettings {
    steps_per_period: usize,
    tolerance: f64,
    max_periods: usize,
    method: &'static str,
}

/// `n` frequencies from `a` to `b`, evenly or geometrically spaced (`n = 1`: the middle).
pub fn grid(a: f64, b: f64, n: usize, log: bool) -> Vec<f64> {
    if n == 1 {
        return vec![if log { (a * b).sqrt() } else { 0.5 * (a + b) }];
    }
    (0..n)
        .map(|k| {
            let s = k as f64 / (n - 1) as f64;
            if log {
                a * (b / a).powf(s)
            } else {
                a + (b - a) * s
            }
        })
        .collect()
}

fn usage(msg: impl Into<String>) -> Error {
    Error::Usage(msg.into())
}

/// Resolves `--output`, `--excitation` and `--force` against the model.
fn resolve(args: &Args, lz: &Linearizable) -> Result<Io, Error> {
    let model = &lz.model;
    let (output, output_label, response_unit) = match args.output.split_once('/') {
        None => {
            let x: f64 = args.output.trim().parse().map_err(|_| {
                usage(format!(
                    "--output {:?}: give a beam abscissa in m (1.0) or MECHANISM/COORDINATE",
                    args.output
                ))
            })?;
            let beam = model
                .beam
                .as_ref()
                .ok_or_else(|| usage("--output: the scenario has no beam"))?;
            let p = BeamPoint::on(beam, x)
                .filter(|p| !p.is_locked())
                .ok_or_else(|| {
                    usage(format!(
                        "--output {x}: not a point of the beam that can move transversely"
                    ))
                })?;
            (ExcitationTarget::Beam(p), format!("beam w(x = {x} m)"), "m")
        }
        Some((mech, coord)) => {
            let names: Vec<&str> = model.mechanisms.iter().map(|m| m.name.as_str()).collect();
            let i = names.iter().position(|n| *n == mech).ok_or_else(|| {
                usage(format!(
                    "--output: no mechanism {mech:?} (mechanisms: {})",
                    names.join(", ")
                ))
            })?;
            let sys = &model.mechanisms[i].system;
            let j = sys.coordinate_index(coord).ok_or_else(|| {
                usage(format!(
                    "--output: mechanism {mech:?} has no coordinate {coord:?} (coordinates: {})",
                    sys.coordinate_names().join(", ")
                ))
            })?;
            let unit = sys.coordinate_units()[j];
            (
                ExcitationTarget::Joint {
                    mechanism: i,
                    joint: j,
                },
                format!("{mech}/{coord}"),
                unit.symbol(),
            )
        }
    };
    let harmonic = |e: &Excitation| matches!(e.time, TimeFunction::Harmonic { .. });
    let chosen = match &args.excitation {
        Some(name) => Some(
            model
                .excitations
                .iter()
                .position(|e| &e.name == name)
                .ok_or_else(|| {
                    let known: Vec<&str> =
                        model.excitations.iter().map(|e| e.name.as_str()).collect();
                    usage(format!(
                        "--excitation: no excitation {name:?} in the scenario (excitations: {})",
                        if known.is_empty() {
                            "none".into()
                        } else {
                            known.join(", ")
                        }
                    ))
                })?,
        ),
        None => {
            let h: Vec<usize> = (0..model.excitations.len())
                .filter(|&k| harmonic(&model.excitations[k]))
                .collect();
            match h.len() {
                0 => None,
                1 => Some(h[0]),
                _ => {
                    return Err(usage(format!(
                        "the scenario has {} harmonic excitations: choose one with --excitation",
                        h.len()
                    )));
                }
            }
        }
    };
    if let Some(f) = args.force
        && !f.is_finite()
    {
        return Err(usage(format!("--force {f}: not a finite number")));
    }
    let excitation = match chosen {
        Some(k) => {
            let mut e = model.excitations[k].clone();
            if let Some(f) = args.force {
                e.amplitude = f;
            }
            e
        }
        None => Excitation {
            name: "force at the output".into(),
            target: output.clone(),
            amplitude: args.force.unwrap_or(1.0),
            time: TimeFunction::Harmonic {
                frequency_hz: args.from,
                phase: 0.0,
            },
        },
    };
    // The force's unit follows its target (a beam force, or a joint torque or force).
    let force_unit = match &excitation.target {
        ExcitationTarget::Beam(_) => "N",
        ExcitationTarget::Joint { mechanism, joint } => {
            lz.model.mechanisms[*mechanism].system.coordinate_units()[*joint].force()
        }
    };
    Ok(Io {
        output,
        output_label,
        response_unit,
        force_unit,
        excitation,
        scenario_excitation: chosen,
    })
}

/// The receptance at the output for the force vector `f`, at `omega` (rad/s).
fn receptance(
    lin: &Linearization,
    output: &ExcitationTarget,
    f: &[f64],
    omega: f64,
) -> Result<Complex<f64>, Error> {
    let z = lin
        .harmonic_response(f, omega)
        .map_err(|e| usage(format!("harmonic response at {omega} rad/s: {e}")))?;
    Ok(match output {
        ExcitationTarget::Beam(p) => {
            let re: Vec<f64> = z.iter().map(|v| v.re).collect();
            let im: Vec<f64> = z.iter().map(|v| v.im).collect();
            Complex::new(p.value(&re), p.value(&im))
        }
        ExcitationTarget::Joint { mechanism, joint } => {
            lin.mechanism_motion(&z)[*mechanism][*joint]
        }
    })
}

/// Runs `damper frf`.
pub fn run(args: Args) -> Result<(), Error> {
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
    let loaded = scenario::load_with(&args.scenario, &args.set)?;
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
    if matches!(sc, Scenario::Mechanism(_)) {
        return Err(usage(format!(
            "{file}: `damper frf` needs a `damper` or `hybrid` scenario (a beam to respond)"
        )));
    }
    // One run at a time into a directory; the files a killed run left are removed here.
    let _lock = OutputLock::acquire(&out).map_err(ReportError::from)?;
    let lz = tangents_for(&sc)?;
    let io = resolve(&args, &lz)?;
    if args.nonlinear.is_some() && io.scenario_excitation.is_none() && args.force.is_none() {
        return Err(usage(
            "--nonlinear: the scenario has no harmonic excitation: give the force amplitude at the output point with --force F (N, or N m on a revolute coordinate)",
        ));
    }
    let linear_error = |what: &str, e: hybrid_core::hybrid::LinearError| {
        usage(format!("{file}: linearisation {what}: {e}"))
    };
    let lin = lz
        .linearize(&lz.model)
        .map_err(|e| linear_error("with generator", e))?;
    let off_model = lz.model.generators_disconnected();
    let lin_off = lz
        .linearize(&off_model)
        .map_err(|e| linear_error("generator disconnected", e))?;
    let f_with = lin.force_vector(&io.excitation.target);
    let f_off = lin_off.force_vector(&io.excitation.target);
    let freqs = grid(args.from, args.to, args.points, args.log);
    let mut linear = Vec::with_capacity(freqs.len());
    for &f in &freqs {
        let w = 2.0 * std::f64::consts::PI * f;
        linear.push(LinearRow {
            f_hz: f,
            with_generator: receptance(&lin, &io.output, &f_with, w)?.into(),
            generator_disconnected: receptance(&lin_off, &io.output, &f_off, w)?.into(),
        });
    }
    let nonlinear = match args.nonlinear {
        None => None,
        Some(m) => Some(nonlinear_rows(&args, &lz, &lin, &io, &f_with, m)?),
    };
    let generators = lz
        .model
        .forces
        .iter()
        .filter(|f| f.generator().is_some())
        .count();
    let files = outputs(
        &args,
        &out,
        &file,
        &lz,
        &lin,
        &io,
        &linear,
        nonlinear.as_deref(),
        generators,
    )?;
    commit_files(&files).map_err(ReportError::from)?;
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

/// The nonlinear steady states at `m` frequencies.
fn nonlinear_rows(
    args: &Args,
    lz: &Linearizable,
    lin: &Linearization,
    io: &Io,
    f_with: &[f64],
    m: usize,
) -> Result<Vec<NonlinearRow>, Error> {
    let mut model: HybridModel = lz.model.clone();
    // Constant excitations stay (they are part of the equilibrium); the driving one is put
    // last; other time-dependent ones are left out.
    model
        .excitations
        .retain(|e| e.time == TimeFunction::Constant);
    let dropped = lz.model.excitations.len()
        - model.excitations.len()
        - usize::from(io.scenario_excitation.is_some());
    if dropped > 0 {
        eprintln!(
            "note: the nonlinear runs leave out {dropped} other time-dependent excitation(s) of the scenario"
        );
    }
    model.excitations.push(io.excitation.clone());
    let excitation = model.excitations.len() - 1;
    let start = rest_state(&mut model, &lin.equilibrium).map_err(|e| {
        usage(format!(
            "{}: the rest state at the static equilibrium: {e}",
            args.scenario.display()
        ))
    })?;
    let options = SteadyOptions {
        excitation,
        method: lz.method,
        steps_per_period: args.steps_per_period,
        tolerance: args.tolerance,
        min_periods: 10,
        max_periods: args.max_periods,
    };
    let freqs = grid(args.from, args.to, m, args.log);
    let bar = crate::progress::bar_or_hidden(
        !args.quiet,
        freqs.len() as u64,
        "frf nonlinear [{bar:40}] {pos}/{len} ETA {eta}",
    );
    let results = steady_states(&model, &start, &io.output, &freqs, &options, &|| bar.inc(1));
    bar.finish_and_clear();
    let force = io.excitation.amplitude.abs();
    let mut rows = Vec::with_capacity(m);
    for (&f, r) in freqs.iter().zip(results) {
        let w = 2.0 * std::f64::consts::PI * f;
        let linear: Receptance = receptance(lin, &io.output, f_with, w)?.into();
        let dt = 1.0 / (f * args.steps_per_period as f64);
        rows.push(match r {
            Ok(s) => NonlinearRow {
                f_hz: f,
                amplitude: Some(s.amplitude),
                magnitude: (force > 0.0).then(|| s.amplitude / force),
                phase_deg: Some(s.phase.to_degrees()),
                distortion: Some(s.distortion),
                periods: s.periods,
                settled: s.settled,
                dt: s.dt,
                linear,
                error: None,
            },
            Err(e) => NonlinearRow {
                f_hz: f,
                amplitude: None,
                magnitude: None,
                phase_deg: None,
                distortion: None,
                periods: e.period,
                settled: false,
                dt,
                linear,
                error: Some(e.error.to_string()),
            },
        });
    }
    Ok(rows)
}

/// The plot could not be drawn (plotters' message).
#[derive(Debug, thiserror::Error)]
#[error("cannot draw frf.svg: {0}")]
struct PlotFailed(String);

impl From<PlotFailed> for Error {
    fn from(e: PlotFailed) -> Error {
        Error::Usage(e.to_string())
    }
}

fn csv_bytes(header: &[String], rows: &[Vec<String>]) -> Result<Vec<u8>, ReportError> {
    let mut w = ::csv::Writer::from_writer(Vec::new());
    w.write_record(header)?;
    for r in rows {
        w.write_record(r)?;
    }
    w.into_inner()
        .map_err(|e| ReportError::Csv(e.into_error().into()))
}

/// Every output file, in memory.
#[allow(clippy::too_many_arguments)]
fn outputs(
    args: &Args,
    out: &Path,
    file: &str,
    lz: &Linearizable,
    lin: &Linearization,
    io: &Io,
    linear: &[LinearRow],
    nonlinear: Option<&[NonlinearRow]>,
    generators: usize,
) -> Result<Vec<OutputFile>, Error> {
    let unit = io.unit();
    let g = |v: f64| format!("{v:e}");
    let header: Vec<String> = vec![
        "f [Hz]".into(),
        format!("|H| with generator [{unit}]"),
        "phase with generator [deg]".into(),
        format!("|H| generator disconnected [{unit}]"),
        "phase generator disconnected [deg]".into(),
        format!("Re H with generator [{unit}]"),
        format!("Im H with generator [{unit}]"),
        format!("Re H generator disconnected [{unit}]"),
        format!("Im H generator disconnected [{unit}]"),
    ];
    let rows: Vec<Vec<String>> = linear
        .iter()
        .map(|r| {
            let (a, b) = (r.with_generator, r.generator_disconnected);
            vec![
                g(r.f_hz),
                g(a.magnitude),
                g(a.phase_deg),
                g(b.magnitude),
                g(b.phase_deg),
                g(a.re),
                g(a.im),
                g(b.re),
                g(b.im),
            ]
        })
        .collect();
    let mut files = vec![OutputFile {
        path: out.join("frf.csv"),
        bytes: csv_bytes(&header, &rows).map_err(Error::from)?,
    }];
    if let Some(nl) = nonlinear {
        let header: Vec<String> = vec![
            "f [Hz]".into(),
            format!("amplitude [{}]", io.response_unit),
            format!("|H| [{unit}]"),
            "phase [deg]".into(),
            format!("|H| linear [{unit}]"),
            "phase linear [deg]".into(),
            "periods".into(),
            "settled".into(),
            "distortion [-]".into(),
            "dt [s]".into(),
            "error".into(),
        ];
        let opt = |v: Option<f64>| v.map_or_else(String::new, g);
        let rows: Vec<Vec<String>> = nl
            .iter()
            .map(|r| {
                vec![
                    g(r.f_hz),
                    opt(r.amplitude),
                    opt(r.magnitude),
                    opt(r.phase_deg),
                    g(r.linear.magnitude),
                    g(r.linear.phase_deg),
                    r.periods.to_string(),
                    r.settled.to_string(),
                    opt(r.distortion),
                    g(r.dt),
                    r.error.clone().unwrap_or_default(),
                ]
            })
            .collect();
        files.push(OutputFile {
            path: out.join("frf_nonlinear.csv"),
            bytes: csv_bytes(&header, &rows).map_err(Error::from)?,
        });
    }
    let json = FrfJson {
        scenario: file.to_string(),
        overrides: args.set.iter().map(scenario::Override::record).collect(),
        output: &io.output_label,
        response_unit: io.response_unit,
        force_unit: io.force_unit,
        excitation: &io.excitation.name,
        force_amplitude: io.excitation.amplitude,
        phase_convention: "response = |H| F sin(omega t + phi_excitation + phase)",
        from_hz: args.from,
        to_hz: args.to,
        points: args.points,
        log: args.log,
        equilibrium_newton_iterations: lin.equilibrium.iterations,
        generators,
        nonlinear_settings: nonlinear.map(|_| NonlinearSettings {
            steps_per_period: args.steps_per_period,
            tolerance: args.tolerance,
            max_periods: args.max_periods,
            method: match lz.method {
                hybrid_core::damper::Method::Newmark => "newmark",
                _ => "hht",
            },
        }),
        linear,
        nonlinear,
    };
    files.push(OutputFile {
        path: out.join("frf.json"),
        bytes: json_bytes(&json).map_err(ReportError::from)?,
    });
    let stem = Path::new(file)
        .file_stem()
        .map_or_else(|| file.to_string(), |s| s.to_string_lossy().into_owned());
    let mut title = format!(
        "{stem}: receptance {} / {} ({})",
        io.output_label, io.excitation.name, unit
    );
    if nonlinear.is_some() {
        title += &format!(
            "; nonlinear at |F| = {:.3e} {}, {} steps/period",
            io.excitation.amplitude.abs(),
            io.force_unit,
            args.steps_per_period
        );
    }
    let svg = if args.log {
        plot(
            &title,
            &unit,
            (args.from..args.to)
                .log_scale()
                .with_key_points(log_ticks(args.from, args.to)),
            linear,
            nonlinear,
        )
    } else {
        plot(&title, &unit, args.from..args.to, linear, nonlinear)
    }
    .map_err(PlotFailed)?;
    files.push(OutputFile {
        path: out.join("frf.svg"),
        bytes: svg,
    });
    Ok(files)
}

/// Tick values of a log axis over `[a, b]` (`0 < a < b`): the 1-2-5 sequence of every
/// decade, thinned to 1-3 or to the decades when it would give more than 12 ticks; the two
/// ends are added when fewer than 3 values fall inside.
fn log_ticks(a: f64, b: f64) -> Vec<f64> {
    let (lo, hi) = (a.log10().floor() as i32, b.log10().ceil() as i32);
    let inside = |mantissas: &[f64]| -> Vec<f64> {
        (lo..=hi)
            .flat_map(|e| mantissas.iter().map(move |m| m * 10f64.powi(e)))
            .filter(|v| *v >= a * (1.0 - 1e-12) && *v <= b * (1.0 + 1e-12))
            .collect()
    };
    let mut ticks = [&[1.0, 2.0, 5.0][..], &[1.0, 3.0], &[1.0]]
        .iter()
        .map(|m| inside(m))
        .find(|t| t.len() <= 12)
        .unwrap_or_default();
    if ticks.len() < 3 {
        ticks.extend([a, b]);
        ticks.sort_by(f64::total_cmp);
        ticks.dedup_by(|x, y| (*x - *y).abs() <= 1e-9 * y.abs());
    }
    ticks
}

/// A tick label: at most four significant digits, no trailing zeros (`2`, `0.5`, `12.5`).
fn tick_label(v: f64) -> String {
    let digits = (3 - v.abs().log10().floor() as i32).clamp(0, 12) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// The SVG plot: `|H|` on a log axis against frequency (`x`: a linear or log range), the
/// linear responses as lines, the nonlinear steady states as markers; the legend in a panel
/// of its own right of the chart (off the traces).
fn plot<X>(
    title: &str,
    unit: &str,
    x: X,
    linear: &[LinearRow],
    nonlinear: Option<&[NonlinearRow]>,
) -> Result<Vec<u8>, String>
where
    X: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
{
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let mut values: Vec<f64> = linear
        .iter()
        .flat_map(|r| {
            [
                r.with_generator.magnitude,
                r.generator_disconnected.magnitude,
            ]
        })
        .chain(nonlinear.into_iter().flatten().filter_map(|r| r.magnitude))
        .filter(|v| *v > 0.0 && v.is_finite())
        .collect();
    if values.is_empty() {
        values.push(1.0);
    }
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min) / 1.5;
    let hi = values.iter().copied().fold(0.0, f64::max) * 1.5;
    let red = RGBColor(200, 30, 30);
    let blue = RGBColor(30, 80, 200);
    let black = RGBColor(0, 0, 0);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1100, 560)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let root = root
            .titled(title, ("sans-serif", 18))
            .map_err(|e| err(&e))?;
        let (left, right) = root.split_horizontally(860);
        let mut chart = ChartBuilder::on(&left)
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(x, (lo..hi).log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("frequency (Hz)")
            .x_labels(12)
            .x_label_formatter(&|v| tick_label(*v))
            .y_desc(format!("|H| ({unit})"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(|e| err(&e))?;
        chart
            .draw_series(LineSeries::new(
                linear
                    .iter()
                    .map(|r| (r.f_hz, r.generator_disconnected.magnitude)),
                blue.stroke_width(2),
            ))
            .map_err(|e| err(&e))?;
        chart
            .draw_series(LineSeries::new(
                linear.iter().map(|r| (r.f_hz, r.with_generator.magnitude)),
                red.stroke_width(2),
            ))
            .map_err(|e| err(&e))?;
        if let Some(nl) = nonlinear {
            chart
                .draw_series(nl.iter().filter_map(|r| {
                    let m = r.magnitude.filter(|m| *m > 0.0)?;
                    Some(Circle::new(
                        (r.f_hz, m),
                        4,
                        if r.settled {
                            black.filled()
                        } else {
                            black.stroke_width(1)
                        },
                    ))
                }))
                .map_err(|e| err(&e))?;
        }
        // The legend, in its own panel.
        let mut entries: Vec<(&str, ShapeStyle, bool)> = vec![
            ("linear, with generator", red.stroke_width(2), false),
            (
                "linear, generator disconnected",
                blue.stroke_width(2),
                false,
            ),
        ];
        if nonlinear.is_some() {
            entries.push(("nonlinear steady state", black.filled(), true));
            entries.push(("(open: not settled)", black.stroke_width(1), true));
        }
        for (k, (label, style, marker)) in entries.into_iter().enumerate() {
            let y = 40 + 26 * k as i32;
            if marker {
                right
                    .draw(&Circle::new((18, y), 4, style))
                    .map_err(|e| err(&e))?;
            } else {
                right
                    .draw(&PathElement::new(vec![(5, y), (30, y)], style))
                    .map_err(|e| err(&e))?;
            }
            right
                .draw(&Text::new(label, (38, y - 7), ("sans-serif", 14)))
                .map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg.into_bytes())
}

#[cfg(test)]
mod tests {
    use super::{log_ticks, tick_label};

    #[test]
    fn log_ticks_follow_1_2_5_and_thin_out() {
        assert_eq!(log_ticks(2.0, 20.0), vec![2.0, 5.0, 10.0, 20.0]);
        assert_eq!(
            log_ticks(0.1, 100.0),
            vec![0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0]
        );
        // Six decades: 1-3 would give 13, so the decades alone.
        assert_eq!(
            log_ticks(1.0, 1e6),
            vec![1.0, 10.0, 100.0, 1e3, 1e4, 1e5, 1e6]
        );
        // Less than a tick pair inside: the ends are added.
        assert_eq!(log_ticks(5.5, 7.5), vec![5.5, 7.5]);
        assert_eq!(log_ticks(4.5, 9.0), vec![4.5, 5.0, 9.0]);
    }

    #[test]
    fn tick_labels_are_short() {
        let labels: Vec<String> = [2.0, 0.5, 12.5, 100.0, 6.425, 0.002, 1e5]
            .into_iter()
            .map(tick_label)
            .collect();
        assert_eq!(
            labels,
            ["2", "0.5", "12.5", "100", "6.425", "0.002", "100000"]
        );
    }
}
