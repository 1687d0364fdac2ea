//! The linearised analysis of a damper or hybrid scenario (issue #11): its static
//! equilibrium and the modes of the linearised reduced equations about it
//! ([`hybrid_core::hybrid::Linearization`], [`hybrid_core::hybrid::modes`]), with the
//! generator connected, with every generator disconnected (mechanism and rotor inertia still
//! attached) and for the bare beam without mechanisms; the velocity amplification of every
//! generator at the equilibrium. What `damper linearize` prints and the sweeps' linear
//! figures are.

use fem_structure::tables::NodeDof;
use hybrid_core::hybrid::{
    BeamPoint, EigenMethod, EquilibriumOptions, HybridModel, LinearStructure, Linearization, Mode,
    ModeKind, Structure, modes,
};
use mbs_symbolic::runtime::TangentSystem;
use nalgebra::Complex;
use serde::Serialize;

use crate::Error;
use crate::analysis::AnalysisError;
use crate::scenario::Scenario;
use crate::setup::{Linearizable, tangents_for};

/// One mode as reported: frequencies, damping and the shape in physical terms.
#[derive(Clone, Debug, Serialize)]
pub struct ModeReport {
    /// 1-based, in increasing `|lambda|`.
    pub index: usize,
    /// Oscillatory, overdamped, rigid or unstable.
    pub kind: ModeKind,
    /// `lambda` (1/s): `[re, im]`.
    pub eigenvalue: [f64; 2],
    /// `|lambda| / 2 pi` (Hz).
    pub natural_frequency_hz: f64,
    /// `|Im lambda| / 2 pi` (Hz).
    pub damped_frequency_hz: f64,
    /// `-Re lambda / |lambda|`.
    pub damping_ratio: f64,
    /// `-Re lambda` (1/s).
    pub decay_rate: f64,
    /// Normwise backward error of the computed pair.
    pub backward_error: f64,
    /// Beam transverse deflection at every node: `[x (m), re, im]`, normalised to a largest
    /// entry 1.
    pub beam_shape: Vec<[f64; 3]>,
    /// An imported structure's nodes that move in the mechanisms' plane: `[node id, ux re,
    /// ux im, uy re, uy im]` (m, a held translation 0; a reduced model expanded to every
    /// node, `q = T z`), normalised as `beam_shape`; empty on the beam.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub structure_shape: Vec<[f64; 5]>,
    /// Per mechanism, per coordinate: `(name, [re, im])` (rad or m per unit of the
    /// normalised beam deflection).
    pub mechanism_shape: Vec<MechanismShape>,
}

/// A mechanism's part of a mode shape.
#[derive(Clone, Debug, Serialize)]
pub struct MechanismShape {
    /// The mechanism.
    pub mechanism: String,
    /// `(coordinate, [re, im])`.
    pub coordinates: Vec<(String, [f64; 2])>,
}

/// A generator's kinematic amplification at the equilibrium.
#[derive(Clone, Debug, Serialize)]
pub struct Amplification {
    /// The force element.
    pub generator: String,
    /// The attachment whose displacement drives it.
    pub attachment: String,
    /// The component of the attachment point's displacement, on an imported structure
    /// (`"x"` or `"y"`; a pin on a node couples both); absent on the beam (transverse).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub component: Option<&'static str>,
    /// `dq_joint / dw` (rad/m, or m/m on a prismatic joint).
    pub joint_per_displacement: f64,
    /// The rotor's speed per beam-point speed, `gear ratio * dq_joint / dw`.
    pub rotor_per_displacement: f64,
}

/// A mechanism at the equilibrium.
#[derive(Clone, Debug, Serialize)]
pub struct MechanismEquilibrium {
    /// Its name.
    pub name: String,
    /// Coordinates by name.
    pub q: Vec<(String, f64)>,
    /// The free (independent) coordinates.
    pub free: Vec<String>,
    /// cond_2 of its dependent Jacobian.
    pub jacobian_condition: f64,
    /// Multipliers of its constraint rows (loops, then per attachment transverse and axial).
    pub multipliers: Vec<f64>,
    /// How far its first attached beam point can still move, from the equilibrium, in the
    /// direction that stretches the mechanism to its singular (toggle) position (m), where
    /// the geometry gives it (the double bar: `2 L (1 - cos a0)` minus the static
    /// deflection): the amplitude the linearisation cannot hold beyond.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reach: Option<f64>,
}

/// The static equilibrium as reported.
#[derive(Clone, Debug, Serialize)]
pub struct EquilibriumReport {
    /// Newton iterations.
    pub iterations: usize,
    /// Final residual norm.
    pub residual: f64,
    /// Largest beam transverse displacement at the equilibrium (m); on an imported
    /// structure the largest of its translations (a reduced model's interface
    /// translations).
    pub beam_max_deflection: f64,
    /// Every mechanism.
    pub mechanisms: Vec<MechanismEquilibrium>,
}

/// Everything `damper linearize` reports.
#[derive(Clone, Debug, Serialize)]
pub struct LinearReport {
    /// The scenario file.
    pub scenario: String,
    /// The `--set` overrides applied, in command-line order.
    pub overrides: Vec<crate::scenario::OverrideRecord>,
    /// The eigen-solver used.
    pub method: EigenMethod,
    /// The equilibrium (generator connected).
    pub equilibrium: EquilibriumReport,
    /// Generators' amplification at the equilibrium.
    pub amplification: Vec<Amplification>,
    /// Modes with the generators connected.
    pub modes: Vec<ModeReport>,
    /// Modes with every generator disconnected (absent without generators).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub generator_disconnected: Option<Vec<ModeReport>>,
    /// Modes of the bare beam (no mechanism; absent without a beam or mechanisms).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bare_beam: Option<Vec<ModeReport>>,
    /// Modes of the bare structure, when the host is an imported structure (no mechanism;
    /// absent without mechanisms): `bare_beam`'s counterpart.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bare_structure: Option<Vec<ModeReport>>,
    /// An imported host structure, with a Craig–Bampton reduction's check (absent on a beam; set by
    /// [`crate::analysis::linearize::linearize`], not by the sweeps' linearisations).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub structure: Option<crate::report::structure::StructureReport>,
}

/// How far mechanism `i`'s first attached beam point can still move from the beam state
/// `beam_q` toward the singular (toggle) position (m): the mechanism's reach less the
/// point's displacement (the reach itself without an attachment); `None` where the geometry
/// does not give a reach.
pub fn remaining_reach(model: &HybridModel, i: usize, beam_q: &[f64]) -> Option<f64> {
    let w = model
        .attachments
        .iter()
        .find(|a| a.mechanism == i)
        .map_or(0.0, |a| reach_point(model, i, &a.beam).value(beam_q));
    Some(model.mechanisms[i].reach? - w)
}

/// The attached point `p` of mechanism `i` seen along the direction its reach is measured
/// in: a beam point along `y` (itself); a node, which moves in the plane, along the axis
/// from the mechanism's pivot (its mount's origin, where a placed two-bar chain has its
/// ground pivot) to the node ([`BeamPoint::along`]).
fn reach_point(model: &HybridModel, i: usize, p: &BeamPoint) -> BeamPoint {
    if p.axial.is_empty() {
        return p.clone();
    }
    let o = model.mechanisms[i].mount.origin;
    let (dx, dy) = (p.x - o[0], p.y - o[1]);
    let norm = dx.hypot(dy);
    if norm > 0.0 {
        p.along([dx / norm, dy / norm])
    } else {
        p.clone()
    }
}

/// The admissible load of one mechanism (issue #22, item 3): its remaining reach at the
/// equilibrium and the beam point of its first attachment, whose harmonic amplitude must
/// stay below the reach. For a harmonic force of amplitude `F` the linear amplitude of the
/// point is `|H_att| F` (`H_att`: the receptance from the force to the point's
/// displacement `w`), so the largest force amplitude the mechanism can take is
///
/// ```text
/// F_max(omega) = reach / |H_att(omega)|
/// ```
#[derive(Clone, Debug)]
pub struct LoadLimit {
    /// Index into [`HybridModel::mechanisms`].
    pub mechanism: usize,
    /// Its name.
    pub name: String,
    /// The remaining reach at the equilibrium (m), [`remaining_reach`].
    pub reach: f64,
    /// The point of its first attachment, seen along the direction of its reach (a node:
    /// along the pivot -> node axis).
    pub point: BeamPoint,
}

impl LoadLimit {
    /// Every mechanism with a reach and an attachment, at the equilibrium of `lin`.
    pub fn of(model: &HybridModel, lin: &Linearization) -> Vec<LoadLimit> {
        let beam_q = &lin.equilibrium.beam_q;
        (0..model.mechanisms.len())
            .filter_map(|i| {
                let a = model.attachments.iter().find(|a| a.mechanism == i)?;
                Some(LoadLimit {
                    mechanism: i,
                    name: model.mechanisms[i].name.clone(),
                    reach: remaining_reach(model, i, beam_q)?,
                    point: reach_point(model, i, &a.beam),
                })
            })
            .collect()
    }

    /// `H_att`: the point's displacement in the harmonic response `z` (per unit force,
    /// [`Linearization::harmonic_response`]).
    pub fn receptance(&self, z: &[Complex<f64>]) -> Complex<f64> {
        self.point.complex_value(z)
    }

    /// `F_max = reach / |H_att|` for the harmonic response `z` per unit force (infinite
    /// where the point does not move).
    pub fn max_force(&self, z: &[Complex<f64>]) -> f64 {
        self.reach / self.receptance(z).norm()
    }
}

/// An admissible load and its unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaxForce {
    /// The force amplitude.
    pub value: f64,
    /// `N`, or `N m` for a joint torque.
    pub unit: &'static str,
}

/// `linear.max_force`: the smallest over the mechanisms of `reach / |H_att|` at `f_hz`
/// for the model's first excitation (`None` without an excitation or a load limit), with
/// its unit (`N` for a beam force, `N m` or `N` for a joint torque or force, `m/s^2` for
/// the supports' acceleration).
pub fn max_force_at(
    model: &HybridModel,
    lin: &Linearization,
    f_hz: f64,
) -> Result<Option<MaxForce>, hybrid_core::hybrid::LinearError> {
    let Some(e) = model.excitations.first() else {
        return Ok(None);
    };
    let limits = LoadLimit::of(model, lin);
    if limits.is_empty() {
        return Ok(None);
    }
    let f = lin.force_vector(&e.target);
    let z = lin.harmonic_response(&f, 2.0 * std::f64::consts::PI * f_hz)?;
    let unit = model.excitation_unit(&e.target);
    Ok(limits
        .iter()
        .map(|l| l.max_force(&z))
        .reduce(f64::min)
        .map(|value| MaxForce { value, unit }))
}

/// Linearises a loaded scenario and computes `k` modes of each variant.
pub fn analyse(
    file: &str,
    sc: &Scenario,
    k: usize,
    method: EigenMethod,
) -> Result<LinearReport, Error> {
    let lin_in = tangents_for(sc)?;
    analyse_model(file, &lin_in, k, method)
}

fn linearise(
    file: &str,
    model: &HybridModel,
    tangents: &[&TangentSystem],
) -> Result<Linearization, Error> {
    Linearization::new(model, tangents, EquilibriumOptions::default()).map_err(|error| {
        Error::Linear {
            file: file.to_string(),
            error,
        }
    })
}

/// A loaded scenario built for linearisation and linearised about its static equilibrium
/// (the generators as the scenario says).
pub fn linearise_scenario(
    file: &str,
    sc: &Scenario,
) -> Result<(Linearizable, Linearization), Error> {
    let input = tangents_for(sc)?;
    let lin = linearise(file, &input.model, &input.tangent_refs())?;
    Ok((input, lin))
}

fn modes_of(
    file: &str,
    lin: &Linearization,
    model: &HybridModel,
    k: usize,
    method: EigenMethod,
) -> Result<Vec<ModeReport>, Error> {
    modes_keeping(file, lin, model, k, method, None)
}

/// [`modes_of`]; with `all`, every mode of the dense eigen-solution is kept there (the
/// same first `k`: the dense solution sorts every eigenvalue, then truncates) for the
/// random figures of the same point ([`crate::random::figures_of`]), where the dense
/// solution is the method (`Auto` up to 600 states).
fn modes_keeping(
    file: &str,
    lin: &Linearization,
    model: &HybridModel,
    k: usize,
    method: EigenMethod,
    all: Option<&mut Vec<Mode>>,
) -> Result<Vec<ModeReport>, Error> {
    let error = |error| Error::Linear {
        file: file.to_string(),
        error,
    };
    let states = crate::random::states(lin);
    let dense = method.is_dense(states);
    let found = match all {
        Some(all) if dense => {
            *all = modes(lin, states, EigenMethod::Dense).map_err(error)?;
            all[..k.min(all.len())].to_vec()
        }
        _ => modes(lin, k, method).map_err(error)?,
    };
    Ok(found
        .iter()
        .enumerate()
        .map(|(i, m)| mode_report(i, m, lin, model))
        .collect())
}

/// [`analyse`] of an already built linearisable system.
pub fn analyse_model(
    file: &str,
    input: &Linearizable,
    k: usize,
    method: EigenMethod,
) -> Result<LinearReport, Error> {
    Ok(analyse_linearization(file, input, k, method)?.0)
}

/// [`analyse`] and the admissible load at the first mode's natural frequency (with the
/// generator) for the scenario's first excitation, [`max_force_at`]: one more complex
/// solve (the sweep figure `linear.max_force`).
/// Also returns the system built for linearisation and its linearisation with the
/// generator(s), for further figures of the same point.
pub fn analyse_with_max_force(
    file: &str,
    sc: &Scenario,
    k: usize,
    method: EigenMethod,
    comparisons: bool,
    all: Option<&mut Vec<Mode>>,
) -> Result<(LinearReport, Option<MaxForce>, Linearizable, Linearization), Error> {
    let input = tangents_for(sc)?;
    let (report, lin) = analyse_linearization_with(file, &input, k, method, comparisons, all)?;
    let max_force = match report.modes.first() {
        Some(m) => max_force_at(&input.model, &lin, m.natural_frequency_hz).map_err(|error| {
            Error::Linear {
                file: file.to_string(),
                error,
            }
        })?,
        None => None,
    };
    Ok((report, max_force, input, lin))
}

/// [`analyse_model`], keeping the linearisation with the generator (its reduced matrices
/// `M_R`, `C_R`, `K_R`: [`Linearization::dense`]).
pub fn analyse_linearization(
    file: &str,
    input: &Linearizable,
    k: usize,
    method: EigenMethod,
) -> Result<(LinearReport, Linearization), Error> {
    analyse_linearization_with(file, input, k, method, true, None)
}

/// [`analyse_linearization`], the comparison variants (generator(s) disconnected, bare
/// beam: two more linearisations and eigen-solutions) only when `comparisons`; with `all`,
/// every mode of the dense eigen-solution kept there (`modes_keeping`).
pub fn analyse_linearization_with(
    file: &str,
    input: &Linearizable,
    k: usize,
    method: EigenMethod,
    comparisons: bool,
    all: Option<&mut Vec<Mode>>,
) -> Result<(LinearReport, Linearization), Error> {
    let refs = input.tangent_refs();
    let model = &input.model;
    let lin = linearise(file, model, &refs)?;
    let with = modes_keeping(file, &lin, model, k, method, all)?;
    let has_generator = model.forces.iter().any(|f| f.generator().is_some());
    let generator_disconnected = if has_generator && comparisons {
        let off = input.model.generators_disconnected();
        let lin_off = linearise(file, &off, &refs)?;
        Some(modes_of(file, &lin_off, &off, k, method)?)
    } else {
        None
    };
    let bare = match &model.structure {
        Some(st) if !model.mechanisms.is_empty() && comparisons => {
            let bare = HybridModel::new(Some(st.clone()), vec![], vec![], vec![], vec![])
                .expect("a structure alone is a valid hybrid model");
            let lin_bare = linearise(file, &bare, &[])?;
            Some(modes_of(file, &lin_bare, &bare, k, method)?)
        }
        _ => None,
    };
    let (bare_beam, bare_structure) = if model.beam().is_some() {
        (bare, None)
    } else {
        (None, bare)
    };
    let eq = &lin.equilibrium;
    let mechanisms = model
        .mechanisms
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let names = m.system.coordinate_names();
            MechanismEquilibrium {
                name: m.name.clone(),
                q: names
                    .iter()
                    .cloned()
                    .zip(eq.mech_q[i].iter().copied())
                    .collect(),
                free: eq.free[i].iter().map(|&c| names[c].clone()).collect(),
                jacobian_condition: eq.conditions[i],
                multipliers: eq.multipliers[i].clone(),
                reach: remaining_reach(model, i, &eq.beam_q),
            }
        })
        .collect();
    let beam_max_deflection = lin
        .translation_dofs()
        .iter()
        .fold(0.0f64, |m, &i| m.max(eq.beam_q[i].abs()));
    let on_beam = model.beam().is_some();
    let mut amplification = vec![];
    for f in &model.forces {
        let Some(g) = f.generator() else { continue };
        for (k, c) in lin.couplings().iter().enumerate() {
            let a = &model.attachments[c.attachment];
            if a.mechanism != f.mechanism {
                continue;
            }
            let r = lin.amplification(f.mechanism, f.joint, k);
            amplification.push(Amplification {
                generator: f.name.clone(),
                attachment: a.name.clone(),
                component: (!on_beam).then_some(if c.axial { "x" } else { "y" }),
                joint_per_displacement: r,
                rotor_per_displacement: g.gear_ratio * r,
            });
        }
    }
    let report = LinearReport {
        scenario: file.to_string(),
        overrides: vec![],
        method,
        equilibrium: EquilibriumReport {
            iterations: eq.iterations,
            residual: eq.residual,
            beam_max_deflection,
            mechanisms,
        },
        amplification,
        modes: with,
        generator_disconnected,
        bare_beam,
        bare_structure,
        structure: None,
    };
    Ok((report, lin))
}

fn mode_report(i: usize, m: &Mode, lin: &Linearization, model: &HybridModel) -> ModeReport {
    let z = m.shape_complex();
    let beam_shape = lin
        .beam_deflection(&z)
        .into_iter()
        .map(|(x, w)| [x, w.re, w.im])
        .collect();
    let structure_shape = lin
        .structure()
        .map_or_else(Vec::new, |st| node_shape(st, &z));
    let motion = lin.mechanism_motion(&z);
    let mechanism_shape = model
        .mechanisms
        .iter()
        .zip(motion)
        .map(|(mm, dq)| MechanismShape {
            mechanism: mm.name.clone(),
            coordinates: mm
                .system
                .coordinate_names()
                .iter()
                .cloned()
                .zip(dq.iter().map(|v| [v.re, v.im]))
                .collect(),
        })
        .collect();
    ModeReport {
        index: i + 1,
        kind: m.kind,
        eigenvalue: m.eigenvalue,
        natural_frequency_hz: m.natural_frequency_hz,
        damped_frequency_hz: m.damped_frequency_hz,
        damping_ratio: m.damping_ratio,
        decay_rate: m.decay_rate,
        backward_error: m.residual,
        beam_shape,
        structure_shape,
        mechanism_shape,
    }
}

/// [`ModeReport::structure_shape`] of the state `z` on an imported structure (empty on the
/// beam).
fn node_shape(st: &Structure, z: &[Complex<f64>]) -> Vec<[f64; 5]> {
    let n = st.dof_count();
    let (re, im): (Vec<f64>, Vec<f64>) = z[..n].iter().map(|v| (v.re, v.im)).unzip();
    node_translations(st, &re)
        .into_iter()
        .zip(node_translations(st, &im))
        .map(|((node, [a, c]), (_, [b, d]))| [node as f64, a, b, c, d])
        .collect()
}

/// The in-plane translations `(node, [u_x, u_y])` of an imported structure's nodes that
/// move in the mechanisms' plane (a held translation 0), in the node table's order, for
/// the structure's coordinates `q` (a reduced model's expanded to every node, `q = T z`);
/// empty on the beam.
pub fn node_translations(st: &Structure, q: &[f64]) -> Vec<(u64, [f64; 2])> {
    let Some(full) = st.imported() else {
        return vec![];
    };
    let expanded;
    let q = match st {
        Structure::Reduced { reduced, .. } => {
            expanded = reduced.expand(q);
            &expanded[..]
        }
        _ => q,
    };
    full.nodes
        .iter()
        .filter_map(|node| {
            let eq = |d: NodeDof| full.dofs.equation.get(&(node.id, d)).copied();
            let (ux, uy) = (eq(NodeDof::Ux), eq(NodeDof::Uy));
            if ux.is_none() && uy.is_none() {
                return None;
            }
            let part = |e: Option<usize>| e.map_or(0.0, |i| q[i]);
            Some((node.id, [part(ux), part(uy)]))
        })
        .collect()
}

/// A receptance peak objective, `peak:X:F1:F2`: the largest `|H|` of the beam's transverse
/// displacement at `x` (m) per unit amplitude of the scenario's first excitation, over the
/// band `F1..F2` (Hz), with the generator(s) connected — the H-infinity design figure.
#[derive(Clone, Debug, PartialEq)]
pub struct PeakSpec {
    /// The output's abscissa on the beam (m).
    pub x: f64,
    /// The band (Hz).
    pub band: (f64, f64),
}

impl PeakSpec {
    /// `peak:X:F1:F2` (`None` for any other figure name).
    pub fn parse(name: &str) -> Option<PeakSpec> {
        let rest = name.strip_prefix("peak:")?;
        let v: Vec<f64> = rest
            .split(':')
            .map(|t| t.trim().parse().ok())
            .collect::<Option<_>>()?;
        match v[..] {
            [x, f1, f2] if x.is_finite() && f1 > 0.0 && f2 > f1 && f2.is_finite() => {
                Some(PeakSpec { x, band: (f1, f2) })
            }
            _ => None,
        }
    }
}

/// Points of the scan of [`receptance_peak`] before the refinement.
const PEAK_SCAN: usize = 200;

/// The peak of [`PeakSpec`] for a loaded scenario: `(frequency (Hz), |H|)`. The band is
/// scanned at `PEAK_SCAN` (200) log-spaced frequencies, then the largest sample is refined by
/// golden-section search between its neighbours, then by regula falsi on the slope of `|H|`
/// (the frequency to its rounding, which the adjoint gradient of the peak needs: its error
/// enters `d|H|/dp` to first order).
pub fn receptance_peak(file: &str, sc: &Scenario, spec: &PeakSpec) -> Result<(f64, f64), Error> {
    let (input, lin) = linearise_scenario(file, sc)?;
    peak_of(file, &input.model, &lin, spec)
}

/// The output point of [`PeakSpec`] on `model`'s beam and the generalised force of its first
/// excitation.
pub fn peak_input(
    file: &str,
    model: &HybridModel,
    lin: &Linearization,
    spec: &PeakSpec,
) -> Result<(BeamPoint, Vec<f64>), Error> {
    let unavailable = |m: String| Error::from(AnalysisError::unavailable(file, m));
    let Some(e) = model.excitations.first() else {
        return Err(unavailable(
            "a peak objective needs an excitation in the scenario".into(),
        ));
    };
    let Some(point) = model.beam().and_then(|b| BeamPoint::on(b, spec.x)) else {
        return Err(unavailable(format!(
            "peak: x = {} is not on the beam",
            spec.x
        )));
    };
    Ok((point, lin.force_vector(&e.target)))
}

/// [`receptance_peak`] of a linearised model.
pub fn peak_of(
    file: &str,
    model: &HybridModel,
    lin: &Linearization,
    spec: &PeakSpec,
) -> Result<(f64, f64), Error> {
    let (point, f) = peak_input(file, model, lin, spec)?;
    let h = |hz: f64| -> Result<f64, Error> {
        let z = lin
            .harmonic_response(&f, 2.0 * std::f64::consts::PI * hz)
            .map_err(|error| Error::Linear {
                file: file.to_string(),
                error,
            })?;
        Ok(point.complex_value(&z).norm())
    };
    let (f1, f2) = spec.band;
    let at = |k: usize| f1 * (f2 / f1).powf(k as f64 / (PEAK_SCAN - 1) as f64);
    let mut best = (0, h(f1)?);
    for k in 1..PEAK_SCAN {
        let v = h(at(k))?;
        if v > best.1 {
            best = (k, v);
        }
    }
    let (mut a, mut b) = (
        at(best.0.saturating_sub(1)),
        at((best.0 + 1).min(PEAK_SCAN - 1)),
    );
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut hc, mut hd) = (h(c)?, h(d)?);
    // Golden section: at most 60 iterations (the bracket shrinks by 0.618 each).
    for _ in 0..60 {
        if (b - a) <= 1e-9 * b {
            break;
        }
        if hc > hd {
            b = d;
            d = c;
            hd = hc;
            c = b - g * (b - a);
            hc = h(c)?;
        } else {
            a = c;
            c = d;
            hc = hd;
            d = a + g * (b - a);
            hd = h(d)?;
        }
    }
    let (fm, hm) = if hc > hd { (c, hc) } else { (d, hd) };
    let (fm, hm) = if hm >= best.1 {
        (fm, hm)
    } else {
        (at(best.0), best.1)
    };
    // The stationary point itself: |H| is flat at its peak, so the golden section locates it
    // only to the square root of |H|'s rounding (~1e-8 of the frequency); the slope
    // g = d|H|^2/d omega / 2 = Re(conj(H) dH/d omega), dz/d omega = -S^-1 (i S'(i omega) z),
    // crosses zero linearly there and locates it to its own rounding.
    let slope = |hz: f64| -> Result<(f64, f64), Error> {
        let sigma = Complex::new(0.0, 2.0 * std::f64::consts::PI * hz);
        let pencil =
            hybrid_core::hybrid::Pencil::new(lin, sigma).map_err(|error| Error::Linear {
                file: file.to_string(),
                error,
            })?;
        let mut z: Vec<Complex<f64>> = f.iter().map(|&v| Complex::new(v, 0.0)).collect();
        pencil.solve_in_place(&mut z);
        let mut dz: Vec<Complex<f64>> = lin
            .pencil_rate_mul(sigma, &z)
            .iter()
            .map(|v| -v * Complex::new(0.0, 1.0))
            .collect();
        pencil.solve_in_place(&mut dz);
        let (h, dh) = (point.complex_value(&z), point.complex_value(&dz));
        Ok(((h.conj() * dh).re, h.norm()))
    };
    let (mut lo, mut hi) = (fm * (1.0 - 1e-6), fm * (1.0 + 1e-6));
    let (mut glo, mut ghi) = (slope(lo)?.0, slope(hi)?.0);
    if lo > f1 && hi < f2 && glo > 0.0 && ghi < 0.0 {
        // Regula falsi with the Illinois modification (g is nearly linear over the bracket:
        // a few steps), at most 60, to a bracket at the frequency's rounding.
        let mut side = 0i8;
        for _ in 0..60 {
            if hi - lo <= 4.0 * f64::EPSILON * hi {
                break;
            }
            let mid = (lo * ghi - hi * glo) / (ghi - glo);
            let mid = if mid > lo && mid < hi {
                mid
            } else {
                0.5 * (lo + hi)
            };
            let g = slope(mid)?.0;
            if g > 0.0 {
                lo = mid;
                glo = g;
                if side == 1 {
                    ghi *= 0.5;
                }
                side = 1;
            } else if g < 0.0 {
                hi = mid;
                ghi = g;
                if side == -1 {
                    glo *= 0.5;
                }
                side = -1;
            } else {
                (lo, hi) = (mid, mid);
            }
        }
        let f = 0.5 * (lo + hi);
        // Its |H| equals the golden section's to the rounding of |H| (5e-11 relative
        // measured on the forced damper, whose dynamic stiffness is ill-conditioned at
        // resonance): either side of it.
        let h = slope(f)?.1;
        if h >= hm * (1.0 - 1e-9) {
            return Ok((f, h));
        }
    }
    Ok((fm, hm))
}

/// A connected generator's phasors in a linear harmonic response (amplitudes and phases of
/// `x e^{i omega t}`): the rotor speed `n i omega q_j`, the current
/// `k_e n i omega q_j / (R_a + R_L + i omega L)` (docs/theory.md section 7), the terminal voltage
/// across the load `R_L i`, and the load's mean power `R_L |i|^2 / 2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeneratorPhasor {
    /// Index of the generator in [`HybridModel::forces`].
    pub force: usize,
    /// Rotor speed (rad/s).
    pub rotor_speed: Complex<f64>,
    /// Current (A).
    pub current: Complex<f64>,
    /// Terminal voltage across the load (V).
    pub voltage: Complex<f64>,
    /// Mean power in the load (W).
    pub load_power: f64,
    /// Mean power dissipated in the circuit, `(R_a + R_L) |i|^2 / 2` (W).
    pub dissipated_power: f64,
}

/// The phasors of every connected generator of `model` in the response `z` of `lin` at
/// `omega` (rad/s), in the order of [`HybridModel::forces`].
pub fn generator_phasors(
    model: &HybridModel,
    lin: &Linearization,
    z: &[Complex<f64>],
    omega: f64,
) -> Vec<GeneratorPhasor> {
    let motion = lin.mechanism_motion(z);
    model
        .forces
        .iter()
        .enumerate()
        .filter_map(|(k, f)| {
            let g = f.generator().filter(|g| g.connected)?;
            let rotor_speed =
                motion[f.mechanism][f.joint] * Complex::new(0.0, omega) * g.gear_ratio;
            let current = g.ke * rotor_speed / Complex::new(g.resistance(), omega * g.inductance);
            Some(GeneratorPhasor {
                force: k,
                rotor_speed,
                current,
                voltage: g.load_resistance * current,
                load_power: 0.5 * g.load_resistance * current.norm_sqr(),
                dissipated_power: 0.5 * g.resistance() * current.norm_sqr(),
            })
        })
        .collect()
}

/// One harmonic excitation's linear response: its angular frequency, complex amplitude
/// (amplitude and phase) and the response `z` per unit amplitude.
#[derive(Clone, Debug)]
pub struct HarmonicResponse {
    /// Angular frequency (rad/s).
    pub omega: f64,
    /// `amplitude e^{i phase}`.
    pub scale: Complex<f64>,
    /// The response per unit amplitude ([`Linearization::harmonic_response`]).
    pub z: Vec<Complex<f64>>,
}

/// The angular frequency and complex amplitude of a harmonic excitation (`None` for any
/// other time function).
pub fn harmonic_of(e: &hybrid_core::hybrid::Excitation) -> Option<(f64, Complex<f64>)> {
    match e.time {
        fem_beam::TimeFunction::Harmonic {
            frequency_hz,
            phase,
        } => Some((
            2.0 * std::f64::consts::PI * frequency_hz,
            Complex::from_polar(e.amplitude, phase),
        )),
        _ => None,
    }
}

/// The responses of `lin` to every excitation of `model`, which must all be harmonic (the
/// `power` objective).
pub fn harmonic_responses(
    file: &str,
    model: &HybridModel,
    lin: &Linearization,
) -> Result<Vec<HarmonicResponse>, Error> {
    let unavailable = |m: String| Error::from(AnalysisError::unavailable(file, m));
    if model.excitations.is_empty() {
        return Err(unavailable(
            "the power objective needs a harmonic excitation".into(),
        ));
    }
    model
        .excitations
        .iter()
        .map(|e| {
            let (omega, scale) = harmonic_of(e).ok_or_else(|| {
                unavailable(format!(
                    "excitation \"{}\": the power objective needs harmonic excitations",
                    e.name
                ))
            })?;
            let f = lin.force_vector(&e.target);
            let z = lin
                .harmonic_response(&f, omega)
                .map_err(|error| Error::Linear {
                    file: file.to_string(),
                    error,
                })?;
            Ok(HarmonicResponse { omega, scale, z })
        })
        .collect()
}

/// The mean power in the load resistances (W) of the steady state made of `responses`: per
/// frequency the responses are superposed (amplitude and phase), each generator's load
/// power is read from its phasors ([`generator_phasors`]); powers at different frequencies
/// add.
pub fn load_power(model: &HybridModel, lin: &Linearization, responses: &[HarmonicResponse]) -> f64 {
    let mut groups: Vec<(f64, Vec<Complex<f64>>)> = vec![];
    for r in responses {
        match groups.iter_mut().find(|(w, _)| *w == r.omega) {
            Some((_, sum)) => sum
                .iter_mut()
                .zip(&r.z)
                .for_each(|(s, z)| *s += r.scale * z),
            None => groups.push((r.omega, r.z.iter().map(|z| r.scale * z).collect())),
        }
    }
    groups
        .iter()
        .flat_map(|(omega, z)| generator_phasors(model, lin, z, *omega))
        .map(|g| g.load_power)
        .sum()
}

/// The mean power harvested in the load resistances (W) in the steady state of the
/// linearised system under the scenario's harmonic excitations (`power`, the harvesting
/// objective; [`harmonic_responses`], [`load_power`]). An excitation that is not harmonic
/// is an error.
pub fn harvested_power(file: &str, sc: &Scenario) -> Result<f64, Error> {
    let (input, lin) = linearise_scenario(file, sc)?;
    let responses = harmonic_responses(file, &input.model, &lin)?;
    Ok(load_power(&input.model, &lin, &responses))
}
