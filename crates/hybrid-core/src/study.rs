//! Running a damper: building the coupled model from a checked [`DamperSetup`] (the pin of
//! eqs. 45–54 placed on the beam), integrating it with samples for the outputs, and the figures of merit (peak amplitude, equivalent
//! damping ratio of the first mode from the free decay, energy account).

use std::collections::BTreeMap;
use std::ops::ControlFlow;
use std::time::Duration;

use fem_beam::{Beam, BeamError};
use mbs_symbolic::model::Model;
use mbs_symbolic::runtime::{ParamError, System};
use serde::Serialize;

use crate::coupling::{Attachment, LinkShapeError, MechanismLink};
use crate::damper::{DamperModel, Energy, Method};
use crate::generator::GeneratorSpec;
// The placement is the engine's (re-exported here for the damper setups).
use crate::hybrid::{
    HybridError, HybridModel, HybridState, Integrator as HybridIntegrator,
    RunError as HybridRunError, RunOptions, Stored, balance_error, input_work,
};
pub use crate::hybrid::{Placement, PlacementError, TwoBar, initial_deflection, place_two_bar};

/// Everything a damper run needs, already checked (the scenario loader of the CLI builds it
/// from a scenario file).
#[derive(Clone, Debug)]
pub struct DamperSetup {
    /// The validated beam.
    pub beam: Beam,
    /// Run-time parameter overrides of the mechanism.
    pub parameters: BTreeMap<String, f64>,
    /// The mechanism point pinned to the beam.
    pub point: String,
    /// The beam point: x coordinate along the beam (m).
    pub x: f64,
    /// The ground pivot.
    pub placement: Placement,
    /// Body whose joint carries the generator.
    pub generator_joint: String,
    /// Stop when cond(J^b) exceeds this.
    pub max_condition: f64,
    /// The generator.
    pub generator: GeneratorSpec,
    /// Initial displacement of the beam point (m), static shape of a point load there.
    pub initial_displacement: f64,
    /// The integration scheme.
    pub method: Method,
    /// Time step (s).
    pub dt: f64,
    /// End time (s).
    pub t_end: f64,
    /// A sample every `every` steps.
    pub every: usize,
}

/// The part of a [`DamperSetup`] a [`SetupError`] is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetupField {
    /// [`DamperSetup::beam`].
    Beam,
    /// [`DamperSetup::parameters`].
    Parameters,
    /// [`DamperSetup::point`].
    Point,
    /// [`DamperSetup::x`].
    X,
    /// [`Placement::HalfAngle`].
    HalfAngle,
    /// [`Placement::Pivot`].
    Pivot,
    /// [`DamperSetup::generator_joint`].
    GeneratorJoint,
    /// The mechanism model itself.
    Model,
}

/// A setup that does not fit its mechanism model or its beam.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// A parameter override that is not a run-time parameter.
    #[error("{name:?} is not a run-time parameter of the model (run-time parameters: {known})")]
    UnknownParameter {
        /// The parameter.
        name: String,
        /// The run-time parameters, comma-separated.
        known: String,
    },
    /// No such point in the model.
    #[error("no point {name:?} in the model (points: {known})")]
    UnknownPoint {
        /// The point.
        name: String,
        /// The model's points, comma-separated.
        known: String,
    },
    /// No such body in the model.
    #[error("no body {0:?} in the model")]
    UnknownBody(String),
    /// The double bar cannot be placed for the beam point.
    #[error("{0}")]
    Placement(PlacementError),
    /// The beam's finite-element model could not be built.
    #[error("{0}")]
    Beam(BeamError),
    /// The beam point is not on the beam.
    #[error("{0}")]
    BeamPoint(BeamError),
    /// A support locks the beam point.
    #[error("the beam cannot move transversely at x = {0} (a support locks it)")]
    Locked(f64),
    /// The mechanism model cannot be the damper's (wrong number of coordinates, ...).
    #[error("{file}: {error}")]
    Shape {
        /// The model file.
        file: String,
        /// What is wrong.
        error: LinkShapeError,
    },
    /// A run-time parameter value was refused.
    #[error("{0}")]
    Parameter(ParamError),
}

impl SetupError {
    /// The part of the setup the error is about.
    pub fn field(&self) -> SetupField {
        match self {
            SetupError::UnknownParameter { .. } | SetupError::Parameter(_) => {
                SetupField::Parameters
            }
            SetupError::Shape { .. } => SetupField::Model,
            SetupError::UnknownPoint { .. }
            | SetupError::Placement(PlacementError::NotTwoBar { .. }) => SetupField::Point,
            SetupError::UnknownBody(_) => SetupField::GeneratorJoint,
            SetupError::Placement(PlacementError::AngleUnreachable { .. }) => SetupField::HalfAngle,
            SetupError::Placement(PlacementError::PivotUnreachable { .. }) => SetupField::Pivot,
            SetupError::Beam(_) => SetupField::Beam,
            SetupError::BeamPoint(_) | SetupError::Locked(_) => SetupField::X,
        }
    }
}

/// The coupled model of a setup and the initial guess of the mechanism coordinates;
/// `model` is the mechanism's description (for its body names).
pub fn build_model<M: System>(
    setup: &DamperSetup,
    model: &Model,
    mut mechanism: M,
    connected: bool,
) -> Result<(DamperModel<M>, [f64; 2]), SetupError> {
    let (dof, rows) = (mechanism.dof(), mechanism.rows());
    if dof != 2 || rows != 0 {
        return Err(SetupError::Shape {
            file: model.source.path.clone(),
            error: LinkShapeError::Shape { dof, rows },
        });
    }
    for (name, value) in &setup.parameters {
        match mechanism.set_param(name, *value) {
            Ok(()) => {}
            Err(ParamError::Unknown { .. }) => {
                let known = mechanism.param_names().join(", ");
                return Err(SetupError::UnknownParameter {
                    name: name.clone(),
                    known,
                });
            }
            Err(e) => return Err(SetupError::Parameter(e)),
        }
    }
    let point = mechanism
        .point_names()
        .iter()
        .position(|p| *p == setup.point)
        .ok_or_else(|| SetupError::UnknownPoint {
            name: setup.point.clone(),
            known: mechanism.point_names().join(", "),
        })?;
    let generator_joint = model
        .body_index(&setup.generator_joint)
        .ok_or_else(|| SetupError::UnknownBody(setup.generator_joint.clone()))?;
    let TwoBar {
        target: [x0, y0],
        guess,
        reach,
    } = place_two_bar(&mechanism, point, setup.placement).map_err(SetupError::Placement)?;

    let beam = fem_beam::BeamModel::new(&setup.beam).map_err(SetupError::Beam)?;
    let coupling = coupling_at(&beam, setup.x)?;
    let mut generator = setup.generator.clone();
    generator.connected = generator.connected && connected;
    let mut link = MechanismLink::new(
        mechanism,
        Attachment { point, x0, y0 },
        generator_joint,
        setup.max_condition,
    )
    .map_err(|error| SetupError::Shape {
        file: model.source.path.clone(),
        error,
    })?;
    link.reach = Some(reach);
    Ok((
        DamperModel {
            beam,
            link,
            generator,
            coupling,
        },
        guess,
    ))
}

/// The transverse displacement weights `(reduced DOF, weight)` of the beam point at `x`
/// (eq. 35; zero weights left out).
fn coupling_at(beam: &fem_beam::BeamModel, x: f64) -> Result<Vec<(usize, f64)>, SetupError> {
    let shape = beam.shape_at(x).map_err(SetupError::BeamPoint)?;
    let coupling: Vec<(usize, f64)> = (0..4)
        .filter_map(|k| shape.dofs[k].map(|i| (i, shape.weights[0][k])))
        .filter(|&(_, w)| w != 0.0)
        .collect();
    if coupling.is_empty() {
        return Err(SetupError::Locked(x));
    }
    Ok(coupling)
}

/// One output row.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Sample {
    /// Time (s).
    pub t: f64,
    /// Beam point displacement (m).
    pub tip_displacement: f64,
    /// Beam point velocity (m/s).
    pub tip_velocity: f64,
    /// Crank angle q1 (rad).
    pub crank_angle: f64,
    /// Coupler angle q2 relative to the crank (rad).
    pub coupler_angle: f64,
    /// Crank rate q1' (rad/s).
    pub crank_rate: f64,
    /// Coupler rate q2' (rad/s).
    pub coupler_rate: f64,
    /// Velocity amplification q1'/y' = g_1 (rad/m).
    pub amplification: f64,
    /// Generator current (A).
    pub current: f64,
    /// Electrical power (R_a + R_L) i^2 (W).
    pub generator_power: f64,
    /// Power in the load R_L i^2 (W).
    pub load_power: f64,
    /// Beam kinetic energy (J).
    pub beam_kinetic_energy: f64,
    /// Beam strain energy (J).
    pub beam_potential_energy: f64,
    /// Mechanism + rotor kinetic energy (J).
    pub mechanism_kinetic_energy: f64,
    /// Mechanism potential energy (gravity, springs) (J).
    pub mechanism_potential_energy: f64,
    /// Stored energy (J).
    pub total_energy: f64,
    /// Energy dissipated by the structure (J).
    pub dissipated_structure: f64,
    /// Energy dissipated in the generator circuit (J).
    pub dissipated_generator: f64,
    /// `(E0 + W) - (E + D)` (J).
    pub energy_balance_error: f64,
    /// Constraint residual |h| (m).
    pub constraint_residual: f64,
    /// cond(J^b).
    pub jacobian_condition: f64,
    /// The signal the damping estimate reads: the modal coordinate of the run's
    /// [`Probe::filter`] (m, for a shape scaled to 1 at the beam point), else the beam point
    /// displacement.
    pub signal: f64,
}

impl Sample {
    /// The row of a damper's hybrid state (mechanism 0 and force element 0, the generator,
    /// when there are any: the bare beam has none, and its mechanism columns are 0 and its
    /// amplification NaN) read at the probe's beam point; stored energies in `stored`,
    /// initial energy `e0`.
    fn of(
        model: &HybridModel,
        integrator: &mut HybridIntegrator,
        s: &HybridState,
        stored: &Stored,
        e0: f64,
        probe: &Probe<'_>,
    ) -> Sample {
        let point = probe.point;
        let acc = &s.account;
        let tip_displacement = point.value(&s.q);
        let mut sample = Sample {
            t: s.t,
            tip_displacement,
            tip_velocity: point.value(&s.v),
            amplification: f64::NAN,
            beam_kinetic_energy: stored.beam_kinetic,
            beam_potential_energy: stored.beam_potential,
            total_energy: stored.total(),
            dissipated_structure: acc.dissipated_structure,
            energy_balance_error: balance_error(e0, stored, acc),
            signal: probe
                .filter
                .map_or(tip_displacement, |f| f.apply_state(&s.q, &s.v, &s.currents)),
            ..Sample::default()
        };
        if let (Some(m), Some(force)) = (s.mechanisms.first(), model.forces.first()) {
            let g = force
                .generator()
                .expect("the damper's force element is its generator");
            let i = s.currents[0];
            sample.crank_angle = m.q[0];
            sample.coupler_angle = m.q[1];
            sample.crank_rate = m.qd[0];
            sample.coupler_rate = m.qd[1];
            sample.amplification = integrator
                .amplification(model, s, 0, 0, force.joint)
                .unwrap_or(f64::NAN);
            sample.current = i;
            sample.generator_power = g.resistance() * i * i;
            sample.load_power = g.load_resistance * i * i;
            sample.mechanism_kinetic_energy = stored.mechanism_kinetic[0];
            sample.mechanism_potential_energy = stored.mechanism_potential[0];
            sample.dissipated_generator = acc.dissipated[0];
            sample.constraint_residual = m.residual;
            sample.jacobian_condition = m.condition;
        }
        sample
    }
}

/// Where a damper run is read: the beam point of its samples and, optionally, the modal
/// filter whose coordinate is the samples' [`Sample::signal`] (the damping estimate's
/// input; without one, the beam point displacement).
#[derive(Clone, Copy, Debug)]
pub struct Probe<'a> {
    /// The beam point (the damper's attachment point).
    pub point: &'a crate::hybrid::BeamPoint,
    /// The modal filter of the first mode, if any.
    pub filter: Option<&'a crate::decay::ModalFilter>,
}

/// The end of a run: the final hybrid state and its energy account.
#[derive(Clone, Debug, PartialEq)]
pub struct RunEnd {
    /// Steps taken.
    pub steps: u64,
    /// Stored energies and the account at the end.
    pub energy: Energy,
    /// The final state of the general hybrid system.
    pub hybrid: HybridState,
}

/// The outcome of one run.
#[derive(Clone, Debug)]
pub struct Run {
    /// Rows every `every` steps (and the last state).
    pub samples: Vec<Sample>,
    /// The final state.
    pub state: RunEnd,
    /// Stored energy at t = 0.
    pub initial_energy: f64,
    /// Largest |energy balance error| / initial energy over the output rows.
    pub energy_balance_rel_error: f64,
    /// Wall-clock time of the integration.
    pub wall: Duration,
}

/// The figures of a finished run, without its samples.
#[derive(Clone, Debug, PartialEq)]
pub struct Figures {
    /// The final state.
    pub state: RunEnd,
    /// Stored energy at t = 0.
    pub initial_energy: f64,
    /// Largest |energy balance error| / initial energy over the output rows.
    pub energy_balance_rel_error: f64,
    /// Wall-clock time of the integration.
    pub wall: Duration,
}

/// Integrates the damper's hybrid `model` from `state` to `t_end` with the integrator's
/// step, handing a [`Sample`] to `sink` at t = 0, every `every` steps and at the end (stored
/// energies are evaluated at those rows only); `sink` may stop the run
/// ([`ControlFlow::Break`], then [`RunError::Stopped`]). `progress` receives the fraction
/// done from time to time. Nothing is kept per sample: memory does not grow with `t_end`.
#[allow(clippy::too_many_arguments)]
pub fn run_streaming(
    model: &HybridModel,
    integrator: &mut HybridIntegrator,
    state: HybridState,
    probe: Probe<'_>,
    t_end: f64,
    every: usize,
    progress: &mut dyn FnMut(f64),
    sink: &mut dyn FnMut(&Sample) -> ControlFlow<()>,
) -> Result<Figures, RunError> {
    let mut e0 = None;
    let outcome = crate::hybrid::run(
        model,
        integrator,
        state,
        RunOptions { t_end, every },
        &mut |s, stored, integrator| {
            let e0 = *e0.get_or_insert(stored.total());
            match sink(&Sample::of(model, integrator, s, stored, e0, &probe)) {
                ControlFlow::Continue(()) => Ok(()),
                ControlFlow::Break(()) => Err(()),
            }
        },
        progress,
    )
    .map_err(|e| match e {
        HybridRunError::Hybrid(e) => RunError::Sim(e),
        HybridRunError::Sink(()) => RunError::Stopped,
    })?;
    let (stored, state) = (&outcome.stored, outcome.state);
    let acc = &state.account;
    // The generator's dissipation split between armature and load (none on a bare beam).
    let (armature, load) = match model.forces.first().and_then(|f| f.generator()) {
        Some(g) if g.resistance() > 0.0 => (
            acc.dissipated[0] * g.armature_resistance / g.resistance(),
            acc.dissipated[0] * g.load_resistance / g.resistance(),
        ),
        _ => (0.0, 0.0),
    };
    let energy = Energy {
        beam_kinetic: stored.beam_kinetic,
        beam_potential: stored.beam_potential,
        mechanism_kinetic: stored.mechanism_kinetic.first().copied().unwrap_or(0.0),
        mechanism_potential: stored.mechanism_potential.first().copied().unwrap_or(0.0),
        magnetic: stored.magnetic,
        dissipated_structure: acc.dissipated_structure,
        dissipated_armature: armature,
        dissipated_load: load,
        external_work: input_work(acc),
    };
    let f = &outcome.figures;
    Ok(Figures {
        initial_energy: f.initial_energy,
        energy_balance_rel_error: f.balance_rel_error,
        wall: f.wall,
        state: RunEnd {
            steps: state.steps,
            energy,
            hybrid: state,
        },
    })
}

/// [`run_streaming`] keeping every sample.
pub fn run(
    model: &HybridModel,
    integrator: &mut HybridIntegrator,
    state: HybridState,
    probe: Probe<'_>,
    t_end: f64,
    every: usize,
    progress: &mut dyn FnMut(f64),
) -> Result<Run, RunError> {
    let steps = (t_end / integrator.step_size()).round() as usize;
    let mut samples = Vec::with_capacity(steps / every.max(1) + 2);
    let f = run_streaming(
        model,
        integrator,
        state,
        probe,
        t_end,
        every,
        progress,
        &mut |s| {
            samples.push(*s);
            ControlFlow::Continue(())
        },
    )?;
    Ok(Run {
        samples,
        state: f.state,
        initial_energy: f.initial_energy,
        energy_balance_rel_error: f.energy_balance_rel_error,
        wall: f.wall,
    })
}

/// How the free decay of `samples` decays ([`crate::decay::estimate`], the one estimator)
/// of their [`Sample::signal`]: the tip displacement, or the modal coordinate when the run
/// had a [`Probe::filter`].
pub fn decay(samples: &[Sample]) -> crate::decay::DecayEstimate {
    let mut d = crate::decay::DecayTracker::default();
    samples.iter().for_each(|s| d.push(s.t, s.signal));
    d.estimate()
}

/// Equivalent viscous damping ratio of the dominant mode from the free decay of the tip
/// ([`decay`]): `None` when the decay is not oscillatory (the estimate then says what it
/// is: over- or critically damped, a rate under one cycle, or no decay).
pub fn damping_ratio(samples: &[Sample]) -> Option<f64> {
    decay(samples).zeta()
}

/// A damper setup ready to run on the general hybrid engine ([`crate::hybrid`]; the damper
/// is its rank-one special case).
pub struct Prepared<M> {
    /// The specialised model (geometry, beam).
    pub coupled: DamperModel<M>,
    /// The same damper as a hybrid system.
    pub hybrid: HybridModel,
    /// The integrator.
    pub integrator: HybridIntegrator,
    /// The initial state.
    pub state: HybridState,
    /// The beam point the damper is pinned to.
    pub point: crate::hybrid::BeamPoint,
    /// The modal filter of the first linearised mode ([`first_mode_filter`]) through which
    /// the run's damping is read, or why there is none (then the beam point's displacement
    /// is read).
    pub filter: Result<crate::decay::ModalFilter, crate::decay::FirstModeError>,
}

/// Builds the model, integrator and initial state of a setup, and the modal filter of its
/// first linearised mode.
pub fn prepare<M: System>(
    setup: &DamperSetup,
    model: &Model,
    mechanism: M,
    connected: bool,
) -> Result<Prepared<M>, RunError> {
    let (coupled, guess) = build_model(setup, model, mechanism, connected)?;
    let (hybrid, q0) = hybrid_of(setup, &coupled, guess)?;
    let n = q0.len();
    let state = crate::hybrid::initial_state(&hybrid, q0, vec![0.0; n])?;
    let integrator = HybridIntegrator::new(&hybrid, setup.method, setup.dt, &state)?;
    let point = hybrid.attachments[0].beam.clone();
    let filter = first_mode_filter(setup, model, &hybrid, &point);
    Ok(Prepared {
        coupled,
        hybrid,
        integrator,
        state,
        point,
        filter,
    })
}

/// The bare beam of a setup ready to run: the same beam, initial deflection and integrator
/// without the mechanism (a hybrid model with a beam and no mechanism), read at the same
/// beam point — the baseline "bare beam (no mechanism)" of the comparison runs.
pub struct BareBeam {
    /// The beam alone as a hybrid system.
    pub hybrid: HybridModel,
    /// The integrator.
    pub integrator: HybridIntegrator,
    /// The initial state.
    pub state: HybridState,
    /// The damper's beam point.
    pub point: crate::hybrid::BeamPoint,
}

/// Builds the bare beam of a setup ([`BareBeam`]).
pub fn prepare_bare_beam(setup: &DamperSetup) -> Result<BareBeam, RunError> {
    let beam = fem_beam::BeamModel::new(&setup.beam).map_err(SetupError::Beam)?;
    let point = crate::hybrid::BeamPoint {
        x: setup.x,
        weights: coupling_at(&beam, setup.x)?,
    };
    let q0 =
        initial_deflection(&beam, &point, setup.initial_displacement).map_err(SetupError::Beam)?;
    let n = q0.len();
    let hybrid = HybridModel::new(Some(beam), vec![], vec![], vec![], vec![])
        .expect("a beam alone is a valid hybrid model");
    let state = crate::hybrid::initial_state(&hybrid, q0, vec![0.0; n])?;
    let integrator = HybridIntegrator::new(&hybrid, setup.method, setup.dt, &state)?;
    Ok(BareBeam {
        hybrid,
        integrator,
        state,
        point,
    })
}

/// The modal filter of the first linearised mode of a prepared damper (the double bar's
/// exact tangents from `model` with the setup's parameters;
/// [`crate::decay::ModalFilter::first_mode`]), to read the first mode's decay free of the
/// others. `Err` with the reason when the damper cannot be linearised.
pub fn first_mode_filter(
    setup: &DamperSetup,
    model: &Model,
    hybrid: &HybridModel,
    point: &crate::hybrid::BeamPoint,
) -> Result<crate::decay::ModalFilter, crate::decay::FirstModeError> {
    let mut tangent = mbs_symbolic::runtime::TangentSystem::new(model);
    for (name, value) in &setup.parameters {
        tangent.set_param(name, *value)?;
    }
    crate::decay::ModalFilter::first_mode(hybrid, &[&tangent], point).map(|(f, _)| f)
}

/// Prepares a setup and runs it, keeping every sample.
pub fn run_setup<M: System>(
    setup: &DamperSetup,
    model: &Model,
    mechanism: M,
    connected: bool,
    progress: &mut dyn FnMut(f64),
) -> Result<(DamperModel<M>, Run), RunError> {
    let mut p = prepare(setup, model, mechanism, connected)?;
    let probe = Probe {
        point: &p.point,
        filter: p.filter.as_ref().ok(),
    };
    let run = run(
        &p.hybrid,
        &mut p.integrator,
        p.state,
        probe,
        setup.t_end,
        setup.every,
        progress,
    )?;
    Ok((p.coupled, run))
}

/// A setup that could not be built or run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The setup does not fit the model or the beam.
    #[error(transparent)]
    Setup(#[from] SetupError),
    /// The simulation stopped.
    #[error(transparent)]
    Sim(#[from] HybridError),
    /// The sample sink asked to stop.
    #[error("stopped by the output")]
    Stopped,
}

/// The damper of a setup as a general [`crate::hybrid::HybridModel`]: the double bar
/// mounted with its pivot at `(x - x0, -y0)` in the beam frame (axes aligned), its point
/// pinned to the beam point at `x` (eqs. 45–46), the generator on its joint; and the beam's
/// initial deflection (the static shape of a load at the beam point scaled to the setup's
/// initial displacement).
pub fn hybrid_of<M: System>(
    setup: &DamperSetup,
    coupled: &DamperModel<M>,
    guess: [f64; 2],
) -> Result<(crate::hybrid::HybridModel, Vec<f64>), SetupError> {
    use crate::hybrid::{
        Attachment as Pin, AttachmentKind, BeamPoint, ForceKind, HybridModel, JointForce, Mount,
        MountedMechanism,
    };
    let link = &coupled.link;
    let beam = coupled.beam.clone();
    let point = BeamPoint {
        x: setup.x,
        weights: coupled.coupling.clone(),
    };
    let q0 =
        initial_deflection(&beam, &point, setup.initial_displacement).map_err(SetupError::Beam)?;
    let mechanism = MountedMechanism {
        name: "damper".into(),
        system: link.mechanism.clone_box(),
        mount: Mount {
            origin: [setup.x - link.attachment.x0, -link.attachment.y0],
            angle: 0.0,
        },
        max_condition: link.max_condition,
        reach: link.reach,
        initial_q: guess.to_vec(),
    };
    let model = HybridModel::new(
        Some(beam),
        vec![mechanism],
        vec![Pin {
            name: "tip".into(),
            mechanism: 0,
            point: link.attachment.point,
            kind: AttachmentKind::Pin,
            beam: point,
        }],
        vec![JointForce {
            name: "generator".into(),
            mechanism: 0,
            joint: link.generator_joint,
            kind: ForceKind::Generator(coupled.generator.clone()),
        }],
        vec![],
    )
    .expect("a checked damper setup is a valid hybrid model");
    Ok((model, q0))
}
