//! Issue #29: the figure catalogue (`codegen_cli::analysis::figures`) — every figure listed
//! by `damper figures`, documented in the README and a column of a sweep; names and PATHs
//! checked before any work; one spelling per figure — and the bugs found on the way
//! (`merge` of base-excited sweeps, whole floats on integer fields, a sweep whose every
//! point failed, an empty `linear.max_force` column).

use crate::common;

use std::path::PathBuf;
use std::time::Instant;

use codegen_cli::analysis::figures::{CATALOGUE, resolve};
use common::damper;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("figures_cli_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The figure names of a `sweep.csv` header (units and the non-figure columns dropped).
fn columns(csv: &str) -> Vec<String> {
    csv.lines()
        .next()
        .unwrap()
        .split(',')
        .filter_map(|h| h.split_once(" [").map(|(n, _)| n.to_string()))
        .collect()
}

fn sweep(dir: &std::path::Path, args: &[&str]) -> String {
    let out = dir.display().to_string();
    let mut all = vec!["sweep"];
    all.extend_from_slice(args);
    all.extend(["-o", &out, "--quiet"]);
    let (code, _, err) = damper(&all);
    assert_eq!(code, 0, "{args:?}: {err}");
    std::fs::read_to_string(dir.join("sweep.csv")).unwrap()
}

#[test]
fn every_catalogue_figure_is_listed_documented_and_a_sweep_column() {
    let readme = common::documentation();
    let dir = scratch("columns");
    let mut seen: Vec<String> = vec![];
    // The time domain with comparison runs, the harmonic figures on request, the random ones.
    seen.extend(columns(&sweep(
        &dir,
        &[
            "scenarios/damper.toml",
            "--set",
            "description=x",
            "--time-domain",
            "--t-end",
            "0.3",
        ],
    )));
    seen.extend(columns(&sweep(
        &dir,
        &[
            "scenarios/forced_damper.toml",
            "--set",
            "description=x",
            "--map",
            "peak:1.0:3:12",
            "--constraint",
            "power>=0",
        ],
    )));
    seen.extend(columns(&sweep(
        &dir,
        &[
            "scenarios/random_damper.toml",
            "--set",
            "description=x",
            "--constraint",
            "rms:1.0>=0",
        ],
    )));
    let (code, listed, err) = damper(&["figures", "scenarios/forced_damper.toml"]);
    assert_eq!(code, 0, "{err}");
    let (code, listed_random, err) = damper(&["figures", "scenarios/random_damper.toml"]);
    assert_eq!(code, 0, "{err}");
    let (code, listed_damper, err) = damper(&["figures", "scenarios/damper.toml"]);
    assert_eq!(code, 0, "{err}");
    let listed = format!("{listed}{listed_random}{listed_damper}");
    for e in CATALOGUE {
        let shown = e.display();
        assert!(
            readme.contains(&format!("`{shown}`")),
            "neither README.md nor docs/guide documents `{shown}`"
        );
        let column = seen
            .iter()
            .find(|c| resolve(c, None).is_ok_and(|r| r.entry.pattern == e.pattern));
        assert!(column.is_some(), "no sweep column of {shown}: {seen:?}");
        // Listed: the pattern, or a name it expands to.
        let any = listed.lines().any(|l| {
            l.split_whitespace().next().is_some_and(|n| {
                n == shown || resolve(n, None).is_ok_and(|r| r.entry.pattern == e.pattern)
            })
        });
        assert!(any, "damper figures does not list {shown}:\n{listed}");
        for u in e.units {
            assert!(
                readme.contains(u),
                "README.md and docs/guide: unit {u} of {shown}"
            );
        }
    }
}

#[test]
fn unknown_figures_and_paths_exit_2_before_any_work_naming_the_nearest() {
    let dir = scratch("unknown");
    let out = dir.display().to_string();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![
                "sweep",
                "scenarios/damper.toml",
                "--set",
                "mechanism.half_angle_deg=3:25:40",
                "--map",
                "linear.zeta",
                "-o",
                &out,
            ],
            "linear.zeta1",
        ),
        (
            vec![
                "sweep",
                "scenarios/damper.toml",
                "--set",
                "mechanism.half_angle_deg=3:25:40",
                "--constraint",
                "linear.rech>=0.002",
                "-o",
                &out,
            ],
            "linear.reach",
        ),
        (
            vec![
                "sweep",
                "scenarios/damper.toml",
                "--set",
                "mechanism.half_angel_deg=3:25:40",
                "-o",
                &out,
            ],
            "unknown field `half_angel_deg`",
        ),
        (
            vec![
                "sweep",
                "scenarios/forced_damper.toml",
                "--set",
                "force[0].load_resistanse=1:9:40",
                "-o",
                &out,
            ],
            "did you mean `load_resistance`?",
        ),
        (
            vec![
                "optimize",
                "scenarios/damper.toml",
                "--vary",
                "mechanism.half_angle_deg=3:25",
                "--maximize",
                "powr",
            ],
            "power",
        ),
        (
            vec![
                "optimize",
                "scenarios/forced_damper.toml",
                "--vary",
                "force[0].gear_ratoi=3:25",
                "--maximize",
                "zeta1",
            ],
            "did you mean `gear_ratio`?",
        ),
        (
            vec![
                "optimize",
                "scenarios/forced_damper.toml",
                "--vary",
                "force[0].load_resistance=1:9",
                "--maximize",
                "generator.genrator.dissipated",
            ],
            "generator.generator.dissipated",
        ),
    ];
    for (args, nearest) in cases {
        let t = Instant::now();
        let line = common::assert_bad_input(&args, &[nearest]);
        let took = t.elapsed().as_secs_f64();
        assert!(took < 0.5, "{args:?} took {took} s: {line}");
    }
    assert!(!dir.join("sweep.csv").exists(), "nothing written");
}

#[test]
fn a_short_name_is_an_alias_of_the_canonical_one() {
    let (a, b) = (scratch("alias_a"), scratch("alias_b"));
    let grid = ["--set", "mechanism.half_angle_deg=3:25:6"];
    let short = sweep(
        &a,
        &[
            &["scenarios/damper.toml"][..],
            &grid,
            &["--constraint", "reach>=0.002", "--map", "zeta1"],
        ]
        .concat(),
    );
    let long = sweep(
        &b,
        &[
            &["scenarios/damper.toml"][..],
            &grid,
            &["--constraint", "linear.reach>=0.002"],
        ]
        .concat(),
    );
    assert_eq!(short, long);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(a.join("sweep.json")).unwrap()).unwrap();
    assert_eq!(json["map"], "linear.zeta1");
    assert_eq!(json["best"]["figure"], "linear.zeta1");
    assert!(json["best"]["index"].as_u64().is_some(), "{json}");
    let (code, out, err) = damper(&[
        "optimize",
        "scenarios/forced_damper.toml",
        "--vary",
        "force[0].load_resistance=1:9",
        "--maximize",
        "power",
        "--grid",
        "3",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let json: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(json["objective"][0], "harmonic.load_power");
}

/// `damper merge` of a base-excited sweep (its `linear.max_force` in m/s^2): the merged
/// files are the unsharded run's, byte for byte.
#[test]
fn a_base_excited_sweep_merges() {
    let (one, parts) = (scratch("base_one"), scratch("base_parts"));
    let set = ["--set", "force[0].load_resistance=1,2,4"];
    sweep(&one, &[&["scenarios/base_damper.toml"][..], &set].concat());
    for i in 0..2 {
        let shard = format!("{i}/2");
        let out = parts.display().to_string();
        let (code, _, err) = damper(
            &[
                &["sweep", "scenarios/base_damper.toml"][..],
                &set,
                &["--shard", &shard, "-o", &out, "--quiet"],
            ]
            .concat(),
        );
        assert_eq!(code, 0, "{err}");
    }
    let (code, _, err) = damper(&["merge", &parts.display().to_string()]);
    assert_eq!(code, 0, "{err}");
    let csv = std::fs::read_to_string(one.join("sweep.csv")).unwrap();
    assert!(csv.contains("linear.max_force [m/s^2]"), "{csv}");
    for f in ["sweep.csv", "sweep.json"] {
        assert_eq!(
            std::fs::read(one.join(f)).unwrap(),
            std::fs::read(parts.join(f)).unwrap(),
            "{f}"
        );
    }
}

/// A sweep without an excitation has no `linear.max_force` column (the README: absent); one
/// with an excitation has it.
#[test]
fn without_an_excitation_there_is_no_max_force_column() {
    let dir = scratch("no_force");
    let free = sweep(&dir, &["scenarios/damper.toml", "--set", "description=x"]);
    assert!(!free.contains("linear.max_force"), "{free}");
    let forced = sweep(
        &dir,
        &["scenarios/forced_damper.toml", "--set", "description=x"],
    );
    assert!(forced.contains("linear.max_force [N]"), "{forced}");
}

/// Every point failed: the files are written (each row its error) and the exit status is 2.
#[test]
fn a_sweep_whose_every_point_failed_exits_2() {
    let dir = scratch("all_failed");
    let out = dir.display().to_string();
    let (code, _, err) = damper(&[
        "sweep",
        "scenarios/damper.toml",
        "--set",
        "generator.load_resistance=-1,-2",
        "-o",
        &out,
        "--quiet",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("every one of the 2 point(s) failed"), "{err}");
    let csv = std::fs::read_to_string(dir.join("sweep.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    // One good point: exit 0.
    let (code, _, err) = damper(&[
        "sweep",
        "scenarios/damper.toml",
        "--set",
        "generator.load_resistance=-1,2",
        "-o",
        &out,
        "--quiet",
    ]);
    assert_eq!(code, 0, "{err}");
}

/// A whole float on an integer field (what a range of floats or a numpy array gives) is the
/// integer: the element count sweeps as `10.0, 50.0, 90.0` like `10, 50, 90`.
#[test]
fn a_whole_float_on_an_integer_field_is_the_integer() {
    let (a, b) = (scratch("int_a"), scratch("int_b"));
    let floats = sweep(
        &a,
        &[
            "scenarios/forced_damper.toml",
            "--set",
            "beam.segment[0].elements=10.0,50.0,90.0",
        ],
    );
    let ints = sweep(
        &b,
        &[
            "scenarios/forced_damper.toml",
            "--set",
            "beam.segment[0].elements=10:90:3",
        ],
    );
    let body = |csv: &str| -> Vec<String> {
        csv.lines()
            .map(|l| {
                let mut c: Vec<&str> = l.split(',').collect();
                c.remove(1);
                c.join(",")
            })
            .collect()
    };
    assert!(
        !floats.contains("must be an integer") && !floats.contains("invalid type"),
        "{floats}"
    );
    assert_eq!(body(&floats), body(&ints));
}
