//! Forward recursion (eqs. 1–3): orientation, position, angular velocity and the
//! acceleration remainders (`q'' = 0`) of every body, in the body's own frame, from the root
//! to the leaves; and the transformation of wrenches back to the parent used by the backward
//! recursion (eqs. 4–9).

use super::vec3::{self, M3, V3};
use super::{Builder, joint};
use crate::expr::Dag;

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
