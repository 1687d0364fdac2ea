//! Output paths with the user's path semantics, closed pipes and signals (issue "Bad input,
//! signals and special files"): symbolic links are followed and kept, fifos and devices
//! are written directly (never read first, never renamed over), output directories appear
//! only with the outputs, a closed standard output ends every command quietly, and SIGTERM
//! ends a run without leaving anything half-written.

use crate::common;

use common::{damper, root};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use codegen_cli::report::writer::{Target, target};
use codegen_cli::report::{OutputFile, commit_files};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("damper-special-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A fifo at `path`, or `None` (test skipped) where `mkfifo` is unavailable.
fn mkfifo(path: &Path) -> Option<()> {
    match Command::new("mkfifo").arg(path).status() {
        Ok(s) if s.success() => Some(()),
        _ => {
            eprintln!("mkfifo unavailable: test skipped");
            None
        }
    }
}

#[cfg(unix)]
fn is_symlink(p: &Path) -> bool {
    std::fs::symlink_metadata(p)
        .unwrap()
        .file_type()
        .is_symlink()
}

#[cfg(unix)]
#[test]
fn generate_to_a_symlink_replaces_the_target_and_keeps_the_link() {
    let dir = temp_dir("gen-symlink");
    std::fs::create_dir(dir.join("real")).unwrap();
    let real = dir.join("real/out.rs");
    std::fs::write(&real, "old").unwrap();
    let link = dir.join("out.rs");
    std::os::unix::fs::symlink("real/out.rs", &link).unwrap();
    let (code, _, err) = damper(&[
        "generate",
        "models/double_bar.toml",
        "-o",
        link.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(is_symlink(&link), "the link was replaced by a regular file");
    let text = std::fs::read_to_string(&real).unwrap();
    assert!(text.contains("pub struct DoubleBar"), "target not written");
    assert_eq!(names(&dir), ["out.rs", "real"]);
    assert_eq!(
        names(&dir.join("real")),
        ["out.rs"],
        "no temporary file left"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `generate -o FIFO` used to read the fifo first (write-if-changed) and hang for ever.
#[cfg(unix)]
#[test]
fn generate_to_a_fifo_streams_without_reading_it_first() {
    use std::os::unix::fs::FileTypeExt;
    let dir = temp_dir("gen-fifo");
    let fifo = dir.join("out.rs");
    let Some(()) = mkfifo(&fifo) else { return };
    let mut child = Command::new(env!("CARGO_BIN_EXE_damper"))
        .args(["generate", "models/double_bar.toml", "-o"])
        .arg(&fifo)
        .current_dir(root())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // The reader: if the writer read the fifo first, both would wait for ever; a watchdog
    // kills the child after 60 s so the test fails instead of hanging.
    let pid = child.id();
    let watchdog = std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_secs(60));
        let _ = Command::new("kill").arg(pid.to_string()).status();
    });
    let mut text = String::new();
    std::fs::File::open(&fifo)
        .unwrap()
        .read_to_string(&mut text)
        .unwrap();
    let status = child.wait().unwrap();
    drop(watchdog);
    assert!(status.success(), "{status:?}");
    assert!(text.contains("pub struct DoubleBar"), "{}", text.len());
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    let _ = std::fs::remove_dir_all(&dir);
}

/// As root, `generate -o /dev/null` replaced the device with a regular file. Tested through
/// the classification only (`stat`), never touching the real device: a character device is
/// a direct target, and a direct target is opened for writing (here a fifo stands in).
#[test]
fn dev_null_is_a_direct_target_never_replaced() {
    assert_eq!(
        target(Path::new("/dev/null")).unwrap(),
        Target::Direct(PathBuf::from("/dev/null"))
    );
}

/// The one writer: a symlinked file keeps its link, a fifo gets the bytes streamed and stays
/// a fifo, missing directories appear with the files; nothing temporary is left.
#[cfg(unix)]
#[test]
fn commit_files_follows_symlinks_and_streams_to_fifos() {
    use std::os::unix::fs::FileTypeExt;
    let dir = temp_dir("commit");
    let fifo = dir.join("pipe.csv");
    let Some(()) = mkfifo(&fifo) else { return };
    std::fs::write(dir.join("target.json"), "old").unwrap();
    std::os::unix::fs::symlink("target.json", dir.join("summary.json")).unwrap();
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(fifo).unwrap())
    };
    let files = [
        OutputFile {
            path: dir.join("summary.json"),
            bytes: b"{}".to_vec(),
        },
        OutputFile {
            path: fifo.clone(),
            bytes: b"t,x\n0,1\n".to_vec(),
        },
        OutputFile {
            path: dir.join("new/sub/plot.svg"),
            bytes: b"<svg/>".to_vec(),
        },
    ];
    commit_files(&files).unwrap();
    assert_eq!(reader.join().unwrap(), b"t,x\n0,1\n");
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    assert!(is_symlink(&dir.join("summary.json")));
    assert_eq!(std::fs::read(dir.join("target.json")).unwrap(), b"{}");
    assert_eq!(
        std::fs::read(dir.join("new/sub/plot.svg")).unwrap(),
        b"<svg/>"
    );
    assert_eq!(
        names(&dir),
        ["new", "pipe.csv", "summary.json", "target.json"]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A commit that fails removes the directories it created and its temporary files.
#[test]
fn failed_commit_removes_the_directories_it_created() {
    let dir = temp_dir("commit-fail");
    std::fs::create_dir(dir.join("taken")).unwrap();
    std::fs::write(dir.join("taken/inner"), "x").unwrap();
    let files = [
        OutputFile {
            path: dir.join("fresh/a.csv"),
            bytes: b"a".to_vec(),
        },
        // A non-empty directory as output file: fails after a.csv was staged.
        OutputFile {
            path: dir.join("taken"),
            bytes: b"b".to_vec(),
        },
    ];
    let err = commit_files(&files).unwrap_err();
    assert!(err.to_string().contains("taken"), "{err}");
    assert_eq!(
        names(&dir),
        ["taken"],
        "created directory and temporary file removed"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Standard output closed by the reader: quiet exit 141, no panic, for every command that
/// prints to standard output.
#[cfg(unix)]
#[test]
fn closed_stdout_ends_every_command_quietly() {
    let dir = temp_dir("pipe");
    let out = dir.join("gen.rs");
    let cases: Vec<Vec<String>> = vec![
        vec!["eval".into(), "models/double_bar.toml".into()],
        vec![
            "modes".into(),
            "beams/cantilever.toml".into(),
            "--count".into(),
            "20".into(),
        ],
        vec![
            "generate".into(),
            "models/double_bar.toml".into(),
            "-o".into(),
            out.display().to_string(),
            "--stats".into(),
        ],
    ];
    let fifo = dir.join("closed");
    let Some(()) = mkfifo(&fifo) else { return };
    for args in cases {
        // A pipe whose reader is gone before the command starts (deterministic, unlike
        // closing a `Stdio::piped()` after the spawn): a fifo opened read-write (Linux opens
        // that without blocking), a write end opened beside it, then the reading handle
        // dropped. Every write to standard output fails with EPIPE.
        let reader = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&fifo)
            .unwrap();
        let writer = std::fs::OpenOptions::new().write(true).open(&fifo).unwrap();
        drop(reader);
        let output = Command::new(env!("CARGO_BIN_EXE_damper"))
            .args(&args)
            .current_dir(root())
            .stdout(writer)
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&output.stderr);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert_eq!(output.status.code(), Some(141), "{args:?}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// SIGTERM during a long mechanism run: exit 143, "interrupted: nothing written" on stderr, no
/// output directory, no temporary file.
#[cfg(unix)]
#[test]
fn sigterm_during_a_mechanism_run_leaves_nothing_behind() {
    let dir = temp_dir("sigterm");
    let text = std::fs::read_to_string(root().join("scenarios/four_bar.toml"))
        .unwrap()
        .replace(
            "../models/four_bar.toml",
            &root().join("models/four_bar.toml").display().to_string(),
        )
        .replace("t_end = 5.0", "t_end = 2000.0");
    let sc = dir.join("long.toml");
    std::fs::write(&sc, text).unwrap();
    let out = dir.join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_damper"))
        .args(["simulate", "--quiet"])
        .arg(&sc)
        .arg("-o")
        .arg(&out)
        .current_dir(root())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status();
    if !matches!(killed, Ok(s) if s.success()) {
        let _ = child.kill();
        let _ = child.wait();
        eprintln!("kill unavailable: test skipped");
        return;
    }
    let output = child.wait_with_output().unwrap();
    let status = output.status;
    assert_eq!(status.code(), Some(143), "{status:?}");
    let err = String::from_utf8_lossy(&output.stderr);
    assert_eq!(
        err.lines().last(),
        Some("interrupted: nothing written"),
        "{err}"
    );
    assert!(!out.exists(), "interrupted run wrote {:?}", names(&out));
    assert_eq!(names(&dir), ["long.toml"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The damper scenario at `dir/name.toml` with edits, bundled model path made absolute.
fn damper_scenario(dir: &Path, name: &str, edits: &[(&str, &str)]) -> PathBuf {
    let mut text = std::fs::read_to_string(root().join("scenarios/damper.toml"))
        .unwrap()
        .replace(
            "../models/double_bar.toml",
            &root().join("models/double_bar.toml").display().to_string(),
        );
    for (old, new) in edits {
        assert!(text.contains(old), "{old}");
        text = text.replacen(old, new, 1);
    }
    let sc = dir.join(format!("{name}.toml"));
    std::fs::write(&sc, text).unwrap();
    sc
}

/// SIGTERM while a damper run streams its time histories: exit 143, the temporary CSV
/// files and the output directory created for them are removed.
#[cfg(unix)]
#[test]
fn sigterm_during_a_streaming_damper_run_leaves_nothing_behind() {
    let dir = temp_dir("sigterm-damper");
    let sc = damper_scenario(&dir, "long", &[("t_end = 5.0", "t_end = 200.0")]);
    let out = dir.join("a/b");
    let mut child = Command::new(env!("CARGO_BIN_EXE_damper"))
        .args(["simulate", "--quiet"])
        .arg(&sc)
        .arg("-o")
        .arg(&out)
        .current_dir(root())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Wait until the stream has started (its temporary file exists), then stop the run.
    let started = std::time::Instant::now();
    while !out.exists() || !names(&out).iter().any(|n| n.contains(".tmp-")) {
        assert!(
            started.elapsed().as_secs() < 30,
            "the run never started streaming"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    // Only temporary files and the directory's lock (`report::lock`).
    assert!(
        names(&out)
            .iter()
            .all(|n| n.contains(".tmp-") || n == ".damper.lock"),
        "{:?}",
        names(&out)
    );
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status();
    if !matches!(killed, Ok(s) if s.success()) {
        let _ = child.kill();
        let _ = child.wait();
        eprintln!("kill unavailable: test skipped");
        return;
    }
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(143), "{status:?}");
    assert_eq!(names(&dir), ["long.toml"], "left behind");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A damper run that stops half-way (driven into its toggle after streaming rows): exit 2,
/// no output file, no temporary file, no output directory.
#[test]
fn a_damper_run_failing_mid_stream_leaves_nothing_behind() {
    let dir = temp_dir("fail-damper");
    let sc = damper_scenario(
        &dir,
        "toggle",
        &[
            ("displacement = 0.001", "displacement = -0.0035"),
            (
                "rotor_inertia = 1e-6",
                "rotor_inertia = 1e-6\nconnected = false",
            ),
        ],
    );
    let out = dir.join("out");
    let (code, stdout, err) = damper(&[
        "simulate",
        sc.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{stdout} {err}");
    assert!(
        err.contains("t = ") && !err.contains("t = 0.000000"),
        "{err}"
    );
    assert_eq!(names(&dir), ["toggle.toml"], "left behind");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A streamed time history whose output name is a symbolic link: the link is followed (its
/// target replaced with the full CSV) and kept.
#[cfg(unix)]
#[test]
fn a_streamed_csv_follows_a_symlink_and_keeps_it() {
    let dir = temp_dir("stream-link");
    let sc = damper_scenario(&dir, "short", &[("t_end = 5.0", "t_end = 0.1")]);
    let out = dir.join("out");
    std::fs::create_dir(&out).unwrap();
    let real = dir.join("real.csv");
    std::fs::write(&real, "old").unwrap();
    std::os::unix::fs::symlink(&real, out.join("time_history.csv")).unwrap();
    let (code, _, err) = damper(&[
        "simulate",
        sc.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let link = std::fs::symlink_metadata(out.join("time_history.csv")).unwrap();
    assert!(link.file_type().is_symlink());
    let text = std::fs::read_to_string(&real).unwrap();
    assert!(text.starts_with("t [s],damper.q1 [rad]"), "{}", &text[..40]);
    assert_eq!(text.lines().count(), 1 + 101, "header and 101 rows");
    assert!(names(&dir).iter().all(|n| !n.contains(".tmp-")));
    assert!(names(&out).iter().all(|n| !n.contains(".tmp-")));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A fifo among the parts of a merge (named as a part in its directory, or given on the
/// command line) is refused from its metadata, never opened (opening it would block).
#[test]
fn merge_refuses_a_fifo_among_its_parts_without_opening_it() {
    let dir = temp_dir("merge-fifo");
    let parts = dir.join("parts");
    let (code, _, err) = damper(&[
        "sweep",
        "scenarios/damper.toml",
        "--quiet",
        "--set",
        "generator.load_resistance=1,10",
        "--shard",
        "0/2",
        "-o",
        parts.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let fifo = parts.join("sweep.part-1-of-2.json");
    let Some(()) = mkfifo(&fifo) else { return };
    let out = dir.join("out");
    let part0 = parts.join("sweep.part-0-of-2.json");
    for args in [
        vec![parts.to_str().unwrap(), "-o", out.to_str().unwrap()],
        vec![
            part0.to_str().unwrap(),
            fifo.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
    ] {
        // A regression would block on the fifo: the child is killed after a minute.
        let mut child = Command::new(env!("CARGO_BIN_EXE_damper"))
            .arg("merge")
            .args(&args)
            .current_dir(root())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let started = std::time::Instant::now();
        while child.try_wait().unwrap().is_none() {
            if started.elapsed().as_secs() > 60 {
                let _ = child.kill();
                panic!("merge blocked on the fifo");
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let output = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(
            err.contains("not a regular file") && err.contains(fifo.to_str().unwrap()),
            "{err}"
        );
        assert!(!out.exists(), "nothing written");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
