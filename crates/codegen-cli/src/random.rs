//! The stationary random response of a scenario about its static equilibrium (issue #20,
//! `damper random`): the RMS of beam displacements and velocities, mechanism coordinates
//! and rates, every generator's current and rotor speed and its mean dissipated and load
//! power, under the scenario's random excitations (`time = { kind = "white_noise" }` or
//! `{ kind = "psd" }`, assumed independent of each other).
//!
//! - **White noise** of one-sided PSD `G` per Hz (ideal: the band is not used): the Lyapunov
//!   equation of the first-order form with intensity `W = G / 2`
//!   ([`hybrid_core::hybrid::StateSpace`]), on the whole state (`dense`: on the complete basis
//!   of every mode, the whole state when they do not span it) or on a modal basis
//!   (`modal`: the first `--modes` modes and the inputs' static responses; the change of every
//!   variance from the basis of half the modes is reported as `truncation`). The part of the
//!   ideal white-noise variance outside the written band, `out_of_band` (largest over the
//!   outputs, relative), is what the band-limited time-domain realisation lacks.
//! - **PSD tables** (and every input with `quadrature`): `∫ |H(f)|² G(f) df` by adaptive
//!   Gauss–Kronrod quadrature over the table's range (`G = 0` outside it, so nothing is
//!   truncated there; a white noise is integrated over `[0, ∞)`), the intervals cut at the
//!   table's points and at the modes' frequencies and half-power points; the summed error
//!   estimate is reported (`quadrature_error`, relative, largest over the outputs).
//!
//! A generator's current is `k_e n q_j' / R` without inductance and its state with one; the
//! mean powers are `R σ_i²` (dissipated in `R = R_a + R_L`, what `simulate` reports as
//! `dissipated`) and `R_L σ_i²` (the load's).

use fem_beam::TimeFunction;
use hybrid_core::hybrid::{
    BeamPoint, EigenMethod, ExcitationTarget, HybridModel, Linearization, Mode, PsdInput,
    StateOutput, StateSpace, modes, psd_at, psd_variances,
};
use serde::Serialize;

use crate::Error;
use crate::analysis::AnalysisError;
use crate::analysis::frf::parse_output;
use crate::scenario::Scenario;
use crate::setup::Linearizable;

/// How the white-noise response is computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RandomMethod {
    /// PSD tables alone by quadrature; white noise dense up to [`DENSE_STATES`] states,
    /// modal above.
    #[default]
    Auto,
    /// The Lyapunov equation of the whole first-order form.
    Dense,
    /// The Lyapunov equation on a modal basis.
    Modal,
    /// Every input by PSD quadrature (white noise over `[0, ∞)`).
    Quadrature,
}

impl RandomMethod {
    /// The `--method` name of the method (`auto`, `dense`, `modal`, `quadrature`).
    pub fn name(self) -> &'static str {
        match self {
            RandomMethod::Auto => "auto",
            RandomMethod::Dense => "dense",
            RandomMethod::Modal => "modal",
            RandomMethod::Quadrature => "quadrature",
        }
    }

    /// `auto`, `dense`, `modal` or `quadrature` (the command's `--method` names).
    pub fn parse(name: &str) -> Option<RandomMethod> {
        Some(match name {
            "auto" => RandomMethod::Auto,
            "dense" => RandomMethod::Dense,
            "modal" => RandomMethod::Modal,
            "quadrature" => RandomMethod::Quadrature,
            _ => return None,
        })
    }
}

/// The RMS of one output (`--output` names: a beam abscissa, `MECHANISM/COORDINATE`) under
/// the scenario's random excitations, by the automatic method with a 20-mode basis where it
/// is modal: the optimiser's `rms:OUTPUT` objective (the H2 design). `(rms, unit)`.
pub fn output_rms(file: &str, sc: &Scenario, output: &str) -> Result<(f64, String), Error> {
    let (input, lin) = crate::linear::linearise_scenario(file, sc)?;
    output_rms_of(file, &input, &lin, output)
}

/// [`output_rms`] of a linearised system.
pub fn output_rms_of(
    file: &str,
    input: &Linearizable,
    lin: &Linearization,
    output: &str,
) -> Result<(f64, String), Error> {
    let report = analyse_linearised(
        file,
        input,
        lin,
        &RandomOptions {
            method: RandomMethod::Auto,
            modes: 20,
            outputs: vec![output.to_string()],
            points: vec![],
        },
    )?;
    let first = report
        .outputs
        .first()
        .ok_or_else(|| AnalysisError::UnknownName {
            what: "output",
            name: output.to_string(),
            nearest: vec![],
            file: Some(file.to_string()),
            message: format!("{file}: rms:{output}: no such output"),
        })?;
    Ok((first.rms, first.unit.clone()))
}

/// Largest first-order state count solved densely by [`RandomMethod::Auto`].
pub const DENSE_STATES: usize = 600;

/// Relative tolerance of the PSD quadrature.
const QUAD_TOL: f64 = 1e-10;
/// Interval cap of the PSD quadrature.
const QUAD_INTERVALS: usize = 4_000;
/// Relative tolerance of the out-of-band share (an estimate of the band's effect).
const BAND_TOL: f64 = 1e-6;

/// One output's RMS.
#[derive(Clone, Debug, Serialize)]
pub struct OutputRms {
    /// `w(x=1)`, `w'(x=1)`, `damper/q1`, `damper/q1'`.
    pub name: String,
    /// SI unit.
    pub unit: String,
    /// Root mean square about the equilibrium.
    pub rms: f64,
}

/// One generator's figures.
#[derive(Clone, Debug, Serialize)]
pub struct GeneratorRms {
    /// The force element.
    pub name: String,
    /// RMS current (A).
    pub rms_current: f64,
    /// RMS rotor speed, gear ratio times the joint rate (rad/s).
    pub rms_rotor_speed: f64,
    /// Mean power dissipated in `R_a + R_L` (W).
    pub mean_power_dissipated: f64,
    /// Mean power in the load `R_L` (W).
    pub mean_power_load: f64,
}

/// One random excitation.
#[derive(Clone, Debug, Serialize)]
pub struct ExcitationPsd {
    /// Its name.
    pub name: String,
    /// `white_noise` or `psd`.
    pub kind: &'static str,
    /// `∫ G df` over its band or table (unit²): the mean square of the input.
    pub mean_square: f64,
}

/// What `damper random` reports.
#[derive(Clone, Debug, Serialize)]
pub struct RandomReport {
    /// The scenario file.
    pub scenario: String,
    /// How it was computed (`lyapunov dense`, `lyapunov modal`, `quadrature`, joined by
    /// ` + ` when white noises and PSD tables are mixed).
    pub method: String,
    /// The outputs.
    pub outputs: Vec<OutputRms>,
    /// The generators.
    pub generators: Vec<GeneratorRms>,
    /// The random excitations.
    pub excitations: Vec<ExcitationPsd>,
    /// First-order states of the linearisation (`2 dim + inductive generators`).
    pub states: usize,
    /// Size of the modal basis (modal method).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub basis: Option<usize>,
    /// Modes behind the modal basis.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub modes: Option<usize>,
    /// Largest relative change of a variance from the basis of half the modes (modal).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truncation: Option<f64>,
    /// Largest relative residual of the Lyapunov equations.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lyapunov_residual: Option<f64>,
    /// Largest relative error estimate of the PSD quadratures.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub quadrature_error: Option<f64>,
    /// Largest share of an ideal white-noise variance outside the written bands.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub out_of_band: Option<f64>,
}

/// Options of [`analyse`].
#[derive(Clone, Debug)]
pub struct RandomOptions {
    /// The method.
    pub method: RandomMethod,
    /// Modes of the modal basis (and of the quadrature's breakpoints).
    pub modes: usize,
    /// Outputs as `--output` names them (default, when `points` is empty too: every
    /// attachment, mechanism coordinate).
    pub outputs: Vec<String>,
    /// Outputs that no name selects, given by their point with a label, reported after the
    /// named ones in this order (displacement and rate each, in m and m/s): a node seen along
    /// a direction ([`BeamPoint::along`]), e.g. along a double bar's pivot -> node axis
    /// ([`crate::linear::LoadLimit::point`], the reach figures of [`crate::sweep_point`]),
    /// the same `(label, point)` pairs as [`attachment_outputs`].
    pub points: Vec<(String, BeamPoint)>,
}

/// An output to report: name, unit, the linear functional.
struct Named {
    name: String,
    unit: String,
    output: StateOutput,
}

fn linear_error(file: &str) -> impl Fn(hybrid_core::hybrid::LinearError) -> Error + '_ {
    move |error| Error::Linear {
        file: file.to_string(),
        error,
    }
}

/// The first-order state count of a linearisation.
pub fn states(lin: &Linearization) -> usize {
    2 * lin.dim() + lin.electrical.len()
}

/// The stationary random response of a loaded scenario (module documentation).
pub fn analyse(file: &str, sc: &Scenario, opts: &RandomOptions) -> Result<RandomReport, Error> {
    let (input, lin) = crate::linear::linearise_scenario(file, sc)?;
    analyse_linearised(file, &input, &lin, opts)
}

/// [`analyse`] of a linearised system.
pub fn analyse_linearised(
    file: &str,
    input: &Linearizable,
    lin: &Linearization,
    opts: &RandomOptions,
) -> Result<RandomReport, Error> {
    analyse_with(file, input, lin, opts, None)
}

/// [`analyse_linearised`] for design figures ([`crate::sweep_point`]): the same variances,
/// without the diagnostics no figure reads (the `out_of_band` share of a white noise, one
/// more quadrature; the Lyapunov residual), and, by the dense method, from the complete
/// modal decomposition already computed instead of the Lyapunov equation's Schur form
/// (`modal_variances`, where it applies).
///
/// `all`: every mode of the point's dense eigen-solution when the caller has it (the
/// linear figures' [`crate::linear::analyse_with_max_force`]): not computed again.
pub fn figures_of(
    file: &str,
    input: &Linearizable,
    lin: &Linearization,
    all: Option<&[Mode]>,
    opts: &RandomOptions,
) -> Result<RandomReport, Error> {
    analyse_with(file, input, lin, opts, Some(all))
}

/// A generator's outputs: its current and rotor speed, and its resistances.
struct GeneratorOutputs {
    name: String,
    /// `R_a + R_L` (ohm).
    resistance: f64,
    /// `R_L` (ohm).
    load_resistance: f64,
    current: StateOutput,
    speed: StateOutput,
}

/// The outputs of a random response, in the order `damper random` and a run's `random`
/// block report them.
struct Outputs {
    /// The named ones (displacement and rate each).
    named: Vec<Named>,
    /// Per generator, its current and rotor speed.
    gens: Vec<GeneratorOutputs>,
}

/// The default displacement outputs of the attachments (unit m), as `damper random` and a
/// run's `random` block name them: a node of an imported structure gives its `ux` and `uy`
/// (`NODE:DOF`, those a support does not hold), a beam point its transverse displacement
/// (`w(x=X)`).
pub fn attachment_outputs(model: &HybridModel) -> Vec<(String, BeamPoint)> {
    let mut out = vec![];
    for a in &model.attachments {
        let node = model
            .structure
            .as_ref()
            .and_then(|st| crate::setup::build::node_at(st, &a.beam));
        match node {
            Some(id) => {
                for (dof, direction) in [("ux", [1.0, 0.0]), ("uy", [0.0, 1.0])] {
                    let p = a.beam.along(direction);
                    if !p.weights.is_empty() {
                        out.push((format!("{id}:{dof}"), p));
                    }
                }
            }
            None => out.push((format!("w(x={})", a.beam.x), a.beam.clone())),
        }
    }
    out
}

/// The outputs of `model`'s random response on `lin`: the `requested` ones (`--output`
/// names), then the `points`, or, without any of either, every attachment's beam point and
/// every mechanism coordinate, each with its rate; then every generator's current and rotor
/// speed.
fn outputs_of(
    model: &HybridModel,
    lin: &Linearization,
    requested: &[String],
    points: &[(String, BeamPoint)],
) -> Result<Outputs, Error> {
    // The outputs: the named ones (displacement and rate each), or every attachment and
    // every mechanism coordinate.
    let mut named: Vec<Named> = vec![];
    let mut push_pair = |target: &ExcitationTarget, label: String, unit: &str| {
        let c = lin.force_vector(target);
        named.push(Named {
            name: label.clone(),
            unit: unit.to_string(),
            output: StateOutput::position(c.clone()),
        });
        named.push(Named {
            name: format!("{label}'"),
            unit: format!("{unit}/s"),
            output: StateOutput::rate(c),
        });
    };
    if requested.is_empty() && points.is_empty() {
        for (label, p) in attachment_outputs(model) {
            push_pair(&ExcitationTarget::Beam(p), label, "m");
        }
        for (i, m) in model.mechanisms.iter().enumerate() {
            let names = m.system.coordinate_names();
            let units = m.system.coordinate_units();
            for (j, n) in names.iter().enumerate() {
                let t = ExcitationTarget::Joint {
                    mechanism: i,
                    joint: j,
                };
                push_pair(&t, format!("{}/{n}", m.name), units[j].symbol());
            }
        }
    } else {
        for o in requested {
            let (t, _, unit) = parse_output(model, o)?;
            let label = match &t {
                ExcitationTarget::Beam(p) if !o.contains(':') => format!("w(x={})", p.x),
                _ => o.clone(),
            };
            push_pair(&t, label, unit);
        }
        for (label, p) in points {
            push_pair(&ExcitationTarget::Beam(p.clone()), label.clone(), "m");
        }
    }
    // Per generator: its current and rotor speed, and R, R_L.
    let mut gens = vec![];
    for (k, f) in model.forces.iter().enumerate() {
        let Some(g) = f.generator() else { continue };
        let joint = lin.force_vector(&ExcitationTarget::Joint {
            mechanism: f.mechanism,
            joint: f.joint,
        });
        let current = match lin.electrical.iter().position(|e| e.force == k) {
            Some(e) if g.connected => StateOutput::current(lin, e),
            _ => {
                let scale = if g.connected {
                    g.ke * g.gear_ratio / g.resistance()
                } else {
                    0.0
                };
                StateOutput::rate(joint.iter().map(|v| v * scale).collect())
            }
        };
        let speed = StateOutput::rate(joint.iter().map(|v| v * g.gear_ratio).collect());
        gens.push(GeneratorOutputs {
            name: f.name.clone(),
            resistance: g.resistance(),
            load_resistance: g.load_resistance,
            current,
            speed,
        });
    }
    Ok(Outputs { named, gens })
}

/// The linear prediction of a run's response spectra: at each of `frequencies` (Hz), the
/// one-sided PSD per Hz `S_y(f) = Σ_k |H_k(f)|² G_k(f)` of every default output of
/// [`analyse`] (every attachment's `w` and `w'`, every mechanism coordinate and rate, every
/// generator's current and rotor speed, in that order: the names of a run's `random` block)
/// under the random excitations among `excitations` as written (independent; `G_k` the
/// written PSD, band-limited as the realisation is; a run's model holds the realisations
/// instead), `H_k` from the pencil ([`hybrid_core::hybrid::psd_at`], the receptance of
/// `damper frf`). One vector per output, one value per frequency.
pub fn response_psd(
    file: &str,
    model: &HybridModel,
    lin: &Linearization,
    excitations: &[hybrid_core::hybrid::Excitation],
    frequencies: &[f64],
) -> Result<Vec<Vec<f64>>, Error> {
    let Outputs { named, gens } = outputs_of(model, lin, &[], &[])?;
    let mut outputs: Vec<StateOutput> = named.into_iter().map(|n| n.output).collect();
    for g in gens {
        outputs.push(g.current);
        outputs.push(g.speed);
    }
    let random: Vec<_> = excitations
        .iter()
        .filter(|e| e.time.psd(0.0).is_some())
        .collect();
    let psds: Vec<Box<dyn Fn(f64) -> f64>> = random
        .iter()
        .map(|e| {
            let t = e.time.clone();
            Box::new(move |f: f64| t.psd(f).unwrap_or(0.0)) as Box<dyn Fn(f64) -> f64>
        })
        .collect();
    let inputs: Vec<PsdInput<'_>> = random
        .iter()
        .zip(&psds)
        .map(|(e, p)| PsdInput {
            force: lin.force_vector(&e.target),
            psd: p.as_ref(),
        })
        .collect();
    let mut at = vec![0.0; outputs.len()];
    let mut out = vec![Vec::with_capacity(frequencies.len()); outputs.len()];
    for &f in frequencies {
        psd_at(lin, &inputs, &outputs, f, &mut at).map_err(linear_error(file))?;
        for (o, v) in out.iter_mut().zip(&at) {
            o.push(*v);
        }
    }
    Ok(out)
}

/// The analysis; `given`: `None` for `damper random` (every diagnostic), `Some` for figures
/// (with the point's modes when the caller has them).
fn analyse_with(
    file: &str,
    input: &Linearizable,
    lin: &Linearization,
    opts: &RandomOptions,
    given: Option<Option<&[Mode]>>,
) -> Result<RandomReport, Error> {
    let diagnostics = given.is_none();
    let unavailable = |m: String| Error::from(AnalysisError::unavailable(file, m));
    let model = &input.model;
    let random: Vec<_> = model
        .excitations
        .iter()
        .filter(|e| e.time.is_random())
        .collect();
    if random.is_empty() {
        return Err(unavailable(
            "no random excitation: give one `time = { kind = \"white_noise\", psd = G, band = [F1, F2] }` or `{ kind = \"psd\", table = [[f, G], ...] }`".into(),
        ));
    }
    let Outputs { named, gens } = outputs_of(model, lin, &opts.outputs, &opts.points)?;
    let mut outputs: Vec<StateOutput> = named.iter().map(|n| n.output.clone()).collect();
    for g in &gens {
        outputs.push(g.current.clone());
        outputs.push(g.speed.clone());
    }
    let no = outputs.len();
    let nstates = states(lin);
    // Automatic: PSD tables alone by quadrature on the pencil (banded plus low rank: O(n)
    // per frequency, against the state space's O(n^3) decomposition and O(n^2) per
    // frequency; no Lyapunov equation applies to a table), white noise by the Lyapunov
    // equation, dense up to `DENSE_STATES` states.
    let only_tables = random
        .iter()
        .all(|e| !matches!(e.time, TimeFunction::WhiteNoise { .. }));
    let method = match opts.method {
        RandomMethod::Auto if only_tables => RandomMethod::Quadrature,
        RandomMethod::Auto if nstates <= DENSE_STATES => RandomMethod::Dense,
        RandomMethod::Auto => RandomMethod::Modal,
        m => m,
    };
    // Modes: the modal basis and the quadrature's breakpoints.
    let k = opts.modes.min(lin.dim()).max(1);
    // Dense: every mode at once (the complete basis below), the first `k` for the cuts.
    // (For figures, every eigenvalue: an overdamped mode's two real roots count as two
    // modes, and the modal variances need the complete set; the first `dim` are the same.)
    let given = given.flatten().filter(|m| m.len() >= k);
    let all = if let (RandomMethod::Dense, Some(m)) = (method, given) {
        m.to_vec()
    } else if method == RandomMethod::Dense {
        let count = if diagnostics { lin.dim() } else { nstates };
        modes(lin, count, EigenMethod::Dense).map_err(linear_error(file))?
    } else {
        modes(lin, k, EigenMethod::Auto).map_err(linear_error(file))?
    };
    let found = &all[..k.min(all.len())];
    let mut breakpoints = vec![];
    for m in found {
        let (fd, half) = (
            m.damped_frequency_hz,
            m.damping_ratio * m.natural_frequency_hz,
        );
        for s in [-3.0, -1.0, 0.0, 1.0, 3.0] {
            let f = fd + s * half;
            if f > 0.0 && f.is_finite() {
                breakpoints.push(f);
            }
        }
    }
    let mut report = RandomReport {
        scenario: file.to_string(),
        method: String::new(),
        outputs: vec![],
        generators: vec![],
        excitations: random
            .iter()
            .map(|e| ExcitationPsd {
                name: e.name.clone(),
                kind: match e.time {
                    TimeFunction::WhiteNoise { .. } => "white_noise",
                    _ => "psd",
                },
                mean_square: fem_beam::random::psd_integral(&e.time, 0.0, f64::INFINITY),
            })
            .collect(),
        states: nstates,
        basis: None,
        modes: None,
        truncation: None,
        lyapunov_residual: None,
        quadrature_error: None,
        out_of_band: None,
    };
    let is_white = |t: &TimeFunction| matches!(t, TimeFunction::WhiteNoise { .. });
    let forces: Vec<Vec<f64>> = random.iter().map(|e| lin.force_vector(&e.target)).collect();
    // Per input: the written PSD (band-limited), the ideal white noise's constant (0 for a
    // table) and the table's PSD (0 for a white noise).
    let written: Vec<Box<dyn Fn(f64) -> f64>> = random
        .iter()
        .map(|e| {
            let t = e.time.clone();
            Box::new(move |f: f64| t.psd(f).unwrap_or(0.0)) as Box<dyn Fn(f64) -> f64>
        })
        .collect();
    let ideal: Vec<f64> = random
        .iter()
        .map(|e| match e.time {
            TimeFunction::WhiteNoise { psd, .. } => psd,
            _ => 0.0,
        })
        .collect();
    let zero = |_f: f64| 0.0;
    let tables_only: Vec<&dyn Fn(f64) -> f64> = random
        .iter()
        .zip(&written)
        .map(|(e, w)| {
            if is_white(&e.time) {
                &zero as &dyn Fn(f64) -> f64
            } else {
                w.as_ref()
            }
        })
        .collect();
    let whites_only: Vec<&dyn Fn(f64) -> f64> = random
        .iter()
        .zip(&written)
        .map(|(e, w)| {
            if is_white(&e.time) {
                w.as_ref()
            } else {
                &zero as &dyn Fn(f64) -> f64
            }
        })
        .collect();
    let has_white = random.iter().any(|e| is_white(&e.time));
    let has_table = random.iter().any(|e| !is_white(&e.time));
    // The range and the cuts of the written PSDs (white noises: their bands; tables).
    let span = |pick: &dyn Fn(&TimeFunction) -> bool| {
        let mut cuts = breakpoints.clone();
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for e in random.iter().filter(|e| pick(&e.time)) {
            let b = fem_beam::random::breakpoints(&e.time).unwrap_or_default();
            lo = b.iter().copied().fold(lo, f64::min);
            hi = b.iter().copied().fold(hi, f64::max);
            cuts.extend(b);
        }
        (lo, hi, cuts)
    };
    let worst = |q: &hybrid_core::hybrid::Quadrature| {
        q.variances
            .iter()
            .zip(&q.errors)
            .map(|(v, e)| if *v > 0.0 { e / v } else { 0.0 })
            .fold(0.0, f64::max)
    };
    let add = |a: &mut [f64], b: &[f64]| a.iter_mut().zip(b).for_each(|(a, b)| *a += b);
    let mut variances = vec![0.0; no];
    let mut methods: Vec<&str> = vec![];
    if method == RandomMethod::Quadrature {
        // Every input through the pencil: the white noises ideal, over [0, inf).
        let consts: Vec<Box<dyn Fn(f64) -> f64>> = ideal
            .iter()
            .zip(&written)
            .map(|(&g, _)| Box::new(move |_f: f64| g) as Box<dyn Fn(f64) -> f64>)
            .collect();
        let mut err: f64 = 0.0;
        if has_white {
            let inputs: Vec<PsdInput<'_>> = forces
                .iter()
                .zip(&consts)
                .map(|(f, p)| PsdInput {
                    force: f.clone(),
                    psd: p.as_ref(),
                })
                .collect();
            let q = psd_variances(
                lin,
                &inputs,
                &outputs,
                (0.0, f64::INFINITY),
                &breakpoints,
                QUAD_TOL,
                QUAD_INTERVALS,
            )
            .map_err(linear_error(file))?;
            add(&mut variances, &q.variances);
            err = err.max(worst(&q));
        }
        if has_table {
            let (lo, hi, cuts) = span(&|t| !is_white(t));
            let inputs: Vec<PsdInput<'_>> = forces
                .iter()
                .zip(&tables_only)
                .map(|(f, p)| PsdInput {
                    force: f.clone(),
                    psd: *p,
                })
                .collect();
            let q = psd_variances(
                lin,
                &inputs,
                &outputs,
                (lo, hi),
                &cuts,
                QUAD_TOL,
                QUAD_INTERVALS,
            )
            .map_err(linear_error(file))?;
            add(&mut variances, &q.variances);
            err = err.max(worst(&q));
        }
        report.quadrature_error = Some(err);
        methods.push("quadrature");
    } else {
        // On a basis: the complete modal one (dense) or the first modes' (modal).
        let solve = |basis: Option<nalgebra::DMatrix<f64>>,
                     modal: Option<&[Mode]>,
                     report: &mut RandomReport|
         -> Result<Vec<f64>, Error> {
            let v_basis = basis.clone();
            let ss = StateSpace::new(lin, &forces, basis).map_err(linear_error(file))?;
            let rows: Vec<_> = outputs.iter().map(|o| ss.row(o)).collect();
            let mut v = vec![0.0; no];
            let w: Vec<f64> = ideal.iter().map(|g| 0.5 * g).collect();
            // For figures: the white noises from the complete modal decomposition.
            let by_modes = match modal {
                Some(all) if has_white && !diagnostics => {
                    modal_variances(&ss, v_basis.as_ref(), all, &w, &rows)
                }
                _ => None,
            };
            if let Some(by_modes) = by_modes {
                add(&mut v, &by_modes);
            } else if has_white {
                let (p, res) = ss.covariance(&w).map_err(linear_error(file))?;
                let lyap: Vec<f64> = rows
                    .iter()
                    .map(|c| (c.transpose() * &p * c)[(0, 0)])
                    .collect();
                report.lyapunov_residual = Some(res);
                add(&mut v, &lyap);
            }
            if has_white && diagnostics {
                // The band-limited share: the written white noises over their bands.
                let (lo, hi, cuts) = span(&is_white);
                let q = ss
                    .psd_variances(
                        &whites_only,
                        &rows,
                        (lo, hi),
                        &cuts,
                        BAND_TOL,
                        QUAD_INTERVALS,
                    )
                    .map_err(linear_error(file))?;
                // (`v` holds the white noises' Lyapunov variances alone here.)
                report.out_of_band = Some(
                    v.iter()
                        .zip(&q.variances)
                        .map(|(a, b)| if *a > 0.0 { (a - b).max(0.0) / a } else { 0.0 })
                        .fold(0.0, f64::max),
                );
            }
            if has_table {
                let (lo, hi, cuts) = span(&|t| !is_white(t));
                let q = ss
                    .psd_variances(
                        &tables_only,
                        &rows,
                        (lo, hi),
                        &cuts,
                        QUAD_TOL,
                        QUAD_INTERVALS,
                    )
                    .map_err(linear_error(file))?;
                report.quadrature_error = Some(worst(&q));
                add(&mut v, &q.variances);
            }
            report.basis = Some(ss.basis_size());
            Ok(v)
        };
        if method == RandomMethod::Dense {
            // The complete basis of every mode (the dense eigen-solver): the same solution as
            // on z itself, but the Schur form of the modal state matrix resolves the slow
            // modes to their own rounding, not to the fastest ones'.
            let first = &all[..all.len().min(lin.dim())];
            let basis = StateSpace::modal_basis(lin, first, &forces).map_err(linear_error(file))?;
            let complete = basis.ncols() == lin.dim();
            variances = solve(complete.then_some(basis), Some(&all), &mut report)?;
            report.basis = None;
            methods.push("lyapunov dense");
        } else {
            let half = StateSpace::modal_basis(lin, &found[..found.len().div_ceil(2)], &forces)
                .map_err(linear_error(file))?;
            let vh = solve(Some(half), None, &mut report)?;
            let basis = StateSpace::modal_basis(lin, found, &forces).map_err(linear_error(file))?;
            variances = solve(Some(basis), None, &mut report)?;
            report.truncation = Some(
                variances
                    .iter()
                    .zip(&vh)
                    .map(|(a, b)| if *a > 0.0 { (a - b).abs() / a } else { 0.0 })
                    .fold(0.0, f64::max),
            );
            report.modes = Some(found.len());
            methods.push("lyapunov modal");
        }
        if has_table {
            methods.push("quadrature");
        }
    }
    report.method = methods.join(" + ");
    let rms = |v: f64| v.max(0.0).sqrt();
    report.outputs = named
        .iter()
        .zip(&variances)
        .map(|(n, v)| OutputRms {
            name: n.name.clone(),
            unit: n.unit.clone(),
            rms: rms(*v),
        })
        .collect();
    let nn = named.len();
    report.generators = gens
        .iter()
        .enumerate()
        .map(|(k, g)| {
            let vi = variances[nn + 2 * k].max(0.0);
            GeneratorRms {
                name: g.name.clone(),
                rms_current: vi.sqrt(),
                rms_rotor_speed: rms(variances[nn + 2 * k + 1]),
                mean_power_dissipated: g.resistance * vi,
                mean_power_load: g.load_resistance * vi,
            }
        })
        .collect();
    Ok(report)
}

/// Largest relative residual of a mode accepted by [`modal_variances`].
const MODAL_RESIDUAL: f64 = 1e-10;
/// Largest normwise backward error of `Phi G = B` accepted by [`modal_variances`]
/// (`|Phi G - B| / (|Phi| |G| + |B|)`, a few hundred times the rounding unit).
const MODAL_SOLVE: f64 = 1e-12;

/// The white-noise variances `c^T P c` of the rows `rows` of the first-order form `ss` (on
/// the basis `basis`, `None`: `z` itself) from its complete eigen-decomposition instead of
/// the Lyapunov equation's Schur form (`docs/theory.md`, "Random figures from one modal
/// decomposition"): with `A = Phi Lambda Phi^-1` (the state eigenvectors `(y, lambda y)`
/// of every mode and its conjugate), `G = Phi^-1 B` and the noise intensities `W = diag(w)`,
///
/// ```text
/// P = Phi Ptilde Phi^H,   Ptilde_ij = (G W G^H)_ij / -(lambda_i + conj lambda_j)
/// c^T P c = sum_ij (c^T phi_i) Ptilde_ij conj(c^T phi_j)
/// ```
///
/// — one complex LU of `Phi` and `O(n^2)` a row, against the Schur form's `O(n^3)` with a
/// large constant. `None` (the caller solves the Lyapunov equation) where it does not apply:
/// electrical states, modes that do not make a complete basis (an overdamped pair cut by
/// the mode count, a multiple eigenvalue), a mode refined to more than `MODAL_RESIDUAL`,
/// an unstable mode, or `Phi G = B` solved worse than `MODAL_SOLVE`.
fn modal_variances(
    ss: &StateSpace,
    basis: Option<&nalgebra::DMatrix<f64>>,
    modes: &[Mode],
    w: &[f64],
    rows: &[nalgebra::DVector<f64>],
) -> Option<Vec<f64>> {
    use nalgebra::{Complex, DMatrix};
    type C = Complex<f64>;
    let n = ss.a.nrows();
    let r = ss.basis_size();
    if n != 2 * r || n == 0 {
        return None;
    }
    let mut lambdas: Vec<C> = Vec::with_capacity(n);
    let mut vectors: Vec<Vec<C>> = Vec::with_capacity(n);
    for m in modes {
        let l = m.lambda();
        if !(m.residual <= MODAL_RESIDUAL && l.re < 0.0) {
            return None;
        }
        let phi = m.shape_complex();
        let y: Vec<C> = match basis {
            Some(v) if v.nrows() == phi.len() && v.ncols() == r => (0..r)
                .map(|c| (0..phi.len()).map(|i| phi[i] * v[(i, c)]).sum())
                .collect(),
            None if phi.len() == r => phi,
            _ => return None,
        };
        if l.im != 0.0 {
            lambdas.push(l.conj());
            vectors.push(y.iter().map(|c| c.conj()).collect());
        }
        lambdas.push(l);
        vectors.push(y);
    }
    if lambdas.len() != n {
        return None;
    }
    let phi = DMatrix::<C>::from_fn(n, n, |i, j| {
        if i < r {
            vectors[j][i]
        } else {
            lambdas[j] * vectors[j][i - r]
        }
    });
    let b = ss.b.map(|v| C::new(v, 0.0));
    let g = phi.clone().lu().solve(&b)?;
    // The normwise backward error of the solve.
    let residual = (&phi * &g - &b).norm();
    if residual.is_nan() || residual > MODAL_SOLVE * (phi.norm() * g.norm() + b.norm()) {
        return None;
    }
    // (G W G^H)_ij / -(lambda_i + conj lambda_j), then the rows' quadratic forms.
    let gw = DMatrix::<C>::from_fn(n, g.ncols(), |i, k| g[(i, k)] * w[k]);
    let mut core = &gw * g.adjoint();
    for j in 0..n {
        for i in 0..n {
            core[(i, j)] /= -(lambdas[i] + lambdas[j].conj());
        }
    }
    let out = rows
        .iter()
        .map(|c| {
            let a = phi.tr_mul(&c.map(|v| C::new(v, 0.0)));
            (a.transpose() * &core * a.map(|v| v.conj()))[(0, 0)].re
        })
        .collect();
    Some(out)
}
