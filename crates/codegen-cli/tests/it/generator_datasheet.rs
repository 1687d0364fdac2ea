//! Generators from their datasheets (issue #20 item 4): the datasheet quantities with units
//! load as the SI constants (the damper kind's `[generator]` and the hybrid kind's
//! `[[force]]`), a unit of the wrong dimension is refused at its line, and with a lossy
//! gearbox the energy account closes and the summary's energy split adds up.

use crate::common;

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use codegen_cli::scenario::{self, Scenario};
use common::{assert_bad_input, damper, root};
use hybrid_core::generator::GeneratorSpec;
use hybrid_core::hybrid::ForceKind;

/// A fresh temporary directory with a copy of the models (so `../models/...` resolves from
/// `dir/scenarios/`).
fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("datasheet_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("scenarios")).unwrap();
    std::fs::create_dir_all(d.join("models")).unwrap();
    for m in ["double_bar.toml", "four_bar.toml"] {
        std::fs::copy(root().join("models").join(m), d.join("models").join(m)).unwrap();
    }
    d
}

/// `scenarios/<file>` with `old` replaced by `new`, written into `dir/scenarios/name`.
fn edited(dir: &Path, file: &str, name: &str, old: &str, new: &str) -> PathBuf {
    let text = std::fs::read_to_string(root().join("scenarios").join(file)).unwrap();
    assert!(text.contains(old), "edit {old:?} does not apply");
    let path = dir.join("scenarios").join(name);
    std::fs::write(&path, text.replacen(old, new, 1)).unwrap();
    path
}

/// The `[generator]` block of `scenarios/damper.toml`.
const DAMPER_GENERATOR: &str = "kt = 0.0235                 # N m / A
ke = 0.0235                 # V s / rad
armature_resistance = 1.5   # ohm
load_resistance = 3.5       # ohm
inductance = 0.0            # H
gear_ratio = 5.0
rotor_inertia = 1e-6        # kg m^2";

/// A small graphite-brush DC motor's datasheet (maxon-like) with a planetary gear.
const DATASHEET: &str = r#"torque_constant = "23.5 mNm/A"
speed_constant = "406 rpm/V"
terminal_resistance = "1.5 Ω"
load_resistance = "3500 mOhm"
terminal_inductance = "0.24 mH"
rotor_inertia = "10.5 g cm^2"
gear_ratio = 5
gear_efficiency = "85 %"
gear_friction = { coulomb = "0.5 mNm", viscous = "0.01 mNm/krpm", smoothing_speed = "10 rpm" }"#;

fn generator_of(path: &Path) -> GeneratorSpec {
    let text = std::fs::read_to_string(path).unwrap();
    let sc = match scenario::parse(&text, path).unwrap_or_else(|e| panic!("{e}")) {
        Scenario::Hybrid(sc) => sc,
        _ => panic!("not a hybrid scenario"),
    };
    match &sc.forces[0].kind {
        ForceKind::Generator(g) => g.clone(),
        k => panic!("{k:?}"),
    }
}

/// Every datasheet field of the damper kind's `[generator]` (rewritten into the hybrid
/// one) against its SI value computed by hand: exact for decimal prefixes, 1e-15 relative
/// through rpm.
#[test]
fn datasheet_fields_load_as_their_si_constants() {
    let dir = temp("load");
    let path = edited(&dir, "damper.toml", "d.toml", DAMPER_GENERATOR, DATASHEET);
    let g = generator_of(&path);
    let rpm = PI / 30.0;
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-15 * b.abs();
    assert_eq!(g.kt, 0.0235);
    assert!(close(g.ke, 60.0 / (2.0 * PI * 406.0)), "{}", g.ke);
    assert_eq!(g.armature_resistance, 1.5);
    assert_eq!(g.load_resistance, 3.5);
    assert_eq!(g.inductance, 2.4e-4);
    assert_eq!(g.rotor_inertia, 1.05e-6);
    assert_eq!(g.gear_ratio, 5.0);
    assert_eq!(g.gear_efficiency, 0.85);
    assert_eq!(g.gear_friction.coulomb, 5e-4);
    assert!(close(g.gear_friction.viscous, 1e-5 / (1000.0 * rpm)));
    assert!(close(g.gear_friction.smoothing_speed, 10.0 * rpm));
    // The SI numbers load unchanged, and one constant stands for both.
    let si = edited(
        &dir,
        "damper.toml",
        "si.toml",
        "ke = 0.0235                 # V s / rad\n",
        "",
    );
    let g = generator_of(&si);
    assert_eq!((g.kt, g.ke, g.gear_efficiency), (0.0235, 0.0235, 1.0));
    assert!(!g.has_gear_loss());
    // The hybrid kind's [[force]] table reads the same fields.
    let hybrid = edited(
        &dir,
        "two_dampers.toml",
        "h.toml",
        "kt = 0.0235                     # torque constant (N m / A)\nke = 0.0235                     # EMF constant (V s / rad)",
        "torque_constant = \"2.35 N·cm/A\"\nke = \"2.4609 mV/rpm\"",
    );
    let g = generator_of(&hybrid);
    assert_eq!(g.kt, 0.0235);
    assert!(close(g.ke, 2.4609e-3 / rpm), "{}", g.ke);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A unit of the wrong dimension, an unknown unit, a torque constant and a speed constant
/// that disagree, two names for one field: one line naming the file, the value's line, the
/// field and what was expected.
#[test]
fn a_wrong_unit_is_refused_at_its_line() {
    let dir = temp("bad");
    let cases: &[(&str, &str, &str, &[&str])] = &[
        (
            "torque_constant = \"23.5 mNm/A\"",
            "torque_constant = \"23.5 mNm\"",
            "torque_constant",
            &["torque_constant: \"23.5 mNm\" is a torque, expected a torque per current"],
        ),
        (
            "rotor_inertia = \"10.5 g cm^2\"",
            "rotor_inertia = \"10.5 g cm\"",
            "rotor_inertia",
            &["rotor_inertia: \"10.5 g cm\" is in kg m, expected a moment of inertia"],
        ),
        (
            "terminal_resistance = \"1.5 Ω\"",
            "terminal_resistance = \"1.5 Q\"",
            "terminal_resistance",
            &["unknown unit \"Q\""],
        ),
        (
            "speed_constant = \"406 rpm/V\"",
            "speed_constant = \"406 rad/s/V\"",
            "speed_constant",
            &["disagree by", "unit mistake"],
        ),
        (
            "terminal_inductance = \"0.24 mH\"",
            "terminal_inductance = \"0.24 mH\"\ninductance = 0.0",
            "terminal_inductance",
            &["give inductance or terminal_inductance, not both"],
        ),
        (
            "coulomb = \"0.5 mNm\"",
            "coulomb = \"0.5 mNm/A\"",
            "gear_friction",
            &["coulomb: \"0.5 mNm/A\" is a torque per current, expected a torque"],
        ),
        (
            "gear_efficiency = \"85 %\"",
            "gear_efficiency = \"185 %\"",
            "gear_efficiency",
            &["generator.gear_efficiency = 1.85e0 is outside its physical range [1e-2, 1e0]"],
        ),
    ];
    for (k, &(old, new, line_needle, needles)) in cases.iter().enumerate() {
        let base = edited(
            &dir,
            "damper.toml",
            "base.toml",
            DAMPER_GENERATOR,
            DATASHEET,
        );
        let text = std::fs::read_to_string(&base).unwrap();
        assert!(text.contains(old), "{old}");
        let path = dir.join("scenarios").join(format!("bad{k}.toml"));
        std::fs::write(&path, text.replacen(old, new, 1)).unwrap();
        let line = std::fs::read_to_string(&path)
            .unwrap()
            .lines()
            .position(|l| l.contains(line_needle))
            .unwrap()
            + 1;
        let at = format!("{}:{line}:", path.display());
        let out = dir.join("out");
        let mut all = vec![at.as_str(), "force \"generator\""];
        all.extend(needles);
        assert_bad_input(
            &[
                "simulate",
                path.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
                "--quiet",
            ],
            &all,
        );
        assert!(!out.exists());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs the paper's damper with `generator` for 0.5 s (free decay); its summary.
fn decay_summary(dir: &Path, name: &str, generator: &str) -> serde_json::Value {
    let path = edited(dir, "damper.toml", name, DAMPER_GENERATOR, generator);
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("t_end = 5.0", "t_end = 0.5");
    std::fs::write(&path, text).unwrap();
    let out = dir.join(format!("out_{name}"));
    let (code, stdout, stderr) = damper(&[
        "simulate",
        path.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(code, 0, "{stdout} {stderr}");
    serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap()
}

/// `(mechanical input, copper, gearbox, load, magnetic change, conversion, residual)` of
/// the first generator of a summary, checked against its other figures.
fn split(summary: &serde_json::Value) -> [f64; 7] {
    let g = &summary["generators"][0];
    let split = &g["energy_split"];
    let f = |k: &str| split[k].as_f64().unwrap_or_else(|| panic!("{k}: {split}"));
    let s = [
        f("mechanical_input"),
        f("copper_loss"),
        f("gearbox_loss"),
        f("load_energy"),
        f("magnetic_change"),
        f("conversion"),
        f("residual"),
    ];
    assert!(s[..4].iter().all(|&x| x > 0.0), "{split}");
    assert!((s[3] / s[1] - 3.5 / 1.5).abs() < 1e-12);
    assert_eq!(s[3], g["harvested_in_load"].as_f64().unwrap());
    assert_eq!(s[6], s[0] - (s[1] + s[2] + s[3] + s[4] + s[5]));
    let dissipated = summary["energy"]["dissipated_elements"]["generator"]
        .as_f64()
        .unwrap();
    assert!((dissipated - (s[1] + s[2] + s[3])).abs() <= 1e-12 * dissipated);
    s
}

/// The paper's damper with a lossy gearbox (the datasheet above: Coulomb and viscous
/// friction and 85 % efficiency, with inductance), free decay for 0.5 s: the energy account
/// closes to the integrator's truncation level, far below the gearbox loss, and the
/// mechanical input equals copper + gearbox + load + magnetic change + conversion loss to
/// the same level — with `k_t = k_e` (the torque constant alone: no conversion loss) and
/// with the datasheet's speed constant as well (`k_e` rounded 9e-4 below `k_t`), whose
/// conversion loss `(k_t - k_e) integral i w dt` is `k_t/k_e - 1` of the electrical energy.
#[test]
fn with_gearbox_loss_the_energy_account_closes_and_the_split_adds_up() {
    let dir = temp("energy");
    let kt = 0.0235;
    let ke = 60.0 / (2.0 * PI * 406.0);
    let ideal = DATASHEET.replace("speed_constant = \"406 rpm/V\"\n", "");
    for (name, generator, ratio) in [
        ("ideal.toml", ideal.as_str(), 1.0),
        ("datasheet.toml", DATASHEET, ke / kt),
    ] {
        let summary = decay_summary(&dir, name, generator);
        let [mech, copper, gear, load, magnetic, conversion, residual] = split(&summary);
        let balance = summary["energy"]["max_balance_error"].as_f64().unwrap();
        eprintln!(
            "{name}: split {:?}, balance error {balance:e}",
            split(&summary)
        );
        assert!(residual.abs() <= 1e-9 * mech, "{residual:e} vs {mech:e}");
        assert!(balance <= 2e-5 * gear, "{balance:e} vs {gear:e}");
        // (kt - ke) integral i w dt = (kt/ke - 1) integral ke i w dt, the electrical energy
        // (to the truncation of the two trapezoidal sums).
        let expected = (1.0 / ratio - 1.0) * (copper + load + magnetic);
        assert!(
            (conversion - expected).abs() <= 1e-9 * mech,
            "{conversion:e} vs {expected:e}"
        );
        if ratio == 1.0 {
            assert_eq!(conversion, 0.0);
        } else {
            assert!(conversion < -1e-4 * mech, "{conversion:e}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
