//! Validation at every entry and work guards (issue "Bad input, signals and special
//! files"): run-time parameter values pass the model file's checks, time settings are
//! checked, no non-finite number reaches an output of a run that exits 0, and runs above
//! the work limits are refused with the estimate and `--allow-long`.

use crate::common;

use common::{assert_bad_input, damper, root};
use std::path::{Path, PathBuf};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("damper-values-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A copy of a bundled file in `dir`, edited (each `old` must occur), paths to bundled
/// models made absolute.
fn edited(dir: &Path, bundled: &str, edits: &[(&str, &str)]) -> PathBuf {
    let mut text = std::fs::read_to_string(root().join(bundled)).unwrap();
    for m in ["double_bar", "four_bar", "slider_crank"] {
        let abs = root()
            .join(format!("models/{m}.toml"))
            .canonicalize()
            .unwrap();
        text = text.replace(&format!("../models/{m}.toml"), &abs.display().to_string());
    }
    for (old, new) in edits {
        assert!(text.contains(old), "{old}");
        text = text.replacen(old, new, 1);
    }
    let path = dir.join(Path::new(bundled).file_name().unwrap());
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn eval_param_negative_mass_is_refused_like_in_the_model_file() {
    let err = assert_bad_input(
        &["eval", "models/double_bar.toml", "--param", "m1=-1"],
        &["--param", "mass must be positive", "m1 = -1"],
    );
    assert!(err.contains("body"), "{err}");
}

#[test]
fn eval_t_nan_is_refused() {
    assert_bad_input(
        &["eval", "models/double_bar.toml", "--t", "nan"],
        &["--t", "must be a finite number"],
    );
}

#[test]
fn eval_param_echo_of_a_huge_name_is_truncated() {
    let name = "x".repeat(100_000); // one argument is limited to 128 kB
    let err = assert_bad_input(
        &[
            "eval",
            "models/double_bar.toml",
            "--param",
            &format!("{name}=1"),
        ],
        &["no such parameter"],
    );
    assert!(err.len() < 1000, "error line of {} bytes", err.len());
}

#[test]
fn damper_scenario_zero_mass_override_is_refused_naming_the_parameter() {
    let dir = temp_dir("m1-zero");
    let sc = edited(
        &dir,
        "scenarios/damper.toml",
        &[(
            "generator_joint = \"crank\"",
            "generator_joint = \"crank\"\nparameters = { m1 = 0.0 }",
        )],
    );
    let out = dir.join("out");
    assert_bad_input(
        &[
            "simulate",
            sc.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
        &[
            "mechanism \"damper\": parameters",
            "mass must be positive",
            "m1 = 0",
        ],
    );
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn damper_scenario_dt_above_t_end_is_refused_naming_the_field() {
    let dir = temp_dir("dt");
    for (old, new) in [
        ("dt = 1e-4", "dt = 1e9"),
        ("t_end = 5.0", "t_end = 1e-9"),
        ("dt = 1e-4", "dt = 6.0"),
    ] {
        let sc = edited(&dir, "scenarios/damper.toml", &[(old, new)]);
        assert_bad_input(
            &[
                "simulate",
                sc.to_str().unwrap(),
                "-o",
                dir.join("out").to_str().unwrap(),
            ],
            &["[integrator] dt", "must not exceed t_end"],
        );
        assert!(!dir.join("out").exists());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn damper_scenario_t_end_1e5_is_refused_with_the_estimate_and_allow_long() {
    let dir = temp_dir("long-damper");
    let sc = edited(
        &dir,
        "scenarios/damper.toml",
        &[("t_end = 5.0", "t_end = 1e5")],
    );
    let err = assert_bad_input(
        &[
            "simulate",
            sc.to_str().unwrap(),
            "-o",
            dir.join("out").to_str().unwrap(),
        ],
        &["estimated at 3.00e9 steps", "--allow-long"], // 3 runs: with generator, 2 comparisons
    );
    assert!(err.contains("output rows"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn mechanism_scenario_tiny_output_step_is_refused_with_the_estimate() {
    let dir = temp_dir("long-mech");
    let sc = edited(
        &dir,
        "scenarios/four_bar.toml",
        &[("output_step = 0.01", "output_step = 1e-12")],
    );
    assert_bad_input(
        &[
            "simulate",
            sc.to_str().unwrap(),
            "-o",
            dir.join("out").to_str().unwrap(),
        ],
        &["5.00e12 output rows", "--allow-long"],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A mechanism without gravity, at rest: no energy at all. The relative drift used to be
/// 0/0, printed as `null`; no summary of a run that exits 0 holds a `null`.
#[test]
fn mechanism_without_gravity_reports_no_null_drift() {
    let dir = temp_dir("no-gravity");
    let model_text = std::fs::read_to_string(root().join("models/four_bar.toml")).unwrap();
    assert!(model_text.contains("gravity"), "four_bar has gravity");
    let model = dir.join("four_bar_no_g.toml");
    let no_g: String = model_text
        .lines()
        .filter(|l| !l.trim_start().starts_with("gravity"))
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(&model, no_g).unwrap();
    let sc = edited(
        &dir,
        "scenarios/four_bar.toml",
        &[("t_end = 5.0", "t_end = 0.5")],
    );
    let text = std::fs::read_to_string(&sc).unwrap();
    let abs = root().join("models/four_bar.toml").canonicalize().unwrap();
    std::fs::write(
        &sc,
        text.replace(&abs.display().to_string(), &model.display().to_string()),
    )
    .unwrap();
    let out = dir.join("out");
    let (code, _, err) = damper(&[
        "simulate",
        sc.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let summary = std::fs::read_to_string(out.join("four_bar_summary.json")).unwrap();
    assert!(!summary.contains("null"), "{summary}");
    let v: serde_json::Value = serde_json::from_str(&summary).unwrap();
    assert_eq!(v["energy"]["max_relative_drift"], 0.0, "{summary}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn beam_density_5e_324_is_refused_not_printed_as_inf() {
    let dir = temp_dir("density");
    let beam = edited(
        &dir,
        "beams/cantilever.toml",
        &[("density = 7850.0", "density = 5e-324")],
    );
    for extra in [&[][..], &["--json"][..]] {
        let mut args = vec!["modes", beam.to_str().unwrap()];
        args.extend_from_slice(extra);
        // Caught where the overflow happens (fem-beam), with the file, line and segment.
        assert_bad_input(
            &args,
            &["cantilever.toml", "density", "floating-point range"],
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A generator whose derived coefficients overflow or are absurd: caught by the scenario
/// loader where the number is produced (`GeneratorSpec::problems`), at the line of the field
/// most likely mistyped, not after a run as "cannot reach ... |h| = inf".
#[test]
fn damper_scenario_overflowing_generator_is_refused_at_its_line() {
    let dir = temp_dir("generator");
    type Case<'a> = (&'a [(&'a str, &'a str)], &'a str, &'a str);
    let cases: [Case; 4] = [
        (
            &[("kt = 0.0235 ", "kt = 1e300 ")],
            "kt = 1e300",
            "generator.kt = 1e300 is outside its physical range [1e-6, 1e4] N m/A",
        ),
        (
            // Every field in range, their product is not.
            &[
                ("kt = 0.0235 ", "kt = 1e4 "),
                ("ke = 0.0235 ", "ke = 1e4 "),
                ("gear_ratio = 5.0", "gear_ratio = 1e4"),
            ],
            "kt = 1e4",
            "kt * ke * gear_ratio^2 / (armature_resistance + load_resistance) = 2.000e15 N m s/rad is not physically sensible",
        ),
        (
            &[
                (
                    "armature_resistance = 1.5 ",
                    "armature_resistance = 5e-324 ",
                ),
                ("load_resistance = 3.5 ", "load_resistance = 5e-324 "),
            ],
            "armature_resistance = 5e-324",
            "kt * ke * gear_ratio^2 / (armature_resistance + load_resistance) = inf is not finite",
        ),
        (
            &[("gear_ratio = 5.0", "gear_ratio = 1e200")],
            "gear_ratio = 1e200",
            "generator.gear_ratio = 1e200 is outside its physical range [1e-3, 1e4]",
        ),
    ];
    for (edits, line_text, message) in cases {
        let sc = edited(&dir, "scenarios/damper.toml", edits);
        let text = std::fs::read_to_string(&sc).unwrap();
        let line = 1 + text.lines().position(|l| l.starts_with(line_text)).unwrap();
        let out = dir.join("out");
        let err = assert_bad_input(
            &[
                "simulate",
                sc.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ],
            &[
                &format!("damper.toml:{line}:"),
                "force \"generator\"",
                message,
            ],
        );
        assert!(!err.contains("cannot reach"), "{err}");
        assert!(!out.exists(), "no output directory for a refused scenario");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// RK4 rows are never closer than its steps: an output step below the step is refused at
/// its line (rows between steps would only be interpolated).
#[test]
fn mechanism_rk4_output_step_below_the_step_is_refused_at_its_line() {
    let dir = temp_dir("rk4-output");
    let sc = edited(
        &dir,
        "scenarios/four_bar.toml",
        &[
            ("method = \"dopri5\"", "method = \"rk4\""),
            ("rtol = 1e-10\natol = 1e-12", "step = 0.02"),
        ],
    );
    let text = std::fs::read_to_string(&sc).unwrap();
    let line = 1 + text
        .lines()
        .position(|l| l.starts_with("output_step"))
        .unwrap();
    let out = dir.join("out");
    assert_bad_input(
        &[
            "simulate",
            sc.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
        &[
            &format!("four_bar.toml:{line}:"),
            "[integrator] output_step",
            "at least the rk4 step 0.02 (got 0.01)",
        ],
    );
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Dormand–Prince without `max_step`: the steps are estimated from the output step and the
/// tolerance (`budget::dopri_typical_step`), so a run of 2.5e7 estimated steps but only
/// 1e6 rows is refused before it starts (it used to have no step estimate at all).
#[test]
fn mechanism_dopri_without_max_step_is_estimated_and_refused() {
    let dir = temp_dir("dopri-steps");
    let sc = edited(
        &dir,
        "scenarios/four_bar.toml",
        &[
            ("t_end = 5.0", "t_end = 1e4"),
            ("rtol = 1e-10", "rtol = 1e-14"),
        ],
    );
    assert!(!std::fs::read_to_string(&sc).unwrap().contains("max_step"));
    let out = dir.join("out");
    assert_bad_input(
        &[
            "simulate",
            sc.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
        &["2.51e7 steps", "1.00e6 output rows", "--allow-long"],
    );
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 23 item 1: hopeless but finite generator and beam values given with `--set` are
/// refused when the scenario is loaded, naming the field and its physical range, before
/// any work (the inductance from about 1e301 up used to hang in the eigen-solver; a huge
/// Young's modulus ended as "shape mismatch: expected size 40 / half-bandwidth 3, got 40 /
/// 3"; a huge density ran to exit 0). Nothing is written.
#[test]
fn out_of_range_generator_and_beam_values_are_refused_naming_field_and_range() {
    let dir = temp_dir("ranges");
    let cases: [(&str, &str, &str); 9] = [
        (
            "scenarios/damper.toml",
            "generator.inductance=1e308",
            "generator.inductance = 1e308 is outside its physical range [0, 1e3] H",
        ),
        (
            "scenarios/damper.toml",
            "generator.inductance=1e301",
            "generator.inductance = 1e301 is outside its physical range [0, 1e3] H",
        ),
        (
            "scenarios/damper.toml",
            "generator.kt=5e-324",
            "generator.kt = 5e-324 is outside its physical range [1e-6, 1e4] N m/A",
        ),
        (
            "scenarios/damper.toml",
            "generator.rotor_inertia=1e9",
            "generator.rotor_inertia = 1e9 is outside its physical range [0, 1e4] kg m^2",
        ),
        (
            "scenarios/damper.toml",
            "generator.load_resistance=1e30",
            "generator.load_resistance = 1e30 is outside its physical range [0, 1e9] ohm",
        ),
        (
            "scenarios/damper.toml",
            "beam.segment[0].youngs_modulus=1e305",
            "segment 0: youngs_modulus = 1e305 is outside its physical range [1e3, 1e13] Pa",
        ),
        (
            "scenarios/damper.toml",
            "beam.segment[0].density=1e300",
            "segment 0: density = 1e300 is outside its physical range [1e0, 1e6] kg/m^3",
        ),
        (
            "scenarios/pendulum_absorber.toml",
            "beam.segment[0].density=1e300",
            "segment 0: density = 1e300 is outside its physical range [1e0, 1e6] kg/m^3",
        ),
        (
            "scenarios/damper.toml",
            "beam.segment[0].length=1e6",
            "segment 0: length = 1e6 is outside its physical range [1e-6, 1e4] m",
        ),
    ];
    for (scenario, set, message) in cases {
        let out = dir.join("out");
        let err = assert_bad_input(
            &[
                "simulate",
                scenario,
                "--set",
                set,
                "-o",
                out.to_str().unwrap(),
            ],
            &[message],
        );
        assert!(!err.contains("shape mismatch"), "{err}");
        assert!(!out.exists(), "{set}: nothing written");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
