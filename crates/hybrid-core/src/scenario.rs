//! The damper scenario file (TOML): beam, mechanism attachment, generator, initial
//! conditions, integrator and outputs. See `scenarios/damper.toml` for a commented example.
//!
//! ```toml
//! kind = "damper"
//! [beam]                      # a fem-beam description ([[beam.segment]], [[beam.support]], ...)
//! [mechanism]
//! model = "../models/double_bar.toml"   # relative to the scenario file
//! point = "tip"               # the mechanism point pinned to the beam
//! x = 1.0                     # beam point (a node, or inside an element: shape functions, eq. 35)
//! half_angle_deg = 10.0       # pivot on the point's line of motion, bars at this half-angle
//! # pivot = [0.0, -0.19696]   # or: ground pivot relative to the undeformed beam point (m)
//! generator_joint = "crank"   # body whose joint carries the generator
//! max_condition = 1e4         # stop when cond(J^b) exceeds this (singular position)
//! parameters = { m1 = 0.024 } # run-time parameter overrides
//! [generator]                 # kt, ke, armature_resistance, load_resistance, inductance,
//!                             # gear_ratio, rotor_inertia, connected
//! [initial]
//! displacement = 0.001        # beam point displacement, static shape of a point load (m)
//! [integrator]
//! method = "newmark"          # or "hht" with alpha in [-1/3, 0]
//! dt = 1e-4
//! t_end = 5.0
//! [output]
//! every = 10                  # CSV row every 10 steps
//! compare_without_generator = true
//! ```

use std::path::{Path, PathBuf};

use fem_beam::{Beam, BeamModel, BeamSpec};
use serde::{Deserialize, Serialize};

use crate::damper::Method;
use crate::generator::GeneratorSpec;

/// A problem with a scenario file: file, line when known, the entity and what is wrong.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{file}{}: {entity}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct ScenarioError {
    /// The scenario file.
    pub file: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// The section or entity (`[generator]`, `[mechanism] model`, ...).
    pub entity: String,
    /// What is wrong.
    pub message: String,
}

/// `[mechanism]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MechanismSpec {
    /// Model file, relative to the scenario file.
    pub model: PathBuf,
    /// Mechanism point pinned to the beam.
    #[serde(default = "default_point")]
    pub point: String,
    /// Beam point: x coordinate along the beam (m).
    pub x: f64,
    /// Half-angle at the pivot in degrees (0 = the singular, straight position).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_angle_deg: Option<f64>,
    /// Ground pivot relative to the undeformed beam point `[x, y]` (m), instead of
    /// `half_angle_deg`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pivot: Option<[f64; 2]>,
    /// Body whose joint carries the generator.
    #[serde(default = "default_joint")]
    pub generator_joint: String,
    /// Stop when the condition number of `J^b` exceeds this.
    #[serde(default = "default_max_condition")]
    pub max_condition: f64,
    /// Run-time parameter overrides.
    #[serde(default)]
    pub parameters: std::collections::BTreeMap<String, f64>,
}

fn default_point() -> String {
    "tip".into()
}
fn default_joint() -> String {
    "crank".into()
}
fn default_max_condition() -> f64 {
    1e4
}

/// `[initial]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialSpec {
    /// Initial displacement of the beam point (m), in the static shape of a point load there;
    /// released from rest.
    pub displacement: f64,
}

/// `[integrator]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorSpec {
    /// `"newmark"` (average acceleration) or `"hht"`.
    #[serde(default = "default_method")]
    pub method: String,
    /// HHT parameter in [-1/3, 0] (`method = "hht"` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f64>,
    /// Time step (s).
    pub dt: f64,
    /// End time (s).
    pub t_end: f64,
}

fn default_method() -> String {
    "newmark".into()
}

/// `[output]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Write a CSV row every `every` steps.
    #[serde(default = "default_every")]
    pub every: usize,
    /// Also run with the generator disconnected, for the comparison (zeta, plot).
    #[serde(default = "yes")]
    pub compare_without_generator: bool,
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec {
            every: default_every(),
            compare_without_generator: true,
        }
    }
}

fn default_every() -> usize {
    10
}
fn yes() -> bool {
    true
}

/// The whole scenario file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioSpec {
    /// Must be `"damper"`.
    pub kind: String,
    /// Free text.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// The beam.
    pub beam: BeamSpec,
    /// The mechanism and where it is pinned.
    pub mechanism: MechanismSpec,
    /// The generator.
    pub generator: GeneratorSpec,
    /// Initial conditions.
    pub initial: InitialSpec,
    /// Time integration.
    pub integrator: IntegratorSpec,
    /// Outputs.
    #[serde(default)]
    pub output: OutputSpec,
}

/// A loaded and checked scenario.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// The scenario file as given.
    pub path: PathBuf,
    /// The file content (for hashing and line lookup).
    pub text: String,
    /// The parsed description.
    pub spec: ScenarioSpec,
    /// The validated beam.
    pub beam: Beam,
    /// The mechanism model file, resolved against the scenario's directory.
    pub model_path: PathBuf,
    /// The integration scheme.
    pub method: Method,
}

/// 1-based line of a byte offset.
fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())]
        .bytes()
        .filter(|b| *b == b'\n')
        .count()
        + 1
}

/// The line where `key` is first assigned inside the table `[section]` (best effort).
pub fn line_of_key(text: &str, section: &str, key: &str) -> Option<usize> {
    let mut in_section = section.is_empty();
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.starts_with('[') {
            let name = t.trim_matches(|c| c == '[' || c == ']').trim();
            in_section = name == section;
            continue;
        }
        if in_section {
            if let Some((k, _)) = t.split_once('=') {
                if k.trim() == key {
                    return Some(i + 1);
                }
            }
        }
    }
    None
}

impl Scenario {
    /// Reads and checks a scenario file. Every error names the file, the line when known and
    /// the entity.
    pub fn load(path: &Path) -> Result<Scenario, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|e| ScenarioError {
            file: path.display().to_string(),
            line: None,
            entity: "file".into(),
            message: format!("cannot read: {e}"),
        })?;
        Scenario::from_str(&text, path)
    }

    /// Parses and checks scenario text; `path` names the file in messages and is the base of
    /// relative paths.
    pub fn from_str(text: &str, path: &Path) -> Result<Scenario, ScenarioError> {
        let file = path.display().to_string();
        let err = |line: Option<usize>, entity: &str, message: String| ScenarioError {
            file: file.clone(),
            line,
            entity: entity.to_string(),
            message,
        };
        let spec: ScenarioSpec = toml::from_str(text).map_err(|e| {
            let line = e.span().map(|s| line_of(text, s.start));
            err(line, "scenario", e.message().trim().to_string())
        })?;
        let at = |section: &str, key: &str| line_of_key(text, section, key);
        if spec.kind != "damper" {
            return Err(err(
                at("", "kind"),
                "kind",
                format!("expected \"damper\", got {:?}", spec.kind),
            ));
        }
        let beam = Beam::new(&spec.beam)
            .map_err(|e| err(None, "[beam]", e.to_string().replace('\n', "; ")))?;
        let m = &spec.mechanism;
        if !(m.x.is_finite() && m.x >= 0.0 && m.x <= beam.length() * (1.0 + 1e-12)) {
            return Err(err(
                at("mechanism", "x"),
                "[mechanism] x",
                format!(
                    "must lie on the beam, 0 to {} m (got {})",
                    beam.length(),
                    m.x
                ),
            ));
        }
        match (m.half_angle_deg, m.pivot) {
            (Some(_), Some(_)) => {
                return Err(err(
                    at("mechanism", "pivot"),
                    "[mechanism]",
                    "give either half_angle_deg or pivot, not both".into(),
                ));
            }
            (None, None) => {
                return Err(err(
                    at("mechanism", "model"),
                    "[mechanism]",
                    "missing half_angle_deg or pivot".into(),
                ));
            }
            (Some(a), None) if !(a.is_finite() && a > 0.0 && a < 90.0) => {
                return Err(err(
                    at("mechanism", "half_angle_deg"),
                    "[mechanism] half_angle_deg",
                    format!("must be between 0 (the singular position) and 90 degrees (got {a})"),
                ));
            }
            _ => {}
        }
        if !(m.max_condition.is_finite() && m.max_condition > 1.0) {
            return Err(err(
                at("mechanism", "max_condition"),
                "[mechanism] max_condition",
                format!("must be > 1 (got {})", m.max_condition),
            ));
        }
        spec.generator.validate().map_err(|msg| {
            let key = msg
                .split_once(' ')
                .map(|(k, _)| k.trim_start_matches("generator."))
                .unwrap_or("");
            err(at("generator", key), "[generator]", msg)
        })?;
        if !spec.initial.displacement.is_finite() {
            return Err(err(
                at("initial", "displacement"),
                "[initial] displacement",
                "must be finite".into(),
            ));
        }
        let ig = &spec.integrator;
        if !(ig.dt.is_finite() && ig.dt > 0.0) {
            return Err(err(
                at("integrator", "dt"),
                "[integrator] dt",
                format!("must be positive (got {})", ig.dt),
            ));
        }
        if !(ig.t_end.is_finite() && ig.t_end > 0.0) {
            return Err(err(
                at("integrator", "t_end"),
                "[integrator] t_end",
                format!("must be positive (got {})", ig.t_end),
            ));
        }
        if ig.t_end / ig.dt > 1e9 {
            return Err(err(
                at("integrator", "dt"),
                "[integrator]",
                format!("t_end / dt = {:.3e} steps is too many", ig.t_end / ig.dt),
            ));
        }
        let method = match (ig.method.as_str(), ig.alpha) {
            ("newmark", None) => Method::Newmark,
            ("newmark", Some(_)) => {
                return Err(err(
                    at("integrator", "alpha"),
                    "[integrator] alpha",
                    "alpha is for method = \"hht\"".into(),
                ));
            }
            ("hht", a) => {
                let alpha = a.unwrap_or(-0.05);
                if !(-1.0 / 3.0..=0.0).contains(&alpha) {
                    return Err(err(
                        at("integrator", "alpha"),
                        "[integrator] alpha",
                        format!("must be in [-1/3, 0] (got {alpha})"),
                    ));
                }
                Method::Hht { alpha }
            }
            (other, _) => {
                return Err(err(
                    at("integrator", "method"),
                    "[integrator] method",
                    format!("unknown method {other:?} (expected \"newmark\" or \"hht\")"),
                ));
            }
        };
        if spec.output.every == 0 {
            return Err(err(
                at("output", "every"),
                "[output] every",
                "must be at least 1".into(),
            ));
        }
        let base = path.parent().unwrap_or(Path::new("."));
        let model_path = base.join(&m.model);
        Ok(Scenario {
            path: path.to_path_buf(),
            text: text.to_string(),
            spec,
            beam,
            model_path,
            method,
        })
    }

    /// Builds the beam's finite-element model.
    pub fn beam_model(&self) -> Result<BeamModel, ScenarioError> {
        BeamModel::new(&self.beam).map_err(|e| self.error(None, "[beam]", e.to_string()))
    }

    /// An error about this scenario, with the line of `key` in `section` when found.
    pub fn error_at(
        &self,
        section: &str,
        key: &str,
        entity: &str,
        message: String,
    ) -> ScenarioError {
        self.error(line_of_key(&self.text, section, key), entity, message)
    }

    fn error(&self, line: Option<usize>, entity: &str, message: String) -> ScenarioError {
        ScenarioError {
            file: self.path.display().to_string(),
            line,
            entity: entity.into(),
            message,
        }
    }
}
