//! The frequency response ([`FrfRequest`] → [`analyse`] → [`Frf`]), what `damper frf` and
//! Python's `Scenario.frf` compute: the output and the excitation resolved against the
//! model, the linear receptances (with the generator and with it disconnected) from the
//! linearisation about the static equilibrium, `H(f) = z_out(f) / F` with
//! `(K - omega^2 M + i omega C) z = f_F`, and the nonlinear steady states from time-domain
//! runs (amplitude and phase of the fundamental, `|H| = A / |F|`); the warnings (a largest
//! response at an edge of the band, excitations the nonlinear runs leave out) as data.

use fem_beam::TimeFunction;
use hybrid_core::hybrid::{
    BeamPoint, Excitation, ExcitationTarget, HybridModel, Linearization, SteadyOptions, rest_state,
    steady_states,
};
use nalgebra::Complex;
use serde::Serialize;

use super::{AnalysisError, Warning};
use crate::Error;
use crate::budget::{self, Quantity};
use crate::linear::{LoadLimit, generator_phasors};
use crate::scenario::Scenario;
use crate::setup::Linearizable;
use crate::setup::tangents_for;

/// The response and the force, resolved against the model.
pub(crate) struct Io {
    pub(crate) output: ExcitationTarget,
    pub(crate) output_label: String,
    pub(crate) response_unit: &'static str,
    pub(crate) force_unit: &'static str,
    pub(crate) excitation: Excitation,
    /// Index of a scenario excitation, `None` for the force at the output point.
    pub(crate) scenario_excitation: Option<usize>,
    /// The mechanisms with a reach and an attachment, at the equilibrium with the
    /// generator: the admissible load.
    pub(crate) limits: Vec<LoadLimit>,
}

impl Io {
    /// The receptance's unit: `m/N`, `rad/(N m)`, ...
    pub(crate) fn unit(&self) -> String {
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
#[derive(Clone, Debug, Serialize)]
pub struct LinearRow {
    /// Frequency (Hz).
    pub f_hz: f64,
    /// With the generator.
    pub with_generator: Receptance,
    /// Generator disconnected.
    pub generator_disconnected: Receptance,
    /// The admissible load with the generator, per load limit (in the order of
    /// `Io::limits`): `reach / |H_att|` (force unit), [`LoadLimit::max_force`].
    pub max_force: Vec<f64>,
    /// Every connected generator's response per unit force, with the generator (in the
    /// order of the scenario's force elements).
    pub generators: Vec<GeneratorRow>,
}

/// A generator's linear response per unit force amplitude `F` at one frequency.
#[derive(Clone, Debug, Serialize)]
pub struct GeneratorRow {
    /// The force element.
    pub name: String,
    /// Current amplitude per unit force, `|i| / |F|` (A per force unit).
    pub current: f64,
    /// Terminal voltage amplitude across the load per unit force, `R_L |i| / |F|` (V per
    /// force unit).
    pub voltage: f64,
    /// Mean load power per unit force squared, `R_L |i|^2 / (2 |F|^2)` (W per force unit
    /// squared).
    pub load_power: f64,
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
    /// Every connected generator's mean load power over the last period of a settled run
    /// (W; empty when the run did not settle or stopped), in the order of
    /// [`LinearRow::generators`].
    pub load_power: Vec<f64>,
    /// The linear prediction of the same powers at this force amplitude (W).
    pub load_power_linear: Vec<f64>,
    /// Why the run stopped (singular position, no convergence), if it did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
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

/// An argument error of `argument` (its whole text `msg`).
fn argument(argument: &str, msg: impl Into<String>) -> Error {
    AnalysisError::argument(argument, msg).into()
}

/// An unknown `what` (a mechanism, a coordinate, an excitation) named `name`, with the
/// valid names `known` to suggest (the text `msg` lists them).
fn unknown<S: AsRef<str>>(what: &'static str, name: &str, known: &[S], msg: String) -> Error {
    AnalysisError::UnknownName {
        what,
        name: diagnostic::truncate(name, 80),
        nearest: known.iter().map(|k| k.as_ref().to_string()).collect(),
        file: None,
        message: msg,
    }
    .into()
}

/// An output named as `--output` takes it (frf, random): a beam abscissa in m (`1.0`: the
/// transverse displacement there), `NODE:DOF` on an imported structure (`613:ux`: node
/// 613's displacement along `x`; `uy` along `y`) or `MECHANISM/COORDINATE`; its target (the
/// same generalised vector as a force there), label and unit.
pub(crate) fn parse_output(
    model: &HybridModel,
    output: &str,
) -> Result<(ExcitationTarget, String, &'static str), Error> {
    if let Some((node, dof)) = output.split_once(':') {
        let node: u64 = node.trim().parse().map_err(|_| {
            argument(
                "--output",
                format!("--output {output:?}: give NODE:DOF with NODE a node id (613:ux)"),
            )
        })?;
        let direction = match dof.trim() {
            "ux" => [1.0, 0.0],
            "uy" => [0.0, 1.0],
            other => {
                return Err(unknown(
                    "dof",
                    other,
                    &["ux", "uy"],
                    format!(
                        "--output {output:?}: no DOF {other:?} in the mechanisms' plane (ux, uy)"
                    ),
                ));
            }
        };
        let structure = model
            .structure
            .as_ref()
            .filter(|s| s.beam().is_none())
            .ok_or_else(|| {
                argument(
                    "--output",
                    format!("--output {output}: NODE:DOF needs a [structure] of kind \"matrices\" (the beam's outputs are abscissae)"),
                )
            })?;
        let p = crate::setup::build::structure_node(structure, node)
            .map_err(|m| argument("--output", format!("--output {output}: {m}")))?
            .along(direction);
        if p.weights.is_empty() {
            return Err(argument(
                "--output",
                format!(
                    "--output {output}: a support holds node {node} along {}",
                    dof.trim()
                ),
            ));
        }
        return Ok((
            ExcitationTarget::Beam(p),
            format!("{node}:{}", dof.trim()),
            "m",
        ));
    }
    Ok(match output.split_once('/') {
        None => {
            let x: f64 = output.trim().parse().map_err(|_| {
                argument(
                    "--output",
                    format!(
                        "--output {:?}: give a beam abscissa in m (1.0) or MECHANISM/COORDINATE",
                        output
                    ),
                )
            })?;
            let beam = model
                .beam()
                .ok_or_else(|| argument("--output", "--output: the scenario has no beam"))?;
            let p = BeamPoint::on(beam, x)
                .filter(|p| !p.is_locked())
                .ok_or_else(|| {
                    argument(
                        "--output",
                        format!("--output {x}: not a point of the beam that can move transversely"),
                    )
                })?;
            (ExcitationTarget::Beam(p), format!("beam w(x = {x} m)"), "m")
        }
        Some((mech, coord)) => {
            let names: Vec<&str> = model.mechanisms.iter().map(|m| m.name.as_str()).collect();
            let i = names.iter().position(|n| *n == mech).ok_or_else(|| {
                unknown(
                    "mechanism",
                    mech,
                    &names,
                    format!(
                        "--output: no mechanism {mech:?} (mechanisms: {})",
                        names.join(", ")
                    ),
                )
            })?;
            let sys = &model.mechanisms[i].system;
            let j = sys.coordinate_index(coord).ok_or_else(|| {
                let known = sys.coordinate_names();
                unknown(
                    "coordinate",
                    coord,
                    known,
                    format!(
                        "--output: mechanism {mech:?} has no coordinate {coord:?} (coordinates: {})",
                        known.join(", ")
                    ),
                )
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
    })
}

/// Resolves `--output`, `--excitation` and `--force` against the model (`lin`: its
/// linearisation with the generator, whose equilibrium gives the remaining reaches).
pub(crate) fn resolve(
    args: &FrfRequest,
    lz: &Linearizable,
    lin: &Linearization,
) -> Result<Io, Error> {
    let model = &lz.model;
    let (output, output_label, response_unit) = parse_output(model, &args.output)?;
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
                    unknown(
                        "excitation",
                        name,
                        &known,
                        format!(
                            "--excitation: no excitation {name:?} in the scenario (excitations: {})",
                            if known.is_empty() {
                                "none".into()
                            } else {
                                known.join(", ")
                            }
                        ),
                    )
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
                    return Err(argument(
                        "--excitation",
                        format!(
                            "the scenario has {} harmonic excitations: choose one with --excitation",
                            h.len()
                        ),
                    ));
                }
            }
        }
    };
    if let Some(f) = args.force
        && !f.is_finite()
    {
        return Err(argument(
            "--force",
            format!("--force {f}: not a finite number"),
        ));
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
    let force_unit = lz.model.excitation_unit(&excitation.target);
    Ok(Io {
        output,
        output_label,
        response_unit,
        force_unit,
        excitation,
        scenario_excitation: chosen,
        limits: LoadLimit::of(model, lin),
    })
}

/// The response per unit force for the force vector `f`, at `omega` (rad/s).
fn response(lin: &Linearization, f: &[f64], omega: f64) -> Result<Vec<Complex<f64>>, Error> {
    lin.harmonic_response(f, omega).map_err(|e| {
        AnalysisError::Numerical {
            file: None,
            message: format!("harmonic response at {omega} rad/s: {e}"),
        }
        .into()
    })
}

/// The receptance at the output for the force vector `f`, at `omega` (rad/s).
fn receptance(
    lin: &Linearization,
    output: &ExcitationTarget,
    f: &[f64],
    omega: f64,
) -> Result<Complex<f64>, Error> {
    Ok(output_of(lin, output, &response(lin, f, omega)?))
}

/// The output's value in the response `z`.
fn output_of(lin: &Linearization, output: &ExcitationTarget, z: &[Complex<f64>]) -> Complex<f64> {
    match output {
        ExcitationTarget::Beam(p) => p.complex_value(z),
        ExcitationTarget::Joint { mechanism, joint } => lin.mechanism_motion(z)[*mechanism][*joint],
        // Every response is relative to the supports.
        ExcitationTarget::Base { .. } => Complex::new(0.0, 0.0),
    }
}

/// The linear receptances at `freqs` (Hz) with the generator (`lin`, force vector `f_with`)
/// and with it disconnected (`lin_off`, `f_off`).
pub(crate) fn linear_rows(
    model: &HybridModel,
    lin: &Linearization,
    lin_off: &Linearization,
    io: &Io,
    (f_with, f_off): (&[f64], &[f64]),
    freqs: &[f64],
) -> Result<Vec<LinearRow>, Error> {
    let mut linear = Vec::with_capacity(freqs.len());
    for &f in freqs {
        let w = 2.0 * std::f64::consts::PI * f;
        // One solve with the generator gives the output and every attachment (H_att).
        let z = response(lin, f_with, w)?;
        linear.push(LinearRow {
            f_hz: f,
            with_generator: output_of(lin, &io.output, &z).into(),
            generator_disconnected: receptance(lin_off, &io.output, f_off, w)?.into(),
            max_force: io.limits.iter().map(|l| l.max_force(&z)).collect(),
            generators: generator_phasors(model, lin, &z, w)
                .iter()
                .map(|g| GeneratorRow {
                    name: model.forces[g.force].name.clone(),
                    current: g.current.norm(),
                    voltage: g.voltage.norm(),
                    load_power: g.load_power,
                })
                .collect(),
        });
    }
    Ok(linear)
}

/// The nonlinear steady states at `m` frequencies.
pub(crate) fn nonlinear_rows(
    args: &FrfRequest,
    lz: &Linearizable,
    lin: &Linearization,
    io: &Io,
    f_with: &[f64],
    m: usize,
    warnings: &mut Vec<Warning>,
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
        warnings.push(Warning::note(format!(
            "the nonlinear runs leave out {dropped} other time-dependent excitation(s) of the scenario"
        )));
    }
    model.excitations.push(io.excitation.clone());
    let excitation = model.excitations.len() - 1;
    let start = rest_state(&mut model, &lin.equilibrium).map_err(|e| {
        AnalysisError::numerical(
            &args.file,
            format!("the rest state at the static equilibrium: {e}"),
        )
    })?;
    let options = SteadyOptions {
        excitation,
        method: lz.method,
        steps_per_period: args.steps_per_period,
        tolerance: args.tolerance,
        min_periods: 10,
        max_periods: args.max_periods,
        // A library caller's stop (Ctrl-C in Python) ends every run at its next period.
        stop: Some(crate::interrupt::stop_requested),
    };
    let freqs = grid(args.from, args.to, m, args.log);
    let bar = crate::progress::bar_or_hidden(
        args.progress,
        freqs.len() as u64,
        "frf nonlinear [{bar:40}] {pos}/{len} ETA {eta}",
    );
    // The runs on a pool of this call: its threads see this call's stop token only.
    let token = crate::interrupt::current();
    let pool = rayon::ThreadPoolBuilder::new()
        .start_handler(move |_| crate::interrupt::adopt(token.clone()))
        .build()
        .map_err(|e| AnalysisError::Resources {
            message: format!("cannot start the worker threads: {e}"),
        })?;
    let results = pool
        .install(|| steady_states(&model, &start, &io.output, &freqs, &options, &|| bar.inc(1)));
    bar.finish_and_clear();
    if crate::interrupt::stop_requested() {
        return Err(Error::Interrupted);
    }
    let force = io.excitation.amplitude.abs();
    let mut rows = Vec::with_capacity(m);
    for (&f, r) in freqs.iter().zip(results) {
        let w = 2.0 * std::f64::consts::PI * f;
        let z = response(lin, f_with, w)?;
        let linear: Receptance = output_of(lin, &io.output, &z).into();
        let phasors = generator_phasors(&model, lin, &z, w);
        let load_power_linear = phasors
            .iter()
            .map(|g| g.load_power * force * force)
            .collect();
        let dt = 1.0 / (f * args.steps_per_period as f64);
        rows.push(match r {
            Ok(s) => NonlinearRow {
                // The load's share of the generator's measured dissipation.
                load_power: if s.settled {
                    phasors
                        .iter()
                        .map(|g| {
                            let spec = model.forces[g.force].generator().expect("a generator");
                            spec.load_part(
                                s.mean_power_dissipated[g.force] - s.mean_power_gearbox[g.force],
                            )
                        })
                        .collect()
                } else {
                    vec![]
                },
                load_power_linear,
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
                load_power: vec![],
                load_power_linear,
                error: Some(e.error.to_string()),
            },
        });
    }
    Ok(rows)
}

/// What to compute: the frequency response of a loaded scenario (the fields of
/// `damper frf`'s options that the analysis reads).
#[derive(Clone, Debug, PartialEq)]
pub struct FrfRequest {
    /// The scenario file as messages name it.
    pub file: String,
    /// The response: a beam abscissa in m (`1.0`), `NODE:DOF` on an imported structure
    /// (`613:ux`), or `MECHANISM/COORDINATE`.
    pub output: String,
    /// Lowest frequency (Hz).
    pub from: f64,
    /// Highest frequency (Hz).
    pub to: f64,
    /// Frequencies of the linear response.
    pub points: usize,
    /// Geometric spacing of the frequencies.
    pub log: bool,
    /// Also the nonlinear steady state at this many frequencies.
    pub nonlinear: Option<usize>,
    /// The scenario excitation that drives the system (default: its only harmonic one).
    pub excitation: Option<String>,
    /// Force amplitude at the output point (or the amplitude of `excitation`).
    pub force: Option<f64>,
    /// Time steps per excitation period of the nonlinear runs.
    pub steps_per_period: usize,
    /// Settle tolerance of the nonlinear runs.
    pub tolerance: f64,
    /// Periods run at most per frequency.
    pub max_periods: usize,
    /// A progress bar for the nonlinear runs (on a terminal).
    pub progress: bool,
    /// Run even above the limits of [`crate::budget`].
    pub allow_long: bool,
}

/// The frequency response of a loaded scenario ([`analyse`]): what `damper frf` writes.
pub struct Frf {
    pub(crate) lz: Linearizable,
    pub(crate) lin: Linearization,
    pub(crate) io: Io,
    /// The frequencies of the linear response (Hz).
    pub freqs: Vec<f64>,
    /// The linear response, one row per frequency.
    pub linear: Vec<LinearRow>,
    /// The nonlinear steady states (`nonlinear`).
    pub nonlinear: Option<Vec<NonlinearRow>>,
    /// What the user should know about the result, in the order found.
    pub warnings: Vec<Warning>,
}

impl Frf {
    /// The response's unit per unit force (`m/N`, `rad/N`, ..).
    pub fn unit(&self) -> String {
        self.io.unit()
    }

    /// The number of generators of the model.
    pub fn generators(&self) -> usize {
        self.lz
            .model
            .forces
            .iter()
            .filter(|f| f.generator().is_some())
            .count()
    }
}

/// The linear (and with `req.nonlinear` the nonlinear) frequency response of `sc`.
pub fn analyse(req: &FrfRequest, sc: &Scenario) -> Result<Frf, Error> {
    let file = &req.file;
    if matches!(sc, Scenario::Mechanism(_)) {
        return Err(AnalysisError::unavailable(
            file,
            "`damper frf` needs a `damper` or `hybrid` scenario (a beam to respond)",
        )
        .into());
    }
    let lz = tangents_for(sc)?;
    let linear_error = |what: &str, e: hybrid_core::hybrid::LinearError| {
        Error::from(AnalysisError::numerical(
            file,
            format!("linearisation {what}: {e}"),
        ))
    };
    let lin = lz
        .linearize(&lz.model)
        .map_err(|e| linear_error("with generator", e))?;
    let io = resolve(req, &lz, &lin)?;
    if req.nonlinear.is_some() && io.scenario_excitation.is_none() && req.force.is_none() {
        return Err(argument(
            "--force",
            "--nonlinear: the scenario has no harmonic excitation: give the force amplitude at the output point with --force F (N, or N m on a revolute coordinate)",
        ));
    }
    let off_model = lz.model.generators_disconnected();
    let lin_off = lz
        .linearize(&off_model)
        .map_err(|e| linear_error("generator disconnected", e))?;
    let f_with = lin.force_vector(&io.excitation.target);
    let f_off = lin_off.force_vector(&io.excitation.target);
    let freqs = grid(req.from, req.to, req.points, req.log);
    let linear = linear_rows(&lz.model, &lin, &lin_off, &io, (&f_with, &f_off), &freqs)?;
    let mut warnings = vec![];
    let nonlinear = match req.nonlinear {
        None => None,
        Some(m) => Some(nonlinear_rows(
            req,
            &lz,
            &lin,
            &io,
            &f_with,
            m,
            &mut warnings,
        )?),
    };
    warnings.extend(band_edge_warnings(file, &linear, &io.unit()));
    Ok(Frf {
        lz,
        lin,
        io,
        freqs,
        linear,
        nonlinear,
        warnings,
    })
}

/// Checks the options of `req` that do not need the scenario (the range, the counts, the
/// limits of [`crate::budget`]).
pub fn check(req: &FrfRequest) -> Result<(), Error> {
    // Frequencies a structure can have: 1e-9 Hz (a period of 30 years) to 1e12 Hz; the
    // bounds keep the geometric spacing and the logarithmic axis finite.
    let (lo, hi) = (1e-9, 1e12);
    let ok_range = req.from.is_finite()
        && req.to.is_finite()
        && req.from >= lo
        && req.to <= hi
        && req.to > req.from;
    if !ok_range {
        return Err(argument(
            "--from",
            format!(
                "--from {} --to {}: give {lo:e} <= from < to <= {hi:e} (Hz)",
                req.from, req.to
            ),
        ));
    }
    if req.points < 2 {
        return Err(argument("--points", "--points: at least 2"));
    }
    if req.nonlinear == Some(0) {
        return Err(argument("--nonlinear", "--nonlinear: at least 1 frequency"));
    }
    if !(req.tolerance > 0.0 && req.tolerance < 1.0) {
        return Err(argument("--tolerance", "--tolerance: between 0 and 1"));
    }
    if req.steps_per_period < 8 {
        return Err(argument(
            "--steps-per-period",
            "--steps-per-period: at least 8",
        ));
    }
    let frequencies = req.points as f64 + req.nonlinear.unwrap_or(0) as f64;
    let mut work = vec![Quantity::bytes(
        "memory",
        frequencies * budget::FRF_BYTES_PER_FREQUENCY,
        budget::MAX_MEMORY,
    )];
    if let Some(m) = req.nonlinear {
        work.push(Quantity::count(
            "time steps",
            m as f64 * req.max_periods as f64 * req.steps_per_period as f64,
            budget::MAX_STEPS,
        ));
    }
    budget::refuse_above(
        &req.file,
        &work,
        "use fewer --points or --nonlinear frequencies, or a smaller --max-periods or --steps-per-period",
        req.allow_long,
    )?;
    Ok(())
}

/// A warning for each linear response (with the generator, generator disconnected) whose
/// largest magnitude over the band lies at its first or last frequency: the peak the user is
/// after may lie outside the band (below it when at the first, above when at the last).
fn band_edge_warnings(file: &str, linear: &[LinearRow], unit: &str) -> Vec<Warning> {
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
            Some(Warning::about(
                file,
                format!("|H| {label}"),
                format!(
                    "the largest |H| {label} ({:.4e} {unit}) is at the {side} frequency of the band, {} Hz: the peak may lie {below} the band (widen it with {widen})",
                    of(&linear[k]),
                    linear[k].f_hz
                ),
            ))
        })
        .collect()
}
