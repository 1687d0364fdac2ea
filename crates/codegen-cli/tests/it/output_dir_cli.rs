//! All or nothing in an output directory (issue 23, item 5): a failed run of any kind
//! commits nothing, a directory is locked for the duration of a run (a second run into it is
//! refused), concurrent runs never leave a mixed set, the temporary files of a killed run are
//! removed by the next run, and write errors name their file.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use codegen_cli::report::OutputLock;
use common::{damper, root};
use serde_json::Value;

/// A fresh temporary directory path for one test (not created).
fn temp_path(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("damper-outdir-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// The names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// `--set integrator.atol=100000` makes the four-bar run stop (exit 2): nothing is written,
/// not even into a directory holding an earlier run's files, and the error names the
/// scenario file.
#[test]
fn a_failed_mechanism_run_commits_nothing() {
    let out = temp_path("mech-fail");
    let o = out.to_str().unwrap();
    let bad = [
        "simulate",
        "scenarios/four_bar.toml",
        "-o",
        o,
        "--set",
        "integrator.atol=100000",
    ];
    let (code, stdout, err) = damper(&bad);
    assert_eq!(code, 2, "{stdout} {err}");
    assert!(err.contains("scenarios/four_bar.toml"), "{err}");
    assert!(err.contains("nothing written"), "{err}");
    assert!(!out.exists(), "a failed run left {:?}", listing(&out));
    // Over a good run's files: they stay as they were.
    let (code, _, err) = damper(&["simulate", "scenarios/four_bar.toml", "-o", o, "--quiet"]);
    assert_eq!(code, 0, "{err}");
    let before: Vec<(String, Vec<u8>)> = listing(&out)
        .into_iter()
        .map(|n| (n.clone(), std::fs::read(out.join(&n)).unwrap()))
        .collect();
    assert_eq!(before.len(), 3, "{before:?}");
    let (code, _, err) = damper(&bad);
    assert_eq!(code, 2, "{err}");
    let after: Vec<(String, Vec<u8>)> = listing(&out)
        .into_iter()
        .map(|n| (n.clone(), std::fs::read(out.join(&n)).unwrap()))
        .collect();
    assert!(before == after, "a failed run changed the directory");
    let _ = std::fs::remove_dir_all(&out);
}

/// While a run holds the directory's lock, another run into it is refused at once with a
/// message naming the directory, and writes nothing; once the lock is released the run
/// goes, and no lock file is left.
#[test]
fn a_run_into_a_locked_directory_is_refused() {
    let out = temp_path("locked");
    let o = out.to_str().unwrap();
    let lock = OutputLock::acquire(&out).unwrap();
    let (code, stdout, err) = damper(&["simulate", "scenarios/four_bar.toml", "-o", o]);
    assert_eq!(code, 2, "{stdout} {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("in use by another run"), "{err}");
    assert!(err.contains(o), "{err}");
    assert!(
        err.contains(&format!("process {}", std::process::id())),
        "{err}"
    );
    assert_eq!(listing(&out), [".damper.lock"]);
    drop(lock);
    assert!(
        !out.exists(),
        "the lock's directory was created for it and is empty"
    );
    let (code, _, err) = damper(&["simulate", "scenarios/four_bar.toml", "-o", o, "--quiet"]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(
        listing(&out),
        ["four_bar.csv", "four_bar.svg", "four_bar_summary.json"]
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// Whether the files in `dir` are one run's set: the CSV's rows are the ones its summary
/// counts, up to the summary's final time.
fn consistent(dir: &Path) -> Result<f64, String> {
    let summary: Value =
        serde_json::from_slice(&std::fs::read(dir.join("four_bar_summary.json")).unwrap()).unwrap();
    let csv = std::fs::read_to_string(dir.join("four_bar.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    let last_t: f64 = rows
        .last()
        .and_then(|r| r.split(',').next())
        .and_then(|t| t.parse().ok())
        .ok_or("no rows")?;
    let t_end = summary["settings"]["t_end"].as_f64().unwrap();
    if rows.len() as u64 != summary["output_rows"].as_u64().unwrap() || last_t != t_end {
        return Err(format!(
            "mixed set: {} rows ending at {last_t}, summary: {} rows to {t_end}",
            rows.len(),
            summary["output_rows"]
        ));
    }
    Ok(t_end)
}

/// 30 pairs of runs with different end times started together into one directory: each
/// run either completes or is refused because the other holds the directory, and the
/// directory always holds one complete set.
#[test]
fn concurrent_runs_into_one_directory_never_leave_a_mixed_set() {
    let out = temp_path("pairs");
    let o = out.to_str().unwrap().to_string();
    let spawn = |t_end: &str| {
        Command::new(env!("CARGO_BIN_EXE_damper"))
            .args(["simulate", "scenarios/four_bar.toml", "--quiet", "-o", &o])
            .args(["--set", &format!("integrator.t_end={t_end}")])
            .current_dir(root())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (mut refused, mut completed) = (0, 0);
    for pair in 0..30 {
        let a = spawn("0.5");
        let b = spawn("0.7");
        for child in [a, b] {
            let r = child.wait_with_output().unwrap();
            let err = String::from_utf8_lossy(&r.stderr);
            match r.status.code() {
                Some(0) => completed += 1,
                Some(2) if err.contains("in use by another run") => refused += 1,
                c => panic!("pair {pair}: exit {c:?}: {err}"),
            }
        }
        consistent(&out).unwrap_or_else(|e| panic!("pair {pair}: {e}"));
        let names = listing(&out);
        assert_eq!(
            names,
            ["four_bar.csv", "four_bar.svg", "four_bar_summary.json"],
            "pair {pair}"
        );
    }
    assert_eq!(refused + completed, 60);
    assert!(completed >= 30, "every pair completes at least one run");
    let _ = std::fs::remove_dir_all(&out);
}

/// A process id that is not running: a child that has ended.
fn dead_pid() -> u32 {
    let mut c = Command::new("true").spawn().unwrap();
    let pid = c.id();
    c.wait().unwrap();
    pid
}

/// Temporary files left by a killed run (`<name>.tmp-<pid>`, its process gone) are removed
/// by the next run into the directory, which names them; those of a running process and
/// other files are kept.
#[test]
fn temporary_files_of_a_killed_run_are_removed_by_the_next_run() {
    let out = temp_path("stale-tmp");
    std::fs::create_dir_all(&out).unwrap();
    let dead = format!("four_bar.csv.tmp-{}", dead_pid());
    let running = format!("four_bar.csv.tmp-{}", std::process::id());
    for name in [&dead, &running, &"notes.tmp-x".to_string()] {
        std::fs::write(out.join(name), "half").unwrap();
    }
    let o = out.to_str().unwrap();
    let (code, _, err) = damper(&["simulate", "scenarios/four_bar.toml", "-o", o, "--quiet"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains(&dead) && err.contains("killed"), "{err}");
    let names = listing(&out);
    assert!(!names.contains(&dead), "{names:?}");
    assert!(names.contains(&running), "{names:?}");
    assert!(names.contains(&"notes.tmp-x".to_string()), "{names:?}");
    let _ = std::fs::remove_dir_all(&out);
}

/// A full disk while a hybrid run streams its time history (`/dev/full` behind the CSV's
/// name): the error names the file, and nothing else is written.
#[cfg(target_os = "linux")]
#[test]
fn a_full_disk_in_a_hybrid_run_names_the_file() {
    let out = temp_path("full");
    std::fs::create_dir_all(&out).unwrap();
    let csv = out.join("time_history.csv");
    std::os::unix::fs::symlink("/dev/full", &csv).unwrap();
    let o = out.to_str().unwrap();
    let (code, _, err) = damper(&[
        "simulate",
        "scenarios/pendulum_absorber.toml",
        "-o",
        o,
        "--quiet",
        "--set",
        "integrator.t_end=0.5",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains(csv.to_str().unwrap()), "{err}");
    assert_eq!(listing(&out), ["time_history.csv"]);
    let _ = std::fs::remove_dir_all(&out);
}

/// A damper run that stops at run time (a time step so large the mechanism loses the beam
/// point) names the scenario file and writes nothing.
#[test]
fn a_stopped_damper_run_names_its_scenario_and_commits_nothing() {
    let out = temp_path("damper-stop");
    let (code, stdout, err) = damper(&[
        "simulate",
        "scenarios/damper.toml",
        "-o",
        out.to_str().unwrap(),
        "--quiet",
        "--set",
        "integrator.dt=0.05",
    ]);
    assert_eq!(code, 2, "{stdout} {err}");
    assert!(
        err.starts_with("error: scenarios/damper.toml: t = "),
        "{err}"
    );
    assert!(!out.exists(), "a failed run left {:?}", listing(&out));
}

/// A run killed with SIGKILL leaves its temporary files (and its unlocked lock file); the
/// next run into the directory is not refused, removes them and leaves only its own set.
#[cfg(target_os = "linux")]
#[test]
fn a_run_after_a_sigkill_cleans_up_and_is_not_refused() {
    let out = temp_path("sigkill");
    let o = out.to_str().unwrap().to_string();
    let mut child = Command::new(env!("CARGO_BIN_EXE_damper"))
        .args([
            "simulate",
            "scenarios/pendulum_absorber.toml",
            "--quiet",
            "-o",
            &o,
        ])
        .args(["--set", "integrator.t_end=100", "--allow-long"])
        .current_dir(root())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let tmp = format!("time_history.csv.tmp-{}", child.id());
    let started = std::time::Instant::now();
    while !out.join(&tmp).exists() {
        assert!(
            started.elapsed().as_secs() < 60,
            "the run never started streaming"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    assert_eq!(listing(&out), [".damper.lock".to_string(), tmp.clone()]);
    let (code, _, err) = damper(&[
        "simulate",
        "scenarios/pendulum_absorber.toml",
        "--quiet",
        "-o",
        &o,
        "--set",
        "integrator.t_end=0.2",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains(&tmp), "{err}");
    assert_eq!(
        listing(&out),
        ["beam_displacement.svg", "summary.json", "time_history.csv"]
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// `sweep` (unsharded), `frf` and `merge` hold their output directory like `simulate`: into
/// a directory another run holds, each is refused on one line and writes nothing; a sharded
/// sweep (whose shards share a directory by design) is not refused.
#[test]
fn sweep_frf_and_merge_into_a_locked_directory_are_refused() {
    let out = temp_path("locked-others");
    let o = out.to_str().unwrap();
    let lock = OutputLock::acquire(&out).unwrap();
    let refused = |args: &[&str]| {
        let before = listing(&out);
        let (code, stdout, err) = damper(args);
        assert_eq!(code, 2, "{args:?}: {stdout} {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains("in use by another run"), "{args:?}: {err}");
        assert_eq!(listing(&out), before, "{args:?} wrote nothing");
    };
    let sweep = [
        "sweep",
        "scenarios/damper.toml",
        "--set",
        "mechanism.half_angle_deg=10,12",
        "-o",
        o,
        "--quiet",
    ];
    refused(&sweep);
    refused(&[
        "frf",
        "scenarios/damper.toml",
        "--output",
        "1.0",
        "--from",
        "4",
        "--to",
        "8",
        "--points",
        "10",
        "-o",
        o,
        "--quiet",
    ]);
    let sharded: Vec<&str> = sweep.iter().copied().chain(["--shard", "0/2"]).collect();
    let (code, _, err) = damper(&sharded);
    assert_eq!(code, 0, "a shard is not refused: {err}");
    refused(&["merge", o]);
    drop(lock);
    let _ = std::fs::remove_dir_all(&out);
}
