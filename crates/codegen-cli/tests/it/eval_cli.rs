//! End-to-end tests of `damper eval`, run as a user would run the binary.

use crate::common;

use common::{assert_bad_input, damper, root};

use serde_json::Value;

fn numbers(v: &Value) -> Vec<f64> {
    match v {
        Value::Array(a) => a.iter().flat_map(numbers).collect(),
        Value::Number(n) => vec![n.as_f64().unwrap()],
        other => panic!("not a number: {other}"),
    }
}

/// The double bar's closed form (two uniform rods, gravity gy along y): the same M and F as a
/// textbook double pendulum with c = L/2 and I = m L^2 / 12, and the tip at
/// `L (cos q1 + cos q12, sin q1 + sin q12)`; in all three backends (the double bar is compiled
/// in, and `gy` is a run-time parameter).
#[test]
fn eval_double_bar_matches_closed_form_in_all_backends() {
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
    let f1 = -h * (2.0 * w1 * w2 + w2 * w2)
        + g * (m * c * q1.cos() + m * (l * q1.cos() + c * (q1 + q2).cos()));
    let f2 = h * w1 * w1 + g * m * c * (q1 + q2).cos();
    let (s1, c1, s12, c12, w12) = (
        q1.sin(),
        q1.cos(),
        (q1 + q2).sin(),
        (q1 + q2).cos(),
        w1 + w2,
    );
    let tip_p = [l * (c1 + c12), l * (s1 + s12), 0.0];
    let tip_j = [-l * (s1 + s12), -l * s12, l * (c1 + c12), l * c12, 0.0, 0.0];
    let tip_a = [
        -l * (c1 * w1 * w1 + c12 * w12 * w12),
        -l * (s1 * w1 * w1 + s12 * w12 * w12),
        0.0,
    ];
    for backend in ["interp", "numeric", "generated"] {
        let a = args(backend);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let (code, out, err) = damper(&a);
        assert_eq!(code, 0, "{err}");
        let v: Value = serde_json::from_str(&out).expect("one JSON object");
        assert_eq!(v["backend"], backend);
        let mm = numbers(&v["M"]);
        let ff = numbers(&v["F"]);
        for (got, want) in mm
            .iter()
            .zip([m11, m12, m12, m22])
            .chain(ff.iter().zip([f1, f2]))
        {
            assert!(
                (got - want).abs() <= 1e-13 * want.abs().max(1e-3),
                "{backend}: {got} vs {want}"
            );
        }
        assert_eq!(numbers(&v["Q"]), vec![0.0, 0.0]);
        assert!(v["op_count"]["M+F"]["total"].as_u64().unwrap() > 0);
        assert!(
            v["M"].as_array().unwrap().len() == 2,
            "M is an array of rows"
        );
        let tip = &v["points"]["tip"];
        for (what, got, want) in [
            ("p", numbers(&tip["p"]), tip_p.to_vec()),
            ("J", numbers(&tip["J"]), tip_j.to_vec()),
            ("A", numbers(&tip["A"]), tip_a.to_vec()),
        ] {
            assert_eq!(got.len(), want.len(), "{backend}: tip {what}");
            for (g, w) in got.iter().zip(&want) {
                assert!(
                    (g - w).abs() <= 1e-13 * w.abs().max(1e-3),
                    "{backend}: tip {what}: {g} vs {w}"
                );
            }
        }
        // No constraints: empty rows, not missing keys.
        for key in ["constraint_names", "h", "J", "A"] {
            assert_eq!(v[key], serde_json::json!([]), "{backend}: {key}");
        }
    }
}

#[test]
fn eval_bad_input_gets_one_line_and_exit_code_2() {
    assert_bad_input(
        &["eval", "models/double_bar.toml", "--q", "1,2,3"],
        &["--q", "expected 2"],
    );
    assert_bad_input(
        &["eval", "models/double_bar.toml", "--param", "nope=1"],
        &["nope", "no such parameter"],
    );
    assert_bad_input(
        &["eval", "models/double_bar.toml", "--param", "m1"],
        &["NAME=VALUE"],
    );
    assert_bad_input(
        &["eval", "models/double_bar.toml", "--param", "m1=abc"],
        &["m1", "not a finite number"],
    );
    assert_bad_input(
        &["eval", "models/no_such_file.toml"],
        &["no_such_file.toml"],
    );
    let dir = std::env::temp_dir().join(format!("damper-eval-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "[[bodies]]\nname = \"crank\"\njoint = \"R3\"\nmass = -1.0\n",
    )
    .unwrap();
    assert_bad_input(
        &["eval", bad.to_str().unwrap()],
        &["bad.toml:4", "crank", "mass"],
    );
    let _ = std::fs::remove_dir_all(&dir);
    // A usage error (missing MODEL) is clap's: exit code 2 with the usage text.
    let (code, _, err) = damper(&["eval"]);
    assert_eq!(code, 2);
    assert!(err.contains("<MODEL>"), "{err}");
}

/// Runs `damper eval` successfully and parses its JSON.
fn eval_json(args: &[&str]) -> Value {
    let (code, out, err) = damper(args);
    assert_eq!(code, 0, "{args:?}: {err}");
    serde_json::from_str(&out).expect("one JSON object")
}

/// `got` and `want` agree to `1e-12` relative to the largest entry of `want` (exactly when
/// all are zero). The backends are three exact formulations (generated code, interpreted
/// expressions, numeric recursion) evaluated in double precision, and the JSON numbers
/// round-trip exactly, so the differences are rounding only: ~1e-16 per operation on terms
/// no larger than the result's scale for these well-conditioned states.
fn assert_agree(what: &str, got: &Value, want: &Value) {
    let (g, w) = (numbers(got), numbers(want));
    assert_eq!(g.len(), w.len(), "{what}: length ({got} vs {want})");
    let scale = w.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (k, (a, b)) in g.iter().zip(&w).enumerate() {
        assert!(
            (a - b).abs() <= 1e-12 * scale,
            "{what}[{k}]: {a} vs {b} (scale {scale})"
        );
    }
}

/// Array-of-arrays shape: `rows` rows of `cols` numbers.
fn assert_rows(what: &str, v: &Value, rows: usize, cols: usize) {
    let a = v
        .as_array()
        .unwrap_or_else(|| panic!("{what}: not an array: {v}"));
    assert_eq!(a.len(), rows, "{what}: rows");
    for r in a {
        let r = r
            .as_array()
            .unwrap_or_else(|| panic!("{what}: row not an array: {r}"));
        assert_eq!(r.len(), cols, "{what}: columns");
        assert!(r.iter().all(Value::is_f64), "{what}: {v}");
    }
}

/// The four-bar (a closed loop: two constraint rows, two named points) in the three backends:
/// every output agrees, with a run-time parameter overridden; the JSON has the documented
/// shape.
#[test]
fn eval_backends_agree_on_the_four_bar() {
    let state = [
        "--q=0.3,0.5,1.2",
        "--qd=1,-2,0.5",
        "--t=0.25",
        "--param=mb=0.4",
    ];
    let run = |backend: &str| {
        let mut args = vec!["eval", "models/four_bar.toml", "--backend", backend];
        args.extend(state);
        eval_json(&args)
    };
    let generated = run("generated");
    assert_eq!(generated["backend"], "generated");
    assert_eq!(generated["model"], "four_bar");
    // Shape: n = 3 coordinates, 2 constraint rows, points by name.
    assert_eq!(
        generated["constraint_names"],
        serde_json::json!(["pin.x", "pin.y"])
    );
    assert_rows("M", &generated["M"], 3, 3);
    assert_rows("J", &generated["J"], 2, 3);
    for key in ["F", "Q"] {
        assert_eq!(numbers(&generated[key]).len(), 3, "{key}");
    }
    for key in ["h", "A"] {
        assert_eq!(numbers(&generated[key]).len(), 2, "{key}");
    }
    let points = generated["points"]
        .as_object()
        .expect("points is an object");
    assert_eq!(
        points.keys().collect::<Vec<_>>(),
        ["coupler_end", "rocker_end"]
    );
    for (name, pt) in points {
        let mut keys: Vec<&String> = pt.as_object().expect("point object").keys().collect();
        keys.sort();
        assert_eq!(keys, ["A", "J", "p"], "{name}");
        assert_eq!(numbers(&pt["p"]).len(), 3, "{name} p");
        assert_eq!(numbers(&pt["A"]).len(), 3, "{name} A");
        assert_rows(&format!("{name} J"), &pt["J"], 3, 3);
    }
    // The loop is open at this state, and the constraint rows are the point difference.
    let diff: Vec<f64> = numbers(&points["rocker_end"]["p"])
        .iter()
        .zip(numbers(&points["coupler_end"]["p"]))
        .map(|(b, a)| b - a)
        .collect();
    assert_agree(
        "h = p_b - p_a",
        &generated["h"],
        &serde_json::json!(diff[..2]),
    );
    assert!(numbers(&generated["h"]).iter().any(|h| h.abs() > 1e-3));

    for backend in ["interp", "numeric"] {
        let other = run(backend);
        for key in ["M", "F", "Q", "h", "J", "A"] {
            assert_agree(&format!("{backend} {key}"), &other[key], &generated[key]);
        }
        for name in ["coupler_end", "rocker_end"] {
            for key in ["p", "J", "A"] {
                assert_agree(
                    &format!("{backend} {name} {key}"),
                    &other["points"][name][key],
                    &generated["points"][name][key],
                );
            }
        }
        assert_eq!(other["constraint_names"], generated["constraint_names"]);
        assert_eq!(other["op_count"], generated["op_count"]);
    }

    // A folded parameter can still be changed in the interpreter and the numeric reference
    // (it is folded only in generated code), and they still agree.
    let mut args = vec![
        "eval",
        "models/four_bar.toml",
        "--q=0.3,0.5,1.2",
        "--qd=1,-2,0.5",
        "--param=a=0.12",
    ];
    let interp = eval_json(&args);
    args.extend(["--backend", "numeric"]);
    let numeric = eval_json(&args);
    for key in ["M", "F", "h", "J", "A"] {
        assert_agree(&format!("a=0.12 {key}"), &numeric[key], &interp[key]);
    }
    assert_ne!(numbers(&interp["h"]), numbers(&generated["h"]));
}

/// `--backend generated` uses the code compiled into the binary only for an unedited bundled
/// model (matched by content hash, wherever the file lives); anything else, or a change of a
/// folded parameter, is a one-line error with exit code 2.
#[test]
fn generated_backend_refuses_models_it_was_not_built_from() {
    let dir = std::env::temp_dir().join(format!("damper-eval-gen-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let original = std::fs::read_to_string(root().join("models/slider_crank.toml")).unwrap();
    // A byte-identical copy elsewhere is the same model.
    let copy = dir.join("slider_crank.toml");
    std::fs::write(&copy, &original).unwrap();
    let v = eval_json(&["eval", copy.to_str().unwrap(), "--backend", "generated"]);
    assert_eq!(v["model"], "slider_crank");
    // An edited copy (even only a comment) is not: its equations may differ.
    let edited = dir.join("edited.toml");
    std::fs::write(&edited, format!("{original}\n# edited\n")).unwrap();
    let edited = edited.to_str().unwrap();
    // Every model under models/ is compiled in, listed by name in sorted order.
    let mut names: Vec<&str> = model_registry::compiled().iter().map(|c| c.name).collect();
    names.sort_unstable();
    assert!(names.contains(&"double_bar") && names.contains(&"slider_crank"));
    assert_bad_input(
        &["eval", edited, "--backend", "generated"],
        &[
            &format!("model {edited} is not compiled into this binary"),
            &format!("(compiled in: {})", names.join(", ")),
            "use --backend interp or numeric, or rebuild",
        ],
    );
    // It is still a valid model for the other backends.
    eval_json(&["eval", edited, "--backend", "interp"]);
    let _ = std::fs::remove_dir_all(&dir);
    // Every model under models/ is compiled in (the one registry), a model elsewhere is not.
    eval_json(&["eval", "models/pendulum.json", "--backend", "generated"]);
    assert_bad_input(
        &[
            "eval",
            "tests/fixtures/spatial_arm.toml",
            "--backend",
            "generated",
        ],
        &[
            "tests/fixtures/spatial_arm.toml",
            "not compiled into this binary",
        ],
    );
    // Folded parameters are baked into the generated code: changing one is an error naming
    // it; run-time ones are fine.
    assert_bad_input(
        &[
            "eval",
            "models/slider_crank.toml",
            "--backend",
            "generated",
            "--param",
            "ms=0.5",
            "--param",
            "l=0.3",
        ],
        &["--param l", "folded into the generated code"],
    );
    eval_json(&[
        "eval",
        "models/slider_crank.toml",
        "--backend",
        "generated",
        "--param",
        "ms=0.5",
    ]);
}
