//! The generator of a `[[force]]` table with `kind = "generator"` (and of the damper kind's
//! `[generator]`, rewritten into one): each field a number in SI units or a datasheet
//! quantity with its unit ([`crate::scenario::units`]), checked into a
//! [`GeneratorSpec`]; every problem is reported at the value it is about.
//!
//! | field | alias | dimension |
//! |---|---|---|
//! | `kt` | `torque_constant` | torque per current (N m/A) |
//! | `ke` | | torque per current (= V s/rad; also V/krpm, mV/rpm) |
//! | | `speed_constant` | speed per voltage (rpm/V): `k_e = 1 / k_n` in SI |
//! | `armature_resistance` | `terminal_resistance` | resistance |
//! | `load_resistance` | | resistance |
//! | `inductance` | `terminal_inductance` | inductance (default 0) |
//! | `gear_ratio` | | number (default 1) |
//! | `rotor_inertia` | | moment of inertia (default 0) |
//! | `gear_efficiency` | | number, e.g. `0.85` or `"85 %"` (default 1) |
//! | `gear_friction` | | `{ coulomb = torque, viscous = rotational damping, smoothing_speed = angular speed }` |
//! | `connected` | | boolean (default true) |
//!
//! One of `kt` and `ke` (or their aliases) may be left out: an ideal DC machine has
//! `k_t = k_e` in SI units, so the other takes its value. When both are given and either is
//! a datasheet quantity (a string with a unit, `torque_constant` or `speed_constant`) they
//! must agree within [`KT_KE_TOLERANCE`]: a datasheet's constants are rounded and carry
//! manufacturing tolerances of a few per cent, while a unit mistake is off by a factor (2π,
//! 60, 1000); beyond it the generator is refused at the EMF constant's line, after the
//! fields' own range checks. (Within it both are used as given: the energy split of a run
//! reports `(k_t - k_e) ∫ i w dt` as the machine's conversion loss.) Plain SI numbers under `kt` and `ke` are used as
//! given, as always.

use std::ops::Range;

use diagnostic::Kind;
use hybrid_core::generator::{GearFriction, GeneratorField, GeneratorSpec};
use toml::Spanned;
use toml::de::DeValue;

use super::checks::de;
use crate::scenario::Doc;
use crate::scenario::units::{Dimension, convert};

/// The largest relative difference `|k_t - k_e| / max(k_t, k_e)` accepted between a given
/// torque constant and a given EMF (or speed) constant: 10 %.
pub const KT_KE_TOLERANCE: f64 = 0.10;

/// A field as written: its name, its dimension, the field of [`GeneratorSpec`] it sets.
struct Field {
    name: &'static str,
    dimension: Dimension,
    target: GeneratorField,
    /// The value is the inverse of the target (a speed constant for `ke`).
    inverse: bool,
}

const FIELDS: [Field; 11] = [
    field("kt", Dimension::TorquePerCurrent, GeneratorField::Kt),
    field(
        "torque_constant",
        Dimension::TorquePerCurrent,
        GeneratorField::Kt,
    ),
    field("ke", Dimension::TorquePerCurrent, GeneratorField::Ke),
    Field {
        name: "speed_constant",
        dimension: Dimension::SpeedPerVoltage,
        target: GeneratorField::Ke,
        inverse: true,
    },
    field(
        "armature_resistance",
        Dimension::Resistance,
        GeneratorField::ArmatureResistance,
    ),
    field(
        "terminal_resistance",
        Dimension::Resistance,
        GeneratorField::ArmatureResistance,
    ),
    field(
        "load_resistance",
        Dimension::Resistance,
        GeneratorField::LoadResistance,
    ),
    field(
        "inductance",
        Dimension::Inductance,
        GeneratorField::Inductance,
    ),
    field(
        "terminal_inductance",
        Dimension::Inductance,
        GeneratorField::Inductance,
    ),
    field(
        "gear_ratio",
        Dimension::Dimensionless,
        GeneratorField::GearRatio,
    ),
    field(
        "rotor_inertia",
        Dimension::Inertia,
        GeneratorField::RotorInertia,
    ),
];

const FRICTION: [Field; 3] = [
    field("coulomb", Dimension::Torque, GeneratorField::GearCoulomb),
    field(
        "viscous",
        Dimension::RotationalDamping,
        GeneratorField::GearViscous,
    ),
    field(
        "smoothing_speed",
        Dimension::AngularSpeed,
        GeneratorField::GearSmoothing,
    ),
];

const EFFICIENCY: Field = field(
    "gear_efficiency",
    Dimension::Dimensionless,
    GeneratorField::GearEfficiency,
);

/// The dimension of a generator field by the name it is written under (`load_resistance`,
/// `speed_constant`, `coulomb`, ...), `None` for a name that is not a generator field.
pub fn field_dimension(name: &str) -> Option<Dimension> {
    FIELDS
        .iter()
        .chain(&FRICTION)
        .chain([&EFFICIENCY])
        .find(|f| f.name == name)
        .map(|f| f.dimension)
}

const fn field(name: &'static str, dimension: Dimension, target: GeneratorField) -> Field {
    Field {
        name,
        dimension,
        target,
        inverse: false,
    }
}

/// The values read so far: per target field, its SI value, where it is written and under
/// which name.
#[derive(Default)]
struct Read {
    values: Vec<(GeneratorField, f64, Range<usize>, &'static str)>,
    /// The names written as datasheet quantities (a string with a unit, or an alias).
    datasheet: Vec<&'static str>,
}

impl Read {
    fn get(&self, f: GeneratorField) -> Option<&(GeneratorField, f64, Range<usize>, &'static str)> {
        self.values.iter().find(|v| v.0 == f)
    }
}

/// Reads one quantity: a number (SI) or a string with a unit.
fn quantity<'a>(
    doc: &mut Doc<'a>,
    v: &Spanned<DeValue<'a>>,
    f: &Field,
    entity: &str,
) -> Option<f64> {
    let x = match v.get_ref() {
        DeValue::String(s) => match convert(s, f.dimension) {
            Ok(x) => x,
            Err(e) => {
                let msg = format!("{}: {e}", f.name);
                doc.push(Kind::InvalidValue, Some(v.span()), Some(entity), msg);
                return None;
            }
        },
        DeValue::Integer(_) | DeValue::Float(_) => de::<f64>(doc, v.clone(), entity)?,
        _ => {
            let msg = format!(
                "{}: expected a number (SI) or a string with a unit: {}",
                f.name,
                f.dimension.describe()
            );
            doc.push(Kind::Syntax, Some(v.span()), Some(entity), msg);
            return None;
        }
    };
    Some(if f.inverse { 1.0 / x } else { x })
}

/// Records `value` for `f` unless another name of the same field is already written.
fn record(
    doc: &mut Doc<'_>,
    read: &mut Read,
    f: &'static Field,
    value: f64,
    span: Range<usize>,
    entity: &str,
) -> bool {
    if let Some(&(_, _, _, other)) = read.get(f.target) {
        let msg = format!("give {other} or {}, not both", f.name);
        doc.push(Kind::InvalidValue, Some(span), Some(entity), msg);
        return false;
    }
    read.values.push((f.target, value, span, f.name));
    true
}

/// The generator of the table `rest` (the `[[force]]` fields after its head), or `None`
/// after reporting every problem; `kind_span` is where a problem without a value of its own
/// is reported.
pub(super) fn generator<'a>(
    doc: &mut Doc<'a>,
    rest: &Spanned<DeValue<'a>>,
    kind_span: Range<usize>,
    entity: &str,
) -> Option<GeneratorSpec> {
    let DeValue::Table(table) = rest.get_ref() else {
        return None;
    };
    let mut ok = true;
    let mut read = Read::default();
    let mut connected = true;
    for (key, v) in table.iter() {
        let name = key.get_ref().as_ref();
        if let Some(f) = FIELDS.iter().chain([&EFFICIENCY]).find(|f| f.name == name) {
            if matches!(v.get_ref(), DeValue::String(_))
                || matches!(f.name, "torque_constant" | "speed_constant")
            {
                read.datasheet.push(f.name);
            }
            match quantity(doc, v, f, entity) {
                Some(x) => ok &= record(doc, &mut read, f, x, v.span(), entity),
                None => ok = false,
            }
        } else if name == "connected" {
            match de::<bool>(doc, v.clone(), entity) {
                Some(c) => connected = c,
                None => ok = false,
            }
        } else if name == "gear_friction" {
            let DeValue::Table(inner) = v.get_ref() else {
                let msg =
                    "gear_friction: expected a table { coulomb = \"...\", viscous = \"...\" }";
                doc.push(Kind::Syntax, Some(v.span()), Some(entity), msg);
                ok = false;
                continue;
            };
            for (k, x) in inner.iter() {
                let kname = k.get_ref().as_ref();
                match FRICTION.iter().find(|f| f.name == kname) {
                    Some(f) => match quantity(doc, x, f, entity) {
                        Some(val) => ok &= record(doc, &mut read, f, val, x.span(), entity),
                        None => ok = false,
                    },
                    None => {
                        let msg = format!(
                            "gear_friction: unknown field `{kname}`, expected one of `coulomb`, `viscous`, `smoothing_speed`"
                        );
                        doc.push(Kind::Syntax, Some(k.span()), Some(entity), msg);
                        ok = false;
                    }
                }
            }
        } else {
            let names: Vec<String> = FIELDS
                .iter()
                .map(|f| f.name)
                .chain(["gear_efficiency", "gear_friction", "connected"])
                .map(|n| format!("`{n}`"))
                .collect();
            let msg = format!(
                "unknown field `{name}`, expected one of {}",
                names.join(", ")
            );
            doc.push(Kind::Syntax, Some(key.span()), Some(entity), msg);
            ok = false;
        }
    }
    if !ok {
        return None;
    }
    // kt and ke: one may stand for both (k_t = k_e in SI); two are checked by `consistent`
    // after the ranges.
    let kt = read.get(GeneratorField::Kt).cloned();
    let ke = read.get(GeneratorField::Ke).cloned();
    let (kt, ke) = match (kt, ke) {
        (None, None) => {
            let msg = "missing field `kt` (or `torque_constant`; `ke` or `speed_constant` \
                       alone stands for both)";
            doc.push(Kind::MissingField, Some(kind_span), Some(entity), msg);
            return None;
        }
        (Some(t), None) => {
            read.values
                .push((GeneratorField::Ke, t.1, t.2.clone(), t.3));
            (t.1, t.1)
        }
        (None, Some(e)) => {
            read.values
                .push((GeneratorField::Kt, e.1, e.2.clone(), e.3));
            (e.1, e.1)
        }
        (Some(t), Some(e)) => (t.1, e.1),
    };
    let mut missing = false;
    for required in [
        GeneratorField::ArmatureResistance,
        GeneratorField::LoadResistance,
    ] {
        if read.get(required).is_none() {
            let msg = format!("missing field `{}`", required.name());
            doc.push(
                Kind::MissingField,
                Some(kind_span.clone()),
                Some(entity),
                msg,
            );
            missing = true;
        }
    }
    if missing {
        return None;
    }
    let value = |f: GeneratorField, default: f64| read.get(f).map_or(default, |v| v.1);
    let spec = GeneratorSpec {
        kt,
        ke,
        armature_resistance: value(GeneratorField::ArmatureResistance, 0.0),
        load_resistance: value(GeneratorField::LoadResistance, 0.0),
        inductance: value(GeneratorField::Inductance, 0.0),
        gear_ratio: value(GeneratorField::GearRatio, 1.0),
        rotor_inertia: value(GeneratorField::RotorInertia, 0.0),
        connected,
        gear_efficiency: value(GeneratorField::GearEfficiency, 1.0),
        gear_friction: GearFriction {
            coulomb: value(GeneratorField::GearCoulomb, 0.0),
            viscous: value(GeneratorField::GearViscous, 0.0),
            smoothing_speed: value(
                GeneratorField::GearSmoothing,
                GearFriction::default().smoothing_speed,
            ),
        },
    };
    let problems = spec.problems();
    for e in &problems {
        // At the field it is about when that is written, at `kind` otherwise.
        let span = e
            .field()
            .and_then(|f| read.get(f))
            .map_or(kind_span.clone(), |v| v.2.clone());
        doc.push(Kind::InvalidValue, Some(span), Some(entity), e.to_string());
    }
    if !problems.is_empty() {
        return None;
    }
    consistent(doc, &read, entity).then_some(spec)
}

/// Whether a torque constant and an EMF (or speed) constant, both given, agree within
/// [`KT_KE_TOLERANCE`] — checked when either is a datasheet quantity (a string with a unit,
/// or `torque_constant`, `speed_constant`): plain SI numbers under `kt` and `ke` keep
/// meaning what they meant (a study may vary one alone). Reported at the EMF constant.
fn consistent(doc: &mut Doc<'_>, read: &Read, entity: &str) -> bool {
    let (Some(t), Some(e)) = (read.get(GeneratorField::Kt), read.get(GeneratorField::Ke)) else {
        return true;
    };
    if t.2 == e.2 || !(read.datasheet.contains(&t.3) || read.datasheet.contains(&e.3)) {
        return true; // one constant standing for both, or plain SI numbers
    }
    let diff = (t.1 - e.1).abs() / t.1.abs().max(e.1.abs());
    if diff <= KT_KE_TOLERANCE {
        return true;
    }
    let msg = format!(
        "{} = {:.4e} N m/A and {} = {:.4e} V s/rad disagree by {:.0} % (an ideal DC machine \
         has kt = ke in SI units; more than {:.0} % is a unit mistake)",
        t.3,
        t.1,
        e.3,
        e.1,
        100.0 * diff,
        100.0 * KT_KE_TOLERANCE
    );
    doc.push(Kind::InvalidValue, Some(e.2.clone()), Some(entity), msg);
    false
}
