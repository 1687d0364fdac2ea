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

/// A model the preset cannot place (a double bar given a third body) is refused with one
/// line naming the scenario line and the model's coordinate count.
#[test]
fn a_mechanism_of_the_wrong_shape_is_refused_in_one_line() {
    let dir = std::env::temp_dir().join(format!("damper-preset-shape-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let root = crate::common::root();
    let model = std::fs::read_to_string(root.join("models/double_bar.toml"))
        .unwrap()
        .replace(
            "[[points]]",
            "[[bodies]]\nname = \"third\"\nparent = \"coupler\"\njoint = \"R3\"\nanchor = [\"L2\", 0, 0]\nmass = \"m2\"\ncom = [\"L2/2\", 0, 0]\ninertia = { xx = 0, yy = \"m2*L2^2/12\", zz = \"m2*L2^2/12\" }\n\n[[points]]",
        );
    std::fs::write(dir.join("triple_bar.toml"), model).unwrap();
    let text = edited(&[(
        "model = \"../models/double_bar.toml\"",
        "model = \"triple_bar.toml\"",
    )]);
    // At the damper file's [mechanism] table, where the placement is asked for.
    let line = 1 + text.lines().position(|l| l == "[mechanism]").unwrap();
    let sc = dir.join("damper.toml");
    std::fs::write(&sc, &text).unwrap();
    let err = crate::common::assert_bad_input(
        &[
            "simulate",
            sc.to_str().unwrap(),
            "-o",
            dir.join("out").to_str().unwrap(),
        ],
        &["3 coordinate(s)", "two-bar chain"],
    );
    assert!(err.contains(&format!("damper.toml:{line}:")), "{err}");
    assert!(!dir.join("out").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The last row of a CSV time history as `(header, values)`.
fn last_row(path: &Path) -> Vec<(String, f64)> {
    let text = std::fs::read_to_string(path).unwrap();
    let header: Vec<String> = text
        .lines()
        .next()
        .unwrap()
        .split(',')
        .map(String::from)
        .collect();
    let last = text.lines().last().unwrap();
    header
        .into_iter()
        .zip(last.split(',').map(|c| c.parse().unwrap_or(f64::NAN)))
        .collect()
}

fn cell(row: &[(String, f64)], name: &str) -> f64 {
    row.iter()
        .find(|(h, _)| h == name)
        .unwrap_or_else(|| panic!("no column {name}"))
        .1
}

/// A viscous damper on the crank written in the mechanism's model file (a model-level
/// force element) and the same damper written as a scenario force element: the same
/// trajectory, the same dissipated energy (`damper.dissipated_model` against
/// `crank_damper.dissipated`), and both energy balances closed.
#[test]
fn a_model_level_damper_closes_the_energy_balance_like_a_scenario_damper() {
    let dir = std::env::temp_dir().join(format!("damper-model-damper-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let root = crate::common::root();
    let c = 0.002; // N m s/rad: about as much as the generator's electrical damping
    let model = std::fs::read_to_string(root.join("models/double_bar.toml")).unwrap()
        + &format!(
            "\n[[forces]]\ntype = \"joint\"\nname = \"crank_damper\"\nbody = \"crank\"\ndamping = {c}\n"
        );
    let damped = dir.join("double_bar_damped.toml");
    std::fs::write(&damped, model).unwrap();
    let model_level = edited(&[(
        "model = \"../models/double_bar.toml\"",
        &format!("model = {:?}", damped.to_str().unwrap()),
    )]);
    let bare_model = root.join("models/double_bar.toml");
    let scenario_level = by_hand("half_angle_deg = 10.0", GENERATOR, NEWMARK).replace(
        "model = \"../models/double_bar.toml\"",
        &format!("model = {:?}", bare_model.to_str().unwrap()),
    ) + &format!(
        "\n[[force]]\nname = \"crank_damper\"\nmechanism = \"damper\"\njoint = \"crank\"\nkind = \"damper\"\nc = {c}\n"
    );
    let mut rows = vec![];
    for (name, text) in [("model", model_level), ("scenario", scenario_level)] {
        let sc = dir.join(format!("{name}.toml"));
        std::fs::write(&sc, text).unwrap();
        let out = dir.join(format!("out_{name}"));
        let (code, _, err) = crate::common::damper(&[
            "simulate",
            sc.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--quiet",
            "--set",
            "integrator.t_end=1.0",
        ]);
        assert_eq!(code, 0, "{name}: {err}");
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
                .unwrap();
        let balance = summary["energy_balance_rel_error"].as_f64().unwrap();
        assert!(balance < 1e-5, "{name}: energy balance {balance}");
        rows.push((last_row(&out.join("time_history.csv")), summary));
    }
    let (model_row, model_summary) = &rows[0];
    let (scenario_row, _) = &rows[1];
    let by_model = cell(model_row, "damper.dissipated_model [J]");
    let by_scenario = cell(scenario_row, "crank_damper.dissipated [J]");
    let initial = model_summary["energy"]["initial"].as_f64().unwrap();
    // A significant share of the initial energy: leaving it out would open the balance.
    assert!(by_model > 0.05 * initial, "{by_model} of {initial}");
    assert!(
        (by_model - by_scenario).abs() <= 1e-9 * by_scenario,
        "{by_model} vs {by_scenario}"
    );
    // The summary's value is the last row's (both written in shortest round-trip form),
    // read back to within one unit in the last place: serde_json's default float parser is
    // not correctly rounded (the summary's 0.00021818255781129954 read as
    // 0.00021818255781129952, where `str::parse` reads the CSV's same text exactly).
    let summary_value = model_summary["energy"]["dissipated_model"]["damper"]
        .as_f64()
        .unwrap();
    assert!(
        (summary_value - by_model).abs() <= f64::EPSILON * by_model.abs(),
        "{summary_value} vs {by_model}"
    );
    for col in ["pin.w [m]", "damper.q1 [rad]", "generator.dissipated [J]"] {
        let (a, b) = (cell(model_row, col), cell(scenario_row, col));
        assert!(
            (a - b).abs() <= 1e-9 * a.abs().max(1e-12),
            "{col}: {a} vs {b}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The damper kind takes `[[excitation]]` as the hybrid kind writes it (and then no
/// `[initial]`): the paper's damper under the forced damper's harmonic tip force gives the
/// outputs of `scenarios/forced_damper.toml` (its hybrid form) bit for bit — every cell of
/// the time history and the summary's figures — apart from the attachment's name.
#[test]
fn a_damper_kind_with_an_excitation_is_its_hybrid_form_bit_for_bit() {
    let root = damper_file()
        .parent()
        .unwrap()
        .parent()
        .unwrap()
        .to_path_buf();
    let model = root.join("models/double_bar.toml").canonicalize().unwrap();
    let model = format!("\"{}\"", model.display());
    let forced = std::fs::read_to_string(root.join("scenarios/forced_damper.toml")).unwrap();
    let excitation =
        &forced[forced.find("[[excitation]]").unwrap()..forced.find("[integrator]").unwrap()];
    let mut damper_kind = std::fs::read_to_string(damper_file()).unwrap();
    let initial = damper_kind.find("[initial]").unwrap();
    let integrator = damper_kind.find("[integrator]").unwrap();
    damper_kind.replace_range(initial..integrator, excitation);
    let damper_kind = damper_kind
        .replace("\"../models/double_bar.toml\"", &model)
        .replace(
            "compare = [\"generator_disconnected\", \"bare_beam\"]",
            "compare = []",
        );
    assert!(
        damper_kind.contains("kind = \"damper\"")
            && !damper_kind.lines().any(|l| l.starts_with("[initial]"))
    );
    let hybrid_kind = forced
        .replace("\"../models/double_bar.toml\"", &model)
        .replace("tip_pin", "pin");
    let dir = std::env::temp_dir().join(format!("preset_excitation_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut outputs = vec![];
    for (name, text) in [("damper_kind", &damper_kind), ("hybrid_kind", &hybrid_kind)] {
        let file = dir.join(format!("{name}.toml"));
        std::fs::write(&file, text).unwrap();
        let out = dir.join(name);
        let (code, _, err) = crate::common::damper(&[
            "simulate",
            file.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert_eq!(code, 0, "{name}: {err}");
        let csv = std::fs::read_to_string(out.join("time_history.csv")).unwrap();
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
                .unwrap();
        outputs.push((csv, summary));
    }
    let ((csv_d, sum_d), (csv_h, sum_h)) = (&outputs[0], &outputs[1]);
    assert!(
        csv_d.lines().count() > 5000,
        "a 5 s run at a row a millisecond"
    );
    assert!(csv_d == csv_h, "the time histories differ");
    for figure in ["peak_amplitude", "generators", "steady_power", "energy"] {
        assert_eq!(sum_d[figure], sum_h[figure], "summary {figure}");
    }
    assert!(
        sum_d["steady_power"].is_object(),
        "a forced run's steady power"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `scenario::parse_with` of `text` (a file beside `scenarios/damper.toml`) with `--set`
/// options, as the hybrid scenario it means.
fn hybrid_with(text: &str, sets: &[String]) -> HybridScenario {
    let overrides: Vec<scenario::Override> = sets.iter().map(|s| s.parse().unwrap()).collect();
    match scenario::parse_with(text, &damper_file(), &overrides) {
        Ok(l) => match l.scenario {
            Scenario::Hybrid(sc) => *sc,
            _ => panic!("not a hybrid scenario"),
        },
        Err(e) => panic!("{sets:?}: {e}"),
    }
}

/// Every (damper path, hybrid path) pair the preset moves fields by is one field: the damper
/// path set on the damper file and the hybrid path set on its hybrid form (to a value that
/// changes the scenario where one can) both load, and give the same model and, bit for bit,
/// the same trajectory; each path translates into the other.
#[test]
fn every_preset_path_pair_is_accepted_by_set_on_its_kind_and_means_the_same_field() {
    use codegen_cli::scenario::preset::{PATHS, translate};
    // A value for each pair (a leaf below a whole table for `generator`); a new pair
    // needs its value here.
    let value = |damper: &str| match damper {
        "mechanism.model" => ("", "\"../models/double_bar.toml\""),
        "mechanism.parameters" => ("", "{ m1 = 0.03 }"),
        "mechanism.max_condition" => ("", "2e4"),
        "mechanism.half_angle_deg" => ("", "12.0"),
        "mechanism.pivot" => ("", "[0.0, -0.19]"),
        "mechanism.point" => ("", "\"tip\""),
        "mechanism.x" => ("", "1.0"),
        "mechanism.generator_joint" => ("", "\"crank\""),
        "generator" => (".load_resistance", "5.0"),
        other => panic!("no test value for the preset's path `{other}`"),
    };
    for (damper, hybrid_path) in PATHS {
        let (below, v) = value(damper);
        let (d, h) = (format!("{damper}{below}"), format!("{hybrid_path}{below}"));
        assert_eq!(translate(&d, true).as_deref(), Some(h.as_str()));
        assert_eq!(translate(&h, false).as_deref(), Some(d.as_str()));
        // `pivot` replaces `half_angle_deg`: both forms start from a pivot.
        let pivot = damper.ends_with("pivot");
        let (damper_text, placement) = if pivot {
            (
                edited(&[("half_angle_deg = 10.0", "pivot = [0.0, -0.19696]")]),
                "pivot = [0.0, -0.19696]",
            )
        } else {
            (edited(&[]), "half_angle_deg = 10.0")
        };
        let hand = by_hand(placement, GENERATOR, NEWMARK);
        let a = hybrid_with(&damper_text, &[format!("{d}={v}")]);
        let b = hybrid_with(&hand, &[format!("{h}={v}")]);
        let (sa, sb) = (steps(&a, 50), steps(&b, 50));
        assert_eq!(sa.q, sb.q, "{d} / {h}");
        assert_eq!(sa.mechanisms[0].q, sb.mechanisms[0].q, "{d} / {h}");
        assert_eq!(sa.currents, sb.currents, "{d} / {h}");
        // The value reached the model: a changed one changes the trajectory.
        if matches!(v, "12.0" | "5.0" | "{ m1 = 0.03 }" | "[0.0, -0.19]") {
            let base = hybrid_with(&damper_text, &[]);
            assert_ne!(steps(&base, 50).mechanisms[0].q, sa.mechanisms[0].q, "{d}");
        }
    }
    assert_eq!(translate("beam.segment[0].elements", true), None);
    assert_eq!(translate("generatorx.kt", true), None);
}

/// A `--set` path of the other kind is answered with this kind's path, both ways; a typo in
/// a `--set` path or in a file's field is answered with the nearest names; one line each,
/// naming the file and the option or line.
#[test]
fn paths_of_the_other_kind_and_typos_get_did_you_mean() {
    use crate::common::assert_bad_input;
    let out = std::env::temp_dir().join(format!("damper-didyoumean-{}", std::process::id()));
    let out = out.to_str().unwrap();
    let cases: [(&str, &str, &[&str]); 6] = [
        (
            "scenarios/forced_damper.toml",
            "generator.load_resistance=3",
            &[
                "scenarios/forced_damper.toml",
                "--set generator.load_resistance=3",
                "did you mean `force[0].load_resistance`?",
            ],
        ),
        (
            "scenarios/forced_damper.toml",
            "mechanism.half_angle_deg=12",
            &["did you mean `mechanism[0].placement.half_angle_deg`?"],
        ),
        (
            "scenarios/damper.toml",
            "force[0].load_resistance=3",
            &[
                "scenarios/damper.toml",
                "did you mean `generator.load_resistance`?",
            ],
        ),
        (
            "scenarios/damper.toml",
            "mechanism[0].placement.half_angle_deg=12",
            &["did you mean `mechanism.half_angle_deg`?"],
        ),
        (
            "scenarios/damper.toml",
            "mechanizm.half_angle_deg=12",
            &[
                "--set mechanizm.half_angle_deg=12",
                "did you mean `mechanism.half_angle_deg`?",
            ],
        ),
        (
            "scenarios/damper.toml",
            "generator.load_resistanc=3",
            &[
                "--set generator.load_resistanc=3",
                "unknown field `load_resistanc`",
                "did you mean `load_resistance`?",
            ],
        ),
    ];
    for (file, set, needles) in cases {
        assert_bad_input(&["simulate", file, "--set", set, "-o", out], needles);
    }
    // A typo in a file's field: at its line, in the damper kind's words in `[mechanism]`.
    let dir = std::env::temp_dir().join(format!("damper-typo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let text = edited(&[
        ("elements = 20", "element = 20"),
        ("half_angle_deg = 10.0", "half_angle_dg = 10.0"),
        ("load_resistance = 3.5", "load_resistanse = 3.5"),
    ])
    .replace(
        "../models/",
        &format!("{}/models/", crate::common::root().display()),
    );
    let file = dir.join("typo.toml");
    std::fs::write(&file, &text).unwrap();
    let line = |needle: &str| text.lines().position(|l| l.starts_with(needle)).unwrap() + 1;
    let f = file.to_str().unwrap();
    assert_bad_input(
        &["simulate", f, "-o", out],
        &[
            &format!("{f}:{}:", line("element =")),
            "unknown field `element`",
            "did you mean `elements`?",
            &format!("{f}:{}:", line("half_angle_dg")),
            "[mechanism]: unknown field `half_angle_dg`",
            "did you mean `half_angle_deg`?",
            &format!("{f}:{}:", line("load_resistanse")),
            "did you mean `load_resistance`?",
        ],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
