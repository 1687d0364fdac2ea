//! The damper kind as a preset of the hybrid scenario: the `kind = "damper"` tables (one
//! `[mechanism]` pinned to one beam point, one `[generator]` on its crank, `[initial]` at
//! the same point) rewritten into the hybrid tables they mean, before the one hybrid reader
//! ([`super::hybrid`]) checks them. Every value keeps its span in the damper file, so a
//! problem is still reported at the damper file's line and column.
//!
//! ```text
//! [mechanism] model, parameters,        -> [[mechanism]] name = "damper", model, parameters,
//!             max_condition,                 max_condition, placement = { attachment = "pin",
//!             half_angle_deg | pivot                       half_angle_deg | pivot }
//! [mechanism] point, x                  -> [[attachment]] name = "pin", mechanism = "damper",
//!                                            kind = "pin", point, x
//! [generator] ...                       -> [[force]] name = "generator", mechanism = "damper",
//!   + [mechanism] generator_joint             joint = generator_joint, kind = "generator", ...
//! [initial] displacement                -> [initial] displacement, x = [mechanism] x
//! [output] every, compare               -> [output] every, compare (default
//!   (compare_without_generator)              ["generator_disconnected"])
//! [[excitation]] ...                    -> [[excitation]] ... (as written; then `[initial]`
//!                                            may be left out: the beam starts at rest)
//! ```

use std::borrow::Cow;
use std::ops::Range;

use diagnostic::Kind;
use toml::Spanned;
use toml::de::{DeArray, DeTable, DeValue};

use super::Doc;

/// The name the preset gives the paper's double bar (columns, messages, `frf --output
/// damper/crank`).
pub const MECHANISM: &str = "damper";
/// The name of the pin between the mechanism's point and the beam point.
pub const ATTACHMENT: &str = "pin";
/// The name of the generator force element.
pub const GENERATOR: &str = "generator";

/// Where the damper kind's fields go in the hybrid form it expands to, as `--set` paths:
/// (damper path, hybrid path), a path below either moving with it (`generator.kt` is
/// `force[0].kt`). The expansion (`expand`) moves the fields by this table, and a `--set`
/// path of the other kind is answered from it ([`translate`]); fields not listed
/// (`beam`, `initial.displacement`, `integrator`, `output`, `[[excitation]]`) keep their path.
pub const PATHS: [(&str, &str); 9] = [
    ("mechanism.model", "mechanism[0].model"),
    ("mechanism.parameters", "mechanism[0].parameters"),
    ("mechanism.max_condition", "mechanism[0].max_condition"),
    (
        "mechanism.half_angle_deg",
        "mechanism[0].placement.half_angle_deg",
    ),
    ("mechanism.pivot", "mechanism[0].placement.pivot"),
    ("mechanism.point", "attachment[0].point"),
    ("mechanism.x", "attachment[0].x"),
    ("mechanism.generator_joint", "force[0].joint"),
    ("generator", "force[0]"),
];

/// The fields of the damper kind's `[mechanism]`, from [`PATHS`].
fn mechanism_fields() -> impl Iterator<Item = &'static str> {
    PATHS
        .iter()
        .filter_map(|(d, _)| d.strip_prefix("mechanism."))
}

/// The path of the other kind's form for a `--set` `path`: a damper-kind path in the hybrid
/// form (`to_hybrid`, `generator.load_resistance` -> `force[0].load_resistance`) or the
/// reverse; `None` when no entry of [`PATHS`] is a prefix of it (the longest one is used).
pub fn translate(path: &str, to_hybrid: bool) -> Option<String> {
    PATHS
        .iter()
        .map(|&(d, h)| if to_hybrid { (d, h) } else { (h, d) })
        .filter_map(|(from, to)| {
            let rest = path.strip_prefix(from)?;
            (rest.is_empty() || rest.starts_with(['.', '[']))
                .then(|| (from.len(), format!("{to}{rest}")))
        })
        .max_by_key(|(n, _)| *n)
        .map(|(_, p)| p)
}

/// The top-level keys of a damper scenario.
const KEYS: [&str; 9] = [
    "kind",
    "description",
    "beam",
    "mechanism",
    "generator",
    "initial",
    "integrator",
    "output",
    "excitation",
];

fn string<'a>(span: Range<usize>, s: &str) -> Spanned<DeValue<'a>> {
    Spanned::new(span, DeValue::String(Cow::Owned(s.to_string())))
}

fn key<'a>(span: Range<usize>, k: &str) -> Spanned<Cow<'a, str>> {
    Spanned::new(span, Cow::Owned(k.to_string()))
}

fn table<'a>(span: Range<usize>, t: DeTable<'a>) -> Spanned<DeValue<'a>> {
    Spanned::new(span, DeValue::Table(t))
}

fn array_of_one<'a>(span: Range<usize>, t: DeTable<'a>) -> Spanned<DeValue<'a>> {
    let items: DeArray<'a> = std::iter::once(table(span.clone(), t)).collect();
    Spanned::new(span, DeValue::Array(items))
}

/// Takes the table `name` out of the document root: its span and entries (`None` when it is
/// absent; reported and `None` when it is not a table).
fn take_table<'a>(doc: &mut Doc<'a>, name: &str) -> Option<(Range<usize>, DeTable<'a>)> {
    let v = doc.root.remove(name)?;
    let span = v.span();
    match v.into_inner() {
        DeValue::Table(t) => Some((span, t)),
        other => {
            let msg = format!(
                "must be a table, written [{name}] (got a {})",
                other.type_str()
            );
            doc.push(Kind::Syntax, Some(span), Some(&format!("[{name}]")), msg);
            None
        }
    }
}

/// Moves the entry `from` of `src` into `dst` as `to` (key span and value span kept).
fn carry<'a>(src: &mut DeTable<'a>, from: &str, dst: &mut DeTable<'a>, to: &str) -> bool {
    match src.remove_entry(from) {
        Some((k, v)) => {
            dst.insert(key(k.span(), to), v);
            true
        }
        None => false,
    }
}

/// Rewrites a damper scenario's tables into the hybrid tables they mean (see the module
/// documentation); unknown top-level keys are reported here, unknown keys inside a table are
/// carried to the hybrid table and reported there, at their own spans.
pub(crate) fn expand(doc: &mut Doc<'_>) {
    doc.check_keys(&KEYS);
    let unknown: Vec<String> = doc
        .root
        .iter()
        .map(|(k, _)| k.get_ref().to_string())
        .filter(|k| !KEYS.contains(&k.as_str()))
        .collect();
    for k in unknown {
        doc.root.remove(k.as_str());
    }
    // A free decay needs its initial deflection; a forced damper may start at rest.
    let forced = doc.root.contains_key("excitation");
    let required: &[&str] = if forced {
        &["beam", "mechanism", "generator"]
    } else {
        &["beam", "mechanism", "generator", "initial"]
    };
    for &required in required {
        if !doc.root.contains_key(required) {
            let msg = format!("missing field `{required}`");
            doc.push(Kind::MissingField, None, None, msg);
        }
    }
    let whole = 0..0;
    let mechanism = take_table(doc, "mechanism");
    let generator = take_table(doc, "generator");
    let initial = take_table(doc, "initial");
    let output = take_table(doc, "output");

    let mut x = None;
    if let Some((span, mut m)) = mechanism {
        let mut mech = DeTable::new();
        mech.insert(key(span.clone(), "name"), string(span.clone(), MECHANISM));
        let mut placement = DeTable::new();
        let mut pin = DeTable::new();
        let mut force = DeTable::new();
        x = m.get("x").cloned();
        // Every `[mechanism]` field to where PATHS says it goes.
        for (from, to) in PATHS {
            let Some(field) = from.strip_prefix("mechanism.") else {
                continue;
            };
            let (dst, leaf) = if let Some(leaf) = to.strip_prefix("mechanism[0].placement.") {
                (&mut placement, leaf)
            } else if let Some(leaf) = to.strip_prefix("mechanism[0].") {
                (&mut mech, leaf)
            } else if let Some(leaf) = to.strip_prefix("attachment[0].") {
                (&mut pin, leaf)
            } else if let Some(leaf) = to.strip_prefix("force[0].") {
                (&mut force, leaf)
            } else {
                unreachable!("PATHS: `{to}` is not in a table the preset writes")
            };
            carry(&mut m, field, dst, leaf);
        }
        if placement.is_empty() {
            let msg = "missing half_angle_deg or pivot";
            doc.push(
                Kind::MissingField,
                Some(span.clone()),
                Some("[mechanism]"),
                msg,
            );
        } else {
            placement.insert(
                key(span.clone(), "attachment"),
                string(span.clone(), ATTACHMENT),
            );
            mech.insert(
                key(span.clone(), "placement"),
                table(span.clone(), placement),
            );
        }

        pin.insert(key(span.clone(), "name"), string(span.clone(), ATTACHMENT));
        pin.insert(
            key(span.clone(), "mechanism"),
            string(span.clone(), MECHANISM),
        );
        pin.insert(key(span.clone(), "kind"), string(span.clone(), "pin"));
        if !pin.contains_key("point") {
            pin.insert(key(span.clone(), "point"), string(span.clone(), "tip"));
        }

        force.insert(key(span.clone(), "name"), string(span.clone(), GENERATOR));
        force.insert(
            key(span.clone(), "mechanism"),
            string(span.clone(), MECHANISM),
        );
        if !force.contains_key("joint") {
            force.insert(key(span.clone(), "joint"), string(span.clone(), "crank"));
        }
        // A field near a damper-kind name is a typo of it: reported here, in the damper
        // kind's words.
        let unknown: Vec<(String, Range<usize>)> = m
            .iter()
            .map(|(k, _)| (k.get_ref().to_string(), k.span()))
            .filter(|(k, _)| !diagnostic::nearest(k, mechanism_fields()).is_empty())
            .collect();
        for (k, kspan) in unknown {
            m.remove(k.as_str());
            let expected: Vec<String> = mechanism_fields().map(|f| format!("`{f}`")).collect();
            let msg = format!(
                "unknown field `{k}`, expected one of {}",
                expected.join(", ")
            );
            doc.push(Kind::UnknownField, Some(kspan), Some("[mechanism]"), msg);
        }
        // Whatever is left is unknown to the damper kind: carried to the mechanism entry,
        // whose reader reports it at its own line.
        for (k, v) in std::mem::take(&mut m) {
            mech.insert(k, v);
        }
        doc.root.insert(
            key(span.clone(), "mechanism"),
            array_of_one(span.clone(), mech),
        );
        doc.root.insert(
            key(span.clone(), "attachment"),
            array_of_one(span.clone(), pin),
        );
        if let Some((gspan, g)) = generator {
            let mut force = force;
            force.insert(
                key(gspan.clone(), "kind"),
                string(gspan.clone(), "generator"),
            );
            for (k, v) in g {
                force.insert(k, v);
            }
            doc.root
                .insert(key(gspan.clone(), "force"), array_of_one(gspan, force));
        }
    }
    if let Some((span, mut i)) = initial {
        if let Some(x) = x {
            i.insert(key(x.span(), "x"), x);
        }
        doc.root
            .insert(key(span.clone(), "initial"), table(span, i));
    }
    let (span, mut o) = output.unwrap_or((whole.clone(), DeTable::new()));
    match (
        o.contains_key("compare"),
        o.remove_entry("compare_without_generator"),
    ) {
        (true, Some((k, _))) => doc.push(
            Kind::InvalidValue,
            Some(k.span()),
            Some("[output] compare_without_generator"),
            "give either `compare` or its older synonym `compare_without_generator`, not both",
        ),
        (false, Some((k, v))) => {
            let vspan = v.span();
            let list: DeArray<'_> = match v.get_ref() {
                DeValue::Boolean(true) => {
                    std::iter::once(string(vspan.clone(), "generator_disconnected")).collect()
                }
                _ => DeArray::new(),
            };
            if !matches!(v.get_ref(), DeValue::Boolean(_)) {
                let msg = format!("must be true or false (got a {})", v.get_ref().type_str());
                let entity = Some("[output] compare_without_generator");
                doc.push(Kind::Syntax, Some(vspan.clone()), entity, msg);
            }
            o.insert(
                key(k.span(), "compare"),
                Spanned::new(vspan, DeValue::Array(list)),
            );
        }
        (false, None) => {
            let list: DeArray<'_> =
                std::iter::once(string(span.clone(), "generator_disconnected")).collect();
            o.insert(
                key(span.clone(), "compare"),
                Spanned::new(span.clone(), DeValue::Array(list)),
            );
        }
        (true, None) => {}
    }
    doc.root.insert(key(span.clone(), "output"), table(span, o));
}
