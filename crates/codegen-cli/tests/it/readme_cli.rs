//! The README against the binary it describes: the command table against `damper --help` and
//! every subcommand's help, where the binary lands and how to install it, and the sample
//! outputs the README shows (produced again here and compared, wall-clock times and output
//! directories aside), so that none of them can drift.

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

/// `text` with the figures that change from run to run masked: the wall-clock time
/// (`steps in 0.459 s`) and the output directory (`outputs in DIR`).
fn masked(line: &str) -> String {
    let mut out = line.to_string();
    if let Some(i) = out.find(" steps in ") {
        let from = i + " steps in ".len();
        if let Some(len) = out[from..].find(" s ") {
            out.replace_range(from..from + len, "<wall>");
        }
    }
    if let Some(i) = out.find("; outputs in ") {
        out.truncate(i + "; outputs in ".len());
        out.push_str("<dir>");
    }
    out
}

/// Every sample line of `damper simulate` in the README (an indented line starting with a
/// bundled scenario's path and giving its steps) is what the bundled scenario prints, apart from the wall-clock
/// time and the output directory.
#[test]
fn readme_sample_runs_are_what_the_scenarios_print() {
    let text = readme();
    let samples: Vec<&str> = text
        .lines()
        .filter(|l| {
            l.starts_with("    scenarios/") && l.contains(".toml: ") && l.contains(" steps in ")
        })
        .map(str::trim_start)
        .collect();
    assert!(samples.len() >= 3, "{samples:?}");
    let dir = temp("samples");
    for sample in samples {
        let scenario = &sample[..sample.find(": ").unwrap()];
        let out_dir = dir.join(scenario.replace('/', "_"));
        let (code, out, err) = damper(&[
            "simulate",
            scenario,
            "-o",
            out_dir.to_str().unwrap(),
            "--quiet",
        ]);
        assert_eq!(code, 0, "damper simulate {scenario}: {err}");
        let printed = out
            .lines()
            .find(|l| l.starts_with(scenario))
            .unwrap_or_else(|| panic!("damper simulate {scenario} printed {out:?}"));
        assert_eq!(
            masked(printed),
            masked(sample),
            "README.md's sample line for {scenario} is out of date; the run prints\n{printed}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The README's `damper generate --stats` sample is the table the command prints.
#[test]
fn readme_generate_stats_sample_is_what_generate_prints() {
    let text = readme();
    let command = "    $ damper generate models/double_bar.toml -o double_bar.rs --stats\n";
    let start = text.find(command).expect("the generate sample") + command.len();
    let sample: Vec<&str> = text[start..]
        .lines()
        .take_while(|l| l.starts_with("    "))
        .map(|l| l[4..].trim_end())
        .collect();
    let dir = temp("generate");
    let file = dir.join("double_bar.rs");
    let (code, out, err) = damper(&[
        "generate",
        "models/double_bar.toml",
        "-o",
        file.to_str().unwrap(),
        "--stats",
    ]);
    assert_eq!(code, 0, "{err}");
    let printed: Vec<&str> = out.lines().map(str::trim_end).collect();
    assert_eq!(
        printed, sample,
        "README.md's `damper generate --stats` sample is out of date; the command prints\n{out}"
    );
    let _ = std::fs::remove_dir_all(&dir);
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
    let text = readme();
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
    let text = readme();
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
