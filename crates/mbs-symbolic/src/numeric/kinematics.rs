//! Ground-frame forward kinematics (eqs. 1–3) and point kinematics.
//!
//! Positions (eq. 1), with `T^0 = I`, `x_O0 = 0` for ground and `p` the parent of body `i`:
//!
//! ```text
//! e_i   = T^p R0_i e_axis                               joint axis in ground
//! T^i   = T^p R0_i Rot(axis, q_i)      (revolute)        T^p R0_i   (prismatic)
//! x_Oi  = x_Op + T^p a_i               (revolute)        x_Op + T^p a_i + e_i q_i   (prismatic)
//! x^i   = x_Oi + T^i c_i                                 centre of mass
//! ```
//!
//! Velocities (eq. 2) and accelerations (eq. 3) by the ground-frame recursion, with
//! `r_i = x_Oi - x_Op`, ground at rest with acceleration `a_0` (`-g` for dynamics, `0` for
//! pure kinematics), and `[R]`, `[P]` selecting revolute or prismatic joints:
//!
//! ```text
//! w_i     = w_p + [R] e_i q'_i
//! v_Oi    = v_Op + w_p x r_i + [P] e_i q'_i
//! alpha_i = alpha_p + [R] (w_p x e_i q'_i + e_i q''_i)
//! a_Oi    = a_Op + alpha_p x r_i + w_p x (w_p x r_i) + [P] (2 w_p x e_i q'_i + e_i q''_i)
//! ```
//!
//! A point `P` fixed on body `i` at ground position `x_P`, with `s = x_P - x_Oi`:
//! `v_P = v_Oi + w_i x s`, `a_P = a_Oi + alpha_i x s + w_i x (w_i x s)`. With `q'' = 0` these
//! accelerations are the paper's remainders `x''^{i,R}`, `w'^{i,R}` (eq. 3), and for a point
//! they are `J' q'`.
//!
//! Jacobian column `j` of a point at `x_P` on a body whose reference chain contains joint `j`
//! (zero otherwise):
//!
//! ```text
//! revolute:   dx_P/dq_j = e_j x (x_P - x_Oj),   dw/dq'_j = e_j     (x_Oj lies on the axis)
//! prismatic:  dx_P/dq_j = e_j,                  dw/dq'_j = 0
//! ```

use nalgebra::{DMatrix, Matrix3, Vector3};

use super::{NumericModel, joint, unit};

/// Ground-frame position and velocity state of one body (eqs. 1–2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyState {
    /// Orientation `T^i`: columns are the body axes in ground coordinates.
    pub rotation: Matrix3<f64>,
    /// Position of the body-frame origin `x_Oi` (on the joint axis for a revolute joint).
    pub origin: Vector3<f64>,
    /// Position of the centre of mass `x^i`.
    pub com: Vector3<f64>,
    /// Angular velocity `w^i`.
    pub omega: Vector3<f64>,
    /// Velocity of the body-frame origin.
    pub origin_velocity: Vector3<f64>,
    /// Velocity of the centre of mass `x'^i`.
    pub com_velocity: Vector3<f64>,
}

/// Configuration-level quantities of every body (eq. 1).
#[derive(Clone, Debug)]
pub(super) struct Frames {
    /// `T^i`.
    pub rot: Vec<Matrix3<f64>>,
    /// `x_Oi`.
    pub origin: Vec<Vector3<f64>>,
    /// Joint axis `e_i` in ground coordinates.
    pub axis: Vec<Vector3<f64>>,
}

/// Velocity and acceleration of one body (eqs. 2–3).
#[derive(Clone, Copy, Debug)]
pub(super) struct Motion {
    /// Angular velocity `w_i`.
    pub omega: Vector3<f64>,
    /// Velocity of the body-frame origin.
    pub vel: Vector3<f64>,
    /// Angular acceleration `alpha_i`.
    pub alpha: Vector3<f64>,
    /// Acceleration of the body-frame origin.
    pub acc: Vector3<f64>,
}

impl Motion {
    const REST: Motion = Motion {
        omega: Vector3::new(0.0, 0.0, 0.0),
        vel: Vector3::new(0.0, 0.0, 0.0),
        alpha: Vector3::new(0.0, 0.0, 0.0),
        acc: Vector3::new(0.0, 0.0, 0.0),
    };
}

impl Frames {
    /// Ground position of a point given in the frame of `body` (ground for `None`).
    pub fn point(&self, body: Option<usize>, local: &Vector3<f64>) -> Vector3<f64> {
        match body {
            Some(i) => self.origin[i] + self.rot[i] * local,
            None => *local,
        }
    }
}

/// Velocity of a point at ground position `x` fixed on `body`.
pub(super) fn point_velocity(
    fr: &Frames,
    motion: &[Motion],
    body: Option<usize>,
    x: &Vector3<f64>,
) -> Vector3<f64> {
    match body {
        Some(i) => {
            let s = x - fr.origin[i];
            motion[i].vel + motion[i].omega.cross(&s)
        }
        None => Vector3::zeros(),
    }
}

/// Acceleration of a point at ground position `x` fixed on `body` (`base` for ground points:
/// the base acceleration used in the recursion).
pub(super) fn point_acceleration(
    fr: &Frames,
    motion: &[Motion],
    body: Option<usize>,
    x: &Vector3<f64>,
    base: &Vector3<f64>,
) -> Vector3<f64> {
    match body {
        Some(i) => {
            let s = x - fr.origin[i];
            let m = &motion[i];
            m.acc + m.alpha.cross(&s) + m.omega.cross(&m.omega.cross(&s))
        }
        None => *base,
    }
}

impl NumericModel {
    /// Forward kinematics at the configuration level (eq. 1).
    pub(super) fn frames(&self, q: &[f64]) -> Frames {
        self.check_len(q, "q");
        let n = self.dof();
        let mut fr = Frames {
            rot: Vec::with_capacity(n),
            origin: Vec::with_capacity(n),
            axis: Vec::with_capacity(n),
        };
        for (i, b) in self.bodies.iter().enumerate() {
            let (tp, xp) = match b.parent {
                Some(p) => (fr.rot[p], fr.origin[p]),
                None => (Matrix3::identity(), Vector3::zeros()),
            };
            let joint = tp * b.r0;
            let e = joint * unit(b.axis);
            let anchor = xp + tp * b.anchor;
            let (t, x) = joint::placement(b.kind, b.axis, joint, &e, anchor, q[i]);
            fr.rot.push(t);
            fr.origin.push(x);
            fr.axis.push(e);
        }
        fr
    }

    /// Velocities and accelerations of every body (eqs. 2–3) with base acceleration `base`;
    /// `qdd = None` means `q'' = 0` (the remainders of eq. 3).
    pub(super) fn motion(
        &self,
        fr: &Frames,
        qd: &[f64],
        qdd: Option<&[f64]>,
        base: &Vector3<f64>,
    ) -> Vec<Motion> {
        self.check_len(qd, "qd");
        if let Some(qdd) = qdd {
            self.check_len(qdd, "qdd");
        }
        let ground = Motion {
            acc: *base,
            ..Motion::REST
        };
        let mut out: Vec<Motion> = Vec::with_capacity(self.dof());
        for (i, b) in self.bodies.iter().enumerate() {
            let (mp, xp) = match b.parent {
                Some(p) => (out[p], fr.origin[p]),
                None => (ground, Vector3::zeros()),
            };
            let e = fr.axis[i];
            let r = fr.origin[i] - xp;
            let qddi = qdd.map_or(0.0, |a| a[i]);
            let mut m = Motion {
                omega: mp.omega,
                vel: mp.vel + mp.omega.cross(&r),
                alpha: mp.alpha,
                acc: mp.acc + mp.alpha.cross(&r) + mp.omega.cross(&mp.omega.cross(&r)),
            };
            joint::add_joint_motion(b.kind, &mut m, &mp.omega, &e, qd[i], qddi);
            out.push(m);
        }
        out
    }

    /// Linear Jacobian column `dx_P/dq_j` of a point at ground position `x` on a body whose
    /// reference chain contains joint `j`.
    pub(super) fn linear_column(&self, fr: &Frames, j: usize, x: &Vector3<f64>) -> Vector3<f64> {
        joint::linear_column(self.bodies[j].kind, &fr.axis[j], &fr.origin[j], x)
    }

    /// Angular Jacobian column `dw/dq'_j` of a body whose reference chain contains joint `j`.
    pub(super) fn angular_column(&self, fr: &Frames, j: usize) -> Vector3<f64> {
        joint::angular_column(self.bodies[j].kind, &fr.axis[j])
    }

    /// The joints on the reference chain of `body` (none for ground).
    pub(super) fn path(&self, body: Option<usize>) -> &[usize] {
        match body {
            Some(i) => &self.paths[i],
            None => &[],
        }
    }

    /// Adds `scale * dx_P/dq` restricted to the ground components `rows` into rows
    /// `row0..row0 + rows.len()` of `out`, for a point at ground position `x` on `body`.
    pub(super) fn add_point_jacobian(
        &self,
        fr: &Frames,
        body: Option<usize>,
        x: &Vector3<f64>,
        scale: f64,
        rows: &[usize],
        row0: usize,
        out: &mut DMatrix<f64>,
    ) {
        for &j in self.path(body) {
            let col = self.linear_column(fr, j, x);
            for (k, &c) in rows.iter().enumerate() {
                out[(row0 + k, j)] += scale * col[c];
            }
        }
    }

    /// Ground-frame orientation, positions and velocities of every body (eqs. 1–2).
    ///
    /// `q` and `qd` must have [`NumericModel::dof`] entries.
    pub fn body_kinematics(&self, q: &[f64], qd: &[f64]) -> Vec<BodyState> {
        let fr = self.frames(q);
        let motion = self.motion(&fr, qd, None, &Vector3::zeros());
        self.bodies
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let com = fr.point(Some(i), &b.com);
                BodyState {
                    rotation: fr.rot[i],
                    origin: fr.origin[i],
                    com,
                    omega: motion[i].omega,
                    origin_velocity: motion[i].vel,
                    com_velocity: point_velocity(&fr, &motion, Some(i), &com),
                }
            })
            .collect()
    }

    /// Ground-frame position of the named point with index `point` (into
    /// [`Model::points`](crate::model::types::Model::points)).
    ///
    /// `q` must have [`NumericModel::dof`] entries.
    pub fn point_position(&self, point: usize, q: &[f64]) -> Vector3<f64> {
        self.check_point(point);
        let p = self.points[point];
        self.frames(q).point(p.body, &p.local)
    }

    /// Ground-frame velocity `J q'` of the named point with index `point`.
    ///
    /// `q` and `qd` must have [`NumericModel::dof`] entries.
    pub fn point_velocity(&self, point: usize, q: &[f64], qd: &[f64]) -> Vector3<f64> {
        self.check_point(point);
        let p = self.points[point];
        let fr = self.frames(q);
        let motion = self.motion(&fr, qd, None, &Vector3::zeros());
        point_velocity(&fr, &motion, p.body, &fr.point(p.body, &p.local))
    }

    /// The 3 x n Jacobian `dx_P/dq` of the named point with index `point` (ground
    /// components; zero columns for joints not on the point's reference chain).
    ///
    /// `q` must have [`NumericModel::dof`] entries.
    pub fn point_jacobian(&self, point: usize, q: &[f64]) -> DMatrix<f64> {
        self.check_point(point);
        let p = self.points[point];
        let fr = self.frames(q);
        let mut out = DMatrix::zeros(3, self.dof());
        let x = fr.point(p.body, &p.local);
        self.add_point_jacobian(&fr, p.body, &x, 1.0, &[0, 1, 2], 0, &mut out);
        out
    }

    /// `J' q'` of the named point with index `point`: its ground-frame acceleration computed
    /// with `q'' = 0` and no gravity (eq. 3 remainder), from the velocity recursion — not by
    /// finite differences.
    ///
    /// `q` and `qd` must have [`NumericModel::dof`] entries.
    pub fn point_bias(&self, point: usize, q: &[f64], qd: &[f64]) -> Vector3<f64> {
        self.check_point(point);
        let p = self.points[point];
        let fr = self.frames(q);
        let zero = Vector3::zeros();
        let motion = self.motion(&fr, qd, None, &zero);
        point_acceleration(&fr, &motion, p.body, &fr.point(p.body, &p.local), &zero)
    }
}
