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
//! # At a node of a [structure] (or anywhere) the pivot may lie along a direction of the
//! # structure's frame, at the half-angle's distance, the knee on the counter-clockwise
//! # ("+") or clockwise ("-", the default) side of the pivot -> point axis:
//! # placement = { attachment = "pin", half_angle_deg = 10.0, pivot_direction = [-1.0, 0.0], knee = "+" }
//! [[attachment]]
//! name = "left_pin"
//! mechanism = "left"
//! point = "tip"              # a point of the model (not on ground)
//! kind = "pin"               # both directions (2 rows) | "roller": transverse only (1 row)
//! # at a node of a [structure]: node = 12, and for a roller direction = [dx, dy] (the
//! # node's displacement along it drives the point; free across it)
//! x = 0.333                  # beam abscissa (m): a node or inside an element (eq. 35)
//! [[force]]
//! name = "gen_left"
//! mechanism = "left"
//! joint = "crank"            # a body name: the force acts on its joint's coordinate
//! kind = "generator"         # + the damper kind's [generator] fields (kt, ke, ...; numbers
//!                            #   in SI or datasheet quantities: see `generator.rs`)
//!                            # | "damper" with c | "spring" with k and q0
//! [[excitation]]
//! name = "shaker"
//! at = { x = 1.0 }           # transverse beam force, or { mechanism = "left", joint = "crank" }
//!                            # or "base": the supports' transverse acceleration (every
//!                            #   mass loaded by -m a_b in the frame moving with them)
//! amplitude = 0.5            # N (N m on a revolute joint; m/s^2 at "base"); not with a random time
//! time = { kind = "harmonic", frequency_hz = 6.2, phase = 0.0 }
//! # or { kind = "step", at = 0.1 }, { kind = "constant" },
//! # { kind = "table", points = [[0.0, 0.0], [0.1, 1.0]] } or
//! # { kind = "table", file = "force.csv" } (t,value rows, piecewise linear, relative to the
//! #   scenario file; an optional header line), or random (no amplitude: the PSD carries the
//! #   level; see `damper random`): { kind = "white_noise", psd = 1e-4, band = [0.5, 500.0] },
//! #   { kind = "psd", table = [[f, G], ...] } or { kind = "psd", file = "psd.csv" } (f,G rows),
//! #   each with an optional seed = N of the time-domain realisation
//! [initial]                  # optional: the beam in the static shape of a point load at x,
//! displacement = 0.001       #   scaled to this displacement there (m); at rest otherwise
//! x = 1.0
//! [integrator]               # as the damper kind: method newmark | hht (alpha), dt, t_end
//! [output]
//! every = 10                 # a CSV row every 10 steps
//! compare = ["generator_disconnected", "bare_beam"]   # comparison runs (none by default):
//!                            #   every generator's circuit open; the beam alone, read at
//!                            #   the attachments' beam points (needs a [beam];
//!                            #   "bare_structure" for a [structure])
//! points = ["741:ux", "741:uy"]  # displacements written as time-history columns in every
//!                            #   run (`741:ux [m]`, `741:ux_dot [m/s]`): NODE:DOF on a
//!                            #   [structure], a beam abscissa ("0.5", column `w(x=0.5)`)
//!                            #   on a [beam]; on a reduced model read through q = T z
//! ```
//!
//! Loading (`reader::from_doc`, through the one loader [`super::load`]) checks the file itself:
//! keys, values, names that refer to other entries of the file, the beam, the time
//! tables. The setup stage ([`crate::setup::build()`]) then loads the mechanism models and
//! checks what needs them (points, joints, coordinates, parameters, points on ground,
//! over-constraint, placements) and assembles the initial state. Both report every problem at once, each
//! with file:line:column and the entity.
//!
//! The reader's files: `schema.rs` (the tables as written, serde), `reader.rs` (one
//! function per section), `checks.rs` (the value checks the sections share), `table.rs`
//! (time functions and time tables) and `generator.rs` (the generator's fields, with
//! datasheet units); this module holds the entries the setup stage reads.

mod checks;
pub mod generator;
mod reader;
mod schema;
mod table;

use std::ops::Range;
use std::path::{Path, PathBuf};

use diagnostic::{Diagnostic, Diagnostics, Kind, LineIndex};
use fem_beam::{Beam, BeamSpec, TimeFunction};
use fem_structure::{MatrixFiles, StructureParts};
use hybrid_core::hybrid::Method;
use hybrid_core::hybrid::{AttachmentKind, ForceKind, Placement};

use super::compare::Comparison;
use super::integrator::IntegratorSpec;

pub(crate) use checks::list;
pub(crate) use reader::from_doc;
pub use table::read_table;

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
    /// Beam abscissa (m; 0 for an attachment at a node).
    pub x: f64,
    /// The node of a `[structure]` it is attached to (`None`: the beam point at `x`).
    pub node: Option<u64>,
    /// The unit direction (structure frame) a roller at a node follows; `None` for a pin
    /// and on the beam (where a roller follows `y`).
    pub direction: Option<[f64; 2]>,
    pub(crate) point_span: Range<usize>,
    /// Where its `x` or `node` is written.
    pub(crate) x_span: Range<usize>,
}

/// Where a `[structure]`'s matrices and tables come from.
#[derive(Clone, Debug)]
pub enum StructureSource {
    /// Files (`kind = "matrices"`), resolved against the scenario's directory.
    Files(MatrixFiles),
    /// Given in memory (`kind = "given"`: the Python package's `Structure.from_matrices`,
    /// through [`crate::scenario::Override::structure`]), with the damping written in the
    /// table.
    Given {
        /// The matrices and tables, checked.
        parts: std::sync::Arc<StructureParts>,
        /// Its damping (`Matrix`: the given `C`).
        damping: fem_structure::DampingInput,
    },
}

impl PartialEq for StructureSource {
    /// Files by their paths; given parts by identity.
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (StructureSource::Files(a), StructureSource::Files(b)) => a == b,
            (
                StructureSource::Given { parts, damping },
                StructureSource::Given {
                    parts: p,
                    damping: d,
                },
            ) => std::sync::Arc::ptr_eq(parts, p) && damping == d,
            _ => false,
        }
    }
}

/// `[structure]`: a model from another finite-element program (`fem_structure`).
#[derive(Clone, Debug, PartialEq)]
pub struct StructureEntry {
    /// Its matrices and tables.
    pub source: StructureSource,
    /// Craig–Bampton reduction with this many fixed-interface modes (`None`: the full
    /// model runs).
    pub reduction_modes: Option<usize>,
    /// What the deformed-shape plots draw (`elements = "..."` of a `matrices` structure),
    /// read and checked against the node table when the scenario is read; `None` when no
    /// elements are given (no such plot).
    pub drawing: Option<StructureDrawing>,
    pub(crate) span: Range<usize>,
}

/// What the deformed-shape plots draw of a node-based structure
/// ([`crate::report::shape`]): its nodes and the lines between them (drawing only).
#[derive(Clone, Debug, PartialEq)]
pub struct StructureDrawing {
    /// The node table.
    pub nodes: Vec<fem_structure::tables::Node>,
    /// `(node1, node2)` per line, in the table's order; every node one of `nodes`.
    pub elements: Vec<(u64, u64)>,
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
    /// The supports' acceleration along a unit direction of the structure's x-y plane
    /// (`at = "base"`, `direction = [dx, dy]`, default `[0, 1]`: the beam's transverse
    /// `y`, the only direction on a beam; amplitude in m/s^2).
    Base {
        /// The direction (unit vector).
        direction: [f64; 2],
    },
    /// A force at a node of a `[structure]` along a unit direction in its x-y plane.
    Node {
        /// The node id.
        node: u64,
        /// The direction (unit vector).
        direction: [f64; 2],
    },
}

/// One `[[excitation]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct ExcitationEntry {
    /// Its name.
    pub name: String,
    /// Where it acts.
    pub target: TargetEntry,
    /// Amplitude (N or N m; m/s^2 at the supports).
    pub amplitude: f64,
    /// Time dependence (a table file already read).
    pub time: TimeFunction,
    pub(crate) at_span: Range<usize>,
}

/// Where an `[output] points` entry reads the structure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PointAt {
    /// The beam's transverse displacement at abscissa `x` (m).
    Beam {
        /// The abscissa.
        x: f64,
    },
    /// A node's displacement along `direction` (`[1, 0]`: its `ux`; `[0, 1]`: its `uy`).
    Node {
        /// The node id.
        node: u64,
        /// The unit direction.
        direction: [f64; 2],
    },
}

/// One `[output] points` entry: a displacement written as a time-history column.
#[derive(Clone, Debug, PartialEq)]
pub struct PointEntry {
    /// The column's name (unit aside): `741:ux`, or `w(x=0.5)` on the beam.
    pub name: String,
    /// What it reads.
    pub at: PointAt,
    pub(crate) span: Range<usize>,
}

/// A loaded and checked hybrid scenario (models not loaded yet: [`crate::setup::build()`]).
#[derive(Clone, Debug)]
pub struct HybridScenario {
    /// The scenario file as given.
    pub path: PathBuf,
    /// Free text.
    pub description: Option<String>,
    /// The beam as written and validated.
    pub beam: Option<(BeamSpec, Beam)>,
    /// The imported structure's files (instead of a beam).
    pub structure: Option<StructureEntry>,
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
    /// Displacements written as time-history columns in every run (`[output] points`).
    pub points: Vec<PointEntry>,
    pub(crate) index: LineIndex,
    pub(crate) beam_span: Option<Range<usize>>,
    pub(crate) initial_x_span: Option<Range<usize>>,
}

impl HybridScenario {
    /// What a plot's title names the scenario by: its description, else its file's path.
    pub fn title(&self) -> String {
        self.description
            .clone()
            .unwrap_or_else(|| self.path.display().to_string())
    }

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
