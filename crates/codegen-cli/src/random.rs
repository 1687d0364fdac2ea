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
    EigenMethod, ExcitationTarget, Linearization, PsdInput, StateOutput, StateSpace, modes,
    psd_variances,
};
use serde::Serialize;

use crate::Error;
use crate::analysis::frf::parse_output;
use crate::scenario::Scenario;
use crate::setup::Linearizable;

/// How the white-noise response is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RandomMethod {
    /// Dense up to [`DENSE_STATES`] states, modal above.
    Auto,
    /// The Lyapunov equation of the whole first-order form.
    Dense,
    /// The Lyapunov equation on a modal basis.
    Modal,
    /// Every input by PSD quadrature (white noise over `[0, ∞)`).
    Quadrature,
}

impl RandomMethod {
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
        },
    )?;
    let first = report
        .outputs
        .first()
        .ok_or_else(|| Error::Usage(format!("{file}: rms:{output}: no such output")))?;
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
    /// Outputs as `--output` names them (default: every attachment, mechanism coordinate).
    pub outputs: Vec<String>,
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
    let usage = |m: String| Error::Usage(format!("{file}: {m}"));
    let model = &input.model;
    let random: Vec<_> = model
        .excitations
        .iter()
        .filter(|e| e.time.is_random())
        .collect();
    if random.is_empty() {
        return Err(usage(
            "no random excitation: give one `time = { kind = \"white_noise\", psd = G, band = [F1, F2] }` or `{ kind = \"psd\", table = [[f, G], ...] }`".into(),
        ));
    }
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
    if opts.outputs.is_empty() {
        for a in &model.attachments {
            let t = ExcitationTarget::Beam(a.beam.clone());
            push_pair(&t, format!("w(x={})", a.beam.x), "m");
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
        for o in &opts.outputs {
            let (t, _, unit) = parse_output(model, o)?;
            let label = match &t {
                ExcitationTarget::Beam(p) => format!("w(x={})", p.x),
                _ => o.clone(),
            };
            push_pair(&t, label, unit);
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
        gens.push((
            f.name.clone(),
            g.resistance(),
            g.load_resistance,
            current,
            speed,
        ));
    }
    let mut outputs: Vec<StateOutput> = named.iter().map(|n| n.output.clone()).collect();
    for (_, _, _, i, s) in &gens {
        outputs.push(i.clone());
        outputs.push(s.clone());
    }
    let no = outputs.len();
    let nstates = states(lin);
    let method = match opts.method {
        RandomMethod::Auto if nstates <= DENSE_STATES => RandomMethod::Dense,
        RandomMethod::Auto => RandomMethod::Modal,
        m => m,
    };
    // Modes: the modal basis and the quadrature's breakpoints.
    let k = opts.modes.min(lin.dim()).max(1);
    // Dense: every mode at once (the complete basis below), the first `k` for the cuts.
    let all = if method == RandomMethod::Dense {
        modes(lin, lin.dim(), EigenMethod::Dense).map_err(linear_error(file))?
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
                     report: &mut RandomReport|
         -> Result<Vec<f64>, Error> {
            let ss = StateSpace::new(lin, &forces, basis).map_err(linear_error(file))?;
            let rows: Vec<_> = outputs.iter().map(|o| ss.row(o)).collect();
            let mut v = vec![0.0; no];
            if has_white {
                let w: Vec<f64> = ideal.iter().map(|g| 0.5 * g).collect();
                let (p, res) = ss.covariance(&w).map_err(linear_error(file))?;
                let lyap: Vec<f64> = rows
                    .iter()
                    .map(|c| (c.transpose() * &p * c)[(0, 0)])
                    .collect();
                report.lyapunov_residual = Some(res);
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
                report.out_of_band = Some(
                    lyap.iter()
                        .zip(&q.variances)
                        .map(|(a, b)| if *a > 0.0 { (a - b).max(0.0) / a } else { 0.0 })
                        .fold(0.0, f64::max),
                );
                add(&mut v, &lyap);
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
            let basis = StateSpace::modal_basis(lin, &all, &forces).map_err(linear_error(file))?;
            let complete = basis.ncols() == lin.dim();
            variances = solve(complete.then_some(basis), &mut report)?;
            report.basis = None;
            methods.push("lyapunov dense");
        } else {
            let half = StateSpace::modal_basis(lin, &found[..found.len().div_ceil(2)], &forces)
                .map_err(linear_error(file))?;
            let vh = solve(Some(half), &mut report)?;
            let basis = StateSpace::modal_basis(lin, found, &forces).map_err(linear_error(file))?;
            variances = solve(Some(basis), &mut report)?;
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
        .map(|(k, (name, r, rl, _, _))| {
            let vi = variances[nn + 2 * k].max(0.0);
            GeneratorRms {
                name: name.clone(),
                rms_current: vi.sqrt(),
                rms_rotor_speed: rms(variances[nn + 2 * k + 1]),
                mean_power_dissipated: r * vi,
                mean_power_load: rl * vi,
            }
        })
        .collect();
    Ok(report)
}
