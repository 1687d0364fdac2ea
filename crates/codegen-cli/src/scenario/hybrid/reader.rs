//! Reading the sections of a hybrid scenario, one function per section: every value and
//! every name that refers to another entry of the file checked, every problem recorded in
//! the document (the order of the sections is the order of the checks).

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use diagnostic::Kind;
use fem_beam::{Beam, BeamSpec};
use hybrid_core::hybrid::{AttachmentKind, ForceKind, Knee, Placement};
use toml::Spanned;
use toml::de::DeValue;

use super::checks::{OnBeam, de, finite, list, mechanism_ref, split, tables, unique};
use super::schema::{
    RawAt, RawAttachment, RawDamper, RawExcitation, RawForceHead, RawInitial, RawMechanism,
    RawOutput, RawRatio, RawSpring, RawStructure, RawStructureDamping,
};
use super::table::time_function;
use super::{
    AttachmentEntry, ExcitationEntry, ForceEntry, HybridScenario, MechanismEntry, PointAt,
    PointEntry, StructureDrawing, StructureEntry, StructureSource, TargetEntry,
};
use crate::scenario::Doc;
use crate::scenario::compare::Comparison;
use crate::scenario::integrator::{IntegratorSpec, check_integrator};
use fem_structure::tables::{read_elements, read_nodes};
use fem_structure::{DampingInput, MatrixFiles};

/// Reads the sections of a hybrid scenario and checks every value and every name that
/// refers to another entry of the file.
pub(crate) fn from_doc(doc: &mut Doc<'_>) -> Option<HybridScenario> {
    doc.check_keys(&[
        "kind",
        "description",
        "beam",
        "structure",
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
    let (beam, beam_span) = beam(doc, &mut ok);
    let structure = structure(doc, beam_span.is_some(), &mut ok);
    let on_beam = OnBeam {
        length: beam.as_ref().map(|(_, b)| b.length()),
        written: beam_span.is_some(),
        structure: doc.root.contains_key("structure"),
    };
    // [[mechanism]]: names first (attachments and forces refer to them).
    let (raw_mechanisms, names) =
        mechanism_tables(doc, beam.is_some() || structure.is_some(), &mut ok);
    let attachments = attachments(doc, &names, &on_beam, &mut ok);
    let mechanisms = mechanisms(doc, &raw_mechanisms, &attachments, &mut ok);
    let forces = forces(doc, &names, &mut ok);
    let excitations = excitations(doc, &names, &on_beam, &mut ok);
    let initial = initial(doc, &on_beam, &mut ok);
    if let (Some(_), Some(s)) = (&initial, &structure) {
        let msg = "[initial] (the static shape of a load at a beam abscissa) is for a [beam]: a [structure] starts at rest";
        doc.push(
            Kind::InvalidValue,
            Some(s.span.clone()),
            Some("[initial]"),
            msg,
        );
        ok = false;
    }
    // [integrator], [output]
    let integrator = doc.section::<IntegratorSpec>("integrator", true);
    let method = integrator
        .as_ref()
        .and_then(|ig| check_integrator(doc, ig.get_ref()));
    let (every, compare, raw_points) = output(doc, beam_span.is_some(), on_beam.structure, &mut ok);
    let points = output_points(doc, &on_beam, raw_points, &mut ok);
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
        structure,
        mechanisms,
        attachments,
        forces,
        excitations,
        initial,
        integrator,
        method,
        every,
        compare,
        points,
        index: doc.index().clone(),
        beam_span,
        initial_x_span,
    })
}

/// Bytes in a GiB.
const GIB: f64 = 1024.0 * 1024.0 * 1024.0;

/// `[beam]`: the beam as written and validated, and where it is written.
#[allow(clippy::type_complexity)]
fn beam(doc: &mut Doc<'_>, ok: &mut bool) -> (Option<(BeamSpec, Beam)>, Option<Range<usize>>) {
    let beam_spec = doc.section::<BeamSpec>("beam", false);
    let beam_span = doc.span(&["beam"]);
    // A beam whose analyses could not fit in this machine is refused before it is built
    // (with or without `--allow-long`; see `crate::budget`).
    let beam_spec = beam_spec.filter(|b| {
        let elements = crate::budget::beam_elements(b.get_ref());
        let bytes = elements * crate::budget::BEAM_BYTES_PER_ELEMENT;
        match crate::budget::machine_memory() {
            Some(machine) if bytes.is_nan() || bytes > machine => {
                let msg = format!(
                    "{elements:.0} beam elements need about {:.1} GiB of memory, more than this machine's {:.1} GiB; use fewer elements",
                    bytes / GIB,
                    machine / GIB
                );
                doc.push(Kind::InvalidValue, beam_span.clone(), Some("[beam]"), msg);
                *ok = false;
                false
            }
            _ => true,
        }
    });
    let beam = match beam_spec {
        Some(b) => match Beam::new_in_physical_range(b.get_ref()) {
            Ok(beam) => Some((b.into_inner(), beam)),
            Err(e) => {
                let msg = e.to_string().replace('\n', "; ");
                doc.push(Kind::InvalidValue, beam_span.clone(), Some("[beam]"), msg);
                *ok = false;
                None
            }
        },
        None => {
            *ok &= !doc.root.contains_key("beam");
            None
        }
    };
    (beam, beam_span)
}

/// `[structure]`: the files of a model from another finite-element program (paths relative to
/// the scenario; `kind = "matrices"`) or the parts given in memory (`kind = "given"`, set by
/// [`crate::scenario::Override::structure`]), its damping and reduction; refused beside a
/// `[beam]`. The matrix files themselves are read when the model is built
/// ([`crate::setup::build()`]); the optional `elements` table (drawing only) is read here
/// with the node table, so that an unknown node or a malformed line is reported (file and
/// line) before any work.
fn structure(doc: &mut Doc<'_>, beam_written: bool, ok: &mut bool) -> Option<StructureEntry> {
    let raw = doc.section::<RawStructure>("structure", false);
    let span = doc.span(&["structure"]);
    let Some(raw) = raw else {
        *ok &= !doc.root.contains_key("structure");
        return None;
    };
    let span = span.unwrap_or(raw.span());
    let raw = raw.into_inner();
    let entity = "[structure]";
    let mut good = true;
    if beam_written {
        let msg = "a scenario has one host structure: a [beam] or a [structure], not both";
        doc.push(Kind::InvalidValue, Some(span.clone()), Some(entity), msg);
        good = false;
    }
    let base = doc.base().to_path_buf();
    let files = [
        ("mass", &raw.mass),
        ("stiffness", &raw.stiffness),
        ("nodes", &raw.nodes),
        ("dofs", &raw.dofs),
    ];
    let given = match raw.kind.get_ref().as_str() {
        "matrices" => {
            for (key, _) in files.iter().filter(|(_, f)| f.is_none()) {
                let msg = format!("missing `{key}` (a file path) for kind = \"matrices\"");
                doc.push(Kind::InvalidValue, Some(span.clone()), Some(entity), msg);
                good = false;
            }
            None
        }
        "given" => match doc.given() {
            Some(parts) => {
                for (key, f) in files.iter() {
                    if let Some(f) = f {
                        let msg = format!(
                            "`{key}`: a given structure's matrices come with it, not from files"
                        );
                        doc.push(Kind::InvalidValue, Some(f.span()), Some(entity), msg);
                        good = false;
                    }
                }
                Some(parts)
            }
            None => {
                let msg = "kind \"given\" is a structure given in memory (Python: Structure.from_matrices and Scenario.load(..., structure=...)); a scenario file names its files with kind = \"matrices\"";
                doc.push(Kind::InvalidValue, Some(raw.kind.span()), Some(entity), msg);
                good = false;
                None
            }
        },
        other => {
            let msg = format!("unknown kind {other:?} (expected \"matrices\")");
            doc.push(Kind::InvalidValue, Some(raw.kind.span()), Some(entity), msg);
            good = false;
            None
        }
    };
    let damping = match raw.damping.as_ref().map(|d| (d.get_ref(), d.span())) {
        None => match &given {
            Some(p) if p.damping.is_some() => DampingInput::Matrix(PathBuf::new()),
            _ => DampingInput::None,
        },
        Some((RawStructureDamping::File(f), span)) => {
            if given.is_some() {
                let msg = "damping: a given structure is damped by its own C (Structure.from_matrices(damping=C)) or by ratios, not by a file";
                doc.push(Kind::InvalidValue, Some(span), Some(entity), msg);
                good = false;
            }
            DampingInput::Matrix(base.join(f))
        }
        Some((RawStructureDamping::Ratios { ratios }, span)) => {
            let valid = |r: &RawRatio| r.mode >= 1 && r.ratio.is_finite() && r.ratio >= 0.0;
            match ratios.as_slice() {
                _ if given.as_ref().is_some_and(|p| p.damping.is_some()) => {
                    let msg = "damping: the given structure has a damping matrix C: give ratios or C, not both";
                    doc.push(Kind::InvalidValue, Some(span), Some(entity), msg);
                    good = false;
                    DampingInput::None
                }
                [a, b] if valid(a) && valid(b) && a.mode != b.mode => {
                    DampingInput::Ratios([(a.mode, a.ratio), (b.mode, b.ratio)])
                }
                _ => {
                    let msg = "damping: give two ratios at two different modes, e.g. { ratios = [{ mode = 1, ratio = 0.003 }, { mode = 2, ratio = 0.003 }] } (ratios finite and >= 0), or a damping matrix file";
                    doc.push(Kind::InvalidValue, Some(span), Some(entity), msg);
                    good = false;
                    DampingInput::None
                }
            }
        }
    };
    let reduction_modes = match &raw.reduction {
        None => None,
        Some(r) => {
            let r = r.get_ref();
            if r.kind.get_ref() != "craig_bampton" {
                let msg = format!(
                    "reduction: unknown kind {:?} (expected \"craig_bampton\")",
                    r.kind.get_ref()
                );
                doc.push(Kind::InvalidValue, Some(r.kind.span()), Some(entity), msg);
                good = false;
            }
            Some(*r.modes.get_ref())
        }
    };
    let path = |p: &Option<Spanned<String>>| {
        p.as_ref()
            .map_or_else(PathBuf::new, |p| base.join(p.get_ref()))
    };
    let drawing = match (&raw.elements, &given) {
        (Some(f), Some(_)) => {
            let msg = "`elements`: a structure given in memory (Structure.from_matrices) is not drawn; the shape plots need a `matrices` structure's files";
            doc.push(Kind::InvalidValue, Some(f.span()), Some(entity), msg);
            good = false;
            None
        }
        (None, _) => None,
        (Some(f), None) => match &raw.nodes {
            Some(nodes) => {
                let read = read_nodes(&base.join(nodes.get_ref())).and_then(|nodes| {
                    let elements = read_elements(&base.join(f.get_ref()), &nodes)?;
                    Ok(StructureDrawing { nodes, elements })
                });
                match read {
                    Ok(d) => Some(d),
                    Err(d) => {
                        doc.diags.0.extend(d.0);
                        good = false;
                        None
                    }
                }
            }
            None => None,
        },
    };
    let source = match given {
        Some(parts) => StructureSource::Given { parts, damping },
        None => StructureSource::Files(MatrixFiles {
            mass: path(&raw.mass),
            stiffness: path(&raw.stiffness),
            nodes: path(&raw.nodes),
            dofs: path(&raw.dofs),
            damping,
        }),
    };
    *ok &= good;
    good.then_some(StructureEntry {
        source,
        reduction_modes,
        drawing,
        span,
    })
}

/// The `[[mechanism]]` tables as written, and their names (unique).
fn mechanism_tables(
    doc: &mut Doc<'_>,
    has_beam: bool,
    ok: &mut bool,
) -> (Vec<RawMechanism>, Vec<String>) {
    let raw_mechanisms: Vec<RawMechanism> = tables(doc, "mechanism")
        .into_iter()
        .filter_map(|v| {
            let m = de::<RawMechanism>(doc, v, "[[mechanism]]");
            *ok &= m.is_some();
            doc.unread_mechanisms += usize::from(m.is_none());
            m
        })
        .collect();
    if raw_mechanisms.is_empty() && !doc.root.contains_key("mechanism") && !has_beam {
        let msg = "a hybrid scenario needs a [beam] or at least one [[mechanism]]";
        doc.push(Kind::MissingField, None, None, msg);
        *ok = false;
    }
    let mut seen = BTreeMap::new();
    for m in &raw_mechanisms {
        unique(doc, &mut seen, &m.name, "mechanism");
    }
    let names: Vec<String> = raw_mechanisms
        .iter()
        .map(|m| m.name.get_ref().clone())
        .collect();
    (raw_mechanisms, names)
}

/// `[[attachment]]`.
fn attachments(
    doc: &mut Doc<'_>,
    names: &[String],
    on_beam: &OnBeam,
    ok: &mut bool,
) -> Vec<AttachmentEntry> {
    let mut attachments = vec![];
    let mut seen = BTreeMap::new();
    for v in tables(doc, "attachment") {
        let v_span = v.span();
        let Some(a) = de::<RawAttachment>(doc, v, "[[attachment]]") else {
            *ok = false;
            continue;
        };
        unique(doc, &mut seen, &a.name, "attachment");
        let entity = format!("attachment \"{}\"", a.name.get_ref());
        let mechanism = mechanism_ref(doc, names, &a.mechanism, &entity);
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
        let (x, node, x_span) = match (&a.x, &a.node) {
            (Some(x), None) => {
                *ok &= on_beam.check(doc, x, &entity);
                (*x.get_ref(), None, x.span())
            }
            (None, Some(n)) => {
                *ok &= on_beam.check_node(doc, n, &entity);
                (0.0, Some(*n.get_ref()), n.span())
            }
            _ => {
                let msg = "give where it is attached: x = ... (a beam abscissa) or node = ... (a node of the [structure])";
                doc.push(Kind::MissingField, Some(v_span.clone()), Some(&entity), msg);
                *ok = false;
                (0.0, None, v_span.clone())
            }
        };
        let direction = roller_direction(doc, &a, kind, &entity, v_span.clone(), ok);
        match (mechanism, kind) {
            (Some(mechanism), Some(kind)) => attachments.push(AttachmentEntry {
                name: a.name.get_ref().clone(),
                mechanism,
                point: a.point.get_ref().clone(),
                kind,
                x,
                node,
                direction,
                point_span: a.point.span(),
                x_span,
            }),
            _ => *ok = false,
        }
    }
    attachments
}

/// The unit vector along a direction `[dx, dy]` written at `d` (`key` names it in the
/// message); `None`, reported at `d`, when it is zero or not finite.
fn unit_direction(
    doc: &mut Doc<'_>,
    d: &Spanned<[f64; 2]>,
    key: &str,
    entity: &str,
) -> Option<[f64; 2]> {
    let [dx, dy] = *d.get_ref();
    let norm = dx.hypot(dy);
    if norm.is_finite() && norm > 0.0 {
        return Some([dx / norm, dy / norm]);
    }
    // As TOML writes them (`nan`, `inf`).
    let toml = |v: f64| {
        if v.is_nan() {
            "nan".into()
        } else {
            v.to_string()
        }
    };
    let msg = format!(
        "{key} must be two finite numbers [dx, dy], not both zero (got [{}, {}])",
        toml(dx),
        toml(dy)
    );
    doc.push(Kind::InvalidValue, Some(d.span()), Some(entity), msg);
    None
}

/// The unit `direction` of a roller at a node (required there, normalised); refused
/// elsewhere (a pin follows both directions, a roller on the beam follows `y`).
fn roller_direction(
    doc: &mut Doc<'_>,
    a: &RawAttachment,
    kind: Option<AttachmentKind>,
    entity: &str,
    span: Range<usize>,
    ok: &mut bool,
) -> Option<[f64; 2]> {
    let roller_at_node = kind == Some(AttachmentKind::Roller) && a.node.is_some();
    match &a.direction {
        None if roller_at_node => {
            let msg = "a roller at a node needs the direction it follows, e.g. direction = [0.0, 1.0] (the node's displacement along it drives the point)";
            doc.push(Kind::MissingField, Some(span), Some(entity), msg);
            *ok = false;
            None
        }
        None => None,
        Some(d) if !roller_at_node => {
            let msg = "direction is for a roller at a node (a pin follows both directions; a roller on the beam follows y)";
            doc.push(Kind::InvalidValue, Some(d.span()), Some(entity), msg);
            *ok = false;
            None
        }
        Some(d) => {
            let unit = unit_direction(doc, d, "direction", entity);
            *ok &= unit.is_some();
            unit
        }
    }
}

/// The values of the `[[mechanism]]` tables (their placements refer to attachments).
fn mechanisms(
    doc: &mut Doc<'_>,
    raw_mechanisms: &[RawMechanism],
    attachments: &[AttachmentEntry],
    ok: &mut bool,
) -> Vec<MechanismEntry> {
    let attachment_names: Vec<String> = attachments.iter().map(|a| a.name.clone()).collect();
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
            *ok = false;
        }
        let origin = match &m.origin {
            Some(o) => {
                if !o.get_ref().iter().all(|x| x.is_finite()) {
                    let msg = "origin must be two finite numbers [x, y] (m)";
                    doc.push(Kind::InvalidValue, Some(o.span()), Some(&entity), msg);
                    *ok = false;
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
                *ok = false;
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
        *ok &= parameters.iter().chain(&initial).all(|p| p.1.is_finite());
        let placement = placement(doc, k, m, &entity, attachments, &attachment_names, ok);
        let model = if model_path.is_absolute() {
            model_path.to_path_buf()
        } else {
            doc.base().join(model_path)
        };
        // The model file is checked now (a regular file within the size limit), read at
        // the setup.
        if !m.model.get_ref().trim().is_empty()
            && let Err(d) = diagnostic::check_input(&model, "model file")
        {
            doc.push(Kind::Io, Some(m.model.span()), Some(&entity), d.to_string());
            *ok = false;
        }
        mechanisms.push(MechanismEntry {
            name: m.name.get_ref().clone(),
            model,
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
    mechanisms
}

/// The `placement` of mechanism `k`: the index of its attachment (one of its own) and how
/// the two-bar chain is placed there.
fn placement(
    doc: &mut Doc<'_>,
    k: usize,
    m: &RawMechanism,
    entity: &str,
    attachments: &[AttachmentEntry],
    attachment_names: &[String],
    ok: &mut bool,
) -> Option<(usize, Placement)> {
    let p = m.placement.as_ref()?;
    let span = p.span();
    let p = p.get_ref();
    if m.origin.is_some() || !m.initial.is_empty() {
        let msg = "placement computes the origin and the initial coordinates: give either placement or origin/initial";
        doc.push(Kind::InvalidValue, Some(span.clone()), Some(entity), msg);
        *ok = false;
    }
    let target = attachment_names
        .iter()
        .position(|n| n == p.attachment.get_ref());
    match target {
        None => {
            let msg = format!(
                "placement: unknown attachment {:?} (attachments: {})",
                p.attachment.get_ref(),
                list(attachment_names)
            );
            doc.push(
                Kind::UnknownName,
                Some(p.attachment.span()),
                Some(entity),
                msg,
            );
            *ok = false;
        }
        Some(a) if attachments[a].mechanism != k => {
            let msg = format!(
                "placement: attachment {:?} belongs to another mechanism",
                p.attachment.get_ref()
            );
            doc.push(
                Kind::InvalidValue,
                Some(p.attachment.span()),
                Some(entity),
                msg,
            );
            *ok = false;
        }
        _ => {}
    }
    let knee = match p.knee.as_ref().map(|k| (k.get_ref().as_str(), k.span())) {
        None | Some(("-", _)) => Some(Knee::Clockwise),
        Some(("+", _)) => Some(Knee::CounterClockwise),
        Some((other, span)) => {
            let msg = format!(
                "placement: knee must be \"+\" (counter-clockwise of the pivot -> point axis) or \"-\" (got {other:?})"
            );
            doc.push(Kind::InvalidValue, Some(span), Some(entity), msg);
            None
        }
    };
    let direction = p
        .pivot_direction
        .as_ref()
        .and_then(|d| unit_direction(doc, d, "placement: pivot_direction", entity));
    if p.pivot.is_some() && (p.pivot_direction.is_some() || p.knee.is_some()) {
        let msg = "placement: pivot_direction and knee go with half_angle_deg, not with pivot";
        doc.push(Kind::InvalidValue, Some(span.clone()), Some(entity), msg);
        *ok = false;
    }
    let how = match (&p.half_angle_deg, &p.pivot) {
        (Some(a), None) => {
            let deg = *a.get_ref();
            if !(deg.is_finite() && deg > 0.0 && deg < 90.0) {
                let msg = format!(
                    "placement: half_angle_deg must be between 0 (the singular position) and 90 degrees (got {deg})"
                );
                doc.push(Kind::InvalidValue, Some(a.span()), Some(entity), msg);
                None
            } else if p.pivot_direction.is_none() {
                if let Some(k) = &p.knee {
                    let msg = "placement: knee goes with pivot_direction (without it the pivot is on the point's line of motion, the knee on the \"-\" side)";
                    doc.push(Kind::InvalidValue, Some(k.span()), Some(entity), msg);
                    None
                } else {
                    Some(Placement::HalfAngle(deg))
                }
            } else {
                // The direction is in the structure's frame here; setup turns it into the
                // mechanism's frame.
                direction
                    .zip(knee)
                    .map(|(direction, knee)| Placement::Along {
                        half_angle_deg: deg,
                        direction,
                        knee,
                    })
            }
        }
        (None, Some(p)) if p.get_ref().iter().all(|x| x.is_finite()) => {
            Some(Placement::Pivot(*p.get_ref()))
        }
        (None, Some(p)) => {
            let msg = "placement: pivot must be two finite numbers [x, y] (m)";
            doc.push(Kind::InvalidValue, Some(p.span()), Some(entity), msg);
            None
        }
        _ => {
            let msg = "placement: give half_angle_deg or pivot (one of them)";
            doc.push(Kind::InvalidValue, Some(span.clone()), Some(entity), msg);
            None
        }
    };
    match (target, how) {
        (Some(a), Some(how)) => Some((a, how)),
        _ => {
            *ok = false;
            None
        }
    }
}

/// `[[force]]`.
fn forces(doc: &mut Doc<'_>, names: &[String], ok: &mut bool) -> Vec<ForceEntry> {
    let mut forces = vec![];
    let mut seen = BTreeMap::new();
    for v in tables(doc, "force") {
        let (head, rest) = split(&v, &["name", "mechanism", "joint", "kind"]);
        let head = Spanned::new(v.span(), DeValue::Table(head));
        let Some(f) = de::<RawForceHead>(doc, head, "[[force]]") else {
            *ok = false;
            continue;
        };
        unique(doc, &mut seen, &f.name, "force");
        let entity = format!("force \"{}\"", f.name.get_ref());
        let mechanism = mechanism_ref(doc, names, &f.mechanism, &entity);
        let kind = force_kind(doc, &f, rest, &entity);
        match (mechanism, kind) {
            (Some(mechanism), Some(kind)) => forces.push(ForceEntry {
                name: f.name.get_ref().clone(),
                mechanism,
                joint: f.joint.get_ref().clone(),
                kind,
                joint_span: f.joint.span(),
            }),
            _ => *ok = false,
        }
    }
    forces
}

/// The force element of a `[[force]]` table: its `kind` and the fields that go with it
/// (`rest`).
fn force_kind<'a>(
    doc: &mut Doc<'a>,
    f: &RawForceHead,
    rest: Spanned<DeValue<'a>>,
    entity: &str,
) -> Option<ForceKind> {
    match f.kind.get_ref().as_str() {
        "generator" => {
            super::generator::generator(doc, &rest, f.kind.span(), entity).map(ForceKind::Generator)
        }
        "damper" => de::<RawDamper>(doc, rest, entity).and_then(|d| {
            let c = *d.c.get_ref();
            if c.is_finite() && c >= 0.0 {
                Some(ForceKind::Damper { c })
            } else {
                let msg = format!("c must be finite and >= 0 (got {c})");
                doc.push(Kind::InvalidValue, Some(d.c.span()), Some(entity), msg);
                None
            }
        }),
        "spring" => de::<RawSpring>(doc, rest, entity).and_then(|s| {
            let k = *s.k.get_ref();
            let q0 = s.q0.as_ref().map_or(0.0, |q| finite(doc, q, entity));
            if k.is_finite() && k >= 0.0 && q0.is_finite() {
                Some(ForceKind::Spring { k, q0 })
            } else {
                if !(k.is_finite() && k >= 0.0) {
                    let msg = format!("k must be finite and >= 0 (got {k})");
                    doc.push(Kind::InvalidValue, Some(s.k.span()), Some(entity), msg);
                }
                None
            }
        }),
        other => {
            let msg = format!(
                "unknown kind {other:?} (expected \"generator\", \"damper\" or \"spring\")"
            );
            doc.push(Kind::InvalidValue, Some(f.kind.span()), Some(entity), msg);
            None
        }
    }
}

/// `[[excitation]]`.
fn excitations(
    doc: &mut Doc<'_>,
    names: &[String],
    on_beam: &OnBeam,
    ok: &mut bool,
) -> Vec<ExcitationEntry> {
    let mut excitations = vec![];
    let mut seen = BTreeMap::new();
    // The first support motion's name and direction: every other must share it.
    let mut base: Option<(String, [f64; 2])> = None;
    for v in tables(doc, "excitation") {
        let (mut taken, rest) = split(&v, &["time", "at"]);
        let Some(e) = de::<RawExcitation>(doc, rest, "[[excitation]]") else {
            *ok = false;
            continue;
        };
        unique(doc, &mut seen, &e.name, "excitation");
        let entity = format!("excitation \"{}\"", e.name.get_ref());
        let Some(at) = taken.remove("at") else {
            let msg = "missing field `at` (e.g. { x = 1.0 }, { mechanism = ..., joint = ... } or \"base\")";
            doc.push(Kind::MissingField, Some(v.span()), Some(&entity), msg);
            *ok = false;
            continue;
        };
        let at_span = at.span();
        let target = excitation_target(doc, at, names, on_beam, &entity).and_then(|t| {
            let (where_, who) = (
                (on_beam, at_span.clone()),
                (e.name.get_ref().as_str(), entity.as_str()),
            );
            base_direction(doc, t, e.direction.as_ref(), where_, &mut base, who)
        });
        let time = match taken.remove("time") {
            None => {
                let msg = "missing field `time` (e.g. { kind = \"harmonic\", frequency_hz = 5.0 })";
                doc.push(Kind::MissingField, Some(v.span()), Some(&entity), msg);
                None
            }
            Some(t) => time_function(doc, t, &entity),
        };
        // A random time carries its level in the PSD; every other kind needs an amplitude.
        let amplitude = match (&e.amplitude, &time) {
            (Some(a), Some(t)) if t.is_random() => {
                let msg = "a random time (white_noise, psd) carries its level in the PSD: remove `amplitude`";
                doc.push(Kind::InvalidValue, Some(a.span()), Some(&entity), msg);
                f64::NAN
            }
            (Some(a), _) => finite(doc, a, &entity),
            (None, Some(t)) if t.is_random() => 1.0,
            (None, Some(_)) => {
                let msg =
                    "missing field `amplitude` (N, or N m on a revolute joint; m/s^2 at \"base\")";
                doc.push(Kind::MissingField, Some(v.span()), Some(&entity), msg);
                f64::NAN
            }
            (None, None) => f64::NAN,
        };
        match (target, time) {
            (Some(target), Some(time)) if amplitude.is_finite() => {
                excitations.push(ExcitationEntry {
                    name: e.name.get_ref().clone(),
                    target,
                    amplitude,
                    time,
                    at_span,
                })
            }
            _ => *ok = false,
        }
    }
    excitations
}

/// A support motion's `direction` (`at = "base"`; normalised, default `[0, 1]`), set on
/// `target`; refused (one line at the key) on any other target, along a beam's axis, or
/// differing from the first support motion's (`base`, recorded here).
fn base_direction(
    doc: &mut Doc<'_>,
    target: TargetEntry,
    direction: Option<&Spanned<[f64; 2]>>,
    (on_beam, at_span): (&OnBeam, Range<usize>),
    base: &mut Option<(String, [f64; 2])>,
    (name, entity): (&str, &str),
) -> Option<TargetEntry> {
    if !matches!(target, TargetEntry::Base { .. }) {
        if let Some(d) = direction {
            let msg = "direction here is for a support motion (at = \"base\"); a force at a node takes it in at = { node = ..., direction = [...] }";
            doc.push(Kind::InvalidValue, Some(d.span()), Some(entity), msg);
            return None;
        }
        return Some(target);
    }
    let (direction, span) = match direction {
        None => ([0.0, 1.0], at_span),
        Some(d) => (unit_direction(doc, d, "direction", entity)?, d.span()),
    };
    if on_beam.written && direction[0] != 0.0 {
        let msg = format!(
            "a beam's supports move along its transverse y only (direction = [0.0, 1.0]), not [{}, {}]: axial support motion needs a [structure]",
            direction[0], direction[1]
        );
        doc.push(Kind::InvalidValue, Some(span), Some(entity), msg);
        return None;
    }
    match base {
        Some((first, f)) if *f != direction => {
            let msg = format!(
                "every support motion shares one direction: [{}, {}] differs from excitation \"{first}\"'s [{}, {}]",
                direction[0], direction[1], f[0], f[1]
            );
            doc.push(Kind::InvalidValue, Some(span), Some(entity), msg);
            return None;
        }
        Some(_) => {}
        None => *base = Some((name.to_string(), direction)),
    }
    Some(TargetEntry::Base { direction })
}

/// An excitation's `at`: `"base"` (the supports), `{ x = ... }` (a beam point) or
/// `{ mechanism = ..., joint = ... }`; `None` (reported at the value) for anything else.
fn excitation_target<'a>(
    doc: &mut Doc<'a>,
    at: Spanned<DeValue<'a>>,
    names: &[String],
    on_beam: &OnBeam,
    entity: &str,
) -> Option<TargetEntry> {
    const FORMS: &str = "at must be \"base\" (the supports), { x = ... } (a beam point), { node = ..., direction = [...] } (a node of a [structure]) or { mechanism = ..., joint = ... }";
    let span = at.span();
    match at.get_ref() {
        DeValue::String(s) if s == "base" => {
            return Some(TargetEntry::Base {
                direction: [0.0, 1.0],
            });
        }
        DeValue::Table(_) => {}
        DeValue::String(s) => {
            let msg = format!("{FORMS}, not {s:?}");
            doc.push(Kind::InvalidValue, Some(span), Some(entity), &msg);
            return None;
        }
        _ => {
            doc.push(Kind::InvalidValue, Some(span), Some(entity), FORMS);
            return None;
        }
    }
    let at = de::<RawAt>(doc, at, entity)?;
    if let Some(n) = &at.node {
        if at.x.is_some() || at.mechanism.is_some() || at.joint.is_some() {
            doc.push(Kind::InvalidValue, Some(span), Some(entity), FORMS);
            return None;
        }
        let Some(d) = &at.direction else {
            let msg = "a force at a node needs its direction in the structure's x-y plane, e.g. at = { node = 5, direction = [1.0, 0.0] }";
            doc.push(Kind::MissingField, Some(span), Some(entity), msg);
            return None;
        };
        let direction = unit_direction(doc, d, "direction", entity)?;
        return on_beam
            .check_node(doc, n, entity)
            .then(|| TargetEntry::Node {
                node: *n.get_ref(),
                direction,
            });
    }
    if let Some(d) = &at.direction {
        let msg = "direction is for a force at a node (at = { node = ..., direction = [...] })";
        doc.push(Kind::InvalidValue, Some(d.span()), Some(entity), msg);
        return None;
    }
    match (&at.x, &at.mechanism, &at.joint) {
        (Some(x), None, None) => on_beam
            .check(doc, x, entity)
            .then(|| TargetEntry::Beam { x: *x.get_ref() }),
        (None, Some(m), Some(j)) => {
            mechanism_ref(doc, names, m, entity).map(|mechanism| TargetEntry::Joint {
                mechanism,
                joint: j.get_ref().clone(),
            })
        }
        _ => {
            doc.push(Kind::InvalidValue, Some(span), Some(entity), FORMS);
            None
        }
    }
}

/// `[initial]`: the displacement, the abscissa and where the abscissa is written.
fn initial(doc: &mut Doc<'_>, on_beam: &OnBeam, ok: &mut bool) -> Option<(f64, f64, Range<usize>)> {
    let raw_initial = doc.section::<RawInitial>("initial", false);
    let initial = raw_initial.and_then(|i| {
        let i = i.into_inner();
        let d = finite(doc, &i.displacement, "[initial] displacement");
        let x_ok = on_beam.check(doc, &i.x, "[initial] x");
        (d.is_finite() && x_ok).then_some((d, *i.x.get_ref(), i.x.span()))
    });
    *ok &= initial.is_some() || !doc.root.contains_key("initial");
    initial
}

/// `[output] points` as written.
type RawPoints = Spanned<Vec<Spanned<String>>>;

/// `[output]`: a row every `every` steps, and the comparison runs (`bare_beam` only with a
/// beam written, `bare_structure` only with a structure written).
fn output(
    doc: &mut Doc<'_>,
    beam_written: bool,
    structure_written: bool,
    ok: &mut bool,
) -> (usize, Vec<Comparison>, Option<RawPoints>) {
    let mut output = doc.section::<RawOutput>("output", false);
    let points = output.as_mut().and_then(|o| o.get_mut().points.take());
    *ok &= output.is_some() || !doc.root.contains_key("output");
    let every = match output.as_ref().and_then(|o| o.get_ref().every.as_ref()) {
        Some(e) if *e.get_ref() == 0 => {
            doc.push(
                Kind::InvalidValue,
                Some(e.span()),
                Some("[output] every"),
                "must be at least 1",
            );
            *ok = false;
            1
        }
        Some(e) => *e.get_ref(),
        None => 10,
    };
    let mut compare = vec![];
    if let Some(list) = output.as_ref().and_then(|o| o.get_ref().compare.as_ref()) {
        // One problem per repeated entry (not per repetition), naming the entry.
        for c in Comparison::ALL {
            let times = list.get_ref().iter().filter(|&&x| x == c).count();
            if times > 1 {
                let msg = match times {
                    2 => format!("{:?} is listed twice", c.key()),
                    n => format!("{:?} is listed {n} times (once at most)", c.key()),
                };
                doc.push(
                    Kind::InvalidValue,
                    Some(list.span()),
                    Some("[output] compare"),
                    msg,
                );
                *ok = false;
            }
        }
        // The bare host's comparison is named after the host: one problem for the wrong one.
        let (wrong, msg) = if beam_written {
            (
                Comparison::BareStructure,
                "\"bare_structure\" is for a [structure]: on a [beam] use \"bare_beam\"",
            )
        } else if structure_written {
            (
                Comparison::BareBeam,
                "\"bare_beam\" is for a [beam]: on a [structure] use \"bare_structure\"",
            )
        } else {
            (Comparison::BareBeam, "\"bare_beam\" needs a [beam]")
        };
        let mut refused = false;
        for c in list.get_ref() {
            let host_missing = *c == wrong
                || (*c == Comparison::BareStructure && !structure_written && !beam_written);
            if compare.contains(c) || (host_missing && refused) {
                continue;
            } else if host_missing {
                refused = true;
                let msg = if *c == wrong {
                    msg
                } else {
                    "\"bare_structure\" needs a [structure]"
                };
                doc.push(
                    Kind::InvalidValue,
                    Some(list.span()),
                    Some("[output] compare"),
                    msg,
                );
                *ok = false;
            } else {
                compare.push(*c);
            }
        }
    }
    (every, compare, points)
}

/// `[output] points`: displacements written as time-history columns, named as `--output`
/// names them: `NODE:DOF` on a `[structure]` (`741:ux`; `ux` or `uy`) or a beam abscissa in
/// m on a `[beam]` (`"0.5"`). Each entry is checked here for its form, its host and (on the
/// beam) its abscissa; a node is looked up when the model is built. Repeats are refused.
fn output_points(
    doc: &mut Doc<'_>,
    on_beam: &OnBeam,
    list: Option<RawPoints>,
    ok: &mut bool,
) -> Vec<PointEntry> {
    let entity = "[output] points";
    let Some(list) = list else {
        return vec![];
    };
    let mut out: Vec<PointEntry> = vec![];
    for p in list.into_inner() {
        let (text, span) = (p.get_ref().trim().to_string(), p.span());
        let at = match text.split_once(':') {
            Some((node, dof)) => {
                let direction = match dof.trim() {
                    "ux" => Some([1.0, 0.0]),
                    "uy" => Some([0.0, 1.0]),
                    _ => None,
                };
                match (node.trim().parse::<u64>(), direction) {
                    (Ok(_), Some(_)) if on_beam.written && !on_beam.structure => {
                        let msg = format!(
                            "{text:?}: the host is a [beam]: give a beam abscissa in m (\"0.5\"), not NODE:DOF"
                        );
                        doc.push(Kind::InvalidValue, Some(span.clone()), Some(entity), msg);
                        None
                    }
                    (Ok(node), Some(direction)) => {
                        let n = Spanned::new(span.clone(), node);
                        on_beam
                            .check_node(doc, &n, entity)
                            .then_some(PointAt::Node { node, direction })
                    }
                    _ => {
                        let msg = format!(
                            "{text:?}: give NODE:DOF with NODE a node id and DOF ux or uy (741:ux)"
                        );
                        doc.push(Kind::InvalidValue, Some(span.clone()), Some(entity), msg);
                        None
                    }
                }
            }
            None => match text.parse::<f64>() {
                Ok(_) if on_beam.structure => {
                    let msg = format!(
                        "{text:?}: the host is a [structure]: name a node as NODE:DOF (\"741:ux\"), not a beam abscissa"
                    );
                    doc.push(Kind::InvalidValue, Some(span.clone()), Some(entity), msg);
                    None
                }
                Ok(x) => {
                    let x = Spanned::new(span.clone(), x);
                    on_beam
                        .check(doc, &x, entity)
                        .then_some(PointAt::Beam { x: *x.get_ref() })
                }
                Err(_) => {
                    let msg = format!(
                        "{text:?}: give a beam abscissa in m (\"0.5\") or NODE:DOF on a [structure] (\"741:ux\")"
                    );
                    doc.push(Kind::InvalidValue, Some(span.clone()), Some(entity), msg);
                    None
                }
            },
        };
        let Some(at) = at else {
            *ok = false;
            continue;
        };
        let name = match at {
            PointAt::Beam { x } => format!("w(x={x})"),
            PointAt::Node { node, direction } => {
                format!("{node}:{}", if direction[0] != 0.0 { "ux" } else { "uy" })
            }
        };
        if out.iter().any(|o| o.name == name) {
            let msg = format!("{name:?} is listed twice");
            doc.push(Kind::InvalidValue, Some(span), Some(entity), msg);
            *ok = false;
            continue;
        }
        out.push(PointEntry { name, at, span });
    }
    out
}
