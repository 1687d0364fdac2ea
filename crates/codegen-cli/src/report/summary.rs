//! The typed JSON summary of a closed-loop mechanism run (`<name>_summary.json`; a damper or
//! hybrid run's is [`crate::report::hybrid::HybridSummary`]) and the one JSON writer of
//! every summary. Non-finite numbers are written as `null`.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::scenario::OverrideRecord;

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
    if let Some(path) = first_null(&tree) {
        return Err(serde::ser::Error::custom(format!(
            "summary field `{path}` is not a finite number"
        )));
    }
    let mut v = serde_json::to_vec_pretty(&tree)?;
    v.push(b'\n');
    Ok(v)
}

/// One step of a path into a JSON tree: an array's index or an object's key.
enum Step<'a> {
    Index(usize),
    Key(&'a str),
}

/// The path of the first `null` in a JSON tree (`a.b[2]`, keys cut to 80 characters):
/// searched first, without a string made on the way, the path written only when there is
/// one.
fn first_null(v: &serde_json::Value) -> Option<String> {
    let mut steps = vec![];
    if !find_null(v, &mut steps) {
        return None;
    }
    let mut path = String::new();
    // From the root: `steps` holds them from the `null` up.
    for step in steps.iter().rev() {
        match step {
            Step::Index(i) => {
                path.push('[');
                path.push_str(&i.to_string());
                path.push(']');
            }
            Step::Key(k) => {
                if !path.is_empty() {
                    path.push('.');
                }
                path.push_str(&diagnostic::truncate(k, 80));
            }
        }
    }
    Some(path)
}

/// Whether there is a `null` in `v`; if so, `steps` ends with the steps from it up to `v`
/// (the first `null` in document order).
fn find_null<'a>(v: &'a serde_json::Value, steps: &mut Vec<Step<'a>>) -> bool {
    use serde_json::Value;
    match v {
        Value::Null => true,
        Value::Array(items) => items.iter().enumerate().any(|(i, x)| {
            let found = find_null(x, steps);
            if found {
                steps.push(Step::Index(i));
            }
            found
        }),
        Value::Object(map) => map.iter().any(|(k, x)| {
            let found = find_null(x, steps);
            if found {
                steps.push(Step::Key(k));
            }
            found
        }),
        _ => false,
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

    /// The path as it was made before: a string for every element on the way.
    fn first_null_by_strings(v: &serde_json::Value, path: String) -> Option<String> {
        use serde_json::Value;
        match v {
            Value::Null => Some(path),
            Value::Array(items) => items
                .iter()
                .enumerate()
                .find_map(|(i, x)| first_null_by_strings(x, format!("{path}[{i}]"))),
            Value::Object(map) => map.iter().find_map(|(k, x)| {
                let key = diagnostic::truncate(k, 80);
                first_null_by_strings(
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

    #[test]
    fn the_first_null_is_named_as_before() {
        let long = "k".repeat(100);
        let trees = [
            serde_json::json!(null),
            serde_json::json!(1.5),
            serde_json::json!({"a": 1, "b": [1, 2, {"c": "x"}]}),
            serde_json::json!({"a": 1, "b": [1, 2, {"c": null}], "d": null}),
            serde_json::json!([[0, [null]], null]),
            serde_json::json!([{"": {"": null}}]),
            serde_json::json!({"": [{"x": [3, null]}]}),
            serde_json::json!({"z": {"y": [true, false, "s", {}, []]}, "a": {"b": null}}),
            serde_json::json!({ (long.clone()): { (long.clone()): [null] } }),
        ];
        for t in &trees {
            assert_eq!(
                first_null(t),
                first_null_by_strings(t, String::new()),
                "{t}"
            );
        }
        assert_eq!(first_null(&trees[3]).as_deref(), Some("b[2].c"));
        assert_eq!(first_null(&trees[4]).as_deref(), Some("[0][1][0]"));
        assert_eq!(first_null(&trees[5]).as_deref(), Some("[0].."));
        assert_eq!(first_null(&trees[2]), None);
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
