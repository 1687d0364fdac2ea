//! End-to-end tests of `damper modes`: the binary is run as a user would run it.

use std::path::PathBuf;
use std::process::{Command, Output};

const BEAM: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../beams/cantilever.toml");

fn damper(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_damper"))
        .args(args)
        .output()
        .expect("run damper")
}

/// Euler–Bernoulli cantilever frequencies of the bundled beam, computed here independently:
/// f_n = (beta_n L)^2 / (2 pi L^2) sqrt(E I / (rho A)), L = 1 m, 40 x 8 mm steel.
fn cantilever_hz() -> Vec<f64> {
    let (l, e, rho, b, h): (f64, f64, f64, f64, f64) = (1.0, 210e9, 7850.0, 0.040, 0.008);
    let (area, i) = (b * h, b * h * h * h / 12.0);
    let beta_l = [
        1.875104068711961,
        4.694091132974175,
        7.854757438237613,
        10.995540734875467,
        14.137_168_391_046_47,
    ];
    beta_l
        .iter()
        .map(|bl: &f64| {
            bl * bl / (2.0 * std::f64::consts::PI * l * l) * (e * i / (rho * area)).sqrt()
        })
        .collect()
}

#[test]
fn json_frequencies_match_euler_bernoulli() {
    let out = damper(&["modes", BEAM, "--count", "5", "--json"]);
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("valid JSON");
    let fe: Vec<f64> = serde_json::from_value(v["frequencies_hz"].clone()).unwrap();
    let analytic: Vec<f64> = serde_json::from_value(v["analytic_hz"].clone()).unwrap();
    let exact = cantilever_hz();
    assert_eq!(fe.len(), 5);
    assert_eq!(analytic.len(), 5);
    for i in 0..5 {
        // The tool's analytic values are the closed form (to rounding).
        assert!(
            (analytic[i] / exact[i] - 1.0).abs() < 1e-12,
            "analytic mode {}: {} vs {}",
            i + 1,
            analytic[i],
            exact[i]
        );
        // 20 elements: FE frequencies are upper bounds, the first three within 0.01 %.
        assert!(
            fe[i] > exact[i],
            "mode {}: {} not above {}",
            i + 1,
            fe[i],
            exact[i]
        );
        if i < 3 {
            assert!(
                fe[i] / exact[i] - 1.0 < 1e-4,
                "mode {}: {} vs {}",
                i + 1,
                fe[i],
                exact[i]
            );
        }
    }
}

#[test]
fn table_lists_modes_with_reference_and_error() {
    let out = damper(&["modes", BEAM]);
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("boundary conditions: cantilever (clamped-free)"),
        "{text}"
    );
    assert!(text.contains("20 elements, 40 free DOFs"), "{text}");
    let rows: Vec<&str> = text
        .lines()
        .filter(|l| {
            l.trim_start()
                .chars()
                .next()
                .is_some_and(|c| c.is_ascii_digit())
        })
        .collect();
    assert_eq!(rows.len(), 5, "default --count is 5:\n{text}");
    // Mode 1: FE, analytic, relative error columns.
    let cols: Vec<&str> = rows[0].split_whitespace().collect();
    assert_eq!(cols[0], "1");
    let (fe, exact, err): (f64, f64, f64) = (
        cols[1].parse().unwrap(),
        cols[2].parse().unwrap(),
        cols[3].parse().unwrap(),
    );
    assert!((exact - cantilever_hz()[0]).abs() < 1e-8, "{text}");
    assert!(
        (fe - exact) / exact > 0.0 && err > 0.0 && err < 1e-4,
        "{text}"
    );
}

#[test]
fn bad_beam_is_a_one_line_error_with_exit_code_2() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let path = dir.join("modes_cli_bad_beam.toml");
    let text = std::fs::read_to_string(BEAM)
        .unwrap()
        .replace("length = 1.0", "length = -1.0");
    std::fs::write(&path, text).unwrap();
    let out = damper(&["modes", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(
        err.contains("modes_cli_bad_beam.toml:9: segment 0: length must be positive (got -1)"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert!(out.stdout.is_empty());

    // Missing file and an impossible mode count: the same contract.
    for args in [
        vec!["modes", "no/such/beam.toml"],
        vec!["modes", BEAM, "--count", "0"],
        vec!["modes", BEAM, "--count", "41"],
    ] {
        let out = damper(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(err.starts_with("error: "), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

/// Standard output closed by the reader (`damper modes .. | head -1`) is no panic: the
/// command exits quietly with 141 (128 + SIGPIPE), nothing on standard error.
#[test]
fn closed_stdout_exits_quietly_without_panic() {
    use std::process::{Command, Stdio};
    for args in [
        &["modes", "beams/cantilever.toml"][..],
        &["modes", "beams/cantilever.toml", "--json"][..],
        &["eval", "models/double_bar.toml"][..],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_damper"))
            .args(args)
            .current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("run damper");
        // The reader goes away before the command writes anything.
        drop(child.stdout.take());
        let out = child.wait_with_output().expect("wait for damper");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert_ne!(out.status.code(), Some(101), "{args:?}: {err}");
        assert!(
            matches!(out.status.code(), Some(141) | Some(0)),
            "{args:?}: {:?} {err}",
            out.status
        );
        assert!(err.is_empty(), "{args:?}: quiet on stderr: {err}");
    }
}

/// A scenario gives its beam's modes: `scenarios/damper.toml`'s beam is the bundled
/// cantilever (the same JSON, number for number); a mechanism scenario, which has no beam,
/// is refused in one line.
#[test]
fn a_scenario_gives_the_modes_of_its_beam() {
    let scenario = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/damper.toml");
    let of = |file: &str| {
        let out = damper(&["modes", file, "--json", "--count", "4"]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap()
    };
    assert_eq!(of(scenario), of(BEAM));
    let four_bar = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/four_bar.toml");
    let out = damper(&["modes", four_bar]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains("four_bar.toml") && err.contains("has no beam"),
        "{err}"
    );
}
