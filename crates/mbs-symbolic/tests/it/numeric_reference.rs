//! Tests of the numeric reference implementation (`mbs_symbolic::numeric`) against closed
//! forms, invariants (docs/theory.md section 8) and finite differences, on hand-built models and
//! on the deterministic random models of `common`.

use crate::common;

use common::{RandomOpts, random_model, random_state};
use mbs_symbolic::model::types::{
    Axis, BinOp, Body, Constraint, ForceElement, Joint, JointKind, Model, Parameter, Scalar,
    SourceInfo,
};
use mbs_symbolic::numeric::{NumericModel, rot};
use nalgebra::{DMatrix, DVector, Vector3};

// ---------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------

fn num(v: f64) -> Scalar {
    Scalar::Num(v)
}

fn zero3() -> [Scalar; 3] {
    [Scalar::ZERO, Scalar::ZERO, Scalar::ZERO]
}

fn diag(a: f64, b: f64, c: f64) -> [[Scalar; 3]; 3] {
    [
        [num(a), num(0.0), num(0.0)],
        [num(0.0), num(b), num(0.0)],
        [num(0.0), num(0.0), num(c)],
    ]
}

fn body(
    name: &str,
    parent: Option<usize>,
    kind: JointKind,
    axis: Axis,
    anchor: [Scalar; 3],
    rotation: Vec<(Axis, Scalar)>,
    mass: Scalar,
    com: [Scalar; 3],
    inertia: [[Scalar; 3]; 3],
) -> Body {
    Body {
        name: name.into(),
        coordinate: name.into(),
        parent,
        joint: Joint {
            kind,
            axis,
            anchor,
            rotation,
        },
        mass,
        com,
        inertia,
    }
}

fn model(name: &str, parameters: Vec<Parameter>, gravity: [f64; 3], bodies: Vec<Body>) -> Model {
    Model {
        name: name.into(),
        source: SourceInfo {
            path: "<test>".into(),
            hash: "0000000000000000".into(),
        },
        parameters,
        gravity: gravity.map(num),
        bodies,
        points: Vec::new(),
        forces: Vec::new(),
        constraints: Vec::new(),
    }
}

/// `|a - b| <= tol * max(|b|, floor)` in the max norm.
fn assert_close_vec(what: &str, a: &DVector<f64>, b: &DVector<f64>, tol: f64, floor: f64) {
    assert_eq!(a.len(), b.len(), "{what}: lengths differ");
    let err = (a - b).amax();
    let scale = b.amax().max(floor);
    assert!(
        err <= tol * scale,
        "{what}: error {err:e} > {tol:e} * {scale:e}\n got {a}\n expected {b}"
    );
}

fn assert_close_mat(what: &str, a: &DMatrix<f64>, b: &DMatrix<f64>, tol: f64, floor: f64) {
    assert_eq!(a.shape(), b.shape(), "{what}: shapes differ");
    let err = (a - b).amax();
    let scale = b.amax().max(floor);
    assert!(
        err <= tol * scale,
        "{what}: error {err:e} > {tol:e} * {scale:e}\n got {a}\n expected {b}"
    );
}

/// Option sets used by the property loops: spatial/planar, chains/trees, with and without
/// prismatic joints.
fn option_sets(force_elements: bool) -> Vec<RandomOpts> {
    let mut out = Vec::new();
    for (bodies, planar, prismatic, branching) in [
        (1, false, false, false),
        (2, true, false, false),
        (3, true, true, true),
        (4, false, true, true),
        (5, false, false, false),
        (6, false, true, true),
        (7, true, true, false),
    ] {
        out.push(RandomOpts {
            bodies,
            planar,
            prismatic,
            branching,
            gravity: true,
            force_elements,
            runtime_params: bodies % 2 == 0,
        });
    }
    out
}

/// `(seed, model)` pairs for the property loops.
fn random_models(force_elements: bool, seeds: u64) -> Vec<(u64, Model)> {
    let mut out = Vec::new();
    for opts in option_sets(force_elements) {
        for seed in 0..seeds {
            let seed = seed * 7919 + opts.bodies as u64;
            out.push((seed, random_model(seed, &opts)));
        }
    }
    out
}

/// The model with its dissipative and non-potential force elements removed: no damping, no
/// constant joint force, no external force.
fn conservative(m: &Model) -> Model {
    let mut m = m.clone();
    m.forces
        .retain(|f| !matches!(f, ForceElement::External { .. }));
    for f in &mut m.forces {
        match f {
            ForceElement::Joint {
                damping, constant, ..
            } => {
                *damping = Scalar::ZERO;
                *constant = Scalar::ZERO;
            }
            ForceElement::PointSpring { damping, .. } => *damping = Scalar::ZERO,
            ForceElement::External { .. } => unreachable!(),
        }
    }
    m
}

// ---------------------------------------------------------------------------------------
// Closed forms
// ---------------------------------------------------------------------------------------

/// Planar double pendulum of two uniform rods: rod 1 (length `l1`, mass `m1`) pivoted on
/// ground at the origin, rod 2 (length `l2`, mass `m2`) pivoted at the tip of rod 1; both
/// joints revolute about z, angles measured from the x axis (q2 relative to rod 1), gravity
/// `-g` along y. `l1` and `m2` are parameters.
fn double_pendulum(l1: f64, l2: f64, m1: f64, m2: f64, g: f64) -> Model {
    // I1 = m1 l1^2 / 12 through the parameter l1.
    let i1 = Scalar::Bin(
        BinOp::Mul,
        Box::new(num(m1 / 12.0)),
        Box::new(Scalar::Bin(
            BinOp::Pow,
            Box::new(Scalar::Param(0)),
            Box::new(num(2.0)),
        )),
    );
    // I2 = m2 l2^2 / 12 through the parameter m2.
    let i2 = Scalar::Bin(
        BinOp::Mul,
        Box::new(Scalar::Param(1)),
        Box::new(num(l2 * l2 / 12.0)),
    );
    let params = vec![
        Parameter {
            name: "l1".into(),
            value: l1,
            runtime: true,
            derived: false,
        },
        Parameter {
            name: "m2".into(),
            value: m2,
            runtime: false,
            derived: false,
        },
    ];
    let half_l1 = Scalar::Bin(BinOp::Div, Box::new(Scalar::Param(0)), Box::new(num(2.0)));
    let rod1 = body(
        "rod1",
        None,
        JointKind::Revolute,
        Axis::Z,
        zero3(),
        vec![],
        num(m1),
        [half_l1, num(0.0), num(0.0)],
        [
            [num(0.0), num(0.0), num(0.0)],
            [num(0.0), i1.clone(), num(0.0)],
            [num(0.0), num(0.0), i1],
        ],
    );
    let rod2 = body(
        "rod2",
        Some(0),
        JointKind::Revolute,
        Axis::Z,
        [Scalar::Param(0), num(0.0), num(0.0)],
        vec![],
        Scalar::Param(1),
        [num(l2 / 2.0), num(0.0), num(0.0)],
        [
            [num(0.0), num(0.0), num(0.0)],
            [num(0.0), i2.clone(), num(0.0)],
            [num(0.0), num(0.0), i2],
        ],
    );
    model("double_pendulum", params, [0.0, -g, 0.0], vec![rod1, rod2])
}

/// Textbook `M` and `F` of the double pendulum (Lagrange), `c_i = l_i / 2`, `I_i` about the
/// centre of mass.
fn double_pendulum_closed_form(
    (l1, l2, m1, m2, g): (f64, f64, f64, f64, f64),
    q: &[f64],
    qd: &[f64],
) -> (DMatrix<f64>, DVector<f64>) {
    let (c1, c2) = (l1 / 2.0, l2 / 2.0);
    let (i1, i2) = (m1 * l1 * l1 / 12.0, m2 * l2 * l2 / 12.0);
    let (s2, k2) = q[1].sin_cos();
    let m11 = i1 + i2 + m1 * c1 * c1 + m2 * (l1 * l1 + c2 * c2 + 2.0 * l1 * c2 * k2);
    let m12 = i2 + m2 * (c2 * c2 + l1 * c2 * k2);
    let m22 = i2 + m2 * c2 * c2;
    let h = m2 * l1 * c2 * s2;
    let f1 = -h * (2.0 * qd[0] * qd[1] + qd[1] * qd[1])
        + (m1 * c1 + m2 * l1) * g * q[0].cos()
        + m2 * c2 * g * (q[0] + q[1]).cos();
    let f2 = h * qd[0] * qd[0] + m2 * c2 * g * (q[0] + q[1]).cos();
    (
        DMatrix::from_row_slice(2, 2, &[m11, m12, m12, m22]),
        DVector::from_vec(vec![f1, f2]),
    )
}

#[test]
fn double_pendulum_matches_closed_form() {
    let dims = (0.9, 0.6, 1.7, 0.8, 9.81);
    let (l1, l2, m1, m2, g) = dims;
    let m = double_pendulum(l1, l2, m1, m2, g);
    let nm = NumericModel::with_default_params(&m);
    for seed in 0..20 {
        let (q, qd, qdd) = random_state(seed, 2);
        let (mc, fc) = double_pendulum_closed_form(dims, &q, &qd);
        assert_close_mat("M", &nm.mass_matrix(&q), &mc, 1e-12, 0.0);
        assert_close_vec("F", &nm.f_vector(&q, &qd), &fc, 1e-12, 0.0);
        let id = &mc * DVector::from_column_slice(&qdd) + &fc;
        assert_close_vec(
            "M q'' + F",
            &nm.inverse_dynamics(&q, &qd, &qdd),
            &id,
            1e-12,
            0.0,
        );
        // No force elements: Q = 0 and q'' = -M^-1 F.
        assert_eq!(nm.q_vector(&q, &qd, 0.0).amax(), 0.0);
        let fd = -mc.clone().lu().solve(&fc).unwrap();
        assert_close_vec("q''", &nm.forward_dynamics(&q, &qd, 0.0), &fd, 1e-11, 1.0);
        // Energies in closed form.
        let (c1, c2) = (l1 / 2.0, l2 / 2.0);
        let v = m1 * g * c1 * q[0].sin() + m2 * g * (l1 * q[0].sin() + c2 * (q[0] + q[1]).sin());
        assert!((nm.potential_energy(&q) - v).abs() <= 1e-12 * (1.0 + v.abs()));
        let qdv = DVector::from_column_slice(&qd);
        let t = 0.5 * qdv.dot(&(&mc * &qdv));
        assert!((nm.kinetic_energy(&q, &qd) - t).abs() <= 1e-12 * t);
    }
}

#[test]
fn double_pendulum_uses_the_given_parameter_values() {
    let m = double_pendulum(0.9, 0.6, 1.7, 0.8, 9.81);
    // Same model, other values of the parameters l1 and m2.
    let nm = NumericModel::new(&m, &[1.3, 2.1]);
    let dims = (1.3, 0.6, 1.7, 2.1, 9.81);
    let (q, qd, _) = random_state(3, 2);
    let (mc, fc) = double_pendulum_closed_form(dims, &q, &qd);
    assert_close_mat("M", &nm.mass_matrix(&q), &mc, 1e-12, 0.0);
    assert_close_vec("F", &nm.f_vector(&q, &qd), &fc, 1e-12, 0.0);
}

#[test]
fn prismatic_joint_on_tilted_frame_matches_closed_form() {
    let (mass, g) = (2.3, 9.81);
    let inertia = [
        [num(0.2), num(0.01), num(-0.02)],
        [num(0.01), num(0.3), num(0.03)],
        [num(-0.02), num(0.03), num(0.25)],
    ];
    let com = [num(0.1), num(-0.2), num(0.3)];
    // Planar: slider along x of a frame turned by theta about z, gravity -g y.
    let theta = 0.4;
    let planar = model(
        "slider",
        vec![],
        [0.0, -g, 0.0],
        vec![body(
            "s",
            None,
            JointKind::Prismatic,
            Axis::X,
            [num(0.5), num(1.0), num(-0.3)],
            vec![(Axis::Z, num(theta))],
            num(mass),
            com.clone(),
            inertia.clone(),
        )],
    );
    // Spatial: slider along x of a frame turned by beta about y then gamma about z, gravity
    // -g z: the axis in ground is (cos b cos c, sin c, -sin b cos c).
    let (beta, gamma) = (0.7, -0.3);
    let spatial = model(
        "slider3d",
        vec![],
        [0.0, 0.0, -g],
        vec![body(
            "s",
            None,
            JointKind::Prismatic,
            Axis::X,
            [num(0.1), num(0.0), num(2.0)],
            vec![(Axis::Y, num(beta)), (Axis::Z, num(gamma))],
            num(mass),
            com,
            inertia,
        )],
    );
    let cases = [
        (
            planar,
            mass * g * theta.sin(),
            Vector3::new(theta.cos(), theta.sin(), 0.0),
        ),
        (
            spatial,
            -mass * g * beta.sin() * gamma.cos(),
            Vector3::new(
                beta.cos() * gamma.cos(),
                gamma.sin(),
                -beta.sin() * gamma.cos(),
            ),
        ),
    ];
    for (m, f_expected, axis) in cases {
        let mut m = m;
        let (k, c, rest, constant) = (3.0, 0.4, 0.2, -0.7);
        m.forces.push(ForceElement::Joint {
            name: "spring".into(),
            body: 0,
            stiffness: num(k),
            damping: num(c),
            rest: num(rest),
            constant: num(constant),
        });
        let nm = NumericModel::with_default_params(&m);
        for (q, qd) in [(0.0, 0.0), (0.8, -1.3), (-1.5, 2.0)] {
            let (q, qd) = ([q], [qd]);
            assert!((nm.mass_matrix(&q)[(0, 0)] - mass).abs() <= 1e-14 * mass);
            let f = nm.f_vector(&q, &qd)[0];
            assert!(
                (f - f_expected).abs() <= 1e-12 * f_expected.abs(),
                "F = {f}"
            );
            let qv = nm.q_vector(&q, &qd, 0.0)[0];
            let q_expected = k * (q[0] - rest) + c * qd[0] - constant;
            assert!((qv - q_expected).abs() <= 1e-14 * (1.0 + q_expected.abs()));
            let a = nm.forward_dynamics(&q, &qd, 0.0)[0];
            let a_expected = -(f_expected + q_expected) / mass;
            assert!((a - a_expected).abs() <= 1e-12 * a_expected.abs());
            // The body translates along the tilted axis without turning.
            let s = nm.body_kinematics(&q, &qd)[0];
            assert!((s.omega.norm()) == 0.0);
            assert!((s.com_velocity - axis * qd[0]).norm() <= 1e-14);
        }
    }
}

/// Cart on a horizontal rail (prismatic along x) carrying a pendulum (revolute about z at the
/// cart origin, centre of mass at distance c along the pendulum's x axis): Lagrange gives
/// `M = [[mc + m, -m c sin q2], [-m c sin q2, I + m c^2]]`,
/// `F = [-m c cos q2 q2'^2, m g c cos q2]`.
#[test]
fn cart_pendulum_matches_closed_form() {
    let (mc, m, c, i, g) = (3.0, 0.7, 0.45, 0.02, 9.81);
    let mdl = model(
        "cart_pendulum",
        vec![],
        [0.0, -g, 0.0],
        vec![
            body(
                "cart",
                None,
                JointKind::Prismatic,
                Axis::X,
                zero3(),
                vec![],
                num(mc),
                [num(0.3), num(-0.1), num(0.0)],
                diag(0.1, 0.1, 0.1),
            ),
            body(
                "pendulum",
                Some(0),
                JointKind::Revolute,
                Axis::Z,
                zero3(),
                vec![],
                num(m),
                [num(c), num(0.0), num(0.0)],
                diag(0.001, i, i),
            ),
        ],
    );
    let nm = NumericModel::with_default_params(&mdl);
    for seed in 0..10 {
        let (q, qd, _) = random_state(seed, 2);
        let (s2, k2) = q[1].sin_cos();
        let mm = DMatrix::from_row_slice(2, 2, &[mc + m, -m * c * s2, -m * c * s2, i + m * c * c]);
        let ff = DVector::from_vec(vec![-m * c * k2 * qd[1] * qd[1], m * g * c * k2]);
        assert_close_mat("M", &nm.mass_matrix(&q), &mm, 1e-13, 0.0);
        assert_close_vec("F", &nm.f_vector(&q, &qd), &ff, 1e-12, 1e-12);
    }
}

/// Spatial closed form in which the inertia tensor turns with the body: a yaw body (revolute
/// about ground z) carrying a pitch body (revolute about x of the yaw body) with principal
/// moments `(A, B, C)` about its centre of mass on both axes. With
/// `w_2 = (q2', q1' sin q2, q1' cos q2)` in body-2 axes, Lagrange gives
/// `M = diag(I1zz + B sin^2 q2 + C cos^2 q2, A)`,
/// `F = [2 (B - C) s c q1' q2', -(B - C) s c q1'^2]`.
#[test]
fn gimbal_matches_closed_form() {
    let (i1zz, a, b, c) = (0.3, 0.5, 0.2, 0.9);
    let mdl = model(
        "gimbal",
        vec![],
        [0.0, 0.0, -9.81],
        vec![
            body(
                "yaw",
                None,
                JointKind::Revolute,
                Axis::Z,
                [num(0.0), num(0.0), num(1.0)],
                vec![],
                num(1.5),
                zero3(),
                [
                    [num(0.4), num(0.05), num(0.07)],
                    [num(0.05), num(0.35), num(-0.02)],
                    [num(0.07), num(-0.02), num(i1zz)],
                ],
            ),
            body(
                "pitch",
                Some(0),
                JointKind::Revolute,
                Axis::X,
                zero3(),
                vec![],
                num(2.0),
                zero3(),
                diag(a, b, c),
            ),
        ],
    );
    let nm = NumericModel::with_default_params(&mdl);
    for seed in 0..10 {
        let (q, qd, _) = random_state(seed, 2);
        let (s, k) = q[1].sin_cos();
        let mm = DMatrix::from_row_slice(2, 2, &[i1zz + b * s * s + c * k * k, 0.0, 0.0, a]);
        let ff = DVector::from_vec(vec![
            2.0 * (b - c) * s * k * qd[0] * qd[1],
            -(b - c) * s * k * qd[0] * qd[0],
        ]);
        assert_close_mat("M", &nm.mass_matrix(&q), &mm, 1e-13, 0.0);
        assert_close_vec("F", &nm.f_vector(&q, &qd), &ff, 1e-12, 1e-12);
        let t = 0.5 * (a * qd[1] * qd[1] + (i1zz + b * s * s + c * k * k) * qd[0] * qd[0]);
        assert!((nm.kinetic_energy(&q, &qd) - t).abs() <= 1e-13 * t);
    }
}

// ---------------------------------------------------------------------------------------
// Invariants on random models
// ---------------------------------------------------------------------------------------

#[test]
fn mass_matrix_is_spd_and_consistent_with_energy_and_inverse_dynamics() {
    for (seed, m) in random_models(true, 6) {
        let nm = NumericModel::with_default_params(&m);
        let n = nm.dof();
        for s in 0..3 {
            let (q, qd, qdd) = random_state(seed * 31 + s, n);
            let mm = nm.mass_matrix(&q);
            assert_eq!(mm, mm.transpose(), "seed {seed}: M not symmetric");
            let eig = mm.clone().symmetric_eigen().eigenvalues;
            assert!(
                eig.min() > 0.0,
                "seed {seed}: M not positive definite: {eig}"
            );
            assert!(mm.clone().cholesky().is_some());
            // q'^T M q' = 2 T (T body by body).
            let qdv = DVector::from_column_slice(&qd);
            let two_t = qdv.dot(&(&mm * &qdv));
            let t = nm.kinetic_energy(&q, &qd);
            assert!(
                (two_t - 2.0 * t).abs() <= 1e-12 * two_t,
                "seed {seed}: q'Mq' = {two_t}, 2T = {}",
                2.0 * t
            );
            // Recursive Newton-Euler == Jacobian form: M q'' + F.
            let f = nm.f_vector(&q, &qd);
            let expected = &mm * DVector::from_column_slice(&qdd) + &f;
            let id = nm.inverse_dynamics(&q, &qd, &qdd);
            assert_close_vec(&format!("seed {seed}: RNEA"), &id, &expected, 1e-12, 1.0);
            // F alone is inverse dynamics with q'' = 0.
            let zero = vec![0.0; n];
            assert_close_vec("F", &nm.inverse_dynamics(&q, &qd, &zero), &f, 1e-12, 1.0);
            // Forward dynamics solves eq. (10).
            let a = nm.forward_dynamics(&q, &qd, 0.3);
            let res = &mm * &a + &f + nm.q_vector(&q, &qd, 0.3);
            assert!(
                res.amax() <= 1e-10 * (1.0 + f.amax()),
                "seed {seed}: residual {res}"
            );
        }
    }
}

/// `F` against the Lagrangian identity built from finite differences of `M` and `V`:
/// `F = M' q' - 1/2 d(q'^T M q')/dq + dV_gravity/dq` (no force elements, so `V` is gravity).
#[test]
fn f_vector_matches_lagrange_equations() {
    let h = 1e-5;
    for (seed, m) in random_models(false, 4) {
        let nm = NumericModel::with_default_params(&m);
        let n = nm.dof();
        let (q, qd, _) = random_state(seed + 5, n);
        let qdv = DVector::from_column_slice(&qd);
        let shifted = |s: f64, dir: &[f64]| -> Vec<f64> {
            q.iter().zip(dir).map(|(a, d)| a + s * d).collect()
        };
        // dM/dt along q'.
        let mdot =
            (nm.mass_matrix(&shifted(h, &qd)) - nm.mass_matrix(&shifted(-h, &qd))) / (2.0 * h);
        let mut expected = &mdot * &qdv;
        for k in 0..n {
            let mut e = vec![0.0; n];
            e[k] = 1.0;
            let (qp, qm) = (shifted(h, &e), shifted(-h, &e));
            let dk_t = (qdv.dot(&(nm.mass_matrix(&qp) * &qdv))
                - qdv.dot(&(nm.mass_matrix(&qm) * &qdv)))
                / (2.0 * h);
            let dk_v = (nm.potential_energy(&qp) - nm.potential_energy(&qm)) / (2.0 * h);
            expected[k] += -0.5 * dk_t + dk_v;
        }
        assert_close_vec(
            &format!("seed {seed}: F vs Lagrange"),
            &nm.f_vector(&q, &qd),
            &expected,
            1e-7,
            1.0,
        );
    }
}

/// Conservative models (gravity, joint springs, point springs) conserve `T + V` along
/// trajectories of `q'' = -M^-1 (F + Q)` (RK4, small steps).
#[test]
fn energy_is_conserved_without_dissipation() {
    let (dt, steps) = (1e-3, 500);
    for (seed, m) in random_models(true, 3) {
        let m = conservative(&m);
        let nm = NumericModel::with_default_params(&m);
        let n = nm.dof();
        let (q0, qd0, _) = random_state(seed + 11, n);
        let energy = |q: &[f64], qd: &[f64]| nm.kinetic_energy(q, qd) + nm.potential_energy(q);
        let e0 = energy(&q0, &qd0);
        let (mut q, mut qd) = (
            DVector::from_vec(q0.clone()),
            DVector::from_vec(qd0.clone()),
        );
        let acc = |q: &DVector<f64>, qd: &DVector<f64>| {
            nm.forward_dynamics(q.as_slice(), qd.as_slice(), 0.0)
        };
        let mut scale = nm.kinetic_energy(&q0, &qd0) + nm.potential_energy(&q0).abs();
        for _ in 0..steps {
            let (k1q, k1v) = (qd.clone(), acc(&q, &qd));
            let (q2, v2) = (&q + &k1q * (dt / 2.0), &qd + &k1v * (dt / 2.0));
            let (k2q, k2v) = (v2.clone(), acc(&q2, &v2));
            let (q3, v3) = (&q + &k2q * (dt / 2.0), &qd + &k2v * (dt / 2.0));
            let (k3q, k3v) = (v3.clone(), acc(&q3, &v3));
            let (q4, v4) = (&q + &k3q * dt, &qd + &k3v * dt);
            let (k4q, k4v) = (v4.clone(), acc(&q4, &v4));
            q += (k1q + k2q * 2.0 + k3q * 2.0 + k4q) * (dt / 6.0);
            qd += (k1v + k2v * 2.0 + k3v * 2.0 + k4v) * (dt / 6.0);
            scale = scale.max(nm.kinetic_energy(q.as_slice(), qd.as_slice()));
        }
        let e1 = energy(q.as_slice(), qd.as_slice());
        assert!(
            (e1 - e0).abs() <= 1e-9 * scale,
            "seed {seed}: energy {e0} -> {e1} (drift {:e}, scale {scale})",
            e1 - e0
        );
        // The motion was not trivial.
        assert!((&q - DVector::from_vec(q0)).amax() > 1e-3);
    }
}

/// `d(T + V)/dt` by central differences along the instantaneous motion (states
/// `q + s q' + s^2/2 q''`, `q' + s q''`, exact to the order needed) equals the power of
/// the non-conservative elements, computed independently element by element from the body
/// kinematics: `-c q'^2 + constant q'` (joints), `-c l'^2` (point dampers), `f . v_P +
/// t . w` (external forces).
#[test]
fn power_balance_with_dissipation_and_external_forces() {
    let h = 1e-4;
    for (seed, m) in random_models(true, 4) {
        let nm = NumericModel::with_default_params(&m);
        let params = m.default_params();
        let n = nm.dof();
        let (q, qd, _) = random_state(seed + 17, n);
        let qdd = nm.forward_dynamics(&q, &qd, 0.0);
        let energy_at = |s: f64| {
            let qs: Vec<f64> = (0..n)
                .map(|i| q[i] + s * qd[i] + 0.5 * s * s * qdd[i])
                .collect();
            let qds: Vec<f64> = (0..n).map(|i| qd[i] + s * qdd[i]).collect();
            nm.kinetic_energy(&qs, &qds) + nm.potential_energy(&qs)
        };
        // Central differences with Richardson extrapolation (stiff springs make the O(h^2)
        // term of a plain central difference large): error O(h^4).
        let central = |h: f64| (energy_at(h) - energy_at(-h)) / (2.0 * h);
        let de_dt = (4.0 * central(h / 2.0) - central(h)) / 3.0;

        let bodies = nm.body_kinematics(&q, &qd);
        let mut power = 0.0;
        let mut scale = nm.kinetic_energy(&q, &qd);
        for f in &m.forces {
            let p = match f {
                ForceElement::Joint {
                    body,
                    damping,
                    constant,
                    ..
                } => {
                    -damping.eval(&params) * qd[*body] * qd[*body]
                        + constant.eval(&params) * qd[*body]
                }
                ForceElement::PointSpring { a, b, damping, .. } => {
                    let d = nm.point_position(*b, &q) - nm.point_position(*a, &q);
                    let v = nm.point_velocity(*b, &q, &qd) - nm.point_velocity(*a, &q, &qd);
                    let ld = d.dot(&v) / d.norm();
                    -damping.eval(&params) * ld * ld
                }
                ForceElement::External {
                    body,
                    point,
                    force,
                    torque,
                    in_body_frame,
                    ..
                } => {
                    let s = &bodies[*body];
                    let ev = |v: &[Scalar; 3]| {
                        Vector3::new(v[0].eval(&params), v[1].eval(&params), v[2].eval(&params))
                    };
                    let (mut fo, mut to) = (ev(force), ev(torque));
                    if *in_body_frame {
                        fo = s.rotation * fo;
                        to = s.rotation * to;
                    }
                    let r = s.rotation * ev(point);
                    let vp = s.origin_velocity + s.omega.cross(&r);
                    fo.dot(&vp) + to.dot(&s.omega)
                }
            };
            scale += p.abs();
            power += p;
        }
        assert!(
            (de_dt - power).abs() <= 1e-8 * scale,
            "seed {seed}: d(T+V)/dt = {de_dt}, power = {power}"
        );
        let qdv = DVector::from_column_slice(&qd);
        let p_nc = -qdv.dot(&nm.q_nonconservative(&q, &qd, 0.0));
        assert!(
            (p_nc - power).abs() <= 1e-12 * scale,
            "seed {seed}: -q'^T Q_nc = {p_nc}, power = {power}"
        );
    }
}

/// Springs: `Q - Q_nc` is the gradient of the spring part of `V` (finite differences).
#[test]
fn spring_forces_are_the_gradient_of_the_potential() {
    let h = 1e-6;
    for (seed, m) in random_models(true, 3) {
        let mut no_gravity = m.clone();
        no_gravity.gravity = zero3();
        let nm = NumericModel::with_default_params(&no_gravity);
        let n = nm.dof();
        let (q, qd, _) = random_state(seed + 23, n);
        let q_springs = nm.q_vector(&q, &qd, 0.0) - nm.q_nonconservative(&q, &qd, 0.0);
        let grad = DVector::from_fn(n, |k, _| {
            let (mut qp, mut qm) = (q.clone(), q.clone());
            qp[k] += h;
            qm[k] -= h;
            (nm.potential_energy(&qp) - nm.potential_energy(&qm)) / (2.0 * h)
        });
        assert_close_vec(&format!("seed {seed}: dV/dq"), &q_springs, &grad, 1e-7, 1.0);
    }
}

// ---------------------------------------------------------------------------------------
// Point kinematics and constraints against finite differences
// ---------------------------------------------------------------------------------------

fn fd_jacobian(
    n: usize,
    rows: usize,
    q: &[f64],
    f: impl Fn(&[f64]) -> DVector<f64>,
) -> DMatrix<f64> {
    let h = 1e-6;
    let mut j = DMatrix::zeros(rows, n);
    for k in 0..n {
        let (mut qp, mut qm) = (q.to_vec(), q.to_vec());
        qp[k] += h;
        qm[k] -= h;
        j.set_column(k, &((f(&qp) - f(&qm)) / (2.0 * h)));
    }
    j
}

/// `d/dt (J(q + q' t) q')` at `t = 0` by central differences.
fn fd_bias(q: &[f64], qd: &[f64], jac: impl Fn(&[f64]) -> DMatrix<f64>) -> DVector<f64> {
    let h = 1e-5;
    let qp: Vec<f64> = q.iter().zip(qd).map(|(a, b)| a + h * b).collect();
    let qm: Vec<f64> = q.iter().zip(qd).map(|(a, b)| a - h * b).collect();
    let qdv = DVector::from_column_slice(qd);
    (jac(&qp) * &qdv - jac(&qm) * &qdv) / (2.0 * h)
}

#[test]
fn point_jacobian_and_bias_match_finite_differences() {
    for (seed, m) in random_models(true, 4) {
        let nm = NumericModel::with_default_params(&m);
        let n = nm.dof();
        let (q, qd, _) = random_state(seed + 29, n);
        for p in 0..nm.point_count() {
            let jac = nm.point_jacobian(p, &q);
            let fd = fd_jacobian(n, 3, &q, |q| {
                DVector::from_column_slice(nm.point_position(p, q).as_slice())
            });
            assert_close_mat(&format!("seed {seed} point {p}: J"), &jac, &fd, 1e-7, 1.0);
            let v = DVector::from_column_slice(nm.point_velocity(p, &q, &qd).as_slice());
            let jqd = &jac * DVector::from_column_slice(&qd);
            assert_close_vec("v = J q'", &v, &jqd, 1e-13, 1.0);
            let bias = DVector::from_column_slice(nm.point_bias(p, &q, &qd).as_slice());
            let fd = fd_bias(&q, &qd, |q| nm.point_jacobian(p, q));
            assert_close_vec(
                &format!("seed {seed} point {p}: J'q'"),
                &bias,
                &fd,
                1e-6,
                1.0,
            );
        }
    }
}

#[test]
fn constraints_jacobian_and_bias_match_finite_differences() {
    let mut angles = 0;
    for (seed, m) in random_models(false, 4) {
        let nm = NumericModel::with_default_params(&m);
        let n = nm.dof();
        let rows = m.constraint_rows();
        assert_eq!(nm.constraint_rows(), rows);
        let (q, qd, _) = random_state(seed + 37, n);
        let h = nm.constraints(&q);
        assert_eq!(h.len(), rows);
        // Rows from the definitions in types::Constraint.
        let params = m.default_params();
        let states = nm.body_kinematics(&q, &qd);
        let mut row = 0;
        for c in &m.constraints {
            match c {
                Constraint::Loop {
                    a, b, components, ..
                } => {
                    let d = nm.point_position(*b, &q) - nm.point_position(*a, &q);
                    for ax in components {
                        assert_eq!(h[row], d[ax.index()]);
                        row += 1;
                    }
                }
                Constraint::Fixed {
                    point,
                    position,
                    components,
                    ..
                } => {
                    let p = nm.point_position(*point, &q);
                    for ax in components {
                        let k = ax.index();
                        assert_eq!(h[row], p[k] - position[k].eval(&params));
                        row += 1;
                    }
                }
                Constraint::Angle {
                    a, b, axis, offset, ..
                } => {
                    // The relative rotation T^a^T T^b is a rotation about `axis` by h + offset.
                    let t = |x: &Option<usize>| {
                        x.map_or(nalgebra::Matrix3::identity(), |i| states[i].rotation)
                    };
                    let rel = t(a).transpose() * t(b);
                    let expected = rot(*axis, h[row] + offset.eval(&params));
                    assert!(
                        (rel - expected).amax() <= 1e-12,
                        "seed {seed}: angle constraint\n{rel}\n{expected}"
                    );
                    angles += 1;
                    row += 1;
                }
            }
        }
        assert_eq!(row, rows);
        let jac = nm.constraint_jacobian(&q);
        let fd = fd_jacobian(n, rows, &q, |q| nm.constraints(q));
        assert_close_mat(&format!("seed {seed}: J"), &jac, &fd, 1e-7, 1.0);
        let bias = nm.constraint_bias(&q, &qd);
        let fd = fd_bias(&q, &qd, |q| nm.constraint_jacobian(q));
        assert_close_vec(&format!("seed {seed}: A"), &bias, &fd, 1e-6, 1.0);
    }
    assert!(angles > 5, "too few angle constraints generated: {angles}");
}

// ---------------------------------------------------------------------------------------
// The random generator itself
// ---------------------------------------------------------------------------------------

#[test]
fn random_models_are_deterministic_and_valid() {
    let opts = RandomOpts::default();
    assert_eq!(random_model(42, &opts), random_model(42, &opts));
    assert_ne!(random_model(42, &opts), random_model(43, &opts));
    assert_eq!(random_state(9, 4), random_state(9, 4));
    for (seed, m) in random_models(true, 4) {
        let params = m.default_params();
        for (i, b) in m.bodies.iter().enumerate() {
            assert!(b.parent.is_none_or(|p| p < i));
            assert!(b.mass.eval(&params) > 0.0);
            let it = nalgebra::Matrix3::from_fn(|r, c| b.inertia[r][c].eval(&params));
            assert_eq!(it, it.transpose(), "seed {seed}");
            let e = it.symmetric_eigen().eigenvalues;
            let (a, bb, c) = (e[0], e[1], e[2]);
            assert!(a > 0.0 && bb > 0.0 && c > 0.0);
            assert!(a + bb > c && bb + c > a && a + c > bb, "seed {seed}: {e}");
        }
        for p in &m.points {
            assert!(p.body.is_none_or(|b| b < m.bodies.len()));
        }
        // Parameters really are used: changing them changes the dynamics.
        let nm0 = NumericModel::new(&m, &params);
        let other: Vec<f64> = params.iter().map(|v| v * 1.1).collect();
        let nm1 = NumericModel::new(&m, &other);
        let (q, qd, _) = random_state(seed, m.dof());
        assert_ne!(nm0.f_vector(&q, &qd), nm1.f_vector(&q, &qd));
    }
    // Planar models stay in the plane.
    let planar = RandomOpts {
        planar: true,
        bodies: 6,
        ..RandomOpts::default()
    };
    for seed in 0..10 {
        let m = random_model(seed, &planar);
        let nm = NumericModel::with_default_params(&m);
        let (q, qd, _) = random_state(seed, 6);
        for s in nm.body_kinematics(&q, &qd) {
            assert_eq!(s.com[2], 0.0);
            assert_eq!(s.omega[0], 0.0);
            assert_eq!(s.omega[1], 0.0);
        }
    }
}
