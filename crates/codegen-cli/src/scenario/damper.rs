//! The damper scenario (`kind = "damper"`, the default), TOML: beam, mechanism attachment, generator, initial
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
//! compare = ["generator_disconnected", "bare_beam"]   # comparison runs (default: the first;
//!                             # `compare_without_generator = true/false` is a synonym of
//!                             # ["generator_disconnected"] / [])
//! ```
//!
//! Every problem is reported at once with file:line:column: unknown keys and malformed
//! sections, out-of-range values, and (when the model is known) names the model does not
//! have ([`DamperScenario::diagnostic`]).

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use diagnostic::{Diagnostic, Diagnostics, Kind, LineIndex};
use fem_beam::{Beam, BeamSpec};
use hybrid_core::damper::Method;
use hybrid_core::generator::GeneratorSpec;
use hybrid_core::hybrid::{Placement, PlacementError};
use hybrid_core::study::{DamperSetup, SetupError, SetupField};
use mbs_symbolic::model::Model;
use serde::{Deserialize, Serialize};
use toml::Spanned;

use super::Doc;

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
    pub parameters: BTreeMap<String, f64>,
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

/// A comparison run of a damper scenario, run next to the run with the generator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Comparison {
    /// The same damper with the generator disconnected: the mechanism and the rotor inertia
    /// (through the gear ratio) stay attached to the beam, only the electrical damping is
    /// gone (near the toggle this lowers the first frequency a lot: not the bare beam).
    GeneratorDisconnected,
    /// The beam alone, without the mechanism: the structure before any damper.
    BareBeam,
}

impl Comparison {
    /// Every comparison, in output order.
    pub const ALL: [Comparison; 2] = [Comparison::GeneratorDisconnected, Comparison::BareBeam];

    /// The key in the scenario, the summary and the output file names.
    pub fn key(self) -> &'static str {
        match self {
            Comparison::GeneratorDisconnected => "generator_disconnected",
            Comparison::BareBeam => "bare_beam",
        }
    }

    /// The legend of its plotted series.
    pub fn legend(self) -> &'static str {
        match self {
            Comparison::GeneratorDisconnected => {
                "generator disconnected (mechanism + rotor inertia attached)"
            }
            Comparison::BareBeam => "bare beam (no mechanism)",
        }
    }
}

/// `[output]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Write a CSV row every `every` steps.
    #[serde(default = "default_every")]
    pub every: usize,
    /// The comparison runs (default `["generator_disconnected"]`), each with its own time
    /// history, summary block and plotted series.
    #[serde(default = "default_compare")]
    pub compare: Vec<Comparison>,
    /// Synonym kept for older scenarios: `true` is `compare = ["generator_disconnected"]`,
    /// `false` is `compare = []` (not both keys in one file). Resolved into `compare` by the
    /// loader, so it is never set on a loaded scenario.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub compare_without_generator: Option<bool>,
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec {
            every: default_every(),
            compare: default_compare(),
            compare_without_generator: None,
        }
    }
}

fn default_every() -> usize {
    10
}
fn default_compare() -> Vec<Comparison> {
    vec![Comparison::GeneratorDisconnected]
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

/// A loaded and checked damper scenario.
#[derive(Clone, Debug)]
pub struct DamperScenario {
    /// The scenario file as given.
    pub path: PathBuf,
    /// The description as read, with defaults filled in (reported in the summary).
    pub spec: ScenarioSpec,
    /// The checked setup of the run (hybrid-core's input).
    pub setup: DamperSetup,
    /// The mechanism model file, resolved against the scenario's directory.
    pub model_path: PathBuf,
    /// Where each field a [`SetupError`] can be about is written.
    spans: BTreeMap<&'static str, Range<usize>>,
    index: LineIndex,
}

impl DamperScenario {
    /// Parses and checks damper scenario text (`kind` absent or `"damper"`); `path` names the
    /// file in messages and is the base of relative paths.
    pub fn from_str(text: &str, path: &Path) -> Result<DamperScenario, Diagnostics> {
        match super::parse(text, path)? {
            super::Scenario::Damper(s) => Ok(*s),
            _ => Err(Diagnostic::new(
                Kind::Unsupported,
                path.display().to_string(),
                "not a damper scenario (`kind = \"damper\"`)",
            )
            .into()),
        }
    }

    /// Checks the run-time parameter overrides (`[mechanism] parameters`) against the
    /// mechanism model with the same physical checks as the model file gets (masses > 0,
    /// inertias physical, lengths finite; [`mbs_symbolic::model::check_parameter_values`]).
    /// Names the model does not have are left to the setup (which lists the known ones).
    pub fn check_parameters(&self, model: &Model) -> Result<(), Diagnostics> {
        let mut values = model.default_params();
        for (name, value) in &self.setup.parameters {
            if let Some(k) = model.param_index(name) {
                values[k] = *value;
            }
        }
        let file = self.path.display().to_string();
        mbs_symbolic::model::check_parameter_values(model, &values, &file).map_err(|d| {
            let at = self.spans.get("parameters").map(|s| s.start);
            d.into_iter()
                .map(|mut d| {
                    d.entity = Some(format!(
                        "[mechanism] parameters: {}",
                        d.entity.take().unwrap_or_default()
                    ));
                    match at {
                        Some(at) => d.at_offset(&self.index, at),
                        None => d,
                    }
                })
                .collect::<Vec<_>>()
                .into()
        })
    }

    /// The problem of a setup that does not fit its model or beam, at the field it is about.
    pub fn diagnostic(&self, e: &SetupError) -> Diagnostic {
        let (key, entity) = match e.field() {
            SetupField::Beam => ("beam", "[beam]"),
            SetupField::Parameters => ("parameters", "[mechanism] parameters"),
            SetupField::Point => ("point", "[mechanism] point"),
            SetupField::X => ("x", "[mechanism] x"),
            SetupField::HalfAngle => ("half_angle_deg", "[mechanism] half_angle_deg"),
            SetupField::Pivot => ("pivot", "[mechanism] pivot"),
            SetupField::GeneratorJoint => ("generator_joint", "[mechanism] generator_joint"),
            SetupField::Model => ("model", "[mechanism] model"),
        };
        let kind = match e {
            SetupError::UnknownParameter { .. }
            | SetupError::UnknownPoint { .. }
            | SetupError::UnknownBody(_) => Kind::UnknownName,
            SetupError::Placement(PlacementError::NotTwoBar { .. }) => Kind::Unsupported,
            _ => Kind::InvalidValue,
        };
        let mut d =
            Diagnostic::new(kind, self.path.display().to_string(), e.to_string()).entity(entity);
        if let Some(span) = self.spans.get(key).filter(|_| key != "beam") {
            d = d.at_offset(&self.index, span.start);
        }
        d
    }
}

/// Reads the sections of a damper scenario and checks every value.
pub(crate) fn from_doc(doc: &mut Doc<'_>) -> Option<DamperScenario> {
    doc.check_keys(&[
        "kind",
        "description",
        "beam",
        "mechanism",
        "generator",
        "initial",
        "integrator",
        "output",
    ]);
    let description = doc.section::<String>("description", false);
    let beam = doc.section::<BeamSpec>("beam", true);
    let mechanism = doc.section::<MechanismSpec>("mechanism", true);
    let generator = doc.section::<GeneratorSpec>("generator", true);
    let initial = doc.section::<InitialSpec>("initial", true);
    let integrator = doc.section::<IntegratorSpec>("integrator", true);
    let output = doc.section::<OutputSpec>("output", false);
    let at = |doc: &Doc<'_>, section: &str, key: &str| doc.span(&[section, key]);

    let beam = beam.and_then(|b| match Beam::new_in_physical_range(b.get_ref()) {
        Ok(beam) => Some((b.into_inner(), beam)),
        Err(e) => {
            let msg = e.to_string().replace('\n', "; ");
            doc.push(Kind::InvalidValue, None, Some("[beam]"), msg);
            None
        }
    });
    if let Some(m) = &mechanism {
        let m = m.get_ref();
        if let Some((_, beam)) = &beam {
            if !(m.x.is_finite() && m.x >= 0.0 && m.x <= beam.length() * (1.0 + 1e-12)) {
                let msg = format!(
                    "must lie on the beam, 0 to {} m (got {})",
                    beam.length(),
                    m.x
                );
                let span = at(doc, "mechanism", "x");
                doc.push(Kind::InvalidValue, span, Some("[mechanism] x"), msg);
            }
        }
        match (m.half_angle_deg, m.pivot) {
            (Some(_), Some(_)) => {
                let span = at(doc, "mechanism", "pivot");
                let msg = "give either half_angle_deg or pivot, not both";
                doc.push(Kind::InvalidValue, span, Some("[mechanism]"), msg);
            }
            (None, None) => {
                let span = doc.span(&["mechanism"]);
                let msg = "missing half_angle_deg or pivot";
                doc.push(Kind::MissingField, span, Some("[mechanism]"), msg);
            }
            (Some(a), None) if !(a.is_finite() && a > 0.0 && a < 90.0) => {
                let span = at(doc, "mechanism", "half_angle_deg");
                let msg =
                    format!("must be between 0 (the singular position) and 90 degrees (got {a})");
                let entity = Some("[mechanism] half_angle_deg");
                doc.push(Kind::InvalidValue, span, entity, msg);
            }
            _ => {}
        }
        if !(m.max_condition.is_finite() && m.max_condition > 1.0) {
            let span = at(doc, "mechanism", "max_condition");
            let msg = format!("must be > 1 (got {})", m.max_condition);
            let entity = Some("[mechanism] max_condition");
            doc.push(Kind::InvalidValue, span, entity, msg);
        }
    }
    if let Some(g) = &generator {
        for e in g.get_ref().problems() {
            let span = match e.field() {
                Some(f) => at(doc, "generator", f.name()).or(Some(g.span())),
                None => Some(g.span()),
            };
            doc.push(Kind::InvalidValue, span, Some("[generator]"), e.to_string());
        }
    }
    if let Some(i) = &initial {
        if !i.get_ref().displacement.is_finite() {
            let span = at(doc, "initial", "displacement");
            let entity = Some("[initial] displacement");
            doc.push(Kind::InvalidValue, span, entity, "must be finite");
        }
    }
    let method = integrator
        .as_ref()
        .and_then(|ig| check_integrator(doc, ig.get_ref()));
    if let Some(o) = &output {
        let (given, synonym) = (
            doc.span(&["output", "compare"]),
            doc.span(&["output", "compare_without_generator"]),
        );
        if given.is_some() && synonym.is_some() {
            doc.push(
                Kind::InvalidValue,
                synonym,
                Some("[output] compare_without_generator"),
                "give either `compare` or its older synonym `compare_without_generator`, not both",
            );
        }
        let list = &o.get_ref().compare;
        for (k, c) in list.iter().enumerate() {
            if list[..k].contains(c) {
                doc.push(
                    Kind::InvalidValue,
                    given.clone(),
                    Some("[output] compare"),
                    format!("{:?} is listed twice", c.key()),
                );
            }
        }
        if o.get_ref().every == 0 {
            let span = at(doc, "output", "every");
            doc.push(
                Kind::InvalidValue,
                span,
                Some("[output] every"),
                "must be at least 1",
            );
        }
    }

    let mut spans = BTreeMap::new();
    for key in [
        "parameters",
        "point",
        "x",
        "half_angle_deg",
        "pivot",
        "generator_joint",
    ] {
        if let Some(s) = doc.span(&["mechanism", key]) {
            spans.insert(key, s);
        }
    }
    let ((beam_spec, beam), mechanism, generator, initial, integrator, method) = (
        beam?,
        mechanism?,
        generator?,
        initial?,
        integrator?,
        method?,
    );
    let (mechanism, generator) = (mechanism.into_inner(), generator.into_inner());
    let (initial, integrator) = (initial.into_inner(), integrator.into_inner());
    let mut output = output.map(Spanned::into_inner).unwrap_or_default();
    if let Some(with) = output.compare_without_generator.take() {
        output.compare = if with { default_compare() } else { vec![] };
    }
    let placement = match (mechanism.half_angle_deg, mechanism.pivot) {
        (Some(a), None) => Placement::HalfAngle(a),
        (None, Some(p)) => Placement::Pivot(p),
        _ => return None, // reported above
    };
    let setup = DamperSetup {
        beam,
        parameters: mechanism.parameters.clone(),
        point: mechanism.point.clone(),
        x: mechanism.x,
        placement,
        generator_joint: mechanism.generator_joint.clone(),
        max_condition: mechanism.max_condition,
        generator: generator.clone(),
        initial_displacement: initial.displacement,
        method,
        dt: integrator.dt,
        t_end: integrator.t_end,
        every: output.every,
    };
    let model_path = doc.base().join(&mechanism.model);
    Some(DamperScenario {
        path: PathBuf::from(doc.file()),
        spec: ScenarioSpec {
            kind: "damper".into(),
            description: description.map(Spanned::into_inner),
            beam: beam_spec,
            mechanism,
            generator,
            initial,
            integrator,
            output,
        },
        setup,
        model_path,
        spans,
        index: doc.index().clone(),
    })
}

/// Checks `[integrator]`; the scheme when it is usable.
pub(crate) fn check_integrator(doc: &mut Doc<'_>, ig: &IntegratorSpec) -> Option<Method> {
    let at = |doc: &Doc<'_>, key: &str| doc.span(&["integrator", key]);
    let mut ok = true;
    if !(ig.dt.is_finite() && ig.dt > 0.0) {
        let msg = format!("must be positive (got {})", ig.dt);
        doc.push(
            Kind::InvalidValue,
            at(doc, "dt"),
            Some("[integrator] dt"),
            msg,
        );
        ok = false;
    }
    if !(ig.t_end.is_finite() && ig.t_end > 0.0) {
        let msg = format!("must be positive (got {})", ig.t_end);
        let span = at(doc, "t_end");
        doc.push(Kind::InvalidValue, span, Some("[integrator] t_end"), msg);
        ok = false;
    }
    if ok && ig.dt > ig.t_end {
        let msg = format!(
            "must not exceed t_end (dt = {}, t_end = {}: not one step would be taken)",
            ig.dt, ig.t_end
        );
        doc.push(
            Kind::InvalidValue,
            at(doc, "dt"),
            Some("[integrator] dt"),
            msg,
        );
        ok = false;
    }
    if ok && ig.t_end / ig.dt > 1e9 {
        let msg = format!("t_end / dt = {:.3e} steps is too many", ig.t_end / ig.dt);
        doc.push(Kind::InvalidValue, at(doc, "dt"), Some("[integrator]"), msg);
        ok = false;
    }
    let method = match (ig.method.as_str(), ig.alpha) {
        ("newmark", None) => Some(Method::Newmark),
        ("newmark", Some(_)) => {
            let msg = "alpha is for method = \"hht\"";
            let span = at(doc, "alpha");
            doc.push(Kind::InvalidValue, span, Some("[integrator] alpha"), msg);
            None
        }
        ("hht", a) => {
            let alpha = a.unwrap_or(-0.05);
            if (-1.0 / 3.0..=0.0).contains(&alpha) {
                Some(Method::Hht { alpha })
            } else {
                let msg = format!("must be in [-1/3, 0] (got {alpha})");
                let span = at(doc, "alpha");
                doc.push(Kind::InvalidValue, span, Some("[integrator] alpha"), msg);
                None
            }
        }
        (other, _) => {
            let msg = format!("unknown method {other:?} (expected \"newmark\" or \"hht\")");
            let span = at(doc, "method");
            doc.push(Kind::InvalidValue, span, Some("[integrator] method"), msg);
            None
        }
    };
    method.filter(|_| ok)
}
