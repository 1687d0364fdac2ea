//! Shared helpers for the integration tests of `mbs-symbolic`: a deterministic random model
//! generator and random states, for property tests of every implementation (numeric
//! reference, symbolic Newton–Euler, generated code).
//!
//! Use from an integration test with `mod common;`. Everything is deterministic: the same
//! seed and options always give the same model, on every platform (`mbs_symbolic::samples::SplitMix64`).

#![allow(dead_code)]

use mbs_symbolic::model::types::{
    Axis, BinOp, Body, Constraint, ForceElement, Func, Joint, JointKind, Model, Parameter, Point,
    Scalar, SourceInfo,
};
use nalgebra::{Matrix3, Vector3};

pub use mbs_symbolic::samples::SplitMix64;

/// What [`random_model`] generates.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RandomOpts {
    /// Number of bodies (= degrees of freedom).
    pub bodies: usize,
    /// Planar in the x-y plane: revolute joints about z, prismatic along x or y, constant
    /// joint rotations only about z, anchors, centres of mass, points and gravity in the x-y
    /// plane, forces in the plane and torques about z. Otherwise fully spatial.
    pub planar: bool,
    /// Allow prismatic joints (about 30 % of the joints); otherwise all revolute.
    pub prismatic: bool,
    /// Random trees (each parent chosen among earlier bodies, sometimes ground); otherwise a
    /// single chain.
    pub branching: bool,
    /// Gravity on (about 9.81 m/s^2, mostly along -y); otherwise zero.
    pub gravity: bool,
    /// A few force elements of every kind (joint spring-damper-constant, point
    /// spring-dampers, external forces in ground and in body frame).
    pub force_elements: bool,
    /// Some parameters are run-time (`Parameter::runtime`); otherwise all are folded.
    pub runtime_params: bool,
}

impl Default for RandomOpts {
    /// Four spatial bodies, everything on.
    fn default() -> Self {
        RandomOpts {
            bodies: 4,
            planar: false,
            prismatic: true,
            branching: true,
            gravity: true,
            force_elements: true,
            runtime_params: true,
        }
    }
}

fn num(v: f64) -> Scalar {
    Scalar::Num(v)
}

fn param(i: usize) -> Scalar {
    Scalar::Param(i)
}

fn mul(a: Scalar, b: Scalar) -> Scalar {
    Scalar::Bin(BinOp::Mul, Box::new(a), Box::new(b))
}

fn rot(axis: Axis, t: f64) -> Matrix3<f64> {
    let (s, c) = t.sin_cos();
    match axis {
        Axis::X => Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c),
        Axis::Y => Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c),
        Axis::Z => Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
    }
}

// Parameter indices of every random model.
const P_MSCALE: usize = 0;
const P_LEN: usize = 1;
const P_G: usize = 2;
const P_KSCALE: usize = 3;
const P_ANG: usize = 4;
const P_ISCALE: usize = 5;

/// A random vector (z = 0 when planar) with components in `[-r, r)`.
fn vec3(rng: &mut SplitMix64, r: f64, planar: bool) -> [f64; 3] {
    let z = if planar { 0.0 } else { rng.uniform(-r, r) };
    [rng.uniform(-r, r), rng.uniform(-r, r), z]
}

fn scalars(v: [f64; 3]) -> [Scalar; 3] {
    v.map(num)
}

/// A random, valid inertia tensor about the centre of mass, `R diag(a, b, c) R^T` with the
/// principal moments satisfying the triangle inequalities strictly (`R` about z only when
/// planar).
fn inertia(rng: &mut SplitMix64, planar: bool) -> Matrix3<f64> {
    let a = rng.uniform(0.02, 0.2);
    let b = rng.uniform(0.02, 0.2);
    let lo = (a - b).abs();
    let c = lo + (a + b - lo) * rng.uniform(0.1, 0.9);
    let r = if planar {
        rot(Axis::Z, rng.uniform(-3.0, 3.0))
    } else {
        rot(Axis::Z, rng.uniform(-3.0, 3.0))
            * rot(Axis::X, rng.uniform(-3.0, 3.0))
            * rot(Axis::Y, rng.uniform(-3.0, 3.0))
    };
    let i = r * Matrix3::from_diagonal(&Vector3::new(a, b, c)) * r.transpose();
    // Exactly symmetric.
    (i + i.transpose()) * 0.5
}

/// A random subset of the ground components (never empty), in increasing axis order.
fn components(rng: &mut SplitMix64, planar: bool) -> Vec<Axis> {
    if planar {
        return match rng.below(3) {
            0 => vec![Axis::X],
            1 => vec![Axis::Y],
            _ => vec![Axis::X, Axis::Y],
        };
    }
    let mask = 1 + rng.below(7);
    (0..3)
        .filter(|k| mask & (1 << k) != 0)
        .map(|k| Axis::from_index(k).unwrap())
        .collect()
}

/// A deterministic random mechanism (see [`RandomOpts`]).
///
/// Always: bodies `b0, b1, ...` with coordinates `q0, q1, ...`, off-axis centres of mass,
/// full valid inertia tensors, constant joint rotations (about z only when planar), one
/// named point per body plus two ground points, and a few constraints (a loop closure, a
/// fixed point and, when a suitable path exists, an angle closure over joints without
/// constant rotations) — constraints do not affect the tree dynamics. Six parameters
/// (`mscale, len, g, kscale, ang, iscale`, indices 0..6) enter masses, anchors, gravity,
/// stiffnesses, joint rotation angles and inertia tensors through `Scalar::Param` and
/// `Scalar::Bin`/`Neg`/`Call`; their default values differ from 1 so that forgetting a
/// parameter changes the numbers.
pub fn random_model(seed: u64, opts: &RandomOpts) -> Model {
    let mut rng = SplitMix64::new(seed ^ 0xA076_1D64_78BD_642F);
    let planar = opts.planar;
    let rt = opts.runtime_params;
    let parameters = vec![
        Parameter {
            name: "mscale".into(),
            value: rng.uniform(0.8, 1.3),
            runtime: rt,
            derived: false,
        },
        Parameter {
            name: "len".into(),
            value: rng.uniform(0.3, 0.6),
            runtime: rt,
            derived: false,
        },
        Parameter {
            name: "g".into(),
            value: 9.81,
            runtime: false,
            derived: false,
        },
        Parameter {
            name: "kscale".into(),
            value: rng.uniform(0.8, 1.5),
            runtime: rt,
            derived: false,
        },
        Parameter {
            name: "ang".into(),
            value: rng.uniform(0.2, 0.9),
            runtime: false,
            derived: false,
        },
        Parameter {
            name: "iscale".into(),
            value: rng.uniform(0.8, 1.3),
            runtime: false,
            derived: false,
        },
    ];

    let gravity = if !opts.gravity {
        [Scalar::ZERO, Scalar::ZERO, Scalar::ZERO]
    } else if planar {
        [
            num(rng.uniform(-1.0, 1.0)),
            Scalar::Neg(Box::new(param(P_G))),
            Scalar::ZERO,
        ]
    } else {
        [
            num(rng.uniform(-2.0, 2.0)),
            Scalar::Neg(Box::new(param(P_G))),
            num(rng.uniform(-2.0, 2.0)),
        ]
    };

    let mut bodies: Vec<Body> = Vec::with_capacity(opts.bodies);
    for i in 0..opts.bodies {
        let parent = if i == 0 {
            None
        } else if opts.branching {
            if rng.chance(0.15) {
                None
            } else {
                Some(rng.below(i))
            }
        } else {
            Some(i - 1)
        };
        let kind = if opts.prismatic && rng.chance(0.3) {
            JointKind::Prismatic
        } else {
            JointKind::Revolute
        };
        let axis = match (planar, kind) {
            (true, JointKind::Revolute) => Axis::Z,
            (true, JointKind::Prismatic) => {
                if rng.chance(0.5) {
                    Axis::X
                } else {
                    Axis::Y
                }
            }
            (false, _) => rng.axis(),
        };
        let mut rotation = Vec::new();
        if planar {
            if rng.chance(0.35) {
                rotation.push((Axis::Z, num(rng.uniform(-1.5, 1.5))));
            }
        } else {
            for _ in 0..rng.below(3) {
                let ax = rng.axis();
                let th = if rng.chance(0.3) {
                    // cos(ang) * c, exercises Call and Bin.
                    mul(
                        Scalar::Call(Func::Cos, Box::new(param(P_ANG))),
                        num(rng.uniform(-2.0, 2.0)),
                    )
                } else {
                    num(rng.uniform(-1.5, 1.5))
                };
                rotation.push((ax, th));
            }
        }
        let a = vec3(&mut rng, 0.5, planar);
        let anchor = if rng.chance(0.4) {
            [mul(num(a[0] / 0.45), param(P_LEN)), num(a[1]), num(a[2])]
        } else {
            scalars(a)
        };
        let m = rng.uniform(0.5, 2.0);
        let mass = if rng.chance(0.5) {
            mul(num(m), param(P_MSCALE))
        } else {
            num(m)
        };
        let com = scalars(vec3(&mut rng, 0.3, planar));
        let it = inertia(&mut rng, planar);
        let scaled = rng.chance(0.4);
        let inertia = std::array::from_fn(|r| {
            std::array::from_fn(|c| {
                let v = num(it[(r, c)]);
                if scaled { mul(v, param(P_ISCALE)) } else { v }
            })
        });
        bodies.push(Body {
            name: format!("b{i}"),
            coordinate: format!("q{i}"),
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
        });
    }

    let mut points: Vec<Point> = (0..opts.bodies)
        .map(|i| Point {
            name: format!("p{i}"),
            body: Some(i),
            position: scalars(vec3(&mut rng, 0.4, planar)),
        })
        .collect();
    for k in 0..2 {
        points.push(Point {
            name: format!("ground{k}"),
            body: None,
            position: scalars(vec3(&mut rng, 0.8, planar)),
        });
    }

    // Two points on different bodies (one may be on ground), never both on ground.
    let pick_pair = |rng: &mut SplitMix64| -> Option<(usize, usize)> {
        for _ in 0..32 {
            let a = rng.below(points.len());
            let b = rng.below(points.len());
            let (ba, bb) = (points[a].body, points[b].body);
            if ba != bb && (ba.is_some() || bb.is_some()) {
                return Some((a, b));
            }
        }
        None
    };

    let mut forces = Vec::new();
    if opts.force_elements && opts.bodies > 0 {
        let mut any = false;
        for i in 0..opts.bodies {
            if rng.chance(0.5) || (!any && i + 1 == opts.bodies) {
                any = true;
                let k = rng.uniform(0.5, 5.0);
                forces.push(ForceElement::Joint {
                    name: format!("joint{i}"),
                    body: i,
                    stiffness: if rng.chance(0.5) {
                        mul(num(k), param(P_KSCALE))
                    } else {
                        num(k)
                    },
                    damping: num(rng.uniform(0.0, 0.5)),
                    rest: num(rng.uniform(-0.5, 0.5)),
                    constant: num(rng.uniform(-0.5, 0.5)),
                });
            }
        }
        for s in 0..2 {
            if let Some((a, b)) = pick_pair(&mut rng) {
                forces.push(ForceElement::PointSpring {
                    name: format!("spring{s}"),
                    a,
                    b,
                    stiffness: mul(num(rng.uniform(1.0, 10.0)), param(P_KSCALE)),
                    damping: num(rng.uniform(0.0, 0.3)),
                    rest_length: num(rng.uniform(0.1, 0.5)),
                });
            }
        }
        for (e, in_body_frame) in [false, true].into_iter().enumerate() {
            let body = rng.below(opts.bodies);
            let (force, torque) = if planar {
                (
                    [rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0), 0.0],
                    [0.0, 0.0, rng.uniform(-1.0, 1.0)],
                )
            } else {
                (vec3(&mut rng, 2.0, false), vec3(&mut rng, 1.0, false))
            };
            forces.push(ForceElement::External {
                name: format!("external{e}"),
                body,
                point: scalars(vec3(&mut rng, 0.4, planar)),
                force: scalars(force),
                torque: scalars(torque),
                in_body_frame,
            });
        }
    }

    let mut constraints = Vec::new();
    if let Some((a, b)) = pick_pair(&mut rng) {
        constraints.push(Constraint::Loop {
            name: "loop".into(),
            a,
            b,
            components: components(&mut rng, planar),
        });
    }
    if opts.bodies > 0 {
        constraints.push(Constraint::Fixed {
            name: "fixed".into(),
            point: rng.below(opts.bodies),
            position: scalars(vec3(&mut rng, 0.8, planar)),
            components: components(&mut rng, planar),
        });
    }
    if let Some(c) = angle_constraint(&mut rng, &bodies, planar) {
        constraints.push(c);
    }

    Model {
        name: format!("random_{seed}"),
        source: SourceInfo {
            path: "<random>".into(),
            hash: format!("{seed:016x}"),
        },
        parameters,
        gravity,
        bodies,
        points,
        forces,
        constraints,
    }
}

/// Reference chain of a body (its ancestors and itself), `[]` for ground.
fn chain(bodies: &[Body], b: Option<usize>) -> Vec<usize> {
    let mut out = Vec::new();
    let mut cur = b;
    while let Some(i) = cur {
        out.push(i);
        cur = bodies[i].parent;
    }
    out
}

/// An angle closure between two bodies (or a body and ground) whose path holds only joints
/// without constant rotation, all revolute ones about the same axis, at least one revolute.
fn angle_constraint(rng: &mut SplitMix64, bodies: &[Body], planar: bool) -> Option<Constraint> {
    let n = bodies.len();
    let start = if n > 0 { rng.below(n) } else { 0 };
    for off in 0..n {
        let b = (start + off) % n;
        for a in std::iter::once(None).chain((0..n).map(Some)) {
            if a == Some(b) {
                continue;
            }
            let (ca, cb) = (chain(bodies, a), chain(bodies, Some(b)));
            let path: Vec<usize> = ca
                .iter()
                .filter(|j| !cb.contains(j))
                .chain(cb.iter().filter(|j| !ca.contains(j)))
                .copied()
                .collect();
            if path.iter().any(|&j| !bodies[j].joint.rotation.is_empty()) {
                continue;
            }
            let revolute: Vec<usize> = path
                .iter()
                .copied()
                .filter(|&j| bodies[j].joint.kind == JointKind::Revolute)
                .collect();
            let Some(&first) = revolute.first() else {
                continue;
            };
            let axis = bodies[first].joint.axis;
            if planar && axis != Axis::Z {
                continue;
            }
            if revolute.iter().any(|&j| bodies[j].joint.axis != axis) {
                continue;
            }
            return Some(Constraint::Angle {
                name: "angle".into(),
                a,
                b: Some(b),
                axis,
                offset: num(rng.uniform(-1.0, 1.0)),
            });
        }
    }
    None
}

/// A deterministic random state `(q, q', q'')` with `n` entries each: `q` in `[-1.2, 1.2)`,
/// `q'` in `[-1.5, 1.5)`, `q''` in `[-2, 2)`.
pub fn random_state(seed: u64, n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut rng = SplitMix64::new(seed ^ 0x57A7_E000_0000_0001);
    let q = (0..n).map(|_| rng.uniform(-1.2, 1.2)).collect();
    let qd = (0..n).map(|_| rng.uniform(-1.5, 1.5)).collect();
    let qdd = (0..n).map(|_| rng.uniform(-2.0, 2.0)).collect();
    (q, qd, qdd)
}

/// Holds point `point` of `model` at the ground position `position` (components `axes`): a
/// `Fixed` constraint named `name`.
pub fn hold(model: &mut Model, name: &str, point: usize, position: [f64; 3], axes: &[Axis]) {
    model.constraints.push(Constraint::Fixed {
        name: name.into(),
        point,
        position: position.map(Scalar::Num),
        components: axes.to_vec(),
    });
}
