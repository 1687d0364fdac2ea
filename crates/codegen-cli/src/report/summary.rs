//! The typed JSON summaries of a run (`summary.json` of a damper, `<name>_summary.json` of a
//! closed-loop mechanism). Non-finite numbers are written as `null`.

use std::collections::BTreeMap;

use std::path::Path;

use hybrid_core::decay::DecayEstimate;
use mbs_symbolic::model::Model;
use serde::Serialize;

use crate::run::DamperOutcome;
use crate::scenario::OverrideRecord;
use crate::scenario::damper::{DamperScenario, ScenarioSpec};

/// `summary.json` of a damper run.
#[derive(Clone, Debug, Serialize)]
pub struct DamperSummary<'a> {
    /// The scenario file.
    pub scenario: String,
    /// The `--set` overrides applied, in command-line order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub overrides: Vec<OverrideRecord>,
    /// The mechanism model's name.
    pub model: &'a str,
    /// The mechanism model file.
    pub model_file: String,
    /// FNV-1a content hash of the model file.
    pub model_hash: &'a str,
    /// Version of the code generator.
    pub generator_version: &'static str,
    /// `generated` or `numeric`.
    pub mechanism_backend: &'a str,
    /// The scenario as read, with defaults.
    pub settings: &'a ScenarioSpec,
    /// Time steps.
    pub steps: u64,
    /// Wall-clock time of the integration (s).
    pub wall_seconds: f64,
    /// Steps per second of wall-clock time.
    pub steps_per_second: f64,
    /// First natural frequency of the bare beam (Hz).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub beam_first_frequency_hz: Option<f64>,
    /// The state at t = 0.
    pub initial: InitialSummary,
    /// Largest |tip displacement| (m).
    pub peak_amplitude: f64,
    /// Equivalent damping ratio of the free decay with the generator (when it oscillates).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub zeta_with_generator: Option<f64>,
    /// Its damped frequency (Hz).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frequency_with_generator_hz: Option<f64>,
    /// The decay with the generator: oscillatory (with damping per cycle), over- or
    /// critically damped, or a rate (`hybrid_core::decay`).
    pub decay_with_generator: DecayEstimate,
    /// The comparison runs by key (`generator_disconnected`, `bare_beam`).
    pub comparisons: BTreeMap<&'static str, ComparisonSummary>,
    /// The energy account.
    pub energy: EnergySummary,
    /// Largest |energy balance error| / initial energy.
    pub energy_balance_rel_error: f64,
}

/// The initial state of a damper run.
#[derive(Clone, Debug, Serialize)]
pub struct InitialSummary {
    /// Tip displacement (m).
    pub tip_displacement: f64,
    /// Crank angle (degrees).
    pub crank_angle_deg: f64,
    /// Coupler angle (degrees).
    pub coupler_angle_deg: f64,
    /// q1'/y' (rad/m).
    pub amplification_rad_per_m: f64,
    /// cond(J^b).
    pub jacobian_condition: f64,
}

/// The energy account of a damper run (J).
#[derive(Clone, Debug, Serialize)]
pub struct EnergySummary {
    /// Stored energy at t = 0.
    pub initial: f64,
    /// Stored energy at the end.
    pub final_stored: f64,
    /// Dissipated in the generator circuit.
    pub dissipated_generator: f64,
    /// ... of which in the armature.
    pub dissipated_armature: f64,
    /// ... of which in the load.
    pub harvested_in_load: f64,
    /// Dissipated by the structure.
    pub dissipated_structure: f64,
    /// Work of external forces.
    pub external_work: f64,
}

/// One comparison run of a damper scenario.
#[derive(Clone, Debug, Serialize)]
pub struct ComparisonSummary {
    /// What the run is (the plot's legend).
    pub label: &'static str,
    /// Equivalent damping ratio of its free decay (when it oscillates).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub zeta: Option<f64>,
    /// Its damped frequency (Hz).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frequency_hz: Option<f64>,
    /// The decay estimate.
    pub decay: DecayEstimate,
    /// Largest |tip displacement| (m).
    pub peak_amplitude: f64,
    /// Energy dissipated by the structure (J).
    pub dissipated_structure: f64,
    /// Stored energy at the end (J).
    pub final_stored: f64,
    /// Largest |energy balance error| / initial energy.
    pub energy_balance_rel_error: f64,
}

impl<'a> DamperSummary<'a> {
    /// The summary of a finished damper run of the scenario `sc` (file `path`) on `model`
    /// (`simulate` writes it; a sweep point reads its figures from it).
    pub fn new(
        path: &Path,
        sc: &'a DamperScenario,
        model: &'a Model,
        o: &'a DamperOutcome,
        overrides: Vec<OverrideRecord>,
    ) -> DamperSummary<'a> {
        let with = &o.with;
        let e = with.state.energy;
        let s0 = with
            .digest
            .first()
            .expect("a damper run samples its initial state");
        let steps = with.state.steps;
        let decay = with.digest.decay();
        let comparisons = o
            .comparisons
            .iter()
            .map(|(c, r)| {
                let d = r.digest.decay();
                (
                    c.key(),
                    ComparisonSummary {
                        label: c.legend(),
                        zeta: d.zeta(),
                        frequency_hz: d.frequency_hz(),
                        decay: d,
                        peak_amplitude: r.digest.peak(),
                        dissipated_structure: r.state.energy.dissipated_structure,
                        final_stored: r.state.energy.total(),
                        energy_balance_rel_error: r.energy_balance_rel_error,
                    },
                )
            })
            .collect();
        DamperSummary {
            scenario: path.display().to_string(),
            overrides,
            model: &model.name,
            model_file: sc.model_path.display().to_string(),
            model_hash: &model.source.hash,
            generator_version: mbs_symbolic::emit::GENERATOR_VERSION,
            mechanism_backend: o.backend,
            settings: &sc.spec,
            steps,
            wall_seconds: with.wall.as_secs_f64(),
            steps_per_second: steps as f64 / with.wall.as_secs_f64().max(1e-12),
            beam_first_frequency_hz: o.beam_first_frequency_hz,
            initial: InitialSummary {
                tip_displacement: s0.tip_displacement,
                crank_angle_deg: s0.crank_angle.to_degrees(),
                coupler_angle_deg: s0.coupler_angle.to_degrees(),
                amplification_rad_per_m: s0.amplification,
                jacobian_condition: s0.jacobian_condition,
            },
            peak_amplitude: o.peak,
            zeta_with_generator: decay.zeta(),
            frequency_with_generator_hz: decay.frequency_hz(),
            decay_with_generator: decay.clone(),
            comparisons,
            energy: EnergySummary {
                initial: with.initial_energy,
                final_stored: e.total(),
                dissipated_generator: e.dissipated_armature + e.dissipated_load,
                dissipated_armature: e.dissipated_armature,
                harvested_in_load: e.dissipated_load,
                dissipated_structure: e.dissipated_structure,
                external_work: e.external_work,
            },
            energy_balance_rel_error: with.energy_balance_rel_error,
        }
    }
}

/// `<name>_summary.json` of a closed-loop mechanism run.
#[derive(Clone, Debug, Serialize)]
pub struct MechanismSummary {
    /// The scenario file.
    pub scenario: String,
    /// The `--set` overrides applied, in command-line order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub overrides: Vec<OverrideRecord>,
    /// Its description.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// The model file.
    pub model: String,
    /// The model's name.
    pub model_name: String,
    /// FNV-1a content hash of the model file.
    pub model_hash: String,
    /// The mechanism backend.
    pub backend: &'static str,
    /// `completed` or `stopped`.
    pub status: &'static str,
    /// Why the run stopped.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Integration settings.
    pub settings: MechanismSettings,
    /// Independent coordinates at the start.
    pub initial_independent: Vec<String>,
    /// ... and at the end.
    pub final_independent: Vec<String>,
    /// Redundant constraint rows dropped.
    pub dropped_constraint_rows: Vec<String>,
    /// Every change of partition.
    pub partition_changes: Vec<ChangeSummary>,
    /// Energy drift.
    pub energy: DriftSummary,
    /// Largest |h|.
    pub max_constraint_residual_norm: f64,
    /// Accepted steps.
    pub steps_accepted: usize,
    /// Rejected steps.
    pub steps_rejected: usize,
    /// Evaluations of the reduced equations.
    pub rhs_evaluations: usize,
    /// Newton iterations of the projection.
    pub newton_iterations: usize,
    /// Smallest accepted step.
    pub min_step: f64,
    /// Largest accepted step.
    pub max_step: f64,
    /// CSV rows written.
    pub output_rows: usize,
    /// Time reached.
    pub final_time: f64,
    /// The last output sample.
    pub final_state: FinalState,
    /// Wall-clock time (s).
    pub wall_time_s: f64,
}

/// The integration settings of a mechanism run.
#[derive(Clone, Debug, Serialize)]
pub struct MechanismSettings {
    /// The scheme.
    pub integrator: IntegratorSummary,
    /// Start time.
    pub t_start: f64,
    /// End time.
    pub t_end: f64,
    /// Output interval.
    pub output_step: f64,
    /// Projection tolerance.
    pub projection_tol: f64,
    /// Step limit.
    pub max_steps: usize,
    /// Partitioning.
    pub partition: PartitionSummary,
}

/// The integration scheme, tagged by `method`.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "method", rename_all = "lowercase")]
pub enum IntegratorSummary {
    /// Dormand–Prince 5(4).
    Dopri5 {
        /// Relative tolerance.
        rtol: f64,
        /// Absolute tolerance.
        atol: f64,
        /// First step.
        #[serde(skip_serializing_if = "Option::is_none")]
        initial_step: Option<f64>,
        /// Largest step.
        #[serde(skip_serializing_if = "Option::is_none")]
        max_step: Option<f64>,
    },
    /// Fixed-step RK4.
    Rk4 {
        /// The step.
        step: f64,
    },
}

/// The partitioning settings.
#[derive(Clone, Debug, Serialize)]
pub struct PartitionSummary {
    /// The requested independent coordinates, or `"automatic"`.
    pub independent: Requested,
    /// Drop redundant rows.
    pub allow_redundant: bool,
    /// Re-partition when J_v degrades.
    pub repartition: bool,
    /// Switch ratio.
    pub switch_ratio: f64,
    /// Largest acceptable cond(J_v).
    pub max_condition: f64,
    /// cond(J_v) that stops the run.
    pub singular_condition: f64,
    /// Rank tolerance.
    pub rank_tol: f64,
}

/// Independent coordinates as requested.
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
pub enum Requested {
    /// By name.
    Names(Vec<String>),
    /// `"automatic"`.
    Automatic(&'static str),
}

/// One change of partition.
#[derive(Clone, Debug, Serialize)]
pub struct ChangeSummary {
    /// Time.
    pub t: f64,
    /// Independent coordinates before.
    pub from: Vec<String>,
    /// ... after.
    pub to: Vec<String>,
    /// cond(J_v) before.
    pub cond_before: f64,
    /// cond(J_v) after.
    pub cond_after: f64,
    /// The log line.
    pub log: String,
}

/// Energy drift of a mechanism run.
#[derive(Clone, Debug, Serialize)]
pub struct DriftSummary {
    /// Total energy at the start.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub initial_total: Option<f64>,
    /// Largest |E - E0|.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_abs_drift: Option<f64>,
    /// ... relative to `relative_to`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_relative_drift: Option<f64>,
    /// What the relative drift is relative to.
    pub relative_to: &'static str,
    /// E - E0 at the end.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub final_drift: Option<f64>,
}

/// The last output sample of a mechanism run.
#[derive(Clone, Debug, Serialize)]
pub struct FinalState {
    /// Time.
    pub t: f64,
    /// Coordinates by name.
    pub q: BTreeMap<String, f64>,
    /// Velocities by name.
    pub qd: BTreeMap<String, f64>,
}

/// Pretty-printed JSON of a summary, with a final newline. A summary has no `null`: absent
/// values are left out, and a non-finite number (which JSON cannot hold and `serde_json`
/// would print as `null`) is an error naming the field, e.g. `energy.max_relative_drift`.
pub fn json_bytes<T: Serialize>(value: &T) -> Result<Vec<u8>, serde_json::Error> {
    let tree = serde_json::to_value(value)?;
    if let Some(path) = first_null(&tree, String::new()) {
        return Err(serde::ser::Error::custom(format!(
            "summary field `{path}` is not a finite number"
        )));
    }
    let mut v = serde_json::to_vec_pretty(&tree)?;
    v.push(b'\n');
    Ok(v)
}

/// The path of the first `null` in a JSON tree (`a.b[2]`).
fn first_null(v: &serde_json::Value, path: String) -> Option<String> {
    use serde_json::Value;
    match v {
        Value::Null => Some(path),
        Value::Array(items) => items
            .iter()
            .enumerate()
            .find_map(|(i, x)| first_null(x, format!("{path}[{i}]"))),
        Value::Object(map) => map.iter().find_map(|(k, x)| {
            let key = diagnostic::truncate(k, 80);
            first_null(
                x,
                if path.is_empty() {
                    key
                } else {
                    format!("{path}.{key}")
                },
            )
        }),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize)]
    struct Drift {
        energy: Inner,
    }
    #[derive(Serialize)]
    struct Inner {
        #[serde(skip_serializing_if = "Option::is_none")]
        absent: Option<f64>,
        max_relative_drift: f64,
    }

    #[test]
    fn nan_in_a_summary_is_an_error_naming_the_field_not_null() {
        let bad = Drift {
            energy: Inner {
                absent: None,
                max_relative_drift: f64::NAN,
            },
        };
        let e = json_bytes(&bad).unwrap_err().to_string();
        assert!(e.contains("energy.max_relative_drift"), "{e}");
        let good = Drift {
            energy: Inner {
                absent: None,
                max_relative_drift: 0.0,
            },
        };
        let text = String::from_utf8(json_bytes(&good).unwrap()).unwrap();
        assert!(!text.contains("null") && !text.contains("absent"), "{text}");
    }
}
