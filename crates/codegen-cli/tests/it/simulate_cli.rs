//! End-to-end tests of `damper simulate` on damper scenarios, run as a user would.

use crate::common;

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
    assert!(stdout.contains("(generated), 1 attachment(s)"), "{stdout}");
    assert!(stdout.contains("; zeta "), "{stdout}");
    assert!(
        stdout.contains("bare beam (no mechanism): zeta"),
        "{stdout}"
    );
    assert_eq!(
        files_in(&out),
        [
            "beam_displacement.svg",
            "damping_vs_amplitude.svg",
            "summary.json",
            "time_history.csv",
            "time_history_bare_beam.csv",
            "time_history_generator_disconnected.csv",
        ]
    );
    let csv = std::fs::read_to_string(out.join("time_history.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    for col in [
        "t [s]",
        "pin.w [m]",
        "pin.w_dot [m/s]",
        "damper.q1 [rad]",
        "damper.q2 [rad]",
        "damper.q1_dot [rad/s]",
        "damper.q2_dot [rad/s]",
        "pin.amplification [rad/m]",
        "generator.current [A]",
        "generator.power [W]",
        "generator.load_power [W]",
        "stored [J]",
        "damper.constraint_residual [m]",
        "damper.cond_jd [-]",
    ] {
        assert!(header.contains(&col), "missing column {col}: {header:?}");
    }
    assert_eq!(
        csv.lines().count(),
        1 + 1 + 1500,
        "header + t = 0 + one row per ms"
    );
    let bare = std::fs::read_to_string(out.join("time_history_bare_beam.csv")).unwrap();
    let bare_header: Vec<&str> = bare.lines().next().unwrap().split(',').collect();
    assert!(bare_header.contains(&"pin.w [m]"), "{bare_header:?}");
    assert!(
        !bare_header.iter().any(|h| h.starts_with("damper.")),
        "no mechanism columns on the bare beam: {bare_header:?}"
    );
    assert_eq!(bare.lines().count(), 1 + 1 + 1500);
    let s: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let model = mbs_symbolic::model::load(&root().join("models/double_bar.toml")).unwrap();
    assert_eq!(s["mechanisms"][0]["model_hash"], model.source.hash.as_str());
    assert_eq!(
        s["generator_version"],
        mbs_symbolic::emit::GENERATOR_VERSION
    );
    assert_eq!(s["mechanisms"][0]["backend"], "generated");
    let c = &s["comparisons"];
    assert_eq!(
        c["generator_disconnected"]["label"],
        "generator disconnected (mechanism + rotor inertia attached)"
    );
    assert_eq!(c["bare_beam"]["label"], "bare beam (no mechanism)");
    let zw = s["damping_ratio"].as_f64().unwrap();
    let zo = c["generator_disconnected"]["damping_ratio"]
        .as_f64()
        .unwrap();
    assert!(zw > 10.0 * zo && zo > 0.0, "{zw} {zo}");
    assert_eq!(s["decay"]["kind"], "oscillatory");
    assert!(
        s["decay"]["cycles"].as_array().unwrap().len() >= 5,
        "{}",
        s["decay"]
    );
    // The bare beam, read through the modal filter of its first mode, decays with the
    // Rayleigh ratio of mode 1 (0.2 %) at the first frequency: Newmark's average
    // acceleration adds no numerical damping and shifts the period by (w h)^2 / 12 ~ 1e-6,
    // and the estimator's own error on ten cycles is ~1e-6 (hybrid-core's tests/decay.rs):
    // 1e-5 relative.
    let zb = c["bare_beam"]["damping_ratio"].as_f64().unwrap();
    assert!((zb - 0.002).abs() < 1e-5 * 0.002, "bare beam zeta {zb}");
    let fb = c["bare_beam"]["decay"]["frequency_hz"].as_f64().unwrap();
    let f1 = s["beam_first_frequency_hz"].as_f64().unwrap();
    let fd = f1 * (1.0 - 0.002f64.powi(2)).sqrt();
    assert!(
        (fb - fd).abs() < 1e-5 * fd,
        "bare beam {fb} Hz vs mode 1 {fd} Hz"
    );
    // With the mechanism and rotor inertia attached (generator disconnected), the frequency
    // is lower than the bare beam's.
    let fo = c["generator_disconnected"]["decay"]["frequency_hz"]
        .as_f64()
        .unwrap();
    assert!(fo < fb, "{fo} vs {fb}");
    assert!(s["energy_balance_rel_error"].as_f64().unwrap() < 1e-5);
    assert!((s["peak_amplitude"].as_f64().unwrap() - 1e-3).abs() < 1e-9);
    let svg = crate::common::svg::checked(&out.join("beam_displacement.svg"), &["time [s]"]).text;
    assert!(svg.starts_with("<svg"));
    for label in [
        "pin",
        "pin (generator disconnected (mechanism + rotor inertia attached))",
        "pin (bare beam (no mechanism))",
    ] {
        assert!(svg.contains(label), "{label} not in the plot");
    }
    let svg = crate::common::svg::checked(
        &out.join("damping_vs_amplitude.svg"),
        &["damping ratio of the cycle [%]"],
    )
    .text;
    assert!(svg.contains("bare beam (no mechanism)") && svg.contains("damping ratio"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `compare_without_generator = true`, the older key, is `compare =
/// ["generator_disconnected"]`; both keys at once are refused.
#[test]
fn the_older_comparison_key_is_a_synonym() {
    let key = "compare = [\"generator_disconnected\", \"bare_beam\"]";
    let (dir, sc) = scenario_copy(
        "synonym",
        &[
            ("t_end = 5.0", "t_end = 0.3"),
            (key, "compare_without_generator = true"),
        ],
    );
    let out = dir.join("out");
    let (code, _, stderr) = damper(&[
        "simulate",
        sc.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(out.join("time_history_generator_disconnected.csv").exists());
    assert!(!out.join("time_history_bare_beam.csv").exists());
    let s: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let compared: Vec<&String> = s["comparisons"].as_object().unwrap().keys().collect();
    assert_eq!(compared, ["generator_disconnected"]);
    assert!(s["comparisons"]["generator_disconnected"].is_object());
    let (dir2, sc) = scenario_copy(
        "both-keys",
        &[(key, &format!("{key}\ncompare_without_generator = false"))],
    );
    assert_bad_input(
        &[
            "simulate",
            sc.to_str().unwrap(),
            "-o",
            dir2.join("o").to_str().unwrap(),
        ],
        &["compare_without_generator", "not both"],
    );
    for d in [dir, dir2] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// Every column of every CSV that every bundled scenario writes has its unit in brackets
/// (`t [s]`, `q1 [rad]`, `cond_jv [-]`), and every run writes a plot.
#[test]
fn every_csv_column_of_every_bundled_scenario_has_a_unit() {
    let dir = std::env::temp_dir().join(format!("damper-units-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("scenarios")).unwrap();
    std::os::unix::fs::symlink(root().join("models"), dir.join("models")).unwrap();
    // The imported structure's files beside the scenario that names them.
    std::os::unix::fs::symlink(
        root().join("scenarios").join("frame"),
        dir.join("scenarios").join("frame"),
    )
    .unwrap();
    let mut names: Vec<PathBuf> = std::fs::read_dir(root().join("scenarios"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 7, "{names:?}");
    for path in names {
        let text = std::fs::read_to_string(&path).unwrap();
        // A short run: every line `t_end = ...` set to 0.05 s.
        let text: String = text
            .lines()
            .map(|l| {
                if l.trim_start().starts_with("t_end =") {
                    "t_end = 0.05".to_string()
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n");
        let name = path.file_name().unwrap();
        let copy = dir.join("scenarios").join(name);
        std::fs::write(&copy, text).unwrap();
        let out = dir.join("out").join(name);
        let (code, _, stderr) = damper(&[
            "simulate",
            copy.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{name:?}: {stderr}");
        let files = files_in(&out);
        assert!(
            files.iter().any(|f| f.ends_with(".svg")),
            "{name:?}: {files:?}"
        );
        let csvs: Vec<&String> = files.iter().filter(|f| f.ends_with(".csv")).collect();
        assert!(!csvs.is_empty(), "{name:?}: {files:?}");
        for f in csvs {
            let text = std::fs::read_to_string(out.join(f)).unwrap();
            for h in text.lines().next().unwrap().split(',') {
                let unit = h.rsplit_once(" [").map(|(_, u)| u);
                assert!(
                    unit.is_some_and(|u| u.len() > 1 && u.ends_with(']')),
                    "{name:?} {f}: column {h:?} has no unit"
                );
            }
        }
    }
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
        &["scenario.toml:43", "force \"generator\"", "load_resistance"],
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

/// Mutation-campaign regression: the modal filter of a fine mesh (40,000 reduced
/// coordinates) built three dense d x d matrices (320 GB at 100,000 elements: the run
/// aborted); above the dense limit the filter goes through the O(n) operator.
#[test]
fn the_modal_filter_of_a_fine_mesh_is_not_dense() {
    let out = std::env::temp_dir().join(format!("damper-fine-mesh-{}", std::process::id()));
    let (code, _, err) = common::damper(&[
        "simulate",
        "scenarios/pendulum_absorber.toml",
        "-o",
        out.to_str().unwrap(),
        "--quiet",
        "--set",
        "integrator.t_end=0.001",
        "--set",
        "beam.segment[0].elements=20000",
    ]);
    assert_eq!(code, 0, "{err}");
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(summary.contains("modal filter"), "the filter was built");
    let _ = std::fs::remove_dir_all(&out);
}
