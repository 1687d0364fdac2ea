//! Standard mechanisms built in code: the benchmark and test problems with known structure.

use crate::model::{Axis, Body, Joint, JointKind, Model, Parameter, Point, Scalar, SourceInfo};

fn num(v: f64) -> Scalar {
    Scalar::Num(v)
}

fn zero3() -> [Scalar; 3] {
    [Scalar::ZERO, Scalar::ZERO, Scalar::ZERO]
}

fn empty_model(name: &str, gravity: [f64; 3]) -> Model {
    Model {
        name: name.into(),
        source: SourceInfo {
            path: format!("<sample {name}>"),
            hash: String::new(),
        },
        parameters: Vec::<Parameter>::new(),
        gravity: gravity.map(num),
        bodies: vec![],
        points: vec![],
        forces: vec![],
        constraints: vec![],
    }
}

/// A planar chain of `n` identical uniform slender rods (length 1 m, mass 1 kg) pivoted about
/// z, each lying along its body x axis, under gravity `-9.81 y`; all parameters numeric (folded).
/// A point `tip` sits at the free end of the last rod.
pub fn planar_chain(n: usize) -> Model {
    let (l, m) = (1.0, 1.0);
    let mut model = empty_model(&format!("planar_chain_{n}"), [0.0, -9.81, 0.0]);
    for i in 0..n {
        let mut inertia: [[Scalar; 3]; 3] = [zero3(), zero3(), zero3()];
        inertia[1][1] = num(m * l * l / 12.0);
        inertia[2][2] = num(m * l * l / 12.0);
        model.bodies.push(Body {
            name: format!("rod{}", i + 1),
            coordinate: format!("q{}", i + 1),
            parent: i.checked_sub(1),
            joint: Joint {
                kind: JointKind::Revolute,
                axis: Axis::Z,
                anchor: [
                    num(if i == 0 { 0.0 } else { l }),
                    Scalar::ZERO,
                    Scalar::ZERO,
                ],
                rotation: vec![],
            },
            mass: num(m),
            com: [num(l / 2.0), Scalar::ZERO, Scalar::ZERO],
            inertia,
        });
    }
    model.points.push(Point {
        name: "tip".into(),
        body: n.checked_sub(1),
        position: [num(l), Scalar::ZERO, Scalar::ZERO],
    });
    model
}

/// A spatial chain of `n` bodies whose revolute joints cycle through the axes z, x, y (every
/// fourth joint prismatic along the local x axis), with off-axis centres of mass, full inertia
/// tensors and gravity `-9.81 z`; all parameters numeric.
pub fn spatial_chain(n: usize) -> Model {
    let mut model = empty_model(&format!("spatial_chain_{n}"), [0.0, 0.0, -9.81]);
    for i in 0..n {
        let axis = [Axis::Z, Axis::X, Axis::Y][i % 3];
        let kind = if i % 4 == 3 {
            JointKind::Prismatic
        } else {
            JointKind::Revolute
        };
        let k = i as f64;
        // A valid full inertia tensor: principal moments (0.02, 0.03, 0.04) rotated about z
        // by 0.3 rad: off-diagonal xy term only, eigenvalues unchanged.
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        let (a, b) = (0.02, 0.03);
        let ixx = c * c * a + s * s * b;
        let iyy = s * s * a + c * c * b;
        let ixy = c * s * (a - b);
        let inertia = [
            [num(ixx), num(ixy), Scalar::ZERO],
            [num(ixy), num(iyy), Scalar::ZERO],
            [Scalar::ZERO, Scalar::ZERO, num(0.04)],
        ];
        model.bodies.push(Body {
            name: format!("b{}", i + 1),
            coordinate: format!("q{}", i + 1),
            parent: i.checked_sub(1),
            joint: Joint {
                kind,
                axis: if kind == JointKind::Prismatic {
                    Axis::X
                } else {
                    axis
                },
                anchor: if i == 0 {
                    zero3()
                } else {
                    [num(0.3), num(0.05), Scalar::ZERO]
                },
                rotation: vec![],
            },
            mass: num(1.0 + 0.1 * k),
            com: [num(0.15), num(0.02), num(-0.01)],
            inertia,
        });
    }
    model.points.push(Point {
        name: "tip".into(),
        body: n.checked_sub(1),
        position: [num(0.3), Scalar::ZERO, Scalar::ZERO],
    });
    model
}
