//! The symbolic recursive Newton–Euler formulation for tree mechanisms (paper section 2.1,
//! eqs. 1–13), in the Fisette–Samin / ROBOTRAN style: every kinematic and dynamic quantity is
//! a node of one expression DAG, expressed in body-fixed frames, with intermediate variables
//! shared rather than expanded.
//!
//! # Forward recursion (eqs. 1–3)
//!
//! For body `i` with parent `p`, relative rotation `R_i` and joint offset `d_i` (in `F_p`):
//!
//! ```text
//! T^i  = T^p R_i                      x_Oi = x_Op + T^p d_i                     (1)
//! w_i  = R_i^T w_p + e_i q'_i                         (revolute; w_i = R_i^T w_p if prismatic)
//! a_i  = R_i^T (a_p + al_p x d_i + w_p x (w_p x d_i) + 2 w_p x u_i q'_i)         remainders of (3)
//! al_i = R_i^T al_p + (R_i^T w_p) x e_i q'_i
//! ```
//!
//! with `a_0 = -g` (gravity as a base acceleration, so gravity lands in `F`), `u_i` the
//! prismatic axis in `F_p`, and all quantities in the body's own frame. `T^i` uses the sine
//! and cosine of the *sum* of the angles of consecutive revolute joints about the same axis
//! (ROBOTRAN's angle grouping) instead of products of rotations.
//!
//! # Backward recursion (eqs. 4–9) and projection (eqs. 10–13)
//!
//! * `F^b` (12): the `D` terms — the inertial wrench of each body with `q'' = 0`,
//!   `f_i = m_i a_Ci`, `n_i = I_i al_i + w_i x (I_i w_i) + c_i x f_i` about `O_i`, summed from
//!   the leaves to the root (`W_p += (R_i f, R_i n + d_i x R_i f)`) and projected on the joint
//!   axis (`e . n` for a revolute, `a . f` for a prismatic joint).
//! * `M^b` (11): the `C` terms — the response of the subtree of body `j` to a unit `q''_j`
//!   is the composite rigid body of that subtree (mass, first moment, inertia about `O_j`,
//!   accumulated from the leaves) times the joint's motion; projecting it on the axes of `j`
//!   and of its ancestors gives column `j` of `M^b` on and above the diagonal
//!   (the "sum over `l : i <= l`" of eq. 9 done once per subtree).
//! * `Q^b` (13): the `E` terms — applied forces and torques of the force elements,
//!   expressed in body frames, summed from the leaves and projected, with the paper's sign
//!   `Q = -(generalised applied force)`; joint force elements add directly to their row.

pub mod vec3;

use crate::expr::{Dag, Id, OpCount};
use crate::model::{ForceElement, JointKind, Model, Scalar};
use vec3::{M3, V3};

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

/// The symbolic equations of motion `M q'' + F + Q = 0` of a tree (eq. 10) and the
/// body kinematics they were derived from, all in one DAG.
#[derive(Clone, Debug)]
pub struct Symbolic {
    /// The expression arena.
    pub dag: Dag,
    /// Number of joint coordinates.
    pub n: usize,
    /// Per-body kinematics.
    pub bodies: Vec<BodyKinematics>,
    /// `M^b`, row-major `n x n`; `mass[i*n+j]` and `mass[j*n+i]` are the same node.
    pub mass: Vec<Id>,
    /// `F^b`: velocity terms and gravity.
    pub f: Vec<Id>,
    /// `Q^b`: force elements, paper sign.
    pub q: Vec<Id>,
    /// Potential energy `V(q)`: gravity `-sum m_i g . x_Ci` plus the springs of the force
    /// elements, `k (q - rest)^2 / 2` and `k (l - l0)^2 / 2`. The gravity part of `F^b` and the
    /// spring part of `Q^b` are its gradient.
    pub potential: Id,
}

struct Builder<'m> {
    model: &'m Model,
    dag: Dag,
}

impl Builder<'_> {
    fn s(&mut self, x: &Scalar) -> Id {
        self.dag.scalar(x, &self.model.parameters)
    }

    fn v(&mut self, x: &[Scalar; 3]) -> V3 {
        [self.s(&x[0]), self.s(&x[1]), self.s(&x[2])]
    }

    fn inertia(&mut self, i: &[[Scalar; 3]; 3]) -> M3 {
        let mut m = [[self.dag.zero(); 3]; 3];
        for r in 0..3 {
            for c in 0..3 {
                // Symmetric by validation; use the upper triangle for both halves so the
                // two halves are the same node.
                let (a, b) = if r <= c { (r, c) } else { (c, r) };
                m[r][c] = self.s(&i[a][b]);
            }
        }
        m
    }
}

/// Composite rigid body: mass, first moment `h = sum m r` and inertia `J` about the origin.
#[derive(Clone, Copy)]
struct Composite {
    m: Id,
    h: V3,
    j: M3,
}

impl Symbolic {
    /// Derives the symbolic equations of motion of the model's tree.
    pub fn derive(model: &Model) -> Symbolic {
        let mut b = Builder {
            model,
            dag: Dag::new(),
        };
        let bodies = forward_kinematics(&mut b);
        let n = model.dof();
        let mass = mass_matrix(&mut b, &bodies);
        // Both ways of bringing in gravity are exact; keep the one that needs fewer
        // operations together with M (the other's nodes are never emitted).
        let f_base = velocity_and_gravity_terms(&mut b, &bodies, Gravity::BaseAcceleration);
        let f_forces = velocity_and_gravity_terms(&mut b, &bodies, Gravity::BodyForces);
        let cost = |f: &[Id], dag: &Dag| {
            let roots: Vec<Id> = mass.iter().chain(f).copied().collect();
            dag.op_count(&roots).total()
        };
        let f = if cost(&f_forces, &b.dag) < cost(&f_base, &b.dag) {
            f_forces
        } else {
            f_base
        };
        let q = applied_terms(&mut b, &bodies);
        let potential = potential_energy(&mut b, &bodies);
        Symbolic {
            dag: b.dag,
            n,
            bodies,
            mass,
            f,
            q,
            potential,
        }
    }

    /// The distinct nodes of `M^b` (upper triangle, row by row) followed by `F^b`.
    pub fn mf_roots(&self) -> Vec<Id> {
        let mut roots = Vec::with_capacity(self.n * (self.n + 1) / 2 + self.n);
        for i in 0..self.n {
            for j in i..self.n {
                roots.push(self.mass[i * self.n + j]);
            }
        }
        roots.extend(&self.f);
        roots
    }

    /// Operations to evaluate `M^b` and `F^b` once (shared intermediates counted once).
    pub fn op_count_mf(&self) -> OpCount {
        self.dag.op_count(&self.mf_roots())
    }

    /// Operations to evaluate `M^b` once.
    pub fn op_count_m(&self) -> OpCount {
        let roots = self.mf_roots();
        self.dag.op_count(&roots[..roots.len() - self.n])
    }

    /// Operations to evaluate `F^b` once.
    pub fn op_count_f(&self) -> OpCount {
        self.dag.op_count(&self.f)
    }

    /// Operations to evaluate `Q^b` once.
    pub fn op_count_q(&self) -> OpCount {
        self.dag.op_count(&self.q)
    }

    /// Ground-frame position of a point fixed on `body` (`None` = ground) at body-frame
    /// coordinates `r` (eq. 1: `x = x_Oi + T^i r`).
    pub fn point_position(&mut self, body: Option<usize>, r: V3) -> V3 {
        match body {
            None => r,
            Some(i) => {
                let t = self.bodies[i].ground_rot;
                let x = self.bodies[i].ground_pos;
                let tr = vec3::mat_vec(&mut self.dag, &t, r);
                vec3::add(&mut self.dag, x, tr)
            }
        }
    }
}

/// Forward recursion: relative and absolute kinematics of every body (eqs. 1–3).
fn forward_kinematics(b: &mut Builder<'_>) -> Vec<BodyKinematics> {
    let model = b.model;
    let mut out: Vec<BodyKinematics> = Vec::with_capacity(model.dof());
    // Angle grouping for T^i: T^i = base * Rot(axis, angle) where `angle` is a sum of the
    // coordinates of consecutive revolute joints about the same axis.
    let mut groups: Vec<Option<(M3, usize, Id)>> = Vec::with_capacity(model.dof());
    let g = b.v(&model.gravity);
    let a_ground = [b.dag.neg(g[0]), b.dag.neg(g[1]), b.dag.neg(g[2])];
    for (i, body) in model.bodies.iter().enumerate() {
        let joint = &body.joint;
        let k = joint.axis.index();
        // Constant rotation R0 of the joint frame.
        let mut r0 = vec3::identity(&mut b.dag);
        for (ax, angle) in &joint.rotation {
            let th = b.s(angle);
            let (s, c) = (b.dag.sin(th), b.dag.cos(th));
            let r = vec3::rot(&mut b.dag, ax.index(), s, c);
            r0 = vec3::mat_mul(&mut b.dag, &r0, &r);
        }
        let r0_is_identity = r0 == vec3::identity(&mut b.dag);
        let anchor = b.v(&joint.anchor);
        let qi = b.dag.q(i);
        let qdi = b.dag.qd(i);
        let (rel_rot, offset, u) = match joint.kind {
            JointKind::Revolute => {
                let (s, c) = (b.dag.sin(qi), b.dag.cos(qi));
                let r = vec3::rot(&mut b.dag, k, s, c);
                (vec3::mat_mul(&mut b.dag, &r0, &r), anchor, None)
            }
            JointKind::Prismatic => {
                let u = [r0[0][k], r0[1][k], r0[2][k]];
                let uq = vec3::scale(&mut b.dag, qi, u);
                (r0, vec3::add(&mut b.dag, anchor, uq), Some(u))
            }
        };
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
        // Orientation with angle grouping.
        let (ground_rot, group) = match joint.kind {
            JointKind::Revolute => {
                let parent_group = body.parent.and_then(|p| groups[p]);
                let (base, angle) = match parent_group {
                    Some((base, ax, angle)) if ax == k && r0_is_identity => {
                        (base, b.dag.add(angle, qi))
                    }
                    _ => (vec3::mat_mul(&mut b.dag, &parent_rot, &r0), qi),
                };
                let (s, c) = (b.dag.sin(angle), b.dag.cos(angle));
                let r = vec3::rot(&mut b.dag, k, s, c);
                (vec3::mat_mul(&mut b.dag, &base, &r), Some((base, k, angle)))
            }
            JointKind::Prismatic => (vec3::mat_mul(&mut b.dag, &parent_rot, &r0), None),
        };
        groups.push(group);
        let tp_d = vec3::mat_vec(&mut b.dag, &parent_rot, offset);
        let ground_pos = vec3::add(&mut b.dag, parent_pos, tp_d);

        // Velocities and acceleration remainders in the body frame (eqs. 2–3, q'' = 0).
        let w_in = vec3::mat_t_vec(&mut b.dag, &rel_rot, w_p);
        let al_in = vec3::mat_t_vec(&mut b.dag, &rel_rot, al_p);
        let e = vec3::unit(&mut b.dag, k);
        let (omega, alpha) = match joint.kind {
            JointKind::Revolute => {
                let eq = vec3::scale(&mut b.dag, qdi, e);
                let omega = vec3::add(&mut b.dag, w_in, eq);
                let wxe = vec3::cross(&mut b.dag, w_in, eq);
                (omega, vec3::add(&mut b.dag, al_in, wxe))
            }
            JointKind::Prismatic => (w_in, al_in),
        };
        // a_i = R_i^T (a_p + al_p x d + w_p x (w_p x d) + 2 w_p x u q'_i), with and without
        // the base acceleration -g.
        let mut rel = vec3::cross(&mut b.dag, al_p, offset);
        let wxd = vec3::cross(&mut b.dag, w_p, offset);
        let t2 = vec3::cross(&mut b.dag, w_p, wxd);
        rel = vec3::add(&mut b.dag, rel, t2);
        if let Some(u) = u {
            let two_qd = {
                let two = b.dag.constant(2.0);
                b.dag.mul(two, qdi)
            };
            let uq = vec3::scale(&mut b.dag, two_qd, u);
            let cor = vec3::cross(&mut b.dag, w_p, uq);
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
fn wrench_to_parent(d: &mut Dag, kin: &BodyKinematics, f: V3, n: V3) -> (V3, V3) {
    let fp = vec3::mat_vec(d, &kin.rel_rot, f);
    let np = vec3::mat_vec(d, &kin.rel_rot, n);
    let dxf = vec3::cross(d, kin.offset, fp);
    (fp, vec3::add(d, np, dxf))
}

/// Projection of a wrench on joint `i`'s axis (eqs. 11–13): the torque component about the
/// axis for a revolute joint, the force component along it for a prismatic joint.
fn project(model: &Model, i: usize, f: V3, n: V3) -> Id {
    let joint = &model.bodies[i].joint;
    match joint.kind {
        JointKind::Revolute => n[joint.axis.index()],
        JointKind::Prismatic => f[joint.axis.index()],
    }
}

/// `M^b` (eq. 11) by composite bodies: see the module documentation.
fn mass_matrix(b: &mut Builder<'_>, kin: &[BodyKinematics]) -> Vec<Id> {
    let model = b.model;
    let n = model.dof();
    let mut comp: Vec<Composite> = Vec::with_capacity(n);
    for body in &model.bodies {
        let m = b.s(&body.mass);
        let c = b.v(&body.com);
        let ic = b.inertia(&body.inertia);
        let h = vec3::scale(&mut b.dag, m, c);
        // J = I_C + m (|c|^2 1 - c c^T)
        let cc = vec3::dot(&mut b.dag, c, c);
        let mut j = ic;
        for r in 0..3 {
            for col in r..3 {
                let outer = b.dag.mul(c[r], c[col]);
                let t = if r == col {
                    b.dag.sub(cc, outer)
                } else {
                    b.dag.neg(outer)
                };
                let mt = b.dag.mul(m, t);
                j[r][col] = b.dag.add(ic[r][col], mt);
                j[col][r] = j[r][col];
            }
        }
        comp.push(Composite { m, h, j });
    }
    for i in (0..n).rev() {
        let Some(p) = model.bodies[i].parent else {
            continue;
        };
        let child = comp[i];
        let d = &mut b.dag;
        let rot = &kin[i].rel_rot;
        let off = kin[i].offset;
        // h' = R h, J' = R J R^T + m(|d|^2 1 - d d^T) + 2 (d.h') 1 - (d h'^T + h' d^T)
        let hr = vec3::mat_vec(d, rot, child.h);
        let rj = vec3::mat_mul(d, rot, &child.j);
        let mut jt = [[d.zero(); 3]; 3];
        for r in 0..3 {
            for c in r..3 {
                jt[r][c] = vec3::dot(d, rj[r], rot[c]);
                jt[c][r] = jt[r][c];
            }
        }
        let dd = vec3::dot(d, off, off);
        let dh = vec3::dot(d, off, hr);
        let two = d.constant(2.0);
        let two_dh = d.mul(two, dh);
        let md = vec3::scale(d, child.m, off);
        let mut add_j = [[d.zero(); 3]; 3];
        for r in 0..3 {
            for c in r..3 {
                // m (|d|^2 delta - d_r d_c) + 2 (d.h) delta - (d_r h_c + h_r d_c)
                let mut t = d.mul(md[r], off[c]);
                t = d.neg(t);
                let cross_terms = {
                    let a = d.mul(off[r], hr[c]);
                    let bb = d.mul(hr[r], off[c]);
                    d.add(a, bb)
                };
                t = d.sub(t, cross_terms);
                if r == c {
                    let mdd = d.mul(child.m, dd);
                    t = d.add(t, mdd);
                    t = d.add(t, two_dh);
                }
                add_j[r][c] = t;
                add_j[c][r] = t;
            }
        }
        let j_shift = vec3::mat_add(d, &jt, &add_j);
        let parent = comp[p];
        let m_new = d.add(parent.m, child.m);
        let h_shift = vec3::add(d, hr, md);
        let h_new = vec3::add(d, parent.h, h_shift);
        let j_new = vec3::mat_add(d, &parent.j, &j_shift);
        comp[p] = Composite {
            m: m_new,
            h: h_new,
            j: j_new,
        };
    }
    let zero = b.dag.zero();
    let mut mass = vec![zero; n * n];
    for i in 0..n {
        let joint = &model.bodies[i].joint;
        let e = vec3::unit(&mut b.dag, joint.axis.index());
        let c = comp[i];
        // Wrench of the subtree for a unit q''_i, about O_i in F_i.
        let (mut f, mut nn) = match joint.kind {
            JointKind::Revolute => (
                vec3::cross(&mut b.dag, e, c.h),
                vec3::mat_vec(&mut b.dag, &c.j, e),
            ),
            JointKind::Prismatic => (
                vec3::scale(&mut b.dag, c.m, e),
                vec3::cross(&mut b.dag, c.h, e),
            ),
        };
        mass[i * n + i] = project(model, i, f, nn);
        let mut k = i;
        while let Some(j) = model.bodies[k].parent {
            (f, nn) = wrench_to_parent(&mut b.dag, &kin[k], f, nn);
            let mji = project(model, j, f, nn);
            mass[j * n + i] = mji;
            mass[i * n + j] = mji;
            k = j;
        }
    }
    mass
}

/// How gravity enters `F^b`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Gravity {
    /// As the base acceleration `-g` of the forward recursion (ROBOTRAN's way).
    BaseAcceleration,
    /// As forces `m g` at the centres of mass, expressed in body frames through the ground
    /// orientations `T^i` (which use angle sums of parallel revolute joints).
    BodyForces,
}

/// `F^b` (eq. 12): inertial wrenches with `q'' = 0` (the `D` terms of eq. 9) and gravity.
fn velocity_and_gravity_terms(
    b: &mut Builder<'_>,
    kin: &[BodyKinematics],
    gravity: Gravity,
) -> Vec<Id> {
    let model = b.model;
    let n = model.dof();
    let g = b.v(&model.gravity);
    let mut wrench: Vec<(V3, V3)> = Vec::with_capacity(n);
    for (body, k) in model.bodies.iter().zip(kin) {
        let m = b.s(&body.mass);
        let c = b.v(&body.com);
        let ic = b.inertia(&body.inertia);
        let d = &mut b.dag;
        let a_o = match gravity {
            Gravity::BaseAcceleration => k.accel,
            Gravity::BodyForces => k.accel_no_gravity,
        };
        // a_C = a_O + al x c + w x (w x c)
        let axc = vec3::cross(d, k.alpha, c);
        let wxc = vec3::cross(d, k.omega, c);
        let wwxc = vec3::cross(d, k.omega, wxc);
        let t = vec3::add(d, a_o, axc);
        let mut a_c = vec3::add(d, t, wwxc);
        if gravity == Gravity::BodyForces {
            // The inertial force m (a_C - g): -g expressed in the body frame, T^i^T (-g).
            let gb = vec3::mat_t_vec(d, &k.ground_rot, g);
            a_c = vec3::sub(d, a_c, gb);
        }
        let f = vec3::scale(d, m, a_c);
        // n = I al + w x (I w) + c x f
        let ia = vec3::mat_vec(d, &ic, k.alpha);
        let iw = vec3::mat_vec(d, &ic, k.omega);
        let gyro = vec3::cross(d, k.omega, iw);
        let cxf = vec3::cross(d, c, f);
        let t = vec3::add(d, ia, gyro);
        let nn = vec3::add(d, t, cxf);
        wrench.push((f, nn));
    }
    backward_and_project(b, kin, wrench)
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
    (0..n).map(|i| project(model, i, w[i].0, w[i].1)).collect()
}

/// `Q^b` (eq. 13): the `E` terms of the force elements, with `Q = -(generalised force)`.
fn applied_terms(b: &mut Builder<'_>, kin: &[BodyKinematics]) -> Vec<Id> {
    let model = b.model;
    let n = model.dof();
    let z = vec3::zero(&mut b.dag);
    let mut applied: Vec<(V3, V3)> = vec![(z, z); n];
    let mut joint_terms: Vec<Id> = vec![b.dag.zero(); n];
    // Applies a ground-frame force at body-frame point r of body i.
    let apply_ground_force =
        |b: &mut Builder<'_>, applied: &mut Vec<(V3, V3)>, i: usize, r: V3, fg: V3| {
            let fb = vec3::mat_t_vec(&mut b.dag, &kin[i].ground_rot, fg);
            let mom = vec3::cross(&mut b.dag, r, fb);
            let f = vec3::add(&mut b.dag, applied[i].0, fb);
            let nn = vec3::add(&mut b.dag, applied[i].1, mom);
            applied[i] = (f, nn);
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
            } => {
                let (k, c, q0, f0) = (b.s(stiffness), b.s(damping), b.s(rest), b.s(constant));
                let (q, qd) = (b.dag.q(*body), b.dag.qd(*body));
                let dq = b.dag.sub(q, q0);
                let spring = b.dag.mul(k, dq);
                let damp = b.dag.mul(c, qd);
                let s = b.dag.add(spring, damp);
                let s = b.dag.sub(s, f0);
                joint_terms[*body] = b.dag.add(joint_terms[*body], s);
            }
            ForceElement::External {
                body,
                point,
                force,
                torque,
                in_body_frame,
                ..
            } => {
                let r = b.v(point);
                let f = b.v(force);
                let t = b.v(torque);
                let (fb, tb) = if *in_body_frame {
                    (f, t)
                } else {
                    let rt = &kin[*body].ground_rot;
                    (
                        vec3::mat_t_vec(&mut b.dag, rt, f),
                        vec3::mat_t_vec(&mut b.dag, rt, t),
                    )
                };
                let mom = vec3::cross(&mut b.dag, r, fb);
                let mom = vec3::add(&mut b.dag, mom, tb);
                let fsum = vec3::add(&mut b.dag, applied[*body].0, fb);
                let nsum = vec3::add(&mut b.dag, applied[*body].1, mom);
                applied[*body] = (fsum, nsum);
            }
            ForceElement::PointSpring {
                a,
                b: pb,
                stiffness,
                damping,
                rest_length,
                ..
            } => {
                let (pa, pbb) = (&model.points[*a], &model.points[*pb]);
                let (ra, rb, d, l) = spring_geometry(b, kin, *a, *pb);
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
                    apply_ground_force(b, &mut applied, i, ra, fa);
                }
                if let Some(i) = pbb.body {
                    let fb = [b.dag.neg(fa[0]), b.dag.neg(fa[1]), b.dag.neg(fa[2])];
                    apply_ground_force(b, &mut applied, i, rb, fb);
                }
            }
        }
    }
    let projected = backward_and_project(b, kin, applied);
    (0..n)
        .map(|i| {
            let neg = b.dag.neg(projected[i]);
            b.dag.add(neg, joint_terms[i])
        })
        .collect()
}

/// `V(q)`: gravity and the springs of the force elements (see [`Symbolic::potential`]).
fn potential_energy(b: &mut Builder<'_>, kin: &[BodyKinematics]) -> Id {
    let model = b.model;
    let g = b.v(&model.gravity);
    let mut v = b.dag.zero();
    for (i, body) in model.bodies.iter().enumerate() {
        let m = b.s(&body.mass);
        let c = b.v(&body.com);
        let x = ground_point(b, kin, Some(i), c);
        let gx = vec3::dot(&mut b.dag, g, x);
        let mgx = b.dag.mul(m, gx);
        v = b.dag.sub(v, mgx);
    }
    let half = b.dag.constant(0.5);
    for fe in &model.forces {
        let stretch_and_k = match fe {
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
        };
        if let Some((s, k)) = stretch_and_k {
            let s2 = b.dag.mul(s, s);
            let ks2 = b.dag.mul(k, s2);
            let e = b.dag.mul(half, ks2);
            v = b.dag.add(v, e);
        }
    }
    v
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
    let xa = ground_point(b, kin, pa.body, ra);
    let xb = ground_point(b, kin, pbb.body, rb);
    let d = vec3::sub(&mut b.dag, xb, xa);
    let dd = vec3::dot(&mut b.dag, d, d);
    (ra, rb, d, b.dag.fun(crate::expr::Fun::Sqrt, dd))
}

fn ground_point(b: &mut Builder<'_>, kin: &[BodyKinematics], body: Option<usize>, r: V3) -> V3 {
    match body {
        None => r,
        Some(i) => {
            let tr = vec3::mat_vec(&mut b.dag, &kin[i].ground_rot, r);
            vec3::add(&mut b.dag, kin[i].ground_pos, tr)
        }
    }
}

#[cfg(test)]
mod tests;
