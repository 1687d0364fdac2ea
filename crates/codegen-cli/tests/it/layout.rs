//! The application's layering (ARCHITECTURE.md): `commands/` only turns clap arguments into
//! a request and a result into files, so nothing below it — the library's other modules and
//! the Python binding — may import `commands::`; and the library below the commands says
//! why it refuses a request with typed errors (`AnalysisError`), never `Error::Usage(String)`.

use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`, sorted (a bounded walk: the source trees are small).
fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut out = vec![];
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap_or_else(|e| panic!("{}: {e}", d.display())) {
            let p = e.expect("a directory entry").path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The lines of `file` that contain `needle`, as `file:line: text`.
fn lines_with(file: &Path, needle: &str) -> Vec<String> {
    let text = std::fs::read_to_string(file).expect("a readable source file");
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.contains(needle))
        .map(|(i, l)| format!("{}:{}: {}", file.display(), i + 1, l.trim()))
        .collect()
}

#[test]
fn the_library_below_the_commands_raises_typed_errors() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let below = |p: &Path| !p.starts_with(src.join("commands")) && p != src.join("main.rs");
    let files: Vec<PathBuf> = sources(&src).into_iter().filter(|p| below(p)).collect();
    assert!(files.len() > 20, "the walk found the sources: {files:?}");
    let uses: Vec<String> = files
        .iter()
        .flat_map(|f| lines_with(f, "Error::Usage("))
        .collect();
    assert!(
        uses.is_empty(),
        "Error::Usage outside commands/ (use analysis::AnalysisError):\n{}",
        uses.join("\n")
    );
}

/// The lines of `file` that name the `commands` module as a path (`commands::`), comments
/// included (a doc link is an import of the vocabulary too).
fn commands_uses(file: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(file).expect("a readable source file");
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.contains("commands::") || l.contains("super::commands"))
        .map(|(i, l)| format!("{}:{}: {}", file.display(), i + 1, l.trim()))
        .collect()
}

#[test]
fn nothing_below_the_commands_imports_them() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = root.join("src");
    let allowed = |p: &Path| p.starts_with(src.join("commands")) || p == src.join("main.rs");
    let mut files: Vec<PathBuf> = sources(&src).into_iter().filter(|p| !allowed(p)).collect();
    files.extend(sources(&root.join("../damper-py/src")));
    assert!(files.len() > 20, "the walk found the sources: {files:?}");
    let uses: Vec<String> = files.iter().flat_map(|f| commands_uses(f)).collect();
    assert!(
        uses.is_empty(),
        "imports of commands:: outside commands/ and main.rs:\n{}",
        uses.join("\n")
    );
}

#[test]
fn the_check_sees_an_import() {
    // The scan itself: a file that imports `commands::` is reported.
    let dir = std::env::temp_dir().join(format!("damper-layout-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    let file = dir.join("x.rs");
    std::fs::write(&file, "use crate::commands::sweep::Grid;\n").expect("written");
    let found = commands_uses(&file);
    std::fs::remove_dir_all(&dir).expect("removed");
    assert_eq!(found.len(), 1, "{found:?}");
}
