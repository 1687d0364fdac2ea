//! The front page (`README.md`) and the guide (`docs/guide/`) against the binary they describe:
//! the command table against `damper --help` and every subcommand's help, where the binary
//! lands and how to install it, and every command they show, run again here with its shown
//! output compared (wall-clock times and output directories aside), so that none can drift.

use crate::common;

use std::collections::BTreeSet;
use std::path::PathBuf;

use common::{damper, root};

fn readme() -> String {
    std::fs::read_to_string(root().join("README.md")).expect("README.md")
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("readme_cli_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A row of the README's command table: the synopsis (without backticks, `\|` unescaped)
/// and the one-line summary.
#[derive(Debug)]
struct Row {
    synopsis: String,
    summary: String,
}

impl Row {
    /// The subcommand: the word after `damper`.
    fn command(&self) -> &str {
        self.synopsis.split_whitespace().nth(1).unwrap_or("")
    }

    /// The options the synopsis names (`-o`, `--set`, `--t-end`, ...).
    fn options(&self) -> BTreeSet<String> {
        options(&self.synopsis)
    }
}

/// Every option name in `text`: `--name`, or `-x` for a short one.
fn options(text: &str) -> BTreeSet<String> {
    text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
        .filter(|w| {
            (w.starts_with("--") && w.len() > 2)
                || (w.len() == 2 && w.starts_with('-') && w.as_bytes()[1].is_ascii_alphabetic())
        })
        .map(str::to_string)
        .collect()
}

/// The table of the README's section `## Commands`.
fn command_table(readme: &str) -> Vec<Row> {
    let start = readme
        .find("\n## Commands\n")
        .expect("README.md has a section `## Commands`");
    let section = &readme[start + 1..];
    let end = section[3..].find("\n## ").map_or(section.len(), |e| e + 3);
    section[..end]
        .lines()
        .filter(|l| l.starts_with("| `damper "))
        .map(|l| {
            let (synopsis, summary) = l[3..]
                .split_once("` | ")
                .unwrap_or_else(|| panic!("README command row {l:?}: `| `SYNOPSIS` | summary |`"));
            Row {
                synopsis: synopsis.replace("\\|", "|"),
                summary: summary.trim_end_matches(" |").to_string(),
            }
        })
        .collect()
}

/// `damper --help`'s command list: (name, summary), without `help`.
fn help_commands() -> Vec<(String, String)> {
    let (code, out, err) = damper(&["--help"]);
    assert_eq!(code, 0, "{err}");
    let start = out.find("Commands:\n").expect("a command list") + "Commands:\n".len();
    out[start..]
        .lines()
        .take_while(|l| !l.trim().is_empty())
        .map(|l| {
            let l = l.trim_start();
            let (name, summary) = l.split_once(' ').unwrap_or((l, ""));
            (name.to_string(), summary.trim().to_string())
        })
        .filter(|(name, _)| name != "help")
        .collect()
}

#[test]
fn help_lists_every_command_of_the_readme_table_with_its_summary() {
    let table = command_table(&readme());
    let mut from_readme: Vec<(String, String)> = table
        .iter()
        .map(|r| (r.command().to_string(), r.summary.clone()))
        .collect();
    let mut from_help = help_commands();
    assert_eq!(from_help.len(), 11, "{from_help:?}");
    from_readme.sort();
    from_help.sort();
    assert_eq!(
        from_help, from_readme,
        "`damper --help` (left) and README.md's command table (right) differ"
    );
    for (name, summary) in &from_help {
        // One short line: the summary of a command, the details in its own help.
        assert!(
            !summary.is_empty() && summary.len() <= 80 && !summary.ends_with('.'),
            "{name}: summary {summary:?} should be one line of at most 80 characters"
        );
    }
    // The program's own description is the current one.
    let (_, out, _) = damper(&["--help"]);
    let about = out.lines().next().unwrap_or("");
    assert!(
        about.contains("vibration dampers") && about.len() <= 100,
        "{about:?}"
    );
}

#[test]
fn every_subcommand_help_matches_the_readme_table() {
    for row in command_table(&readme()) {
        let name = row.command();
        let (code, out, err) = damper(&[name, "--help"]);
        assert_eq!(code, 0, "damper {name} --help: {err}");
        let first = out.lines().next().unwrap_or("");
        assert_eq!(
            first, row.summary,
            "damper {name} --help: its first line is README.md's summary"
        );
        let options_start = out.find("\nOptions:\n").expect("an option list");
        // One entry per option of the help: its names (`-o, --out`).
        let help_options: Vec<BTreeSet<String>> = out[options_start..]
            .lines()
            .filter(|l| l.trim_start().starts_with('-'))
            .map(|l| options(l.split("  ").find(|p| !p.is_empty()).unwrap_or("")))
            .filter(|names| !names.is_empty() && !names.contains("--help"))
            .collect();
        let readme_options = row.options();
        let missing: Vec<_> = help_options
            .iter()
            .filter(|names| names.is_disjoint(&readme_options))
            .collect();
        let stale: Vec<_> = readme_options
            .iter()
            .filter(|o| !help_options.iter().any(|names| names.contains(*o)))
            .collect();
        assert!(
            missing.is_empty() && stale.is_empty(),
            "damper {name}: README.md's synopsis `{}` lacks {missing:?} and names options the command does not have: {stale:?}",
            row.synopsis
        );
        let usage = out
            .lines()
            .find(|l| l.starts_with("Usage: "))
            .unwrap_or_else(|| panic!("damper {name} --help: no usage line"));
        assert!(
            usage.starts_with(&format!("Usage: damper {name} ")),
            "{usage}"
        );
    }
}

/// The binary is `damper`, the one binary of `crates/codegen-cli` (so `cargo install --path
/// crates/codegen-cli` puts `damper` on the PATH), built into `target/<profile>/damper`; the
/// README says both.
#[test]
fn readme_says_where_the_binary_lands_and_how_to_install_it() {
    let text = readme();
    for needle in [
        "target/release/damper",
        "cargo build --release -p codegen-cli",
        "cargo install --path crates/codegen-cli",
    ] {
        assert!(text.contains(needle), "README.md should say {needle:?}");
    }
    let manifest: toml::Table =
        std::fs::read_to_string(root().join("crates/codegen-cli/Cargo.toml"))
            .unwrap()
            .parse()
            .unwrap();
    assert_eq!(manifest["package"]["name"].as_str(), Some("codegen-cli"));
    let bins = manifest["bin"].as_array().expect("[[bin]] tables");
    let names: Vec<_> = bins.iter().filter_map(|b| b["name"].as_str()).collect();
    assert_eq!(names, ["damper"], "the crate's only binary is `damper`");
    let exe = PathBuf::from(env!("CARGO_BIN_EXE_damper"));
    assert_eq!(exe.file_stem().and_then(|s| s.to_str()), Some("damper"));
    let profile_dir = exe.parent().and_then(|p| p.parent()).unwrap();
    assert!(
        profile_dir.ends_with("target")
            || profile_dir.parent().is_some_and(|p| p.ends_with("target")),
        "{}",
        exe.display()
    );
}

/// `x` with three significant digits (`14.6`, `143`, `1.27`, `41.2`).
fn sig3(x: f64) -> String {
    let digits = 2 - x.abs().log10().floor() as i32;
    format!("{:.*}", digits.max(0) as usize, x)
}

/// The README's operating-angle table ("The paper's claim, reproduced") is what the sweep it
/// shows computes: frequencies to 1 mHz, damping ratios and amplifications as printed.
#[test]
fn readme_operating_angle_table_is_what_the_sweep_computes() {
    let text = common::documentation();
    let command = "damper sweep scenarios/damper.toml --set mechanism.half_angle_deg=20,10,5,2 -o out/operating_angle";
    let start = text.find(command).expect("the operating-angle sweep") + command.len();
    let table: Vec<Vec<String>> = text[start..]
        .lines()
        .skip_while(|l| !l.starts_with("| half-angle"))
        .skip(2)
        .take_while(|l| l.starts_with("| "))
        .map(|l| {
            l.trim_matches('|')
                .split(" | ")
                .map(|c| c.trim().to_string())
                .collect()
        })
        .collect();
    assert_eq!(table.len(), 4, "{table:?}");
    let dir = temp("operating_angle");
    let (code, _, err) = damper(&[
        "sweep",
        "scenarios/damper.toml",
        "--set",
        "mechanism.half_angle_deg=20,10,5,2",
        "-o",
        dir.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(code, 0, "{err}");
    let csv = std::fs::read_to_string(dir.join("sweep.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |name: &str| {
        header
            .iter()
            .position(|h| h.starts_with(name))
            .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
    };
    let (angle, f1, z1, f1d, z1d, amp) = (
        column("mechanism.half_angle_deg"),
        column("linear.f1 "),
        column("linear.zeta1 "),
        column("linear.f1_generator_disconnected"),
        column("linear.zeta1_generator_disconnected"),
        column("linear.amplification"),
    );
    for (row, expected) in lines.zip(&table) {
        let cells: Vec<f64> = row
            .split(',')
            .map(|c| c.parse().unwrap_or(f64::NAN))
            .collect();
        let computed = vec![
            format!("{} deg", cells[angle]),
            format!("{:.3} Hz", cells[f1]),
            format!("{} %", sig3(100.0 * cells[z1])),
            format!("{:.3} Hz", cells[f1d]),
            format!("{:.2} %", 100.0 * cells[z1d]),
            format!("{} rad/m", sig3(cells[amp])),
        ];
        assert_eq!(
            &computed, expected,
            "README.md's operating-angle table is out of date (left: the sweep)"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `line` with every 16-hex-digit content hash replaced by `<hash>`.
fn hashes_masked(line: &str) -> String {
    line.split(' ')
        .map(|w| {
            let core = w.trim_matches(|c: char| !c.is_ascii_alphanumeric());
            if core.len() == 16 && core.chars().all(|c| c.is_ascii_hexdigit()) {
                w.replace(core, "<hash>")
            } else {
                w.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// The README's sample of the stale-model notice (`models/double_bar.toml` edited after the
/// build) is the notice the registry writes for that case, content hashes aside.
#[test]
fn readme_stale_model_notice_is_the_registrys() {
    let text = common::documentation();
    let sample = text
        .lines()
        .find(|l| l.starts_with("    note: model models/double_bar.toml changed"))
        .expect("the README's sample notice")
        .trim_start();
    let notice = model_registry::Stale {
        file: "models/double_bar.toml".into(),
        hash: "0000000000000000".into(),
        compiled: model_registry::find_by_name("double_bar").unwrap(),
        edited_in_place: true,
    }
    .to_string();
    assert_eq!(
        hashes_masked(sample),
        hashes_masked(&notice),
        "README.md's sample notice is out of date"
    );
}

/// A command the front page or the guide shows, with the output shown after it.
#[derive(Debug)]
struct Example {
    /// `page:line` of the command.
    at: String,
    /// The shell text, `cargo run --release -p codegen-cli --` written as `damper`.
    command: String,
    /// The output lines shown after it (a ```` ```console ```` block), `...` lines dropped.
    shown: Vec<String>,
}

/// A synopsis, not a command: it names a placeholder (`SCENARIO`, `PATH=VALUES`, `[-o DIR]`,
/// `...`).
fn is_synopsis(command: &str) -> bool {
    command.contains("...")
        || command.contains(" [")
        || command
            .split(|c: char| c.is_whitespace() || "=:[]()|,'".contains(c))
            .any(|w| {
                w.len() >= 2
                    && w.starts_with(|c: char| c.is_ascii_uppercase())
                    && w.chars()
                        .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_')
            })
}

/// Every `damper` command of a page: in ```` ```console ```` blocks the `$ ` lines (their
/// output the lines that follow), in other code blocks (fenced or indented) the lines that
/// start with `damper ` or `cargo run --release -p codegen-cli -- ` (no output shown).
/// A line ending in `\` continues on the next.
fn examples(page: &str, text: &str) -> Vec<Example> {
    const CARGO: &str = "cargo run --release -p codegen-cli -- ";
    let lines: Vec<&str> = text.lines().collect();
    let mut found: Vec<Example> = vec![];
    let mut fence: Option<&str> = None; // the info string of the open fenced block
    let mut in_block = false; // an example started in the open console block
    let mut i = 0;
    while i < lines.len() {
        let line = lines[i];
        i += 1;
        if let Some(info) = line.trim_start().strip_prefix("```") {
            fence = match fence {
                Some(_) => None,
                None => Some(info.trim()),
            };
            in_block = false;
            continue;
        }
        let console = fence == Some("console");
        let indented = fence.is_none()
            && line.starts_with("    ")
            && (i < 2 || lines[i - 2].trim().is_empty() || lines[i - 2].starts_with("    "));
        let body = if console {
            line.strip_prefix("$ ")
        } else if fence.is_some() || indented {
            let t = line.trim_start();
            Some(t.strip_prefix("$ ").unwrap_or(t))
        } else {
            None
        };
        let Some(body) = body else {
            if console && in_block && !line.trim().is_empty() && line.trim() != "..." {
                found.last_mut().unwrap().shown.push(line.to_string());
            }
            continue;
        };
        let body = body
            .strip_prefix(CARGO)
            .map_or(body.to_string(), |rest| format!("damper {rest}"));
        if !body.starts_with("damper ") {
            continue;
        }
        let at = format!("{page}:{i}");
        let mut command = body.trim_end().to_string();
        while command.ends_with('\\') && i < lines.len() {
            command.pop();
            command.truncate(command.trim_end().len());
            command.push(' ');
            command.push_str(lines[i].trim());
            command = command.trim_end().to_string();
            i += 1;
        }
        if is_synopsis(&command) {
            in_block = false;
        } else {
            found.push(Example {
                at,
                command,
                shown: vec![],
            });
            in_block = console;
        }
    }
    found
}

/// A token of printed output with the figures that change from run to run or machine to
/// machine made comparable: `Ok(x)` for a number (trailing `,;:)%` stripped), else the text.
fn token(t: &str) -> Result<f64, &str> {
    let core = t
        .trim_start_matches('(')
        .trim_end_matches([',', ';', ':', ')', '%']);
    core.parse::<f64>().map_err(|_| t)
}

/// Whether a shown line reads as the printed one: the same words, numbers equal to 1e-9
/// relative (or both below 1e-12 in magnitude: residuals at round-off), a wall-clock time
/// (`in 0.31 s`, `12 ms`) and the output directory (`outputs in DIR`) whatever they are.
fn same_line(shown: &str, printed: &str) -> bool {
    let a: Vec<&str> = shown.split_whitespace().collect();
    let b: Vec<&str> = printed.split_whitespace().collect();
    if a.len() != b.len() {
        return false;
    }
    (0..a.len()).all(|k| {
        if a[k] == b[k] {
            return true;
        }
        let unit = a.get(k + 1).map(|u| u.trim_end_matches([',', ';', ')']));
        let wall = (k > 0 && a[k - 1] == "in" && matches!(unit, Some("s") | Some("ms")))
            || (k > 1 && a[k - 2] == "outputs" && a[k - 1] == "in");
        match (token(a[k]), token(b[k])) {
            _ if wall => true,
            (Ok(x), Ok(y)) => {
                (x - y).abs() <= 1e-9 * x.abs().max(y.abs()) || (x.abs() < 1e-12 && y.abs() < 1e-12)
            }
            _ => false,
        }
    })
}

/// Every `damper` command the front page and the guide show runs from a directory holding
/// the bundled `scenarios/`, `models/` and `beams/`, exits with status 0 (non-zero where the
/// shown output is an error), and prints every output line shown after it (in any order of
/// its two streams; numbers to 1e-9, wall-clock times and output directories aside).
#[test]
fn every_command_of_the_front_page_and_the_guide_runs_and_prints_what_is_shown() {
    let dir = temp("guide");
    for d in ["scenarios", "models", "beams"] {
        std::os::unix::fs::symlink(root().join(d).canonicalize().unwrap(), dir.join(d)).unwrap();
    }
    let exe = PathBuf::from(env!("CARGO_BIN_EXE_damper"));
    let path = format!(
        "{}:{}",
        exe.parent().unwrap().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut all = vec![];
    for (page, text) in common::documentation_pages() {
        all.extend(examples(&page, &text));
    }
    assert!(all.len() >= 15, "{all:#?}");
    let mut failures = vec![];
    for e in &all {
        let out = std::process::Command::new("sh")
            .args(["-c", &e.command])
            .current_dir(&dir)
            .env("PATH", &path)
            .output()
            .expect("sh");
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        let printed: Vec<&str> = stdout.lines().chain(stderr.lines()).collect();
        let error_shown = e.shown.iter().any(|l| l.starts_with("error"));
        if out.status.success() == error_shown {
            failures.push(format!(
                "{}: `{}` exited with {} ({})",
                e.at,
                e.command,
                out.status,
                stderr.trim_end()
            ));
            continue;
        }
        for s in &e.shown {
            if !printed.iter().any(|p| same_line(s, p)) {
                failures.push(format!(
                    "{}: `{}` does not print the shown line\n  {s}\nit printed:\n{}",
                    e.at,
                    e.command,
                    printed.join("\n")
                ));
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn synopses_and_commands_are_told_apart() {
    assert!(is_synopsis(
        "damper sweep SCENARIO --set PATH=VALUES -o OUT"
    ));
    assert!(is_synopsis(
        "damper simulate scenarios/damper.toml [-o DIR]"
    ));
    assert!(!is_synopsis(
        "damper optimize scenarios/damper.toml --vary mechanism.half_angle_deg=3:25 --constraint 'reach>=0.002'"
    ));
    assert!(same_line(
        "scenarios/damper.toml: 50000 steps in 0.315 s (1 mechanism(s)); zeta 4.083 %; outputs in out/damper",
        "scenarios/damper.toml: 50000 steps in 0.402 s (1 mechanism(s)); zeta 4.083 %; outputs in /tmp/x"
    ));
    assert!(!same_line("zeta 4.083 %", "zeta 4.084 %"));
    assert!(same_line("residual 6.59e-23", "residual 7.1e-23"));
    let page = "text\n\n```console\n$ damper figures scenarios/damper.toml \\\n    --json\nline one\n...\n```\n\n    damper sweep SCENARIO --set PATH=VALUES\n";
    let found = examples("p.md", page);
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!(
        found[0].command,
        "damper figures scenarios/damper.toml --json"
    );
    assert_eq!(found[0].shown, ["line one"]);
    assert_eq!(found[0].at, "p.md:4");
}

/// The design map the front page shows (`docs/img/design_map.svg`) is the one its tour's
/// sweep draws today, byte for byte (regenerate it with that command when plots change).
#[test]
fn front_page_design_map_is_what_the_tour_sweep_draws() {
    let dir = temp("design_map");
    let (code, _, err) = damper(&[
        "sweep",
        "scenarios/damper.toml",
        "--set",
        "mechanism.half_angle_deg=3:25:12",
        "--set",
        "generator.load_resistance=0.5:20:12:log",
        "--constraint",
        "linear.reach>=0.002",
        "--constraint",
        "linear.zeta1>=0.05",
        "-o",
        dir.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(code, 0, "{err}");
    let drawn = std::fs::read(dir.join("sweep_map_linear.zeta1.svg")).unwrap();
    let shown = std::fs::read(root().join("docs/img/design_map.svg")).unwrap();
    assert!(
        drawn == shown,
        "docs/img/design_map.svg is out of date: copy {}/sweep_map_linear.zeta1.svg over it",
        dir.display()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
