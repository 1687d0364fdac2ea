//! Forward recursion (eqs. 1–3): orientation, position, angular velocity and the
//! acceleration remainders (`q'' = 0`) of every body, in the body's own frame, from the root
//! to the leaves; and the transformation of wrenches back to the parent used by the backward
//! recursion (eqs. 4–9).

use super::vec3::{self, M3, V3};
use super::{Builder, joint};
use crate::expr::{Dag, Id};

/// Symbolic kinematics of one body (all entries are DAG nodes).
#[derive(Clone, Debug)]
pub struct BodyKinematics {
    /// Relative rotation `R_i` of the body frame in the parent frame.
    pub rel_rot: M3,
    /// Offset `d_i` of the body origin from the parent origin, in the parent frame.
    pub offset: V3,
    /// Orientation `T^i` of the body frame in the ground frame (eq. 1).
    pub ground_rot: M3,
    /// Position `x_Oi` of the body origin in the ground frame (eq. 1).
    pub ground_pos: V3,
    /// Angular velocity in the body frame.
    pub omega: V3,
    /// Angular acceleration remainder (`q'' = 0`) in the body frame.
    pub alpha: V3,
    /// Origin acceleration remainder (`q'' = 0`, including the base acceleration `-g`) in the
    /// body frame.
    pub accel: V3,
    /// The same without gravity (base acceleration zero).
    pub accel_no_gravity: V3,
    /// The part of the origin acceleration remainder the joint adds, in the parent frame:
    /// `al_p x d + w_p x (w_p x d) + 2 w_p x u q'_i`, so that
    /// `accel = R_i^T (accel_p + rel_accel)`.
    pub rel_accel: V3,
    /// The parent body (`None` = ground).
    pub parent: Option<usize>,
    /// The joint axis in the ground frame, `T^i e_i`: the rotation axis of a revolute joint,
    /// the sliding direction `T^p u_i` of a prismatic joint.
    pub ground_axis: V3,
    /// Whether the joint slides (its Jacobian column is the axis itself) rather than turns
    /// (the axis times the lever arm).
    pub slides: bool,
    /// `T^p d_i`: the body origin relative to the parent origin, in the ground frame
    /// (the step of eq. 1's position recursion).
    pub ground_offset: V3,
}

/// Forward recursion: relative and absolute kinematics of every body (eqs. 1–3).
pub(super) fn forward_kinematics(b: &mut Builder<'_>) -> Vec<BodyKinematics> {
    let model = b.model;
    let mut out: Vec<BodyKinematics> = Vec::with_capacity(model.dof());
    // Angle grouping for T^i (see `joint::ground_rotation`).
    let mut groups: Vec<Option<joint::Group>> = Vec::with_capacity(model.dof());
    let g = b.v(&model.gravity);
    let a_ground = [b.dag.neg(g[0]), b.dag.neg(g[1]), b.dag.neg(g[2])];
    for (i, body) in model.bodies.iter().enumerate() {
        let jt = &body.joint;
        let r0 = joint::constant_rotation(&mut b.dag, jt, &model.parameters);
        let r0_is_identity = r0 == vec3::identity(&mut b.dag);
        let anchor = b.v(&jt.anchor);
        let qi = b.dag.q(i);
        let qdi = b.dag.qd(i);
        let (rel_rot, offset, slide) = joint::placement(&mut b.dag, jt, &r0, anchor, qi);
        let (parent_rot, parent_pos, w_p, al_p, a_p, a0_p) = match body.parent {
            None => {
                let id = vec3::identity(&mut b.dag);
                let z = vec3::zero(&mut b.dag);
                (id, z, z, z, a_ground, z)
            }
            Some(p) => {
                let pk = &out[p];
                (
                    pk.ground_rot,
                    pk.ground_pos,
                    pk.omega,
                    pk.alpha,
                    pk.accel,
                    pk.accel_no_gravity,
                )
            }
        };
        let parent_group = body.parent.and_then(|p| groups[p]);
        let (ground_rot, group) = joint::ground_rotation(
            &mut b.dag,
            jt,
            parent_group,
            &parent_rot,
            &r0,
            r0_is_identity,
            qi,
        );
        groups.push(group);
        let tp_d = vec3::mat_vec(&mut b.dag, &parent_rot, offset);
        // Column k of T^i: Rot(e, q) leaves e fixed, so T^i e = T^p R0 e for both kinds
        // (for a sliding joint T^p u_i, u_i = R0 e).
        let k = jt.axis.index();
        let ground_axis = [ground_rot[0][k], ground_rot[1][k], ground_rot[2][k]];
        let ground_pos = vec3::add(&mut b.dag, parent_pos, tp_d);

        // Velocities and acceleration remainders in the body frame (eqs. 2–3, q'' = 0).
        let w_in = vec3::mat_t_vec(&mut b.dag, &rel_rot, w_p);
        let al_in = vec3::mat_t_vec(&mut b.dag, &rel_rot, al_p);
        let (omega, alpha) = joint::angular_motion(&mut b.dag, jt, w_in, al_in, qdi);
        // a_i = R_i^T (a_p + al_p x d + w_p x (w_p x d) + 2 w_p x u q'_i), with and without
        // the base acceleration -g.
        let mut rel = vec3::cross(&mut b.dag, al_p, offset);
        let wxd = vec3::cross(&mut b.dag, w_p, offset);
        let t2 = vec3::cross(&mut b.dag, w_p, wxd);
        rel = vec3::add(&mut b.dag, rel, t2);
        if let Some(cor) = joint::coriolis(&mut b.dag, slide, w_p, qdi) {
            rel = vec3::add(&mut b.dag, rel, cor);
        }
        let with_g = vec3::add(&mut b.dag, a_p, rel);
        let accel = vec3::mat_t_vec(&mut b.dag, &rel_rot, with_g);
        let without_g = vec3::add(&mut b.dag, a0_p, rel);
        let accel_no_gravity = vec3::mat_t_vec(&mut b.dag, &rel_rot, without_g);
        out.push(BodyKinematics {
            rel_rot,
            offset,
            ground_rot,
            ground_pos,
            omega,
            alpha,
            accel,
            accel_no_gravity,
            rel_accel: rel,
            parent: body.parent,
            ground_axis,
            slides: slide.is_some(),
            ground_offset: tp_d,
        });
    }
    out
}

/// Transforms a wrench `(f, n)` about the child origin in the child frame to the parent
/// origin in the parent frame.
pub(super) fn wrench_to_parent(d: &mut Dag, kin: &BodyKinematics, f: V3, n: V3) -> (V3, V3) {
    let fp = vec3::mat_vec(d, &kin.rel_rot, f);
    let np = vec3::mat_vec(d, &kin.rel_rot, n);
    let dxf = vec3::cross(d, kin.offset, fp);
    (fp, vec3::add(d, np, dxf))
}

/// Ground-frame position of a point at body-frame coordinates `r` of `body` (`None` =
/// ground): `x = x_Oi + T^i r` (eq. 1).
pub(super) fn ground_point(d: &mut Dag, kin: &[BodyKinematics], body: Option<usize>, r: V3) -> V3 {
    match body {
        None => r,
        Some(i) => {
            let tr = vec3::mat_vec(d, &kin[i].ground_rot, r);
            vec3::add(d, kin[i].ground_pos, tr)
        }
    }
}

/// Jacobian `dp/dq` (eq. 49) of the ground-frame point `p = x_Oi + T^i r` fixed on `body`,
/// three rows of `n`, by columns: for each joint `j` on the path from `body` to the root,
///
/// ```text
/// column j = a_j x (p - x_Oj)   (turning joint)      a_j                (sliding joint)
/// ```
///
/// with `a_j` the joint axis in the ground frame. The lever arms are accumulated from the
/// body towards the root, `p - x_Op = (p - x_Oj) + T^p d_j`, so each column costs a cross
/// product and one vector addition: O(N) for the whole Jacobian, where differentiating `p`
/// once per coordinate costs O(N^2). Joints off the path have zero columns.
pub(super) fn point_jacobian(
    d: &mut Dag,
    kin: &[BodyKinematics],
    body: Option<usize>,
    r: V3,
) -> [Vec<Id>; 3] {
    let z = d.zero();
    let mut rows = [vec![z; kin.len()], vec![z; kin.len()], vec![z; kin.len()]];
    let Some(i) = body else {
        return rows;
    };
    let mut lever = vec3::mat_vec(d, &kin[i].ground_rot, r);
    let mut at = Some(i);
    while let Some(j) = at {
        let k = &kin[j];
        let col = if k.slides {
            k.ground_axis
        } else {
            vec3::cross(d, k.ground_axis, lever)
        };
        for (row, c) in rows.iter_mut().zip(col) {
            row[j] = c;
        }
        at = k.parent;
        if at.is_some() {
            lever = vec3::add(d, lever, k.ground_offset);
        }
    }
    rows
}

/// Bias `A = J' q'` (eq. 50) of the same point: its acceleration with `q'' = 0`, from the
/// forward recursion's remainders (eq. 3) in the body frame,
/// `A = T^i (a_Oi + al_i x r + w_i x (w_i x r))`, with the origin remainder `a_Oi` that
/// excludes the base acceleration. Every term is then a product with a joint rate, so `A`
/// is exactly `0.0` at `q' = 0`. (The remainder that includes the base acceleration `-g`,
/// with `g` added back in the ground frame, is equal in exact arithmetic but leaves a
/// rounding residue proportional to `|g|` at rest: it is not offered.)
pub(super) fn point_bias(d: &mut Dag, kin: &[BodyKinematics], body: Option<usize>, r: V3) -> V3 {
    let Some(i) = body else {
        return vec3::zero(d);
    };
    let k = &kin[i];
    let axr = vec3::cross(d, k.alpha, r);
    let wxr = vec3::cross(d, k.omega, r);
    let wwxr = vec3::cross(d, k.omega, wxr);
    let t = vec3::add(d, k.accel_no_gravity, axr);
    let a_body = vec3::add(d, t, wwxr);
    vec3::mat_vec(d, &k.ground_rot, a_body)
}
