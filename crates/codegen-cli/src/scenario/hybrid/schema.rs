//! The serde shapes of the hybrid scenario's tables, as written (every value spanned for
//! diagnostics); [`super::reader`] checks them into the entries of [`super`].

use std::collections::BTreeMap;

use serde::Deserialize;
use toml::Spanned;

use crate::scenario::compare::Comparison;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMechanism {
    pub(super) name: Spanned<String>,
    pub(super) model: Spanned<String>,
    #[serde(default)]
    pub(super) origin: Option<Spanned<[f64; 2]>>,
    #[serde(default)]
    pub(super) angle_deg: Option<Spanned<f64>>,
    #[serde(default)]
    pub(super) parameters: BTreeMap<String, Spanned<f64>>,
    #[serde(default)]
    pub(super) initial: BTreeMap<String, Spanned<f64>>,
    #[serde(default)]
    pub(super) max_condition: Option<Spanned<f64>>,
    #[serde(default)]
    pub(super) placement: Option<Spanned<RawPlacement>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPlacement {
    pub(super) attachment: Spanned<String>,
    #[serde(default)]
    pub(super) half_angle_deg: Option<Spanned<f64>>,
    #[serde(default)]
    pub(super) pivot: Option<Spanned<[f64; 2]>>,
    /// From the attached point towards the pivot (structure frame), with `half_angle_deg`.
    #[serde(default)]
    pub(super) pivot_direction: Option<Spanned<[f64; 2]>>,
    /// `"+"` (counter-clockwise of the pivot -> point axis) or `"-"`.
    #[serde(default)]
    pub(super) knee: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawAttachment {
    pub(super) name: Spanned<String>,
    pub(super) mechanism: Spanned<String>,
    pub(super) point: Spanned<String>,
    #[serde(default)]
    pub(super) kind: Option<Spanned<String>>,
    /// A beam abscissa (with a `[beam]`).
    #[serde(default)]
    pub(super) x: Option<Spanned<f64>>,
    /// A node id (with a `[structure]`).
    #[serde(default)]
    pub(super) node: Option<Spanned<u64>>,
    /// The direction a roller at a node follows (structure frame).
    #[serde(default)]
    pub(super) direction: Option<Spanned<[f64; 2]>>,
}

/// `[structure]`: a model from another finite-element program.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawStructure {
    pub(super) kind: Spanned<String>,
    #[serde(default)]
    pub(super) mass: Option<Spanned<String>>,
    #[serde(default)]
    pub(super) stiffness: Option<Spanned<String>>,
    #[serde(default)]
    pub(super) nodes: Option<Spanned<String>>,
    #[serde(default)]
    pub(super) dofs: Option<Spanned<String>>,
    #[serde(default)]
    pub(super) damping: Option<Spanned<RawStructureDamping>>,
    #[serde(default)]
    pub(super) reduction: Option<Spanned<RawReduction>>,
    /// `elements.csv` (`node1,node2`), for the deformed-shape plots only.
    #[serde(default)]
    pub(super) elements: Option<Spanned<String>>,
}

/// `[structure] damping`: a matrix file, or Rayleigh damping from two modal ratios.
#[derive(Deserialize)]
#[serde(untagged)]
pub(super) enum RawStructureDamping {
    File(String),
    Ratios { ratios: Vec<RawRatio> },
}

/// One `{ mode = 1, ratio = 0.003 }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRatio {
    pub(super) mode: usize,
    pub(super) ratio: f64,
}

/// `[structure] reduction`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawReduction {
    pub(super) kind: Spanned<String>,
    pub(super) modes: Spanned<usize>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawForceHead {
    pub(super) name: Spanned<String>,
    pub(super) mechanism: Spanned<String>,
    pub(super) joint: Spanned<String>,
    pub(super) kind: Spanned<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawDamper {
    pub(super) c: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSpring {
    pub(super) k: Spanned<f64>,
    #[serde(default)]
    pub(super) q0: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawExcitation {
    pub(super) name: Spanned<String>,
    /// Absent for a random `time` (its PSD carries the level), required otherwise.
    #[serde(default)]
    pub(super) amplitude: Option<Spanned<f64>>,
    /// The direction of a support motion (`at = "base"`), structure frame.
    #[serde(default)]
    pub(super) direction: Option<Spanned<[f64; 2]>>,
}

/// The table form of an excitation's `at` (its string form `"base"` is read apart).

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawAt {
    #[serde(default)]
    pub(super) x: Option<Spanned<f64>>,
    #[serde(default)]
    pub(super) node: Option<Spanned<u64>>,
    #[serde(default)]
    pub(super) direction: Option<Spanned<[f64; 2]>>,
    #[serde(default)]
    pub(super) mechanism: Option<Spanned<String>>,
    #[serde(default)]
    pub(super) joint: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawInitial {
    pub(super) displacement: Spanned<f64>,
    pub(super) x: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawOutput {
    #[serde(default)]
    pub(super) every: Option<Spanned<usize>>,
    #[serde(default)]
    pub(super) compare: Option<Spanned<Vec<Comparison>>>,
    #[serde(default)]
    pub(super) points: Option<Spanned<Vec<Spanned<String>>>>,
}
