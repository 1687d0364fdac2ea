//! What a hybrid system is made of: an optional beam, mechanisms placed in the beam's plane,
//! attachments between mechanism points and beam points, force elements on joints and
//! excitations — and the checks that make such a description usable.

use fem_beam::{BeamModel, ShapeAt, TimeFunction};
use mbs_symbolic::runtime::{System, Workspace};
use nalgebra::{DMatrix, DVector};

use super::structure::{LinearStructure, Structure};
use crate::generator::GeneratorSpec;

/// Where a mechanism's ground frame sits in the beam's plane: the beam frame has `x` along
/// the undeformed beam axis and `y` along its transverse displacement `w`. A point `p` of the
/// mechanism (its ground-frame `x`, `y`) is at `origin + R(angle) p` in the beam frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Mount {
    /// Position of the mechanism's ground origin in the beam frame (m).
    pub origin: [f64; 2],
    /// Angle from the beam's `x` axis to the mechanism's `x` axis (rad).
    pub angle: f64,
}

impl Mount {
    /// `(cos, sin)` of the mounting angle.
    pub fn rotation(&self) -> (f64, f64) {
        (self.angle.cos(), self.angle.sin())
    }

    /// A mechanism-frame vector rotated into the beam frame.
    pub fn rotate(&self, v: [f64; 2]) -> [f64; 2] {
        let (c, s) = self.rotation();
        [c * v[0] - s * v[1], s * v[0] + c * v[1]]
    }

    /// A beam-frame vector rotated into the mechanism frame, `R(angle)^T v` (the inverse
    /// of [`Mount::rotate`]).
    pub fn to_ground(&self, v: [f64; 2]) -> [f64; 2] {
        let (c, s) = self.rotation();
        [c * v[0] + s * v[1], -s * v[0] + c * v[1]]
    }

    /// The beam's transverse direction `y` in the mechanism's ground frame,
    /// `R(angle)^T (0, 1, 0) = (sin, cos, 0)`: the direction in which a beam's supports move
    /// the mechanism's ground under a base excitation.
    pub fn transverse_in_ground(&self) -> [f64; 3] {
        let (c, s) = self.rotation();
        [s, c, 0.0]
    }

    /// A mechanism-frame point in the beam frame.
    pub fn to_beam(&self, p: [f64; 2]) -> [f64; 2] {
        self.to_beam_with(self.rotation(), p)
    }

    /// [`Mount::to_beam`] with the rotation `(cos, sin)` already evaluated
    /// ([`Mount::rotation`]): the step's hot path keeps it instead of evaluating the
    /// trigonometric functions at every call.
    #[inline]
    pub fn to_beam_with(&self, (c, s): (f64, f64), p: [f64; 2]) -> [f64; 2] {
        let r = [c * p[0] - s * p[1], s * p[0] + c * p[1]];
        [self.origin[0] + r[0], self.origin[1] + r[1]]
    }
}

/// A mechanism of the hybrid system: any [`System`] (generated, interpreted or numeric), with
/// its loop constraints, placed in the beam's plane.
#[derive(Clone, Debug)]
pub struct MountedMechanism {
    /// Name used in reports and messages.
    pub name: String,
    /// The mechanism's equations (run-time parameters already set).
    pub system: Box<dyn System>,
    /// Where its ground frame is.
    pub mount: Mount,
    /// 2-norm condition number of its dependent Jacobian `J_d` beyond which the run stops
    /// (approach of a singular position).
    pub max_condition: f64,
    /// How far the first attached beam point can move from its undeformed position in the
    /// direction that stretches the mechanism (m), where the geometry gives it (reported when
    /// the mechanism cannot follow).
    pub reach: Option<f64>,
    /// Initial values of all coordinates: exact for the independent ones (the free
    /// coordinates of the first partition), a guess (selecting the assembly branch) for the
    /// dependent ones.
    pub initial_q: Vec<f64>,
}

/// A point of the host structure: where it is and the weights giving its displacement from
/// the structure's coordinates. On the beam (eq. 35) the point moves transversely only,
/// `w = sum_k weight_k q_k`; a node of an imported model moves along `y` by its `uy`
/// coordinate and along `x` by its `ux` coordinate (the [`BeamPoint::axial`] weights, empty on
/// the beam).
#[derive(Clone, Debug, PartialEq)]
pub struct BeamPoint {
    /// Abscissa along the beam, or the node's `x` (m).
    pub x: f64,
    /// The point's undeformed `y` (m; 0 on the beam).
    pub y: f64,
    /// `(coordinate, weight)` of the displacement along [`BeamPoint::direction`] (`y`
    /// unless seen along another direction); zero weights and locked DOFs are left out.
    pub weights: Vec<(usize, f64)>,
    /// `(coordinate, weight)` of the displacement along `x` (empty on the beam, whose
    /// points do not move axially).
    pub axial: Vec<(usize, f64)>,
    /// The unit direction (structure frame) of the displacement that `weights` give:
    /// `[0, 1]` (along `y`) on the beam and at a node; a point seen along a direction `d`
    /// ([`BeamPoint::along`]: a roller at a node, a force along `d`) has the weights of
    /// `d . (u_x, u_y)` and this `d`.
    pub direction: [f64; 2],
}

impl BeamPoint {
    /// The point at `x` of `beam`: one weight 1 at a node, up to four shape-function weights
    /// inside an element (eq. 35). `None` when `x` is not on the beam.
    pub fn on(beam: &BeamModel, x: f64) -> Option<BeamPoint> {
        let shape: ShapeAt = beam.shape_at(x).ok()?;
        let weights = (0..4)
            .filter_map(|k| shape.dofs[k].map(|i| (i, shape.weights[0][k])))
            .filter(|&(_, w)| w != 0.0)
            .collect();
        Some(BeamPoint {
            x,
            y: 0.0,
            weights,
            axial: vec![],
            direction: [0.0, 1.0],
        })
    }

    /// A node of an imported structure at `position`, moved by its coordinates `ux` and
    /// `uy` (`None` where a support holds the node in that direction).
    pub fn node(position: [f64; 2], ux: Option<usize>, uy: Option<usize>) -> BeamPoint {
        BeamPoint {
            x: position[0],
            y: position[1],
            weights: uy.map(|k| (k, 1.0)).into_iter().collect(),
            axial: ux.map(|k| (k, 1.0)).into_iter().collect(),
            direction: [0.0, 1.0],
        }
    }

    /// This point seen along the unit `direction` (structure frame): one component, the
    /// displacement `d . (u_x, u_y)`, its weights those of `u_x` times `d_x` then those of
    /// `u_y` times `d_y` (zeros left out), no axial component.
    pub fn along(&self, direction: [f64; 2]) -> BeamPoint {
        let d = direction;
        let mut weights: Vec<(usize, f64)> =
            self.axial.iter().map(|&(k, w)| (k, w * d[0])).collect();
        weights.extend(self.weights.iter().map(|&(k, w)| (k, w * d[1])));
        weights.retain(|&(_, w)| w != 0.0);
        BeamPoint {
            x: self.x,
            y: self.y,
            weights,
            axial: vec![],
            direction: d,
        }
    }

    /// The weights of one component: along `x` (`axial`) or along `y`.
    pub fn component(&self, axial: bool) -> &[(usize, f64)] {
        if axial { &self.axial } else { &self.weights }
    }

    /// The displacement along `x` (`axial`) or `y` of a coordinate vector.
    #[inline]
    pub fn value_along(&self, axial: bool, x: &[f64]) -> f64 {
        self.component(axial).iter().map(|&(k, w)| w * x[k]).sum()
    }

    /// `out += f n` for the component along `x` (`axial`) or `y`.
    pub fn add_force_along(&self, axial: bool, f: f64, out: &mut [f64]) {
        for &(k, w) in self.component(axial) {
            out[k] += w * f;
        }
    }

    /// The displacement along `y`, `w = sum_k weight_k x_k`, for a coordinate vector
    /// (displacements, velocities, ...).
    pub fn value(&self, x: &[f64]) -> f64 {
        self.weights.iter().map(|&(k, w)| w * x[k]).sum()
    }

    /// [`BeamPoint::value`] of a complex DOF vector (a harmonic response).
    pub fn complex_value(&self, z: &[nalgebra::Complex<f64>]) -> nalgebra::Complex<f64> {
        self.weights.iter().map(|&(k, w)| z[k] * w).sum()
    }

    /// `out += f n` (the generalized force vector of a unit force along `y`, scaled by `f`).
    pub fn add_force(&self, f: f64, out: &mut [f64]) {
        for &(k, w) in &self.weights {
            out[k] += w * f;
        }
    }

    /// Whether every DOF of the point is locked (a support holds it): it moves neither
    /// along `y` nor along `x`.
    pub fn is_locked(&self) -> bool {
        self.weights.is_empty() && self.axial.is_empty()
    }
}

/// How a mechanism point follows a beam point (eqs. 45–46).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AttachmentKind {
    /// Both directions: rows `P_y - w(x_b)` and `P_x - x_b` (2 rows).
    Pin,
    /// One component only: row `d . P - d . P_0 - w` with `d` the beam point's
    /// [`BeamPoint::direction`] (on the beam `d = y`: `P_y - w(x_b)`, the point slides
    /// freely along the beam axis; at a node along any `d`, free across it) (1 row).
    Roller,
}

impl AttachmentKind {
    /// Constraint rows it adds.
    pub fn rows(self) -> usize {
        match self {
            AttachmentKind::Pin => 2,
            AttachmentKind::Roller => 1,
        }
    }

    /// `"pin"` or `"roller"`.
    pub fn as_str(self) -> &'static str {
        match self {
            AttachmentKind::Pin => "pin",
            AttachmentKind::Roller => "roller",
        }
    }
}

/// A mechanism point attached to a beam point.
#[derive(Clone, Debug, PartialEq)]
pub struct Attachment {
    /// Name used in reports and messages.
    pub name: String,
    /// Index into [`HybridModel::mechanisms`].
    pub mechanism: usize,
    /// Index of the mechanism point ([`System::point_names`]).
    pub point: usize,
    /// Pin or roller.
    pub kind: AttachmentKind,
    /// The beam point.
    pub beam: BeamPoint,
}

/// One displacement component of an attachment's point through which the structure and a
/// mechanism are coupled: the transverse (`y`) component of every attachment, and the axial
/// (`x`) one of a pin on a point that moves along `x` (a node of an imported model; the
/// beam's points do not). The engine's coupling unknowns `w` are these, in
/// [`HybridModel::couplings`] order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Coupling {
    /// Index into [`HybridModel::attachments`].
    pub attachment: usize,
    /// The `x` component (else `y`).
    pub axial: bool,
}

/// A force element on a joint, in the paper's sign (its contribution to `Q^b`, eq. 13).
#[derive(Clone, Debug, PartialEq)]
pub enum ForceKind {
    /// The DC generator (docs/theory.md section 7), with its current as a state when its
    /// inductance is > 0.
    Generator(GeneratorSpec),
    /// Viscous damper: `Q_j += c q_j'`.
    Damper {
        /// Damping coefficient (N s/m or N m s/rad).
        c: f64,
    },
    /// Linear spring: `Q_j += k (q_j - q0)`, energy `k (q_j - q0)^2 / 2`.
    Spring {
        /// Stiffness (N/m or N m/rad).
        k: f64,
        /// Unstretched value of the coordinate (m or rad).
        q0: f64,
    },
}

impl ForceKind {
    /// `"generator"`, `"damper"` or `"spring"`.
    pub fn as_str(&self) -> &'static str {
        match self {
            ForceKind::Generator(_) => "generator",
            ForceKind::Damper { .. } => "damper",
            ForceKind::Spring { .. } => "spring",
        }
    }
}

/// A force element on joint `joint` of mechanism `mechanism`.
#[derive(Clone, Debug, PartialEq)]
pub struct JointForce {
    /// Name used in reports and messages.
    pub name: String,
    /// Index into [`HybridModel::mechanisms`].
    pub mechanism: usize,
    /// Coordinate index of the joint.
    pub joint: usize,
    /// What it is.
    pub kind: ForceKind,
}

impl JointForce {
    /// The generator, if this is one.
    #[inline]
    pub fn generator(&self) -> Option<&GeneratorSpec> {
        match &self.kind {
            ForceKind::Generator(g) => Some(g),
            _ => None,
        }
    }

    /// Whether it carries a current state (a connected generator with inductance > 0).
    #[inline]
    pub fn has_current_state(&self) -> bool {
        self.generator()
            .is_some_and(GeneratorSpec::has_current_state)
    }

    /// The current through it at joint speed `qd` when it has no current state (0 for
    /// elements that are not generators).
    #[inline]
    pub fn quasi_static_current(&self, qd: f64) -> f64 {
        self.generator().map_or(0.0, |g| g.quasi_static_current(qd))
    }

    /// Adds the element to `M^b` (rotor inertia) and `Q^b` at joint position `q`, speed `qd`,
    /// with generator current `current`.
    #[inline]
    pub fn add_to_equations(
        &self,
        q: f64,
        qd: f64,
        current: f64,
        m: &mut DMatrix<f64>,
        qv: &mut DVector<f64>,
    ) {
        let j = self.joint;
        match &self.kind {
            ForceKind::Generator(g) => g.add_to_equations(j, qd, current, m, qv),
            ForceKind::Damper { c } => qv[j] += c * qd,
            ForceKind::Spring { k, q0 } => qv[j] += k * (q - q0),
        }
    }

    /// Power dissipated at joint speed `qd` and current `current` (W): `(R_a + R_L) i^2` plus
    /// the gear's loss ([`GeneratorSpec::gear_loss_power`]) for a generator, `c q'^2` for a
    /// damper, 0 for a spring.
    pub fn dissipated_power(&self, qd: f64, current: f64) -> f64 {
        match &self.kind {
            ForceKind::Generator(g) if g.has_gear_loss() => {
                g.resistance() * current * current + g.gear_loss_power(qd)
            }
            ForceKind::Generator(g) => g.resistance() * current * current,
            ForceKind::Damper { c } => c * qd * qd,
            ForceKind::Spring { .. } => 0.0,
        }
    }

    /// Stored energy at joint position `q` and current `current` (J): the spring's
    /// `k (q - q0)^2 / 2`, the generator's magnetic `L i^2 / 2`.
    pub fn stored_energy(&self, q: f64, current: f64) -> f64 {
        match &self.kind {
            ForceKind::Generator(g) => 0.5 * g.inductance * current * current,
            ForceKind::Damper { .. } => 0.0,
            ForceKind::Spring { k, q0 } => 0.5 * k * (q - q0).powi(2),
        }
    }
}

/// Where an excitation acts.
#[derive(Clone, Debug, PartialEq)]
pub enum ExcitationTarget {
    /// A transverse force at a beam point.
    Beam(BeamPoint),
    /// A torque (revolute) or force (prismatic) on a joint of a mechanism, driving the
    /// coordinate: `Q_j -= f(t)`.
    Joint {
        /// Index into [`HybridModel::mechanisms`].
        mechanism: usize,
        /// Coordinate index of the joint.
        joint: usize,
    },
    /// The supports: a prescribed acceleration `a_b(t) d` (m/s^2) of everything that holds
    /// the system — the structure's supports and every mechanism's ground frame move
    /// together along the unit `direction` `d` of the structure's x-y plane (`[0, 1]`, the
    /// beam's `y`, on a beam: the only direction a beam accepts). The equations are written
    /// in the frame moving with the supports: structure DOFs are relative to the supports,
    /// mechanism grounds move with them, and every mass carries the inertial load
    /// `-m a_b d`: `P += -(A r) a_b` on the structure (`r` the rigid translation along `d`,
    /// [`LinearStructure::rigid_translation`]) and `F^b += -G(q) a_b R^T d` on each
    /// mechanism (`G = dF^b/dg`, [`System::gravity_load_jacobian`]; `R^T d` the direction in
    /// the mechanism's ground frame). docs/theory.md section 13.6.
    Base {
        /// The unit direction of the support motion in the structure's (beam's) frame.
        direction: [f64; 2],
    },
}

impl ExcitationTarget {
    /// The supports' motion along the beam's transverse `y` (the only direction on a beam).
    pub const BASE_Y: ExcitationTarget = ExcitationTarget::Base {
        direction: [0.0, 1.0],
    };

    /// Whether this is the supports' motion ([`ExcitationTarget::Base`]).
    pub fn is_base(&self) -> bool {
        matches!(self, ExcitationTarget::Base { .. })
    }
}

/// An external excitation: `amplitude * time(t)` at `target`.
#[derive(Clone, Debug, PartialEq)]
pub struct Excitation {
    /// Name used in reports and messages.
    pub name: String,
    /// Where it acts.
    pub target: ExcitationTarget,
    /// Amplitude (N, or N m on a revolute joint; m/s^2 for the supports' acceleration).
    pub amplitude: f64,
    /// Time dependence (harmonic, step, piecewise-linear table, constant).
    pub time: TimeFunction,
}

impl Excitation {
    /// The force, torque or support acceleration at time `t`.
    pub fn value(&self, t: f64) -> f64 {
        self.amplitude * self.time.value(t)
    }

    /// The motion this excitation gives the supports when it is their acceleration
    /// ([`ExcitationTarget::Base`]): `(u, v)`, displacement (m) and velocity (m/s) at `t`,
    /// the integrals of `a(t) = amplitude f(t)`:
    ///
    /// - harmonic `sin(w t + phi)` (`w > 0`): the zero-mean periodic motion
    ///   `v = -a cos(w t + phi) / w`, `u = -a sin(w t + phi) / w^2` (the steady motion of a
    ///   support shaken at that frequency, whatever it did before `t = 0`);
    /// - constant, step, table (and a harmonic at 0 Hz, a constant): the exact integrals
    ///   from rest at `t = 0` (`u(0) = v(0) = 0`; the table is piecewise linear, so its
    ///   integrals are exact piecewise polynomials).
    ///
    /// - a random kind's realisation ([`fem_beam::TimeFunction::Sampled`]): its zero-mean
    ///   periodic integrals (exact at the realisation's grid, linear between); an unrealised
    ///   random kind (never run) has none: `(0, 0)`.
    ///
    /// Allocation-free; `O(points)` for a table.
    pub fn support_motion(&self, t: f64) -> (f64, f64) {
        let a = self.amplitude;
        match &self.time {
            TimeFunction::Harmonic {
                frequency_hz,
                phase,
            } if *frequency_hz > 0.0 => {
                let w = 2.0 * std::f64::consts::PI * frequency_hz;
                let (s, c) = (w * t + phase).sin_cos();
                (-a * s / (w * w), -a * c / w)
            }
            TimeFunction::Harmonic { phase, .. } => {
                let f = phase.sin();
                (a * f * t * t / 2.0, a * f * t)
            }
            TimeFunction::Constant => (a * t * t / 2.0, a * t),
            TimeFunction::Step { at } => {
                let d = (t - at.max(0.0)).max(0.0);
                (a * d * d / 2.0, a * d)
            }
            TimeFunction::Table { points } => {
                // Exact over each linear piece [t0, t1]: u += v dt + dt^2 (2 f0 + f1) / 6,
                // v += dt (f0 + f1) / 2, the pieces cut at the table's times.
                let (mut u, mut v) = (0.0, 0.0);
                let mut t0 = 0.0;
                let knots = points.iter().map(|p| p[0]).filter(|&k| k > 0.0 && k < t);
                for t1 in knots.chain(std::iter::once(t)) {
                    if t1 <= t0 {
                        continue;
                    }
                    let (f0, f1) = (self.time.value(t0), self.time.value(t1));
                    let dt = t1 - t0;
                    u += v * dt + dt * dt * (2.0 * f0 + f1) / 6.0;
                    v += dt * (f0 + f1) / 2.0;
                    t0 = t1;
                }
                (a * u, a * v)
            }
            TimeFunction::Sampled(s) => {
                let (u, v) = s.integrals(t);
                (a * u, a * v)
            }
            TimeFunction::WhiteNoise { .. } | TimeFunction::Psd { .. } => (0.0, 0.0),
        }
    }
}

/// A hybrid system: beam + mechanisms + attachments + force elements + excitations.
///
/// Built by [`HybridModel::new`], which checks that every index exists and that no
/// mechanism is over-constrained (more loop and attachment rows than coordinates).
#[derive(Clone, Debug)]
pub struct HybridModel {
    /// The host structure (eq. 44): the beam or an imported model, if there is one.
    pub structure: Option<Structure>,
    /// The mechanisms.
    pub mechanisms: Vec<MountedMechanism>,
    /// The attachments (each joins one mechanism point to one beam point).
    pub attachments: Vec<Attachment>,
    /// Force elements on joints.
    pub forces: Vec<JointForce>,
    /// Excitations.
    pub excitations: Vec<Excitation>,
}

/// Why a hybrid system description cannot be used; each names the entity (`mechanism
/// "left"`, `attachment "tip"`, `force "gen"`, `excitation "shaker"`) and carries the
/// index or value at fault.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ModelError {
    /// A mechanism index out of range.
    #[error("{entity}: no mechanism number {index}")]
    NoMechanism {
        /// The entity.
        entity: String,
        /// The index.
        index: usize,
    },
    /// A point index out of range of its mechanism's points.
    #[error("{entity}: mechanism \"{mechanism}\" has no point number {index}")]
    NoPoint {
        /// The entity.
        entity: String,
        /// The mechanism.
        mechanism: String,
        /// The index.
        index: usize,
    },
    /// A joint index out of range of its mechanism's coordinates.
    #[error("{entity}: mechanism \"{mechanism}\" has no joint number {index}")]
    NoJoint {
        /// The entity.
        entity: String,
        /// The mechanism.
        mechanism: String,
        /// The index.
        index: usize,
    },
    /// A beam point's weights refer to degrees of freedom the beam does not have (or are
    /// not finite).
    #[error("{entity}: beam point outside the beam")]
    OutsideBeam {
        /// The entity.
        entity: String,
    },
    /// More constraint rows than coordinates.
    #[error(
        "mechanism \"{mechanism}\": over-constrained: {rows} constraint rows ({loops} loop row(s) + {attached} attachment row(s)) for {dof} coordinate(s)"
    )]
    OverConstrained {
        /// The mechanism.
        mechanism: String,
        /// Total rows.
        rows: usize,
        /// Loop rows of the model.
        loops: usize,
        /// Rows from attachments.
        attached: usize,
        /// Coordinates.
        dof: usize,
    },
    /// Attachments or beam excitations without a beam.
    #[error("{entity}: there is no beam to attach to")]
    NoBeam {
        /// The entity.
        entity: String,
    },
    /// A beam point held by a support.
    #[error("{entity}: the beam cannot move transversely at x = {x} (a support locks it)")]
    Locked {
        /// The entity.
        entity: String,
        /// The abscissa.
        x: f64,
    },
    /// Initial coordinates of the wrong count.
    #[error("{entity}: {given} initial coordinate(s) given for {dof} coordinate(s)")]
    InitialCount {
        /// The mechanism.
        entity: String,
        /// Coordinates given.
        given: usize,
        /// Coordinates of the model.
        dof: usize,
    },
    /// A non-finite mounting position, angle or initial coordinate.
    #[error("{entity}: mounting position, angle and initial coordinates must be finite")]
    NotFinitePlacement {
        /// The mechanism.
        entity: String,
    },
    /// A stop condition number that is not above 1.
    #[error("{entity}: max_condition = {value} must be > 1")]
    MaxCondition {
        /// The mechanism.
        entity: String,
        /// The value.
        value: f64,
    },
    /// A generator whose parameters cannot be used.
    #[error("{entity}: {source}")]
    Generator {
        /// The force element.
        entity: String,
        /// Why.
        source: crate::generator::GeneratorError,
    },
    /// A damper or spring with a negative or non-finite coefficient.
    #[error("{entity}: {kind} values must be finite and non-negative")]
    Coefficient {
        /// The force element.
        entity: String,
        /// Its kind (`damper`, `spring`).
        kind: &'static str,
    },
    /// A non-finite excitation amplitude.
    #[error("{entity}: amplitude = {value} is not finite")]
    Amplitude {
        /// The excitation.
        entity: String,
        /// The value.
        value: f64,
    },
    /// A support motion whose direction is not a unit vector of finite components.
    #[error("{entity}: direction = [{}, {}] is not a unit vector", .direction[0], .direction[1])]
    BaseDirection {
        /// The excitation.
        entity: String,
        /// The direction.
        direction: [f64; 2],
    },
    /// A support motion along a direction other than the beam's transverse `y`.
    #[error(
        "{entity}: direction = [{}, {}]: the beam's supports move along its transverse y only ([0.0, 1.0]); \
         axial support motion needs a [structure]",
        .direction[0], .direction[1]
    )]
    BaseNotTransverse {
        /// The excitation.
        entity: String,
        /// The direction.
        direction: [f64; 2],
    },
    /// Support motions along different directions.
    #[error(
        "{entity}: direction = [{}, {}] differs from excitation \"{first}\"'s [{}, {}]; \
         every support motion of a scenario must share one direction",
        .direction[0], .direction[1], .first_direction[0], .first_direction[1]
    )]
    BaseDirections {
        /// The excitation.
        entity: String,
        /// Its direction.
        direction: [f64; 2],
        /// The first support motion.
        first: String,
        /// Its direction.
        first_direction: [f64; 2],
    },
}

impl HybridModel {
    /// Checks a description: indices, over-constraint, beam presence, values.
    pub fn new(
        structure: Option<Structure>,
        mechanisms: Vec<MountedMechanism>,
        attachments: Vec<Attachment>,
        forces: Vec<JointForce>,
        excitations: Vec<Excitation>,
    ) -> Result<HybridModel, ModelError> {
        let model = HybridModel {
            structure,
            mechanisms,
            attachments,
            forces,
            excitations,
        };
        model.check()?;
        Ok(model)
    }

    fn check(&self) -> Result<(), ModelError> {
        for m in &self.mechanisms {
            let entity = format!("mechanism \"{}\"", m.name);
            if m.initial_q.len() != m.system.dof() {
                return Err(ModelError::InitialCount {
                    entity,
                    given: m.initial_q.len(),
                    dof: m.system.dof(),
                });
            }
            let finite = m.mount.origin.iter().all(|x| x.is_finite())
                && m.mount.angle.is_finite()
                && m.initial_q.iter().all(|x| x.is_finite());
            if !finite {
                return Err(ModelError::NotFinitePlacement { entity });
            }
            if m.max_condition.is_nan() || m.max_condition <= 1.0 {
                return Err(ModelError::MaxCondition {
                    entity,
                    value: m.max_condition,
                });
            }
        }
        for a in &self.attachments {
            let entity = format!("attachment \"{}\"", a.name);
            let Some(m) = self.mechanisms.get(a.mechanism) else {
                return Err(ModelError::NoMechanism {
                    entity,
                    index: a.mechanism,
                });
            };
            if a.point >= m.system.point_names().len() {
                return Err(ModelError::NoPoint {
                    entity,
                    mechanism: m.name.clone(),
                    index: a.point,
                });
            }
            let Some(structure) = &self.structure else {
                return Err(ModelError::NoBeam { entity });
            };
            if a.beam.is_locked() {
                return Err(ModelError::Locked {
                    entity,
                    x: a.beam.x,
                });
            }
            if a.beam
                .weights
                .iter()
                .chain(&a.beam.axial)
                .any(|&(k, w)| k >= structure.dof_count() || !w.is_finite())
                || !(a.beam.x.is_finite() && a.beam.y.is_finite())
            {
                return Err(ModelError::OutsideBeam { entity });
            }
        }
        for (i, m) in self.mechanisms.iter().enumerate() {
            let attached: usize = self
                .attachments
                .iter()
                .filter(|a| a.mechanism == i)
                .map(|a| a.kind.rows())
                .sum();
            let (loops, dof) = (m.system.rows(), m.system.dof());
            if loops + attached > dof {
                return Err(ModelError::OverConstrained {
                    mechanism: m.name.clone(),
                    rows: loops + attached,
                    loops,
                    attached,
                    dof,
                });
            }
        }
        for f in &self.forces {
            let entity = format!("force \"{}\"", f.name);
            let Some(m) = self.mechanisms.get(f.mechanism) else {
                return Err(ModelError::NoMechanism {
                    entity,
                    index: f.mechanism,
                });
            };
            if f.joint >= m.system.dof() {
                return Err(ModelError::NoJoint {
                    entity,
                    mechanism: m.name.clone(),
                    index: f.joint,
                });
            }
            if let ForceKind::Generator(g) = &f.kind {
                if let Err(source) = g.validate() {
                    return Err(ModelError::Generator { entity, source });
                }
            }
            let ok = match &f.kind {
                ForceKind::Generator(_) => true,
                ForceKind::Damper { c } => c.is_finite() && *c >= 0.0,
                ForceKind::Spring { k, q0 } => k.is_finite() && *k >= 0.0 && q0.is_finite(),
            };
            if !ok {
                return Err(ModelError::Coefficient {
                    entity,
                    kind: f.kind.as_str(),
                });
            }
        }
        for e in &self.excitations {
            let entity = format!("excitation \"{}\"", e.name);
            if !e.amplitude.is_finite() {
                return Err(ModelError::Amplitude {
                    entity,
                    value: e.amplitude,
                });
            }
            match &e.target {
                ExcitationTarget::Beam(p) => {
                    let Some(structure) = &self.structure else {
                        return Err(ModelError::NoBeam { entity });
                    };
                    if p.weights
                        .iter()
                        .chain(&p.axial)
                        .any(|&(k, _)| k >= structure.dof_count())
                    {
                        return Err(ModelError::OutsideBeam { entity });
                    }
                }
                ExcitationTarget::Joint { mechanism, joint } => {
                    let Some(m) = self.mechanisms.get(*mechanism) else {
                        return Err(ModelError::NoMechanism {
                            entity,
                            index: *mechanism,
                        });
                    };
                    if *joint >= m.system.dof() {
                        return Err(ModelError::NoJoint {
                            entity,
                            mechanism: m.name.clone(),
                            index: *joint,
                        });
                    }
                }
                ExcitationTarget::Base { direction: d } => {
                    let unit =
                        d.iter().all(|x| x.is_finite()) && (d[0].hypot(d[1]) - 1.0).abs() <= 1e-12;
                    if !unit {
                        return Err(ModelError::BaseDirection {
                            entity,
                            direction: *d,
                        });
                    }
                    if self.beam().is_some() && d[0] != 0.0 {
                        return Err(ModelError::BaseNotTransverse {
                            entity,
                            direction: *d,
                        });
                    }
                    let first = self.excitations.iter().find(|f| f.target.is_base());
                    if let Some(f) = first
                        && f.target != e.target
                        && let ExcitationTarget::Base { direction: fd } = f.target
                    {
                        return Err(ModelError::BaseDirections {
                            entity,
                            direction: *d,
                            first: f.name.clone(),
                            first_direction: fd,
                        });
                    }
                }
            }
        }
        Ok(())
    }

    /// The coupling components, attachment by attachment: its `y` component, then its `x`
    /// component for a pin whose point moves along `x` ([`Coupling`]). On the beam, one per
    /// attachment. Allocates: called at setup.
    pub fn couplings(&self) -> Vec<Coupling> {
        let mut out = Vec::with_capacity(self.attachments.len());
        for (i, a) in self.attachments.iter().enumerate() {
            out.push(Coupling {
                attachment: i,
                axial: false,
            });
            if a.kind == AttachmentKind::Pin && !a.beam.axial.is_empty() {
                out.push(Coupling {
                    attachment: i,
                    axial: true,
                });
            }
        }
        out
    }

    /// The coupling index of attachment `attachment`'s `y` component.
    pub fn coupling_of(&self, attachment: usize) -> usize {
        self.couplings()
            .iter()
            .position(|c| c.attachment == attachment && !c.axial)
            .expect("every attachment has its y component")
    }

    /// The coupling components' values `w` for structure coordinates `q`.
    pub fn coupling_values(&self, q: &[f64]) -> Vec<f64> {
        self.couplings()
            .iter()
            .map(|c| self.attachments[c.attachment].beam.value_along(c.axial, q))
            .collect()
    }

    /// Number of the structure's coordinates (0 without a structure).
    pub fn structure_dofs(&self) -> usize {
        self.structure
            .as_ref()
            .map_or(0, LinearStructure::dof_count)
    }

    /// The beam, when the host structure is the built-in beam.
    pub fn beam(&self) -> Option<&BeamModel> {
        self.structure.as_ref().and_then(Structure::beam)
    }

    /// Adds the force elements and joint excitations of mechanism `mech` to `M^b` and `Q^b`
    /// at `(q, q', t)`, with generator currents `currents` (one per force element; used for
    /// those with a current state, the others take their quasi-static current). The one
    /// place joint forces enter the equations, shared by every formulation (the follower's
    /// trial evaluations add the same terms in the same order through the same
    /// [`JointForce::add_to_equations`] and [`HybridModel::add_joint_excitations`], over
    /// the mechanism's own force elements).
    pub fn add_joint_forces(
        &self,
        mech: usize,
        t: f64,
        q: &[f64],
        qd: &[f64],
        currents: &[f64],
        m: &mut DMatrix<f64>,
        qv: &mut DVector<f64>,
    ) {
        for (f, &i) in self.forces.iter().zip(currents) {
            if f.mechanism != mech {
                continue;
            }
            let j = f.joint;
            let current = if f.has_current_state() {
                i
            } else {
                f.quasi_static_current(qd[j])
            };
            f.add_to_equations(q[j], qd[j], current, m, qv);
        }
        self.add_joint_excitations(mech, t, qv);
    }

    /// The joint excitations of mechanism `mech` at time `t` subtracted from its `Q^b`
    /// (`qv`): the last part of [`HybridModel::add_joint_forces`].
    pub fn add_joint_excitations(&self, mech: usize, t: f64, qv: &mut DVector<f64>) {
        for e in &self.excitations {
            if let ExcitationTarget::Joint { mechanism, joint } = e.target
                && mechanism == mech
            {
                qv[joint] -= e.value(t);
            }
        }
    }

    /// Whether an excitation acts on a joint of mechanism `mech`
    /// ([`HybridModel::add_joint_excitations`] changes nothing without one).
    pub fn has_joint_excitation(&self, mech: usize) -> bool {
        self.excitations.iter().any(
            |e| matches!(e.target, ExcitationTarget::Joint { mechanism, .. } if mechanism == mech),
        )
    }

    /// The unit of an excitation's amplitude at `target`: `N` for a beam force, the force
    /// unit of the joint's coordinate (`N m` or `N`), `m/s^2` for the supports.
    pub fn excitation_unit(&self, target: &ExcitationTarget) -> &'static str {
        match target {
            ExcitationTarget::Beam(_) => "N",
            ExcitationTarget::Joint { mechanism, joint } => {
                self.mechanisms[*mechanism].system.coordinate_units()[*joint].force()
            }
            ExcitationTarget::Base { .. } => "m/s^2",
        }
    }

    /// Whether an excitation moves the supports ([`ExcitationTarget::Base`]).
    pub fn has_base_excitation(&self) -> bool {
        self.excitations.iter().any(|e| e.target.is_base())
    }

    /// The direction `d` of the supports' motion (structure frame, unit): the one every
    /// base excitation shares ([`HybridModel::new`] refuses two), `[0, 1]` without one.
    pub fn base_direction(&self) -> [f64; 2] {
        self.excitations
            .iter()
            .find_map(|e| match e.target {
                ExcitationTarget::Base { direction } => Some(direction),
                _ => None,
            })
            .unwrap_or([0.0, 1.0])
    }

    /// The supports' acceleration `a_b(t)` along [`HybridModel::base_direction`] (m/s^2):
    /// the sum of the base excitations (0 without one).
    pub fn base_acceleration(&self, t: f64) -> f64 {
        self.excitations
            .iter()
            .filter(|e| e.target.is_base())
            .map(|e| e.value(t))
            .sum()
    }

    /// The direction of the supports' motion in mechanism `mech`'s ground frame,
    /// `R^T d` ([`Mount::to_ground`]; `[sin, cos, 0]` of the mounting angle for `d = y`,
    /// exactly).
    fn base_direction_in_ground(&self, mech: usize) -> [f64; 3] {
        let d = self.mechanisms[mech].mount.to_ground(self.base_direction());
        [d[0], d[1], 0.0]
    }

    /// The supports' motion at `t`: `[u, v, a]`, displacement (m), velocity (m/s) and
    /// acceleration (m/s^2), summed over the base excitations
    /// ([`Excitation::support_motion`]; zeros without one). The beam's absolute transverse
    /// displacement is `w_abs = w + u` (the state holds `w` relative to the supports).
    pub fn support_motion(&self, t: f64) -> [f64; 3] {
        let mut out = [0.0; 3];
        for e in &self.excitations {
            if e.target.is_base() {
                let (u, v) = e.support_motion(t);
                out[0] += u;
                out[1] += v;
                out[2] += e.value(t);
            }
        }
        out
    }

    /// The structure load per unit support acceleration, `-(A r)` (N per m/s^2; `A` the
    /// mass matrix, `r` the rigid translation along [`HybridModel::base_direction`]: on the
    /// beam 1 on every free transverse DOF, 0 on the rotations; locked DOFs are not in the
    /// reduced vector). Empty without a structure. Allocates: computed once at setup.
    pub fn base_beam_load(&self) -> Vec<f64> {
        let Some(structure) = &self.structure else {
            return Vec::new();
        };
        structure.base_load(self.base_direction())
    }

    /// Adds the inertial load of the supports' acceleration at time `t` to mechanism
    /// `mech`'s `Q^b` (in `ws.q`) at `q`: `Q^b -= G(q) a_b(t) R^T d` (see
    /// [`ExcitationTarget::Base`]), leaving `G(q)` in `ws.gravity_jacobian`. Nothing (and
    /// no evaluation) while `a_b(t) = 0`. Allocation-free on the generated and interpreted
    /// backends.
    pub fn add_base_load(&self, mech: usize, t: f64, q: &[f64], ws: &mut Workspace) {
        let a = self.base_acceleration(t);
        if a == 0.0 {
            return;
        }
        let m = &self.mechanisms[mech];
        m.system.gravity_load_jacobian(q, ws);
        let d = self.base_direction_in_ground(mech);
        for r in 0..ws.q.len() {
            let g = &ws.gravity_jacobian;
            ws.q[r] -= a * (g[(r, 0)] * d[0] + g[(r, 1)] * d[1] + g[(r, 2)] * d[2]);
        }
    }

    /// The power of the supports' inertial loads on mechanism `mech` per unit support
    /// acceleration at `(q, q')`: `q'^T G(q) R^T d = -d . sum_i m_i v_Ci` (W per m/s^2;
    /// `v_Ci` relative to the supports). Evaluates `G(q)` into `ws`.
    pub fn base_power_mechanism(
        &self,
        mech: usize,
        q: &[f64],
        qd: &[f64],
        ws: &mut Workspace,
    ) -> f64 {
        let m = &self.mechanisms[mech];
        m.system.gravity_load_jacobian(q, ws);
        let d = self.base_direction_in_ground(mech);
        let g = &ws.gravity_jacobian;
        (0..qd.len())
            .map(|r| qd[r] * (g[(r, 0)] * d[0] + g[(r, 1)] * d[1] + g[(r, 2)] * d[2]))
            .sum()
    }

    /// Adds the beam excitations at time `t` to the beam load vector `p`.
    pub fn add_beam_excitations(&self, t: f64, p: &mut [f64]) {
        for e in &self.excitations {
            if let ExcitationTarget::Beam(bp) = &e.target {
                bp.add_force(e.value(t), p);
            }
        }
    }
}
