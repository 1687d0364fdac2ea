//! Shared harness of the CLI end-to-end tests: run the `damper` binary as a user would.

#![allow(dead_code)] // each test binary uses its own subset

pub mod svg;

use std::path::PathBuf;
use std::process::Command;

/// The workspace root (the binary runs there, so bundled paths like `models/...` resolve).
pub fn root() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

/// Runs `damper ARGS` in the workspace root: (exit code, stdout, stderr).
pub fn damper(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_damper"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("run damper");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Asserts that `damper ARGS` fails as bad input: exit code 2, nothing on stdout, one line on
/// stderr (no panic) mentioning every needle. Returns the error line.
pub fn assert_bad_input(args: &[&str], needles: &[&str]) -> String {
    let (code, out, err) = damper(args);
    assert_eq!(code, 2, "exit code for {args:?}: stdout {out} stderr {err}");
    assert!(out.is_empty(), "nothing on stdout for bad input: {out}");
    assert_eq!(err.trim_end().lines().count(), 1, "one-line error: {err}");
    assert!(!err.contains("panicked") && !err.contains("NaN"), "{err}");
    for n in needles {
        assert!(
            err.contains(n),
            "{args:?}: error {err:?} should mention {n:?}"
        );
    }
    err
}

/// The bundled scenario files (`scenarios/*.toml`), sorted.
pub fn bundled_scenarios() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(root().join("scenarios"))
        .expect("scenarios/")
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
}

/// The user documentation: `README.md` (the front page) followed by every page of the guide
/// under `docs/guide/` (sorted by name), as `(path relative to the root, text)`.
pub fn documentation_pages() -> Vec<(String, String)> {
    let mut pages = vec![(
        "README.md".to_string(),
        std::fs::read_to_string(root().join("README.md")).expect("README.md"),
    )];
    let mut guide: Vec<PathBuf> = std::fs::read_dir(root().join("docs/guide"))
        .expect("docs/guide/")
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    guide.sort();
    for p in guide {
        let text = std::fs::read_to_string(&p).expect("a guide page");
        let name = p.strip_prefix(root()).unwrap_or(&p).display().to_string();
        pages.push((name, text));
    }
    pages
}

/// The front page and the guide in one text (see [`documentation_pages`]).
pub fn documentation() -> String {
    documentation_pages()
        .into_iter()
        .map(|(_, text)| text)
        .collect::<Vec<_>>()
        .join("\n")
}
