//! End-to-end tests of `damper eval`, run as a user would run the binary.

use std::process::Command;

use serde_json::Value;

fn root() -> std::path::PathBuf {
    std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

fn damper(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_damper")).args(args).current_dir(root()).output().expect("run damper");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn numbers(v: &Value) -> Vec<f64> {
    match v {
        Value::Array(a) => a.iter().flat_map(numbers).collect(),
        Value::Number(n) => vec![n.as_f64().unwrap()],
        other => panic!("not a number: {other}"),
    }
}

/// The double bar's closed form (two uniform rods, gravity gy along y): the same M and F as a
/// textbook double pendulum with c = L/2 and I = m L^2 / 12.
#[test]
fn eval_double_bar_matches_closed_form_in_both_backends() {
    let (q1, q2, w1, w2, gy): (f64, f64, f64, f64, f64) = (0.3, -0.6, 1.0, 2.0, -9.81);
    let args = |backend: &'static str| {
        vec![
            "eval".to_string(),
            "models/double_bar.toml".into(),
            format!("--q={q1},{q2}"),
            format!("--qd={w1},{w2}"),
            format!("--param=gy={gy}"),
            "--backend".into(),
            backend.into(),
        ]
    };
    let (l, m) = (0.1, 0.024);
    let (c, i) = (l / 2.0, m * l * l / 12.0);
    let h = m * l * c * q2.sin();
    let m11 = 2.0 * i + m * c * c + m * (l * l + c * c + 2.0 * l * c * q2.cos());
    let m12 = i + m * (c * c + l * c * q2.cos());
    let m22 = i + m * c * c;
    let g = -gy;
    let f1 = -h * (2.0 * w1 * w2 + w2 * w2) + g * (m * c * q1.cos() + m * (l * q1.cos() + c * (q1 + q2).cos()));
    let f2 = h * w1 * w1 + g * m * c * (q1 + q2).cos();
    for backend in ["interp", "numeric"] {
        let a = args(backend);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let (code, out, err) = damper(&a);
        assert_eq!(code, 0, "{err}");
        let v: Value = serde_json::from_str(&out).expect("one JSON object");
        assert_eq!(v["backend"], backend);
        let mm = numbers(&v["M"]);
        let ff = numbers(&v["F"]);
        for (got, want) in mm.iter().zip([m11, m12, m12, m22]).chain(ff.iter().zip([f1, f2])) {
            assert!((got - want).abs() <= 1e-13 * want.abs().max(1e-3), "{backend}: {got} vs {want}");
        }
        assert_eq!(numbers(&v["Q"]), vec![0.0, 0.0]);
        assert!(v["op_count"]["M+F"]["total"].as_u64().unwrap() > 0);
        assert!(v["M"].as_array().unwrap().len() == 2, "M is an array of rows");
    }
}

fn assert_bad_input(args: &[&str], needles: &[&str]) {
    let (code, out, err) = damper(args);
    assert_eq!(code, 2, "exit code for {args:?}: stdout {out} stderr {err}");
    assert!(out.is_empty(), "nothing on stdout for bad input: {out}");
    assert_eq!(err.trim_end().lines().count(), 1, "one-line error: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: error {err:?} should mention {n:?}");
    }
}

#[test]
fn eval_bad_input_gets_one_line_and_exit_code_2() {
    assert_bad_input(&["eval", "models/double_bar.toml", "--q", "1,2,3"], &["--q", "expected 2"]);
    assert_bad_input(&["eval", "models/double_bar.toml", "--param", "nope=1"], &["nope", "no such parameter"]);
    assert_bad_input(&["eval", "models/double_bar.toml", "--param", "m1"], &["NAME=VALUE"]);
    assert_bad_input(&["eval", "models/double_bar.toml", "--param", "m1=abc"], &["m1", "not a finite number"]);
    assert_bad_input(&["eval", "models/no_such_file.toml"], &["no_such_file.toml"]);
    let dir = std::env::temp_dir().join(format!("damper-eval-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[[bodies]]\nname = \"crank\"\njoint = \"R3\"\nmass = -1.0\n").unwrap();
    assert_bad_input(&["eval", bad.to_str().unwrap()], &["bad.toml:4", "crank", "mass"]);
    let _ = std::fs::remove_dir_all(&dir);
    // A usage error (missing MODEL) is clap's: exit code 2 with the usage text.
    let (code, _, err) = damper(&["eval"]);
    assert_eq!(code, 2);
    assert!(err.contains("<MODEL>"), "{err}");
}
