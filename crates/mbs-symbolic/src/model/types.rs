//! The validated mechanism model: the typed tree every other part of the crate works on.
//!
//! # Kinematic conventions (shared by the symbolic and numeric implementations)
//!
//! Bodies are stored parent-before-child; body `i` owns joint `i` and coordinate `q_i`
//! (the paper's numbering, section 2.1: `a < b` when `a` is on the reference chain of `b`).
//! Every body `i` has a body-fixed frame `F_i`; the ground frame is `F_0`.
//!
//! Joint `i` connects the parent `p` (ground when `parent == None`) to body `i`:
//!
//! ```text
//! joint frame:  origin  a_i  (the `anchor`, coordinates in F_p)
//!               orientation  R0_i = Rot(ax_1, th_1) * Rot(ax_2, th_2) * ...   (relative to F_p,
//!               the `rotation` list applied in the listed order; identity when empty)
//! revolute  (R1..R3):  F_i origin = a_i,                      R_i = R0_i * Rot(axis, q_i)
//! prismatic (T1..T3):  F_i origin = a_i + R0_i * (q_i e_axis),  R_i = R0_i
//! ```
//!
//! so that, in ground coordinates (eq. 1), `T^i = T^p R_i` and
//! `x_Oi = x_Op + T^p (a_i + [prismatic] R0_i e_axis q_i)`.
//! `Rot(z, t) = [[cos t, -sin t, 0], [sin t, cos t, 0], [0, 0, 1]]` (active rotation; its
//! columns are the rotated axes in the parent frame), and likewise for x and y.
//!
//! Mass properties, point positions and force application points are given in `F_i`:
//! `com` is the centre of mass, `inertia` the symmetric inertia tensor about the centre of
//! mass in body axes.
//!
//! # Sign convention (docs/theory.md section 2)
//!
//! `M q'' + F + Q = 0`: `F` holds the velocity terms and gravity (gravity enters as a base
//! acceleration `-g`), `Q = -(generalised applied force)` from the force elements.

use std::fmt;

/// A coordinate axis of a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Axis {
    /// The x axis (index 0).
    X,
    /// The y axis (index 1).
    Y,
    /// The z axis (index 2).
    Z,
}

impl Axis {
    /// Index of the axis: x = 0, y = 1, z = 2.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }

    /// The axis with the given index (0, 1 or 2).
    pub fn from_index(i: usize) -> Option<Axis> {
        match i {
            0 => Some(Axis::X),
            1 => Some(Axis::Y),
            2 => Some(Axis::Z),
            _ => None,
        }
    }

    /// Lower-case name: `"x"`, `"y"` or `"z"`.
    pub fn name(self) -> &'static str {
        ["x", "y", "z"][self.index()]
    }
}

/// The kind of a one-degree-of-freedom joint.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum JointKind {
    /// Rotation about the joint axis (ROBOTRAN R1, R2, R3).
    Revolute,
    /// Translation along the joint axis (ROBOTRAN T1, T2, T3).
    Prismatic,
}

impl JointKind {
    /// The unit of this joint's coordinate: the one place that maps a joint type to a unit
    /// (a new joint type names its unit here).
    pub fn coordinate_unit(self) -> CoordinateUnit {
        match self {
            JointKind::Revolute => CoordinateUnit::Angle,
            JointKind::Prismatic => CoordinateUnit::Length,
        }
    }
}

/// What a joint coordinate measures; the unit symbols of the coordinate, its rates and its
/// generalised force follow from it (SI, radians inside).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CoordinateUnit {
    /// An angle (rad): the generalised force is a torque (N m).
    Angle,
    /// A length (m): the generalised force is a force (N).
    Length,
}

impl CoordinateUnit {
    /// The coordinate's unit: `"rad"` or `"m"`.
    pub fn symbol(self) -> &'static str {
        match self {
            CoordinateUnit::Angle => "rad",
            CoordinateUnit::Length => "m",
        }
    }

    /// The unit of the coordinate's rate: `"rad/s"` or `"m/s"`.
    pub fn rate(self) -> &'static str {
        match self {
            CoordinateUnit::Angle => "rad/s",
            CoordinateUnit::Length => "m/s",
        }
    }

    /// The unit of the coordinate's acceleration: `"rad/s^2"` or `"m/s^2"`.
    pub fn acceleration(self) -> &'static str {
        match self {
            CoordinateUnit::Angle => "rad/s^2",
            CoordinateUnit::Length => "m/s^2",
        }
    }

    /// The unit of the generalised force on the coordinate: `"N m"` or `"N"`.
    pub fn force(self) -> &'static str {
        match self {
            CoordinateUnit::Angle => "N m",
            CoordinateUnit::Length => "N",
        }
    }

    /// The unit of the coordinate per metre of another coordinate (a kinematic influence
    /// `dq/dw` on a length `w`): `"rad/m"` or `"m/m"`.
    pub fn per_metre(self) -> &'static str {
        match self {
            CoordinateUnit::Angle => "rad/m",
            CoordinateUnit::Length => "m/m",
        }
    }
}

/// A unary function usable in parameter expressions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Func {
    /// `sin`
    Sin,
    /// `cos`
    Cos,
    /// `tan`
    Tan,
    /// `sqrt`
    Sqrt,
    /// `exp`
    Exp,
    /// `ln` (natural logarithm)
    Ln,
    /// `abs`
    Abs,
}

impl Func {
    /// Applies the function to a number.
    pub fn apply(self, x: f64) -> f64 {
        match self {
            Func::Sin => x.sin(),
            Func::Cos => x.cos(),
            Func::Tan => x.tan(),
            Func::Sqrt => x.sqrt(),
            Func::Exp => x.exp(),
            Func::Ln => x.ln(),
            Func::Abs => x.abs(),
        }
    }

    /// The name used in expressions.
    pub fn name(self) -> &'static str {
        match self {
            Func::Sin => "sin",
            Func::Cos => "cos",
            Func::Tan => "tan",
            Func::Sqrt => "sqrt",
            Func::Exp => "exp",
            Func::Ln => "ln",
            Func::Abs => "abs",
        }
    }
}

/// A binary operator of parameter expressions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BinOp {
    /// `a + b`
    Add,
    /// `a - b`
    Sub,
    /// `a * b`
    Mul,
    /// `a / b`
    Div,
    /// `a ^ b`
    Pow,
}

/// A numeric field of the model: a number or an arithmetic expression over named
/// parameters (`"m1*L1^2/12"`), already parsed and checked.
#[derive(Clone, Debug, PartialEq)]
pub enum Scalar {
    /// A literal number (`pi` is folded to a number by the parser).
    Num(f64),
    /// A named parameter: index into [`Model::parameters`].
    Param(usize),
    /// `-a`
    Neg(Box<Scalar>),
    /// `a op b`
    Bin(BinOp, Box<Scalar>, Box<Scalar>),
    /// `f(a)`
    Call(Func, Box<Scalar>),
}

impl Scalar {
    /// The constant zero.
    pub const ZERO: Scalar = Scalar::Num(0.0);

    /// Evaluates the expression with the given parameter values (indexed like
    /// [`Model::parameters`]).
    pub fn eval(&self, params: &[f64]) -> f64 {
        match self {
            Scalar::Num(v) => *v,
            Scalar::Param(i) => params[*i],
            Scalar::Neg(a) => -a.eval(params),
            Scalar::Bin(op, a, b) => {
                let (a, b) = (a.eval(params), b.eval(params));
                match op {
                    BinOp::Add => a + b,
                    BinOp::Sub => a - b,
                    BinOp::Mul => a * b,
                    BinOp::Div => a / b,
                    BinOp::Pow => a.powf(b),
                }
            }
            Scalar::Call(f, a) => f.apply(a.eval(params)),
        }
    }

    /// True when the expression is the literal zero.
    pub fn is_zero(&self) -> bool {
        matches!(self, Scalar::Num(v) if *v == 0.0)
    }
}

/// A named parameter of the model.
#[derive(Clone, Debug, PartialEq)]
pub struct Parameter {
    /// Name as written in the model file.
    pub name: String,
    /// Default value. For a derived parameter, the value of its expression at the defaults
    /// (for display only: fields that use it hold its expression).
    pub value: f64,
    /// `true`: kept as a run-time field of the generated code (changing it needs no
    /// regeneration). `false`: folded into the equations at generation time.
    pub runtime: bool,
    /// `true` when the value was written as an expression of earlier parameters: every
    /// reference to it is replaced by that expression, so it follows the parameters it uses
    /// and cannot be set on its own.
    pub derived: bool,
}

/// One joint: the connection of a body to its parent.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    /// Revolute or prismatic.
    pub kind: JointKind,
    /// The joint axis, in the joint frame.
    pub axis: Axis,
    /// Origin of the joint frame in the parent frame.
    pub anchor: [Scalar; 3],
    /// Constant rotation of the joint frame relative to the parent frame: elementary rotations
    /// applied in the listed order, `R0 = Rot(ax_1, th_1) * Rot(ax_2, th_2) * ...`.
    pub rotation: Vec<(Axis, Scalar)>,
}

/// A rigid body of the tree.
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    /// Name as written in the model file.
    pub name: String,
    /// Name of the body's joint coordinate (defaults to the body name).
    pub coordinate: String,
    /// Parent body index, `None` for ground. Always smaller than this body's index.
    pub parent: Option<usize>,
    /// The joint connecting the body to its parent.
    pub joint: Joint,
    /// Mass (validated positive at the default parameter values).
    pub mass: Scalar,
    /// Centre of mass in the body frame.
    pub com: [Scalar; 3],
    /// Symmetric inertia tensor about the centre of mass, in body axes
    /// (`inertia[r][c] == inertia[c][r]`).
    pub inertia: [[Scalar; 3]; 3],
}

/// A named point fixed on a body (or on ground).
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// Name as written in the model file.
    pub name: String,
    /// Body index, `None` for ground.
    pub body: Option<usize>,
    /// Position in the body frame (ground frame for ground points).
    pub position: [Scalar; 3],
}

/// A force element; each contributes to `Q^b` (eq. 13) with `Q = -(generalised force)`.
#[derive(Clone, Debug, PartialEq)]
pub enum ForceElement {
    /// Spring, damper and constant generalised force on one joint: the generalised applied
    /// force on `q_body` is `-stiffness (q - rest) - damping q' + constant`.
    Joint {
        /// Name as written in the model file.
        name: String,
        /// Body (and so joint and coordinate) index.
        body: usize,
        /// Stiffness (N/m or N m/rad).
        stiffness: Scalar,
        /// Viscous damping (N s/m or N m s/rad).
        damping: Scalar,
        /// Coordinate value where the spring is relaxed.
        rest: Scalar,
        /// Constant generalised force (N or N m).
        constant: Scalar,
    },
    /// Spring-damper between two named points (either may be on ground). With
    /// `d = p_b - p_a`, `l = |d|`, `l' = d . (v_b - v_a) / l`, the tension
    /// `f = stiffness (l - rest_length) + damping l'` pulls `a` towards `b` (force `+f d/l` on
    /// `a`, `-f d/l` on `b`).
    PointSpring {
        /// Name as written in the model file.
        name: String,
        /// Index into [`Model::points`].
        a: usize,
        /// Index into [`Model::points`].
        b: usize,
        /// Stiffness (N/m).
        stiffness: Scalar,
        /// Viscous damping (N s/m).
        damping: Scalar,
        /// Rest length (m).
        rest_length: Scalar,
    },
    /// Constant force applied at a point of a body and constant torque on the body.
    External {
        /// Name as written in the model file.
        name: String,
        /// Body index.
        body: usize,
        /// Application point in the body frame.
        point: [Scalar; 3],
        /// Force components, in the ground frame if `in_body_frame` is false, else in the
        /// body frame.
        force: [Scalar; 3],
        /// Torque components, same frame as `force`.
        torque: [Scalar; 3],
        /// Whether force and torque follow the body (body frame) or are fixed in space.
        in_body_frame: bool,
    },
}

impl ForceElement {
    /// The element's name.
    pub fn name(&self) -> &str {
        match self {
            ForceElement::Joint { name, .. }
            | ForceElement::PointSpring { name, .. }
            | ForceElement::External { name, .. } => name,
        }
    }
}

/// A kinematic constraint `h(q) = 0` closing a loop or fixing a point (eq. 14).
/// Rows of `h` follow the declaration order; within a constraint, the listed components.
#[derive(Clone, Debug, PartialEq)]
pub enum Constraint {
    /// Two points coincide: `h = (p_b - p_a)[components]`, components of the ground frame.
    Loop {
        /// Name as written in the model file.
        name: String,
        /// Index into [`Model::points`].
        a: usize,
        /// Index into [`Model::points`].
        b: usize,
        /// Ground-frame components constrained (all three, or a subset such as x, y).
        components: Vec<Axis>,
    },
    /// A point held at a fixed ground position: `h = (p - position)[components]`.
    Fixed {
        /// Name as written in the model file.
        name: String,
        /// Index into [`Model::points`].
        point: usize,
        /// Target position in the ground frame.
        position: [Scalar; 3],
        /// Ground-frame components constrained.
        components: Vec<Axis>,
    },
    /// Relative-angle closure about an axis (planar revolute cut): the rotation angle of body
    /// `b` relative to body `a` (`None` = ground) about `axis`, minus `offset`, is zero. The
    /// angle is the signed sum of the revolute coordinates on the path between `a` and `b`
    /// (`+` on `b`'s side of the common ancestor, `-` on `a`'s), so validation requires every
    /// joint on that path to be a revolute about `axis` with no constant joint rotation.
    Angle {
        /// Name as written in the model file.
        name: String,
        /// First body, `None` for ground.
        a: Option<usize>,
        /// Second body, `None` for ground.
        b: Option<usize>,
        /// The common axis of the path's revolute joints.
        axis: Axis,
        /// Relative angle at which the constraint is satisfied.
        offset: Scalar,
    },
}

impl Constraint {
    /// The constraint's name.
    pub fn name(&self) -> &str {
        match self {
            Constraint::Loop { name, .. }
            | Constraint::Fixed { name, .. }
            | Constraint::Angle { name, .. } => name,
        }
    }

    /// Number of scalar rows the constraint contributes to `h`.
    pub fn rows(&self) -> usize {
        match self {
            Constraint::Loop { components, .. } | Constraint::Fixed { components, .. } => {
                components.len()
            }
            Constraint::Angle { .. } => 1,
        }
    }
}

/// Where the model came from (for `@generated` headers and diagnostics).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SourceInfo {
    /// File name as given by the user (or `"<string>"`).
    pub path: String,
    /// FNV-1a 64-bit hash of the file content, 16 lower-case hex digits.
    pub hash: String,
}

/// A validated mechanism: a tree of rigid bodies, points, force elements and constraints.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// Model name (the `name` key, or the file stem).
    pub name: String,
    /// Where the model was read from.
    pub source: SourceInfo,
    /// Named parameters, in declaration order.
    pub parameters: Vec<Parameter>,
    /// Gravity vector in the ground frame (m/s^2).
    pub gravity: [Scalar; 3],
    /// Bodies, parent before child; body `i` owns coordinate `q_i`.
    pub bodies: Vec<Body>,
    /// Named points.
    pub points: Vec<Point>,
    /// Force elements.
    pub forces: Vec<ForceElement>,
    /// Constraints (loop closures, fixed points, angle closures).
    pub constraints: Vec<Constraint>,
}

impl Model {
    /// Number of joint coordinates (one per body).
    pub fn dof(&self) -> usize {
        self.bodies.len()
    }

    /// The default values of all parameters, indexed like [`Model::parameters`].
    pub fn default_params(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.value).collect()
    }

    /// Index of the parameter with this name.
    pub fn param_index(&self, name: &str) -> Option<usize> {
        self.parameters.iter().position(|p| p.name == name)
    }

    /// Index of the body with this name.
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// Index of the point with this name.
    pub fn point_index(&self, name: &str) -> Option<usize> {
        self.points.iter().position(|p| p.name == name)
    }

    /// Total number of constraint rows.
    pub fn constraint_rows(&self) -> usize {
        self.constraints.iter().map(Constraint::rows).sum()
    }
}

impl fmt::Display for Axis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
