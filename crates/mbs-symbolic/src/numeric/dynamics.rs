//! Tree dynamics (eqs. 10–13) in the ground frame: mass matrix and remainder terms from
//! body Jacobians, an independent recursive Newton–Euler for inverse dynamics, force
//! elements, forward dynamics and energies.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use super::joint;
use super::kinematics::{Frames, Motion, point_acceleration, point_velocity};
use super::{NForce, NumericModel};

/// Which parts of the force elements [`NumericModel::generalised_force`] collects.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Part {
    /// Everything (eq. 13).
    All,
    /// Only what is not derived from the potential of [`NumericModel::potential_energy`].
    NonConservative,
}

impl NumericModel {
    /// Inertia tensor of body `i` about its centre of mass in ground axes,
    /// `I^g = T^i I T^i^T`.
    fn ground_inertia(&self, fr: &Frames, i: usize) -> Matrix3<f64> {
        fr.rot[i] * self.bodies[i].inertia * fr.rot[i].transpose()
    }

    /// Mass matrix `M^b(q)` (eq. 11), assembled from the body Jacobians at the centres of
    /// mass:
    ///
    /// ```text
    /// M = sum_i ( m_i Jv_i^T Jv_i + Jw_i^T I_i^g Jw_i )
    /// ```
    ///
    /// Exactly symmetric (the lower triangle is mirrored). `q` must have
    /// [`NumericModel::dof`] entries.
    pub fn mass_matrix(&self, q: &[f64]) -> DMatrix<f64> {
        let fr = self.frames(q);
        let n = self.dof();
        let mut m = DMatrix::zeros(n, n);
        let mut jv = Vec::with_capacity(n);
        let mut jw = Vec::with_capacity(n);
        for (i, b) in self.bodies.iter().enumerate() {
            let path = &self.paths[i];
            let xc = fr.point(Some(i), &b.com);
            let ig = self.ground_inertia(&fr, i);
            jv.clear();
            jw.clear();
            for &j in path {
                jv.push(self.linear_column(&fr, j, &xc));
                jw.push(self.angular_column(&fr, j));
            }
            for (a, &j) in path.iter().enumerate() {
                let ig_w = ig * jw[a];
                for (c, &k) in path.iter().enumerate().take(a + 1) {
                    m[(j, k)] += b.mass * jv[a].dot(&jv[c]) + jw[c].dot(&ig_w);
                }
            }
        }
        for j in 0..n {
            for k in 0..j {
                m[(k, j)] = m[(j, k)];
            }
        }
        m
    }

    /// Projects the inertial wrenches of all bodies (evaluated from `motion`) on the joint
    /// axes: `sum_i Jv_i^T m_i a_i + Jw_i^T (I_i^g alpha_i + w_i x I_i^g w_i)`.
    fn project_inertial(
        &self,
        fr: &Frames,
        motion: &[Motion],
        base: &Vector3<f64>,
    ) -> DVector<f64> {
        let mut out = DVector::zeros(self.dof());
        for (i, b) in self.bodies.iter().enumerate() {
            let xc = fr.point(Some(i), &b.com);
            let ac = point_acceleration(fr, motion, Some(i), &xc, base);
            let ig = self.ground_inertia(fr, i);
            let (w, alpha) = (motion[i].omega, motion[i].alpha);
            let force = ac * b.mass;
            let torque = ig * alpha + w.cross(&(ig * w));
            self.add_wrench(fr, Some(i), &xc, &force, &torque, 1.0, &mut out);
        }
        out
    }

    /// Adds `scale * (Jv_P^T force + Jw^T torque)` for a force applied at ground position `x`
    /// on `body` and a torque on that body, into `out`.
    fn add_wrench(
        &self,
        fr: &Frames,
        body: Option<usize>,
        x: &Vector3<f64>,
        force: &Vector3<f64>,
        torque: &Vector3<f64>,
        scale: f64,
        out: &mut DVector<f64>,
    ) {
        for &j in self.path(body) {
            let g =
                self.linear_column(fr, j, x).dot(force) + self.angular_column(fr, j).dot(torque);
            out[j] += scale * g;
        }
    }

    /// `F^b(q, q')` (eq. 12): velocity terms (gyroscopic, centrifugal, Coriolis) and gravity,
    /// the inertial wrenches of the accelerations computed with `q'' = 0` and base
    /// acceleration `-g`, projected with the body Jacobians:
    ///
    /// ```text
    /// F = sum_i ( Jv_i^T m_i a_i^R + Jw_i^T ( I_i^g alpha_i^R + w_i x I_i^g w_i ) )
    /// ```
    ///
    /// `q` and `qd` must have [`NumericModel::dof`] entries.
    pub fn f_vector(&self, q: &[f64], qd: &[f64]) -> DVector<f64> {
        let fr = self.frames(q);
        let base = -self.gravity;
        let motion = self.motion(&fr, qd, None, &base);
        self.project_inertial(&fr, &motion, &base)
    }

    /// Inverse dynamics of the tree without force elements, `M^b q'' + F^b` (eqs. 10–12), by
    /// a ground-frame recursive Newton–Euler independent of [`NumericModel::mass_matrix`] and
    /// [`NumericModel::f_vector`]: forward pass for the accelerations (base acceleration
    /// `-g`), backward pass for the wrench `(f_i, n_i)` that the parent exerts on body `i`
    /// (moment about the body-frame origin `x_Oi`, which lies on a revolute axis),
    ///
    /// ```text
    /// f_i = m_i a_i + sum_{c child of i} f_c
    /// n_i = I_i^g alpha_i + w_i x I_i^g w_i + (x^i - x_Oi) x m_i a_i
    ///       + sum_c ( n_c + (x_Oc - x_Oi) x f_c )
    /// tau_i = e_i . n_i  (revolute),   e_i . f_i  (prismatic)
    /// ```
    ///
    /// `q`, `qd` and `qdd` must have [`NumericModel::dof`] entries.
    pub fn inverse_dynamics(&self, q: &[f64], qd: &[f64], qdd: &[f64]) -> DVector<f64> {
        let fr = self.frames(q);
        let base = -self.gravity;
        let motion = self.motion(&fr, qd, Some(qdd), &base);
        let n = self.dof();
        let mut f = vec![Vector3::zeros(); n];
        let mut moment = vec![Vector3::zeros(); n];
        let mut tau = DVector::zeros(n);
        for i in (0..n).rev() {
            let b = &self.bodies[i];
            let xc = fr.point(Some(i), &b.com);
            let ma = point_acceleration(&fr, &motion, Some(i), &xc, &base) * b.mass;
            let ig = self.ground_inertia(&fr, i);
            let w = motion[i].omega;
            f[i] += ma;
            moment[i] += ig * motion[i].alpha + w.cross(&(ig * w)) + (xc - fr.origin[i]).cross(&ma);
            tau[i] = joint::project(b.kind, &fr.axis[i], &f[i], &moment[i]);
            if let Some(p) = b.parent {
                let (fi, ni) = (f[i], moment[i]);
                f[p] += fi;
                moment[p] += ni + (fr.origin[i] - fr.origin[p]).cross(&fi);
            }
        }
        tau
    }

    /// Generalised applied force of the force elements (`-Q`), or only its non-conservative
    /// part.
    fn generalised_force(&self, q: &[f64], qd: &[f64], part: Part) -> DVector<f64> {
        let fr = self.frames(q);
        let motion = self.motion(&fr, qd, None, &Vector3::zeros());
        let cons = if part == Part::All { 1.0 } else { 0.0 };
        let zero = Vector3::zeros();
        let mut g = DVector::zeros(self.dof());
        for force in &self.forces {
            match *force {
                NForce::Joint {
                    body,
                    stiffness,
                    damping,
                    rest,
                    constant,
                } => {
                    g[body] += -cons * stiffness * (q[body] - rest) - damping * qd[body] + constant;
                }
                NForce::PointSpring {
                    a,
                    b,
                    stiffness,
                    damping,
                    rest_length,
                } => {
                    let (pa, pb) = (self.points[a], self.points[b]);
                    let (xa, xb) = (fr.point(pa.body, &pa.local), fr.point(pb.body, &pb.local));
                    let d = xb - xa;
                    let l = d.norm();
                    if l == 0.0 {
                        // Coincident points: the direction is undefined; no force.
                        continue;
                    }
                    let u = d / l;
                    let va = point_velocity(&fr, &motion, pa.body, &xa);
                    let vb = point_velocity(&fr, &motion, pb.body, &xb);
                    let ld = u.dot(&(vb - va));
                    let tension = cons * stiffness * (l - rest_length) + damping * ld;
                    let fa = u * tension;
                    self.add_wrench(&fr, pa.body, &xa, &fa, &zero, 1.0, &mut g);
                    self.add_wrench(&fr, pb.body, &xb, &fa, &zero, -1.0, &mut g);
                }
                NForce::External {
                    body,
                    point,
                    force,
                    torque,
                    in_body_frame,
                } => {
                    let (f, t) = if in_body_frame {
                        (fr.rot[body] * force, fr.rot[body] * torque)
                    } else {
                        (force, torque)
                    };
                    let x = fr.point(Some(body), &point);
                    self.add_wrench(&fr, Some(body), &x, &f, &t, 1.0, &mut g);
                }
            }
        }
        g
    }

    /// `Q^b(q, q', t)` (eq. 13) of all force elements, with the paper's sign:
    /// `Q = -(generalised applied force)`, so that `M q'' + F + Q = 0`.
    ///
    /// Per element (see [`ForceElement`](crate::model::types::ForceElement)): joint
    /// `-k (q - rest) - c q' + constant` on its coordinate; point spring-damper tension
    /// `f = k (l - l0) + c l'` applied as `+f d/l` at `a` and `-f d/l` at `b` (no force when
    /// the two points coincide, `l = 0`, where the direction is undefined); external force at
    /// its point and torque on its body (rotated with `T^i` when given in the body frame);
    /// each projected with the point and body Jacobians, `Jv^T f + Jw^T t`. No current force
    /// element depends on time: `t` is accepted for the signature of eq. (13).
    ///
    /// `q` and `qd` must have [`NumericModel::dof`] entries.
    pub fn q_vector(&self, q: &[f64], qd: &[f64], t: f64) -> DVector<f64> {
        let _ = t;
        -self.generalised_force(q, qd, Part::All)
    }

    /// The part of [`NumericModel::q_vector`] not derived from the springs' potential in
    /// [`NumericModel::potential_energy`]: joint and point damping, constant joint forces and
    /// external forces and torques. Along any motion of the tree,
    ///
    /// ```text
    /// d(T + V)/dt = -q'^T Q_nc
    /// ```
    ///
    /// `q` and `qd` must have [`NumericModel::dof`] entries.
    pub fn q_nonconservative(&self, q: &[f64], qd: &[f64], t: f64) -> DVector<f64> {
        let _ = t;
        -self.generalised_force(q, qd, Part::NonConservative)
    }

    /// Dissipation power `D(q, q')` and input power `P(q, q')` of the force elements, as
    /// `(D, P)` (the symbolic counterparts are stated with each element in
    /// `dynamics/elements.rs`):
    ///
    /// ```text
    /// joint spring-damper        D_e = c q'^2      P_e = constant q'
    /// point spring-damper        D_e = c l'^2      P_e = 0            (l' = u . (v_b - v_a))
    /// external force and torque  D_e = 0           P_e = f . x_P' + t . w      (ground frame)
    /// ```
    ///
    /// With [`NumericModel::potential_energy`] (gravity and springs) and
    /// [`NumericModel::q_nonconservative`] they satisfy, at every state,
    ///
    /// ```text
    /// -q'^T Q_nc = P - D,      so along any motion   d(T + V)/dt = P - D
    /// ```
    ///
    /// (docs/theory.md section 8). A point spring-damper whose points coincide contributes
    /// nothing, as in [`NumericModel::q_vector`].
    ///
    /// `q` and `qd` must have [`NumericModel::dof`] entries.
    pub fn element_power(&self, q: &[f64], qd: &[f64]) -> (f64, f64) {
        let fr = self.frames(q);
        let motion = self.motion(&fr, qd, None, &Vector3::zeros());
        let (mut d, mut p) = (0.0, 0.0);
        for force in &self.forces {
            match *force {
                NForce::Joint {
                    body,
                    damping,
                    constant,
                    ..
                } => {
                    d += damping * qd[body] * qd[body];
                    p += constant * qd[body];
                }
                NForce::PointSpring { a, b, damping, .. } => {
                    let (pa, pb) = (self.points[a], self.points[b]);
                    let (xa, xb) = (fr.point(pa.body, &pa.local), fr.point(pb.body, &pb.local));
                    let dv = xb - xa;
                    let l = dv.norm();
                    if l == 0.0 {
                        continue;
                    }
                    let va = point_velocity(&fr, &motion, pa.body, &xa);
                    let vb = point_velocity(&fr, &motion, pb.body, &xb);
                    let ld = (dv / l).dot(&(vb - va));
                    d += damping * ld * ld;
                }
                NForce::External {
                    body,
                    point,
                    force,
                    torque,
                    in_body_frame,
                } => {
                    let (f, t) = if in_body_frame {
                        (fr.rot[body] * force, fr.rot[body] * torque)
                    } else {
                        (force, torque)
                    };
                    let x = fr.point(Some(body), &point);
                    let v = point_velocity(&fr, &motion, Some(body), &x);
                    p += f.dot(&v) + t.dot(&motion[body].omega);
                }
            }
        }
        (d, p)
    }

    /// Forward dynamics of the tree (eq. 10): `q'' = -M^-1 (F + Q)`, or `None` when `M` is
    /// singular (possible only for degenerate models, e.g. a body without inertia about its
    /// joint axis at the end of a chain).
    ///
    /// `q` and `qd` must have [`NumericModel::dof`] entries.
    pub fn try_forward_dynamics(&self, q: &[f64], qd: &[f64], t: f64) -> Option<DVector<f64>> {
        let m = self.mass_matrix(q);
        let rhs = -(self.f_vector(q, qd) + self.q_vector(q, qd, t));
        match m.clone().cholesky() {
            Some(ch) => Some(ch.solve(&rhs)),
            None => m.lu().solve(&rhs),
        }
    }

    /// Forward dynamics of the tree (eq. 10): `q'' = -M^-1 (F + Q)` by a Cholesky
    /// factorisation of `M`; all entries NaN when `M` is singular (see
    /// [`NumericModel::try_forward_dynamics`]).
    ///
    /// `q` and `qd` must have [`NumericModel::dof`] entries.
    pub fn forward_dynamics(&self, q: &[f64], qd: &[f64], t: f64) -> DVector<f64> {
        self.try_forward_dynamics(q, qd, t)
            .unwrap_or_else(|| DVector::from_element(self.dof(), f64::NAN))
    }

    /// Kinetic energy, body by body: `T = sum_i ( 1/2 m_i |x'^i|^2 + 1/2 w_i . I_i^g w_i )`
    /// (equal to `1/2 q'^T M q'`).
    ///
    /// `q` and `qd` must have [`NumericModel::dof`] entries.
    pub fn kinetic_energy(&self, q: &[f64], qd: &[f64]) -> f64 {
        let fr = self.frames(q);
        let motion = self.motion(&fr, qd, None, &Vector3::zeros());
        let mut t = 0.0;
        for (i, b) in self.bodies.iter().enumerate() {
            let xc = fr.point(Some(i), &b.com);
            let vc = point_velocity(&fr, &motion, Some(i), &xc);
            let w = motion[i].omega;
            t += 0.5 * b.mass * vc.norm_squared() + 0.5 * w.dot(&(self.ground_inertia(&fr, i) * w));
        }
        t
    }

    /// Potential energy `V(q)`, made of exactly:
    ///
    /// ```text
    /// V = - sum_i m_i g . x^i                                  gravity (zero at the origin)
    ///     + sum_joint elements     1/2 k (q_i - rest)^2        joint springs
    ///     + sum_point spring-dampers 1/2 k (l - rest_length)^2  point springs
    /// ```
    ///
    /// Gravity is part of `F` (eq. 12), the springs part of `Q` (eq. 13); everything else in
    /// `Q` — damping, constant joint forces, external forces — is left out of `V` and
    /// collected by [`NumericModel::q_nonconservative`], so that along the motion
    /// `d(T + V)/dt = -q'^T Q_nc` (docs/theory.md section 8), and `T + V` is conserved when there
    /// is none.
    ///
    /// `q` must have [`NumericModel::dof`] entries.
    pub fn potential_energy(&self, q: &[f64]) -> f64 {
        let fr = self.frames(q);
        let mut v = 0.0;
        for (i, b) in self.bodies.iter().enumerate() {
            v -= b.mass * self.gravity.dot(&fr.point(Some(i), &b.com));
        }
        for force in &self.forces {
            match *force {
                NForce::Joint {
                    body,
                    stiffness,
                    rest,
                    ..
                } => v += 0.5 * stiffness * (q[body] - rest).powi(2),
                NForce::PointSpring {
                    a,
                    b,
                    stiffness,
                    rest_length,
                    ..
                } => {
                    let (pa, pb) = (self.points[a], self.points[b]);
                    let l = (fr.point(pb.body, &pb.local) - fr.point(pa.body, &pa.local)).norm();
                    v += 0.5 * stiffness * (l - rest_length).powi(2);
                }
                NForce::External { .. } => {}
            }
        }
        v
    }

    /// `G(q) = dF^b/dg = -sum_i m_i J_Ci^T` (`n x 3`): the Jacobian of every body's centre
    /// of mass from the recursive kinematics, weighted by its mass. A ground frame that
    /// accelerates by `a` adds `-G(q) a` to `F^b`.
    ///
    /// `q` must have [`NumericModel::dof`] entries.
    pub fn gravity_load_jacobian(&self, q: &[f64]) -> DMatrix<f64> {
        self.check_len(q, "q");
        let fr = self.frames(q);
        let mut jt = DMatrix::zeros(3, self.dof());
        for (i, b) in self.bodies.iter().enumerate() {
            let com = fr.point(Some(i), &b.com);
            self.add_point_jacobian(&fr, Some(i), &com, -b.mass, &[0, 1, 2], 0, &mut jt);
        }
        jt.transpose()
    }
}
