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
        for k in ["model", "max_condition", "parameters"] {
            carry(&mut m, k, &mut mech, k);
        }
        let mut placement = DeTable::new();
        placement.insert(
            key(span.clone(), "attachment"),
            string(span.clone(), ATTACHMENT),
        );
        let placed = carry(&mut m, "half_angle_deg", &mut placement, "half_angle_deg")
            | carry(&mut m, "pivot", &mut placement, "pivot");
        if !placed {
            let msg = "missing half_angle_deg or pivot";
            doc.push(
                Kind::MissingField,
                Some(span.clone()),
                Some("[mechanism]"),
                msg,
            );
        } else {
            mech.insert(
                key(span.clone(), "placement"),
                table(span.clone(), placement),
            );
        }

        let mut pin = DeTable::new();
        pin.insert(key(span.clone(), "name"), string(span.clone(), ATTACHMENT));
        pin.insert(
            key(span.clone(), "mechanism"),
            string(span.clone(), MECHANISM),
        );
        pin.insert(key(span.clone(), "kind"), string(span.clone(), "pin"));
        if !carry(&mut m, "point", &mut pin, "point") {
            pin.insert(key(span.clone(), "point"), string(span.clone(), "tip"));
        }
        x = m.get("x").cloned();
        carry(&mut m, "x", &mut pin, "x");

        let mut force = DeTable::new();
        force.insert(key(span.clone(), "name"), string(span.clone(), GENERATOR));
        force.insert(
            key(span.clone(), "mechanism"),
            string(span.clone(), MECHANISM),
        );
        if !carry(&mut m, "generator_joint", &mut force, "joint") {
            force.insert(key(span.clone(), "joint"), string(span.clone(), "crank"));
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
