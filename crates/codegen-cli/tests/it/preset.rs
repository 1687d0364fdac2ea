//! The damper kind as a preset of the hybrid scenario (`scenario::preset`): a damper file
//! read as the hybrid scenario it means builds the same coupled system as the damper
//! pipeline's own setup (`hybrid_core::study::prepare`), step for step; its problems are
//! reported at the damper file's lines.

use std::path::{Path, PathBuf};

use codegen_cli::scenario::{self, DamperScenario};
use hybrid_core::hybrid::{HybridModel, HybridState, Integrator};
use hybrid_core::study::prepare;

fn damper_file() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/damper.toml"
    ))
}

fn edited(edits: &[(&str, &str)]) -> String {
    let mut text = std::fs::read_to_string(damper_file()).unwrap();
    for (old, new) in edits {
        assert!(text.contains(old), "edit {old:?} does not apply");
        text = text.replacen(old, new, 1);
    }
    text
}

/// The damper pipeline's model and initial state.
fn old(text: &str) -> (HybridModel, HybridState, DamperScenario) {
    let sc = DamperScenario::from_str(text, &damper_file()).unwrap_or_else(|e| panic!("{e}"));
    let model = mbs_symbolic::model::load(&sc.model_path).unwrap();
    let system = model_registry::find_by_name("double_bar").unwrap().system();
    let p = prepare(&sc.setup, &model, system, true).unwrap_or_else(|e| panic!("{e}"));
    (p.hybrid, p.state, sc)
}

/// Relative difference of two vectors, scaled by the larger norm (1e-300 floor).
fn rel(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = a.iter().chain(b).fold(1e-300f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

/// The preset and the damper pipeline: the same system (sizes, names of the parts), the
/// same initial state and the same trajectory to 1e-12 of each block's largest entry over
/// `t_end`.
fn same_run(edits: &[(&str, &str)], t_end: f64) {
    let text = edited(edits);
    let (om, mut os, sc) = old(&text);
    let preset =
        scenario::parse_damper_as_hybrid(&text, &damper_file()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(preset.compare, sc.spec.output.compare, "comparison runs");
    assert_eq!(preset.every, sc.setup.every);
    let built = preset.build().unwrap_or_else(|e| panic!("{e}"));
    let (nm, mut ns) = (built.model, built.state);
    assert_eq!(nm.mechanisms.len(), 1);
    assert_eq!(nm.mechanisms[0].name, om.mechanisms[0].name);
    assert_eq!(nm.forces[0].joint, om.forces[0].joint);
    assert_eq!(nm.attachments[0].point, om.attachments[0].point);
    assert_eq!(ns.q.len(), os.q.len());
    let mut oi = Integrator::new(&om, sc.setup.method, sc.setup.dt, &os).unwrap();
    let mut ni = Integrator::new(&nm, preset.method, preset.integrator.dt, &ns).unwrap();
    let steps = (t_end / sc.setup.dt).round() as usize;
    let mut worst = [0.0f64; 4];
    for k in 0..=steps {
        if k > 0 {
            oi.step(&om, &mut os).unwrap();
            ni.step(&nm, &mut ns).unwrap();
        }
        assert_eq!(os.t, ns.t);
        worst[0] = worst[0].max(rel(&os.q, &ns.q));
        worst[1] = worst[1].max(rel(&os.v, &ns.v));
        worst[2] = worst[2].max(rel(&os.mechanisms[0].q, &ns.mechanisms[0].q));
        worst[3] = worst[3].max(rel(&os.currents, &ns.currents));
    }
    for (w, what) in worst
        .iter()
        .zip(["beam q", "beam v", "mechanism q", "current"])
    {
        assert!(*w <= 1e-12, "{edits:?}: {what} differs by {w:e}");
    }
}

#[test]
fn the_preset_runs_the_damper_pipeline_trajectory() {
    same_run(&[], 0.3);
}

#[test]
fn the_preset_runs_the_damper_pipeline_trajectory_at_20_and_5_degrees() {
    same_run(&[("half_angle_deg = 10.0", "half_angle_deg = 20.0")], 0.2);
    // At 5 degrees the double bar reaches 0.19 mm: released from 0.1 mm.
    same_run(
        &[
            ("half_angle_deg = 10.0", "half_angle_deg = 5.0"),
            ("displacement = 0.001", "displacement = 0.0001"),
        ],
        0.2,
    );
}

#[test]
fn the_preset_runs_the_damper_pipeline_trajectory_with_an_inductive_generator_and_hht() {
    same_run(
        &[
            ("inductance = 0.0", "inductance = 0.002"),
            ("method = \"newmark\"", "method = \"hht\"\nalpha = -0.1"),
            (
                "compare = [\"generator_disconnected\", \"bare_beam\"]",
                "compare_without_generator = true",
            ),
        ],
        0.2,
    );
}

#[test]
fn the_preset_with_a_pivot_and_defaults() {
    // `pivot` instead of `half_angle_deg`; `point` and `generator_joint` left to their
    // defaults; no [output] (one comparison by default).
    let text = edited(&[("half_angle_deg = 10.0", "pivot = [0.0, -0.19696]")])
        .replace("point = \"tip\"", "")
        .replace("generator_joint = \"crank\"", "");
    let text = text.split("[output]").next().unwrap().to_string();
    let (om, os, _) = old(&text);
    let built = scenario::parse_damper_as_hybrid(&text, &damper_file())
        .unwrap_or_else(|e| panic!("{e}"))
        .build()
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(rel(&os.q, &built.state.q) <= 1e-12);
    assert!(rel(&os.mechanisms[0].q, &built.state.mechanisms[0].q) <= 1e-12);
    assert_eq!(
        om.mechanisms[0].mount.origin,
        built.model.mechanisms[0].mount.origin
    );
}

/// Problems of a damper file are reported at the damper file's line and column, every one
/// at once, through the preset.
#[test]
fn preset_problems_name_the_damper_file_lines() {
    let text = edited(&[
        ("half_angle_deg = 10.0", "half_angle_deg = 95.0"),
        ("kt = 0.0235", "kt = -1.0"),
        ("x = 1.0 ", "x = 7.0 "),
        ("dt = 1e-4", "dt = -1.0"),
    ]);
    let line_of = |needle: &str| text.lines().position(|l| l.contains(needle)).unwrap() + 1;
    let err = scenario::parse_damper_as_hybrid(&text, Path::new("scenarios/damper.toml"))
        .unwrap_err()
        .to_string();
    for needle in ["half_angle_deg = 95.0", "kt = -1.0", "x = 7.0", "dt = -1.0"] {
        let at = format!("scenarios/damper.toml:{}:", line_of(needle));
        assert!(err.contains(&at), "{needle}: expected {at} in\n{err}");
    }
    // An unknown key inside a table is reported at its own line.
    let text = edited(&[(
        "max_condition = 1e4",
        "max_condition = 1e4\nmax_conditoin = 2",
    )]);
    let err = scenario::parse_damper_as_hybrid(&text, Path::new("d.toml"))
        .unwrap_err()
        .to_string();
    let line = text
        .lines()
        .position(|l| l.starts_with("max_conditoin"))
        .unwrap()
        + 1;
    assert!(err.contains(&format!("d.toml:{line}:")), "{err}");
    assert!(err.contains("max_conditoin"), "{err}");
}
