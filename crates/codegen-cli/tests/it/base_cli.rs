//! Base (support) excitation through the CLI (`at = "base"`): the bundled
//! `scenarios/base_damper.toml` writes the supports' motion and the tip's absolute motion,
//! the supports' work closes the energy balance; a wrong `at` is one line at its place.

use crate::common;

use common::{assert_bad_input, damper, root};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("damper-base-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The header and rows of a CSV of numbers.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|s| s.trim_matches('"').to_string())
        .collect();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|x| x.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    (header, rows)
}

/// `simulate scenarios/base_damper.toml` (0.3 s): `base.a`, `base.v`, `base.u` are the
/// harmonic acceleration `a sin(w t)` and its zero-mean periodic integrals
/// `-a cos(w t) / w`, `-a sin(w t) / w^2` (closed form, 1e-12); `tip_pin.w_abs` and
/// `tip_pin.w_dot_abs` are the relative columns plus the supports' motion; the summary marks
/// the excitation as the supports' and its energy balance closes (as the tip-force
/// scenario's does: 3e-6 over 5 s).
#[test]
fn base_damper_writes_the_supports_motion_and_absolute_columns() {
    let dir = temp_dir("run");
    let out = dir.join("out");
    let (code, _, err) = damper(&[
        "simulate",
        root().join("scenarios/base_damper.toml").to_str().unwrap(),
        "--set",
        "integrator.t_end=0.3",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let (header, rows) = read_csv(&out.join("time_history.csv"));
    let col = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column {name}: {header:?}"))
    };
    let (t, a, v, u) = (
        col("t [s]"),
        col("base.a [m/s^2]"),
        col("base.v [m/s]"),
        col("base.u [m]"),
    );
    let (w, wd, wa, wda) = (
        col("tip_pin.w [m]"),
        col("tip_pin.w_dot [m/s]"),
        col("tip_pin.w_abs [m]"),
        col("tip_pin.w_dot_abs [m/s]"),
    );
    assert_eq!(col("support.value [m/s^2]") + 1, col("support.work [J]"));
    let (amp, omega) = (0.05, 2.0 * PI * 5.94);
    assert_eq!(rows.len(), 301);
    for r in &rows {
        let (s, c) = (omega * r[t]).sin_cos();
        assert!((r[a] - amp * s).abs() <= 1e-12 * amp, "{r:?}");
        assert!(
            (r[v] + amp * c / omega).abs() <= 1e-12 * amp / omega,
            "{r:?}"
        );
        assert!((r[u] + amp * s / (omega * omega)).abs() <= 1e-12 * amp / (omega * omega));
        assert!((r[wa] - (r[w] + r[u])).abs() <= 1e-15 * (r[w].abs() + r[u].abs() + 1e-300));
        assert!((r[wda] - (r[wd] + r[v])).abs() <= 1e-15 * (r[wd].abs() + r[v].abs() + 1e-300));
    }
    // The tip moves relative to the clamp (the supports' motion is 36 um).
    let peak = rows.iter().fold(0.0f64, |m, r| m.max(r[w].abs()));
    assert!(peak > 1e-5, "{peak}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let e = &summary["excitations"][0];
    assert_eq!(e["supports"], serde_json::Value::Bool(true), "{e}");
    let work = e["work"].as_f64().unwrap();
    let last = rows.last().unwrap();
    assert!(work > 0.0 && (work - last[col("support.work [J]")]).abs() <= 1e-12 * work);
    let balance = summary["energy_balance_rel_error"].as_f64().unwrap();
    assert!(balance < 1e-5, "{balance}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// An `at` that is neither `"base"` nor a table is refused in one line at its place, naming
/// the excitation and the forms there are.
#[test]
fn a_wrong_at_is_one_line_at_its_place() {
    let dir = temp_dir("at");
    let text = std::fs::read_to_string(root().join("scenarios/base_damper.toml")).unwrap();
    let abs = root()
        .join("models/double_bar.toml")
        .canonicalize()
        .unwrap();
    let text = text.replace("../models/double_bar.toml", &abs.display().to_string());
    for (bad, needles) in [
        ("at = \"bases\"", &["\"base\"", "not \"bases\""][..]),
        ("at = 3", &["at must be \"base\""][..]),
        ("at = { x = 1.0, joint = \"crank\" }", &["at must be"][..]),
    ] {
        let edited = text.replacen("at = \"base\"", bad, 1);
        assert_ne!(edited, text);
        let path = dir.join("base_damper.toml");
        std::fs::write(&path, edited).unwrap();
        let err = assert_bad_input(
            &[
                "simulate",
                path.to_str().unwrap(),
                "-o",
                dir.join("out").to_str().unwrap(),
            ],
            needles,
        );
        assert!(
            err.contains("base_damper.toml:") && err.contains("excitation \"support\""),
            "{err}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
