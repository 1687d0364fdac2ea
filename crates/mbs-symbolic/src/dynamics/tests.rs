//! Unit tests of the symbolic derivation against closed forms (the randomised comparison
//! with the numeric reference lives in the crate's integration tests).

use super::forces::{Recursion, velocity_and_gravity_terms};
use super::kinematics::forward_kinematics;
use super::*;
use crate::expr::{EvalInput, Tape};
use crate::model::{Axis, Body, Joint, JointKind, Parameter, SourceInfo};

fn rod(name: &str, parent: Option<usize>, anchor_x: f64, l: f64, m: f64, c: f64, izz: f64) -> Body {
    let z = Scalar::ZERO;
    let mut inertia = [
        [z.clone(), z.clone(), z.clone()],
        [z.clone(), z.clone(), z.clone()],
        [z.clone(), z.clone(), z.clone()],
    ];
    inertia[1][1] = Scalar::Num(izz);
    inertia[2][2] = Scalar::Num(izz);
    let _ = l;
    Body {
        name: name.into(),
        coordinate: name.into(),
        parent,
        joint: Joint {
            kind: JointKind::Revolute,
            axis: Axis::Z,
            anchor: [Scalar::Num(anchor_x), z.clone(), z.clone()],
            rotation: vec![],
        },
        mass: Scalar::Num(m),
        com: [Scalar::Num(c), z.clone(), z.clone()],
        inertia,
    }
}

/// A double pendulum whose gravity `(gx, gy, 0)` is a pair of run-time parameters.
pub(crate) fn double_pendulum(
    l1: f64,
    m1: f64,
    c1: f64,
    i1: f64,
    m2: f64,
    c2: f64,
    i2: f64,
) -> Model {
    Model {
        name: "double_pendulum".into(),
        source: SourceInfo {
            path: "<test>".into(),
            hash: "0".into(),
        },
        parameters: vec![
            Parameter {
                name: "gx".into(),
                value: 0.0,
                runtime: true,
                derived: false,
            },
            Parameter {
                name: "gy".into(),
                value: -9.81,
                runtime: true,
                derived: false,
            },
        ],
        gravity: [Scalar::Param(0), Scalar::Param(1), Scalar::ZERO],
        bodies: vec![
            rod("b1", None, 0.0, l1, m1, c1, i1),
            rod("b2", Some(0), l1, 0.0, m2, c2, i2),
        ],
        points: vec![],
        forces: vec![],
        constraints: vec![],
    }
}

#[test]
fn double_pendulum_matches_closed_form() {
    let (l1, m1, c1, i1, m2, c2, i2) = (0.7, 1.3, 0.31, 0.05, 0.9, 0.42, 0.03);
    let model = double_pendulum(l1, m1, c1, i1, m2, c2, i2);
    let sym = Symbolic::derive(&model);
    let mut roots = sym.mass.clone();
    roots.extend(&sym.f);
    roots.extend(&sym.q);
    let tape = Tape::new(&sym.dag, &roots);
    let g0 = 9.81;
    for &(q1, q2, w1, w2) in &[
        (0.3, -0.8, 1.1, -2.0),
        (2.0, 1.0, -0.4, 0.7),
        (0.0, 0.0, 0.0, 0.0),
    ] {
        let out = tape.eval_vec(&EvalInput {
            q: &[q1, q2],
            qd: &[w1, w2],
            qdd: &[],
            t: 0.0,
            params: &[0.0, -g0],
        });
        let c2q = q2.cos();
        let h = m2 * l1 * c2 * q2.sin();
        let m11 = i1 + i2 + m1 * c1 * c1 + m2 * (l1 * l1 + c2 * c2 + 2.0 * l1 * c2 * c2q);
        let m12 = i2 + m2 * (c2 * c2 + l1 * c2 * c2q);
        let m22 = i2 + m2 * c2 * c2;
        let f1 = -h * (2.0 * w1 * w2 + w2 * w2)
            + g0 * (m1 * c1 * q1.cos() + m2 * (l1 * q1.cos() + c2 * (q1 + q2).cos()));
        let f2 = h * w1 * w1 + g0 * m2 * c2 * (q1 + q2).cos();
        let expected = [m11, m12, m12, m22, f1, f2, 0.0, 0.0];
        for (k, (a, e)) in out.iter().zip(expected).enumerate() {
            assert!(
                (a - e).abs() <= 1e-13 * (1.0 + e.abs()),
                "entry {k}: {a} vs {e}"
            );
        }
    }
}

#[test]
fn planar_chain_uses_angle_sums_and_no_out_of_plane_terms() {
    let model = double_pendulum(1.0, 1.0, 0.5, 1.0 / 12.0, 1.0, 0.5, 1.0 / 12.0);
    let sym = Symbolic::derive(&model);
    // T^2 = Rot(z, q1 + q2): sine and cosine of the angle sum, not products of rotations.
    let t2 = sym.bodies[1].ground_rot;
    assert_eq!(sym.dag.sexpr(t2[0][0]), "(cos (+ q0 q1))");
    assert_eq!(sym.dag.sexpr(t2[1][0]), "(sin (+ q0 q1))");
    assert!(sym.dag.is_const(t2[2][2], 1.0) && sym.dag.is_const(t2[0][2], 0.0));
    // M22 of a planar chain is a constant.
    assert!(sym.dag.as_const(sym.mass[3]).is_some());
}

#[test]
fn operation_count_grows_at_most_quadratically() {
    // A fully expanded Lagrangian grows exponentially with N; the recursive formulation with
    // shared intermediates must not grow faster than O(N^2).
    for planar in [true, false] {
        let count = |n: usize| {
            let m = if planar {
                crate::samples::planar_chain(n)
            } else {
                crate::samples::spatial_chain(n)
            };
            Symbolic::derive(&m).op_count_mf().total() as f64
        };
        let (c8, c16, c32) = (count(8), count(16), count(32));
        eprintln!("planar={planar}: N=8 {c8}, N=16 {c16}, N=32 {c32}");
        assert!(
            c32 / c16 < 4.4 && c16 / c8 < 4.4,
            "planar={planar}: {c8} {c16} {c32}"
        );
    }
}

#[test]
fn planar_chain_operation_counts() {
    for n in [2, 4, 8] {
        let s = Symbolic::derive(&crate::samples::planar_chain(n));
        eprintln!(
            "N={n}: M {} | F {} | M+F {}",
            s.op_count_m(),
            s.op_count_f(),
            s.op_count_mf()
        );
    }
}

/// A spatial tree: two branches from the base, one through a prismatic joint (whose offset
/// `d` depends on `q`, so the composite form's first moments do), tilted joint frames,
/// off-axis centres of mass and full inertia tensors, gravity off every axis.
fn branched_tree_with_a_slider() -> Model {
    let src = r#"
name = "branched"
gravity = [1.2, -9.3, 2.1]

[[bodies]]
name = "base"
parent = "ground"
joint = "R3"
mass = 2.0
com = [0.01, 0.02, 0.1]
inertia = { xx = 0.03, yy = 0.04, zz = 0.02, xy = 0.001, xz = -0.002, yz = 0.0015 }

[[bodies]]
name = "slide"
parent = "base"
joint = { type = "prismatic", axis = "x", rotation = [{ axis = "y", angle = 0.4 }] }
anchor = [0.1, 0.05, 0.2]
mass = 0.8
com = [0.05, -0.01, 0.02]
inertia = { xx = 0.001, yy = 0.003, zz = 0.003, yz = 0.0002 }

[[bodies]]
name = "wrist"
parent = "slide"
joint = { type = "revolute", axis = "x", rotation = [{ axis = "z", angle = 0.3 }] }
anchor = [0.1, 0.0, 0.0]
mass = 0.3
com = [0.03, 0.005, 0.01]
inertia = { xx = 0.0004, yy = 0.0006, zz = 0.0007, xy = 0.0001 }

[[bodies]]
name = "arm"
parent = "base"
joint = "R2"
anchor = [-0.2, 0.0, 0.3]
mass = 1.1
com = [0.15, 0.02, -0.01]
inertia = { xx = 0.002, yy = 0.02, zz = 0.021, xz = 0.0003 }
"#;
    crate::model::parse_str(src, "branched.toml", crate::model::Format::Toml)
        .unwrap_or_else(|e| panic!("{e:?}"))
}

/// Every way of bringing gravity into `F^b` (base acceleration, body forces) and of carrying
/// the wrenches (plain, composite) gives the same values; `derive` keeps the cheapest, so
/// all must be right.
#[test]
fn gravity_as_base_acceleration_or_body_forces_agree() {
    for model in [
        crate::samples::planar_chain(3),
        crate::samples::spatial_chain(5),
        double_pendulum(0.7, 1.3, 0.31, 0.05, 0.9, 0.42, 0.03),
        branched_tree_with_a_slider(),
    ] {
        let mut b = Builder {
            model: &model,
            dag: Dag::new(),
        };
        let kin = forward_kinematics(&mut b);
        let fa =
            velocity_and_gravity_terms(&mut b, &kin, Gravity::BaseAcceleration, Recursion::Plain);
        let variants = [
            (Gravity::BodyForces, Recursion::Plain),
            (Gravity::BaseAcceleration, Recursion::Composite),
            (Gravity::BodyForces, Recursion::Composite),
        ]
        .map(|(g, r)| velocity_and_gravity_terms(&mut b, &kin, g, r));
        let n = model.dof();
        let params: Vec<f64> = model
            .parameters
            .iter()
            .map(|p| if p.name == "gx" { 2.5 } else { p.value })
            .collect();
        for s in 0..5 {
            let q: Vec<f64> = (0..n)
                .map(|i| ((i * 7 + s * 3) as f64 * 0.37).sin())
                .collect();
            let qd: Vec<f64> = (0..n).map(|i| ((i * 5 + s) as f64 * 0.91).cos()).collect();
            let input = EvalInput {
                q: &q,
                qd: &qd,
                qdd: &[],
                t: 0.0,
                params: &params,
            };
            let va = Tape::new(&b.dag, &fa).eval_vec(&input);
            let scale = va.iter().fold(1.0f64, |m, x| m.max(x.abs()));
            for (k, fb) in variants.iter().enumerate() {
                let vb = Tape::new(&b.dag, fb).eval_vec(&input);
                for (x, y) in va.iter().zip(&vb) {
                    assert!(
                        (x - y).abs() <= 1e-13 * scale,
                        "{} variant {k}: {x} vs {y}",
                        model.name
                    );
                }
            }
        }
    }
}

#[test]
#[ignore = "prints the expressions of a 2-link planar chain"]
fn show_planar_two_link() {
    let s = Symbolic::derive(&crate::samples::planar_chain(2));
    for r in s.mf_roots() {
        eprintln!("{}", s.dag.sexpr(r));
    }
}
