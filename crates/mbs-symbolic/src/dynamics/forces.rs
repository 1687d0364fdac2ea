//! The inertial and gravity terms of the equations of motion, `F^b` (eq. 12, the `D` terms
//! of eq. 9 — inertial wrenches with `q'' = 0` and gravity), summed from the leaves to the
//! root and projected on the joint axes; the backward recursion and projection are shared
//! with the force elements' `Q^b` (eq. 13, `elements.rs`).

use super::kinematics::{BodyKinematics, wrench_to_parent};
use super::vec3::{self, V3};
use super::{Builder, joint};
use crate::expr::Id;

/// How gravity enters `F^b`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Gravity {
    /// As the base acceleration `-g` of the forward recursion (ROBOTRAN's way).
    BaseAcceleration,
    /// As forces `m g` at the centres of mass, expressed in body frames through the ground
    /// orientations `T^i` (which use angle sums of parallel revolute joints).
    BodyForces,
}

/// How the backward recursion of `F^b` carries the subtree wrenches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Recursion {
    /// Each body's wrench `(f, n)` in its frame, rotated to the parent whole (eqs. 4–9).
    Plain,
    /// In composite form `F_i = M_i a_i + G_i`, `N_i = S_i x a_i + H_i` (see
    /// [`velocity_and_gravity_terms`]).
    Composite,
}

/// `F^b` (eq. 12): inertial wrenches with `q'' = 0` (the `D` terms of eq. 9) and gravity.
///
/// With [`Recursion::Composite`] the backward recursion carries each subtree's wrench about
/// `O_i` in `F_i` as
///
/// ```text
/// F_i = M_i a_i + G_i        N_i = S_i x a_i + H_i
/// ```
///
/// with `a_i` the origin acceleration remainder with gravity (`accel`, or
/// `accel_no_gravity - T^i^T g`), `M_i` the subtree's mass, `S_i = m_i c_i + sum_k M_k d_k`
/// the first moment of the body's own mass and of its children's masses placed at their
/// origins, and `G_i`, `H_i` the rest (the body's own `m (al x c + w x (w x c))`, its
/// moment, and what the children transmit besides `M_k a_i`). Because
/// `R_k a_k = a_i + rel_k` for a child `k` (the forward recursion), the force a child
/// transmits is `R_k F_k = M_k (a_i + rel_k) + R_k G_k`: the acceleration is never
/// rotated back to the frame it came from (`R_k R_k^T a_i` leaves products of sines and
/// cosines that cancel only through `sin^2 + cos^2 = 1`), and each body's gravity comes from
/// its own `T^i` (angle sums) instead of travelling through the relative rotations. This
/// wins on planar chains (the 2-link chain's `F^b` from 28 to 19 operations); where the
/// rotations are full (spatial chains) its extra products can cost more than they save,
/// so `Symbolic::derive` keeps whichever variant is cheaper.
pub(super) fn velocity_and_gravity_terms(
    b: &mut Builder<'_>,
    kin: &[BodyKinematics],
    gravity: Gravity,
    recursion: Recursion,
) -> Vec<Id> {
    let model = b.model;
    let n = model.dof();
    let g = b.v(&model.gravity);
    let mut accel: Vec<V3> = Vec::with_capacity(n);
    let mut mass: Vec<Id> = Vec::with_capacity(n);
    let mut first: Vec<V3> = Vec::with_capacity(n);
    let mut rem_f: Vec<V3> = Vec::with_capacity(n);
    let mut rem_n: Vec<V3> = Vec::with_capacity(n);
    for (body, k) in model.bodies.iter().zip(kin) {
        let m = b.s(&body.mass);
        let c = b.v(&body.com);
        let ic = b.inertia(&body.inertia);
        let d = &mut b.dag;
        let a = match gravity {
            Gravity::BaseAcceleration => k.accel,
            Gravity::BodyForces => {
                // -g expressed in the body frame, T^i^T (-g).
                let gb = vec3::mat_t_vec(d, &k.ground_rot, g);
                vec3::sub(d, k.accel_no_gravity, gb)
            }
        };
        // The acceleration of the centre of mass a + al x c + w x (w x c), and the moment
        // I al + w x (I w) + c x f.
        let axc = vec3::cross(d, k.alpha, c);
        let wxc = vec3::cross(d, k.omega, c);
        let wwxc = vec3::cross(d, k.omega, wxc);
        let r = vec3::add(d, axc, wwxc);
        let ia = vec3::mat_vec(d, &ic, k.alpha);
        let iw = vec3::mat_vec(d, &ic, k.omega);
        let gyro = vec3::cross(d, k.omega, iw);
        let t = vec3::add(d, ia, gyro);
        let (fr, first_moment) = match recursion {
            // The whole force m (a + r).
            Recursion::Plain => {
                let a_c = vec3::add(d, a, r);
                let z = vec3::zero(d);
                (vec3::scale(d, m, a_c), z)
            }
            // m a in composite form (M, S), the rest m r into G.
            Recursion::Composite => (vec3::scale(d, m, r), vec3::scale(d, m, c)),
        };
        let cxf = vec3::cross(d, c, fr);
        accel.push(a);
        mass.push(m);
        first.push(first_moment);
        rem_f.push(fr);
        rem_n.push(vec3::add(d, t, cxf));
    }
    if recursion == Recursion::Plain {
        let wrench = rem_f.into_iter().zip(rem_n).collect();
        return backward_and_project(b, kin, wrench);
    }
    let mut out = vec![b.dag.zero(); n];
    for i in (0..n).rev() {
        let d = &mut b.dag;
        let ma = vec3::scale(d, mass[i], accel[i]);
        let f = vec3::add(d, ma, rem_f[i]);
        let sxa = vec3::cross(d, first[i], accel[i]);
        let nn = vec3::add(d, sxa, rem_n[i]);
        out[i] = joint::project(model, i, f, nn);
        let Some(p) = model.bodies[i].parent else {
            continue;
        };
        let k = &kin[i];
        // R_i F_i = M_i (a_p + rel_i) + R_i G_i, and R_i N_i + d_i x (R_i F_i) with
        // d_i x M_i a_p going into S_p.
        let rn = vec3::mat_vec(d, &k.rel_rot, nn);
        let rg = vec3::mat_vec(d, &k.rel_rot, rem_f[i]);
        let mrel = vec3::scale(d, mass[i], k.rel_accel);
        let gt = vec3::add(d, mrel, rg);
        let dxg = vec3::cross(d, k.offset, gt);
        let md = vec3::scale(d, mass[i], k.offset);
        first[p] = vec3::add(d, first[p], md);
        let t = vec3::add(d, rem_n[p], rn);
        rem_n[p] = vec3::add(d, t, dxg);
        rem_f[p] = vec3::add(d, rem_f[p], gt);
        mass[p] = d.add(mass[p], mass[i]);
    }
    out
}

/// Sums wrenches from the leaves to the root and projects each on its joint axis.
pub(super) fn backward_and_project(
    b: &mut Builder<'_>,
    kin: &[BodyKinematics],
    mut w: Vec<(V3, V3)>,
) -> Vec<Id> {
    let model = b.model;
    let n = model.dof();
    for i in (0..n).rev() {
        if let Some(p) = model.bodies[i].parent {
            let (f, nn) = wrench_to_parent(&mut b.dag, &kin[i], w[i].0, w[i].1);
            let fp = vec3::add(&mut b.dag, w[p].0, f);
            let np = vec3::add(&mut b.dag, w[p].1, nn);
            w[p] = (fp, np);
        }
    }
    (0..n)
        .map(|i| joint::project(model, i, w[i].0, w[i].1))
        .collect()
}

/// `G(q) = dF^b/dg = -sum_i m_i J_Ci^T` (`n x 3`, row-major: `out[3 j + k]` is the
/// derivative of `F^b_j` with respect to gravity component `g_k`). `F^b` is linear in
/// gravity (it enters as the base acceleration `a_0 = -g`), so a frame moving with
/// acceleration `a` (ground-frame components) loads the tree with `-G(q) a`: the
/// equations in the moving frame are the fixed-frame ones with `g` replaced by `g - a`.
///
/// By columns, from the subtree sums (leaves to root) of mass `M_j` and first moment
/// `S_j = sum m_i x_Ci` of the bodies carried by joint `j`:
///
/// ```text
/// row j = -a_j x (S_j - M_j x_Oj)   (turning joint)      -M_j a_j   (sliding joint)
/// ```
///
/// with `a_j` the joint axis in the ground frame (the lever arms of
/// `kinematics::point_jacobian`, summed over the subtree once instead of per body).
pub(super) fn gravity_jacobian(b: &mut Builder<'_>, kin: &[BodyKinematics]) -> Vec<Id> {
    let model = b.model;
    let n = model.dof();
    let mut mass: Vec<Id> = Vec::with_capacity(n);
    let mut first: Vec<V3> = Vec::with_capacity(n);
    for (i, body) in model.bodies.iter().enumerate() {
        let m = b.s(&body.mass);
        let c = b.v(&body.com);
        let x = super::kinematics::ground_point(&mut b.dag, kin, Some(i), c);
        mass.push(m);
        first.push(vec3::scale(&mut b.dag, m, x));
    }
    let z = b.dag.zero();
    let mut out = vec![z; 3 * n];
    for j in (0..n).rev() {
        let d = &mut b.dag;
        let k = &kin[j];
        let col = if k.slides {
            vec3::scale(d, mass[j], k.ground_axis)
        } else {
            let mx = vec3::scale(d, mass[j], k.ground_pos);
            let lever = vec3::sub(d, first[j], mx);
            vec3::cross(d, k.ground_axis, lever)
        };
        for c in 0..3 {
            out[3 * j + c] = d.neg(col[c]);
        }
        if let Some(p) = model.bodies[j].parent {
            mass[p] = d.add(mass[p], mass[j]);
            first[p] = vec3::add(d, first[p], first[j]);
        }
    }
    out
}
