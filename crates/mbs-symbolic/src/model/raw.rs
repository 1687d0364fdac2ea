//! The model file as written: serde structures, one per entity, before validation.
//!
//! Every structure denies unknown fields so that typos are reported. Numeric fields are
//! [`RawScalar`]s (a number or an expression string); names and keywords (axes, joint types,
//! frames, components) stay strings here and are checked by `validate.rs`, which can then
//! say what was expected. The top-level table and the `[parameters]` table are walked
//! directly in the [`Node`](super::node::Node) tree (to keep the written order); each entity
//! of `bodies`, `points`, `forces` and `constraints` is deserialized on its own.

use std::fmt;

use serde::Deserialize;
use serde::de::value::{MapAccessDeserializer, SeqAccessDeserializer};
use serde::de::{self, MapAccess, SeqAccess, Visitor};

/// A numeric field: a number, or an expression over parameters.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum RawScalar {
    Num(f64),
    Expr(String),
}

/// Three coordinates `[x, y, z]`.
pub(crate) type RawVec3 = [RawScalar; 3];

impl<'de> Deserialize<'de> for RawScalar {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = RawScalar;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a number or an expression string")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<RawScalar, E> {
                Ok(RawScalar::Num(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<RawScalar, E> {
                Ok(RawScalar::Num(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<RawScalar, E> {
                Ok(RawScalar::Num(v as f64))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<RawScalar, E> {
                Ok(RawScalar::Expr(v.to_string()))
            }
        }
        d.deserialize_any(V)
    }
}

/// A parameter: `L1 = 0.1`, `I1 = "m1*L1^2/12"` or `m1 = { value = 0.024, runtime = true }`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct RawParam {
    pub value: RawScalar,
    pub runtime: bool,
    /// True when written as a table (the value is then on the `value` key).
    pub table: bool,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawParamTable {
    value: RawScalar,
    #[serde(default)]
    runtime: bool,
}

impl<'de> Deserialize<'de> for RawParam {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RawParam;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a number, an expression string or a table { value, runtime }")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<RawParam, E> {
                Ok(plain(RawScalar::Num(v)))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<RawParam, E> {
                Ok(plain(RawScalar::Num(v as f64)))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<RawParam, E> {
                Ok(plain(RawScalar::Num(v as f64)))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<RawParam, E> {
                Ok(plain(RawScalar::Expr(v.to_string())))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<RawParam, A::Error> {
                let t = RawParamTable::deserialize(MapAccessDeserializer::new(map))?;
                Ok(RawParam {
                    value: t.value,
                    runtime: t.runtime,
                    table: true,
                })
            }
        }
        fn plain(value: RawScalar) -> RawParam {
            RawParam {
                value,
                runtime: false,
                table: false,
            }
        }
        d.deserialize_any(V)
    }
}

/// One elementary rotation of a joint frame: `{ axis = "x", angle = "pi/2" }`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawRotation {
    pub axis: String,
    pub angle: RawScalar,
}

/// A joint: a ROBOTRAN code (`"R3"`) or a table.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum RawJoint {
    Code(String),
    Table(RawJointTable),
}

/// `joint = { type = "revolute", axis = "z", anchor = [..], rotation = [..] }`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawJointTable {
    #[serde(rename = "type")]
    pub kind: String,
    pub axis: Option<String>,
    pub anchor: Option<RawVec3>,
    pub rotation: Option<Vec<RawRotation>>,
}

impl<'de> Deserialize<'de> for RawJoint {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RawJoint;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a joint code (R1, R2, R3, T1, T2, T3) or a table { type, axis, .. }")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<RawJoint, E> {
                Ok(RawJoint::Code(v.to_string()))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<RawJoint, A::Error> {
                RawJointTable::deserialize(MapAccessDeserializer::new(map)).map(RawJoint::Table)
            }
        }
        d.deserialize_any(V)
    }
}

/// An inertia tensor: `{ xx, yy, zz, xy, xz, yz }` (missing entries 0) or a 3x3 array.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum RawInertia {
    Table(RawInertiaTable),
    Matrix(Box<[RawVec3; 3]>),
}

#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawInertiaTable {
    pub xx: Option<RawScalar>,
    pub yy: Option<RawScalar>,
    pub zz: Option<RawScalar>,
    pub xy: Option<RawScalar>,
    pub xz: Option<RawScalar>,
    pub yz: Option<RawScalar>,
}

impl<'de> Deserialize<'de> for RawInertia {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RawInertia;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a table { xx, yy, zz, xy, xz, yz } or a 3x3 array")
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<RawInertia, A::Error> {
                RawInertiaTable::deserialize(MapAccessDeserializer::new(map)).map(RawInertia::Table)
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<RawInertia, A::Error> {
                <[RawVec3; 3]>::deserialize(SeqAccessDeserializer::new(seq))
                    .map(|m| RawInertia::Matrix(Box::new(m)))
            }
        }
        d.deserialize_any(V)
    }
}

/// `[[bodies]]`
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawBody {
    pub name: String,
    pub parent: Option<String>,
    pub joint: RawJoint,
    pub anchor: Option<RawVec3>,
    pub rotation: Option<Vec<RawRotation>>,
    pub coordinate: Option<String>,
    pub mass: RawScalar,
    pub com: Option<RawVec3>,
    pub inertia: Option<RawInertia>,
}

/// `[[points]]`
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawPoint {
    pub name: String,
    pub body: String,
    pub position: Option<RawVec3>,
}

/// `[[forces]]` with `type = "joint"` (the `type` key is removed before deserializing).
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawJointForce {
    pub name: Option<String>,
    pub body: String,
    pub stiffness: Option<RawScalar>,
    pub damping: Option<RawScalar>,
    pub rest: Option<RawScalar>,
    pub constant: Option<RawScalar>,
}

/// `[[forces]]` with `type = "spring"`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawSpring {
    pub name: Option<String>,
    pub a: String,
    pub b: String,
    pub stiffness: Option<RawScalar>,
    pub damping: Option<RawScalar>,
    pub rest_length: Option<RawScalar>,
}

/// The application point of an external force: a point name or body-frame coordinates.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum RawPointRef {
    Name(String),
    Coords(RawVec3),
}

impl<'de> Deserialize<'de> for RawPointRef {
    fn deserialize<D: de::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RawPointRef;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a point name or body-frame coordinates [x, y, z]")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<RawPointRef, E> {
                Ok(RawPointRef::Name(v.to_string()))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<RawPointRef, A::Error> {
                RawVec3::deserialize(SeqAccessDeserializer::new(seq)).map(RawPointRef::Coords)
            }
        }
        d.deserialize_any(V)
    }
}

/// `[[forces]]` with `type = "external"`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawExternal {
    pub name: Option<String>,
    pub body: Option<String>,
    pub point: Option<RawPointRef>,
    pub force: Option<RawVec3>,
    pub torque: Option<RawVec3>,
    pub frame: Option<String>,
}

/// `[[constraints]]` with `type = "loop"`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawLoop {
    pub name: Option<String>,
    pub a: String,
    pub b: String,
    pub components: Option<Vec<String>>,
}

/// `[[constraints]]` with `type = "fixed"`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawFixed {
    pub name: Option<String>,
    pub point: String,
    pub position: RawVec3,
    pub components: Option<Vec<String>>,
}

/// `[[constraints]]` with `type = "angle"`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawAngle {
    pub name: Option<String>,
    pub a: String,
    pub b: String,
    pub axis: String,
    pub offset: Option<RawScalar>,
}
