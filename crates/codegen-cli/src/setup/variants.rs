//! The comparison runs of a built hybrid scenario (`[output] compare`) as engine models:
//! every generator disconnected, or the bare beam (structure) read at the attachments' beam
//! points (nodes)
//! (`hybrid_core::hybrid::HybridModel::generators_disconnected`, `bare_beam`), each from the
//! scenario's initial state.

use hybrid_core::hybrid::{BeamPoint, initial_state};

use super::Built;
use crate::Error;
use crate::scenario::Comparison;

/// Beam points read as the attachments are, by name, without being attached.
pub type Probes = Vec<(String, BeamPoint)>;

/// The system of a comparison run of a built scenario, from the same initial state, and the
/// beam points it reads as probes (the bare beam's: where the attachments were); `None` for
/// `bare_beam`/`bare_structure` without a host (the loader refuses it).
pub fn comparison(
    file: &str,
    built: &Built,
    c: Comparison,
) -> Result<Option<(Built, Probes)>, Error> {
    let model = &built.model;
    let (variant, models, probes) = match c {
        Comparison::GeneratorDisconnected => (
            model.generators_disconnected(),
            built.models.clone(),
            vec![],
        ),
        Comparison::BareBeam | Comparison::BareStructure => {
            let Some(bare) = model.bare_beam() else {
                return Ok(None);
            };
            let probes: Vec<(String, BeamPoint)> = model
                .attachments
                .iter()
                .map(|a| (a.name.clone(), a.beam.clone()))
                .collect();
            (bare, vec![], probes)
        }
    };
    let state =
        initial_state(&variant, built.state.q.clone(), built.state.v.clone()).map_err(|error| {
            Error::Hybrid {
                file: file.to_string(),
                error,
            }
        })?;
    let variant = Built {
        model: variant,
        state,
        models,
        points: built.points.clone(),
    };
    Ok(Some((variant, probes)))
}
