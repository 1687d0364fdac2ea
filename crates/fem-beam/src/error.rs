//! Typed errors of the crate.
//!
//! Three layers, from the inside out:
//!
//! - [`LinalgError`]: small `Copy` errors of the banded kernels (a non-positive pivot,
//!   mismatched sizes), carrying the offending index.
//! - [`InputError`]: one problem with a beam description, naming the entity the user wrote
//!   (`segment 2`, `support 0`, `load 1`, `damping`) and the field.
//! - [`BeamError`]: everything a public operation can fail with. Validation collects every
//!   [`InputError`] at once ([`BeamError::Invalid`]); TOML syntax and type errors carry the
//!   file, line and column ([`BeamError::Parse`]).

use std::fmt;

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
#[derive(Clone, Debug, PartialEq, Error)]
pub enum InputError {
    /// The description has no `[[segment]]`.
    #[error("the beam has no segments: add at least one [[segment]] table")]
    NoSegments,
    /// A quantity that must be strictly positive is zero or negative.
    #[error("{entity}: {field} must be positive (got {value})")]
    NotPositive {
        /// Where.
        entity: Entity,
        /// TOML field name.
        field: &'static str,
        /// The value given.
        value: f64,
    },
    /// A quantity that must be zero or positive is negative.
    #[error("{entity}: {field} must not be negative (got {value})")]
    Negative {
        /// Where.
        entity: Entity,
        /// TOML field name.
        field: &'static str,
        /// The value given.
        value: f64,
    },
    /// A quantity is NaN or infinite.
    #[error("{entity}: {field} must be a finite number (got {value})")]
    NotFinite {
        /// Where.
        entity: Entity,
        /// TOML field name.
        field: &'static str,
        /// The value given.
        value: f64,
    },
    /// A segment is meshed into zero elements.
    #[error("segment {segment}: elements must be at least 1 (got 0)")]
    NoElements {
        /// Segment index.
        segment: usize,
    },
    /// A segment is meshed into more elements than the crate accepts.
    #[error("segment {segment}: elements must be at most {max} (got {got})")]
    TooManyElements {
        /// Segment index.
        segment: usize,
        /// The number given.
        got: usize,
        /// The limit ([`crate::MAX_ELEMENTS`]).
        max: usize,
    },
    /// Fields that exclude each other were both given, or a required choice was not made.
    #[error("{entity}: {message}")]
    Choice {
        /// Where.
        entity: Entity,
        /// The first field concerned (used to locate the line).
        field: &'static str,
        /// What to write instead.
        message: &'static str,
    },
    /// A node index beyond the last node.
    #[error("{entity}: node {node} does not exist (the beam has {nodes} nodes, 0 to {last})", last = nodes - 1)]
    NodeOutOfRange {
        /// Where.
        entity: Entity,
        /// The node given.
        node: usize,
        /// Number of nodes of the mesh.
        nodes: usize,
    },
    /// A position `x` that does not coincide with a node of the mesh.
    #[error(
        "{entity}: x = {x} is not at a node (nearest is node {nearest} at x = {nearest_x}): \
         supports and nodal loads must sit on nodes"
    )]
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
    #[error("{entity}: segment {segment} does not exist (the beam has {segments} segments)")]
    SegmentOutOfRange {
        /// Where.
        entity: Entity,
        /// The segment given.
        segment: usize,
        /// Number of segments.
        segments: usize,
    },
    /// `damping.ratios` does not have exactly two entries.
    #[error("damping: ratios needs exactly two entries, one per target mode (got {got})")]
    RatioCount {
        /// Number of entries given.
        got: usize,
    },
    /// A target mode number of `damping.ratios` is zero (modes are numbered from 1).
    #[error("damping: ratios[{index}]: mode numbers start at 1 (got 0)")]
    ModeZero {
        /// Entry of `ratios`.
        index: usize,
    },
    /// Both entries of `damping.ratios` target the same mode.
    #[error("damping: ratios target mode {mode} twice; give two different modes")]
    SameMode {
        /// The repeated mode number.
        mode: usize,
    },
}

impl InputError {
    /// The TOML location the error is about: table key, array index, field (any may be
    /// missing). Used to find the line in the source text.
    pub fn location(&self) -> (Option<Entity>, Option<&'static str>) {
        match self {
            InputError::NoSegments => (None, None),
            InputError::NotPositive { entity, field, .. }
            | InputError::Negative { entity, field, .. }
            | InputError::NotFinite { entity, field, .. }
            | InputError::Choice { entity, field, .. } => (Some(*entity), Some(field)),
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
}

/// An [`InputError`] with the line of the source file it refers to, when known.
#[derive(Clone, Debug, PartialEq)]
pub struct Issue {
    /// 1-based line in the source text, when the description came from TOML text.
    pub line: Option<usize>,
    /// The problem.
    pub error: InputError,
}

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
    /// TOML syntax error, unknown field, missing field or wrong type.
    #[error("{origin}:{line}:{column}: {message}")]
    Parse {
        /// File name (or other origin) of the text.
        origin: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// The description is well-formed TOML but not a valid beam: every problem found.
    #[error("{}", display_issues(origin.as_deref(), issues))]
    Invalid {
        /// File name of the description, when it came from a file.
        origin: Option<String>,
        /// All problems: segments, supports, damping, loads, each in file order.
        issues: Vec<Issue>,
    },
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
    /// A banded kernel failed.
    #[error(transparent)]
    Linalg(#[from] LinalgError),
}

fn display_issues(origin: Option<&str>, issues: &[Issue]) -> String {
    let mut out = String::new();
    for (i, issue) in issues.iter().enumerate() {
        if i > 0 {
            out.push_str("; ");
        }
        match (origin, issue.line) {
            (Some(o), Some(l)) => out.push_str(&format!("{o}:{l}: ")),
            (Some(o), None) => out.push_str(&format!("{o}: ")),
            (None, Some(l)) => out.push_str(&format!("line {l}: ")),
            (None, None) => {}
        }
        out.push_str(&issue.error.to_string());
    }
    out
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
        let err = BeamError::Invalid {
            origin: Some("b.toml".into()),
            issues: vec![
                Issue {
                    line: Some(3),
                    error: InputError::NoElements { segment: 0 },
                },
                Issue {
                    line: None,
                    error: InputError::NoSegments,
                },
            ],
        };
        let s = err.to_string();
        assert_eq!(
            s,
            "b.toml:3: segment 0: elements must be at least 1 (got 0); b.toml: the beam has no \
             segments: add at least one [[segment]] table"
        );
        assert!(!s.contains('\n'));
    }
}
