//! The force elements, each in one place: its contribution to `Q^b` (eq. 13, paper sign
//! `Q = -(generalised applied force)`), its potential energy, its dissipation power and
//! the power of whatever is left (work put in).
//!
//! # The energy identity (docs/theory.md sections 2 and 8)
//!
//! Every element splits its generalised applied force `-Q_e` into the gradient of a potential
//! `V_e(q)` and a remainder whose power is either dissipated (`D_e(q, q') >= 0`, viscous
//! dampers) or put in (`P_e(q, q')`, any sign: loads that have no potential here):
//!
//! ```text
//! -q'^T Q_e = -dV_e/dt - D_e + P_e                      for every motion q(t)
//! ```
//!
//! so that along any motion of the tree `d(T + V)/dt = sum_e (P_e - D_e)` with
//! `V = V_gravity + sum_e V_e` (`energy.rs`). Per element:
//!
//! ```text
//! element                    Q_e (row / wrench)             V_e                D_e        P_e
//! joint spring-damper        k (q - q0) + c q' - f0         k (q - q0)^2 / 2   c q'^2     f0 q'
//! point spring-damper        tension k (l - l0) + c l'      k (l - l0)^2 / 2   c l'^2     0
//! external force and torque  -(J_v^T f + J_w^T t)           0                  0          f . x_P' + t . w
//! ```
//!
//! A constant joint force `f0` and an external load are counted as work input, not as a
//! potential: a torque of constant ground direction has no potential on a spatial tree (the
//! angular velocity is not the rate of any coordinate function), and a body-frame load
//! (a follower force) has none at all; for uniformity the ground-frame force and the constant
//! joint force are treated the same way. `V` therefore holds gravity and the springs only,
//! exactly as before, and nothing is counted twice: each term of `-q'^T Q_e` is in exactly
//! one of `dV_e/dt`, `D_e`, `P_e`. `D_e >= 0` whenever the damping coefficient is (a negative
//! coefficient is an energy source and shows as a negative `D_e`). No element depends on
//! time.
//!
//! Adding a force element means adding a `ForceElement` variant (model types and
//! validation), one function here returning its [`Contribution`], and the same formulas in
//! the numeric reference (`numeric/dynamics.rs`, `NumericModel::element_power`).

use super::Builder;
use super::forces::backward_and_project;
use super::kinematics::{BodyKinematics, ground_point};
use super::vec3::{self, V3};
use crate::expr::{Fun, Id};
use crate::model::{ForceElement, Scalar};

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

/// What one force element contributes besides its `Q^b` terms (see the module
/// documentation): `None` for a zero term.
#[derive(Clone, Copy, Debug, Default)]
struct Contribution {
    /// Potential energy `V_e(q)`.
    potential: Option<Id>,
    /// Dissipation power `D_e(q, q')`.
    dissipation: Option<Id>,
    /// Power put in, `P_e(q, q')`.
    input: Option<Id>,
}

/// The force elements' terms of the equations and of the energy account.
pub(super) struct Elements {
    /// `Q^b` (eq. 13), paper sign, one entry per coordinate.
    pub q: Vec<Id>,
    /// `V_e` of each element that stores energy, in model order.
    pub potentials: Vec<Id>,
    /// `D = sum_e D_e`.
    pub dissipation: Id,
    /// `P = sum_e P_e`.
    pub input: Id,
}

/// `Q^b` (eq. 13) of the force elements, with `Q = -(generalised force)`, and their
/// potentials, dissipation and input power (see the module documentation).
pub(super) fn force_elements(b: &mut Builder<'_>, kin: &[BodyKinematics]) -> Elements {
    let model = b.model;
    let n = model.dof();
    let z = vec3::zero(&mut b.dag);
    let mut acc = Applied {
        wrench: vec![(z, z); n],
        joint: vec![b.dag.zero(); n],
    };
    let mut potentials = Vec::new();
    let (mut dissipation, mut input) = (Vec::new(), Vec::new());
    for fe in &model.forces {
        let c = match fe {
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
        };
        potentials.extend(c.potential);
        dissipation.extend(c.dissipation);
        input.extend(c.input);
    }
    let Applied { wrench, joint } = acc;
    let projected = backward_and_project(b, kin, wrench);
    let q = (0..n)
        .map(|i| {
            let neg = b.dag.neg(projected[i]);
            b.dag.add(neg, joint[i])
        })
        .collect();
    Elements {
        q,
        potentials,
        dissipation: b.dag.sum(dissipation),
        input: b.dag.sum(input),
    }
}

/// `k s^2 / 2`.
fn spring_energy(b: &mut Builder<'_>, k: Id, s: Id) -> Id {
    let half = b.dag.constant(0.5);
    let s2 = b.dag.mul(s, s);
    let ks2 = b.dag.mul(k, s2);
    b.dag.mul(half, ks2)
}

/// `c x^2` (the power of a viscous damper at rate `x`).
fn damper_power(b: &mut Builder<'_>, c: Id, x: Id) -> Id {
    let x2 = b.dag.mul(x, x);
    b.dag.mul(c, x2)
}

/// Joint spring–damper with constant force on the row of `body`:
///
/// ```text
/// Q_body += k (q - q0) + c q' - f0,   V = k (q - q0)^2 / 2,   D = c q'^2,   P = f0 q'
/// ```
fn joint_spring_damper(
    b: &mut Builder<'_>,
    acc: &mut Applied,
    body: usize,
    [stiffness, damping, rest, constant]: [&Scalar; 4],
) -> Contribution {
    let (k, c, q0, f0) = (b.s(stiffness), b.s(damping), b.s(rest), b.s(constant));
    let (q, qd) = (b.dag.q(body), b.dag.qd(body));
    let dq = b.dag.sub(q, q0);
    let spring = b.dag.mul(k, dq);
    let damp = b.dag.mul(c, qd);
    let s = b.dag.add(spring, damp);
    let s = b.dag.sub(s, f0);
    acc.joint[body] = b.dag.add(acc.joint[body], s);
    Contribution {
        potential: Some(spring_energy(b, k, dq)),
        dissipation: Some(damper_power(b, c, qd)),
        input: Some(b.dag.mul(f0, qd)),
    }
}

/// External force and torque on `body`, the force applied at a body-frame point `r`; given
/// in the ground frame unless `in_body_frame`. No potential; its power is work put in:
///
/// ```text
/// P = f_g . x_P' + t_b . w_b      (x_P = x_Oi + T^i r; f_g ground frame, t_b and w_b body frame)
/// ```
fn external_load(
    b: &mut Builder<'_>,
    kin: &[BodyKinematics],
    acc: &mut Applied,
    body: usize,
    [point, force, torque]: [&[Scalar; 3]; 3],
    in_body_frame: bool,
) -> Contribution {
    let r = b.v(point);
    let f = b.v(force);
    let t = b.v(torque);
    let rt = kin[body].ground_rot;
    let (fb, tb, fg) = if in_body_frame {
        (f, t, vec3::mat_vec(&mut b.dag, &rt, f))
    } else {
        (
            vec3::mat_t_vec(&mut b.dag, &rt, f),
            vec3::mat_t_vec(&mut b.dag, &rt, t),
            f,
        )
    };
    acc.add_body_force(b, body, r, fb, Some(tb));
    let x = ground_point(&mut b.dag, kin, Some(body), r);
    let xd = b.dag.time_derivative_many(&x);
    let fv = vec3::dot(&mut b.dag, fg, [xd[0], xd[1], xd[2]]);
    let tw = vec3::dot(&mut b.dag, tb, kin[body].omega);
    Contribution {
        potential: None,
        dissipation: None,
        input: Some(b.dag.add(fv, tw)),
    }
}

/// Spring–damper between named points `a` and `b`: tension `k (l - l0) + c l'` along
/// `d = p_b - p_a`, pulling `a` towards `b` and `b` towards `a`;
///
/// ```text
/// V = k (l - l0)^2 / 2,   D = c l'^2,   P = 0,   l' = d . d' / l
/// ```
///
/// Undefined where the points coincide (`l = 0`: no direction).
fn point_spring(
    b: &mut Builder<'_>,
    kin: &[BodyKinematics],
    acc: &mut Applied,
    (a, pb): (usize, usize),
    [stiffness, damping, rest_length]: [&Scalar; 3],
) -> Contribution {
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
    Contribution {
        potential: Some(spring_energy(b, k, stretch)),
        dissipation: Some(damper_power(b, c, ld)),
        input: None,
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
