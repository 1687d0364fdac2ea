//! `damper linearize`: every bundled damper and hybrid scenario linearises with finite,
//! converged modes; the three variants (generator connected, disconnected, bare beam) are
//! labelled and ordered; `--set` changes the operating point; bad input is one line.

use crate::common;

use common::{assert_bad_input, bundled_scenarios, damper};

fn json(args: &[&str]) -> serde_json::Value {
    let (code, out, err) = damper(args);
    assert_eq!(code, 0, "{args:?}: {err}");
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("{args:?}: {e}: {out}"))
}

#[test]
fn every_bundled_scenario_linearises_with_converged_modes() {
    let mut done = 0;
    for path in bundled_scenarios() {
        let text = std::fs::read_to_string(&path).unwrap();
        let p = path.display().to_string();
        if text.contains("kind = \"mechanism\"") {
            assert_bad_input(&["linearize", &p], &["no beam to linearise", ".toml"]);
            continue;
        }
        let r = json(&["linearize", &p, "--modes", "4", "--json"]);
        for variant in [
            "modes",
            "generator_disconnected",
            "bare_beam",
            "bare_structure",
        ] {
            let Some(modes) = r[variant].as_array() else {
                continue;
            };
            assert_eq!(modes.len(), 4, "{p}: {variant}");
            let mut last = 0.0;
            for m in modes {
                let f = m["natural_frequency_hz"].as_f64().unwrap();
                let z = m["damping_ratio"].as_f64().unwrap();
                let e = m["backward_error"].as_f64().unwrap();
                assert!(
                    f >= last && f.is_finite(),
                    "{p}: {variant}: increasing |lambda|"
                );
                assert!(z.is_finite() && z > 0.0, "{p}: {variant}: damped, stable");
                assert!(e < 1e-12, "{p}: {variant}: backward error {e:e}");
                // The shape: along the beam, or at the structure's nodes.
                let shape = if text.contains("[structure]") {
                    "structure_shape"
                } else {
                    "beam_shape"
                };
                assert!(!m[shape].as_array().unwrap().is_empty(), "{p}: {shape}");
                last = f;
            }
        }
        done += 1;
    }
    assert!(done >= 5, "damper and hybrid scenarios linearised: {done}");
}

#[test]
fn the_generator_adds_damping_and_the_half_angle_moves_it() {
    let at = |angle: &str| {
        let set = format!("mechanism.half_angle_deg={angle}");
        json(&[
            "linearize",
            "scenarios/damper.toml",
            "--json",
            "--set",
            &set,
        ])
    };
    let z = |r: &serde_json::Value, v: &str| r[v][0]["damping_ratio"].as_f64().unwrap();
    let (r10, r20) = (at("10"), at("20"));
    assert_eq!(r10["overrides"][0]["path"], "mechanism.half_angle_deg");
    assert_eq!(r10["overrides"][0]["value"], 10);
    // Closer to the toggle: more amplification, more damping of the first mode.
    let a = |r: &serde_json::Value| {
        r["amplification"][0]["joint_per_displacement"]
            .as_f64()
            .unwrap()
    };
    assert!(a(&r10) > a(&r20));
    assert!(z(&r10, "modes") > z(&r20, "modes"));
    // Disconnected: the structure's damping only, near the bare beam's Rayleigh 0.2 %.
    for r in [&r10, &r20] {
        assert!(z(r, "modes") > 5.0 * z(r, "generator_disconnected"));
        assert!((z(r, "bare_beam") - 0.002).abs() < 1e-12);
    }
}

#[test]
fn bad_linearize_input_is_one_line() {
    assert_bad_input(
        &["linearize", "scenarios/damper.toml", "--modes", "0"],
        &["--modes"],
    );
    // A usage error is clap's (exit 2, the message and a hint).
    let (code, _, err) = damper(&["linearize", "scenarios/damper.toml", "--method", "qr"]);
    assert_eq!(code, 2);
    assert!(
        err.contains("expected auto, dense or shift-invert"),
        "{err}"
    );
    assert_bad_input(&["linearize", "scenarios/nope.toml"], &["nope.toml"]);
    assert_bad_input(
        &[
            "linearize",
            "scenarios/damper.toml",
            "--set",
            "generator.load_resistance=-1",
        ],
        &["load_resistance"],
    );
}

#[test]
fn eigen_solves_above_the_limits_are_refused_unless_allow_long() {
    let fine = [
        "linearize",
        "scenarios/damper.toml",
        "--set",
        "beam.segment[0].elements=3000",
    ];
    let with = |extra: &[&'static str]| {
        let mut v = fine.to_vec();
        v.extend_from_slice(extra);
        v
    };
    // A dense solve of about 12,000 states: gigabytes.
    assert_bad_input(
        &with(&["--method", "dense"]),
        &["GiB of memory", "dense", "--allow-long"],
    );
    // Every mode by Arnoldi: the Krylov space is the whole space.
    assert_bad_input(
        &with(&["--method", "shift-invert", "--modes", "1000000000"]),
        &["GiB of memory", "Arnoldi", "--allow-long"],
    );
    // A few modes of the same beam, and every mode of the small one, are within the limits.
    let (code, _, err) = damper(&with(&["--modes", "2"]));
    assert_eq!(code, 0, "{err}");
    let (code, out, err) = damper(&[
        "linearize",
        "scenarios/damper.toml",
        "--modes",
        "1000000000",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("modes of the bare beam"), "{out}");
}

/// The exact tangents of every bundled damper and hybrid scenario, about its equilibrium
/// (as bundled, and preloaded by in-plane gravity on the double bar and the absorber's
/// arm), equal central differences of the independent dense KKT accelerations
/// (`hybrid_core::hybrid::reference::tangent_error`) to 1e-7 relative.
#[test]
fn tangents_of_every_bundled_scenario_equal_differences_of_the_kkt_system() {
    use codegen_cli::scenario::{self, Override};
    use codegen_cli::setup::tangents_for;
    use hybrid_core::hybrid::reference::tangent_error;
    let gravity = |path: &str, g: &str| {
        let text = format!("{{ {g} = -9.81 }}");
        Override::new(path, text.parse::<toml_edit::Value>().unwrap(), &text).unwrap()
    };
    let mut checked = 0;
    for path in bundled_scenarios() {
        let text = std::fs::read_to_string(&path).unwrap();
        // Mechanisms alone have no linearisation; an imported structure none yet (#30).
        if text.contains("kind = \"mechanism\"") || text.contains("[structure]") {
            continue;
        }
        let mut variants = vec![vec![]];
        if text.contains("double_bar.toml") && !text.contains("kind = \"hybrid\"") {
            variants.push(vec![gravity("mechanism.parameters", "gy")]);
        }
        if text.contains("absorber.toml") {
            variants.push(vec![gravity("mechanism[0].parameters", "gy")]);
        }
        for overrides in variants {
            let loaded = scenario::load_with(&path, &overrides)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let input = tangents_for(&loaded.scenario).unwrap();
            let lin = input.linearize(&input.model).unwrap();
            let worst = tangent_error(&input.model, &lin, 11);
            let preload = lin
                .equilibrium
                .multipliers
                .iter()
                .flatten()
                .fold(0.0f64, |m, l| m.max(l.abs()));
            println!(
                "{} {:?}: worst {worst:e}, largest multiplier {preload:e}",
                path.display(),
                overrides.len()
            );
            assert!(worst < 1e-7, "{}: {worst:e}", path.display());
            if !overrides.is_empty() {
                assert!(preload > 1e-3, "gravity preloads the attachment");
            }
            checked += 1;
        }
    }
    assert!(checked >= 7, "{checked}");
}
