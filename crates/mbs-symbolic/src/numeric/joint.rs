//! Every joint type's formulas of the numeric reference, in one place (eqs. 1–3, 11–13, all
//! in the ground frame): the elementary rotations, the joint's placement, its velocity and
//! acceleration contributions, its Jacobian columns and the projection of a wrench on its
//! axis. Independent of the symbolic derivation (`dynamics/joint.rs` holds the same
//! formulas in body frames); adding a joint type means adding an arm to each function here.

use nalgebra::{Matrix3, Vector3};

use super::kinematics::Motion;
use crate::model::types::{Axis, JointKind};

/// The elementary active rotation `Rot(axis, angle)` of the model conventions
/// (`Rot(z, t) = [[cos t, -sin t, 0], [sin t, cos t, 0], [0, 0, 1]]`, likewise for x and y):
/// its columns are the rotated axes expressed in the unrotated frame.
pub fn rot(axis: Axis, angle: f64) -> Matrix3<f64> {
    let (s, c) = angle.sin_cos();
    match axis {
        Axis::X => Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c),
        Axis::Y => Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c),
        Axis::Z => Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
    }
}

/// The unit vector along a coordinate axis.
pub(super) fn unit(axis: Axis) -> Vector3<f64> {
    let mut e = Vector3::zeros();
    e[axis.index()] = 1.0;
    e
}

/// Ground orientation and origin of a body (eq. 1) from its joint frame's orientation
/// `joint = T^p R0`, the ground axis `e`, the ground anchor and the coordinate `q`.
pub(super) fn placement(
    kind: JointKind,
    axis: Axis,
    joint: Matrix3<f64>,
    e: &Vector3<f64>,
    anchor: Vector3<f64>,
    q: f64,
) -> (Matrix3<f64>, Vector3<f64>) {
    match kind {
        JointKind::Revolute => (joint * rot(axis, q), anchor),
        JointKind::Prismatic => (joint, anchor + e * q),
    }
}

/// Adds the joint's own motion (eqs. 2–3) to `m`, which holds the parent's motion carried to
/// the body: `omega_p` is the parent's angular velocity, `e` the ground axis.
pub(super) fn add_joint_motion(
    kind: JointKind,
    m: &mut Motion,
    omega_p: &Vector3<f64>,
    e: &Vector3<f64>,
    qd: f64,
    qdd: f64,
) {
    match kind {
        JointKind::Revolute => {
            m.omega += e * qd;
            m.alpha += omega_p.cross(e) * qd + e * qdd;
        }
        JointKind::Prismatic => {
            m.vel += e * qd;
            m.acc += omega_p.cross(e) * (2.0 * qd) + e * qdd;
        }
    }
}

/// Linear Jacobian column `dx/dq_j` of a ground point `x` moved by joint `j` with ground axis
/// `e` and body origin `origin`.
pub(super) fn linear_column(
    kind: JointKind,
    e: &Vector3<f64>,
    origin: &Vector3<f64>,
    x: &Vector3<f64>,
) -> Vector3<f64> {
    match kind {
        JointKind::Revolute => e.cross(&(x - origin)),
        JointKind::Prismatic => *e,
    }
}

/// Angular Jacobian column `dw/dq'_j` of joint `j` with ground axis `e`.
pub(super) fn angular_column(kind: JointKind, e: &Vector3<f64>) -> Vector3<f64> {
    match kind {
        JointKind::Revolute => *e,
        JointKind::Prismatic => Vector3::zeros(),
    }
}

/// Projection of a wrench (force `f`, moment `n` about the body origin) on the joint axis
/// `e` (eqs. 11–13).
pub(super) fn project(
    kind: JointKind,
    e: &Vector3<f64>,
    f: &Vector3<f64>,
    n: &Vector3<f64>,
) -> f64 {
    match kind {
        JointKind::Revolute => e.dot(n),
        JointKind::Prismatic => e.dot(f),
    }
}

/// Whether the coordinate is a rotation angle about the joint axis (it then counts in an
/// angle constraint).
pub(super) fn is_rotation(kind: JointKind) -> bool {
    match kind {
        JointKind::Revolute => true,
        JointKind::Prismatic => false,
    }
}
