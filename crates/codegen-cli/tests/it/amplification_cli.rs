//! One definition of amplification: the kinematic influence `dq/dw` of a beam point's
//! displacement on the generator joint (free coordinates held, from the constraint
//! Jacobian), written from `t = 0` on — the same number `damper linearize` reports — and the
//! speed ratio `q'/w'` under its own name, only where it says something else.

use crate::common;

use std::path::{Path, PathBuf};

use common::damper;

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("amplification_cli_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// (header, rows) of a CSV time history; an empty cell is NaN.
pub(crate) fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|c| c.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    (header, rows)
}

fn column(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name:?} in {header:?}"))
}

/// `damper linearize SCENARIO --json`'s amplification of the first generator.
fn linearised_amplification(scenario: &str) -> f64 {
    let (code, out, err) = damper(&["linearize", scenario, "--json"]);
    assert_eq!(code, 0, "{err}");
    let r: serde_json::Value = serde_json::from_str(&out).unwrap();
    r["amplification"][0]["joint_per_displacement"]
        .as_f64()
        .unwrap()
}

/// The forced damper starts at rest in its equilibrium (undeformed beam, no gravity, the
/// shaker's sine zero at t = 0): its amplification column at t = 0 is the linearisation's
/// `dq1/dw` at the equilibrium — once an empty cell, as a speed ratio is undefined at rest.
/// Without free coordinates `q1' = (dq1/dw) w'` on every row, so no speed-ratio column.
#[test]
fn hybrid_amplification_at_rest_is_the_kinematic_influence_of_the_linearisation() {
    let scenario = "scenarios/forced_damper.toml";
    let dir = temp("forced");
    let (code, _, err) = damper(&[
        "simulate",
        scenario,
        "-o",
        dir.to_str().unwrap(),
        "--quiet",
        "--set",
        "integrator.t_end=0.2",
    ]);
    assert_eq!(code, 0, "{err}");
    let (header, rows) = read_csv(&dir.join("time_history.csv"));
    let amp = column(&header, "tip_pin.amplification [rad/m]");
    let (w_dot, q1_dot) = (
        column(&header, "tip_pin.w_dot [m/s]"),
        column(&header, "damper.q1_dot [rad/s]"),
    );
    assert!(
        !header.iter().any(|h| h.contains("speed_ratio")),
        "{header:?}"
    );
    let at_rest = &rows[0];
    assert_eq!(at_rest[0], 0.0);
    assert_eq!(at_rest[w_dot], 0.0, "the run starts at rest");
    let linear = linearised_amplification(scenario);
    assert!(linear > 1.0, "{linear}");
    assert!(
        (at_rest[amp] - linear).abs() <= 1e-12 * linear,
        "amplification at t = 0: {} vs damper linearize {linear}",
        at_rest[amp]
    );
    // The same definition on every row: q1' = (dq1/dw) w' (eq. 18, no free coordinate).
    let peak = rows.iter().map(|r| r[w_dot].abs()).fold(0.0, f64::max);
    assert!(peak > 0.0);
    let mut checked = 0;
    for r in rows.iter().filter(|r| r[w_dot].abs() > 1e-3 * peak) {
        let predicted = r[amp] * r[w_dot];
        assert!(
            (predicted - r[q1_dot]).abs() <= 1e-9 * r[q1_dot].abs(),
            "t = {}: (dq1/dw) w' = {predicted} vs q1' = {}",
            r[0],
            r[q1_dot]
        );
        checked += 1;
    }
    assert!(checked > 100, "{checked} rows checked");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The damper kind's amplification column is the same quantity: started at rest in its
/// equilibrium (`initial.displacement = 0`), its value at t = 0 is the linearisation's.
#[test]
fn damper_kind_amplification_at_rest_is_the_kinematic_influence_of_the_linearisation() {
    let dir = temp("damper");
    let (code, _, err) = damper(&[
        "simulate",
        "scenarios/damper.toml",
        "-o",
        dir.to_str().unwrap(),
        "--quiet",
        "--set",
        "integrator.t_end=0.05",
        "--set",
        "initial.displacement=0",
    ]);
    assert_eq!(code, 0, "{err}");
    let (header, rows) = read_csv(&dir.join("time_history.csv"));
    let amp = column(&header, "pin.amplification [rad/m]");
    let first = rows[0][amp];
    let linear = linearised_amplification("scenarios/damper.toml");
    assert!(
        (first - linear).abs() <= 1e-12 * linear,
        "damper kind at t = 0: {first} vs linearisation {linear}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Where the generator joint has its own motion (the absorber's pendulum is a free
/// coordinate) the speed ratio adds information and has its own column, empty at rest;
/// the amplification (free coordinates held) is written from t = 0.
#[test]
fn speed_ratio_has_its_own_column_where_it_differs_from_the_amplification() {
    let dir = temp("absorber");
    let (code, _, err) = damper(&[
        "simulate",
        "scenarios/pendulum_absorber.toml",
        "-o",
        dir.to_str().unwrap(),
        "--quiet",
        "--set",
        "integrator.t_end=0.05",
    ]);
    assert_eq!(code, 0, "{err}");
    let (header, rows) = read_csv(&dir.join("time_history.csv"));
    let amp = column(&header, "tip.amplification [rad/m]");
    let ratio = column(&header, "tip.speed_ratio [rad/m]");
    assert_eq!(ratio, amp + 1);
    assert!(rows[0][amp].is_finite(), "amplification written at t = 0");
    assert!(rows[0][ratio].is_nan(), "no speed ratio at rest");
    assert!(rows.iter().skip(1).any(|r| r[ratio].is_finite()));
    let summary = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    assert!(
        summary.contains("\"speed_ratio_rms\"") && !summary.contains("amplification_rms"),
        "{summary}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
