//! The outputs of a hybrid run (`kind = "hybrid"`): the columns of its CSV time history
//! ([`Columns`]) and its typed JSON summary ([`HybridSummary`]).
//!
//! Columns, in order (units in brackets):
//!
//! - `t [s]`;
//! - per mechanism `M`: every coordinate `M.q [rad|m]`, every rate `M.q_dot [rad/s|m/s]`,
//!   `M.cond_jd [-]` (2-norm condition number of its dependent Jacobian) and
//!   `M.constraint_residual [m]` (|h| after the position solve);
//! - per attachment `A`: on the beam `A.w [m]`, `A.w_dot [m/s]` (the beam point's
//!   displacement and velocity); at a node of a `[structure]` the node's two in-plane
//!   components `A.ux [m]`, `A.ux_dot [m/s]`, `A.uy [m]`, `A.uy_dot [m/s]` (pin or roller;
//!   0 along a direction a support holds; on a reduced model read through `q = T z`) and,
//!   where a generator is on its mechanism, `A.amplification [rad/m]`: the
//!   kinematic influence `dq/dw` of the beam point's displacement on the generator joint
//!   (free coordinates held; a column of `R`, eq. 18, from the constraint Jacobian at the
//!   row's configuration — defined at rest, so written from `t = 0` on, and the same
//!   definition as the damper kind's `amplification` and `damper linearize`'s). Where the
//!   generator joint's speed is not that influence times the beam point's speed (its
//!   mechanism has free coordinates or several attachments) also `A.speed_ratio [rad/m]`,
//!   generator joint speed / beam point speed (empty where the beam point is at rest);
//! - per force element `F`: `F.dissipated [J]`; a generator also `F.current [A]`,
//!   `F.power [W]` (`(R_a + R_L) i^2`), `F.load_power [W]` (`R_L i^2`, the power harvested
//!   in the load) and `F.harvested [J]` (the load's share `R_L / (R_a + R_L)` of the
//!   energy dissipated in the circuit; `F.dissipated` also holds the gear's loss);
//! - per excitation `E`: `E.value [N|N m|m/s^2]` and `E.work [J]` (a base excitation's
//!   work is that of the inertial loads `-m a_b y` on every mass, in the frame moving
//!   with the supports);
//! - with a base excitation (`at = "base"`): the supports' motion along its direction `d`
//!   `base.a [m/s^2]`, `base.v [m/s]`, `base.u [m]` ([`HybridModel::support_motion`]:
//!   harmonic — the zero-mean periodic motion; constant, step, table — the integrals from
//!   rest at `t = 0`), and per attachment `A` its absolute motion `A.w_abs [m]`,
//!   `A.w_dot_abs [m/s]` (`w + (d_A . d) u`, `w' + (d_A . d) v`, `d_A` the direction `w` is
//!   measured along — the beam's `y`, where `d_A . d = 1`: every other displacement is
//!   relative to the supports; at a node `A.ux_abs`, `A.ux_dot_abs`, `A.uy_abs`,
//!   `A.uy_dot_abs` with `d_A` the axis);
//! - the energy account: `beam_kinetic [J]`, `beam_potential [J]`, per mechanism
//!   `M.kinetic [J]` and `M.potential [J]`, `magnetic [J]`, `stored [J]`,
//!   `dissipated_structure [J]`, `beam_load_work [J]` and `balance_error [J]`
//!   (`(E_0 + W) - (E + D)`, every dissipation and input work in it);
//! - a comparison run's probes `P.w [m]`, `P.w_dot [m/s]` (at a node `P.ux`, `P.ux_dot`,
//!   `P.uy`, `P.uy_dot`), named as the attachments they stand for;
//! - per mechanism `M` whose model has force elements of its own:
//!   `M.dissipated_model [J]` (its dampers) and `M.model_work [J]` (its constant loads);
//! - per `[output] points` entry `P` (`741:ux`, `w(x=0.5)`): `P [m]`, `P_dot [m/s]`.

use std::collections::BTreeMap;

use hybrid_core::hybrid::{BeamPoint, HybridModel, HybridState, Integrator, Stored, balance_error};
use mbs_symbolic::model::Model;
use serde::Serialize;

use crate::scenario::OverrideRecord;
use crate::setup::Probes;
use crate::setup::build::readings;

use crate::scenario::integrator::IntegratorSpec;

/// The CSV layout of a hybrid run: header and the row of a state.
#[derive(Clone, Debug)]
pub struct Columns {
    header: Vec<String>,
    /// Per attachment: the generator force element on its mechanism, if any, and whether
    /// the speed ratio has its own column.
    amplifier: Vec<Option<(usize, bool)>>,
    /// Per attachment, the displacements it writes (`A.w`, or a node's `A.ux`, `A.uy`).
    attached: Vec<Probes>,
    /// Structure points read but not attached, each seen along one direction: the probes'
    /// readings, then the output points.
    probes: Probes,
    /// How many of [`Columns::probes`] are the output points (the last ones).
    points: usize,
    /// The mechanisms whose own model's force elements have columns (the last ones).
    model_elements: Vec<usize>,
    /// Whether the supports' motion and the absolute attachment motion have columns.
    base: bool,
    cells: Vec<f64>,
}

impl Columns {
    /// The columns of `model` run from `initial`; the units of each coordinate are its
    /// backend's ([`mbs_symbolic::runtime::System::coordinate_units`]).
    pub fn new(model: &HybridModel, initial: &HybridState) -> Columns {
        let unit = |m: usize, c: usize| model.mechanisms[m].system.coordinate_units()[c];
        let mut h = vec!["t [s]".to_string()];
        for m in &model.mechanisms {
            let names = m.system.coordinate_names();
            let units = m.system.coordinate_units();
            for (c, u) in names.iter().zip(units) {
                h.push(format!("{}.{c} [{}]", m.name, u.symbol()));
            }
            for (c, u) in names.iter().zip(units) {
                h.push(format!("{}.{c}_dot [{}]", m.name, u.rate()));
            }
            h.push(format!("{}.cond_jd [-]", m.name));
            h.push(format!("{}.constraint_residual [m]", m.name));
        }
        let mut amplifier = vec![];
        let attached: Vec<Probes> = model
            .attachments
            .iter()
            .map(|a| readings(model, &a.name, &a.beam))
            .collect();
        for (a, read) in model.attachments.iter().zip(&attached) {
            for (name, _) in read {
                h.push(format!("{name} [m]"));
                h.push(format!("{name}_dot [m/s]"));
            }
            let g = model
                .forces
                .iter()
                .position(|f| f.mechanism == a.mechanism && f.generator().is_some());
            let g = g.map(|g| {
                let f = &model.forces[g];
                let u = unit(f.mechanism, f.joint).per_metre();
                h.push(format!("{}.amplification [{u}]", a.name));
                // q_g' = sum_k (dq_g/dw_k) w_k' + (terms of the free coordinates): the speed
                // ratio is the influence itself unless there are other terms.
                let attached = model
                    .attachments
                    .iter()
                    .filter(|b| b.mechanism == a.mechanism)
                    .count();
                let own_motion = !initial.mechanisms[a.mechanism].free.is_empty();
                let speed_ratio = attached > 1 || own_motion;
                if speed_ratio {
                    h.push(format!("{}.speed_ratio [{u}]", a.name));
                }
                (g, speed_ratio)
            });
            amplifier.push(g);
        }
        for f in &model.forces {
            h.push(format!("{}.dissipated [J]", f.name));
            if f.generator().is_some() {
                h.push(format!("{}.current [A]", f.name));
                h.push(format!("{}.power [W]", f.name));
                h.push(format!("{}.load_power [W]", f.name));
                h.push(format!("{}.harvested [J]", f.name));
            }
        }
        for e in &model.excitations {
            let u = model.excitation_unit(&e.target);
            h.push(format!("{}.value [{u}]", e.name));
            h.push(format!("{}.work [J]", e.name));
        }
        let base = model.has_base_excitation();
        if base {
            h.extend(["base.a [m/s^2]", "base.v [m/s]", "base.u [m]"].map(String::from));
            for (name, _) in attached.iter().flatten() {
                h.push(format!("{name}_abs [m]"));
                h.push(format!("{name}_dot_abs [m/s]"));
            }
        }
        h.push("beam_kinetic [J]".into());
        h.push("beam_potential [J]".into());
        for m in &model.mechanisms {
            h.push(format!("{}.kinetic [J]", m.name));
            h.push(format!("{}.potential [J]", m.name));
        }
        for name in [
            "magnetic [J]",
            "stored [J]",
            "dissipated_structure [J]",
            "beam_load_work [J]",
            "balance_error [J]",
        ] {
            h.push(name.into());
        }
        let cells = Vec::with_capacity(h.len());
        Columns {
            header: h,
            amplifier,
            attached,
            probes: vec![],
            points: 0,
            model_elements: vec![],
            base,
            cells,
        }
    }

    /// These columns and, last, `M.dissipated_model [J]` and `M.model_work [J]` of every
    /// mechanism whose model has force elements of its own (`models`, in the order of the
    /// mechanisms): the energy its dampers dissipated and the work of its constant loads,
    /// both in the energy account.
    pub fn with_model_elements(mut self, model: &HybridModel, models: &[Model]) -> Columns {
        for (k, (m, mm)) in model.mechanisms.iter().zip(models).enumerate() {
            if !mm.forces.is_empty() {
                self.header.push(format!("{}.dissipated_model [J]", m.name));
                self.header.push(format!("{}.model_work [J]", m.name));
                self.model_elements.push(k);
            }
        }
        self
    }

    /// These columns and, after the energy account, `P.w [m]` and `P.w_dot [m/s]` of every
    /// probe `P` of `model` (at a node `P.ux`, `P.ux_dot`, `P.uy`, `P.uy_dot`): a structure
    /// point read but not attached (a comparison run's bare structure read where the
    /// attachments were). Before [`Columns::with_points`].
    pub fn with_probes(mut self, model: &HybridModel, probes: &[(String, BeamPoint)]) -> Columns {
        debug_assert_eq!(self.points, 0, "probes before the output points");
        for (name, point) in probes {
            for (name, p) in readings(model, name, point) {
                self.header.push(format!("{name} [m]"));
                self.header.push(format!("{name}_dot [m/s]"));
                self.probes.push((name, p));
            }
        }
        self
    }

    /// These columns and, last, `P [m]` and `P_dot [m/s]` of every output point `P`
    /// (`[output] points`, [`crate::setup::build::output_points`]).
    pub fn with_points(mut self, points: &[(String, BeamPoint)]) -> Columns {
        for (name, p) in points {
            self.header.push(format!("{name} [m]"));
            self.header.push(format!("{name}_dot [m/s]"));
            self.probes.push((name.clone(), p.clone()));
            self.points += 1;
        }
        self
    }

    /// The header.
    pub fn header(&self) -> &[String] {
        &self.header
    }

    /// The row of `state` with stored energies `stored` (`e0`: stored energy at the start)
    /// and amplifications `amplification` (from [`amplifications`]).
    pub fn row(
        &mut self,
        model: &HybridModel,
        state: &HybridState,
        stored: &Stored,
        e0: f64,
        amplification: &[f64],
    ) -> &[f64] {
        let c = &mut self.cells;
        c.clear();
        c.push(state.t);
        for ms in &state.mechanisms {
            c.extend(&ms.q);
            c.extend(&ms.qd);
            c.push(ms.condition);
            c.push(ms.residual);
        }
        for (k, ((a, g), read)) in model
            .attachments
            .iter()
            .zip(&self.amplifier)
            .zip(&self.attached)
            .enumerate()
        {
            let wd = a.beam.value(&state.v);
            for (_, p) in read {
                c.push(p.value(&state.q));
                c.push(p.value(&state.v));
            }
            if let Some((g, speed_ratio)) = *g {
                let f = &model.forces[g];
                c.push(amplification[k]);
                if speed_ratio {
                    let speed = state.mechanisms[f.mechanism].qd[f.joint];
                    c.push(if wd != 0.0 { speed / wd } else { f64::NAN });
                }
            }
        }
        for (k, f) in model.forces.iter().enumerate() {
            let d = state.account.dissipated[k];
            c.push(d);
            if let Some(g) = f.generator() {
                let i = state.currents[k];
                c.push(i);
                c.push(g.resistance() * i * i);
                c.push(g.load_resistance * i * i);
                c.push(g.load_part(state.account.circuit_dissipated(k)));
            }
        }
        for (k, e) in model.excitations.iter().enumerate() {
            c.push(e.value(state.t));
            c.push(state.account.excitation_work[k]);
        }
        if self.base {
            let [u, v, a] = model.support_motion(state.t);
            c.extend([a, v, u]);
            let d = model.base_direction();
            for (_, p) in self.attached.iter().flatten() {
                // The supports' motion along the reading's direction (1 on a beam).
                let along = p.direction[0] * d[0] + p.direction[1] * d[1];
                c.push(p.value(&state.q) + along * u);
                c.push(p.value(&state.v) + along * v);
            }
        }
        c.push(stored.beam_kinetic);
        c.push(stored.beam_potential);
        for (k, p) in stored
            .mechanism_kinetic
            .iter()
            .zip(&stored.mechanism_potential)
        {
            c.push(*k);
            c.push(*p);
        }
        c.push(stored.magnetic);
        c.push(stored.total());
        c.push(state.account.dissipated_structure);
        c.push(state.account.beam_load_work);
        c.push(balance_error(e0, stored, &state.account));
        let (probes, points) = self.probes.split_at(self.probes.len() - self.points);
        for (_, p) in probes {
            c.push(p.value(&state.q));
            c.push(p.value(&state.v));
        }
        for &k in &self.model_elements {
            c.push(state.account.dissipated_model[k]);
            c.push(state.account.model_input_work[k]);
        }
        for (_, p) in points {
            c.push(p.value(&state.q));
            c.push(p.value(&state.v));
        }
        debug_assert_eq!(c.len(), self.header.len());
        &self.cells
    }
}

/// Per attachment, the amplification of the generator on its mechanism at `state` into
/// `out`: the kinematic influence `dq/dw` of the beam point's displacement on the
/// generator joint, free coordinates held (eq. 18, [`Integrator::amplification`]); NaN
/// without a generator (or at a singular `J_d`). A run computes it at every output row
/// whether or not the rows are written, so that writing them cannot change the run.
pub fn amplifications(
    model: &HybridModel,
    state: &HybridState,
    integrator: &mut Integrator,
    out: &mut Vec<f64>,
) {
    out.clear();
    for (k, a) in model.attachments.iter().enumerate() {
        let g = model
            .forces
            .iter()
            .find(|f| f.mechanism == a.mechanism && f.generator().is_some());
        out.push(g.map_or(f64::NAN, |f| {
            integrator
                .amplification(model, state, f.mechanism, k, f.joint)
                .unwrap_or(f64::NAN)
        }));
    }
}

/// `summary.json` of a hybrid run.
#[derive(Clone, Debug, Serialize)]
pub struct HybridSummary<'a> {
    /// The scenario file.
    pub scenario: String,
    /// The `--set` overrides applied, in command-line order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub overrides: Vec<OverrideRecord>,
    /// Its description.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub description: Option<&'a str>,
    /// Version of the code generator.
    pub generator_version: &'static str,
    /// `[integrator]` as read.
    pub integrator: &'a IntegratorSpec,
    /// A CSV row every `every` steps.
    pub every: usize,
    /// Time steps.
    pub steps: u64,
    /// CSV rows written.
    pub output_rows: u64,
    /// Wall-clock time of the integration (s).
    pub wall_seconds: f64,
    /// Steps per second of wall-clock time.
    pub steps_per_second: f64,
    /// First natural frequency of the bare beam (Hz).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub beam_first_frequency_hz: Option<f64>,
    /// The host structure (its kind, size and reduction check).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub structure: Option<super::structure::StructureReport>,
    /// Largest |displacement| of the first attachment's beam point (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peak_amplitude: Option<f64>,
    /// Equivalent damping ratio of the first mode's free decay (`decay`, when it
    /// oscillates); only for a free decay (no excitation, no beam load).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub damping_ratio: Option<f64>,
    /// The decay of the first mode (see `decay_signal`; `hybrid_core::decay`: damping per
    /// cycle, or over-/critically damped with a rate); only for a free decay.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub decay: Option<hybrid_core::decay::DecayEstimate>,
    /// What the decay is read from: the modal filter of the first linearised mode (scaled
    /// to the first attachment's beam point), or that point's displacement.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub decay_signal: Option<&'static str>,
    /// The mechanisms.
    pub mechanisms: Vec<MechanismReport>,
    /// The attachments.
    pub attachments: Vec<AttachmentReport>,
    /// Every node displacement column and output point of the time history (`pin.ux`,
    /// `741:ux`), with its peak; absent on a beam without `[output] points` (a beam
    /// attachment's `A.w` has its peak in `attachments`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub points: Vec<PointReport>,
    /// The generators.
    pub generators: Vec<GeneratorReport>,
    /// The excitations.
    pub excitations: Vec<ExcitationReport>,
    /// Under a periodic forcing (harmonic excitations with commensurate frequencies): the
    /// mean powers over the trailing settled periods, separately from the whole-run
    /// account ([`crate::report::steady_power`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub steady_power: Option<crate::report::steady_power::SteadyPower>,
    /// The energy account.
    pub energy: HybridEnergy,
    /// Largest |energy balance error| / `energy.relative_to` at the output steps.
    pub energy_balance_rel_error: f64,
    /// Changes of independent coordinates.
    pub repartitions: Vec<RepartitionReport>,
    /// Under random excitation: the realisations' seeds and the stationary RMS values and
    /// mean powers with their standard errors ([`super::random_run`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub random: Option<super::random_run::RandomRunReport>,
    /// The comparison runs (`[output] compare`), by key.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub comparisons: BTreeMap<&'static str, ComparisonReport>,
}

/// One comparison run of a hybrid scenario (every generator disconnected, or the bare
/// beam read at the attachments' beam points): the figures of its own summary.
#[derive(Clone, Debug, Serialize)]
pub struct ComparisonReport {
    /// The legend of its plotted series.
    pub label: &'static str,
    /// Equivalent damping ratio of its first mode's free decay.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub damping_ratio: Option<f64>,
    /// The decay of its first mode.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub decay: Option<hybrid_core::decay::DecayEstimate>,
    /// What the decay is read from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub decay_signal: Option<&'static str>,
    /// Largest |displacement| of the first beam point (m).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peak_amplitude: Option<f64>,
    /// The beam points read (the attachments, or for the bare beam the points where they
    /// were).
    pub attachments: Vec<AttachmentReport>,
    /// Its node displacement columns and output points with their peaks (as the run's).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub points: Vec<PointReport>,
    /// Its energy account.
    pub energy: HybridEnergy,
    /// Largest |energy balance error| / `energy.relative_to` at the output steps.
    pub energy_balance_rel_error: f64,
    /// CSV rows written.
    pub output_rows: u64,
}

impl ComparisonReport {
    /// The comparison block of a run's own summary.
    pub fn of(label: &'static str, s: HybridSummary<'_>) -> ComparisonReport {
        ComparisonReport {
            label,
            damping_ratio: s.damping_ratio,
            decay: s.decay,
            decay_signal: s.decay_signal,
            peak_amplitude: s.peak_amplitude,
            attachments: s.attachments,
            points: s.points,
            energy: s.energy,
            energy_balance_rel_error: s.energy_balance_rel_error,
            output_rows: s.output_rows,
        }
    }
}

/// One mechanism of a hybrid run.
#[derive(Clone, Debug, Serialize)]
pub struct MechanismReport {
    /// Its name.
    pub name: String,
    /// The model's name.
    pub model: String,
    /// The model file.
    pub model_file: String,
    /// FNV-1a content hash of the model file.
    pub model_hash: String,
    /// `generated` or `interpreter`.
    pub backend: &'static str,
    /// Free (independent) coordinates at the start.
    pub initial_free: Vec<String>,
    /// ... and at the end.
    pub final_free: Vec<String>,
    /// Coordinates at the start.
    pub initial_q: BTreeMap<String, f64>,
    /// Coordinates at the end.
    pub final_q: BTreeMap<String, f64>,
    /// Largest cond(J_d) at the output steps.
    pub max_condition: f64,
    /// Largest constraint residual at the output steps.
    pub max_constraint_residual: f64,
}

/// One attachment of a hybrid run.
#[derive(Clone, Debug, Serialize)]
pub struct AttachmentReport {
    /// Its name.
    pub name: String,
    /// `pin` or `roller`.
    pub kind: &'static str,
    /// Beam abscissa (m).
    pub x: f64,
    /// Largest |displacement| of the beam point (m).
    pub peak_displacement: f64,
    /// Largest |displacement| over the last tenth of the run (m): the steady-state
    /// amplitude of a forced run.
    pub final_amplitude: f64,
    /// `sqrt(sum qd_g^2 / sum w_dot^2)` over the output rows: the RMS ratio of the generator
    /// joint speed to the beam point speed (where a generator is on the mechanism; a speed
    /// ratio, not the kinematic amplification `dq/dw` of the time history).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_ratio_rms: Option<f64>,
}

/// One displacement column of a hybrid run's time history read at a node or an output
/// point: its peak.
#[derive(Clone, Debug, Serialize)]
pub struct PointReport {
    /// The column's name without its unit (`pin.ux`, `741:ux`, `w(x=0.5)`).
    pub name: String,
    /// Largest |displacement| at the output steps (m).
    pub peak_displacement: f64,
    /// Largest |displacement| over the last tenth of the run (m).
    pub final_amplitude: f64,
}

/// One generator of a hybrid run.
#[derive(Clone, Debug, Serialize)]
pub struct GeneratorReport {
    /// Its name.
    pub name: String,
    /// Its mechanism.
    pub mechanism: String,
    /// Energy dissipated in its circuit, `(R_a + R_L) i^2` integrated, and in its gear (J).
    pub dissipated: f64,
    /// Of which in the load, `R_L i^2` integrated (J).
    pub harvested_in_load: f64,
    /// Mean power into the load over the run (W).
    pub mean_load_power: f64,
    /// Largest |current| at the output steps (A).
    pub peak_current: f64,
    /// Where the energy it took from its joint went.
    pub energy_split: EnergySplit,
    /// Its parameters as run (overrides applied; a comparison run's with the circuit open).
    pub settings: hybrid_core::generator::GeneratorSpec,
}

/// The energy split of one generator over a run (J; `hybrid_core::generator`): the work it
/// took from its joint went into the armature's copper, the gear, the load and the magnetic
/// field. The rotor's kinetic energy is counted with its mechanism's.
#[derive(Clone, Debug, Serialize)]
pub struct EnergySplit {
    /// Mechanical input, `integral (n k_t i + n tau_g) q' dt`.
    pub mechanical_input: f64,
    /// Copper loss of the armature, `integral R_a i^2 dt`.
    pub copper_loss: f64,
    /// Loss in the gear, `integral tau_g w dt` (efficiency and friction).
    pub gearbox_loss: f64,
    /// Energy delivered to the load, `integral R_L i^2 dt` (= `harvested_in_load`).
    pub load_energy: f64,
    /// Change of the magnetic energy `L i^2 / 2` since the start (at rest, no current).
    pub magnetic_change: f64,
    /// Lost by unequal torque and EMF constants, `integral (k_t - k_e) i w dt` (0 for the
    /// ideal machine, `k_t = k_e` in SI; in the energy balance as a dissipation).
    pub conversion: f64,
    /// `mechanical_input - (copper_loss + gearbox_loss + load_energy + magnetic_change +
    /// conversion)`: the time integration's truncation.
    pub residual: f64,
}

/// One excitation of a hybrid run.
#[derive(Clone, Debug, Serialize)]
pub struct ExcitationReport {
    /// Its name.
    pub name: String,
    /// Work done on the system (J).
    pub work: f64,
    /// Whether it is the supports' acceleration (`at = "base"`; written only then): its
    /// work is the supports' input work, that of the inertial loads in the frame moving
    /// with them.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub supports: bool,
}

/// The energy account of a hybrid run (J).
#[derive(Clone, Debug, Serialize)]
pub struct HybridEnergy {
    /// Stored energy at the start.
    pub initial: f64,
    /// Stored energy at the end.
    pub final_stored: f64,
    /// Dissipated by the beam's Rayleigh damping.
    pub dissipated_structure: f64,
    /// Dissipated by each force element.
    pub dissipated_elements: BTreeMap<String, f64>,
    /// Dissipated by the dampers of each mechanism's own model (mechanisms whose model has
    /// force elements).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub dissipated_model: BTreeMap<String, f64>,
    /// Work of the constant loads of each mechanism's own model (the same mechanisms).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub model_work: BTreeMap<String, f64>,
    /// Work of the beam's own loads.
    pub beam_load_work: f64,
    /// Work of each excitation.
    pub excitation_work: BTreeMap<String, f64>,
    /// Largest |balance error| at the output steps.
    pub max_balance_error: f64,
    /// What the relative error is relative to.
    pub relative_to: &'static str,
    /// Its value.
    pub scale: f64,
}

/// A change of independent coordinates.
#[derive(Clone, Debug, Serialize)]
pub struct RepartitionReport {
    /// Time (s).
    pub t: f64,
    /// The mechanism.
    pub mechanism: String,
    /// Free coordinates before.
    pub from: Vec<String>,
    /// ... after.
    pub to: Vec<String>,
    /// cond(J_d) before.
    pub cond_before: f64,
    /// ... after.
    pub cond_after: f64,
}
