//! The fixed-size trait that generated code implements.
//!
//! Sizes are const generics — `N` joint coordinates, `NC` constraint rows — so every output is
//! a caller-owned fixed-size array: evaluations allocate nothing and cannot index out of
//! bounds. The equations follow the paper's convention `M q'' + F + Q + J^T lambda = 0`
//! (eqs. 10 and 17).

use crate::model::CoordinateUnit;

/// Position, Jacobian and bias of a named point (eqs. 49–50).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointKinematics<const N: usize> {
    /// Position in the ground frame.
    pub p: [f64; 3],
    /// Jacobian `dp/dq` (3 rows of `N`).
    pub j: [[f64; N]; 3],
    /// Bias `J' q'` (the point's acceleration when `q'' = 0`).
    pub a: [f64; 3],
}

impl<const N: usize> Default for PointKinematics<N> {
    fn default() -> Self {
        PointKinematics {
            p: [0.0; 3],
            j: [[0.0; N]; 3],
            a: [0.0; 3],
        }
    }
}

/// All equations of a mechanism at one state: `M^b`, `F^b`, `Q^b` (eqs. 11–13) and `h`, `J`,
/// `A` (eqs. 14–16).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evaluation<const N: usize, const NC: usize> {
    /// `M^b(q)`.
    pub mass: [[f64; N]; N],
    /// `F^b(q, q')`.
    pub f: [f64; N],
    /// `Q^b(q, q', t)`.
    pub q: [f64; N],
    /// `h(q)`.
    pub h: [f64; NC],
    /// `J(q)`.
    pub j: [[f64; N]; NC],
    /// `A(q, q')`.
    pub a: [f64; NC],
}

impl<const N: usize, const NC: usize> Default for Evaluation<N, NC> {
    fn default() -> Self {
        Evaluation {
            mass: [[0.0; N]; N],
            f: [0.0; N],
            q: [0.0; N],
            h: [0.0; NC],
            j: [[0.0; N]; NC],
            a: [0.0; NC],
        }
    }
}

/// The equations of a mechanism with `N` coordinates and `NC` constraint rows.
pub trait Mechanism<const N: usize, const NC: usize> {
    /// Whether the model has force elements (`[[forces]]`); without them
    /// [`Mechanism::element_power`] is zero at every state.
    const FORCE_ELEMENTS: bool = true;

    /// Names of the run-time parameters, in the model's order.
    fn param_names(&self) -> &[&'static str];

    /// Sets a run-time parameter by name; `false` when there is no such parameter.
    fn set_param(&mut self, name: &str, value: f64) -> bool;

    /// Names of the named points, in the model's order.
    fn point_names(&self) -> &[&'static str];

    /// What each coordinate measures (angle or length, from its joint type), in
    /// coordinate order.
    fn coordinate_units(&self) -> &[CoordinateUnit];

    /// `M^b(q)` (eq. 11).
    fn mass_matrix(&self, q: &[f64; N], m: &mut [[f64; N]; N]);

    /// `F^b(q, q')`: velocity terms and gravity (eq. 12).
    fn f_vector(&self, q: &[f64; N], qd: &[f64; N], f: &mut [f64; N]);

    /// `Q^b(q, q', t)`: force elements, paper sign (eq. 13).
    fn q_vector(&self, q: &[f64; N], qd: &[f64; N], t: f64, out: &mut [f64; N]);

    /// `h(q)` (eq. 14).
    fn constraints(&self, q: &[f64; N], h: &mut [f64; NC]);

    /// `J(q) = dh/dq` (eq. 15).
    fn constraint_jacobian(&self, q: &[f64; N], j: &mut [[f64; N]; NC]);

    /// `A(q, q') = J' q'` (eq. 16).
    fn constraint_bias(&self, q: &[f64; N], qd: &[f64; N], a: &mut [f64; NC]);

    /// Potential energy `V(q)`: gravity and the springs of the force elements (the gravity
    /// part of `F^b` and the spring part of `Q^b` are its gradient).
    fn potential_energy(&self, q: &[f64; N]) -> f64;

    /// `G(q) = dF^b/dg` (`g[j][k] = dF^b_j/dg_k`): see
    /// [`super::System::gravity_load_jacobian`].
    fn gravity_load_jacobian(&self, q: &[f64; N], g: &mut [[f64; 3]; N]);

    /// `[D, P]`: the dissipation power and the input power of the force elements at
    /// `(q, q')` (see [`super::System::element_power`]; docs/theory.md section 8).
    fn element_power(&self, q: &[f64; N], qd: &[f64; N]) -> [f64; 2];

    /// `M^b`, `F^b`, `Q^b`, `h`, `J` and `A` at once. The default calls the separate
    /// methods; generated code overrides it with one fused body in which every intermediate
    /// (trigonometric leaves, rotation products) is computed once. Results are bit-identical
    /// to the separate methods'.
    fn evaluate(&self, q: &[f64; N], qd: &[f64; N], t: f64, out: &mut Evaluation<N, NC>) {
        self.mass_matrix(q, &mut out.mass);
        self.f_vector(q, qd, &mut out.f);
        self.q_vector(q, qd, t, &mut out.q);
        self.constraints(q, &mut out.h);
        self.constraint_jacobian(q, &mut out.j);
        self.constraint_bias(q, qd, &mut out.a);
    }

    /// `M^b`, `F^b`, `Q^b`, `h`, `J`, `A` (eqs. 11–16) and the kinematics of every named
    /// point (eqs. 49–50; `points[k]` for [`Mechanism::point_names`]`[k]`) at once. `false`,
    /// with nothing written, when `points` does not hold exactly one entry per named point.
    /// The default calls [`Mechanism::evaluate`] and [`Mechanism::point_kinematics`];
    /// generated code overrides it with one fused body in which the trigonometric leaves and
    /// rotation products are shared between the dynamics and the points. Results are
    /// bit-identical to the separate methods'.
    fn evaluate_with_points(
        &self,
        q: &[f64; N],
        qd: &[f64; N],
        t: f64,
        out: &mut Evaluation<N, NC>,
        points: &mut [PointKinematics<N>],
    ) -> bool {
        if points.len() != self.point_names().len() {
            return false;
        }
        self.evaluate(q, qd, t, out);
        for (k, p) in points.iter_mut().enumerate() {
            self.point_kinematics(k, q, qd, p);
        }
        true
    }

    /// Kinematics of point `k` (index into [`Mechanism::point_names`]); `false` when there is
    /// no such point (the output is then left unchanged).
    fn point_kinematics(
        &self,
        k: usize,
        q: &[f64; N],
        qd: &[f64; N],
        out: &mut PointKinematics<N>,
    ) -> bool;

    /// Position `p` and Jacobian `j = dp/dq` of point `k` (eq. 49) without the bias: the
    /// `p` and `j` of [`Mechanism::point_kinematics`] (which do not depend on `q'`);
    /// `false` when there is no such point (the outputs are then left unchanged). The
    /// default calls [`Mechanism::point_kinematics`] with `q' = 0`; generated code
    /// overrides it with a body computing only `p` and `j` (bit-identical, the bias's
    /// operations left out).
    fn point_position(
        &self,
        k: usize,
        q: &[f64; N],
        p: &mut [f64; 3],
        j: &mut [[f64; N]; 3],
    ) -> bool {
        let mut pk = PointKinematics::<N>::default();
        if !self.point_kinematics(k, q, &[0.0; N], &mut pk) {
            return false;
        }
        *p = pk.p;
        *j = pk.j;
        true
    }
}
