//! Building blocks shared by the hybrid-engine tests: beams, generators, mechanisms placed
//! on beam points, random hybrid systems of every shape, the paper's damper.

#![allow(dead_code)]

pub mod damper;

#[allow(unused_imports)] // the benches share this module
pub use damper::{PaperDamper, double_bar_model};

use std::f64::consts::PI;
use std::path::Path;

use fem_beam::{Beam, BeamModel, TimeFunction};
use hybrid_core::generator::GeneratorSpec;
use hybrid_core::hybrid::{
    Attachment, AttachmentKind, BeamPoint, Excitation, ExcitationTarget, ForceKind, HybridModel,
    JointForce, Mount, MountedMechanism,
};
use mbs_symbolic::runtime::{InterpretedSystem, System};
use mbs_symbolic::samples::SplitMix64;
use nalgebra::{DMatrix, DVector};

// ---------------------------------------------------------------------------------------
// Building blocks
// ---------------------------------------------------------------------------------------

pub fn compiled(name: &str) -> Box<dyn System> {
    model_registry::find_by_name(name)
        .unwrap_or_else(|| panic!("model {name} is compiled in"))
        .system()
}

pub fn fixture(name: &str) -> Box<dyn System> {
    let path = format!("{}/tests/fixtures/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    let model = mbs_symbolic::model::load(Path::new(&path)).unwrap_or_else(|e| panic!("{e}"));
    Box::new(InterpretedSystem::new(&model))
}

/// The damper's steel section (1 m, 40 x 8 mm) with `elements` elements.
pub fn beam(elements: usize, supports: &[(f64, &str)], damping: Option<f64>) -> BeamModel {
    let mut text = format!(
        "[[segment]]\nlength = 1.0\nyoungs_modulus = 210e9\ndensity = 7850.0\n\
         width = 0.040\nheight = 0.008\nelements = {elements}\n"
    );
    for (x, kind) in supports {
        text += &format!("[[support]]\nx = {x}\nkind = \"{kind}\"\n");
    }
    if let Some(z) = damping {
        text += &format!(
            "[damping]\nratios = [{{ mode = 1, ratio = {z} }}, {{ mode = 2, ratio = {z} }}]\n"
        );
    }
    BeamModel::new(&Beam::from_toml_str(&text, "test_beam.toml").unwrap()).unwrap()
}

/// The static deflection under a unit force at `x`, scaled to `w(x) = amplitude`.
pub fn static_shape(beam: &BeamModel, x: f64, amplitude: f64) -> Vec<f64> {
    let point = BeamPoint::on(beam, x).unwrap();
    let mut p = vec![0.0; beam.dof_count()];
    point.add_force(1.0, &mut p);
    let shape = beam.static_deflection(&p).unwrap();
    let w = point.value(&shape);
    shape.iter().map(|s| s * amplitude / w).collect()
}

pub fn generator(inductance: f64, connected: bool) -> GeneratorSpec {
    GeneratorSpec {
        kt: 0.0235,
        ke: 0.0235,
        armature_resistance: 1.5,
        load_resistance: 3.5,
        inductance,
        gear_ratio: 5.0,
        rotor_inertia: 1e-6,
        connected,
        gear_efficiency: 1.0,
        gear_friction: Default::default(),
    }
}

/// The mount that puts mechanism point `point` (at coordinates `q`) on `target` in the
/// beam frame with mounting angle `angle`.
pub fn mount_for(sys: &dyn System, point: usize, q: &[f64], angle: f64, target: [f64; 2]) -> Mount {
    let mut ws = sys.workspace();
    assert!(sys.point_kinematics(point, q, &vec![0.0; q.len()], &mut ws));
    let (c, s) = (angle.cos(), angle.sin());
    let (px, py) = (ws.point_p[0], ws.point_p[1]);
    Mount {
        origin: [target[0] - (c * px - s * py), target[1] - (s * px + c * py)],
        angle,
    }
}

/// Direction (in the mechanism frame) in which point `point` moves when the mechanism's
/// own loops are kept closed and coordinate `driver` turns (the other coordinates listed in
/// `dependent` follow; the rest stay).
pub fn loop_motion(
    sys: &dyn System,
    point: usize,
    q: &[f64],
    driver: usize,
    dependent: &[usize],
) -> f64 {
    let mut ws = sys.workspace();
    sys.evaluate_positions(q, &mut ws);
    let nr = sys.rows();
    let jd = DMatrix::from_fn(nr, nr, |r, c| ws.j[(r, dependent[c])]);
    let rhs = DVector::from_fn(nr, |r, _| -ws.j[(r, driver)]);
    let sol = jd.lu().solve(&rhs).unwrap();
    let mut dq = vec![0.0; q.len()];
    dq[driver] = 1.0;
    for (k, &c) in dependent.iter().enumerate() {
        dq[c] = sol[k];
    }
    assert!(sys.point_kinematics(point, q, &vec![0.0; q.len()], &mut ws));
    let v: Vec<f64> = (0..2)
        .map(|r| (0..q.len()).map(|c| ws.point_j[(r, c)] * dq[c]).sum())
        .collect();
    v[1].atan2(v[0])
}

/// `[q2, q3]` closing the triangle crank end `K` – `E` – `D` with `|E - K| = b`,
/// `|E - D| = c`, `D = (d, 0)` (elbow up), as absolute angles `(theta_b, theta_c)`.
pub fn close_triangle(a: f64, q1: f64, b: f64, c: f64, d: f64) -> (f64, f64) {
    let k = [a * q1.cos(), a * q1.sin()];
    let (dx, dy) = (d - k[0], -k[1]);
    let r = dx.hypot(dy);
    let beta = ((b * b + r * r - c * c) / (2.0 * b * r)).acos();
    let tb = dy.atan2(dx) + beta;
    let e = [k[0] + b * tb.cos(), k[1] + b * tb.sin()];
    let tc = e[1].atan2(e[0] - d);
    (tb, tc)
}

/// The shapes of mechanism the random systems are made of.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// The paper's double bar, tip pinned (no free coordinate).
    DoubleBarPin,
    /// The double bar, tip on a roller (one free coordinate).
    DoubleBarRoller,
    /// Roller carriage with a pendulum arm (the arm free).
    CarriageArm,
    /// Three bars with the tip pinned: a crank-rocker four-bar with the beam (one free).
    Chain3,
    /// The slider-crank (own loop) with the slider on a roller (no free coordinate).
    SliderCrank,
    /// Four-bar (own loop) with an arm, coupler midpoint on a roller (the arm free).
    FourBarArm,
}

pub const SHAPES: [Shape; 6] = [
    Shape::DoubleBarPin,
    Shape::DoubleBarRoller,
    Shape::CarriageArm,
    Shape::Chain3,
    Shape::SliderCrank,
    Shape::FourBarArm,
];

/// A mechanism of `shape` at a random consistent configuration, with its attachment point
/// on `target` (beam frame), and its force elements `(joint, kind)`.
pub struct Placed {
    pub mech: MountedMechanism,
    pub point: usize,
    pub kind: AttachmentKind,
    pub forces: Vec<(usize, ForceKind)>,
}

impl Placed {
    /// Adds the placed mechanism as mechanism `i`, attached at `beam` (attachment `att{i}`),
    /// with its force elements (`f{i}_{k}`) as `keep` changes them (`None`: left out).
    pub fn push_into(
        self,
        i: usize,
        beam: BeamPoint,
        (mechs, atts, forces): (
            &mut Vec<MountedMechanism>,
            &mut Vec<Attachment>,
            &mut Vec<JointForce>,
        ),
        mut keep: impl FnMut(ForceKind) -> Option<ForceKind>,
    ) {
        atts.push(Attachment {
            name: format!("att{i}"),
            mechanism: i,
            point: self.point,
            kind: self.kind,
            beam,
        });
        for (k, (joint, kind)) in self.forces.into_iter().enumerate() {
            if let Some(kind) = keep(kind) {
                forces.push(JointForce {
                    name: format!("f{i}_{k}"),
                    mechanism: i,
                    joint,
                    kind,
                });
            }
        }
        mechs.push(self.mech);
    }
}

/// What [`place`] draws for a shape: the system, its attached point's name, pin or roller,
/// the configuration, the mounting angle and the force elements.
pub type Drawn = (
    Box<dyn System>,
    &'static str,
    AttachmentKind,
    Vec<f64>,
    f64,
    Vec<(usize, ForceKind)>,
);

pub fn place(shape: Shape, rng: &mut SplitMix64, target: [f64; 2], inductance: f64) -> Placed {
    let (system, point, kind, q, angle, forces): Drawn = match shape {
        Shape::DoubleBarPin | Shape::DoubleBarRoller => {
            let kind = if shape == Shape::DoubleBarPin {
                AttachmentKind::Pin
            } else {
                AttachmentKind::Roller
            };
            let q = vec![rng.uniform(0.3, 1.2), -rng.uniform(0.5, 2.0)];
            (
                compiled("double_bar"),
                "tip",
                kind,
                q,
                rng.uniform(-PI, PI),
                vec![(0, ForceKind::Generator(generator(inductance, true)))],
            )
        }
        Shape::CarriageArm => (
            fixture("carriage_arm"),
            "roller",
            AttachmentKind::Roller,
            vec![rng.uniform(-0.02, 0.02), rng.uniform(-PI, PI)],
            rng.uniform(-0.6, 0.6),
            vec![
                (
                    1,
                    ForceKind::Spring {
                        k: 0.05,
                        q0: rng.uniform(-0.5, 0.5),
                    },
                ),
                (1, ForceKind::Damper { c: 2e-4 }),
            ],
        ),
        Shape::Chain3 => {
            let (l1, l2, l3) = (0.05, 0.15, 0.12);
            let d = rng.uniform(0.1, 0.18);
            let q1 = rng.uniform(0.0, 2.0 * PI);
            let (t2, t3) = close_triangle(l1, q1, l2, l3, d);
            (
                fixture("chain3"),
                "tip",
                AttachmentKind::Pin,
                vec![q1, t2 - q1, t3 + PI - t2],
                rng.uniform(-PI, PI),
                vec![(0, ForceKind::Damper { c: 1e-4 })],
            )
        }
        Shape::SliderCrank => {
            let (r, l) = (0.05, 0.20);
            let q1 = rng.uniform(0.3, 1.2);
            let t2 = -(r * q1.sin() / l).asin();
            let q = vec![q1, t2 - q1, r * q1.cos() + l * t2.cos()];
            // The slider moves along the mechanism's x: turn it towards the beam's y.
            (
                compiled("slider_crank"),
                "piston_pin",
                AttachmentKind::Roller,
                q,
                PI / 2.0 + rng.uniform(-0.5, 0.5),
                vec![(0, ForceKind::Generator(generator(inductance, true)))],
            )
        }
        Shape::FourBarArm => {
            let q1 = rng.uniform(0.0, 2.0 * PI);
            let (tb, tc) = close_triangle(0.10, q1, 0.25, 0.20, 0.30);
            let q = vec![q1, tb - q1, tc, rng.uniform(-PI, PI)];
            let sys = fixture("four_bar_arm");
            let p = sys.point_index("coupler_mid").unwrap();
            // Turn the coupler midpoint's loop motion towards the beam's y (within 0.6 rad).
            let dir = loop_motion(sys.as_ref(), p, &q, 0, &[1, 2]);
            let angle = PI / 2.0 - dir + rng.uniform(-0.6, 0.6);
            (
                sys,
                "coupler_mid",
                AttachmentKind::Roller,
                q,
                angle,
                vec![(3, ForceKind::Spring { k: 0.02, q0: 0.3 })],
            )
        }
    };
    let p = system.point_index(point).unwrap();
    let mount = mount_for(system.as_ref(), p, &q, angle, target);
    Placed {
        mech: MountedMechanism {
            name: format!("{shape:?}"),
            system,
            mount,
            max_condition: 1e8,
            reach: None,
            initial_q: q,
        },
        point: p,
        kind,
        forces,
    }
}

/// A random hybrid system: cantilever or simply supported beam, 1–3 mechanisms of random
/// shapes at random abscissae inside elements with random mounting angles, random beam
/// initial displacement and velocity, optionally Rayleigh damping and excitations.
pub struct Case {
    pub model: HybridModel,
    pub q0: Vec<f64>,
    pub v0: Vec<f64>,
}

pub fn random_case(seed: u64, shapes: Option<&[Shape]>, damped: bool) -> Case {
    let mut rng = SplitMix64::new(seed);
    let ne = 4 + rng.below(4);
    let cantilever = rng.below(2) == 0;
    let supports: &[(f64, &str)] = if cantilever {
        &[(0.0, "clamped")]
    } else {
        &[(0.0, "pinned"), (1.0, "pinned")]
    };
    let damping = (rng.below(2) == 0 || damped).then_some(0.01);
    let bm = beam(ne, supports, damping);
    let le = 1.0 / ne as f64;
    let x_load = if cantilever { 1.0 } else { 0.5 };
    let q0: Vec<f64> = static_shape(&bm, x_load, rng.uniform(0.5e-3, 2e-3));
    let v0: Vec<f64> = static_shape(&bm, rng.uniform(0.3, 0.9), rng.uniform(-0.05, 0.05));
    let shapes: Vec<Shape> = match shapes {
        Some(s) => s.to_vec(),
        None => (0..1 + rng.below(3))
            .map(|_| SHAPES[rng.below(SHAPES.len())])
            .collect(),
    };
    // Distinct elements for the attachments, random abscissae inside them.
    let mut elements: Vec<usize> = (0..ne).collect();
    let (mut mechs, mut atts, mut forces) = (Vec::new(), Vec::new(), Vec::new());
    for (i, &shape) in shapes.iter().enumerate() {
        let e = elements.remove(rng.below(elements.len()));
        let x = (e as f64 + rng.uniform(0.15, 0.85)) * le;
        let bp = BeamPoint::on(&bm, x).unwrap();
        assert!(bp.weights.len() > 1, "inside an element");
        let target = [x, bp.value(&q0)];
        let inductance = if rng.below(2) == 0 { 0.0 } else { 2e-3 };
        let placed = place(shape, &mut rng, target, inductance);
        placed.push_into(i, bp, (&mut mechs, &mut atts, &mut forces), Some);
    }
    let mut excitations = Vec::new();
    if rng.below(2) == 0 {
        excitations.push(Excitation {
            name: "beam_force".into(),
            target: ExcitationTarget::Beam(BeamPoint::on(&bm, rng.uniform(0.3, 1.0)).unwrap()),
            amplitude: rng.uniform(0.5, 3.0),
            time: TimeFunction::Harmonic {
                frequency_hz: rng.uniform(3.0, 20.0),
                phase: rng.uniform(0.0, 2.0 * PI),
            },
        });
    }
    if rng.below(2) == 0 {
        excitations.push(Excitation {
            name: "joint_torque".into(),
            target: ExcitationTarget::Joint {
                mechanism: 0,
                joint: 0,
            },
            amplitude: rng.uniform(1e-3, 1e-2),
            time: TimeFunction::Harmonic {
                frequency_hz: rng.uniform(3.0, 20.0),
                phase: 0.0,
            },
        });
    }
    let model = HybridModel::new(Some(bm.into()), mechs, atts, forces, excitations)
        .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
    Case { model, q0, v0 }
}

/// The paper's damper (scenarios/damper.toml): 20-element steel cantilever, 0.2 % Rayleigh
/// damping on modes 1 and 2, the double bar at 10 degrees half-angle pinned to the tip, the
/// generator on the crank; `(model, initial beam DOFs)` for a 1 mm tip displacement.
pub fn paper_damper(
    elements: usize,
    damping: bool,
    connected: bool,
    inductance: f64,
) -> (HybridModel, Vec<f64>) {
    paper_damper_at(elements, damping, connected, inductance, 10.0)
}

/// [`paper_damper`] at half-angle `half_angle_deg` ([`PaperDamper`]).
pub fn paper_damper_at(
    elements: usize,
    damping: bool,
    connected: bool,
    inductance: f64,
    half_angle_deg: f64,
) -> (HybridModel, Vec<f64>) {
    PaperDamper {
        elements,
        rayleigh: damping.then_some(0.002),
        half_angle_deg,
        generator: generator(inductance, connected),
        ..PaperDamper::default()
    }
    .hybrid()
}

pub fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

pub fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// The model file of a mechanism built by these helpers, from its name (a [`Shape`]'s
/// debug name, or `damper` for the paper's double bar).
pub fn model_file(name: &str) -> String {
    let root = env!("CARGO_MANIFEST_DIR");
    let (dir, file) = match name {
        "DoubleBarPin" | "DoubleBarRoller" | "damper" => ("../../models", "double_bar"),
        "SliderCrank" => ("../../models", "slider_crank"),
        "CarriageArm" => ("tests/fixtures", "carriage_arm"),
        "Chain3" => ("tests/fixtures", "chain3"),
        "FourBarArm" => ("tests/fixtures", "four_bar_arm"),
        other => panic!("no model file known for mechanism {other}"),
    };
    format!("{root}/{dir}/{file}.toml")
}

/// One exact tangent model per mechanism of `model` (default parameters plus `params`).
pub fn tangents(
    model: &HybridModel,
    params: &[(&str, f64)],
) -> Vec<mbs_symbolic::runtime::TangentSystem> {
    model
        .mechanisms
        .iter()
        .map(|m| {
            let file = model_file(&m.name);
            let mm = mbs_symbolic::model::load(Path::new(&file)).unwrap_or_else(|e| panic!("{e}"));
            let mut t = mbs_symbolic::runtime::TangentSystem::new(&mm);
            for &(name, value) in params {
                let _ = t.set_param(name, value);
            }
            t
        })
        .collect()
}
