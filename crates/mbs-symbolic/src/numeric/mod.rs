//! Independent numeric reference implementation of the tree dynamics (eqs. 1–17).
//!
//! Everything here is computed with `f64` and nalgebra in the **ground frame**, in a
//! formulation deliberately different from the symbolic recursive Newton–Euler of the
//! `dynamics` module, so that the two can be compared:
//!
//! - forward kinematics (eq. 1): orientation `T^i`, body-frame origin `x_Oi` and centre of
//!   mass `x^i` of every body, ground-frame joint axes `e_i`;
//! - velocities and "remainder" accelerations (eqs. 2–3) by a ground-frame recursion;
//! - geometric Jacobians of points and bodies, column `j` built directly from the joint axis:
//!   revolute `(e_j x (p - x_Oj), e_j)`, prismatic `(e_j, 0)`;
//! - mass matrix (eq. 11) from the body Jacobians (virtual work / Kane form),
//!
//!   ```text
//!   M = sum_i ( m_i Jv_i^T Jv_i + Jw_i^T I_i^g Jw_i ),      I_i^g = T^i I_i T^i^T
//!   ```
//!
//! - `F` (eq. 12) projected the same way from the accelerations computed with `q'' = 0` and a
//!   base acceleration `-g` (gravity),
//!
//!   ```text
//!   F = sum_i ( Jv_i^T m_i a_i^R + Jw_i^T ( I_i^g alpha_i^R + w_i x I_i^g w_i ) );
//!   ```
//!
//! - `Q` (eq. 13) as minus the generalised applied force, `Q = -sum (Jv_p^T f + Jw^T t)`;
//! - [`NumericModel::inverse_dynamics`] by a *separate* ground-frame recursive Newton–Euler
//!   (forward pass for accelerations, backward pass accumulating joint wrenches about each
//!   joint origin, projection on the joint axis), so that `M q'' + F` is cross-checked
//!   against a second formulation in the tests;
//! - constraints (eqs. 14–16) from point positions, point Jacobians and point accelerations
//!   computed with `q'' = 0` (no finite differences anywhere).
//!
//! The sign convention is the paper's (eq. 10, docs/theory.md section 2):
//! `M q'' + F + Q = 0`, gravity in `F`, `Q = -(generalised applied force)`, and with
//! constraints `M q'' + F + Q + J^T lambda = 0` (eq. 17).
//!
//! This is a reference, not a hot path: the functions allocate their results.

use nalgebra::{Matrix3, Vector3};

use crate::model::types::{Axis, Constraint, ForceElement, JointKind, Model, Scalar};

mod constraints;
mod dynamics;
mod joint;
mod kinematics;
pub use joint::rot;
use joint::unit;

pub use kinematics::BodyState;

/// A body with every [`Scalar`] evaluated.
#[derive(Clone, Debug)]
struct NBody {
    /// Parent body, `None` for ground.
    parent: Option<usize>,
    /// Revolute or prismatic.
    kind: JointKind,
    /// Joint axis, in the joint frame.
    axis: Axis,
    /// Joint anchor `a_i` in the parent frame.
    anchor: Vector3<f64>,
    /// Constant joint rotation `R0_i` relative to the parent frame.
    r0: Matrix3<f64>,
    /// Mass `m_i`.
    mass: f64,
    /// Centre of mass in the body frame.
    com: Vector3<f64>,
    /// Inertia tensor about the centre of mass, body axes.
    inertia: Matrix3<f64>,
}

/// A named point with its position evaluated.
#[derive(Clone, Copy, Debug)]
struct NPoint {
    /// Body, `None` for ground.
    body: Option<usize>,
    /// Position in the body frame (ground frame for ground points).
    local: Vector3<f64>,
}

/// A force element with every [`Scalar`] evaluated.
#[derive(Clone, Debug)]
enum NForce {
    /// [`ForceElement::Joint`].
    Joint {
        body: usize,
        stiffness: f64,
        damping: f64,
        rest: f64,
        constant: f64,
    },
    /// [`ForceElement::PointSpring`].
    PointSpring {
        a: usize,
        b: usize,
        stiffness: f64,
        damping: f64,
        rest_length: f64,
    },
    /// [`ForceElement::External`].
    External {
        body: usize,
        point: Vector3<f64>,
        force: Vector3<f64>,
        torque: Vector3<f64>,
        in_body_frame: bool,
    },
}

/// A constraint with every [`Scalar`] evaluated.
#[derive(Clone, Debug)]
enum NConstraint {
    /// [`Constraint::Loop`]: rows `(p_b - p_a)[c]`.
    Loop {
        a: usize,
        b: usize,
        components: Vec<usize>,
    },
    /// [`Constraint::Fixed`]: rows `(p - position)[c]`.
    Fixed {
        point: usize,
        position: Vector3<f64>,
        components: Vec<usize>,
    },
    /// [`Constraint::Angle`]: `h = sum_k sign_k q_k - offset` over the revolute joints of the
    /// path between the two bodies.
    Angle {
        terms: Vec<(usize, f64)>,
        offset: f64,
    },
}

/// A [`Model`] with all parameter expressions evaluated: the numeric reference for
/// `M^b` (eq. 11), `F^b` (eq. 12), `Q^b` (eq. 13), `h`, `J`, `A` (eqs. 14–16), point
/// kinematics and energies.
///
/// Every method taking joint coordinates `q`, velocities `qd` or accelerations `qdd`
/// requires slices of length [`NumericModel::dof`] and panics with a clear message
/// otherwise; point indices must be valid indices into [`Model::points`].
#[derive(Clone, Debug)]
pub struct NumericModel {
    bodies: Vec<NBody>,
    /// `paths[i]`: the joints on the reference chain of body `i` (its ancestors and `i`
    /// itself), in increasing order.
    paths: Vec<Vec<usize>>,
    gravity: Vector3<f64>,
    points: Vec<NPoint>,
    forces: Vec<NForce>,
    constraints: Vec<NConstraint>,
    constraint_rows: usize,
}

fn eval3(s: &[Scalar; 3], params: &[f64]) -> Vector3<f64> {
    Vector3::new(s[0].eval(params), s[1].eval(params), s[2].eval(params))
}

impl NumericModel {
    /// Builds the numeric model, evaluating every parameter expression of `model` once with
    /// the given parameter values (indexed like [`Model::parameters`]; use
    /// [`Model::default_params`] for the defaults).
    ///
    /// # Panics
    ///
    /// If `params.len() != model.parameters.len()`, or if the model breaks the invariants
    /// that validation guarantees (a parent index not smaller than its child, an index of a
    /// body or point out of range).
    pub fn new(model: &Model, params: &[f64]) -> Self {
        assert_eq!(
            params.len(),
            model.parameters.len(),
            "NumericModel::new: {} parameter values given, the model declares {}",
            params.len(),
            model.parameters.len()
        );
        let n = model.bodies.len();
        let mut bodies = Vec::with_capacity(n);
        let mut paths: Vec<Vec<usize>> = Vec::with_capacity(n);
        for (i, b) in model.bodies.iter().enumerate() {
            if let Some(p) = b.parent {
                assert!(
                    p < i,
                    "NumericModel::new: body `{}` (index {i}) has parent index {p}; parents \
                     must come first",
                    b.name
                );
            }
            let mut r0 = Matrix3::identity();
            for (ax, th) in &b.joint.rotation {
                r0 *= rot(*ax, th.eval(params));
            }
            let mut inertia = Matrix3::zeros();
            for r in 0..3 {
                for c in 0..3 {
                    inertia[(r, c)] = b.inertia[r][c].eval(params);
                }
            }
            bodies.push(NBody {
                parent: b.parent,
                kind: b.joint.kind,
                axis: b.joint.axis,
                anchor: eval3(&b.joint.anchor, params),
                r0,
                mass: b.mass.eval(params),
                com: eval3(&b.com, params),
                inertia,
            });
            let mut path = match b.parent {
                Some(p) => paths[p].clone(),
                None => Vec::new(),
            };
            path.push(i);
            paths.push(path);
        }
        let check_body = |i: usize, what: &str| {
            assert!(
                i < n,
                "NumericModel::new: {what} refers to body index {i} of {n}"
            );
        };
        let points: Vec<NPoint> = model
            .points
            .iter()
            .map(|p| {
                if let Some(b) = p.body {
                    check_body(b, &format!("point `{}`", p.name));
                }
                NPoint {
                    body: p.body,
                    local: eval3(&p.position, params),
                }
            })
            .collect();
        let np = points.len();
        let check_point = |i: usize, what: &str| {
            assert!(
                i < np,
                "NumericModel::new: {what} refers to point index {i} of {np}"
            );
        };
        let forces = model
            .forces
            .iter()
            .map(|f| match f {
                ForceElement::Joint {
                    name,
                    body,
                    stiffness,
                    damping,
                    rest,
                    constant,
                } => {
                    check_body(*body, &format!("force element `{name}`"));
                    NForce::Joint {
                        body: *body,
                        stiffness: stiffness.eval(params),
                        damping: damping.eval(params),
                        rest: rest.eval(params),
                        constant: constant.eval(params),
                    }
                }
                ForceElement::PointSpring {
                    name,
                    a,
                    b,
                    stiffness,
                    damping,
                    rest_length,
                } => {
                    check_point(*a, &format!("force element `{name}`"));
                    check_point(*b, &format!("force element `{name}`"));
                    NForce::PointSpring {
                        a: *a,
                        b: *b,
                        stiffness: stiffness.eval(params),
                        damping: damping.eval(params),
                        rest_length: rest_length.eval(params),
                    }
                }
                ForceElement::External {
                    name,
                    body,
                    point,
                    force,
                    torque,
                    in_body_frame,
                } => {
                    check_body(*body, &format!("force element `{name}`"));
                    NForce::External {
                        body: *body,
                        point: eval3(point, params),
                        force: eval3(force, params),
                        torque: eval3(torque, params),
                        in_body_frame: *in_body_frame,
                    }
                }
            })
            .collect();
        let constraints = model
            .constraints
            .iter()
            .map(|c| match c {
                Constraint::Loop {
                    name,
                    a,
                    b,
                    components,
                } => {
                    check_point(*a, &format!("constraint `{name}`"));
                    check_point(*b, &format!("constraint `{name}`"));
                    NConstraint::Loop {
                        a: *a,
                        b: *b,
                        components: components.iter().map(|c| c.index()).collect(),
                    }
                }
                Constraint::Fixed {
                    name,
                    point,
                    position,
                    components,
                } => {
                    check_point(*point, &format!("constraint `{name}`"));
                    NConstraint::Fixed {
                        point: *point,
                        position: eval3(position, params),
                        components: components.iter().map(|c| c.index()).collect(),
                    }
                }
                Constraint::Angle {
                    name, a, b, offset, ..
                } => {
                    let empty = Vec::new();
                    let path_of = |x: &Option<usize>| match x {
                        Some(i) => {
                            check_body(*i, &format!("constraint `{name}`"));
                            &paths[*i]
                        }
                        None => &empty,
                    };
                    let (pa, pb) = (path_of(a), path_of(b));
                    // Joints on b's side of the common ancestor count +, on a's side -.
                    let mut terms = Vec::new();
                    for &j in pb.iter().filter(|j| !pa.contains(j)) {
                        if joint::is_rotation(bodies[j].kind) {
                            terms.push((j, 1.0));
                        }
                    }
                    for &j in pa.iter().filter(|j| !pb.contains(j)) {
                        if joint::is_rotation(bodies[j].kind) {
                            terms.push((j, -1.0));
                        }
                    }
                    terms.sort_by_key(|t| t.0);
                    NConstraint::Angle {
                        terms,
                        offset: offset.eval(params),
                    }
                }
            })
            .collect();
        NumericModel {
            bodies,
            paths,
            gravity: eval3(&model.gravity, params),
            points,
            forces,
            constraints,
            constraint_rows: model.constraint_rows(),
        }
    }

    /// [`NumericModel::new`] with the model's default parameter values.
    pub fn with_default_params(model: &Model) -> Self {
        Self::new(model, &model.default_params())
    }

    /// Number of joint coordinates (one per body).
    pub fn dof(&self) -> usize {
        self.bodies.len()
    }

    /// Number of named points.
    pub fn point_count(&self) -> usize {
        self.points.len()
    }

    /// Total number of constraint rows, the length of `h` (eq. 14).
    pub fn constraint_rows(&self) -> usize {
        self.constraint_rows
    }

    /// The gravity vector in the ground frame (evaluated).
    pub fn gravity(&self) -> Vector3<f64> {
        self.gravity
    }

    /// Asserts that a state slice has one entry per coordinate.
    fn check_len(&self, v: &[f64], what: &str) {
        assert_eq!(
            v.len(),
            self.dof(),
            "NumericModel: `{what}` has {} entries, the model has {} coordinates",
            v.len(),
            self.dof()
        );
    }

    /// Asserts that a point index is valid.
    fn check_point(&self, point: usize) {
        assert!(
            point < self.points.len(),
            "NumericModel: point index {point} out of range (the model has {} points)",
            self.points.len()
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::types::{Body, Joint, Parameter, Point, SourceInfo};

    fn num(v: f64) -> Scalar {
        Scalar::Num(v)
    }

    /// A point mass `m` on a massless rod of length `l` (revolute about z at the origin,
    /// angle from the x axis), gravity `-g` along y, with a named point at the mass.
    fn pendulum(m: f64, l: f64, g: f64) -> Model {
        let zero = || [Scalar::ZERO, Scalar::ZERO, Scalar::ZERO];
        Model {
            name: "pendulum".into(),
            source: SourceInfo {
                path: "<test>".into(),
                hash: "0000000000000000".into(),
            },
            parameters: vec![Parameter {
                name: "l".into(),
                value: l,
                runtime: false,
                derived: false,
            }],
            gravity: [num(0.0), num(-g), num(0.0)],
            bodies: vec![Body {
                name: "rod".into(),
                coordinate: "rod".into(),
                parent: None,
                joint: Joint {
                    kind: JointKind::Revolute,
                    axis: Axis::Z,
                    anchor: zero(),
                    rotation: vec![],
                },
                mass: num(m),
                com: [Scalar::Param(0), num(0.0), num(0.0)],
                inertia: std::array::from_fn(|_| std::array::from_fn(|_| Scalar::ZERO)),
            }],
            points: vec![Point {
                name: "tip".into(),
                body: Some(0),
                position: [Scalar::Param(0), num(0.0), num(0.0)],
            }],
            forces: vec![],
            constraints: vec![Constraint::Angle {
                name: "angle".into(),
                a: None,
                b: Some(0),
                axis: Axis::Z,
                offset: num(0.25),
            }],
        }
    }

    #[test]
    fn rot_follows_the_model_convention() {
        let half_pi = std::f64::consts::FRAC_PI_2;
        // Active rotations: Rot(z, pi/2) turns x into y, Rot(x, pi/2) y into z,
        // Rot(y, pi/2) z into x.
        let cases = [
            (Axis::Z, Vector3::x(), Vector3::y()),
            (Axis::X, Vector3::y(), Vector3::z()),
            (Axis::Y, Vector3::z(), Vector3::x()),
        ];
        for (axis, from, to) in cases {
            let r = rot(axis, half_pi);
            assert!((r * from - to).norm() < 1e-15);
            assert!((r * r.transpose() - Matrix3::identity()).norm() < 1e-15);
            assert!((r.determinant() - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn point_mass_pendulum() {
        let (m, l, g) = (2.0, 0.7, 9.81);
        let nm = NumericModel::with_default_params(&pendulum(m, l, g));
        let (q, qd) = ([0.3], [1.7]);
        assert!((nm.mass_matrix(&q)[(0, 0)] - m * l * l).abs() < 1e-14);
        // F = dV/dq = m g l cos q; no velocity term for one degree of freedom.
        assert!((nm.f_vector(&q, &qd)[0] - m * g * l * q[0].cos()).abs() < 1e-13);
        let tip = nm.point_position(0, &q);
        assert!((tip - Vector3::new(l * q[0].cos(), l * q[0].sin(), 0.0)).norm() < 1e-15);
        // Centripetal acceleration -l q'^2 (cos q, sin q).
        let bias = nm.point_bias(0, &q, &qd);
        assert!((bias + tip * qd[0] * qd[0]).norm() < 1e-14);
        // Angle constraint q - offset.
        assert_eq!(nm.constraints(&q)[0], 0.3 - 0.25);
        assert_eq!(nm.constraint_jacobian(&q)[(0, 0)], 1.0);
        assert_eq!(nm.constraint_bias(&q, &qd)[0], 0.0);
        // Another parameter value moves the mass.
        let nm2 = NumericModel::new(&pendulum(m, l, g), &[1.1]);
        assert!((nm2.mass_matrix(&q)[(0, 0)] - m * 1.1 * 1.1).abs() < 1e-14);
    }

    #[test]
    fn massless_tree_has_no_forward_dynamics() {
        let mut model = pendulum(2.0, 0.7, 9.81);
        model.bodies[0].mass = num(0.0);
        let nm = NumericModel::with_default_params(&model);
        assert!(nm.try_forward_dynamics(&[0.1], &[0.0], 0.0).is_none());
        assert!(nm.forward_dynamics(&[0.1], &[0.0], 0.0)[0].is_nan());
    }

    #[test]
    #[should_panic(expected = "`qd` has 2 entries, the model has 1 coordinates")]
    fn wrong_slice_length_is_reported() {
        let nm = NumericModel::with_default_params(&pendulum(2.0, 0.7, 9.81));
        nm.f_vector(&[0.0], &[0.0, 1.0]);
    }

    #[test]
    #[should_panic(expected = "1 parameter values given, the model declares 0")]
    fn wrong_parameter_count_is_reported() {
        let mut model = pendulum(2.0, 0.7, 9.81);
        model.parameters.clear();
        NumericModel::new(&model, &[1.0]);
    }
}
