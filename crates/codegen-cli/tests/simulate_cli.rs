//! End-to-end tests of `damper simulate` on damper scenarios, run as a user would.

mod common;

use common::{assert_bad_input, damper, root};
use std::path::{Path, PathBuf};

use serde_json::Value;

/// A temporary directory with a copy of the bundled scenario, edited; returns (dir, scenario).
fn scenario_copy(name: &str, edits: &[(&str, &str)]) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("damper-sim-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut text = std::fs::read_to_string(root().join("scenarios/damper.toml")).unwrap();
    let model = root()
        .join("models/double_bar.toml")
        .canonicalize()
        .unwrap();
    text = text.replace(
        "model = \"../models/double_bar.toml\"",
        &format!("model = {:?}", model.display().to_string()),
    );
    for (old, new) in edits {
        assert!(text.contains(old), "{old}");
        text = text.replacen(old, new, 1);
    }
    let path = dir.join("scenario.toml");
    std::fs::write(&path, text).unwrap();
    (dir, path)
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

#[test]
fn simulate_damper_writes_history_summary_and_plot() {
    let (dir, sc) = scenario_copy("ok", &[("t_end = 5.0", "t_end = 1.5")]);
    let out = dir.join("out");
    let (code, stdout, stderr) = damper(&[
        "simulate",
        sc.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("zeta with generator"), "{stdout}");
    assert_eq!(
        files_in(&out),
        [
            "summary.json",
            "time_history.csv",
            "time_history_without_generator.csv",
            "tip_displacement.svg"
        ]
    );
    let csv = std::fs::read_to_string(out.join("time_history.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    for col in [
        "t",
        "tip_displacement",
        "tip_velocity",
        "crank_angle",
        "coupler_angle",
        "crank_rate",
        "coupler_rate",
        "amplification",
        "current",
        "generator_power",
        "total_energy",
        "constraint_residual",
    ] {
        assert!(header.contains(&col), "missing column {col}: {header:?}");
    }
    assert_eq!(
        csv.lines().count(),
        1 + 1 + 1500,
        "header + t = 0 + one row per ms"
    );
    let s: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let model = mbs_symbolic::model::load(&root().join("models/double_bar.toml")).unwrap();
    assert_eq!(s["model_hash"], model.source.hash.as_str());
    assert_eq!(
        s["generator_version"],
        mbs_symbolic::emit::GENERATOR_VERSION
    );
    assert_eq!(s["mechanism_backend"], "generated");
    let (zw, zo) = (
        s["zeta_with_generator"].as_f64().unwrap(),
        s["zeta_without_generator"].as_f64().unwrap(),
    );
    assert!(zw > 10.0 * zo && zo > 0.0, "{zw} {zo}");
    assert!(s["energy_balance_rel_error"].as_f64().unwrap() < 1e-5);
    assert!((s["peak_amplitude"].as_f64().unwrap() - 1e-3).abs() < 1e-9);
    let svg = std::fs::read_to_string(out.join("tip_displacement.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("generator disconnected"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_scenarios_name_file_line_and_entity() {
    let (dir, sc) = scenario_copy(
        "badkey",
        &[("gear_ratio = 5.0", "gear_ratio = 5.0\ngear_raito = 4.0")],
    );
    assert_bad_input(
        &[
            "simulate",
            sc.to_str().unwrap(),
            "-o",
            dir.join("o").to_str().unwrap(),
        ],
        &["scenario.toml:", "gear_raito"],
    );
    let (dir2, sc) = scenario_copy(
        "badval",
        &[("load_resistance = 3.5", "load_resistance = -3.5")],
    );
    assert_bad_input(
        &[
            "simulate",
            sc.to_str().unwrap(),
            "-o",
            dir2.join("o").to_str().unwrap(),
        ],
        &["scenario.toml:43", "[generator]", "load_resistance"],
    );
    let (dir3, sc) = scenario_copy(
        "badangle",
        &[("half_angle_deg = 10.0", "half_angle_deg = 0.0")],
    );
    assert_bad_input(
        &[
            "simulate",
            sc.to_str().unwrap(),
            "-o",
            dir3.join("o").to_str().unwrap(),
        ],
        &["half_angle_deg", "singular"],
    );
    assert_bad_input(&["simulate", "scenarios/no_such.toml"], &["no_such.toml"]);
    for d in [dir, dir2, dir3] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// A run driven into the toggle position stops with the clear error and writes no output
/// file.
#[test]
fn singular_run_fails_cleanly_and_writes_nothing() {
    let (dir, sc) = scenario_copy(
        "toggle",
        &[
            ("displacement = 0.001", "displacement = -0.0035"),
            (
                "rotor_inertia = 1e-6",
                "rotor_inertia = 1e-6\nconnected = false",
            ),
        ],
    );
    let out = dir.join("out");
    let err = assert_bad_input(
        &[
            "simulate",
            sc.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
        &["t = ", "displacement"],
    );
    assert!(
        err.contains("singular") || err.contains("cannot reach"),
        "{err}"
    );
    assert!(
        files_in(&out).is_empty(),
        "no output files: {:?}",
        files_in(&out)
    );
    // The output directory is created only when the run has its outputs.
    assert!(
        !out.exists(),
        "a failed run leaves no empty output directory"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
