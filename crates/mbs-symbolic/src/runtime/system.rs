//! The object-safe, dynamic-size mechanism interface ([`System`]) and its preallocated
//! [`Workspace`].

use std::fmt;

use nalgebra::{DMatrix, DVector, Vector3};

use crate::model::{Constraint, CoordinateUnit, Model};

/// Preallocated buffers for the evaluations of a [`System`].
///
/// Created by [`System::workspace`] with the system's sizes; each evaluation method
/// overwrites the buffers it documents and leaves the others untouched.
#[derive(Clone, Debug)]
pub struct Workspace {
    /// `M^b(q)` (eq. 11), `n x n`.
    pub m: DMatrix<f64>,
    /// `F^b(q, q')`: velocity terms and gravity (eq. 12).
    pub f: DVector<f64>,
    /// `Q^b(q, q', t)`: force elements, paper sign (eq. 13).
    pub q: DVector<f64>,
    /// `h(q)` (eq. 14), one entry per constraint row.
    pub h: DVector<f64>,
    /// `J(q) = dh/dq` (eq. 15), `rows x n`.
    pub j: DMatrix<f64>,
    /// `A(q, q') = J' q'` (eq. 16).
    pub a: DVector<f64>,
    /// Position of the point last evaluated by [`System::point_kinematics`], ground frame.
    pub point_p: Vector3<f64>,
    /// Its Jacobian `dp/dq` (eq. 49), `3 x n`.
    pub point_j: DMatrix<f64>,
    /// Its bias `J' q'` (eq. 50): the point's acceleration when `q'' = 0`.
    pub point_a: Vector3<f64>,
    /// `G(q) = dF^b/dg = -sum_i m_i J_Ci^T`, `n x 3`, written by
    /// [`System::gravity_load_jacobian`].
    pub gravity_jacobian: DMatrix<f64>,
    /// Backend scratch space (the interpreter's tape slots); length
    /// [`System::scratch_len`].
    pub scratch: Vec<f64>,
}

impl Workspace {
    /// Zeroed buffers for `n` coordinates, `rows` constraint rows and `scratch` backend slots.
    pub fn new(n: usize, rows: usize, scratch: usize) -> Workspace {
        Workspace {
            m: DMatrix::zeros(n, n),
            f: DVector::zeros(n),
            q: DVector::zeros(n),
            h: DVector::zeros(rows),
            j: DMatrix::zeros(rows, n),
            a: DVector::zeros(rows),
            point_p: Vector3::zeros(),
            point_j: DMatrix::zeros(3, n),
            point_a: Vector3::zeros(),
            gravity_jacobian: DMatrix::zeros(n, 3),
            scratch: vec![0.0; scratch],
        }
    }
}

/// A bias entry (`A = J' q'`, eqs. 16 and 50) as every backend stores it: `x + 0.0`, which
/// is `x` itself except that `-0.0` becomes `+0.0`. Every term of a bias is a product with
/// a joint rate, so at `q' = 0` it is zero exactly, but a sum of such zeros carries the
/// sign of its terms; stored this way a bias at rest is bitwise `0.0` on every backend.
#[inline]
pub(super) fn bias_entry(x: f64) -> f64 {
    x + 0.0
}

/// Stores `values` into `out` as bias entries ([`bias_entry`]).
#[inline]
pub(super) fn store_bias(values: &[f64], out: &mut [f64]) {
    for (o, v) in out.iter_mut().zip(values) {
        *o = bias_entry(*v);
    }
}

/// The power of a mechanism's force elements at one state (W), split as in
/// docs/theory.md section 8: along any motion of the tree `d(T + V)/dt = input - dissipated`,
/// `V` being [`System::potential_energy`] (gravity and springs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ElementPower {
    /// `D(q, q') >= 0` (for non-negative damping coefficients): `c q'^2` of the joint
    /// dampers and `c l'^2` of the point spring-dampers.
    pub dissipated: f64,
    /// `P(q, q')`, any sign: the power of the loads that have no potential — `f0 q'` of the
    /// constant joint forces, `f . x' + t . w` of the external forces and torques (ground-
    /// or body-frame).
    pub input: f64,
}

/// Which of the three backends implements a [`System`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Backend {
    /// Code generated from the model and compiled in ([`super::GeneratedSystem`]).
    Generated,
    /// The symbolic equations evaluated by the DAG interpreter
    /// ([`super::InterpretedSystem`]).
    Interpreted,
    /// The independent numeric recursive reference ([`super::NumericSystem`]).
    Numeric,
}

impl Backend {
    /// The short name used in reports: `"generated"`, `"interpreter"`, `"numeric"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Backend::Generated => "generated",
            Backend::Interpreted => "interpreter",
            Backend::Numeric => "numeric",
        }
    }
}

impl fmt::Display for Backend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Why a run-time parameter could not be set.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ParamError {
    /// The mechanism has no run-time parameter of that name.
    #[error("no run-time parameter `{name}` (run-time parameters: {})", list(.available))]
    Unknown {
        /// The name asked for.
        name: String,
        /// The run-time parameters there are.
        available: Vec<String>,
    },
    /// The value is not a finite number.
    #[error("parameter `{name}` = {value} is not a finite number")]
    NotFinite {
        /// The parameter.
        name: String,
        /// The value given.
        value: f64,
    },
}

fn list(names: &[String]) -> String {
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}

/// A mechanism with [`System::dof`] tree coordinates and [`System::rows`] constraint rows,
/// evaluated into caller-owned buffers (paper convention `M q'' + F + Q + J^T lambda = 0`,
/// eq. 17).
///
/// Callers pass slices of length [`System::dof`] and a workspace made by
/// [`System::workspace`]; implementations may panic otherwise (a programming error, not bad
/// input). The generated and interpreted backends allocate nothing once the workspace
/// exists; the numeric reference allocates (it is a reference, not a hot path).
pub trait System: Send + Sync {
    /// Which backend this is.
    fn backend(&self) -> Backend;

    /// Number of tree coordinates `n`.
    fn dof(&self) -> usize;

    /// Number of constraint rows (the length of `h`).
    fn rows(&self) -> usize;

    /// The names of the coordinates, constraint rows, points and run-time parameters.
    fn names(&self) -> &Names;

    /// Names of the coordinates, in the model's order.
    fn coordinate_names(&self) -> &[String] {
        &self.names().coordinates
    }

    /// What each coordinate measures (angle or length), in the model's order.
    fn coordinate_units(&self) -> &[CoordinateUnit] {
        &self.names().units
    }

    /// Names of the constraint rows (`"<constraint>.<component>"`), in the model's order.
    fn constraint_names(&self) -> &[String] {
        &self.names().constraints
    }

    /// Names of the named points, in the model's order (indices for
    /// [`System::point_kinematics`]).
    fn point_names(&self) -> &[String] {
        &self.names().points
    }

    /// Names of the run-time parameters (those [`System::set_param`] accepts), in the
    /// model's order.
    fn param_names(&self) -> &[String] {
        &self.names().params
    }

    /// Sets a run-time parameter.
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), ParamError>;

    /// Length of [`Workspace::scratch`] the backend needs.
    fn scratch_len(&self) -> usize {
        0
    }

    /// A workspace with this system's sizes.
    fn workspace(&self) -> Workspace {
        Workspace::new(self.dof(), self.rows(), self.scratch_len())
    }

    /// Fills `M`, `F`, `Q`, `h`, `J` and `A` at `(q, q', t)`.
    fn evaluate(&self, q: &[f64], qd: &[f64], t: f64, ws: &mut Workspace);

    /// Fills `h` and `J` at `q` only (position-level work: assembly, projection).
    fn evaluate_positions(&self, q: &[f64], ws: &mut Workspace);

    /// Potential energy `V(q)`: gravity and the springs of the force elements (the gravity
    /// part of `F^b` and the spring part of `Q^b` are its gradient).
    fn potential_energy(&self, q: &[f64], ws: &mut Workspace) -> f64;

    /// The dissipation and input power of the force elements at `(q, q')` (no element
    /// depends on time). With `Q_nc` the part of `Q^b` that is not the springs' gradient,
    /// `-q'^T Q_nc = input - dissipated` at every state; the generated and interpreted
    /// backends allocate nothing.
    fn element_power(&self, q: &[f64], qd: &[f64], ws: &mut Workspace) -> ElementPower;

    /// `G(q) = dF^b/dg = -sum_i m_i J_Ci^T` (ground-frame gravity components, `J_Ci` the
    /// Jacobian of body `i`'s centre of mass) into [`Workspace::gravity_jacobian`]. `F^b`
    /// is linear in gravity (the base acceleration `a_0 = -g`), so in a ground frame that
    /// accelerates by `a` the equations are the fixed-frame ones plus the inertial load
    /// `F^b += -G(q) a` (gravity `g` becomes `g - a`). The generated and interpreted
    /// backends allocate nothing.
    fn gravity_load_jacobian(&self, q: &[f64], ws: &mut Workspace);

    /// Whether the model has force elements: without them [`System::element_power`] is
    /// zero at every state, and a caller may skip it.
    fn has_force_elements(&self) -> bool {
        true
    }

    /// The dissipation power `D(q, q')` of the force elements (see
    /// [`System::element_power`]).
    fn dissipated_power(&self, q: &[f64], qd: &[f64], ws: &mut Workspace) -> f64 {
        self.element_power(q, qd, ws).dissipated
    }

    /// Kinematics of point `k` (index into [`System::point_names`]) into
    /// [`Workspace::point_p`], [`Workspace::point_j`] and [`Workspace::point_a`]; `false`
    /// (workspace unchanged) when there is no such point.
    fn point_kinematics(&self, k: usize, q: &[f64], qd: &[f64], ws: &mut Workspace) -> bool;

    /// Position and Jacobian of point `k` (eq. 49) into [`Workspace::point_p`] and
    /// [`Workspace::point_j`]: the values [`System::point_kinematics`] writes there (they do
    /// not depend on `q'`); `false` (workspace unchanged) when there is no such point.
    /// [`Workspace::point_a`] is not part of the result: the default calls
    /// [`System::point_kinematics`] with `q' = 0` (writing the bias at rest), the generated
    /// backend computes `p` and `J` alone and leaves it unchanged.
    fn point_position(&self, k: usize, q: &[f64], ws: &mut Workspace) -> bool {
        /// `q' = 0` for up to this many coordinates without allocating.
        const ZEROS: [f64; 64] = [0.0; 64];
        match ZEROS.get(..q.len()) {
            Some(zero) => self.point_kinematics(k, q, zero, ws),
            None => self.point_kinematics(k, q, &vec![0.0; q.len()], ws),
        }
    }

    /// [`System::evaluate`] and [`System::point_kinematics`] of point `k` at the same state,
    /// in one call: generated code computes them in one fused body sharing the trigonometric
    /// leaves (bit-identical to the separate calls). `false` (and only `M`, `F`, `Q`, `h`,
    /// `J`, `A` written) when there is no such point.
    fn evaluate_with_point(
        &self,
        k: usize,
        q: &[f64],
        qd: &[f64],
        t: f64,
        ws: &mut Workspace,
    ) -> bool {
        self.evaluate(q, qd, t, ws);
        self.point_kinematics(k, q, qd, ws)
    }

    /// A boxed copy (same backend, same parameter values).
    fn clone_box(&self) -> Box<dyn System>;

    /// Index of the point named `name`.
    fn point_index(&self, name: &str) -> Option<usize> {
        self.point_names().iter().position(|p| p == name)
    }

    /// Index of the coordinate named `name`.
    fn coordinate_index(&self, name: &str) -> Option<usize> {
        self.coordinate_names().iter().position(|c| c == name)
    }
}

impl Clone for Box<dyn System> {
    fn clone(&self) -> Self {
        self.clone_box()
    }
}

impl fmt::Debug for dyn System {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("System")
            .field("backend", &self.backend())
            .field("dof", &self.dof())
            .field("rows", &self.rows())
            .finish()
    }
}

/// `System` for references and boxes: every method forwards to the pointee.
macro_rules! forward_system {
    ($($ty:ty),*) => {$(
        impl<S: System + ?Sized> System for $ty {
            fn backend(&self) -> Backend {
                (**self).backend()
            }
            fn dof(&self) -> usize {
                (**self).dof()
            }
            fn rows(&self) -> usize {
                (**self).rows()
            }
            fn names(&self) -> &Names {
                (**self).names()
            }
            fn set_param(&mut self, name: &str, value: f64) -> Result<(), ParamError> {
                (**self).set_param(name, value)
            }
            fn scratch_len(&self) -> usize {
                (**self).scratch_len()
            }
            fn evaluate(&self, q: &[f64], qd: &[f64], t: f64, ws: &mut Workspace) {
                (**self).evaluate(q, qd, t, ws)
            }
            fn evaluate_positions(&self, q: &[f64], ws: &mut Workspace) {
                (**self).evaluate_positions(q, ws)
            }
            fn potential_energy(&self, q: &[f64], ws: &mut Workspace) -> f64 {
                (**self).potential_energy(q, ws)
            }
            fn element_power(&self, q: &[f64], qd: &[f64], ws: &mut Workspace) -> ElementPower {
                (**self).element_power(q, qd, ws)
            }
            fn has_force_elements(&self) -> bool {
                (**self).has_force_elements()
            }
            fn gravity_load_jacobian(&self, q: &[f64], ws: &mut Workspace) {
                (**self).gravity_load_jacobian(q, ws)
            }
            fn point_kinematics(
                &self,
                k: usize,
                q: &[f64],
                qd: &[f64],
                ws: &mut Workspace,
            ) -> bool {
                (**self).point_kinematics(k, q, qd, ws)
            }
            fn point_position(&self, k: usize, q: &[f64], ws: &mut Workspace) -> bool {
                (**self).point_position(k, q, ws)
            }
            fn clone_box(&self) -> Box<dyn System> {
                (**self).clone_box()
            }
        }
    )*};
}

forward_system!(&mut S, Box<S>);

/// Names of the coordinates of a model, in coordinate order.
pub fn coordinate_names(model: &Model) -> Vec<String> {
    model.bodies.iter().map(|b| b.coordinate.clone()).collect()
}

/// Names of the constraint rows of a model, in row order: `"<name>.<component>"` for loop
/// and fixed-point constraints, the constraint's name for an angle closure (the same names
/// as [`crate::constraints::ConstraintExprs::names`]).
pub fn constraint_row_names(model: &Model) -> Vec<String> {
    let mut out = Vec::with_capacity(model.constraint_rows());
    for c in &model.constraints {
        match c {
            Constraint::Loop {
                name, components, ..
            }
            | Constraint::Fixed {
                name, components, ..
            } => out.extend(components.iter().map(|ax| format!("{name}.{ax}"))),
            Constraint::Angle { name, .. } => out.push(name.clone()),
        }
    }
    out
}

/// Names and model indices of the run-time parameters of a model (derived parameters
/// cannot be set on their own).
fn runtime_params(model: &Model) -> (Vec<String>, Vec<usize>) {
    model
        .parameters
        .iter()
        .enumerate()
        .filter(|(_, p)| p.runtime && !p.derived)
        .map(|(k, p)| (p.name.clone(), k))
        .unzip()
}

/// The names of a mechanism's coordinates, constraint rows, points and run-time
/// parameters (each in the model's order), owned by every backend.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Names {
    /// Coordinates.
    pub coordinates: Vec<String>,
    /// Constraint rows.
    pub constraints: Vec<String>,
    /// Named points.
    pub points: Vec<String>,
    /// Run-time parameters.
    pub params: Vec<String>,
    /// What each coordinate measures (angle or length, from its joint type), in
    /// coordinate order: the units of the coordinate's columns and generalised force.
    pub units: Vec<CoordinateUnit>,
}

impl Names {
    /// The names of `model`, with the model indices of its run-time parameters (in the
    /// order of [`Names::params`]).
    pub fn of(model: &Model) -> (Names, Vec<usize>) {
        let (params, param_index) = runtime_params(model);
        let names = Names {
            coordinates: coordinate_names(model),
            constraints: constraint_row_names(model),
            points: model.points.iter().map(|p| p.name.clone()).collect(),
            params,
            units: model
                .bodies
                .iter()
                .map(|b| b.joint.kind.coordinate_unit())
                .collect(),
        };
        (names, param_index)
    }

    /// The position of run-time parameter `name` in [`Names::params`], after checking that
    /// `value` is finite.
    pub fn param(&self, name: &str, value: f64) -> Result<usize, ParamError> {
        let Some(k) = self.params.iter().position(|n| n == name) else {
            return Err(ParamError::Unknown {
                name: name.to_string(),
                available: self.params.clone(),
            });
        };
        if !value.is_finite() {
            return Err(ParamError::NotFinite {
                name: name.to_string(),
                value,
            });
        }
        Ok(k)
    }
}
