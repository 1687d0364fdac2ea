//! A damper or hybrid scenario as a general hybrid system with one exact tangent model per
//! mechanism ([`TangentSystem`], built from the same model file with the same run-time
//! parameters as the mechanism's system): what linearising it
//! ([`hybrid_core::hybrid::Linearization::new`]) and running it in the time domain need.

use std::collections::BTreeMap;
use std::sync::{Mutex, OnceLock};

use mbs_symbolic::model::Model;
use mbs_symbolic::runtime::TangentSystem;

use hybrid_core::hybrid::Method;
use hybrid_core::hybrid::{EquilibriumOptions, HybridModel, LinearError, Linearization};

use crate::Error;
use crate::analysis::AnalysisError;
use crate::scenario::{HybridScenario, Scenario};

/// A scenario built for linearisation.
#[derive(Debug)]
pub struct Linearizable {
    /// The hybrid system, the generators connected as the scenario says.
    pub model: HybridModel,
    /// One exact tangent model per mechanism (the scenario's run-time parameters set).
    pub tangents: Vec<TangentSystem>,
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
        Scenario::Hybrid(sc) => {
            // The model only: the equilibrium does not need the initial state, which may be
            // out of the mechanism's reach where the rest position is not.
            let (model, models) = super::build_model(sc)?;
            let tangents = hybrid_tangents(sc, &models)?;
            Ok(Linearizable {
                model,
                tangents,
                method: sc.method,
                dt: sc.integrator.dt,
            })
        }
        Scenario::Mechanism(sc) => Err(AnalysisError::unavailable(
            &sc.file,
            "a `kind = \"mechanism\"` scenario has no beam to linearise: give a `damper` or `hybrid` scenario",
        )
        .into()),
    }
}

/// One tangent model per mechanism of a built hybrid scenario, with the scenario's
/// run-time parameters.
pub fn hybrid_tangents(sc: &HybridScenario, models: &[Model]) -> Result<Vec<TangentSystem>, Error> {
    models
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

/// The tangent models derived so far in this process, by the content hash of their model
/// file, with how many times each was derived: a sweep derives each model's symbolic
/// tangents once, not once per grid point (and not again for the time-domain run's modal
/// filter). One entry per distinct model content; the same content always derives the same
/// tangents, so reuse changes no result.
type Derived = BTreeMap<String, (Option<TangentSystem>, usize)>;

fn cache() -> &'static Mutex<Derived> {
    static DERIVED: OnceLock<Mutex<Derived>> = OnceLock::new();
    DERIVED.get_or_init(Default::default)
}

fn derived(model: &Model) -> TangentSystem {
    let key = &model.source.hash;
    // A poisoned lock only means another thread panicked while holding it; the map is
    // still a valid set of derived tangents.
    let lock = || cache().lock().unwrap_or_else(|e| e.into_inner());
    if let Some((Some(t), _)) = lock().get(key) {
        return t.clone();
    }
    // Derived outside the lock (parallel sweep workers of different models do not wait on
    // each other); two workers deriving the same model at once derive the same tangents.
    let t = TangentSystem::new(model);
    let mut map = lock();
    let entry = map.entry(key.clone()).or_insert((None, 0));
    entry.1 += 1;
    entry.0.get_or_insert_with(|| t.clone());
    t
}

/// How many times this process derived the symbolic tangents of the model file with
/// content hash `hash` (0 when never): at most once per model in a sequential run.
pub fn tangent_derivations(hash: &str) -> usize {
    cache()
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .get(hash)
        .map_or(0, |e| e.1)
}

/// The tangent model of `model` with run-time parameters `params` (already checked by the
/// loader against the same model).
fn tangent(model: &Model, params: &[(String, f64)]) -> Result<TangentSystem, Error> {
    let mut t = derived(model);
    for (name, value) in params {
        t.set_param(name, *value).map_err(|e| {
            AnalysisError::unavailable(&model.source.path, format!("parameter {name}: {e}"))
        })?;
    }
    Ok(t)
}

impl Linearizable {
    /// An upper bound of the first-order states of its linearisation, known before it is
    /// made (the work estimates of `linearize` and `random`): twice the structure's coordinates
    /// and every mechanism coordinate, plus one current per generator.
    pub fn first_order_states(&self) -> usize {
        // The structure's coordinates: the beam's reduced DOFs, an imported model's
        // equations, a reduction's reduced coordinates.
        let beam = self.model.structure_dofs();
        let coordinates: usize = self.tangents.iter().map(|t| t.dof()).sum();
        let generators = self
            .model
            .forces
            .iter()
            .filter(|f| f.generator().is_some())
            .count();
        (beam + coordinates)
            .saturating_mul(2)
            .saturating_add(generators)
    }

    /// The tangent models as the slice [`Linearization::new`] takes.
    pub fn tangent_refs(&self) -> Vec<&TangentSystem> {
        self.tangents.iter().collect()
    }

    /// Linearises `model` (this scenario's system or a variant of it with the same
    /// mechanisms, e.g. [`HybridModel::generators_disconnected`]) about its static equilibrium.
    pub fn linearize(&self, model: &HybridModel) -> Result<Linearization, LinearError> {
        Linearization::new(model, &self.tangent_refs(), EquilibriumOptions::default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::{self, Override};
    use std::path::Path;

    /// Linearising the same scenario at several parameter values (a sweep's points) derives
    /// the model's tangents once; the reused tangents carry each point's parameters.
    #[test]
    fn a_model_s_tangents_are_derived_once() {
        let path = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../scenarios/two_dampers.toml"
        ));
        let at = |deg: f64| {
            let o = Override::new(
                "mechanism[0].placement.half_angle_deg",
                toml_edit::Value::from(deg),
                &format!("{deg}"),
            )
            .unwrap();
            let loaded = scenario::load_with(path, &[o]).unwrap();
            let lz = tangents_for(&loaded.scenario).unwrap();
            let lin = lz.linearize(&lz.model).unwrap();
            let hash = loaded_hash(&loaded.scenario);
            (lin, hash)
        };
        let (_, hash) = at(10.0);
        let before = tangent_derivations(&hash);
        assert!(before >= 1);
        let (a, _) = at(12.0);
        let (b, _) = at(15.0);
        assert_eq!(tangent_derivations(&hash), before, "derived again");
        // Different operating points: the reused tangents are evaluated at each.
        assert_ne!(a.equilibrium.mech_q[0], b.equilibrium.mech_q[0]);
    }

    fn loaded_hash(sc: &scenario::Scenario) -> String {
        match sc {
            scenario::Scenario::Hybrid(h) => {
                mbs_symbolic::model::load(&h.mechanisms[0].model)
                    .unwrap()
                    .source
                    .hash
            }
            _ => unreachable!("two_dampers.toml is a hybrid scenario"),
        }
    }
}
