//! The paper's damper exactly as `scenarios/damper.toml` describes it, built without the
//! application: as a general hybrid system (the engine's [`HybridModel`] and initial
//! state) and as the rank-one oracle's [`DamperModel`] — the same beam, the same double bar
//! placed by its half-angle, the same generator on the joint of body `crank`. The fields a
//! test varies are those of [`PaperDamper`]; its [`Default`] is the bundled scenario. (The
//! oracle's side, `PaperDamper::oracle`, is in `oracle/build.rs`: the benches share this
//! module without the oracle.)
//!
//! Also the run of the engine that the damper tests read (samples of the beam point, the
//! first mode's modal coordinate, the energy account): what the application's damper run
//! reports, from the engine alone.

use std::path::Path;

use fem_beam::{Beam, BeamModel};
use hybrid_core::decay::{DecayEstimate, DecayTracker, ModalFilter};
use hybrid_core::generator::GeneratorSpec;
use hybrid_core::hybrid::{
    Attachment, AttachmentKind, BeamPoint, ForceKind, HybridError, HybridModel, HybridState,
    Integrator, JointForce, Method, Mount, MountedMechanism, Placement, RunError, RunOptions,
    initial_deflection, initial_state, input_work, place_two_bar,
};
use mbs_symbolic::runtime::System;

/// The paper's damper (`scenarios/damper.toml`) with the fields the tests vary.
#[derive(Clone, Debug)]
pub struct PaperDamper {
    /// Elements of the 1 m steel cantilever (40 x 8 mm, clamped at x = 0).
    pub elements: usize,
    /// Rayleigh damping: this ratio on modes 1 and 2 (`None`: alpha = beta = 0).
    pub rayleigh: Option<f64>,
    /// The beam point the double bar's `tip` is pinned to (m).
    pub x: f64,
    /// Half-angle of the double bar at its ground pivot (degrees; 0 = the toggle).
    pub half_angle_deg: f64,
    /// Run-time parameter overrides of the double bar (`m1`, `m2`, `L1`, `L2`, `gx`, `gy`).
    pub parameters: Vec<(&'static str, f64)>,
    /// Stop when cond(J^b) exceeds this.
    pub max_condition: f64,
    /// The generator on the joint of body `crank` (`connected = false`: circuit open).
    pub generator: GeneratorSpec,
    /// Initial displacement of the beam point (m): static shape of a load there, at rest.
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

impl Default for PaperDamper {
    /// `scenarios/damper.toml` as bundled.
    fn default() -> PaperDamper {
        PaperDamper {
            elements: 20,
            rayleigh: Some(0.002),
            x: 1.0,
            half_angle_deg: 10.0,
            parameters: vec![],
            max_condition: 1e4,
            generator: GeneratorSpec {
                kt: 0.0235,
                ke: 0.0235,
                armature_resistance: 1.5,
                load_resistance: 3.5,
                inductance: 0.0,
                gear_ratio: 5.0,
                rotor_inertia: 1e-6,
                connected: true,
                gear_efficiency: 1.0,
                gear_friction: Default::default(),
            },
            initial_displacement: 1e-3,
            method: Method::Newmark,
            dt: 1e-4,
            t_end: 5.0,
            every: 10,
        }
    }
}

/// `models/double_bar.toml`.
pub fn double_bar_file() -> String {
    format!(
        "{}/../../models/double_bar.toml",
        env!("CARGO_MANIFEST_DIR")
    )
}

/// The double bar's model description.
pub fn double_bar_model() -> mbs_symbolic::model::Model {
    mbs_symbolic::model::load(Path::new(&double_bar_file())).unwrap_or_else(|e| panic!("{e}"))
}

/// The double bar's generated code (model registry).
pub fn double_bar() -> Box<dyn System> {
    model_registry::find_by_name("double_bar")
        .expect("models/double_bar.toml is compiled in")
        .system()
}

/// How the damper is placed (scenario `[mechanism]`), the same for the engine and the
/// oracle.
pub struct Geometry {
    /// The beam point at `x`.
    pub point: BeamPoint,
    /// The double bar's point `tip`.
    pub tip: usize,
    /// The joint of body `crank` (the generator's).
    pub joint: usize,
    /// `tip` relative to the ground pivot at the half-angle, `[x0, y0]` (m).
    pub target: [f64; 2],
    /// Initial guess of the double bar's coordinates.
    pub guess: [f64; 2],
    /// How far the beam point can move towards the toggle (m).
    pub reach: f64,
}

impl PaperDamper {
    /// The scenario's `[beam]`.
    pub fn beam(&self) -> BeamModel {
        let mut text = format!(
            "name = \"damper cantilever\"\n[[segment]]\nlength = 1.0\nyoungs_modulus = 210e9\n\
             density = 7850.0\nwidth = 0.040\nheight = 0.008\nelements = {}\n\
             [[support]]\nx = 0.0\nkind = \"clamped\"\n[damping]\n",
            self.elements
        );
        text += &match self.rayleigh {
            Some(z) => {
                format!("ratios = [{{ mode = 1, ratio = {z} }}, {{ mode = 2, ratio = {z} }}]\n")
            }
            None => "alpha = 0.0\nbeta = 0.0\n".into(),
        };
        let beam = Beam::from_toml_str(&text, "damper_beam.toml").unwrap_or_else(|e| panic!("{e}"));
        BeamModel::new(&beam).unwrap_or_else(|e| panic!("{e}"))
    }

    /// `system` (a double bar) with the run-time parameter overrides set.
    pub fn with_parameters<M: System>(&self, mut system: M) -> M {
        for &(name, value) in &self.parameters {
            system
                .set_param(name, value)
                .unwrap_or_else(|e| panic!("{e}"));
        }
        system
    }

    /// Where the double bar `system` goes on `beam`.
    pub fn geometry<M: System + ?Sized>(&self, beam: &BeamModel, system: &M) -> Geometry {
        let point = BeamPoint::on(beam, self.x).expect("the beam point is on the beam");
        assert!(!point.is_locked(), "a support locks x = {}", self.x);
        let tip = system
            .point_index("tip")
            .expect("the double bar's point tip");
        let joint = double_bar_model()
            .body_index("crank")
            .expect("the double bar's body crank");
        let placed = place_two_bar(system, tip, Placement::HalfAngle(self.half_angle_deg))
            .unwrap_or_else(|e| panic!("{e}"));
        Geometry {
            point,
            tip,
            joint,
            target: placed.target,
            guess: placed.guess,
            reach: placed.reach,
        }
    }

    /// The damper on the general engine with the generated double bar, and the beam's
    /// initial deflection.
    pub fn hybrid(&self) -> (HybridModel, Vec<f64>) {
        self.hybrid_with(double_bar())
    }

    /// The damper on the general engine with `system` as its double bar: mounted with its
    /// pivot at `(x - x0, -y0)` in the beam frame (axes aligned), its `tip` pinned to the
    /// beam point (eqs. 45–46), the generator on the crank's joint; and the beam's initial
    /// deflection (the static shape of a load at the beam point).
    pub fn hybrid_with(&self, system: Box<dyn System>) -> (HybridModel, Vec<f64>) {
        let system = self.with_parameters(system);
        let beam = self.beam();
        let g = self.geometry(&beam, system.as_ref());
        let q0 = initial_deflection(&beam, &g.point, self.initial_displacement)
            .unwrap_or_else(|e| panic!("{e}"));
        let mechanism = MountedMechanism {
            name: "damper".into(),
            system,
            mount: Mount {
                origin: [self.x - g.target[0], -g.target[1]],
                angle: 0.0,
            },
            max_condition: self.max_condition,
            reach: Some(g.reach),
            initial_q: g.guess.to_vec(),
        };
        let model = HybridModel::new(
            Some(beam.into()),
            vec![mechanism],
            vec![Attachment {
                name: "tip".into(),
                mechanism: 0,
                point: g.tip,
                kind: AttachmentKind::Pin,
                beam: g.point,
            }],
            vec![JointForce {
                name: "generator".into(),
                mechanism: 0,
                joint: g.joint,
                kind: ForceKind::Generator(self.generator.clone()),
            }],
            vec![],
        )
        .unwrap_or_else(|e| panic!("{e}"));
        (model, q0)
    }

    /// The engine's model, its initial state (at rest) and integrator.
    pub fn engine(&self) -> Result<(HybridModel, HybridState, Integrator), HybridError> {
        let (model, q0) = self.hybrid();
        let n = q0.len();
        let state = initial_state(&model, q0, vec![0.0; n])?;
        let integrator = Integrator::new(&model, self.method, self.dt, &state)?;
        Ok((model, state, integrator))
    }

    /// Runs the damper on the engine with the generated double bar ([`DamperRun`]).
    pub fn run(&self) -> Result<DamperRun, HybridError> {
        self.run_with(double_bar())
    }

    /// Runs the damper on the engine with `system` as its double bar, from its initial
    /// state to `t_end`, a sample at t = 0, every `every` steps and at the end; the
    /// samples' signal is the first linearised mode's modal coordinate (when the damper can
    /// be linearised; else the beam point's displacement).
    pub fn run_with(&self, system: Box<dyn System>) -> Result<DamperRun, HybridError> {
        let (model, q0) = self.hybrid_with(system);
        let n = q0.len();
        let state = initial_state(&model, q0, vec![0.0; n])?;
        let mut integrator = Integrator::new(&model, self.method, self.dt, &state)?;
        let point = model.attachments[0].beam.clone();
        let tangents = super::tangents(&model, &self.parameters);
        let refs: Vec<_> = tangents.iter().collect();
        let filter = ModalFilter::first_mode(&model, &refs, &point)
            .ok()
            .map(|(f, _)| f);
        let mut samples = vec![];
        let outcome = hybrid_core::hybrid::run::<()>(
            &model,
            &mut integrator,
            state,
            RunOptions {
                t_end: self.t_end,
                every: self.every,
            },
            &mut |s, stored, _| {
                let tip_displacement = point.value(&s.q);
                samples.push(Sample {
                    t: s.t,
                    tip_displacement,
                    crank_rate: s.mechanisms[0].qd[0],
                    total_energy: stored.total(),
                    signal: filter
                        .as_ref()
                        .map_or(tip_displacement, |f| f.apply_state(&s.q, &s.v, &s.currents)),
                });
                Ok(())
            },
            &mut |_| {},
        )
        .map_err(|e| match e {
            RunError::Hybrid(e) => e,
            RunError::Sink(()) => unreachable!("the sink keeps every row"),
        })?;
        let (stored, state) = (&outcome.stored, outcome.state);
        let acc = &state.account;
        let g = &self.generator;
        let (armature, load) = if g.resistance() > 0.0 {
            (
                acc.dissipated[0] * g.armature_resistance / g.resistance(),
                acc.dissipated[0] * g.load_resistance / g.resistance(),
            )
        } else {
            (0.0, 0.0)
        };
        let energy = Energy {
            beam_kinetic: stored.beam_kinetic,
            beam_potential: stored.beam_potential,
            mechanism_kinetic: stored.mechanism_kinetic[0],
            mechanism_potential: stored.mechanism_potential[0],
            magnetic: stored.magnetic,
            dissipated_structure: acc.dissipated_structure,
            dissipated_armature: armature,
            dissipated_load: load,
            external_work: input_work(acc),
        };
        Ok(DamperRun {
            samples,
            energy,
            initial_energy: outcome.figures.initial_energy,
            energy_balance_rel_error: outcome.figures.balance_rel_error,
            state,
        })
    }
}

/// Stored energies and the energy account at the end of a damper run (J).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energy {
    /// `v^T A v / 2`.
    pub beam_kinetic: f64,
    /// `q^T C q / 2`.
    pub beam_potential: f64,
    /// Mechanism and rotor kinetic energy.
    pub mechanism_kinetic: f64,
    /// Mechanism potential energy (gravity, springs).
    pub mechanism_potential: f64,
    /// `L i^2 / 2`.
    pub magnetic: f64,
    /// Dissipated by the beam's Rayleigh damping.
    pub dissipated_structure: f64,
    /// Dissipated in the armature, `integral R_a i^2 dt`.
    pub dissipated_armature: f64,
    /// Dissipated (harvested) in the load, `integral R_L i^2 dt`.
    pub dissipated_load: f64,
    /// Work of the beam loads and excitations.
    pub external_work: f64,
}

impl Energy {
    /// Stored energy.
    pub fn total(&self) -> f64 {
        self.beam_kinetic
            + self.beam_potential
            + self.mechanism_kinetic
            + self.mechanism_potential
            + self.magnetic
    }

    /// Energy dissipated so far (structure + generator).
    pub fn dissipated(&self) -> f64 {
        self.dissipated_structure + self.dissipated_armature + self.dissipated_load
    }
}

/// One sample of a damper run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Time (s).
    pub t: f64,
    /// Beam point displacement (m).
    pub tip_displacement: f64,
    /// Crank rate q1' (rad/s).
    pub crank_rate: f64,
    /// Stored energy (J).
    pub total_energy: f64,
    /// The first mode's modal coordinate, else the beam point displacement.
    pub signal: f64,
}

/// A damper run on the engine ([`PaperDamper::run`]).
#[derive(Clone, Debug)]
pub struct DamperRun {
    /// Rows every `every` steps (and the last state).
    pub samples: Vec<Sample>,
    /// Stored energies and the energy account at the end (the generator's dissipation
    /// split between armature and load).
    pub energy: Energy,
    /// Stored energy at t = 0.
    pub initial_energy: f64,
    /// Largest |energy balance error| / energy scale over the output rows.
    pub energy_balance_rel_error: f64,
    /// The final state.
    pub state: HybridState,
}

/// How the free decay of the samples' signal decays (the one estimator).
pub fn decay(samples: &[Sample]) -> DecayEstimate {
    let mut d = DecayTracker::default();
    samples.iter().for_each(|s| d.push(s.t, s.signal));
    d.estimate()
}

/// Equivalent viscous damping ratio of the first mode from the free decay ([`decay`]).
pub fn damping_ratio(samples: &[Sample]) -> Option<f64> {
    decay(samples).zeta()
}
