//! A damper or hybrid scenario as a general hybrid system with one exact tangent model per
//! mechanism ([`TangentSystem`], built from the same model file with the same run-time
//! parameters as the mechanism's system): what linearising it
//! ([`hybrid_core::hybrid::Linearization::new`]) and running it in the time domain need.

use mbs_symbolic::model::{JointKind, Model};
use mbs_symbolic::runtime::TangentSystem;

use hybrid_core::damper::Method;
use hybrid_core::hybrid::{EquilibriumOptions, HybridModel, LinearError, Linearization};

use super::hybrid::Built;
use super::{HybridScenario, Scenario};
use crate::Error;

/// A scenario built for linearisation.
#[derive(Debug)]
pub struct Linearizable {
    /// The hybrid system, the generators connected as the scenario says.
    pub model: HybridModel,
    /// One exact tangent model per mechanism (the scenario's run-time parameters set).
    pub tangents: Vec<TangentSystem>,
    /// Per mechanism, whether each coordinate is an angle (revolute) or a length.
    pub revolute: Vec<Vec<bool>>,
    /// The scenario's integration scheme.
    pub method: Method,
    /// The scenario's time step (s).
    pub dt: f64,
}

/// Loads the mechanism models of a `kind = "damper"` or `kind = "hybrid"` scenario, builds
/// the hybrid system (generated code when compiled in, the interpreter otherwise) and one
/// [`TangentSystem`] per mechanism with the same run-time parameters. A mechanism scenario
/// (no beam, nothing to linearise about a rest state here) is a usage error.
pub fn tangents_for(scenario: &Scenario) -> Result<Linearizable, Error> {
    match scenario {
        Scenario::Damper(sc) => {
            let model = mbs_symbolic::model::load(&sc.model_path)?;
            sc.check_parameters(&model)?;
            let system = model_registry::system_for(&model, None)?.system;
            // The model only (not `study::prepare`): the equilibrium does not need the
            // initial state, which may be out of the mechanism's reach where the rest
            // position is not.
            let (coupled, guess) = hybrid_core::study::build_model(&sc.setup, &model, system, true)
                .map_err(|e| Error::Input(sc.diagnostic(&e).into()))?;
            let (hybrid, _) = hybrid_core::study::hybrid_of(&sc.setup, &coupled, guess)
                .map_err(|e| Error::Input(sc.diagnostic(&e).into()))?;
            let params: Vec<(String, f64)> = sc
                .setup
                .parameters
                .iter()
                .map(|(k, v)| (k.clone(), *v))
                .collect();
            Ok(Linearizable {
                model: hybrid,
                tangents: vec![tangent(&model, &params)?],
                revolute: vec![revolute(&model)],
                method: sc.setup.method,
                dt: sc.setup.dt,
            })
        }
        Scenario::Hybrid(sc) => {
            let built = sc.build()?;
            let tangents = hybrid_tangents(sc, &built)?;
            Ok(Linearizable {
                model: built.model,
                tangents,
                revolute: built.revolute,
                method: sc.method,
                dt: sc.integrator.dt,
            })
        }
        Scenario::Mechanism(sc) => Err(Error::Usage(format!(
            "{}: a `kind = \"mechanism\"` scenario has no beam to linearise: give a `damper` or `hybrid` scenario",
            sc.file
        ))),
    }
}

/// One tangent model per mechanism of a built hybrid scenario, with the scenario's
/// run-time parameters.
pub fn hybrid_tangents(sc: &HybridScenario, built: &Built) -> Result<Vec<TangentSystem>, Error> {
    built
        .models
        .iter()
        .zip(&sc.mechanisms)
        .map(|(m, entry)| {
            let params: Vec<(String, f64)> = entry
                .parameters
                .iter()
                .map(|(k, v, _)| (k.clone(), *v))
                .collect();
            tangent(m, &params)
        })
        .collect()
}

/// The tangent model of `model` with run-time parameters `params` (already checked by the
/// loader against the same model).
fn tangent(model: &Model, params: &[(String, f64)]) -> Result<TangentSystem, Error> {
    let mut t = TangentSystem::new(model);
    for (name, value) in params {
        t.set_param(name, *value)
            .map_err(|e| Error::Usage(format!("{}: parameter {name}: {e}", model.source.path)))?;
    }
    Ok(t)
}

fn revolute(model: &Model) -> Vec<bool> {
    model
        .bodies
        .iter()
        .map(|b| b.joint.kind == JointKind::Revolute)
        .collect()
}

impl Linearizable {
    /// The tangent models as the slice [`Linearization::new`] takes.
    pub fn tangent_refs(&self) -> Vec<&TangentSystem> {
        self.tangents.iter().collect()
    }

    /// Linearises `model` (this scenario's system or a variant of it with the same
    /// mechanisms, e.g. [`disconnected`]) about its static equilibrium.
    pub fn linearize(&self, model: &HybridModel) -> Result<Linearization, LinearError> {
        Linearization::new(model, &self.tangent_refs(), EquilibriumOptions::default())
    }
}
