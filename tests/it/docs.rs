//! The documentation ships with the code: every theory citation in the sources names a
//! section of `docs/theory.md` that exists (no file outside the repository is cited), and
//! every path of the guide's layout table (`docs/guide/layout.md`) exists.

use std::fs;
use std::path::{Path, PathBuf};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The text files of the repository that can cite the theory (sources, docs, scripts),
/// build outputs and virtual environments left out; sorted for a deterministic report.
fn text_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            let name = entry.file_name();
            let name = name.to_string_lossy();
            if name.starts_with('.') || name == "target" || name == "build" || name == "out" {
                continue;
            }
            let Ok(kind) = entry.file_type() else {
                continue;
            };
            if kind.is_dir() {
                walk(&path, out);
            } else if kind.is_file()
                && ["rs", "md", "py", "pyi", "toml"]
                    .iter()
                    .any(|e| path.extension().is_some_and(|x| x == *e))
            {
                out.push(path);
            }
        }
    }
    let mut files = vec![root().join("README.md")];
    for dir in ["crates", "tests", "docs", "scripts", "benches"] {
        walk(&root().join(dir), &mut files);
    }
    files.sort();
    files
}

/// The section numbers of `docs/theory.md` (its `## N. Title` headings).
fn theory_sections() -> Vec<u32> {
    let text = fs::read_to_string(root().join("docs/theory.md")).expect("docs/theory.md");
    text.lines()
        .filter_map(|l| l.strip_prefix("## "))
        .filter_map(|l| l.split_once('.'))
        .filter_map(|(n, _)| n.parse().ok())
        .collect()
}

/// The section numbers a citation's following text names: `section 8`, `sections 2 and 8`,
/// `sections 5–7`, `§3`, `§§2–3` (a range cites both ends). Comment markers and line breaks
/// between the file name and the numbers are skipped.
fn cited_sections(after: &str) -> Vec<u32> {
    let flat: String = after
        .replace("//!", " ")
        .replace("///", " ")
        .replace("//", " ")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    let rest = flat.trim_start_matches([' ', ',', '(']);
    let Some(numbers) = ["sections ", "section ", "§§", "§"]
        .iter()
        .find_map(|p| rest.strip_prefix(p))
    else {
        return vec![];
    };
    let mut out = vec![];
    let mut digits = String::new();
    for c in numbers.chars() {
        if c.is_ascii_digit() {
            digits.push(c);
            continue;
        }
        if !digits.is_empty() {
            out.push(digits.parse().expect("digits"));
            digits.clear();
        }
        if !matches!(c, '–' | '-' | ' ' | 'a' | 'n' | 'd') {
            break;
        }
    }
    if !digits.is_empty() {
        out.push(digits.parse().expect("digits"));
    }
    out
}

#[test]
fn every_theory_citation_names_an_existing_section_of_the_shipped_theory_page() {
    let sections = theory_sections();
    assert!(
        (1..=11).all(|n| sections.contains(&n)),
        "docs/theory.md sections: {sections:?}"
    );
    // Spelled in two pieces so that this file does not cite what it forbids.
    let outside = [["THEORY", ".md"].concat(), ["shared", "/docs"].concat()];
    let mut problems = vec![];
    let mut citations = 0;
    for path in text_files() {
        let Ok(text) = fs::read_to_string(&path) else {
            continue;
        };
        let shown = path.strip_prefix(root()).unwrap_or(&path).display();
        for (i, line) in text.lines().enumerate() {
            for o in &outside {
                if line.contains(o.as_str()) {
                    problems.push(format!(
                        "{shown}:{}: cites `{o}`, outside the repository",
                        i + 1
                    ));
                }
            }
        }
        for (at, _) in text.match_indices("docs/theory.md") {
            let after: String = text[at + "docs/theory.md".len()..]
                .chars()
                .take(60)
                .collect();
            for n in cited_sections(&after) {
                citations += 1;
                if !sections.contains(&n) {
                    let line = text[..at].lines().count();
                    problems.push(format!("{shown}:{line}: docs/theory.md has no section {n}"));
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    // The sources do cite sections (the scan finds them: the test can fail).
    assert!(citations >= 30, "only {citations} section citations found");
}

#[test]
fn the_citation_scanner_reads_every_form_used() {
    assert_eq!(cited_sections(" section 8)."), vec![8]);
    assert_eq!(cited_sections(" sections 2 and 8)"), vec![2, 8]);
    assert_eq!(cited_sections(" sections 5–7). Physics"), vec![5, 7]);
    assert_eq!(cited_sections(" §§2–3)."), vec![2, 3]);
    assert_eq!(cited_sections(" §3), warm"), vec![3]);
    assert_eq!(cited_sections("\n//! section 7)"), vec![7]);
    assert_eq!(cited_sections("` (eqs. 10–17):"), Vec::<u32>::new());
}

/// The backticked names of a table cell.
fn backticked(cell: &str) -> Vec<&str> {
    cell.split('`').skip(1).step_by(2).collect()
}

#[test]
fn every_path_of_the_guide_layout_table_exists() {
    let table =
        fs::read_to_string(root().join("docs/guide/layout.md")).expect("docs/guide/layout.md");
    let mut missing = vec![];
    let mut checked = 0;
    for row in table.lines().filter(|l| l.starts_with("| `")) {
        let cells: Vec<&str> = row.split(" | ").collect();
        let paths = backticked(cells[0]);
        for p in &paths {
            checked += 1;
            if !root().join(p).exists() {
                missing.push(format!("layout path `{p}`"));
            }
        }
        // Folders and files the role names: under the crate, its `src/`, or the root.
        if let [dir] = paths[..] {
            let dir = root().join(dir);
            if dir.is_dir() {
                let role = cells[1..].join(" | ");
                for name in backticked(&role)
                    .into_iter()
                    .filter(|n| n.ends_with('/') || n.ends_with(".rs"))
                {
                    checked += 1;
                    if ![
                        dir.join(name),
                        dir.join("src").join(name),
                        root().join(name),
                    ]
                    .iter()
                    .any(|p| p.exists())
                    {
                        missing.push(format!("`{name}` named in the row of {}", paths[0]));
                    }
                }
            }
        }
    }
    assert!(missing.is_empty(), "missing: {}", missing.join(", "));
    assert!(checked >= 15, "only {checked} layout paths found");
}
