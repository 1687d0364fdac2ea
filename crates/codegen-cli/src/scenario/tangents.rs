//! The linearisable form of a scenario: its hybrid model (the damper kind as its rank-one
//! special case, the hybrid kind as built) together with one exact tangent model
//! ([`TangentSystem`]: symbolic first derivatives of the mechanism's equations) per
//! mechanism, built from the same model file with the same run-time parameters as the
//! mechanism's system. What `damper linearize`, the frequency response and the sweeps'
//! linearised figures start from.

use hybrid_core::hybrid::{ForceKind, HybridModel};
use mbs_symbolic::runtime::TangentSystem;

use super::Scenario;
use crate::Error;

/// A scenario's hybrid model and its mechanisms' tangent models.
pub struct Linearisable {
    /// The hybrid system (generators connected as the scenario says).
    pub model: HybridModel,
    /// One tangent model per mechanism, in the model's order.
    pub tangents: Vec<TangentSystem>,
}

impl Linearisable {
    /// The tangent models as the slice of references
    /// [`hybrid_core::hybrid::Linearization::new`] takes.
    pub fn tangent_refs(&self) -> Vec<&TangentSystem> {
        self.tangents.iter().collect()
    }

    /// The same system with every generator disconnected (mechanism and rotor inertia
    /// still attached): the baseline "generator disconnected".
    pub fn without_generators(&self) -> HybridModel {
        let mut m = self.model.clone();
        for f in &mut m.forces {
            if let ForceKind::Generator(g) = &mut f.kind {
                g.connected = false;
            }
        }
        m
    }
}

/// Builds the hybrid model and the tangent models of a damper or hybrid scenario; a
/// mechanism scenario has no beam to linearise about ([`Error::Usage`]).
pub fn tangents_for(sc: &Scenario) -> Result<Linearisable, Error> {
    match sc {
        Scenario::Damper(sc) => {
            let model = mbs_symbolic::model::load(&sc.model_path)?;
            sc.check_parameters(&model)?;
            let system = model_registry::system_for(&model, None)?.system;
            let (coupled, guess) = hybrid_core::study::build_model(&sc.setup, &model, system, true)
                .map_err(|e| Error::Input(sc.diagnostic(&e).into()))?;
            let (hybrid, _) = hybrid_core::study::hybrid_of(&sc.setup, &coupled, guess)
                .map_err(|e| Error::Input(sc.diagnostic(&e).into()))?;
            let mut tangent = TangentSystem::new(&model);
            for (name, value) in &sc.setup.parameters {
                tangent
                    .set_param(name, *value)
                    .map_err(|e| Error::Usage(format!("{}: {e}", sc.path.display())))?;
            }
            Ok(Linearisable {
                model: hybrid,
                tangents: vec![tangent],
            })
        }
        Scenario::Hybrid(sc) => {
            let built = sc.build()?;
            let mut tangents = Vec::with_capacity(built.models.len());
            for (model, entry) in built.models.iter().zip(&sc.mechanisms) {
                let mut tangent = TangentSystem::new(model);
                for (name, value, _) in &entry.parameters {
                    tangent
                        .set_param(name, *value)
                        .map_err(|e| Error::Usage(format!("{}: {e}", sc.path.display())))?;
                }
                tangents.push(tangent);
            }
            Ok(Linearisable {
                model: built.model,
                tangents,
            })
        }
        Scenario::Mechanism(sc) => Err(Error::Usage(format!(
            "{}: a mechanism scenario has no beam and no static equilibrium to linearise about: linearise a damper or hybrid scenario",
            sc.file
        ))),
    }
}
