//! `damper simulate` on `kind = "hybrid"` scenarios: the bundled ones write their files with
//! the figures they promise, and every bad scenario is one line naming the file, the line,
//! the entity and why, exit 2, with no output.

use crate::common;

use std::path::{Path, PathBuf};

use common::{assert_bad_input, damper, root};

/// A fresh temporary directory for one test.
fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hybrid_cli_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `scenarios/two_dampers.toml` with edits, written next to a copy of the models (so the
/// relative model paths resolve) into `dir`; returns the scenario path.
fn edited(dir: &Path, name: &str, edits: &[(&str, &str)]) -> PathBuf {
    let mut text = std::fs::read_to_string(root().join("scenarios/two_dampers.toml")).unwrap();
    for (old, new) in edits {
        assert!(text.contains(old), "edit {old:?} does not apply");
        text = text.replacen(old, new, 1);
    }
    let scenarios = dir.join("scenarios");
    std::fs::create_dir_all(&scenarios).unwrap();
    let models = dir.join("models");
    std::fs::create_dir_all(&models).unwrap();
    for m in ["double_bar.toml", "four_bar.toml"] {
        std::fs::copy(root().join("models").join(m), models.join(m)).unwrap();
    }
    let path = scenarios.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// 1-based line of the first line containing `needle` in `path`.
fn line_of(path: &Path, needle: &str) -> usize {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .position(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("{needle:?} not in {}", path.display()))
        + 1
}

/// Runs a bad scenario: exit 2, one line with `file:line`, the needles, no output directory.
fn bad(path: &Path, line_needle: &str, needles: &[&str]) {
    let out = path.parent().unwrap().join("out");
    let file = path.display().to_string();
    let line = line_of(path, line_needle);
    let at = format!("{file}:{line}:");
    let mut all = vec![at.as_str()];
    all.extend(needles);
    assert_bad_input(
        &["simulate", &file, "-o", out.to_str().unwrap(), "--quiet"],
        &all,
    );
    assert!(!out.exists(), "no output for a bad scenario");
}

#[test]
fn two_dampers_reports_both_generators_and_closes_the_energy_balance() {
    let dir = temp("two");
    let out = dir.join("out");
    let (code, stdout, stderr) = damper(&[
        "simulate",
        "scenarios/two_dampers.toml",
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(code, 0, "{stdout} {stderr}");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let gens = summary["generators"].as_array().unwrap();
    assert_eq!(gens.len(), 2, "{summary}");
    let (l, r) = (
        gens[0]["harvested_in_load"].as_f64().unwrap(),
        gens[1]["harvested_in_load"].as_f64().unwrap(),
    );
    // The two dampers sit symmetrically on a symmetric beam in a symmetric initial shape.
    assert!(l > 0.0 && (l - r).abs() <= 1e-9 * l, "{l} vs {r}");
    // R_L / (R_a + R_L) = 3.5 / 5 of each generator's dissipation.
    let d = gens[0]["dissipated"].as_f64().unwrap();
    assert!((l / d - 0.7).abs() < 1e-12);
    // Trapezoidal power of the account at dt = 1e-4: O(dt^2) error.
    let rel = summary["energy_balance_rel_error"].as_f64().unwrap();
    assert!(rel < 1e-4, "{rel}");
    let zeta = summary["damping_ratio"].as_f64().unwrap();
    assert!(zeta > 0.002 && zeta < 0.2, "{zeta}");
    let csv = std::fs::read_to_string(out.join("time_history.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    for col in [
        "left.q1 [rad]",
        "right.cond_jd [-]",
        "left_pin.w [m]",
        "right_pin.amplification [rad/m]",
        "gen_left.current [A]",
        "gen_right.harvested [J]",
        "balance_error [J]",
    ] {
        assert!(header.contains(col), "{col} not in {header}");
    }
    // 30,000 steps, a row every 10 and the initial row, plus the header.
    assert_eq!(csv.lines().count(), 3002);
    assert!(out.join("beam_displacement.svg").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unknown_names_are_reported_with_file_line_and_entity() {
    let dir = temp("names");
    let p = edited(
        &dir,
        "a.toml",
        &[(
            "mechanism = \"right\"\npoint",
            "mechanism = \"rigth\"\npoint",
        )],
    );
    bad(
        &p,
        "\"rigth\"",
        &["attachment \"right_pin\"", "unknown mechanism \"rigth\""],
    );
    let p = edited(&dir, "b.toml", &[("point = \"tip\"", "point = \"tipp\"")]);
    bad(
        &p,
        "\"tipp\"",
        &[
            "attachment \"left_pin\"",
            "no point \"tipp\"",
            "points: tip",
        ],
    );
    let p = edited(&dir, "c.toml", &[("joint = \"crank\"", "joint = \"crnk\"")]);
    bad(
        &p,
        "\"crnk\"",
        &["force \"gen_left\"", "no body \"crnk\"", "crank, coupler"],
    );
    let p = edited(
        &dir,
        "d.toml",
        &[(
            "placement = { attachment = \"left_pin\", half_angle_deg = 10.0 }",
            "origin = [0.3333333333333333, -0.197]\ninitial = { q1 = 1.4, q9 = 0.3 }",
        )],
    );
    bad(
        &p,
        "q9",
        &["mechanism \"left\": initial", "unknown coordinate \"q9\""],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_attachments_name_the_entity_and_why() {
    let dir = temp("attach");
    // Outside the beam.
    let p = edited(&dir, "a.toml", &[("x = 0.6666666666666666", "x = 1.5")]);
    bad(
        &p,
        "x = 1.5",
        &["attachment \"right_pin\"", "must lie on the beam, 0 to 1 m"],
    );
    // On a support.
    let p = edited(&dir, "b.toml", &[("x = 0.6666666666666666", "x = 1.0")]);
    bad(
        &p,
        "x = 1.0          # 2/3",
        &["attachment \"right_pin\"", "a support locks it"],
    );
    // Over-constrained: the four-bar (3 coordinates, 2 loop rows) pinned (2 rows).
    let p = edited(
        &dir,
        "c.toml",
        &[
            (
                "model = \"../models/double_bar.toml\"\nplacement = { attachment = \"right_pin\", half_angle_deg = 10.0 }",
                "model = \"../models/four_bar.toml\"\ninitial = { q1 = 0.6, q2 = 1.2, q3 = 1.9 }",
            ),
            (
                "mechanism = \"right\"\npoint = \"tip\"",
                "mechanism = \"right\"\npoint = \"coupler_end\"",
            ),
        ],
    );
    bad(
        &p,
        "name = \"right\"",
        &[
            "mechanism \"right\"",
            "over-constrained: 4 constraint rows (2 loop row(s) + 2 attachment row(s)) for 3 coordinate(s)",
        ],
    );
    // No beam.
    let text = std::fs::read_to_string(root().join("scenarios/two_dampers.toml")).unwrap();
    let start = text.find("[beam]").unwrap();
    let end = text.find("# The first damper").unwrap();
    let (i0, i1) = (
        text.find("[initial]").unwrap(),
        text.find("[integrator]").unwrap(),
    );
    let no_beam = format!("{}{}{}", &text[..start], &text[end..i0], &text[i1..]);
    let p = edited(&dir, "d.toml", &[]);
    std::fs::write(&p, no_beam).unwrap();
    bad(
        &p,
        "x = 0.3333333333333333",
        &["attachment \"left_pin\"", "there is no [beam]"],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_point_on_ground_or_that_cannot_move_is_refused() {
    let dir = temp("ground");
    let p = edited(&dir, "a.toml", &[]);
    // A copy of the double bar with a point on the ground body and one on the crank's pivot.
    let model = std::fs::read_to_string(root().join("models/double_bar.toml")).unwrap()
        + "\n[[points]]\nname = \"base\"\nbody = \"ground\"\nposition = [0.0, 0.0, 0]\n\n[[points]]\nname = \"hub\"\nbody = \"crank\"\nposition = [0.0, 0.0, 0]\n";
    std::fs::write(dir.join("models/grounded.toml"), model).unwrap();
    let text = std::fs::read_to_string(&p).unwrap().replace(
        "name = \"right\"\nmodel = \"../models/double_bar.toml\"\nplacement = { attachment = \"right_pin\", half_angle_deg = 10.0 }",
        "name = \"right\"\nmodel = \"../models/grounded.toml\"\norigin = [0.6666666666666666, 0.0]",
    );
    assert!(text.contains("grounded"));
    let roller = text.replace(
        "mechanism = \"right\"\npoint = \"tip\"\nkind = \"pin\"",
        "mechanism = \"right\"\npoint = \"base\"\nkind = \"roller\"",
    );
    std::fs::write(&p, &roller).unwrap();
    bad(
        &p,
        "point = \"base\"",
        &[
            "attachment \"right_pin\"",
            "point \"base\" is on the ground body",
        ],
    );
    let hub = text.replace(
        "mechanism = \"right\"\npoint = \"tip\"\nkind = \"pin\"",
        "mechanism = \"right\"\npoint = \"hub\"\nkind = \"roller\"",
    );
    std::fs::write(&p, &hub).unwrap();
    bad(
        &p,
        "point = \"hub\"",
        &[
            "attachment \"right_pin\"",
            "does not move",
            "Jacobian is zero",
        ],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn every_problem_of_a_file_is_reported_at_once() {
    let dir = temp("many");
    let p = edited(
        &dir,
        "a.toml",
        &[
            ("kind = \"pin\"", "kind = \"pinn\""),
            ("t_end = 3.0", "t_end = -1.0"),
            ("elements = 24", "elements = 24\ncolour = \"red\""),
        ],
    );
    let out = dir.join("out");
    let (code, stdout, stderr) =
        damper(&["simulate", p.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(code, 2, "{stdout} {stderr}");
    for needle in ["unknown kind \"pinn\"", "t_end", "colour"] {
        assert!(stderr.contains(needle), "{needle}: {stderr}");
    }
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_time_table_from_csv_drives_an_excitation_and_bad_rows_name_the_csv_line() {
    let dir = temp("table");
    let add = "[initial]\n";
    let exc = "[[excitation]]\nname = \"hammer\"\nat = { x = 0.5 }\namplitude = 1.0\ntime = { kind = \"table\", file = \"force.csv\" }\n\n[initial]\n";
    let p = edited(
        &dir,
        "a.toml",
        &[(add, exc), ("t_end = 3.0", "t_end = 0.05")],
    );
    let table = p.parent().unwrap().join("force.csv");
    std::fs::write(&table, "t,value\n0.0,0.0\n0.001,2.0\n0.002,0.0\n").unwrap();
    let out = dir.join("out");
    let (code, stdout, stderr) = damper(&[
        "simulate",
        p.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(code, 0, "{stdout} {stderr}");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let work = summary["excitations"][0]["work"].as_f64().unwrap();
    assert!(work != 0.0 && work.is_finite(), "{summary}");
    assert!(
        summary.get("damping_ratio").is_none(),
        "no free decay: {summary}"
    );
    std::fs::write(
        &table,
        "t,value\n0.0,0.0\n0.001,abc\n0.002,1.0\n0.0015,1.0\n",
    )
    .unwrap();
    let out2 = dir.join("out2");
    let e = assert_bad_input(
        &[
            "simulate",
            p.to_str().unwrap(),
            "-o",
            out2.to_str().unwrap(),
        ],
        &[
            "force.csv:3",
            "force.csv:5",
            "0.0015 does not come after 0.002",
        ],
    );
    assert!(!out2.exists(), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `two_dampers.toml` asks for both comparison runs: each writes its own time history
/// (the bare beam read at the attachments' beam points), a summary block and a series of
/// the plots, and each run's free-decay damping is its linearised first mode's (the bare
/// beam: Rayleigh's 0.2 % within 1e-4; the generators disconnected: within 1 % at 1 mm, as
/// the run as described).
#[test]
fn two_dampers_writes_its_comparison_runs() {
    let out = std::env::temp_dir().join(format!("damper-compare-{}", std::process::id()));
    let o = out.to_str().unwrap();
    let (code, stdout, err) =
        damper(&["simulate", "scenarios/two_dampers.toml", "-o", o, "--quiet"]);
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("generator disconnected"), "{stdout}");
    assert!(stdout.contains("bare beam"), "{stdout}");
    for f in [
        "time_history.csv",
        "time_history_generator_disconnected.csv",
        "time_history_bare_beam.csv",
        "damping_vs_amplitude.svg",
        "beam_displacement.svg",
        "summary.json",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let bare = std::fs::read_to_string(out.join("time_history_bare_beam.csv")).unwrap();
    let header = bare.lines().next().unwrap();
    assert!(
        header.contains("left_pin.w [m]") && header.contains("right_pin.w [m]"),
        "{header}"
    );
    assert!(
        !header.contains("left.crank"),
        "no mechanism in the bare beam: {header}"
    );
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let (code, text, err) = damper(&[
        "linearize",
        "scenarios/two_dampers.toml",
        "--json",
        "--modes",
        "1",
    ]);
    assert_eq!(code, 0, "{err}");
    let lin: serde_json::Value = serde_json::from_str(&text).unwrap();
    let z = |v: &serde_json::Value| v.as_f64().unwrap();
    let bare_lin = z(&lin["bare_beam"][0]["damping_ratio"]);
    let off_lin = z(&lin["generator_disconnected"][0]["damping_ratio"]);
    let c = &s["comparisons"];
    let bare_td = z(&c["bare_beam"]["damping_ratio"]);
    let off_td = z(&c["generator_disconnected"]["damping_ratio"]);
    assert!(
        (bare_td - bare_lin).abs() <= 1e-4 * bare_lin,
        "{bare_td} vs {bare_lin}"
    );
    assert!(
        (off_td - off_lin).abs() <= 0.01 * off_lin,
        "{off_td} vs {off_lin}"
    );
    assert!(z(&s["damping_ratio"]) > 5.0 * off_td, "the generators damp");
    for key in ["bare_beam", "generator_disconnected"] {
        assert!(z(&c[key]["energy_balance_rel_error"]) < 1e-4, "{key}");
        assert_eq!(
            z(&c[key]["peak_amplitude"]),
            z(&s["peak_amplitude"]),
            "{key}: same start"
        );
    }
    let _ = std::fs::remove_dir_all(&out);
}
