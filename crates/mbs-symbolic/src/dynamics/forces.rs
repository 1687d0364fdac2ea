//! The force terms of the equations of motion: `F^b` (eq. 12, the `D` terms of eq. 9 —
//! inertial wrenches with `q'' = 0` and gravity) and `Q^b` (eq. 13, the `E` terms — the
//! force elements, paper sign `Q = -(generalised applied force)`), both summed from the
//! leaves to the root and projected on the joint axes.
//!
//! Each force element has one function here ([`joint_spring_damper`], [`external_load`],
//! [`point_spring`]) and its stored energy in [`spring_stretch`]: adding a force element
//! means adding a `ForceElement` variant (model types and validation), its function and
//! match arms here, and the same formulas in the numeric reference (`numeric/`).

use super::kinematics::{BodyKinematics, ground_point, wrench_to_parent};
use super::vec3::{self, V3};
use super::{Builder, joint};
use crate::expr::{Fun, Id};
use crate::model::{ForceElement, Scalar};

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
fn backward_and_project(
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

/// Accumulators of the force elements' contributions to `Q^b`: the applied wrench of each
/// body (force and moment about `O_i`, body frame) and the direct terms of each joint row.
struct Applied {
    wrench: Vec<(V3, V3)>,
    joint: Vec<Id>,
}

impl Applied {
    /// Adds a body-frame force `fb` at body-frame point `r` and a body-frame torque `tb` (if
    /// any) to the applied wrench of body `i`.
    fn add_body_force(&mut self, b: &mut Builder<'_>, i: usize, r: V3, fb: V3, tb: Option<V3>) {
        let mut mom = vec3::cross(&mut b.dag, r, fb);
        if let Some(tb) = tb {
            mom = vec3::add(&mut b.dag, mom, tb);
        }
        let f = vec3::add(&mut b.dag, self.wrench[i].0, fb);
        let nn = vec3::add(&mut b.dag, self.wrench[i].1, mom);
        self.wrench[i] = (f, nn);
    }

    /// Adds a ground-frame force `fg` at body-frame point `r` of body `i`.
    fn add_ground_force(
        &mut self,
        b: &mut Builder<'_>,
        kin: &[BodyKinematics],
        i: usize,
        r: V3,
        fg: V3,
    ) {
        let fb = vec3::mat_t_vec(&mut b.dag, &kin[i].ground_rot, fg);
        self.add_body_force(b, i, r, fb, None);
    }
}

/// `Q^b` (eq. 13): the `E` terms of the force elements, with `Q = -(generalised force)`.
pub(super) fn applied_terms(b: &mut Builder<'_>, kin: &[BodyKinematics]) -> Vec<Id> {
    let model = b.model;
    let n = model.dof();
    let z = vec3::zero(&mut b.dag);
    let mut acc = Applied {
        wrench: vec![(z, z); n],
        joint: vec![b.dag.zero(); n],
    };
    for fe in &model.forces {
        match fe {
            ForceElement::Joint {
                body,
                stiffness,
                damping,
                rest,
                constant,
                ..
            } => joint_spring_damper(b, &mut acc, *body, [stiffness, damping, rest, constant]),
            ForceElement::External {
                body,
                point,
                force,
                torque,
                in_body_frame,
                ..
            } => external_load(
                b,
                kin,
                &mut acc,
                *body,
                [point, force, torque],
                *in_body_frame,
            ),
            ForceElement::PointSpring {
                a,
                b: pb,
                stiffness,
                damping,
                rest_length,
                ..
            } => point_spring(
                b,
                kin,
                &mut acc,
                (*a, *pb),
                [stiffness, damping, rest_length],
            ),
        }
    }
    let Applied { wrench, joint } = acc;
    let projected = backward_and_project(b, kin, wrench);
    (0..n)
        .map(|i| {
            let neg = b.dag.neg(projected[i]);
            b.dag.add(neg, joint[i])
        })
        .collect()
}

/// Joint spring–damper with constant force on the row of `body`: `k (q - q0) + c q' - f0`.
fn joint_spring_damper(
    b: &mut Builder<'_>,
    acc: &mut Applied,
    body: usize,
    [stiffness, damping, rest, constant]: [&Scalar; 4],
) {
    let (k, c, q0, f0) = (b.s(stiffness), b.s(damping), b.s(rest), b.s(constant));
    let (q, qd) = (b.dag.q(body), b.dag.qd(body));
    let dq = b.dag.sub(q, q0);
    let spring = b.dag.mul(k, dq);
    let damp = b.dag.mul(c, qd);
    let s = b.dag.add(spring, damp);
    let s = b.dag.sub(s, f0);
    acc.joint[body] = b.dag.add(acc.joint[body], s);
}

/// External force and torque on `body`, the force applied at a body-frame point; given in the
/// ground frame unless `in_body_frame`.
fn external_load(
    b: &mut Builder<'_>,
    kin: &[BodyKinematics],
    acc: &mut Applied,
    body: usize,
    [point, force, torque]: [&[Scalar; 3]; 3],
    in_body_frame: bool,
) {
    let r = b.v(point);
    let f = b.v(force);
    let t = b.v(torque);
    let (fb, tb) = if in_body_frame {
        (f, t)
    } else {
        let rt = &kin[body].ground_rot;
        (
            vec3::mat_t_vec(&mut b.dag, rt, f),
            vec3::mat_t_vec(&mut b.dag, rt, t),
        )
    };
    acc.add_body_force(b, body, r, fb, Some(tb));
}

/// Spring–damper between named points `a` and `b`: tension `k (l - l0) + c l'` along
/// `d = p_b - p_a`, pulling `a` towards `b` and `b` towards `a`.
fn point_spring(
    b: &mut Builder<'_>,
    kin: &[BodyKinematics],
    acc: &mut Applied,
    (a, pb): (usize, usize),
    [stiffness, damping, rest_length]: [&Scalar; 3],
) {
    let model = b.model;
    let (pa, pbb) = (&model.points[a], &model.points[pb]);
    let (ra, rb, d, l) = spring_geometry(b, kin, a, pb);
    // l' = d . d' / l, with d' the time derivative of d along the motion.
    let dv = b.dag.time_derivative_many(&d);
    let ddv = vec3::dot(&mut b.dag, d, [dv[0], dv[1], dv[2]]);
    let ld = b.dag.div(ddv, l);
    let (k, c, l0) = (b.s(stiffness), b.s(damping), b.s(rest_length));
    let stretch = b.dag.sub(l, l0);
    let ks = b.dag.mul(k, stretch);
    let cl = b.dag.mul(c, ld);
    let tension = b.dag.add(ks, cl);
    let per_len = b.dag.div(tension, l);
    let fa = vec3::scale(&mut b.dag, per_len, d);
    if let Some(i) = pa.body {
        acc.add_ground_force(b, kin, i, ra, fa);
    }
    if let Some(i) = pbb.body {
        let fb = [b.dag.neg(fa[0]), b.dag.neg(fa[1]), b.dag.neg(fa[2])];
        acc.add_ground_force(b, kin, i, rb, fb);
    }
}

/// The stretch `s` and stiffness `k` of a force element that stores energy `k s^2 / 2`
/// (`None` for one that stores none): `q - q0` of a joint spring, `l - l0` of a point spring.
pub(super) fn spring_stretch(
    b: &mut Builder<'_>,
    kin: &[BodyKinematics],
    fe: &ForceElement,
) -> Option<(Id, Id)> {
    match fe {
        ForceElement::Joint {
            body,
            stiffness,
            rest,
            ..
        } => {
            let (k, q0) = (b.s(stiffness), b.s(rest));
            let q = b.dag.q(*body);
            Some((b.dag.sub(q, q0), k))
        }
        ForceElement::PointSpring {
            a,
            b: pb,
            stiffness,
            rest_length,
            ..
        } => {
            let (_, _, _, l) = spring_geometry(b, kin, *a, *pb);
            let (k, l0) = (b.s(stiffness), b.s(rest_length));
            Some((b.dag.sub(l, l0), k))
        }
        ForceElement::External { .. } => None,
    }
}

/// Geometry of a spring between points `a` and `b`: their body-frame positions, the ground
/// vector `d = p_b - p_a` and the length `l = |d|`.
fn spring_geometry(
    b: &mut Builder<'_>,
    kin: &[BodyKinematics],
    a: usize,
    pb: usize,
) -> (V3, V3, V3, Id) {
    let (pa, pbb) = (&b.model.points[a], &b.model.points[pb]);
    let ra = b.v(&pa.position);
    let rb = b.v(&pbb.position);
    let xa = ground_point(&mut b.dag, kin, pa.body, ra);
    let xb = ground_point(&mut b.dag, kin, pbb.body, rb);
    let d = vec3::sub(&mut b.dag, xb, xa);
    let dd = vec3::dot(&mut b.dag, d, d);
    (ra, rb, d, b.dag.fun(Fun::Sqrt, dd))
}
