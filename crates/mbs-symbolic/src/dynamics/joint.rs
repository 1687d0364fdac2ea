//! Every joint type's formulas, in one place (paper eqs. 1–3 and 11): the joint's relative
//! rotation and offset, its contribution to the body's orientation (with ROBOTRAN's angle
//! grouping), to the velocities and acceleration remainders, the motion of a unit `q''`
//! (for `M^b`), and the projection of a wrench on the joint's axis.
//!
//! For body `i` with joint axis `e_i` (a unit vector of the joint frame), coordinate `q_i`,
//! constant joint rotation `R0_i` and anchor `a_i`:
//!
//! ```text
//!             revolute                          prismatic
//! R_i         R0_i Rot(e_i, q_i)                R0_i                              (1)
//! d_i         a_i                               a_i + u_i q_i,  u_i = R0_i e_i    (1)
//! w_i         R_i^T w_p + e_i q'_i              R_i^T w_p                         (2)
//! al_i        R_i^T al_p + (R_i^T w_p) x e_i q'_i   R_i^T al_p                    (3)
//! a_i extra   -                                 2 w_p x u_i q'_i (Coriolis)       (3)
//! unit q''    (e x h, J e) of the subtree       (m e, h x e) of the subtree       (9)
//! projection  e_i . n_i                         e_i . f_i                         (11–13)
//! ```
//!
//! Adding a joint type means adding a [`JointKind`] variant (model types and validation),
//! one arm to each function of this file, and the same formulas in the numeric reference
//! (`numeric/joint.rs`).

use super::vec3::{self, M3, V3};
use crate::expr::{Dag, Id};
use crate::model::{Joint, JointKind, Model, Parameter};

/// An orientation group for `T^i`: `T^i = base Rot(axis, angle)`, `angle` a sum of the
/// coordinates of consecutive revolute joints about the same axis.
pub(super) type Group = (M3, usize, Id);

/// The constant rotation `R0` of the joint frame: the product of the elementary rotations
/// listed in the model, in order.
pub(super) fn constant_rotation(dag: &mut Dag, joint: &Joint, params: &[Parameter]) -> M3 {
    let mut r0 = vec3::identity(dag);
    for (ax, angle) in &joint.rotation {
        let th = dag.scalar(angle, params);
        let (s, c) = (dag.sin(th), dag.cos(th));
        let r = vec3::rot(dag, ax.index(), s, c);
        r0 = vec3::mat_mul(dag, &r0, &r);
    }
    r0
}

/// Relative rotation `R_i` and offset `d_i` of the body in its parent's frame (eq. 1), and
/// the sliding axis `u_i` in the parent frame (`None` for a joint that does not slide).
pub(super) fn placement(
    dag: &mut Dag,
    joint: &Joint,
    r0: &M3,
    anchor: V3,
    qi: Id,
) -> (M3, V3, Option<V3>) {
    let k = joint.axis.index();
    match joint.kind {
        JointKind::Revolute => {
            let (s, c) = (dag.sin(qi), dag.cos(qi));
            let r = vec3::rot(dag, k, s, c);
            (vec3::mat_mul(dag, r0, &r), anchor, None)
        }
        JointKind::Prismatic => {
            let u = [r0[0][k], r0[1][k], r0[2][k]];
            let uq = vec3::scale(dag, qi, u);
            (*r0, vec3::add(dag, anchor, uq), Some(u))
        }
    }
}

/// Ground orientation `T^i = T^p R_i` (eq. 1) with angle grouping: a revolute joint about
/// the same axis as its parent's group, without constant rotation, extends the group's angle
/// sum instead of multiplying rotations. Returns `T^i` and the body's group (`None` when the
/// joint does not rotate).
pub(super) fn ground_rotation(
    dag: &mut Dag,
    joint: &Joint,
    parent_group: Option<Group>,
    parent_rot: &M3,
    r0: &M3,
    r0_is_identity: bool,
    qi: Id,
) -> (M3, Option<Group>) {
    let k = joint.axis.index();
    match joint.kind {
        JointKind::Revolute => {
            let (base, angle) = match parent_group {
                Some((base, ax, angle)) if ax == k && r0_is_identity => (base, dag.add(angle, qi)),
                _ => (vec3::mat_mul(dag, parent_rot, r0), qi),
            };
            let (s, c) = (dag.sin(angle), dag.cos(angle));
            let r = vec3::rot(dag, k, s, c);
            (vec3::mat_mul(dag, &base, &r), Some((base, k, angle)))
        }
        JointKind::Prismatic => (vec3::mat_mul(dag, parent_rot, r0), None),
    }
}

/// Angular velocity and angular acceleration remainder of the body (eqs. 2–3, `q'' = 0`),
/// from the parent's `w_in = R_i^T w_p` and `al_in = R_i^T al_p`.
pub(super) fn angular_motion(
    dag: &mut Dag,
    joint: &Joint,
    w_in: V3,
    al_in: V3,
    qdi: Id,
) -> (V3, V3) {
    let e = vec3::unit(dag, joint.axis.index());
    match joint.kind {
        JointKind::Revolute => {
            let eq = vec3::scale(dag, qdi, e);
            let omega = vec3::add(dag, w_in, eq);
            let wxe = vec3::cross(dag, w_in, eq);
            (omega, vec3::add(dag, al_in, wxe))
        }
        JointKind::Prismatic => (w_in, al_in),
    }
}

/// The Coriolis term `2 w_p x u q'_i` of a sliding joint's origin acceleration (eq. 3), in
/// the parent frame; `None` for a joint that does not slide.
pub(super) fn coriolis(dag: &mut Dag, slide: Option<V3>, w_p: V3, qdi: Id) -> Option<V3> {
    let u = slide?;
    let two_qd = {
        let two = dag.constant(2.0);
        dag.mul(two, qdi)
    };
    let uq = vec3::scale(dag, two_qd, u);
    Some(vec3::cross(dag, w_p, uq))
}

/// The wrench `(f, n)` about `O_i` in `F_i` needed to give the subtree of body `i` (composite
/// mass `m`, first moment `h`, inertia `j` about `O_i`) a unit `q''_i` (the `C` terms of
/// eq. 9).
pub(super) fn unit_motion_wrench(dag: &mut Dag, joint: &Joint, m: Id, h: V3, j: &M3) -> (V3, V3) {
    let e = vec3::unit(dag, joint.axis.index());
    match joint.kind {
        JointKind::Revolute => (vec3::cross(dag, e, h), vec3::mat_vec(dag, j, e)),
        JointKind::Prismatic => (vec3::scale(dag, m, e), vec3::cross(dag, h, e)),
    }
}

/// Projection of a wrench on joint `i`'s axis (eqs. 11–13): the torque component about the
/// axis for a revolute joint, the force component along it for a prismatic joint.
pub(super) fn project(model: &Model, i: usize, f: V3, n: V3) -> Id {
    let joint = &model.bodies[i].joint;
    match joint.kind {
        JointKind::Revolute => n[joint.axis.index()],
        JointKind::Prismatic => f[joint.axis.index()],
    }
}

/// Whether the joint's coordinate is a rotation angle about its axis (it then adds to the
/// relative angle of an angle constraint, eq. 14).
pub(crate) fn is_rotation(joint: &Joint) -> bool {
    match joint.kind {
        JointKind::Revolute => true,
        JointKind::Prismatic => false,
    }
}
