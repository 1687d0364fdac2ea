//! The one scenario loader: the bundled scenarios of both kinds load, and every problem of a
//! bad scenario is reported at once with file:line:column, for both kinds.

use crate::common;

use std::f64::consts::PI;
use std::path::Path;

use codegen_cli::scenario::{self, Scenario};
use diagnostic::Kind;
use hybrid_core::closed_loop::{AssemblyOptions, System, assemble};
use hybrid_core::hybrid::{Integrator, RunOptions, run};
use mbs_symbolic::model;

use common::root;

/// Generated code of a model under `models/`, from the model registry.
fn compiled(name: &str) -> Box<dyn System> {
    model_registry::find_by_name(name)
        .unwrap_or_else(|| panic!("models/{name} is compiled in"))
        .system()
}

fn four_bar() -> Box<dyn System> {
    compiled("four_bar")
}

fn slider_crank() -> Box<dyn System> {
    compiled("slider_crank")
}

/// Four-bar geometry of `models/four_bar.toml`: crank a, coupler b, rocker c, ground d.
const A: f64 = 0.10;
const B: f64 = 0.25;
const C: f64 = 0.20;
const D: f64 = 0.30;

/// Closed-form four-bar position: rocker angle q3 and relative coupler angle q2 for crank
/// angle q1 (`sign` selects the branch).
fn four_bar_closed_form(q1: f64, sign: f64) -> (f64, f64) {
    let p = 2.0 * C * (D - A * q1.cos());
    let q = -2.0 * A * C * q1.sin();
    let r = B * B - C * C - (D - A * q1.cos()).powi(2) - (A * q1.sin()).powi(2);
    let q3 = q.atan2(p) + sign * (r / p.hypot(q)).acos();
    let (ax, ay) = (A * q1.cos(), A * q1.sin());
    let (bx, by) = (D + C * q3.cos(), C * q3.sin());
    let theta2 = (by - ay).atan2(bx - ax);
    (q3, theta2 - q1)
}

/// Difference of two angles reduced to (-pi, pi].
fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(2.0 * PI);
    if d > PI { d - 2.0 * PI } else { d }
}

/// A mechanism scenario from a file (panics on any other kind or a problem).
fn mechanism_scenario(path: &Path) -> Box<scenario::MechanismScenario> {
    match scenario::load(path).unwrap_or_else(|e| panic!("{e}")) {
        Scenario::Mechanism(s) => s,
        _ => panic!("{}: not a mechanism scenario", path.display()),
    }
}

/// The bundled scenarios parse, resolve against their models and assemble; the four-bar
/// one names its initial branch correctly (upper branch of the closed form).
#[test]
fn bundled_scenarios_parse_and_assemble() {
    for (file, sys) in [
        (
            "scenarios/four_bar.toml",
            Box::new(four_bar()) as Box<dyn System>,
        ),
        (
            "scenarios/slider_crank.toml",
            Box::new(slider_crank()) as Box<dyn System>,
        ),
    ] {
        let sc = mechanism_scenario(&root().join(file));
        let model = model::load(&sc.model).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(model.dof(), sys.dof());
        let r = sc.resolve(sys.coordinate_names()).unwrap();
        let (q, qd) = assemble(
            &sys,
            &r.q0,
            &r.fixed,
            &r.qd0,
            &r.qd_given,
            &AssemblyOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{file}: {e}"));
        if file.contains("four_bar") {
            let (q3, q2) = four_bar_closed_form(q[0], 1.0);
            assert!(angle_diff(q[2], q3).abs() < 1e-10 && angle_diff(q[1], q2).abs() < 1e-10);
            assert!(qd.iter().all(|v| *v == 0.0));
        }
        assert!((r.settings.t_end - 5.0).abs() < 1e-15, "{file}: 5 s");
    }
}

/// The bundled damper scenario loads, and a damper scenario without `kind` is a damper.
#[test]
fn bundled_damper_scenario_loads_and_kind_defaults_to_damper() {
    let path = root().join("scenarios/damper.toml");
    // The damper kind is a preset: it loads as the hybrid scenario it means.
    let hybrid = |s: Scenario| match s {
        Scenario::Hybrid(s) => s,
        _ => panic!("the damper scenario loads as another kind"),
    };
    let sc = hybrid(scenario::load(&path).unwrap_or_else(|e| panic!("{e}")));
    assert_eq!(sc.integrator.dt, 1e-4);
    assert_eq!(sc.mechanisms.len(), 1);
    assert_eq!(sc.attachments.len(), 1);
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("kind = \"damper\""));
    let untagged = text.replacen("kind = \"damper\"", "", 1);
    let sc2 = hybrid(scenario::parse(&untagged, &path).unwrap_or_else(|e| panic!("{e}")));
    assert_eq!(sc2.integrator.t_end, sc.integrator.t_end);
}

/// A typo in the kind tag names the kinds there are, at the tag's line.
#[test]
fn unknown_kind_lists_the_kinds() {
    let e = scenario::parse(
        "kind = \"mechanizm\"\nmodel = \"x.toml\"\n",
        Path::new("s.toml"),
    )
    .unwrap_err();
    assert_eq!(e.len(), 1, "{e}");
    let d = &e.0[0];
    assert_eq!((d.line, d.column), (Some(1), Some(8)), "{e}");
    assert!(
        d.message
            .contains("unknown kind `mechanizm`, expected one of `damper`, `mechanism`"),
        "{e}"
    );
}

/// Line (1-based) of the first line of `text` that starts with `prefix`.
fn line_of(text: &str, prefix: &str) -> usize {
    text.lines()
        .position(|l| l.trim_start().starts_with(prefix))
        .unwrap()
        + 1
}

/// Every problem of a bad damper scenario, in different sections, at once, each with its
/// file:line:column.
#[test]
fn every_problem_of_a_bad_damper_scenario_is_reported_at_once() {
    let path = root().join("scenarios/damper.toml");
    let good = std::fs::read_to_string(&path).unwrap();
    let mut text = good.clone();
    for (old, new) in [
        ("gear_ratio = 5.0", "gear_ratio = 5.0\ngear_raito = 4.0"),
        ("dt = 1e-4", "dt = -1e-4"),
        ("half_angle_deg = 10.0", "half_angle_deg = 95.0"),
        ("every = 10", "every = 0"),
    ] {
        assert!(text.contains(old), "{old}");
        text = text.replacen(old, new, 1);
    }
    // The model files exist in `scenarios/` (the loader checks them).
    let e = scenario::parse_in(&text, "bad.toml", &root().join("scenarios")).unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.len(), 4, "{msg}");
    let expect = [
        (line_of(&text, "half_angle_deg"), "mechanism \"damper\""),
        (line_of(&text, "gear_raito"), "force \"generator\""),
        (line_of(&text, "dt ="), "[integrator] dt"),
        (line_of(&text, "every"), "[output] every"),
    ];
    for (d, (line, entity)) in e.iter().zip(expect) {
        assert_eq!(d.file, "bad.toml", "{msg}");
        assert_eq!(d.line, Some(line), "{entity}: {msg}");
        assert!(d.column.is_some(), "{msg}");
        assert_eq!(d.entity.as_deref(), Some(entity), "{msg}");
    }
    assert!(msg.contains("gear_raito"), "{msg}");
    assert!(
        msg.contains(&format!("bad.toml:{}:", line_of(&text, "dt ="))),
        "{msg}"
    );
    assert_eq!(e.0[1].kind, Kind::Syntax);
    assert_eq!(e.0[2].kind, Kind::InvalidValue);
}

/// Every problem of a bad mechanism scenario at once, each with file:line:column.
#[test]
fn every_problem_of_a_bad_mechanism_scenario_is_reported_at_once() {
    let path = root().join("scenarios/four_bar.toml");
    let good = std::fs::read_to_string(&path).unwrap();
    let mut text = good.clone();
    for (old, new) in [
        ("q = { q1 = 0.6 }", "q = { q1 = nan }"),
        ("t_end = 5.0", "t_end = 5.0\nt_ned = 4.0"),
    ] {
        assert!(text.contains(old), "{old}");
        text = text.replacen(old, new, 1);
    }
    text.push_str("\n[partitoin]\nrank_tol = 0.5\n");
    // The model files exist in `scenarios/` (the loader checks them).
    let e = scenario::parse_in(&text, "bad.toml", &root().join("scenarios")).unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.len(), 3, "{msg}");
    // A malformed section or an unknown one stops nothing else.
    let lines: Vec<usize> = e.iter().map(|d| d.line.unwrap()).collect();
    let expected = [
        line_of(&text, "q = "),
        line_of(&text, "t_ned"),
        line_of(&text, "[partitoin]"),
    ];
    assert_eq!(lines, expected, "{msg}");
    assert!(
        msg.contains("[initial] q.q1: must be a finite number"),
        "{msg}"
    );
    assert!(msg.contains("t_ned") && msg.contains("partitoin"), "{msg}");
    assert!(e.iter().all(|d| d.column.is_some()), "{msg}");
}

/// Every bundled scenario under `scenarios/` loads and runs a few hundred steps (the damper
/// and hybrid kinds 300 fixed steps, the mechanism kind 0.3 s of adaptive steps) with finite
/// results; a new scenario file is covered by being there.
#[test]
fn every_bundled_scenario_loads_and_runs_a_few_hundred_steps() {
    let files = common::bundled_scenarios();
    assert!(files.len() >= 5, "{files:?}");
    for path in &files {
        let name = path.display().to_string();
        match scenario::load(path).unwrap_or_else(|e| panic!("{e}")) {
            Scenario::Mechanism(mut sc) => {
                let model = model::load(&sc.model).unwrap();
                sc.settings.t_end = sc.settings.t_start + 0.3;
                let mut rows = 0;
                let o = codegen_cli::run::mechanism(&sc, &model, false, &mut |_, _, r| {
                    rows += 1;
                    assert!(r.q.iter().chain(&r.qd).all(|x| x.is_finite()), "{name}");
                })
                .unwrap_or_else(|e| panic!("{name}: {e}"));
                o.result.unwrap_or_else(|e| panic!("{name}: {e}"));
                assert!(rows > 10 && o.stats.steps_accepted > 10, "{name}");
            }
            Scenario::Hybrid(sc) => {
                let built = codegen_cli::setup::build(&sc).unwrap_or_else(|e| panic!("{e}"));
                let mut integrator =
                    Integrator::new(&built.model, sc.method, sc.integrator.dt, &built.state)
                        .unwrap();
                let mut rows = 0;
                let out = run::<()>(
                    &built.model,
                    &mut integrator,
                    built.state.clone(),
                    RunOptions {
                        t_end: 300.0 * sc.integrator.dt,
                        every: 30,
                    },
                    &mut |s, e, _| {
                        rows += 1;
                        let finite = s.q.iter().chain(&s.v).all(|x| x.is_finite())
                            && s.mechanisms
                                .iter()
                                .all(|m| m.q.iter().all(|x| x.is_finite()))
                            && e.total().is_finite();
                        assert!(finite, "{name} at t = {}", s.t);
                        Ok(())
                    },
                    &mut |_| {},
                )
                .unwrap_or_else(|e| panic!("{name}: {e:?}"));
                assert_eq!(out.figures.steps, 300, "{name}");
                assert_eq!(rows, 11, "{name}");
                assert!(
                    out.figures.balance_rel_error < 1e-3,
                    "{name}: {:?}",
                    out.figures
                );
            }
        }
    }
}

/// Linear-time input handling (issue 23, item 3): a damper scenario whose `compare` list
/// holds 10^6 entries, or whose pivot is a 10^6-element array, is refused naming the field
/// (measured by hand: under 1 s), and its error output stays short.
#[test]
fn a_scenario_with_a_million_element_array_is_refused() {
    let text = std::fs::read_to_string(root().join("scenarios/damper.toml")).unwrap();
    let base = root().join("scenarios");
    let compare = format!("compare = [{}]", vec!["\"bare_beam\""; 1_000_000].join(","));
    let numbers = format!("half_angle_deg = [{}]", vec!["10.0"; 1_000_000].join(","));
    for (from, to, needle) in [
        (
            "compare = [\"generator_disconnected\", \"bare_beam\"]",
            compare,
            "\"bare_beam\" is listed 1000000 times",
        ),
        ("half_angle_deg = 10.0", numbers, "[mechanism]"),
    ] {
        assert!(text.contains(from), "{from}");
        let big = text.replace(from, &to);
        let e = scenario::parse_in(&big, "big.toml", &base).unwrap_err();
        let shown = e.to_string();
        assert!(
            shown.starts_with("big.toml:") && shown.contains(needle),
            "{shown}"
        );
        assert!(
            shown.lines().count() <= diagnostic::MAX_SHOWN + 1,
            "{} lines",
            shown.lines().count()
        );
    }
}

/// `compare = ["bare_beam"]` needs a beam; a comparison listed twice is refused too.
#[test]
fn hybrid_comparisons_are_checked() {
    let text = "kind = \"hybrid\"\n[[mechanism]]\nname = \"p\"\nmodel = \"../models/pendulum.json\"\n[integrator]\ndt = 1e-3\nt_end = 0.1\n[output]\ncompare = [\"bare_beam\"]\n";
    let err = codegen_cli::scenario::parse(text, std::path::Path::new("scenarios/x.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("scenarios/x.toml:9:") && err.contains("needs a [beam]"),
        "{err}"
    );
    let two = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/two_dampers.toml"
    ))
    .unwrap()
    .replace(
        "compare = [\"generator_disconnected\", \"bare_beam\"]",
        "compare = [\"bare_beam\", \"bare_beam\"]",
    );
    let err = codegen_cli::scenario::parse(&two, std::path::Path::new("t.toml"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("listed twice"), "{err}");
}
