//! The hybrid scenario (`kind = "hybrid"`), TOML: an optional beam, any number of
//! mechanisms (any model file) placed in the beam's plane, attachments between mechanism
//! points and beam points, force elements on joints and excitations (paper eqs. 44–58 in
//! the general form of `hybrid_core::hybrid`). See `scenarios/two_dampers.toml` and
//! `scenarios/forced_damper.toml` for commented examples.
//!
//! ```toml
//! kind = "hybrid"
//! description = "..."
//! [beam]                     # optional; the damper kind's beam tables (segment, support,
//!                            #   damping, load, distributed_load)
//! [[mechanism]]
//! name = "left"
//! model = "../models/double_bar.toml"   # relative to the scenario file; generated code when
//!                                       #   compiled in, the DAG interpreter otherwise
//! origin = [0.333, -0.2]     # m: the mechanism's ground origin in the beam frame (x along
//!                            #   the beam, y transverse); default [0, 0]
//! angle_deg = 0.0            # mounting angle from the beam's x axis to the mechanism's
//! parameters = { m1 = 0.1 }  # run-time parameter overrides (checked like the damper kind)
//! initial = { q1 = 1.4 }     # coordinate -> value: exact for free coordinates, a guess for
//!                            #   dependent ones (default 0)
//! max_condition = 1e4        # stop when cond(J_d) exceeds this (singular position)
//! # A two-bar chain pinned to a beam point, placed as in the damper kind (instead of
//! # origin and initial): half_angle_deg = 10.0, or pivot = [x, y] from the beam point.
//! # placement = { attachment = "left_pin", half_angle_deg = 10.0 }
//! [[attachment]]
//! name = "left_pin"
//! mechanism = "left"
//! point = "tip"              # a point of the model (not on ground)
//! kind = "pin"               # both directions (2 rows) | "roller": transverse only (1 row)
//! x = 0.333                  # beam abscissa (m): a node or inside an element (eq. 35)
//! [[force]]
//! name = "gen_left"
//! mechanism = "left"
//! joint = "crank"            # a body name: the force acts on its joint's coordinate
//! kind = "generator"         # + the damper kind's [generator] fields (kt, ke, ...)
//!                            # | "damper" with c | "spring" with k and q0
//! [[excitation]]
//! name = "shaker"
//! at = { x = 1.0 }           # transverse beam force, or { mechanism = "left", joint = "crank" }
//! amplitude = 0.5            # N (N m on a revolute joint)
//! time = { kind = "harmonic", frequency_hz = 6.2, phase = 0.0 }
//! # or { kind = "step", at = 0.1 }, { kind = "constant" },
//! # { kind = "table", points = [[0.0, 0.0], [0.1, 1.0]] } or
//! # { kind = "table", file = "force.csv" } (t,value rows, piecewise linear, relative to the
//! #   scenario file; an optional header line)
//! [initial]                  # optional: the beam in the static shape of a point load at x,
//! displacement = 0.001       #   scaled to this displacement there (m); at rest otherwise
//! x = 1.0
//! [integrator]               # as the damper kind: method newmark | hht (alpha), dt, t_end
//! [output]
//! every = 10                 # a CSV row every 10 steps
//! compare = ["generator_disconnected", "bare_beam"]   # comparison runs (none by default):
//!                            #   every generator's circuit open; the beam alone, read at
//!                            #   the attachments' beam points (needs a [beam])
//! ```
//!
//! Loading ([`from_doc`], through the one loader [`super::load`]) checks the file itself:
//! keys, values, names that refer to other entries of the file, the beam, the time
//! tables. The setup stage ([`crate::setup::build`]) then loads the mechanism models and checks what needs
//! them (points, joints, coordinates, parameters, points on ground, over-constraint,
//! placements) and assembles the initial state. Both report every problem at once, each
//! with file:line:column and the entity.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use diagnostic::{Diagnostic, Diagnostics, Kind, LineIndex};
use fem_beam::{Beam, BeamSpec, TimeFunction};
use hybrid_core::damper::Method;
use hybrid_core::generator::GeneratorSpec;
use hybrid_core::hybrid::{AttachmentKind, ForceKind, Placement};
use serde::Deserialize;
use serde::de::DeserializeOwned;
use toml::Spanned;
use toml::de::{DeTable, DeValue, ValueDeserializer};

use super::Doc;
use super::compare::Comparison;
use super::integrator::{IntegratorSpec, check_integrator};

/// One `[[mechanism]]`, checked against the file (names not yet against its model).
#[derive(Clone, Debug, PartialEq)]
pub struct MechanismEntry {
    /// Its name.
    pub name: String,
    /// The model file, resolved against the scenario's directory.
    pub model: PathBuf,
    /// Ground origin in the beam frame (m); replaced by the placement when there is one.
    pub origin: [f64; 2],
    /// Mounting angle (rad).
    pub angle: f64,
    /// Run-time parameter overrides, with where each is written.
    pub parameters: Vec<(String, f64, Range<usize>)>,
    /// Initial coordinates by name, with where each is written.
    pub initial: Vec<(String, f64, Range<usize>)>,
    /// Stop when cond(J_d) exceeds this.
    pub max_condition: f64,
    /// A two-bar placement for an attachment (index into the attachments).
    pub placement: Option<(usize, Placement)>,
    pub(crate) span: Range<usize>,
    pub(crate) model_span: Range<usize>,
    pub(crate) placement_span: Option<Range<usize>>,
}

/// One `[[attachment]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct AttachmentEntry {
    /// Its name.
    pub name: String,
    /// Index of the mechanism.
    pub mechanism: usize,
    /// Name of the mechanism point.
    pub point: String,
    /// Pin or roller.
    pub kind: AttachmentKind,
    /// Beam abscissa (m).
    pub x: f64,
    pub(crate) point_span: Range<usize>,
    pub(crate) x_span: Range<usize>,
}

/// One `[[force]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct ForceEntry {
    /// Its name.
    pub name: String,
    /// Index of the mechanism.
    pub mechanism: usize,
    /// Body name whose joint carries it.
    pub joint: String,
    /// What it is.
    pub kind: ForceKind,
    pub(crate) joint_span: Range<usize>,
}

/// Where an `[[excitation]]` acts, as written.
#[derive(Clone, Debug, PartialEq)]
pub enum TargetEntry {
    /// A transverse force at beam abscissa `x` (m).
    Beam {
        /// The abscissa.
        x: f64,
    },
    /// A torque or force on a joint.
    Joint {
        /// Index of the mechanism.
        mechanism: usize,
        /// Body name whose joint it drives.
        joint: String,
    },
}

/// One `[[excitation]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct ExcitationEntry {
    /// Its name.
    pub name: String,
    /// Where it acts.
    pub target: TargetEntry,
    /// Amplitude (N or N m).
    pub amplitude: f64,
    /// Time dependence (a table file already read).
    pub time: TimeFunction,
    pub(crate) at_span: Range<usize>,
}

/// A loaded and checked hybrid scenario (models not loaded yet: [`crate::setup::build`]).
#[derive(Clone, Debug)]
pub struct HybridScenario {
    /// The scenario file as given.
    pub path: PathBuf,
    /// Free text.
    pub description: Option<String>,
    /// The beam as written and validated.
    pub beam: Option<(BeamSpec, Beam)>,
    /// The mechanisms.
    pub mechanisms: Vec<MechanismEntry>,
    /// The attachments.
    pub attachments: Vec<AttachmentEntry>,
    /// The force elements.
    pub forces: Vec<ForceEntry>,
    /// The excitations.
    pub excitations: Vec<ExcitationEntry>,
    /// Initial beam deflection: `(displacement, x)`.
    pub initial: Option<(f64, f64)>,
    /// `[integrator]` as read.
    pub integrator: IntegratorSpec,
    /// The scheme.
    pub method: Method,
    /// A CSV row every `every` steps.
    pub every: usize,
    /// The comparison runs beside the run as described (`[output] compare`; none by
    /// default, `["generator_disconnected"]` for the damper preset).
    pub compare: Vec<Comparison>,
    pub(crate) index: LineIndex,
    pub(crate) beam_span: Option<Range<usize>>,
    pub(crate) initial_x_span: Option<Range<usize>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMechanism {
    name: Spanned<String>,
    model: Spanned<String>,
    #[serde(default)]
    origin: Option<Spanned<[f64; 2]>>,
    #[serde(default)]
    angle_deg: Option<Spanned<f64>>,
    #[serde(default)]
    parameters: BTreeMap<String, Spanned<f64>>,
    #[serde(default)]
    initial: BTreeMap<String, Spanned<f64>>,
    #[serde(default)]
    max_condition: Option<Spanned<f64>>,
    #[serde(default)]
    placement: Option<Spanned<RawPlacement>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlacement {
    attachment: Spanned<String>,
    #[serde(default)]
    half_angle_deg: Option<Spanned<f64>>,
    #[serde(default)]
    pivot: Option<Spanned<[f64; 2]>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAttachment {
    name: Spanned<String>,
    mechanism: Spanned<String>,
    point: Spanned<String>,
    #[serde(default)]
    kind: Option<Spanned<String>>,
    x: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawForceHead {
    name: Spanned<String>,
    mechanism: Spanned<String>,
    joint: Spanned<String>,
    kind: Spanned<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDamper {
    c: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpring {
    k: Spanned<f64>,
    #[serde(default)]
    q0: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawExcitation {
    name: Spanned<String>,
    at: Spanned<RawAt>,
    amplitude: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAt {
    #[serde(default)]
    x: Option<Spanned<f64>>,
    #[serde(default)]
    mechanism: Option<Spanned<String>>,
    #[serde(default)]
    joint: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawInitial {
    displacement: Spanned<f64>,
    x: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawOutput {
    #[serde(default)]
    every: Option<Spanned<usize>>,
    #[serde(default)]
    compare: Option<Spanned<Vec<Comparison>>>,
}

/// Deserializes one value on its own; a malformed one is reported (at the serde error's
/// span) and `None`.
fn de<'a, T: DeserializeOwned>(
    doc: &mut Doc<'a>,
    v: Spanned<DeValue<'a>>,
    entity: &str,
) -> Option<T> {
    let span = v.span();
    match T::deserialize(ValueDeserializer::from(v)) {
        Ok(t) => Some(t),
        Err(e) => {
            let at = e.span().or(Some(span));
            doc.push(Kind::Syntax, at, Some(entity), e.message().trim());
            None
        }
    }
}

/// The tables of the array of tables `[[key]]` (empty when absent; reported when `key` is
/// something else).
fn tables<'a>(doc: &mut Doc<'a>, key: &str) -> Vec<Spanned<DeValue<'a>>> {
    let Some(v) = doc.root.get(key) else {
        return vec![];
    };
    match v.get_ref() {
        DeValue::Array(items)
            if items
                .iter()
                .all(|i| matches!(i.get_ref(), DeValue::Table(_))) =>
        {
            items.iter().cloned().collect()
        }
        _ => {
            let span = v.span();
            let msg = format!("must be an array of tables, written [[{key}]]");
            doc.push(Kind::Syntax, Some(span), Some(&format!("[[{key}]]")), msg);
            vec![]
        }
    }
}

/// The entries of a table value with `keys` taken out (as a table) and the rest.
fn split<'a>(v: &Spanned<DeValue<'a>>, keys: &[&str]) -> (DeTable<'a>, Spanned<DeValue<'a>>) {
    let mut taken = DeTable::new();
    let mut rest = DeTable::new();
    if let DeValue::Table(t) = v.get_ref() {
        for (k, x) in t.iter() {
            if keys.contains(&k.get_ref().as_ref()) {
                taken.insert(k.clone(), x.clone());
            } else {
                rest.insert(k.clone(), x.clone());
            }
        }
    }
    (taken, Spanned::new(v.span(), DeValue::Table(rest)))
}

/// Records a duplicate name.
fn unique(doc: &mut Doc<'_>, seen: &mut BTreeMap<String, ()>, name: &Spanned<String>, what: &str) {
    if seen.insert(name.get_ref().clone(), ()).is_some() {
        let entity = format!("{what} \"{}\"", name.get_ref());
        let msg = format!("a {what} of this name is already defined");
        doc.push(Kind::Duplicate, Some(name.span()), Some(&entity), msg);
    }
}

/// The index of the mechanism `name`, or a recorded problem.
fn mechanism_ref(
    doc: &mut Doc<'_>,
    names: &[String],
    name: &Spanned<String>,
    entity: &str,
) -> Option<usize> {
    let k = names.iter().position(|n| n == name.get_ref());
    if k.is_none() {
        let msg = format!(
            "unknown mechanism {:?} (mechanisms: {})",
            name.get_ref(),
            list(names)
        );
        doc.push(Kind::UnknownName, Some(name.span()), Some(entity), msg);
    }
    k
}

/// The names, comma-separated (`none` when there is none).
pub(crate) fn list(names: &[String]) -> String {
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}

/// A finite value, or a recorded problem.
fn finite(doc: &mut Doc<'_>, v: &Spanned<f64>, entity: &str) -> f64 {
    let x = *v.get_ref();
    if !x.is_finite() {
        let msg = format!("must be a finite number (got {x})");
        doc.push(Kind::InvalidValue, Some(v.span()), Some(entity), msg);
    }
    x
}

/// Reads the sections of a hybrid scenario and checks every value and every name that
/// refers to another entry of the file.
pub(crate) fn from_doc(doc: &mut Doc<'_>) -> Option<HybridScenario> {
    doc.check_keys(&[
        "kind",
        "description",
        "beam",
        "mechanism",
        "attachment",
        "force",
        "excitation",
        "initial",
        "integrator",
        "output",
    ]);
    let mut ok = true;
    let description = doc.section::<String>("description", false);
    let beam_spec = doc.section::<BeamSpec>("beam", false);
    let beam_span = doc.span(&["beam"]);
    let beam = match beam_spec {
        Some(b) => match Beam::new_in_physical_range(b.get_ref()) {
            Ok(beam) => Some((b.into_inner(), beam)),
            Err(e) => {
                let msg = e.to_string().replace('\n', "; ");
                doc.push(Kind::InvalidValue, beam_span.clone(), Some("[beam]"), msg);
                ok = false;
                None
            }
        },
        None => {
            ok &= !doc.root.contains_key("beam");
            None
        }
    };
    let length = beam.as_ref().map(|(_, b)| b.length());
    let on_beam = |doc: &mut Doc<'_>, x: &Spanned<f64>, entity: &str| -> bool {
        let v = *x.get_ref();
        match length {
            Some(l) if v.is_finite() && v >= 0.0 && v <= l * (1.0 + 1e-12) => true,
            Some(l) => {
                let msg = format!("must lie on the beam, 0 to {l} m (got {v})");
                doc.push(Kind::InvalidValue, Some(x.span()), Some(entity), msg);
                false
            }
            None if beam_span.is_some() => false, // the beam's own problem is reported
            None => {
                let msg = "there is no [beam] to attach to or to load";
                doc.push(Kind::InvalidValue, Some(x.span()), Some(entity), msg);
                false
            }
        }
    };

    // [[mechanism]]: names first (attachments and forces refer to them).
    let raw_mechanisms: Vec<RawMechanism> = tables(doc, "mechanism")
        .into_iter()
        .filter_map(|v| {
            let m = de::<RawMechanism>(doc, v, "[[mechanism]]");
            ok &= m.is_some();
            m
        })
        .collect();
    if raw_mechanisms.is_empty() && !doc.root.contains_key("mechanism") && beam.is_none() {
        let msg = "a hybrid scenario needs a [beam] or at least one [[mechanism]]";
        doc.push(Kind::MissingField, None, None, msg);
        ok = false;
    }
    let mut seen = BTreeMap::new();
    for m in &raw_mechanisms {
        unique(doc, &mut seen, &m.name, "mechanism");
    }
    let names: Vec<String> = raw_mechanisms
        .iter()
        .map(|m| m.name.get_ref().clone())
        .collect();

    // [[attachment]]
    let mut attachments = vec![];
    let mut seen = BTreeMap::new();
    for v in tables(doc, "attachment") {
        let Some(a) = de::<RawAttachment>(doc, v, "[[attachment]]") else {
            ok = false;
            continue;
        };
        unique(doc, &mut seen, &a.name, "attachment");
        let entity = format!("attachment \"{}\"", a.name.get_ref());
        let mechanism = mechanism_ref(doc, &names, &a.mechanism, &entity);
        let kind = match a.kind.as_ref().map(|k| (k.get_ref().as_str(), k.span())) {
            None | Some(("pin", _)) => Some(AttachmentKind::Pin),
            Some(("roller", _)) => Some(AttachmentKind::Roller),
            Some((other, span)) => {
                let msg = format!("unknown kind {other:?} (expected \"pin\" or \"roller\")");
                doc.push(Kind::InvalidValue, Some(span), Some(&entity), msg);
                None
            }
        };
        // Kept when x is wrong (reported), so that placements still find it.
        ok &= on_beam(doc, &a.x, &entity);
        match (mechanism, kind) {
            (Some(mechanism), Some(kind)) => attachments.push(AttachmentEntry {
                name: a.name.get_ref().clone(),
                mechanism,
                point: a.point.get_ref().clone(),
                kind,
                x: *a.x.get_ref(),
                point_span: a.point.span(),
                x_span: a.x.span(),
            }),
            _ => ok = false,
        }
    }
    let attachment_names: Vec<String> = attachments.iter().map(|a| a.name.clone()).collect();

    // The mechanisms' values.
    let mut mechanisms = vec![];
    for (k, m) in raw_mechanisms.iter().enumerate() {
        let entity = format!("mechanism \"{}\"", m.name.get_ref());
        let model_path = Path::new(m.model.get_ref());
        if m.model.get_ref().trim().is_empty() {
            doc.push(
                Kind::InvalidValue,
                Some(m.model.span()),
                Some(&entity),
                "empty model path",
            );
            ok = false;
        }
        let origin = match &m.origin {
            Some(o) => {
                if !o.get_ref().iter().all(|x| x.is_finite()) {
                    let msg = "origin must be two finite numbers [x, y] (m)";
                    doc.push(Kind::InvalidValue, Some(o.span()), Some(&entity), msg);
                    ok = false;
                }
                *o.get_ref()
            }
            None => [0.0, 0.0],
        };
        let angle = m
            .angle_deg
            .as_ref()
            .map_or(0.0, |a| finite(doc, a, &entity))
            .to_radians();
        let max_condition = match &m.max_condition {
            Some(c) if !(c.get_ref().is_finite() && *c.get_ref() > 1.0) => {
                let msg = format!("max_condition must be > 1 (got {})", c.get_ref());
                doc.push(Kind::InvalidValue, Some(c.span()), Some(&entity), msg);
                ok = false;
                1e4
            }
            Some(c) => *c.get_ref(),
            None => 1e4,
        };
        let named = |doc: &mut Doc<'_>, map: &BTreeMap<String, Spanned<f64>>| {
            map.iter()
                .map(|(n, v)| {
                    (
                        n.clone(),
                        finite(doc, v, &format!("{entity}: {n}")),
                        v.span(),
                    )
                })
                .collect::<Vec<_>>()
        };
        let parameters = named(doc, &m.parameters);
        let initial = named(doc, &m.initial);
        ok &= parameters.iter().chain(&initial).all(|p| p.1.is_finite());
        let placement = match &m.placement {
            None => None,
            Some(p) => {
                let span = p.span();
                let p = p.get_ref();
                if m.origin.is_some() || !m.initial.is_empty() {
                    let msg = "placement computes the origin and the initial coordinates: give either placement or origin/initial";
                    doc.push(Kind::InvalidValue, Some(span.clone()), Some(&entity), msg);
                    ok = false;
                }
                let target = attachment_names
                    .iter()
                    .position(|n| n == p.attachment.get_ref());
                match target {
                    None => {
                        let msg = format!(
                            "placement: unknown attachment {:?} (attachments: {})",
                            p.attachment.get_ref(),
                            list(&attachment_names)
                        );
                        doc.push(
                            Kind::UnknownName,
                            Some(p.attachment.span()),
                            Some(&entity),
                            msg,
                        );
                        ok = false;
                    }
                    Some(a) if attachments[a].mechanism != k => {
                        let msg = format!(
                            "placement: attachment {:?} belongs to another mechanism",
                            p.attachment.get_ref()
                        );
                        doc.push(
                            Kind::InvalidValue,
                            Some(p.attachment.span()),
                            Some(&entity),
                            msg,
                        );
                        ok = false;
                    }
                    _ => {}
                }
                let how = match (&p.half_angle_deg, &p.pivot) {
                    (Some(a), None) => {
                        let deg = *a.get_ref();
                        if deg.is_finite() && deg > 0.0 && deg < 90.0 {
                            Some(Placement::HalfAngle(deg))
                        } else {
                            let msg = format!(
                                "placement: half_angle_deg must be between 0 (the singular position) and 90 degrees (got {deg})"
                            );
                            doc.push(Kind::InvalidValue, Some(a.span()), Some(&entity), msg);
                            None
                        }
                    }
                    (None, Some(p)) if p.get_ref().iter().all(|x| x.is_finite()) => {
                        Some(Placement::Pivot(*p.get_ref()))
                    }
                    (None, Some(p)) => {
                        let msg = "placement: pivot must be two finite numbers [x, y] (m)";
                        doc.push(Kind::InvalidValue, Some(p.span()), Some(&entity), msg);
                        None
                    }
                    _ => {
                        let msg = "placement: give half_angle_deg or pivot (one of them)";
                        doc.push(Kind::InvalidValue, Some(span.clone()), Some(&entity), msg);
                        None
                    }
                };
                match (target, how) {
                    (Some(a), Some(how)) => Some((a, how)),
                    _ => {
                        ok = false;
                        None
                    }
                }
            }
        };
        mechanisms.push(MechanismEntry {
            name: m.name.get_ref().clone(),
            model: if model_path.is_absolute() {
                model_path.to_path_buf()
            } else {
                doc.base().join(model_path)
            },
            origin,
            angle,
            parameters,
            initial,
            max_condition,
            placement,
            span: m.name.span(),
            model_span: m.model.span(),
            placement_span: m.placement.as_ref().map(|p| p.span()),
        });
    }

    // [[force]]
    let mut forces = vec![];
    let mut seen = BTreeMap::new();
    for v in tables(doc, "force") {
        let (head, rest) = split(&v, &["name", "mechanism", "joint", "kind"]);
        let head = Spanned::new(v.span(), DeValue::Table(head));
        let Some(f) = de::<RawForceHead>(doc, head, "[[force]]") else {
            ok = false;
            continue;
        };
        unique(doc, &mut seen, &f.name, "force");
        let entity = format!("force \"{}\"", f.name.get_ref());
        let mechanism = mechanism_ref(doc, &names, &f.mechanism, &entity);
        let kind = match f.kind.get_ref().as_str() {
            "generator" => de::<GeneratorSpec>(doc, rest.clone(), &entity).and_then(|g| {
                let problems = g.problems();
                for e in &problems {
                    // At the field it is about when that is written, at `kind` otherwise.
                    let span = e
                        .field()
                        .and_then(|field| rest.get_ref().get(field.name()))
                        .map_or(f.kind.span(), |v| v.span());
                    doc.push(Kind::InvalidValue, Some(span), Some(&entity), e.to_string());
                }
                problems.is_empty().then_some(ForceKind::Generator(g))
            }),
            "damper" => de::<RawDamper>(doc, rest, &entity).and_then(|d| {
                let c = *d.c.get_ref();
                if c.is_finite() && c >= 0.0 {
                    Some(ForceKind::Damper { c })
                } else {
                    let msg = format!("c must be finite and >= 0 (got {c})");
                    doc.push(Kind::InvalidValue, Some(d.c.span()), Some(&entity), msg);
                    None
                }
            }),
            "spring" => de::<RawSpring>(doc, rest, &entity).and_then(|s| {
                let k = *s.k.get_ref();
                let q0 = s.q0.as_ref().map_or(0.0, |q| finite(doc, q, &entity));
                if k.is_finite() && k >= 0.0 && q0.is_finite() {
                    Some(ForceKind::Spring { k, q0 })
                } else {
                    if !(k.is_finite() && k >= 0.0) {
                        let msg = format!("k must be finite and >= 0 (got {k})");
                        doc.push(Kind::InvalidValue, Some(s.k.span()), Some(&entity), msg);
                    }
                    None
                }
            }),
            other => {
                let msg = format!(
                    "unknown kind {other:?} (expected \"generator\", \"damper\" or \"spring\")"
                );
                doc.push(Kind::InvalidValue, Some(f.kind.span()), Some(&entity), msg);
                None
            }
        };
        match (mechanism, kind) {
            (Some(mechanism), Some(kind)) => forces.push(ForceEntry {
                name: f.name.get_ref().clone(),
                mechanism,
                joint: f.joint.get_ref().clone(),
                kind,
                joint_span: f.joint.span(),
            }),
            _ => ok = false,
        }
    }

    // [[excitation]]
    let mut excitations = vec![];
    let mut seen = BTreeMap::new();
    for v in tables(doc, "excitation") {
        let (mut time, rest) = split(&v, &["time"]);
        let Some(e) = de::<RawExcitation>(doc, rest, "[[excitation]]") else {
            ok = false;
            continue;
        };
        unique(doc, &mut seen, &e.name, "excitation");
        let entity = format!("excitation \"{}\"", e.name.get_ref());
        let amplitude = finite(doc, &e.amplitude, &entity);
        let at = e.at.get_ref();
        let target = match (&at.x, &at.mechanism, &at.joint) {
            (Some(x), None, None) => {
                on_beam(doc, x, &entity).then(|| TargetEntry::Beam { x: *x.get_ref() })
            }
            (None, Some(m), Some(j)) => {
                mechanism_ref(doc, &names, m, &entity).map(|mechanism| TargetEntry::Joint {
                    mechanism,
                    joint: j.get_ref().clone(),
                })
            }
            _ => {
                let msg =
                    "at must be { x = ... } (a beam point) or { mechanism = ..., joint = ... }";
                doc.push(Kind::InvalidValue, Some(e.at.span()), Some(&entity), msg);
                None
            }
        };
        let time = match time.remove("time") {
            None => {
                let msg = "missing field `time` (e.g. { kind = \"harmonic\", frequency_hz = 5.0 })";
                doc.push(Kind::MissingField, Some(v.span()), Some(&entity), msg);
                None
            }
            Some(t) => time_function(doc, t, &entity),
        };
        match (target, time) {
            (Some(target), Some(time)) if amplitude.is_finite() => {
                excitations.push(ExcitationEntry {
                    name: e.name.get_ref().clone(),
                    target,
                    amplitude,
                    time,
                    at_span: e.at.span(),
                })
            }
            _ => ok = false,
        }
    }

    // [initial]
    let raw_initial = doc.section::<RawInitial>("initial", false);
    let initial = raw_initial.and_then(|i| {
        let i = i.into_inner();
        let d = finite(doc, &i.displacement, "[initial] displacement");
        let x_ok = on_beam(doc, &i.x, "[initial] x");
        (d.is_finite() && x_ok).then_some((d, *i.x.get_ref(), i.x.span()))
    });
    ok &= initial.is_some() || !doc.root.contains_key("initial");

    // [integrator], [output]
    let integrator = doc.section::<IntegratorSpec>("integrator", true);
    let method = integrator
        .as_ref()
        .and_then(|ig| check_integrator(doc, ig.get_ref()));
    let output = doc.section::<RawOutput>("output", false);
    ok &= output.is_some() || !doc.root.contains_key("output");
    let every = match output.as_ref().and_then(|o| o.get_ref().every.as_ref()) {
        Some(e) if *e.get_ref() == 0 => {
            doc.push(
                Kind::InvalidValue,
                Some(e.span()),
                Some("[output] every"),
                "must be at least 1",
            );
            ok = false;
            1
        }
        Some(e) => *e.get_ref(),
        None => 10,
    };
    let mut compare = vec![];
    if let Some(list) = output.as_ref().and_then(|o| o.get_ref().compare.as_ref()) {
        for c in list.get_ref() {
            if compare.contains(c) {
                let msg = format!("{:?} is listed twice", c.key());
                doc.push(
                    Kind::InvalidValue,
                    Some(list.span()),
                    Some("[output] compare"),
                    msg,
                );
                ok = false;
            } else if *c == Comparison::BareBeam && beam_span.is_none() {
                let msg = "\"bare_beam\" needs a [beam]";
                doc.push(
                    Kind::InvalidValue,
                    Some(list.span()),
                    Some("[output] compare"),
                    msg,
                );
                ok = false;
            } else {
                compare.push(*c);
            }
        }
    }
    let (integrator, method) = (integrator?.into_inner(), method?);
    if !ok {
        return None;
    }
    let (initial, initial_x_span) = match initial {
        Some((d, x, span)) => (Some((d, x)), Some(span)),
        None => (None, None),
    };
    Some(HybridScenario {
        path: PathBuf::from(doc.file()),
        description: description.map(Spanned::into_inner),
        beam,
        mechanisms,
        attachments,
        forces,
        excitations,
        initial,
        integrator,
        method,
        every,
        compare,
        index: doc.index().clone(),
        beam_span,
        initial_x_span,
    })
}

/// An excitation's `time`: a [`TimeFunction`] as fem-beam reads it, or
/// `{ kind = "table", file = "..." }` read from a CSV file of `t,value` rows.
fn time_function<'a>(
    doc: &mut Doc<'a>,
    t: Spanned<DeValue<'a>>,
    entity: &str,
) -> Option<TimeFunction> {
    let (mut file, rest) = split(&t, &["file"]);
    let time = match file.remove("file") {
        Some(f) => {
            let span = f.span();
            let name = de::<String>(doc, f, entity)?;
            let (kind, extra) = split(&rest, &["kind"]);
            let is_table = kind
                .get("kind")
                .is_some_and(|k| matches!(k.get_ref(), DeValue::String(s) if s == "table"));
            let extra_empty = matches!(extra.get_ref(), DeValue::Table(t) if t.is_empty());
            if !is_table || !extra_empty {
                let msg = "time: `file` goes with kind = \"table\" and nothing else";
                doc.push(Kind::InvalidValue, Some(span), Some(entity), msg);
                return None;
            }
            let path = doc.base().join(&name);
            match read_table(&path) {
                Ok(points) => TimeFunction::Table { points },
                Err(d) => {
                    doc.diags.0.extend(d.0);
                    return None;
                }
            }
        }
        None => de::<TimeFunction>(doc, t.clone(), entity)?,
    };
    let problems = time.problems();
    for e in &problems {
        doc.push(
            Kind::InvalidValue,
            Some(t.span()),
            Some(entity),
            format!("time: {e}"),
        );
    }
    problems.is_empty().then_some(time)
}

/// Reads a time table: `t,value` rows (a header line is allowed), every bad row reported
/// with the table file's name and line.
pub fn read_table(path: &Path) -> Result<Vec<[f64; 2]>, Diagnostics> {
    let file = path.display().to_string();
    let text = std::fs::read(path).map_err(|e| {
        Diagnostics::from(Diagnostic::new(
            Kind::Io,
            file.clone(),
            format!("cannot read the time table: {e}"),
        ))
    })?;
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_slice());
    let mut points: Vec<[f64; 2]> = vec![];
    let mut diags = vec![];
    for (k, record) in reader.records().enumerate() {
        let bad = |line: Option<u64>, msg: String| {
            Diagnostic::new(Kind::InvalidValue, file.clone(), msg).at_line(line.map(|l| l as usize))
        };
        let record = match record {
            Ok(r) => r,
            Err(e) => {
                let line = e.position().map(|p| p.line());
                diags.push(bad(line, format!("cannot read the row: {e}")));
                continue;
            }
        };
        let line = record.position().map(|p| p.line());
        if record.iter().all(str::is_empty) {
            continue;
        }
        let numbers: Vec<Option<f64>> = record.iter().map(|c| c.parse::<f64>().ok()).collect();
        if k == 0 && numbers.iter().all(Option::is_none) {
            continue; // a header line
        }
        match numbers[..] {
            [Some(t), Some(v)] if t.is_finite() && v.is_finite() => {
                if let Some(&[prev, _]) = points.last() {
                    if t <= prev {
                        diags.push(bad(
                            line,
                            format!(
                                "time {t} does not come after {prev} (times must increase strictly)"
                            ),
                        ));
                        continue;
                    }
                }
                points.push([t, v]);
            }
            _ => diags.push(bad(
                line,
                format!(
                    "expected two finite numbers `t,value`, got {:?}",
                    diagnostic::truncate(&record.iter().collect::<Vec<_>>().join(","), 60)
                ),
            )),
        }
    }
    if diags.is_empty() && points.is_empty() {
        diags.push(Diagnostic::new(
            Kind::InvalidValue,
            file,
            "the time table has no `t,value` row",
        ));
    }
    if diags.is_empty() {
        Ok(points)
    } else {
        Err(Diagnostics(diags))
    }
}

impl HybridScenario {
    /// Parses and checks hybrid scenario text; `path` names the file in messages and is the
    /// base of relative paths.
    pub fn from_str(text: &str, path: &Path) -> Result<HybridScenario, Diagnostics> {
        match super::parse(text, path)? {
            super::Scenario::Hybrid(s) => Ok(*s),
            _ => Err(Diagnostic::new(
                Kind::Unsupported,
                path.display().to_string(),
                "not a `kind = \"hybrid\"` scenario",
            )
            .into()),
        }
    }

    /// A problem of this scenario at a span of its file, about `entity`.
    pub(crate) fn at(
        &self,
        kind: Kind,
        span: Option<&Range<usize>>,
        entity: &str,
        msg: impl Into<String>,
    ) -> Diagnostic {
        let d = Diagnostic::new(kind, self.path.display().to_string(), msg).entity(entity);
        match span {
            Some(s) => d.at_offset(&self.index, s.start),
            None => d,
        }
    }
}
