//! `--set PATH=VALUE` overrides on `damper simulate`, and `damper sweep` / `damper merge`:
//! grid parsing, failed points recorded, results independent of the thread count, and
//! sharded runs (separate processes, as a Slurm job array runs them) merged byte for byte
//! into the unsharded files.

use crate::common;

use std::path::{Path, PathBuf};

use codegen_cli::analysis::sweep::{Grid, parse_values};
use common::{assert_bad_input, damper, root};
use toml_edit::Value;

/// A fresh scratch directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("damper-sweep-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap()
}

fn floats(values: &[Value]) -> Vec<f64> {
    values
        .iter()
        .map(|v| v.as_float().expect("a float"))
        .collect()
}

#[test]
fn a_b_n_ranges_have_exact_endpoints_and_lists_are_toml_values() {
    let v = floats(&parse_values("0.1:0.7:7").unwrap());
    assert_eq!(v.len(), 7);
    assert_eq!(v[0], 0.1);
    assert_eq!(v[6], 0.7);
    for (k, x) in v.iter().enumerate() {
        if k < 6 {
            assert_eq!(*x, 0.1 + (0.7 - 0.1) * k as f64 / 6.0, "point {k}");
        }
    }
    assert_eq!(
        floats(&parse_values("5.0:20:4").unwrap()),
        [5.0, 10.0, 15.0, 20.0]
    );
    assert_eq!(floats(&parse_values("1:2:3").unwrap()), [1.0, 1.5, 2.0]);
    // Integers stay integers when the step is whole (element counts).
    let ints: Vec<i64> = parse_values("10:40:4")
        .unwrap()
        .iter()
        .map(|v| v.as_integer().unwrap())
        .collect();
    assert_eq!(ints, [10, 20, 30, 40]);
    let list = parse_values("0.5,1,abc,[1, 2],{ a = 1 }").unwrap();
    assert_eq!(list.len(), 5);
    assert_eq!(list[0].as_float(), Some(0.5));
    assert_eq!(list[1].as_integer(), Some(1));
    assert_eq!(list[2].as_str(), Some("abc"));
    assert!(list[3].is_array() && list[4].is_inline_table());
    assert!(parse_values("1:2:1").is_err());
    assert!(parse_values("1,,2").is_err());
    // The last option varies fastest.
    let g = Grid::parse(&["a=1,2".into(), "b=x,y,z".into()]).unwrap();
    assert_eq!(g.len(), 6);
    let p = |i| {
        g.point(i)
            .iter()
            .map(|v| v.to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    assert_eq!(p(0), "1 \"x\"");
    assert_eq!(p(2), "1 \"z\"");
    assert_eq!(p(3), "2 \"x\"");
}

#[test]
fn set_changes_the_result_and_is_recorded_in_the_summary() {
    let dir = scratch("set");
    let run = |name: &str, sets: &[&str]| {
        let out = dir.join(name);
        let mut args = vec!["simulate", "scenarios/damper.toml", "--quiet", "-o"];
        let out_s = out.to_str().unwrap().to_string();
        args.push(&out_s);
        for s in sets {
            args.extend(["--set", s]);
        }
        let (code, _, err) = damper(&args);
        assert_eq!(code, 0, "{err}");
        summary(&out)
    };
    let base = run("base", &["integrator.t_end=0.5"]);
    let high = run(
        "high",
        &["integrator.t_end=0.5", "generator.load_resistance=10"],
    );
    let z = |s: &serde_json::Value| s["damping_ratio"].as_f64().unwrap();
    // A larger load resistance lowers the current, hence the electrical damping.
    assert!(z(&high) < 0.6 * z(&base), "{} vs {}", z(&high), z(&base));
    assert_eq!(
        high["overrides"],
        serde_json::json!([
            {"path": "integrator.t_end", "value": 0.5},
            {"path": "generator.load_resistance", "value": 10}
        ])
    );
    assert_eq!(high["generators"][0]["settings"]["load_resistance"], 10.0);
    // A hybrid scenario: a field of the second mechanism.
    let out = dir.join("hybrid");
    let (code, _, err) = damper(&[
        "simulate",
        "scenarios/two_dampers.toml",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
        "--set",
        "integrator.t_end=0.01",
        "--set",
        "mechanism[1].placement.half_angle_deg=12.5",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(
        summary(&out)["overrides"][1],
        serde_json::json!({"path": "mechanism[1].placement.half_angle_deg", "value": 12.5})
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_overrides_are_one_line_naming_the_option_and_write_nothing() {
    let dir = scratch("bad");
    let out = dir.join("out");
    let out_s = out.to_str().unwrap();
    for (set, needles) in [
        (
            "mechanizm.x=1",
            vec!["--set mechanizm.x=1", "no `mechanizm`"],
        ),
        (
            "beam.segment[3].elements=4",
            vec!["--set beam.segment[3].elements=4", "index 3 out of range"],
        ),
        (
            "mechanism.half_angle_deg=-1",
            vec!["--set mechanism.half_angle_deg=-1", "between 0"],
        ),
        (
            "mechanism.half_angle_deg=abc",
            vec!["--set mechanism.half_angle_deg=abc", "invalid type"],
        ),
        (
            "beam.segment[0].elements=0",
            vec!["--set beam.segment[0].elements=0", "at least 1"],
        ),
        (
            "mechanism.half_angel_deg=5",
            vec![
                "--set mechanism.half_angel_deg=5",
                "unknown field `half_angel_deg`",
            ],
        ),
    ] {
        let err = assert_bad_input(
            &[
                "simulate",
                "scenarios/damper.toml",
                "--quiet",
                "-o",
                out_s,
                "--set",
                set,
            ],
            &needles,
        );
        // Not a misleading line of the file: the option is named instead.
        assert!(err.contains("damper.toml: --set "), "{err}");
        assert!(!out.exists(), "{set}: no output directory");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn range_and_list_cannot_be_mixed() {
    // `2,10:20:3` is a list of two TOML values: `10:20:3` is then a string.
    let v = parse_values("2,10:20:3").unwrap();
    assert_eq!(v[1].as_str(), Some("10:20:3"));
}

fn read(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn sweeps_record_failed_points_and_do_not_depend_on_threads_or_shards() {
    let dir = scratch("grid");
    let spec = [
        "--set",
        "mechanism.half_angle_deg=2,8,12,16,20",
        "--set",
        "generator.load_resistance=1,10",
    ];
    let run = |out: &Path, extra: &[&str]| {
        let mut args = vec![
            "sweep",
            "scenarios/damper.toml",
            "--time-domain",
            "--quiet",
            "--t-end",
            "0.5",
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend(spec);
        args.extend(extra);
        let (code, stdout, err) = damper(&args);
        assert_eq!(code, 0, "{err}");
        assert!(stdout.is_empty(), "{stdout}");
        err
    };
    let one = dir.join("one");
    let err = run(&one, &["--threads", "1"]);
    // At 2 degrees the mechanism cannot reach the 1 mm initial displacement: the
    // time-domain run fails, the linearised figures (about the rest position) are kept.
    assert!(
        err.contains("10 of 10 point(s)")
            && err.contains("0 failed (2 time-domain run(s) failed, their linear figures kept)"),
        "{err}"
    );
    let two = dir.join("two");
    run(&two, &["--threads", "2"]);
    assert_same_outputs(&one, &two, "1 vs 2 threads");
    // Grid order, failed points recorded with their error, the others computed.
    let csv = String::from_utf8(read(&one.join("sweep.csv"))).unwrap();
    let mut rows = csv::Reader::from_reader(csv.as_bytes());
    let header = rows.headers().unwrap().clone();
    assert_eq!(&header[0], "index");
    assert_eq!(&header[1], "mechanism.half_angle_deg");
    assert_eq!(&header[2], "generator.load_resistance");
    assert_eq!(&header[3], "linear.f1 [Hz]");
    assert_eq!(&header[header.len() - 2], "error");
    assert_eq!(&header[header.len() - 1], "time_domain_error");
    let f1_col = 3;
    let zeta_col = header
        .iter()
        .position(|h| h == "damping_ratio [-]")
        .expect("time-domain figures after the linearised ones");
    assert!(header.iter().any(|h| h == "linear.zeta1 [-]"));
    let rows: Vec<csv::StringRecord> = rows.records().map(Result::unwrap).collect();
    assert_eq!(rows.len(), 10);
    let angles: Vec<&str> = rows.iter().map(|r| r.get(1).unwrap()).collect();
    assert_eq!(
        angles,
        ["2", "2", "8", "8", "12", "12", "16", "16", "20", "20"]
    );
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r.get(0).unwrap(), i.to_string());
        assert!(r.get(header.len() - 2).unwrap().is_empty());
        let error = r.get(header.len() - 1).unwrap();
        let f1: f64 = r.get(f1_col).unwrap().parse().unwrap();
        assert!(f1 > 1.0, "point {i}: linear f1 {f1}");
        if i < 2 {
            assert!(error.contains("cannot reach the beam point"), "{error}");
            assert!(r.get(zeta_col).unwrap().is_empty());
        } else {
            assert!(error.is_empty(), "{error}");
            let zeta: f64 = r.get(zeta_col).unwrap().parse().unwrap();
            assert!(zeta > 0.005 && zeta < 0.5, "point {i}: zeta {zeta}");
        }
    }
    // Less damping with the larger load resistance, at every angle.
    for pair in rows[2..].chunks(2) {
        let z = |r: &csv::StringRecord| r.get(zeta_col).unwrap().parse::<f64>().unwrap();
        assert!(z(&pair[1]) < z(&pair[0]));
    }
    let json: serde_json::Value = serde_json::from_slice(&read(&one.join("sweep.json"))).unwrap();
    assert_eq!(json["grid_size"], 10);
    assert_eq!(json["failed"], 0);
    assert_eq!(json["time_domain_failed"], 2);
    assert_eq!(json["scenario"], "scenarios/damper.toml");
    assert_eq!(json["points"][2]["parameters"], serde_json::json!([8, 1]));

    // Shards as separate processes (as a Slurm job array runs them), then merged.
    for n in [1usize, 2, 3, 7] {
        let sharded = dir.join(format!("shards-{n}"));
        for i in 0..n {
            let shard = format!("{i}/{n}");
            run(&sharded, &["--shard", &shard, "--threads", "1"]);
        }
        assert!(!sharded.join("sweep.csv").exists());
        let (code, _, err) = damper(&["merge", sharded.to_str().unwrap()]);
        assert_eq!(code, 0, "{err}");
        assert_same_outputs(&one, &sharded, &format!("{n} shards"));
    }

    // A missing shard, a shard given twice, parts of different sweeps.
    let s3 = dir.join("shards-3");
    let part = |i: usize| s3.join(format!("sweep.part-{i}-of-3.json"));
    let merged = dir.join("merged").to_str().unwrap().to_string();
    let p = |i| part(i).to_str().unwrap().to_string();
    assert_bad_input(
        &["merge", &p(0), &p(2), "-o", &merged],
        &["missing shard", "sweep.part-1-of-3.json"],
    );
    assert_bad_input(
        &["merge", &p(0), &p(1), &p(1), &p(2), "-o", &merged],
        &["shard 1 of 3 given twice"],
    );
    let other = dir.join("other");
    let mut args = vec![
        "sweep",
        "scenarios/damper.toml",
        "--time-domain",
        "--quiet",
        "--t-end",
        "0.5",
        "-o",
        other.to_str().unwrap(),
        "--set",
        "mechanism.half_angle_deg=2,8,12,16,20",
        "--set",
        "generator.load_resistance=1,11",
        "--shard",
        "1/3",
    ];
    let (code, _, err) = damper(&args);
    assert_eq!(code, 0, "{err}");
    let other_part = other.join("sweep.part-1-of-3.json");
    assert_bad_input(
        &[
            "merge",
            &p(0),
            other_part.to_str().unwrap(),
            &p(2),
            "-o",
            &merged,
        ],
        &["parts of different sweeps", "--set specs"],
    );
    // The same specs on a different scenario text.
    let scenario = dir.join("damper.toml");
    let text = std::fs::read_to_string(root().join("scenarios/damper.toml")).unwrap();
    std::fs::write(
        &scenario,
        text.replace("../models/", &format!("{}/models/", root().display()))
            .replace("rotor_inertia = 1e-6", "rotor_inertia = 2e-6"),
    )
    .unwrap();
    let scenario_s = scenario.to_str().unwrap().to_string();
    args[1] = &scenario_s;
    args[11] = "generator.load_resistance=1,10";
    let (code, _, err) = damper(&args);
    assert_eq!(code, 0, "{err}");
    assert_bad_input(
        &[
            "merge",
            &p(0),
            other_part.to_str().unwrap(),
            &p(2),
            "-o",
            &merged,
        ],
        &["parts of different sweeps", "scenario content"],
    );
    assert!(!Path::new(&merged).exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_sweep_specs_are_one_line_and_write_nothing() {
    let dir = scratch("badspec");
    let out = dir.join("out");
    let out_s = out.to_str().unwrap();
    let base = [
        "sweep",
        "scenarios/damper.toml",
        "--time-domain",
        "-o",
        out_s,
    ];
    let with = |extra: &[&'static str]| {
        let mut a: Vec<&str> = base.to_vec();
        a.extend(extra);
        a
    };
    assert_bad_input(&with(&["--set", "a=1:2:1"]), &["--set a=1:2:1", "n >= 2"]);
    assert_bad_input(
        &with(&["--set", "mechanism.x=1", "--shard", "3/3"]),
        &["--shard 3/3"],
    );
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every file a (time-domain) sweep of the damper writes is the same, byte for byte, in
/// `a` and `b`.
/// Every file of sweep `a` is in `b`, byte for byte, and `b` has no other (sweep.csv and
/// sweep.json at least).
fn assert_same_outputs(a: &std::path::Path, b: &std::path::Path, what: &str) {
    let names = |d: &std::path::Path| -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with("sweep") && !n.starts_with("sweep.part-"))
            .collect();
        v.sort();
        v
    };
    let files = names(a);
    assert!(files.iter().any(|f| f == "sweep.csv") && files.iter().any(|f| f == "sweep.json"));
    assert_eq!(files, names(b), "{what}");
    for f in &files {
        let read =
            |d: &std::path::Path| std::fs::read(d.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert_eq!(read(a), read(b), "{f}: {what}");
    }
}

#[test]
fn oversized_sweeps_are_refused_in_one_line_before_any_work() {
    let dir = scratch("limits");
    let out = dir.join("out");
    let out_s = out.to_str().unwrap().to_string();
    let sweep = |scenario: &'static str, extra: &[&str]| {
        let mut a = vec!["sweep", scenario, "--quiet", "-o", &out_s];
        a.extend_from_slice(extra);
        assert_bad_input(&a, &[]).trim_end().to_string()
    };
    // Refused before the scenario is read (the file does not exist): no work at all.
    let e = sweep("no-such.toml", &["--set", "generator.kt=1:1e9:1000000000"]);
    assert!(
        e.contains("1.00e9 grid points") && e.contains("--allow-long"),
        "{e}"
    );
    let e = sweep(
        "no-such.toml",
        &[
            "--set",
            "generator.kt=1:2:10000",
            "--set",
            "generator.ke=1:2:10000",
        ],
    );
    assert!(
        e.contains("1.00e8 grid points") && e.contains("--shard"),
        "{e}"
    );
    // 2^64 points: no wrap to an empty grid.
    let e = sweep(
        "no-such.toml",
        &[
            "--set",
            "generator.kt=1:2:65536",
            "--set",
            "generator.ke=1:2:65536",
            "--set",
            "generator.inductance=1:2:65536",
            "--set",
            "generator.load_resistance=1:2:65536",
        ],
    );
    assert!(
        e.contains("65536 x 65536 x 65536 x 65536 = 1.84e19 points"),
        "{e}"
    );
    // Many axes: the line names their number, not every factor.
    let many: Vec<String> = (0..70).map(|_| "generator.kt=1:2:2".to_string()).collect();
    let mut args: Vec<&str> = vec![];
    for m in &many {
        args.extend(["--set", m.as_str()]);
    }
    let e = sweep("no-such.toml", &args);
    assert!(
        e.contains("the product of 70 axes = 1.18e21 points") && e.len() < 300,
        "{e}"
    );
    let huge = ["--set", "generator.kt=0:1:18446744073709551615"];
    let e = sweep("no-such.toml", &huge);
    assert!(e.contains("1.84e19 grid points"), "{e}");
    // With --allow-long, the values that cannot be allocated are an error, not a panic.
    let e = sweep("no-such.toml", &[huge[0], huge[1], "--allow-long"]);
    // (refused by the memory estimate, beyond the machine whatever the flag, before any
    // allocation is tried).
    assert!(
        e.contains("do not fit in memory") || e.contains("more than this machine's memory"),
        "{e}"
    );
    // The time-domain run of a point is bounded as `simulate` bounds it.
    let e = sweep(
        "scenarios/damper.toml",
        &[
            "--set",
            "generator.load_resistance=1,10",
            "--time-domain",
            "--t-end",
            "3000",
        ],
    );
    assert!(
        e.contains("9.00e7 time steps a point") && e.contains("--allow-long"),
        "{e}"
    );
    let e = assert_bad_input(
        &[
            "simulate",
            "scenarios/damper.toml",
            "--set",
            "integrator.t_end=3000",
            "-o",
            &out_s,
        ],
        &["9.00e7 steps"],
    );
    assert!(e.contains("--allow-long"));
    assert!(!out.exists(), "nothing written");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_point_above_the_step_limit_records_it_and_threads_are_capped_to_the_machine() {
    let dir = scratch("point-limit");
    let out = dir.join("out");
    let (code, stdout, err) = damper(&[
        "sweep",
        "scenarios/damper.toml",
        "--quiet",
        "--time-domain",
        "--set",
        "integrator.t_end=0.05,3000",
        "--threads",
        "100000",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(stdout.is_empty(), "{stdout}");
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    assert!(
        err.contains(&format!("--threads 100000 capped to {cores}")),
        "{err}"
    );
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    let mut rows = csv::Reader::from_reader(csv.as_bytes());
    let rows: Vec<csv::StringRecord> = rows.records().map(Result::unwrap).collect();
    let error = |r: &csv::StringRecord| r.get(r.len() - 1).unwrap().to_string();
    assert_eq!(error(&rows[0]), "");
    assert!(
        error(&rows[1]).contains("9.00e7 time steps") && error(&rows[1]).contains("--allow-long"),
        "{}",
        error(&rows[1])
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The two parts (`--shard 0/2`, `1/2`) of a linearised sweep of three points in `dir`.
fn two_parts(dir: &Path, set: &str) -> [PathBuf; 2] {
    for shard in ["0/2", "1/2"] {
        let (code, _, err) = damper(&[
            "sweep",
            "scenarios/damper.toml",
            "--quiet",
            "--set",
            set,
            "--shard",
            shard,
            "-o",
            dir.to_str().unwrap(),
        ]);
        assert_eq!(code, 0, "{err}");
    }
    [0, 1].map(|i| dir.join(format!("sweep.part-{i}-of-2.json")))
}

#[test]
fn merge_refuses_edited_deleted_non_finite_truncated_and_foreign_parts() {
    use codegen_cli::analysis::sweep::Part;
    let dir = scratch("tamper");
    let good = two_parts(&dir.join("good"), "generator.load_resistance=1,10,100");
    let other = two_parts(&dir.join("other"), "generator.load_resistance=1,10,1000");
    let merged = dir.join("merged");
    let merged_s = merged.to_str().unwrap().to_string();
    let text = std::fs::read_to_string(&good[0]).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let edit = |f: &dyn Fn(&mut serde_json::Value)| {
        let mut j = json.clone();
        f(&mut j);
        serde_json::to_string_pretty(&j).unwrap()
    };
    let set_value = |v: &'static str| {
        edit(&move |j| j["rows"][0]["figures"][0]["value"] = serde_json::json!(v))
    };
    let mut huge: Part = serde_json::from_str(&text).unwrap();
    huge.shards = usize::MAX;
    huge.checksum = huge.checksum();
    let cases: Vec<(&str, String, &[&str])> = vec![
        ("edited", set_value("6.5"), &["checksum", "edited"]),
        (
            "deleted",
            edit(&|j| {
                j["rows"][0]["figures"].as_array_mut().unwrap().remove(1);
            }),
            &["checksum"],
        ),
        (
            "absent",
            edit(&|j| j["rows"][0]["figures"][0]["value"] = serde_json::Value::Null),
            &["checksum"],
        ),
        (
            "nan",
            set_value("NaN"),
            &["point 0: figure linear.f1 is not a finite number"],
        ),
        (
            "inf",
            set_value("-inf"),
            &["point 0: figure linear.f1 is not a finite number"],
        ),
        (
            "truncated",
            text[..text.len() / 2].to_string(),
            &["not a complete sweep part file"],
        ),
        (
            "shards",
            serde_json::to_string_pretty(&huge).unwrap(),
            &["18446744073709551615"],
        ),
    ];
    for (name, part0, needles) in cases {
        let case = dir.join(name);
        std::fs::create_dir_all(&case).unwrap();
        let p0 = case.join("sweep.part-0-of-2.json");
        std::fs::write(&p0, part0).unwrap();
        std::fs::copy(&good[1], case.join("sweep.part-1-of-2.json")).unwrap();
        let e = assert_bad_input(&["merge", case.to_str().unwrap(), "-o", &merged_s], needles);
        assert!(
            e.contains(p0.to_str().unwrap()),
            "{name}: names the part: {e}"
        );
        assert!(!merged.exists(), "{name}: nothing written");
    }
    // A part of another sweep.
    let (g0, o1) = (good[0].to_str().unwrap(), other[1].to_str().unwrap());
    assert_bad_input(
        &["merge", g0, o1, "-o", &merged_s],
        &["parts of different sweeps", "--set specs"],
    );
    // The untouched parts merge.
    let (code, _, err) = damper(&["merge", g0, good[1].to_str().unwrap(), "-o", &merged_s]);
    assert_eq!(code, 0, "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn merge_of_one_part_of_a_million_shards_is_a_short_line() {
    let dir = scratch("million");
    let (code, _, err) = damper(&[
        "sweep",
        "scenarios/damper.toml",
        "--quiet",
        "--set",
        "generator.load_resistance=1,10",
        "--shard",
        "0/1000000",
        "-o",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let out = dir.join("out");
    let e = assert_bad_input(
        &["merge", dir.to_str().unwrap(), "-o", out.to_str().unwrap()],
        &[
            "missing shard(s) of 1000000: sweep.part-1-of-1000000.json",
            "and 999994 more",
        ],
    );
    assert!(e.len() < 400, "{} bytes: {e}", e.len());
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Mutation-campaign regression: a swept resistance from a subnormal value (`5e-324`) to 1
/// once hung in the plot's logarithmic axis (plotters' key points never end on subnormal
/// bounds); the sweep now finishes, the axis linear.
#[test]
fn a_subnormal_axis_value_does_not_hang_the_plot() {
    let out = std::env::temp_dir().join(format!("damper-sweep-subnormal-{}", std::process::id()));
    let (code, _, err) = damper(&[
        "sweep",
        "scenarios/two_dampers.toml",
        "--set",
        "force[0].load_resistance=5e-324,1",
        "-o",
        out.to_str().unwrap(),
        "--quiet",
        "--threads",
        "1",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.join("sweep_damping.svg").is_file());
    let _ = std::fs::remove_dir_all(&out);
}

/// `a:b:n:log`: a geometric progression with exact endpoints; a non-positive end refused.
#[test]
fn log_spacing_is_geometric_with_exact_ends() {
    let v = parse_values("0.5:20:7:log").unwrap();
    let x: Vec<f64> = v.iter().map(|v| v.as_float().unwrap()).collect();
    assert_eq!(x.len(), 7);
    assert_eq!((x[0], x[6]), (0.5, 20.0));
    let r = x[1] / x[0];
    for w in x.windows(2) {
        assert!((w[1] / w[0] / r - 1.0).abs() < 1e-12, "{x:?}");
    }
    let e = parse_values("0:20:7:log").unwrap_err().to_string();
    assert!(e.contains("a > 0 and b > 0"), "{e}");
}

/// A two-axis sweep with constraints: the design map is drawn, the best feasible point is
/// the best of the grid that satisfies every constraint (recomputed here from sweep.csv),
/// the same in merged shards; a fixed `--set` is not an axis of the map or of the line
/// plots; an infeasible problem says so.
#[test]
fn a_two_axis_sweep_draws_the_design_map_and_names_the_best_feasible_point() {
    let dir = scratch("map");
    let args = |out: &Path| -> Vec<String> {
        [
            "sweep",
            "scenarios/damper.toml",
            "--quiet",
            "--set",
            "generator.gear_ratio=5",
            "--set",
            "mechanism.half_angle_deg=4:20:9",
            "--set",
            "generator.load_resistance=0.5:20:6:log",
            "--constraint",
            "linear.reach>=0.002",
            "--constraint",
            "linear.zeta1>=0.03",
            "-o",
            out.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec()
    };
    let out = dir.join("whole");
    let a = args(&out);
    let (code, _, err) = damper(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(code, 0, "{err}");
    let svg = crate::common::svg::checked(
        &out.join("sweep_map_linear.zeta1.svg"),
        &["linear.zeta1 [-]"],
    )
    .text;
    assert!(
        svg.contains("contour of linear.reach&gt;=0.002")
            || svg.contains("contour of linear.reach>=0.002"),
        "contour legend"
    );
    assert!(svg.contains("best feasible point"), "best point marked");
    // The best feasible point, recomputed from the CSV.
    let bytes = read(&out.join("sweep.csv"));
    let mut csv = csv::Reader::from_reader(&bytes[..]);
    let header = csv.headers().unwrap().clone();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (reach, zeta) = (col("linear.reach [m]"), col("linear.zeta1 [-]"));
    let mut best: Option<(usize, f64)> = None;
    let mut feasible = 0;
    for r in csv.records().map(Result::unwrap) {
        let (re, z): (f64, f64) = (r[reach].parse().unwrap(), r[zeta].parse().unwrap());
        if re >= 0.002 && z >= 0.03 {
            feasible += 1;
            if best.is_none_or(|b| z > b.1) {
                best = Some((r[0].parse().unwrap(), z));
            }
        }
    }
    let (index, z) = best.expect("a feasible point");
    assert!(feasible > 3 && feasible < 54, "{feasible} of 54 feasible");
    let json: serde_json::Value = serde_json::from_slice(&read(&out.join("sweep.json"))).unwrap();
    assert_eq!(json["best"]["index"], index);
    // (serde_json's default float parsing is within an ulp of the written shortest form.)
    let v = json["best"]["value"].as_f64().unwrap();
    assert!((v - z).abs() <= 4.0 * f64::EPSILON * z, "{v} vs {z}");
    assert!(err.contains(&format!("#{index} ")), "{err}");
    // Shards merged: the same files, map included.
    let sharded = dir.join("sharded");
    for i in 0..2 {
        let mut a = args(&sharded);
        a.extend(["--shard".to_string(), format!("{i}/2")]);
        let (code, _, err) = damper(&a.iter().map(String::as_str).collect::<Vec<_>>());
        assert_eq!(code, 0, "{err}");
    }
    let (code, _, err) = damper(&["merge", sharded.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert_same_outputs(&out, &sharded, "2 shards");
    // One swept field besides a fixed one: the line plots run along it.
    let line = dir.join("line");
    let (code, _, err) = damper(&[
        "sweep",
        "scenarios/damper.toml",
        "--quiet",
        "--set",
        "generator.gear_ratio=5",
        "--set",
        "mechanism.half_angle_deg=4:20:5",
        "--constraint",
        "linear.reach>=0.5",
        "-o",
        line.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("no grid point satisfies the constraints"),
        "{err}"
    );
    let svg =
        crate::common::svg::checked(&line.join("sweep_damping.svg"), &["damping ratio [%]"]).text;
    assert!(svg.contains("vs mechanism.half_angle_deg"), "x axis");
    assert!(
        !svg.contains("generator.gear_ratio=5:"),
        "a fixed field is no line label"
    );
    assert!(!line.join("sweep_map_linear.zeta1.svg").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
