//! End-to-end tests of `damper simulate` on plain closed-loop mechanism scenarios
//! (`kind = "mechanism"`), run as a user would run the binary.

use crate::common;

use common::{damper, root};
use std::path::{Path, PathBuf};

use serde_json::Value;

/// A fresh temporary directory for one test.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("damper-mech-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Reads a CSV file: header and rows of numbers (empty cells as NaN, which must not occur).
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|c| c.parse::<f64>().unwrap_or(f64::NAN))
                .collect::<Vec<f64>>()
        })
        .collect();
    (header, rows)
}

/// The column named `name` (its header is `name [unit]`).
fn col(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h.split(" [").next() == Some(name))
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
}

/// The bundled four-bar scenario runs with the compiled-in generated code and writes the
/// CSV (named columns: coordinates, velocities, energies, residual, cond(J_v)) and the
/// summary; energy drift below 1e-8 relative, constraint residuals at rounding level.
#[test]
fn four_bar_scenario_writes_csv_and_summary() {
    let out = temp_dir("four-bar");
    let (code, _, err) = damper(&[
        "simulate",
        "scenarios/four_bar.toml",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("generated"), "backend not reported: {err}");
    let (header, rows) = read_csv(&out.join("four_bar.csv"));
    assert_eq!(
        header,
        [
            "t [s]",
            "q1 [rad]",
            "q2 [rad]",
            "q3 [rad]",
            "q1_dot [rad/s]",
            "q2_dot [rad/s]",
            "q3_dot [rad/s]",
            "kinetic_energy [J]",
            "potential_energy [J]",
            "total_energy [J]",
            "constraint_residual_norm [m]",
            "cond_jv [-]"
        ]
    );
    assert!(header.iter().any(|h| h.contains("residual")));
    assert!(header.iter().any(|h| h.contains("energy")));
    assert_eq!(rows.len(), 501);
    assert!(
        rows.iter().flatten().all(|x| x.is_finite()),
        "non-finite cell"
    );
    let (t, e, r) = (
        col(&header, "t"),
        col(&header, "total_energy"),
        col(&header, "constraint_residual_norm"),
    );
    assert_eq!(rows[0][t], 0.0);
    assert_eq!(rows[500][t], 5.0);
    assert_eq!(
        rows[0][col(&header, "q1")],
        0.6,
        "the held coordinate keeps its value"
    );
    let e0 = rows[0][e];
    let drift = rows
        .iter()
        .map(|row| (row[e] - e0).abs())
        .fold(0.0, f64::max);
    assert!(drift < 1e-8 * e0.abs(), "energy drift {drift:e}");
    assert!(rows.iter().all(|row| row[r] < 1e-12));

    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("four_bar_summary.json")).unwrap())
            .unwrap();
    assert_eq!(summary["backend"], "generated");
    assert_eq!(summary["status"], "completed");
    assert!(summary["steps_accepted"].as_u64().unwrap() > 100);
    assert!(summary["energy"]["max_relative_drift"].as_f64().unwrap() < 1e-8);
    assert!(summary["max_constraint_residual_norm"].as_f64().unwrap() < 1e-12);
    assert!(summary["wall_time_s"].as_f64().is_some());
    assert!(summary["partition_changes"].is_array());
    // Nothing half-written is left behind.
    let leftovers: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty());
    let _ = std::fs::remove_dir_all(&out);
}

/// A model file that is not byte-identical to a compiled-in one (here: the four-bar with an
/// extra comment) runs with the DAG interpreter, says so, and gives the same trajectory.
#[test]
fn model_not_compiled_in_uses_the_interpreter_with_the_same_result() {
    let dir = temp_dir("interp");
    let model = std::fs::read_to_string(root().join("models/four_bar.toml")).unwrap();
    std::fs::write(
        dir.join("my_four_bar.toml"),
        format!("# a user's copy\n{model}"),
    )
    .unwrap();
    let scenario = std::fs::read_to_string(root().join("scenarios/four_bar.toml"))
        .unwrap()
        .replace("../models/four_bar.toml", "my_four_bar.toml")
        .replace("t_end = 5.0", "t_end = 1.0");
    std::fs::write(dir.join("fb.toml"), scenario).unwrap();
    let out = dir.join("out");
    let sc = dir.join("fb.toml");
    let (code, _, err) = damper(&[
        "simulate",
        sc.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("interpreter"), "{err}");
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("fb_summary.json")).unwrap())
            .unwrap();
    assert_eq!(summary["backend"], "interpreter");

    let gen_out = dir.join("gen");
    let gen_sc = dir.join("gen.toml");
    std::fs::write(
        &gen_sc,
        std::fs::read_to_string(&sc).unwrap().replace(
            "my_four_bar.toml",
            &root().join("models/four_bar.toml").display().to_string(),
        ),
    )
    .unwrap();
    let (code, _, err) = damper(&[
        "simulate",
        gen_sc.to_str().unwrap(),
        "-o",
        gen_out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let (_, a) = read_csv(&out.join("fb.csv"));
    let (_, b) = read_csv(&gen_out.join("gen.csv"));
    assert_eq!(a.len(), b.len());
    for (ra, rb) in a.iter().zip(&b) {
        for k in 1..7 {
            assert!(
                (ra[k] - rb[k]).abs() < 1e-9,
                "t = {}: column {k}: {} vs {}",
                ra[0],
                ra[k],
                rb[k]
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A parallelogram linkage assembled with all links on one line is a singular
/// configuration: the command fails with one line naming it, a non-zero exit code, no NaN
/// and no output files.
#[test]
fn singular_configuration_fails_with_a_clear_error() {
    let dir = temp_dir("singular");
    let model = std::fs::read_to_string(root().join("models/four_bar.toml"))
        .unwrap()
        .replace("b = 0.25", "b = 0.30")
        .replace("c = 0.20", "c = 0.10");
    std::fs::write(dir.join("parallelogram.toml"), model).unwrap();
    let scenario = std::fs::read_to_string(root().join("scenarios/four_bar.toml"))
        .unwrap()
        .replace("../models/four_bar.toml", "parallelogram.toml")
        .replace("q = { q1 = 0.6 }", "q = { q1 = 0.0 }")
        .replace(
            "guess = { q2 = 0.0, q3 = 1.6 }",
            "guess = { q2 = 0.0, q3 = 0.0 }",
        );
    let sc = dir.join("par.toml");
    std::fs::write(&sc, scenario).unwrap();
    let out = dir.join("out");
    let (code, _, err) = damper(&[
        "simulate",
        sc.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_ne!(code, 0);
    let last = err.lines().last().unwrap_or_default();
    assert!(last.starts_with("error:"), "{err}");
    assert!(last.contains("singular configuration at t = 0"), "{err}");
    assert!(
        last.contains("smallest singular value") && last.contains("q1 = "),
        "{err}"
    );
    assert!(!err.contains("NaN"), "{err}");
    assert!(!out.join("par.csv").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Mistakes in the scenario are reported with the file and the line; an unreachable
/// position with the constraint rows involved.
#[test]
fn bad_scenarios_are_reported_with_file_line_and_entity() {
    let dir = temp_dir("bad");
    let base = std::fs::read_to_string(root().join("scenarios/four_bar.toml"))
        .unwrap()
        .replace(
            "../models/four_bar.toml",
            &root().join("models/four_bar.toml").display().to_string(),
        );
    let typo = dir.join("typo.toml");
    std::fs::write(&typo, base.replace("rtol = 1e-10", "rtoll = 1e-10")).unwrap();
    let (code, _, err) = damper(&[
        "simulate",
        typo.to_str().unwrap(),
        "-o",
        dir.join("o1").to_str().unwrap(),
    ]);
    assert_ne!(code, 0);
    let line = base.lines().position(|l| l.starts_with("rtol")).unwrap() + 1;
    assert!(
        err.contains(&format!("typo.toml:{line}")) && err.contains("rtoll"),
        "{err}"
    );

    let unknown = dir.join("unknown.toml");
    std::fs::write(
        &unknown,
        base.replace("qd = { q1 = 0.0 }", "qd = { q9 = 0.0 }"),
    )
    .unwrap();
    let (code, _, err) = damper(&[
        "simulate",
        unknown.to_str().unwrap(),
        "-o",
        dir.join("o2").to_str().unwrap(),
    ]);
    assert_ne!(code, 0);
    assert!(
        err.contains("qd.q9") && err.contains("unknown coordinate"),
        "{err}"
    );

    let far = dir.join("far.toml");
    std::fs::write(
        &far,
        base.replace("q = { q1 = 0.6 }", "q = { q1 = 0.6, q3 = -1.0 }")
            .replace("guess = { q2 = 0.0, q3 = 1.6 }", "guess = { q2 = 0.0 }"),
    )
    .unwrap();
    let (code, _, err) = damper(&[
        "simulate",
        far.to_str().unwrap(),
        "-o",
        dir.join("o3").to_str().unwrap(),
    ]);
    assert_ne!(code, 0);
    assert!(
        err.contains("cannot be satisfied") && err.contains("pin."),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Column units come with the backend's names (`CoordinateUnit` from each joint type): the
/// slider-crank's prismatic slider reads in metres, its revolute joints in radians, in the
/// mechanism kind and in the hybrid kind alike.
#[test]
fn column_units_follow_the_joint_types() {
    let dir = temp_dir("units");
    let (code, _, err) = damper(&[
        "simulate",
        "scenarios/slider_crank.toml",
        "-o",
        dir.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(code, 0, "{err}");
    let (header, _) = read_csv(&dir.join("slider_crank.csv"));
    for h in ["q1 [rad]", "q3 [m]", "q1_dot [rad/s]", "q3_dot [m/s]"] {
        assert!(header.iter().any(|c| c == h), "{h} in {header:?}");
    }
    let (code, _, err) = damper(&[
        "simulate",
        "scenarios/slider_crank_damper.toml",
        "-o",
        dir.join("h").to_str().unwrap(),
        "--quiet",
        "--set",
        "integrator.t_end=0.01",
    ]);
    assert_eq!(code, 0, "{err}");
    let (header, _) = read_csv(&dir.join("h").join("time_history.csv"));
    for h in [
        "slider_crank.q1 [rad]",
        "slider_crank.s [m]",
        "slider_crank.s_dot [m/s]",
    ] {
        assert!(header.iter().any(|c| c == h), "{h} in {header:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
