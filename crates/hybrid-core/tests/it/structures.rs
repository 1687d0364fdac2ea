//! The structure interface's three implementations agree: the beam (banded), the same beam
//! written out as Matrix Market files and read back as an imported sparse model, and the
//! Craig–Bampton reduction of that model with every fixed-interface mode kept (which spans
//! the whole space). Compared through the interface only: modes, the support load, and a
//! Newmark trajectory of the damped beam under a tip force, run by one generic integrator.

use std::path::Path;

use fem_beam::{Beam, BeamModel, Dof, TimeFunction};
use fem_structure::mtx::{SymTriplets, parse_matrix_market};
use fem_structure::tables::{parse_dofs, parse_nodes};
use fem_structure::{
    DampingInput, ImportedStructure, Reduced, beam_structure_files, craig_bampton,
};
use hybrid_core::hybrid::{
    Attachment, AttachmentKind, BeamPoint, Excitation, ExcitationTarget, ForceKind, HybridModel,
    HybridState, Integrator, JointForce, LinearStructure, Mount, MountedMechanism, Structure,
    initial_state,
};
use nalgebra::{DMatrix, DVector};

use crate::common::damper::{Geometry, PaperDamper};

fn beam() -> BeamModel {
    let text = r#"
[[segment]]
length = 1.2
youngs_modulus = 70e9
density = 2700.0
width = 0.03
height = 0.006
elements = 16
[[support]]
x = 0.0
kind = "clamped"
[damping]
ratios = [{ mode = 1, ratio = 0.02 }, { mode = 2, ratio = 0.01 }]
"#;
    BeamModel::new(&Beam::from_toml_str(text, "beam.toml").unwrap()).unwrap()
}

/// The beam written out by [`beam_structure_files`] (its banded matrices' lower triangles
/// as Matrix Market texts, its free DOFs as `uy` / `rz` of their nodes) and read back as an
/// imported model.
pub(crate) fn exported(b: &BeamModel) -> ImportedStructure {
    let files = beam_structure_files(b);
    let read = |t: &str, f: &str| parse_matrix_market(t, f).unwrap();
    let nodes = parse_nodes(&files.nodes, "nodes.csv").unwrap();
    let dofs = parse_dofs(&files.dofs, "dofs.csv", b.dof_count(), &nodes).unwrap();
    let damping = files.damping.as_deref().expect("the beam is damped");
    ImportedStructure::from_parts(
        read(&files.mass, "M.mtx"),
        read(&files.stiffness, "K.mtx"),
        Some(read(damping, "C.mtx")),
        &DampingInput::Matrix("C.mtx".into()),
        nodes,
        dofs,
        (Path::new("M.mtx"), Path::new("K.mtx")),
    )
    .unwrap()
}

/// Average-acceleration Newmark of `A q'' + B q' + C q = f` from rest, through the
/// interface only; the state every 20 steps.
fn newmark<S: LinearStructure>(s: &S, f: &[f64], h: f64, steps: usize) -> Vec<Vec<f64>> {
    let n = s.dof_count();
    let (beta, gamma) = (0.25, 0.5);
    let mass = s.factorize_newmark(0.0, 0.0).unwrap();
    let k = s.factorize_newmark(gamma * h, beta * h * h).unwrap();
    let (mut q, mut v, mut a) = (vec![0.0; n], vec![0.0; n], f.to_vec());
    S::solve_in_place(&mass, &mut a);
    let mut out = Vec::new();
    let (mut qh, mut vh, mut r) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for step in 1..=steps {
        for i in 0..n {
            qh[i] = q[i] + h * v[i] + h * h * (0.5 - beta) * a[i];
            vh[i] = v[i] + h * (1.0 - gamma) * a[i];
        }
        r.copy_from_slice(f);
        s.damping_mul_add(-1.0, &vh, &mut r);
        s.stiffness_mul_add(-1.0, &qh, &mut r);
        S::solve_in_place(&k, &mut r);
        a.copy_from_slice(&r);
        for i in 0..n {
            q[i] = qh[i] + beta * h * h * a[i];
            v[i] = vh[i] + gamma * h * a[i];
        }
        if step % 20 == 0 {
            out.push(q.clone());
        }
    }
    out
}

fn max_abs(x: &[Vec<f64>]) -> f64 {
    x.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()))
}

#[test]
fn the_beam_its_matrix_export_and_its_reduction_agree() {
    let b = beam();
    let s = exported(&b);
    let n = b.dof_count();
    assert_eq!(LinearStructure::dof_count(&s), n);
    let tip = b.dof_index(16, Dof::Transverse).unwrap();

    // Modes (the beam's own solver vs shift-invert subspace iteration on the sparse model).
    let mb = LinearStructure::modes(&b, 4).unwrap();
    let ms = LinearStructure::modes(&s, 4).unwrap();
    for (x, y) in mb.eigenvalues.iter().zip(&ms.eigenvalues) {
        assert!((x - y).abs() < 1e-10 * x, "{x} vs {y}");
    }

    // The support load -A r along y.
    let pb = b.base_load([0.0, 1.0]);
    let ps = s.base_load([0.0, 1.0]);
    let scale = pb.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (x, y) in pb.iter().zip(&ps) {
        assert!((x - y).abs() <= 1e-14 * scale, "{x} vs {y}");
    }

    // A Newmark trajectory under a 2 N step force at the tip.
    let mut f = vec![0.0; n];
    f[tip] = 2.0;
    let (h, steps) = (2e-4, 2000);
    let tb = newmark(&b, &f, h, steps);
    let ts = newmark(&s, &f, h, steps);
    let amp = max_abs(&tb);
    assert!(amp > 1e-4, "the tip moves: {amp}");
    for (x, y) in tb.iter().flatten().zip(ts.iter().flatten()) {
        assert!((x - y).abs() <= 1e-10 * amp, "{x} vs {y}");
    }

    // Craig–Bampton on the tip DOF with every interior mode: the same trajectory, mapped
    // back q = T z, and the same modes.
    let r = craig_bampton(&s.stiffness, &s.mass, s.damping.as_ref(), &[tip], n - 1).unwrap();
    assert_eq!(LinearStructure::dof_count(&r), n);
    let fr = r.transform.transpose() * DVector::from_column_slice(&f);
    let tr = newmark(&r, fr.as_slice(), h, steps);
    for (x, z) in tb.iter().zip(&tr) {
        let q = r.expand(z);
        for (a, c) in x.iter().zip(&q) {
            assert!((a - c).abs() <= 1e-9 * amp, "{a} vs {c}");
        }
    }
    let mr = LinearStructure::modes(&r, 4).unwrap();
    for (x, y) in mb.eigenvalues.iter().zip(&mr.eigenvalues) {
        assert!((x - y).abs() < 1e-9 * x, "{x} vs {y}");
    }
}

/// The paper's damper on its beam, on the beam exported as an imported sparse model, and on
/// that model's Craig–Bampton reduction with every mode kept (interface: the attachment
/// point's DOFs): the same engine, the same trajectory — every beam DOF
/// and every mechanism coordinate over 0.2 s (2,000 steps through the toggle's
/// amplification) to 1e-10 of their amplitude (1e-9 for the reduction, whose transform
/// comes from an eigen-decomposition).
#[test]
fn the_damper_runs_the_same_on_every_kind_of_structure() {
    let paper = PaperDamper {
        t_end: 0.2,
        ..PaperDamper::default()
    };
    let (beam_model, q0) = paper.hybrid();
    let beam = beam_model.beam().unwrap().clone();
    let n = q0.len();
    let steps = 2000;
    let run = |model: &HybridModel, q0: Vec<f64>| -> Vec<HybridState> {
        let mut state = initial_state(model, q0, vec![0.0; n]).unwrap();
        let mut integrator = Integrator::new(model, paper.method, paper.dt, &state).unwrap();
        let mut out = vec![state.clone()];
        for k in 1..=steps {
            integrator.step(model, &mut state).unwrap();
            if k % 100 == 0 {
                out.push(state.clone());
            }
        }
        out
    };
    let reference = run(&beam_model, q0.clone());
    let amp = |f: &dyn Fn(&HybridState) -> &[f64]| {
        reference
            .iter()
            .flat_map(|s| f(s).iter())
            .fold(0.0f64, |m, v| m.max(v.abs()))
    };
    let (q_amp, m_amp) = (amp(&|s| &s.q), amp(&|s| &s.mechanisms[0].q));
    assert!(q_amp > 1e-3, "the beam moves: {q_amp}");

    // Imported: the same coordinates, the same point weights.
    let mut imported = beam_model.clone();
    imported.structure = Some(Structure::Imported(exported(&beam)));
    let other = run(&imported, q0.clone());
    for (a, b) in reference.iter().zip(&other) {
        for (x, y) in a.q.iter().zip(&b.q) {
            assert!((x - y).abs() <= 1e-10 * q_amp, "t = {}: {x} vs {y}", a.t);
        }
        for (x, y) in a.mechanisms[0].q.iter().zip(&b.mechanisms[0].q) {
            assert!((x - y).abs() <= 1e-10 * m_amp, "t = {}: {x} vs {y}", a.t);
        }
    }

    // Craig–Bampton with every mode: z = T^-1 q.
    let (reduced, r) = reduced_variant(&beam_model, n);
    let t_inv: DMatrix<f64> = r.transform.clone().try_inverse().unwrap();
    let z0 = (&t_inv * DVector::from_column_slice(&q0))
        .as_slice()
        .to_vec();
    let other = run(&reduced, z0);
    for (a, b) in reference.iter().zip(&other) {
        let q = r.expand(&b.q);
        for (x, y) in a.q.iter().zip(&q) {
            assert!((x - y).abs() <= 1e-9 * q_amp, "t = {}: {x} vs {y}", a.t);
        }
        for (x, y) in a.mechanisms[0].q.iter().zip(&b.mechanisms[0].q) {
            assert!((x - y).abs() <= 1e-9 * m_amp, "t = {}: {x} vs {y}", a.t);
        }
    }
}

/// `model` (the damper on its beam, one attachment) with the beam replaced by its
/// export's Craig–Bampton reduction keeping `modes` fixed-interface modes (capped at the
/// interior DOFs): the attachment point's DOFs are the interface, the first reduced
/// coordinates in their sorted order, so the point keeps its weights on them.
pub(crate) fn reduced_variant(model: &HybridModel, modes: usize) -> (HybridModel, Reduced) {
    let beam = model.beam().expect("a beam host");
    let s = exported(beam);
    let point = &model.attachments[0].beam;
    let mut interface: Vec<usize> = point.weights.iter().map(|w| w.0).collect();
    interface.sort_unstable();
    let interior = beam.dof_count() - interface.len();
    let r = craig_bampton(
        &s.stiffness,
        &s.mass,
        s.damping.as_ref(),
        &interface,
        modes.min(interior),
    )
    .unwrap();
    assert_eq!(r.interface, interface);
    let mut reduced = model.clone();
    reduced.attachments[0].beam = BeamPoint {
        x: point.x,
        y: 0.0,
        axial: vec![],
        weights: point
            .weights
            .iter()
            .map(|&(k, w)| (interface.iter().position(|&i| i == k).unwrap(), w))
            .collect(),
        direction: [0.0, 1.0],
    };
    reduced.structure = Some(Structure::Reduced {
        full: Box::new(s),
        reduced: Box::new(r.clone()),
    });
    (reduced, r)
}

/// A one-node structure (mass `m` on springs `k[0]`, `k[1]` along its two equations) whose
/// equation 0 is the node's `first` translation (`ux` or `uy`) and equation 1 the other.
pub(crate) fn one_node(m: f64, k: [f64; 2], first: &str) -> ImportedStructure {
    let second = if first == "ux" { "uy" } else { "ux" };
    node_on_springs(m, &[(first, k[0]), (second, k[1])])
}

/// Node 7 at the origin with mass `m` on each of its equations, equation `i` the node's
/// translation `springs[i].0` on a spring of stiffness `springs[i].1`; the translations not
/// listed are held.
pub(crate) fn node_on_springs(m: f64, springs: &[(&str, f64)]) -> ImportedStructure {
    let n = springs.len();
    let diag = |v: &dyn Fn(usize) -> f64| SymTriplets {
        n,
        lower: (0..n).map(|i| (i, i, v(i))).collect(),
    };
    let nodes = parse_nodes("id,x,y\n7,0,0\n", "nodes.csv").unwrap();
    let mut table = String::from("eq,node,dof\n");
    for (i, (dof, _)) in springs.iter().enumerate() {
        table += &format!("{i},7,{dof}\n");
    }
    let dofs = parse_dofs(&table, "dofs.csv", n, &nodes).unwrap();
    ImportedStructure::from_parts(
        diag(&|_| m),
        diag(&|i| springs[i].1),
        None,
        &DampingInput::None,
        nodes,
        dofs,
        (Path::new("M.mtx"), Path::new("K.mtx")),
    )
    .unwrap()
}

/// The paper's double bar (no gravity) on node 7 of [`one_node`] (mass 2 kg, springs 4e4
/// and 1e5 N/m along `x` and `y`) by `kind` (a roller following `direction`; a pin ignores
/// it), its generator on the crank; `turned`: the same physical system turned by 90 degrees
/// (equations `uy`, `ux`, the mount turned, the roller's direction turned by the caller).
pub(crate) fn damper_on_node(
    paper: &PaperDamper,
    kind: AttachmentKind,
    direction: [f64; 2],
    turned: bool,
) -> HybridModel {
    let (first, (ux, uy)) = if turned {
        ("uy", (1, 0))
    } else {
        ("ux", (0, 1))
    };
    let point = BeamPoint::node([0.0, 0.0], Some(ux), Some(uy));
    let point = match kind {
        AttachmentKind::Pin => point,
        AttachmentKind::Roller => point.along(direction),
    };
    let mount = |g: &Geometry| {
        let origin = [-g.target[0], -g.target[1]];
        match turned {
            true => Mount {
                origin: [-origin[1], origin[0]],
                angle: std::f64::consts::FRAC_PI_2,
            },
            false => Mount { origin, angle: 0.0 },
        }
    };
    double_bar_on(paper, one_node(2.0, [4e4, 1e5], first), mount, kind, point).0
}

/// The paper's double bar attached to `structure` at `point` by `kind`, mounted by
/// `mount(geometry)` (the geometry of its placement on the paper's beam), its generator on
/// the crank; and that geometry.
pub(crate) fn double_bar_on(
    paper: &PaperDamper,
    structure: ImportedStructure,
    mount: impl FnOnce(&Geometry) -> Mount,
    kind: AttachmentKind,
    point: BeamPoint,
) -> (HybridModel, Geometry) {
    let system = paper.with_parameters(crate::common::damper::double_bar());
    let g = paper.geometry(&paper.beam(), system.as_ref());
    let model = HybridModel::new(
        Some(Structure::Imported(structure)),
        vec![MountedMechanism {
            name: "damper".into(),
            system,
            mount: mount(&g),
            max_condition: paper.max_condition,
            reach: None,
            initial_q: g.guess.to_vec(),
        }],
        vec![Attachment {
            name: "tip".into(),
            mechanism: 0,
            point: g.tip,
            kind,
            beam: point,
        }],
        vec![JointForce {
            name: "generator".into(),
            mechanism: 0,
            joint: g.joint,
            kind: ForceKind::Generator(paper.generator.clone()),
        }],
        vec![],
    )
    .unwrap();
    (model, g)
}

/// 0.3 s of `model` from rest at `q0` by the paper's method and step, a state every 50 steps.
fn sampled(paper: &PaperDamper, model: &HybridModel, q0: Vec<f64>) -> Vec<HybridState> {
    let mut state = initial_state(model, q0, vec![0.0; 2]).unwrap();
    let mut integrator = Integrator::new(model, paper.method, paper.dt, &state).unwrap();
    let mut out = vec![state.clone()];
    for k in 1..=3000 {
        integrator.step(model, &mut state).unwrap();
        if k % 50 == 0 {
            out.push(state.clone());
        }
    }
    out
}

/// The paper's damper without gravity (the node tests' mechanism).
pub(crate) fn weightless_paper() -> PaperDamper {
    PaperDamper {
        parameters: vec![("gx", 0.0), ("gy", 0.0)],
        ..PaperDamper::default()
    }
}

/// A node that moves along both axes, with the double bar pinned to it: the pin couples
/// through both of its rows (the `y` row as on the beam, the `x` row as well). The same
/// physical system turned by 90 degrees — the structure's equations now `uy`, `ux`, the
/// mechanism's mount turned with it — swaps the roles of the two rows; its trajectory must be
/// the first one turned (equation 0 equal, equation 1 of opposite sign, the mechanism's
/// coordinates equal) to round-off (1e-9 of the amplitudes over 0.3 s through the generator's
/// damping). The supports shake along a direction `[0.6, 0.8]`, turned with the rest
/// (`[-0.8, 0.6]`): the structure's inertial load and the mechanism's ground motion follow
/// the direction (docs/theory.md section 13.6).
#[test]
fn a_pin_on_a_node_couples_both_directions() {
    let paper = weightless_paper();
    let build = |turned: bool| -> (HybridModel, Vec<f64>) {
        let q0 = if turned {
            vec![1e-3, -4e-4]
        } else {
            vec![1e-3, 4e-4]
        };
        let direction = if turned { [-0.8, 0.6] } else { [0.6, 0.8] };
        let shake = Excitation {
            name: "base".into(),
            target: ExcitationTarget::Base { direction },
            amplitude: 3.0,
            time: TimeFunction::Harmonic {
                frequency_hz: 17.0,
                phase: 0.3,
            },
        };
        let mut model = damper_on_node(&paper, AttachmentKind::Pin, [0.0, 1.0], turned);
        model.excitations.push(shake);
        (model, q0)
    };
    let run = |(model, q0): (HybridModel, Vec<f64>)| -> Vec<HybridState> {
        assert_eq!(model.couplings().len(), 2, "the pin couples both rows");
        sampled(&paper, &model, q0)
    };
    let a = run(build(false));
    let b = run(build(true));
    let amp = |i: usize| a.iter().fold(0.0f64, |m, s| m.max(s.q[i].abs()));
    let mamp = a
        .iter()
        .flat_map(|s| s.mechanisms[0].q.iter())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    // Both directions move and the generator damps the motion.
    assert!(amp(0) > 5e-4 && amp(1) > 2e-4, "{} {}", amp(0), amp(1));
    let last = a.last().unwrap();
    assert!(last.account.dissipated[0] > 0.0);
    for (x, y) in a.iter().zip(&b) {
        assert!((x.q[0] - y.q[0]).abs() <= 1e-9 * amp(0), "t = {}", x.t);
        assert!((x.q[1] + y.q[1]).abs() <= 1e-9 * amp(1), "t = {}", x.t);
        for (p, r) in x.mechanisms[0].q.iter().zip(&y.mechanisms[0].q) {
            assert!((p - r).abs() <= 1e-9 * mamp, "t = {}: {p} vs {r}", x.t);
        }
    }
}

/// A roller at a node along a direction `d` couples the node's displacement along `d` only
/// (one row, one coupling). Checked against two other formulations of the same system:
/// the system turned by 90 degrees (the structure's equations `uy`, `ux`, the mechanism's
/// mount and the roller's direction `[0, 1] -> [-1, 0]` turned with it) gives the turned
/// trajectory to 1e-9 of the amplitudes; and the node's motion across `d` does not reach
/// the mechanism (the same run with a different initial `ux` gives the same `uy` and
/// mechanism coordinates to the last bit).
#[test]
fn a_roller_on_a_node_follows_its_direction_only() {
    let paper = weightless_paper();
    let build = |turned: bool| -> HybridModel {
        let direction = if turned { [-1.0, 0.0] } else { [0.0, 1.0] };
        damper_on_node(&paper, AttachmentKind::Roller, direction, turned)
    };
    let run = |model: HybridModel, q0: Vec<f64>| -> Vec<HybridState> {
        assert_eq!(model.couplings().len(), 1, "a roller couples one row");
        sampled(&paper, &model, q0)
    };
    let a = run(build(false), vec![1e-3, 4e-4]);
    let b = run(build(true), vec![1e-3, -4e-4]);
    let c = run(build(false), vec![-3e-3, 4e-4]);
    let amp = |i: usize| a.iter().fold(0.0f64, |m, s| m.max(s.q[i].abs()));
    let mamp = a
        .iter()
        .flat_map(|s| s.mechanisms[0].q.iter())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(amp(0) > 5e-4 && amp(1) > 2e-4, "{} {}", amp(0), amp(1));
    assert!(a.last().unwrap().account.dissipated[0] > 0.0);
    for ((x, y), z) in a.iter().zip(&b).zip(&c) {
        assert!((x.q[0] - y.q[0]).abs() <= 1e-9 * amp(0), "t = {}", x.t);
        assert!((x.q[1] + y.q[1]).abs() <= 1e-9 * amp(1), "t = {}", x.t);
        for (p, r) in x.mechanisms[0].q.iter().zip(&y.mechanisms[0].q) {
            assert!((p - r).abs() <= 1e-9 * mamp, "t = {}: {p} vs {r}", x.t);
        }
        assert_eq!(x.q[1], z.q[1], "t = {}: ux reached the mechanism", x.t);
        assert_eq!(x.mechanisms[0].q, z.mechanisms[0].q, "t = {}", x.t);
    }
}
