//! Typed errors of the crate.
//!
//! Three layers, from the inside out:
//!
//! - [`LinalgError`]: small `Copy` errors of the banded kernels (a non-positive pivot,
//!   mismatched sizes), carrying the offending index.
//! - [`InputError`]: one problem with a beam description, naming the entity the user wrote
//!   (`segment 2`, `support 0`, `load 1`, `damping`) and the field: the typed,
//!   machine-readable cause ([`crate::Beam::validate`] returns every one found).
//! - [`BeamError`]: everything a public operation can fail with. Problems with a beam
//!   description, TOML syntax and type errors as well as every validation problem, are
//!   reported at once as the workspace's one diagnostic type ([`BeamError::Input`] with
//!   [`Diagnostics`]: file, line, entity, message, kind); each [`InputError`] becomes a
//!   [`Diagnostic`] at that boundary ([`InputError::to_diagnostic`]).

use std::fmt;

use diagnostic::{Diagnostic, Diagnostics, Kind};
use thiserror::Error;

/// Errors of the banded matrix kernels ([`crate::BandedSym`], [`crate::BandedFactor`]).
#[derive(Clone, Copy, Debug, PartialEq, Error)]
pub enum LinalgError {
    /// The LDL^T factorisation met a pivot that is not a positive finite number: the matrix
    /// is not (numerically) positive definite.
    #[error("matrix is not positive definite: pivot {index} is {pivot:e}")]
    NotPositiveDefinite {
        /// Row of the pivot (0-based).
        index: usize,
        /// Value of the pivot.
        pivot: f64,
    },
    /// A matrix handed to a factorisation has an entry that is not a finite number (its
    /// inputs overflowed, e.g. material values far outside their physical ranges): refused
    /// before the elimination, naming the first such entry.
    #[error("entry ({row}, {column}) of the matrix is {value} (not a finite number)")]
    NotFinite {
        /// Row of the entry (0-based, original numbering).
        row: usize,
        /// Column of the entry (0-based, `column <= row`).
        column: usize,
        /// The entry.
        value: f64,
    },
    /// Two operands do not have the same size and half-bandwidth, or a dense matrix is not
    /// square.
    #[error(
        "shape mismatch: expected size {expected_size} / half-bandwidth {expected_band}, \
         got {got_size} / {got_band}"
    )]
    ShapeMismatch {
        /// Size of the receiver.
        expected_size: usize,
        /// Half-bandwidth of the receiver.
        expected_band: usize,
        /// Size of the other operand (row count for a dense matrix).
        got_size: usize,
        /// Half-bandwidth of the other operand (column count for a dense matrix).
        got_band: usize,
    },
}

/// The entity of a beam description an [`InputError`] is about. Indices are 0-based, in the
/// order the tables appear in the file (`segment 0` is the first `[[segment]]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Entity {
    /// The `index`-th `[[segment]]`.
    Segment(usize),
    /// The `index`-th `[[support]]`.
    Support(usize),
    /// The `index`-th `[[load]]` (nodal force / moment).
    Load(usize),
    /// The `index`-th `[[distributed_load]]`.
    DistributedLoad(usize),
    /// The `[damping]` table.
    Damping,
}

impl Entity {
    /// The TOML key of the table the entity lives in and its array index, if any.
    pub fn toml_key(self) -> (&'static str, Option<usize>) {
        match self {
            Entity::Segment(i) => ("segment", Some(i)),
            Entity::Support(i) => ("support", Some(i)),
            Entity::Load(i) => ("load", Some(i)),
            Entity::DistributedLoad(i) => ("distributed_load", Some(i)),
            Entity::Damping => ("damping", None),
        }
    }
}

impl fmt::Display for Entity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Entity::Segment(i) => write!(f, "segment {i}"),
            Entity::Support(i) => write!(f, "support {i}"),
            Entity::Load(i) => write!(f, "load {i}"),
            Entity::DistributedLoad(i) => write!(f, "distributed_load {i}"),
            Entity::Damping => f.write_str("damping"),
        }
    }
}

/// One problem with a beam description, naming the entity and the field as written in the
/// file.
#[derive(Clone, Debug, PartialEq)]
pub enum InputError {
    /// The description has no `[[segment]]`.
    NoSegments,
    /// A quantity that must be strictly positive is zero or negative.
    NotPositive {
        /// Where.
        entity: Entity,
        /// TOML field name.
        field: &'static str,
        /// The value given.
        value: f64,
    },
    /// A quantity that must be zero or positive is negative.
    Negative {
        /// Where.
        entity: Entity,
        /// TOML field name.
        field: &'static str,
        /// The value given.
        value: f64,
    },
    /// A quantity is NaN or infinite.
    NotFinite {
        /// Where.
        entity: Entity,
        /// TOML field name.
        field: &'static str,
        /// The value given.
        value: f64,
    },
    /// A segment is meshed into zero elements.
    NoElements {
        /// Segment index.
        segment: usize,
    },
    /// A segment is meshed into more elements than the crate accepts.
    TooManyElements {
        /// Segment index.
        segment: usize,
        /// The number given.
        got: usize,
        /// The limit ([`crate::MAX_ELEMENTS`]).
        max: usize,
    },
    /// Fields that exclude each other were both given, or a required choice was not made.
    Choice {
        /// Where.
        entity: Entity,
        /// The first field concerned (used to locate the line).
        field: &'static str,
        /// What to write instead.
        message: &'static str,
    },
    /// A node index beyond the last node.
    NodeOutOfRange {
        /// Where.
        entity: Entity,
        /// The node given.
        node: usize,
        /// Number of nodes of the mesh.
        nodes: usize,
    },
    /// A position `x` that does not coincide with a node of the mesh.
    NotAtNode {
        /// Where.
        entity: Entity,
        /// The position given.
        x: f64,
        /// The nearest node.
        nearest: usize,
        /// Its position.
        nearest_x: f64,
    },
    /// A segment index beyond the last segment.
    SegmentOutOfRange {
        /// Where.
        entity: Entity,
        /// The segment given.
        segment: usize,
        /// Number of segments.
        segments: usize,
    },
    /// `damping.ratios` does not have exactly two entries.
    RatioCount {
        /// Number of entries given.
        got: usize,
    },
    /// A target mode number of `damping.ratios` is zero (modes are numbered from 1).
    ModeZero {
        /// Entry of `ratios`.
        index: usize,
    },
    /// Both entries of `damping.ratios` target the same mode.
    SameMode {
        /// The repeated mode number.
        mode: usize,
    },
    /// A finite value outside the physical range of its field
    /// ([`crate::PHYSICAL_RANGES`]): a typing or unit mistake.
    OutsidePhysicalRange {
        /// Where.
        entity: Entity,
        /// TOML field name.
        field: &'static str,
        /// The value given.
        value: f64,
        /// Smallest accepted value.
        min: f64,
        /// Largest accepted value.
        max: f64,
        /// SI unit of the field.
        unit: &'static str,
    },
    /// The values of a segment are each valid but together put its element matrices (38),
    /// (39) or its element frequencies out of floating-point range: an entry overflows to
    /// infinity, or a diagonal entry underflows to zero or a subnormal number (e.g.
    /// `density = 5e-324`). Usually wrong units.
    OutOfRange {
        /// Where.
        entity: Entity,
        /// The TOML field blamed (`density` for the mass matrix and the frequencies,
        /// `youngs_modulus` for the stiffness matrix).
        field: &'static str,
        /// Its value.
        value: f64,
        /// What left the range, e.g. `element mass matrix (38)`.
        what: &'static str,
    },
}

impl InputError {
    /// The entity the problem is about (`None` for the missing `[[segment]]` tables).
    pub fn entity(&self) -> Option<Entity> {
        self.location().0
    }

    /// The TOML location the error is about: the entity and the field (either may be
    /// missing). Used to find the line in the source text.
    pub fn location(&self) -> (Option<Entity>, Option<&'static str>) {
        match self {
            InputError::NoSegments => (None, None),
            InputError::NotPositive { entity, field, .. }
            | InputError::Negative { entity, field, .. }
            | InputError::NotFinite { entity, field, .. }
            | InputError::Choice { entity, field, .. }
            | InputError::OutsidePhysicalRange { entity, field, .. }
            | InputError::OutOfRange { entity, field, .. } => (Some(*entity), Some(field)),
            InputError::NoElements { segment } | InputError::TooManyElements { segment, .. } => {
                (Some(Entity::Segment(*segment)), Some("elements"))
            }
            InputError::NodeOutOfRange { entity, .. } => (Some(*entity), Some("node")),
            InputError::NotAtNode { entity, .. } => (Some(*entity), Some("x")),
            InputError::SegmentOutOfRange { entity, .. } => (Some(*entity), Some("segment")),
            InputError::RatioCount { .. }
            | InputError::ModeZero { .. }
            | InputError::SameMode { .. } => (Some(Entity::Damping), Some("ratios")),
        }
    }

    /// The machine-readable kind of the problem.
    pub fn kind(&self) -> Kind {
        match self {
            InputError::NoSegments => Kind::MissingField,
            InputError::NodeOutOfRange { .. } | InputError::SegmentOutOfRange { .. } => {
                Kind::UnknownName
            }
            InputError::SameMode { .. } => Kind::Duplicate,
            InputError::NotPositive { .. }
            | InputError::Negative { .. }
            | InputError::NotFinite { .. }
            | InputError::NoElements { .. }
            | InputError::TooManyElements { .. }
            | InputError::Choice { .. }
            | InputError::NotAtNode { .. }
            | InputError::RatioCount { .. }
            | InputError::ModeZero { .. }
            | InputError::OutsidePhysicalRange { .. }
            | InputError::OutOfRange { .. } => Kind::InvalidValue,
        }
    }

    /// What is wrong, without the entity (which [`Display`](fmt::Display) puts in front).
    pub fn message(&self) -> String {
        match self {
            InputError::NoSegments => {
                "the beam has no segments: add at least one [[segment]] table".to_string()
            }
            InputError::NotPositive { field, value, .. } => {
                format!("{field} must be positive (got {value})")
            }
            InputError::Negative { field, value, .. } => {
                format!("{field} must not be negative (got {value})")
            }
            InputError::NotFinite { field, value, .. } => {
                format!("{field} must be a finite number (got {value})")
            }
            InputError::NoElements { .. } => "elements must be at least 1 (got 0)".to_string(),
            InputError::TooManyElements { got, max, .. } => {
                format!("elements must be at most {max} (got {got})")
            }
            InputError::Choice { message, .. } => (*message).to_string(),
            InputError::NodeOutOfRange { node, nodes, .. } => format!(
                "node {node} does not exist (the beam has {nodes} nodes, 0 to {})",
                nodes.saturating_sub(1)
            ),
            InputError::NotAtNode {
                x,
                nearest,
                nearest_x,
                ..
            } => format!(
                "x = {x} is not at a node (nearest is node {nearest} at x = {nearest_x}): \
                 supports and nodal loads must sit on nodes"
            ),
            InputError::SegmentOutOfRange {
                segment, segments, ..
            } => format!("segment {segment} does not exist (the beam has {segments} segments)"),
            InputError::RatioCount { got } => {
                format!("ratios needs exactly two entries, one per target mode (got {got})")
            }
            InputError::ModeZero { index } => {
                format!("ratios[{index}]: mode numbers start at 1 (got 0)")
            }
            InputError::SameMode { mode } => {
                format!("ratios target mode {mode} twice; give two different modes")
            }
            InputError::OutsidePhysicalRange {
                field,
                value,
                min,
                max,
                unit,
                ..
            } => format!(
                "{field} = {value:e} is outside its physical range [{min:e}, {max:e}] {unit}"
            ),
            InputError::OutOfRange {
                field, value, what, ..
            } => format!(
                "{field} = {value:e} puts the {what} out of floating-point range \
                 (overflow or underflow; check the units)"
            ),
        }
    }

    /// The problem as the workspace's diagnostic: `file` (may be empty), the 1-based `line`
    /// when known, the entity as the user wrote it, the message and the kind.
    pub fn to_diagnostic(&self, file: &str, line: Option<usize>) -> Diagnostic {
        let d = Diagnostic::new(self.kind(), file, self.message()).at_line(line);
        match self.entity() {
            Some(entity) => d.entity(entity.to_string()),
            None => d,
        }
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(entity) = self.entity() {
            write!(f, "{entity}: ")?;
        }
        f.write_str(&self.message())
    }
}

impl std::error::Error for InputError {}

/// Every error a public operation of the crate can return.
#[derive(Debug, Error)]
pub enum BeamError {
    /// The beam file could not be read. (The I/O error is part of the message, not a
    /// separate source, so a chain-printing reporter does not repeat it.)
    #[error("cannot read {path}: {error}")]
    Io {
        /// The path as given.
        path: String,
        /// The I/O error.
        error: std::io::Error,
    },
    /// Problems with a beam description: a TOML syntax or type error, an unknown or
    /// missing field, or every validation problem found, in file order. Displayed on one
    /// line, the diagnostics joined with `; `.
    #[error("{}", one_line(.0))]
    Input(Diagnostics),
    /// A static solution was asked for a beam whose supports leave rigid-body motion free.
    #[error(
        "static solution impossible: the supports leave {rigid_modes} rigid-body motion(s) free \
         (clamp a node, or lock the transverse DOF at two different nodes)"
    )]
    Unconstrained {
        /// Number of rigid-body modes (1 or 2).
        rigid_modes: usize,
    },
    /// Every DOF of the beam is locked: there is nothing to solve for.
    #[error("every DOF of the beam is locked: nothing can move")]
    NoFreeDofs,
    /// More modes (or zero modes) were requested than the model has.
    #[error(
        "cannot compute {requested} modes: the beam has {available} free DOFs (ask for 1 to {available})"
    )]
    ModeCount {
        /// Modes requested.
        requested: usize,
        /// Free DOFs of the reduced model.
        available: usize,
    },
    /// A position outside the beam.
    #[error("x = {x} is outside the beam (0 to {length})")]
    OutOfBeam {
        /// Position asked for.
        x: f64,
        /// Length of the beam.
        length: f64,
    },
    /// A vector of the wrong length was passed.
    #[error("{what} has length {got}, expected {expected}")]
    Length {
        /// Which argument.
        what: &'static str,
        /// Its length.
        got: usize,
        /// The expected length.
        expected: usize,
    },
    /// Rayleigh damping from target modal ratios could not be built.
    #[error("damping: {0}")]
    Damping(String),
    /// The subspace iteration did not converge.
    #[error("modal analysis did not converge in {iterations} iterations (residual {residual:e})")]
    NotConverged {
        /// Iterations done.
        iterations: usize,
        /// Largest residual of a wanted mode at the end.
        residual: f64,
    },
    /// A dense symmetric eigen-decomposition reached its iteration cap.
    #[error(
        "the dense symmetric eigen-decomposition (size {size}) did not converge within {iterations} QR sweeps"
    )]
    EigenNotConverged {
        /// The cap reached.
        iterations: usize,
        /// Size of the matrix.
        size: usize,
    },
    /// A banded kernel failed.
    #[error(transparent)]
    Linalg(#[from] LinalgError),
}

fn one_line(diagnostics: &Diagnostics) -> String {
    diagnostics
        .iter()
        .map(|d| d.to_string())
        .collect::<Vec<_>>()
        .join("; ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_entity_and_field() {
        let e = InputError::NotPositive {
            entity: Entity::Segment(2),
            field: "length",
            value: -1.0,
        };
        assert_eq!(e.to_string(), "segment 2: length must be positive (got -1)");
        let e = InputError::NodeOutOfRange {
            entity: Entity::Support(0),
            node: 30,
            nodes: 21,
        };
        assert_eq!(
            e.to_string(),
            "support 0: node 30 does not exist (the beam has 21 nodes, 0 to 20)"
        );
    }

    #[test]
    fn invalid_joins_issues_on_one_line() {
        let err = BeamError::Input(Diagnostics(vec![
            InputError::NoElements { segment: 0 }.to_diagnostic("b.toml", Some(3)),
            InputError::NoSegments.to_diagnostic("b.toml", None),
        ]));
        let s = err.to_string();
        assert_eq!(
            s,
            "b.toml:3: segment 0: elements must be at least 1 (got 0); b.toml: the beam has no \
             segments: add at least one [[segment]] table"
        );
        assert!(!s.contains('\n'));
    }
}
