//! Constraints of closed structures (eqs. 14–16): `h(q)`, `J = dh/dq` and `A = J' q'`.
//!
//! Rows follow the declaration order of
//! [`Model::constraints`](crate::model::types::Model::constraints) and, within a constraint,
//! its listed ground components:
//!
//! ```text
//! Loop:   h = (x_b - x_a)[c]          J = (J_b - J_a)[c]    A = (a_b - a_a)[c]
//! Fixed:  h = (x_p - position)[c]     J = J_p[c]            A = a_p[c]
//! Angle:  h = sum_k s_k q_k - offset  J = s_k at column k   A = 0
//! ```
//!
//! where `a_P` is the acceleration of point `P` computed with `q'' = 0` and no gravity
//! ([`NumericModel::point_bias`]), and for an angle constraint the sum runs over the revolute
//! joints on the path between the two bodies: `s_k = +1` for joints on `b`'s side of their
//! common ancestor, `-1` on `a`'s side.

use nalgebra::{DMatrix, DVector, Vector3};

use super::kinematics::{Frames, Motion, point_acceleration};
use super::{NConstraint, NumericModel};

impl NumericModel {
    /// Ground position of a named point from precomputed frames.
    fn point_at(&self, fr: &Frames, point: usize) -> Vector3<f64> {
        let p = self.points[point];
        fr.point(p.body, &p.local)
    }

    /// Acceleration (with `q'' = 0`, no gravity) of a named point from precomputed motion.
    fn point_bias_at(&self, fr: &Frames, motion: &[Motion], point: usize) -> Vector3<f64> {
        let p = self.points[point];
        let x = fr.point(p.body, &p.local);
        point_acceleration(fr, motion, p.body, &x, &Vector3::zeros())
    }

    /// The constraint functions `h(q)` (eq. 14), one row per constrained component, in
    /// declaration order.
    ///
    /// `q` must have [`NumericModel::dof`] entries.
    pub fn constraints(&self, q: &[f64]) -> DVector<f64> {
        let fr = self.frames(q);
        let mut h = DVector::zeros(self.constraint_rows);
        let mut row = 0;
        for c in &self.constraints {
            match c {
                NConstraint::Loop { a, b, components } => {
                    let d = self.point_at(&fr, *b) - self.point_at(&fr, *a);
                    for &k in components {
                        h[row] = d[k];
                        row += 1;
                    }
                }
                NConstraint::Fixed {
                    point,
                    position,
                    components,
                } => {
                    let d = self.point_at(&fr, *point) - position;
                    for &k in components {
                        h[row] = d[k];
                        row += 1;
                    }
                }
                NConstraint::Angle { terms, offset } => {
                    h[row] = terms.iter().map(|&(j, s)| s * q[j]).sum::<f64>() - offset;
                    row += 1;
                }
            }
        }
        h
    }

    /// The constraint Jacobian `J = dh/dq` (eq. 15), `constraint_rows x dof`, assembled from
    /// the analytic point Jacobians.
    ///
    /// `q` must have [`NumericModel::dof`] entries.
    pub fn constraint_jacobian(&self, q: &[f64]) -> DMatrix<f64> {
        let fr = self.frames(q);
        let mut jac = DMatrix::zeros(self.constraint_rows, self.dof());
        let mut row = 0;
        for c in &self.constraints {
            match c {
                NConstraint::Loop { a, b, components } => {
                    for (p, s) in [(*b, 1.0), (*a, -1.0)] {
                        let body = self.points[p].body;
                        let x = self.point_at(&fr, p);
                        self.add_point_jacobian(&fr, body, &x, s, components, row, &mut jac);
                    }
                    row += components.len();
                }
                NConstraint::Fixed {
                    point, components, ..
                } => {
                    let body = self.points[*point].body;
                    let x = self.point_at(&fr, *point);
                    self.add_point_jacobian(&fr, body, &x, 1.0, components, row, &mut jac);
                    row += components.len();
                }
                NConstraint::Angle { terms, .. } => {
                    for &(j, s) in terms {
                        jac[(row, j)] += s;
                    }
                    row += 1;
                }
            }
        }
        jac
    }

    /// The constraint bias `A = J' q'` (eq. 16): the second time derivative of `h` computed
    /// with `q'' = 0`, from the point accelerations of the velocity recursion (no finite
    /// differences); zero for angle constraints, which are linear in `q`.
    ///
    /// `q` and `qd` must have [`NumericModel::dof`] entries.
    pub fn constraint_bias(&self, q: &[f64], qd: &[f64]) -> DVector<f64> {
        let fr = self.frames(q);
        let motion = self.motion(&fr, qd, None, &Vector3::zeros());
        let mut a = DVector::zeros(self.constraint_rows);
        let mut row = 0;
        for c in &self.constraints {
            match c {
                NConstraint::Loop {
                    a: pa,
                    b: pb,
                    components,
                } => {
                    let d = self.point_bias_at(&fr, &motion, *pb)
                        - self.point_bias_at(&fr, &motion, *pa);
                    for &k in components {
                        a[row] = d[k];
                        row += 1;
                    }
                }
                NConstraint::Fixed {
                    point, components, ..
                } => {
                    let d = self.point_bias_at(&fr, &motion, *point);
                    for &k in components {
                        a[row] = d[k];
                        row += 1;
                    }
                }
                NConstraint::Angle { .. } => row += 1,
            }
        }
        a
    }
}
