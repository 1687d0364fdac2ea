//! The damper kind as a preset of the hybrid scenario (`scenario::preset`): a damper file
//! loads as the hybrid scenario it means — the same scenario, model and trajectory as the
//! hybrid file written out by hand — and its problems are reported at the damper file's
//! lines. (The trajectory of the paper's damper against the rank-one formulation and the
//! full system with multipliers is checked in hybrid-core's tests.)

use std::path::{Path, PathBuf};

use codegen_cli::scenario::{self, HybridScenario, Scenario};
use hybrid_core::hybrid::{HybridState, Integrator};

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

fn hybrid(text: &str) -> HybridScenario {
    match scenario::parse(text, &damper_file()).unwrap_or_else(|e| panic!("{e}")) {
        Scenario::Hybrid(sc) => *sc,
        _ => panic!("not a hybrid scenario"),
    }
}

/// `scenarios/damper.toml` written out as the hybrid scenario it means, with the values of
/// `generator` and `placement` given.
fn by_hand(placement: &str, generator: &str, integrator: &str) -> String {
    let damper = std::fs::read_to_string(damper_file()).unwrap();
    let beam = damper
        .split("[mechanism]")
        .next()
        .unwrap()
        .split("[beam]")
        .nth(1)
        .unwrap();
    format!(
        r#"kind = "hybrid"
description = "Steel cantilever with the double-bar amplified electromagnetic damper at its tip"
[beam]
{beam}
[[mechanism]]
name = "damper"
model = "../models/double_bar.toml"
placement = {{ attachment = "pin", {placement} }}
max_condition = 1e4

[[attachment]]
name = "pin"
mechanism = "damper"
point = "tip"
kind = "pin"
x = 1.0

[[force]]
name = "generator"
mechanism = "damper"
joint = "crank"
kind = "generator"
{generator}

[initial]
displacement = 0.001
x = 1.0

[integrator]
{integrator}

[output]
every = 10
compare = ["generator_disconnected", "bare_beam"]
"#
    )
}

const GENERATOR: &str = "kt = 0.0235\nke = 0.0235\narmature_resistance = 1.5\nload_resistance = 3.5\ninductance = 0.0\ngear_ratio = 5.0\nrotor_inertia = 1e-6";
const NEWMARK: &str = "method = \"newmark\"\ndt = 1e-4\nt_end = 5.0";

/// Steps `steps` times from the scenario's initial state.
fn steps(sc: &HybridScenario, steps: usize) -> HybridState {
    let built = codegen_cli::setup::build(sc).unwrap_or_else(|e| panic!("{e}"));
    let mut state = built.state.clone();
    let mut integ = Integrator::new(&built.model, sc.method, sc.integrator.dt, &state).unwrap();
    for _ in 0..steps {
        integ.step(&built.model, &mut state).unwrap();
    }
    state
}

/// The preset and the hybrid file written by hand: the same scenario (names, comparisons,
/// output), the same model and, bit for bit, the same trajectory.
fn same_as_by_hand(edits: &[(&str, &str)], placement: &str, generator: &str, integrator: &str) {
    let preset = hybrid(&edited(edits));
    let hand = hybrid(&by_hand(placement, generator, integrator));
    assert_eq!(preset.compare, hand.compare);
    assert_eq!(preset.every, hand.every);
    assert_eq!(preset.method, hand.method);
    assert_eq!(preset.integrator, hand.integrator);
    let names = |s: &HybridScenario| {
        (
            s.mechanisms
                .iter()
                .map(|m| m.name.clone())
                .collect::<Vec<_>>(),
            s.attachments
                .iter()
                .map(|a| a.name.clone())
                .collect::<Vec<_>>(),
        )
    };
    assert_eq!(names(&preset), names(&hand));
    let (a, b) = (steps(&preset, 300), steps(&hand, 300));
    assert_eq!(a.q, b.q);
    assert_eq!(a.v, b.v);
    assert_eq!(a.mechanisms[0].q, b.mechanisms[0].q);
    assert_eq!(a.currents, b.currents);
    assert!(a.q.iter().any(|x| *x != 0.0));
}

#[test]
fn the_damper_preset_is_the_hybrid_scenario_written_by_hand() {
    same_as_by_hand(&[], "half_angle_deg = 10.0", GENERATOR, NEWMARK);
}

#[test]
fn the_preset_carries_the_placement_generator_and_scheme() {
    same_as_by_hand(
        &[
            ("half_angle_deg = 10.0", "half_angle_deg = 20.0"),
            ("inductance = 0.0", "inductance = 0.01"),
            ("method = \"newmark\"", "method = \"hht\"\nalpha = -0.1"),
        ],
        "half_angle_deg = 20.0",
        &GENERATOR.replace("inductance = 0.0", "inductance = 0.01"),
        "method = \"hht\"\nalpha = -0.1\ndt = 1e-4\nt_end = 5.0",
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
    let sc = hybrid(&text);
    assert_eq!(
        sc.compare,
        vec![codegen_cli::scenario::Comparison::GeneratorDisconnected]
    );
    let hand = by_hand("pivot = [0.0, -0.19696]", GENERATOR, NEWMARK);
    let (a, b) = (steps(&sc, 50), steps(&hybrid(&hand), 50));
    assert_eq!(a.q, b.q);
    assert_eq!(a.mechanisms[0].q, b.mechanisms[0].q);
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
    let err = scenario::parse(&text, Path::new("scenarios/damper.toml"))
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
    let err = scenario::parse(&text, Path::new("d.toml"))
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
