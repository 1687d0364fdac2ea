//! End-to-end tests of `damper generate`, run as a user would run the binary: the file it
//! writes is exactly the library's emission and parses as Rust; `--stats` prints the
//! operation counts; bad models and unwritable outputs are one-line errors with exit code 2
//! that leave no file (partial or temporary) behind.

use crate::common;

use common::{assert_bad_input, damper, root};
use std::path::{Path, PathBuf};

use mbs_symbolic::emit::{EmitOptions, generate};

/// A fresh, empty scratch directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("damper-generate-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn library_output(rel: &str, struct_name: Option<&str>) -> mbs_symbolic::emit::Generated {
    let model = mbs_symbolic::model::load(&root().join(rel)).unwrap_or_else(|e| panic!("{e}"));
    let opts = EmitOptions {
        struct_name: struct_name.map(str::to_string),
        ..EmitOptions::default()
    };
    generate(&model, &opts).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn generate_writes_the_library_emission_and_it_parses() {
    let dir = scratch("ok");
    let out = dir.join("four_bar.rs");
    let out_s = out.to_str().unwrap();
    let (code, stdout, err) = damper(&["generate", "models/four_bar.toml", "-o", out_s]);
    assert_eq!(code, 0, "{err}");
    assert!(stdout.is_empty(), "no --stats, nothing on stdout: {stdout}");
    assert!(err.contains("written") && err.contains("FourBar"), "{err}");
    let written = std::fs::read_to_string(&out).unwrap();
    assert_eq!(written, library_output("models/four_bar.toml", None).source);
    let file = syn::parse_file(&written).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        file.items
            .iter()
            .any(|i| matches!(i, syn::Item::Struct(s) if s.ident == "FourBar"))
    );

    // Unchanged output is not rewritten (same bytes, same modification time).
    let mtime = std::fs::metadata(&out).unwrap().modified().unwrap();
    let (code, _, err) = damper(&["generate", "models/four_bar.toml", "--output", out_s]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("unchanged"), "{err}");
    assert_eq!(std::fs::metadata(&out).unwrap().modified().unwrap(), mtime);

    // --struct-name, and a JSON model.
    let (code, _, err) = damper(&[
        "generate",
        "models/pendulum.json",
        "-o",
        out_s,
        "--struct-name",
        "Swing",
    ]);
    assert_eq!(code, 0, "{err}");
    let written = std::fs::read_to_string(&out).unwrap();
    assert_eq!(
        written,
        library_output("models/pendulum.json", Some("Swing")).source
    );
    syn::parse_file(&written).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(listing(&dir), ["four_bar.rs"], "no temporary file left");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn stats_prints_one_row_per_function_and_the_sums() {
    let dir = scratch("stats");
    let out = dir.join("x.rs");
    let (code, stdout, err) = damper(&[
        "generate",
        "models/double_bar.toml",
        "-o",
        out.to_str().unwrap(),
        "--stats",
    ]);
    assert_eq!(code, 0, "{err}");
    let rows: Vec<Vec<&str>> = stdout
        .lines()
        .map(|l| l.split_whitespace().collect())
        .collect();
    assert_eq!(
        rows[0],
        ["function", "adds", "muls", "divs", "funcs", "negs", "total"]
    );
    let stats = library_output("models/double_bar.toml", None).stats;
    assert_eq!(
        rows.len(),
        stats.len() + 2,
        "header, functions, all:\n{stdout}"
    );
    let mut sums = [0usize; 6];
    for ((name, c), row) in stats.iter().zip(&rows[1..]) {
        let want = [c.adds, c.muls, c.divs, c.funcs, c.negs, c.total()];
        let got: Vec<usize> = row[1..].iter().map(|x| x.parse().unwrap()).collect();
        assert_eq!(row[0], name);
        assert_eq!(got, want, "{name}");
        for (s, w) in sums.iter_mut().zip(want) {
            *s += w;
        }
    }
    let last = rows.last().unwrap();
    assert_eq!(last[0], "all");
    let got: Vec<usize> = last[1..].iter().map(|x| x.parse().unwrap()).collect();
    assert_eq!(got, sums);
    // The double bar's functions, by name.
    let names: Vec<&str> = rows[1..rows.len() - 1].iter().map(|r| r[0]).collect();
    assert_eq!(
        names,
        [
            "mass_matrix",
            "f_vector",
            "q_vector",
            "constraints",
            "constraint_jacobian",
            "constraint_bias",
            "potential_energy",
            "element_power",
            "gravity_load_jacobian",
            "evaluate",
            "point_tip",
            "position_tip",
            "evaluate_with_points",
            "hoisted_values"
        ]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A bad model is reported with its file and line; an existing output is left untouched.
#[test]
fn bad_model_is_an_error_with_file_and_line_and_writes_nothing() {
    let dir = scratch("bad");
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "[[bodies]]\nname = \"crank\"\njoint = \"R3\"\nmass = -1.0\n",
    )
    .unwrap();
    let out = dir.join("out.rs");
    std::fs::write(&out, "// previous content\n").unwrap();
    assert_bad_input(
        &[
            "generate",
            bad.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ],
        &["bad.toml:4", "crank", "mass"],
    );
    assert_eq!(
        std::fs::read_to_string(&out).unwrap(),
        "// previous content\n"
    );
    // An invalid struct name is an error too, not a panic.
    assert_bad_input(
        &[
            "generate",
            "models/double_bar.toml",
            "-o",
            out.to_str().unwrap(),
            "--struct-name",
            "fn",
        ],
        &["struct name \"fn\"", "not a Rust identifier"],
    );
    assert_eq!(listing(&dir), ["bad.toml", "out.rs"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Outputs that cannot be written: a missing directory, a directory, a path below a regular
/// file. Each is a one-line error with exit code 2, and nothing is created.
#[test]
fn unwritable_output_is_an_error_and_leaves_no_file() {
    let dir = scratch("unwritable");
    let file = dir.join("plain.txt");
    std::fs::write(&file, "x").unwrap();
    let cases = [
        (dir.join("missing").join("x.rs"), "does not exist"),
        (dir.clone(), "is a directory"),
        (file.join("x.rs"), "is not a directory"),
    ];
    for (out, needle) in &cases {
        assert_bad_input(
            &[
                "generate",
                "models/double_bar.toml",
                "-o",
                out.to_str().unwrap(),
            ],
            &[needle],
        );
    }
    assert_eq!(listing(&dir), ["plain.txt"], "nothing created");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "x");
    let _ = std::fs::remove_dir_all(&dir);
    // Usage errors are clap's (exit code 2): -o is required.
    let (code, _, err) = damper(&["generate", "models/double_bar.toml"]);
    assert_eq!(code, 2);
    assert!(err.contains("--output"), "{err}");
}

/// A planar chain of `n` bodies (revolute joints about z).
fn chain(dir: &Path, n: usize) -> PathBuf {
    let mut text = String::from("name = \"chain\"\ngravity = [0.0, -9.81, 0.0]\n");
    for i in 0..n {
        let (parent, x) = match i {
            0 => ("ground".to_string(), 0.0),
            _ => (format!("b{}", i - 1), 0.1),
        };
        text += &format!(
            "\n[[bodies]]\nname = \"b{i}\"\nparent = \"{parent}\"\njoint = \"R3\"\nanchor = [{x}, 0, 0]\ncoordinate = \"q{i}\"\nmass = 0.1\ncom = [0.05, 0, 0]\ninertia = {{ xx = 0, yy = 1e-4, zz = 1e-4 }}\n"
        );
    }
    let path = dir.join(format!("chain{n}.toml"));
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_model_above_the_size_limit_is_refused_unless_allow_long() {
    let dir = scratch("limit");
    let out = dir.join("chain.rs");
    let out_s = out.to_str().unwrap();
    // 10^4 bodies: an estimated 37 GiB of source (it ran out of memory after a minute).
    let big = chain(&dir, 10_000);
    assert_bad_input(
        &["generate", big.to_str().unwrap(), "-o", out_s],
        &[
            "GiB of generated source",
            "10000 coordinates",
            "--allow-long",
        ],
    );
    // 290 bodies: just above the limit (32 MiB); --allow-long generates it.
    let moderate = chain(&dir, 290);
    let args = ["generate", moderate.to_str().unwrap(), "-o", out_s];
    assert_bad_input(&args, &["MiB of generated source", "--allow-long"]);
    assert!(!out.exists(), "nothing written on a refusal");
    let mut long = args.to_vec();
    long.push("--allow-long");
    let (code, _, err) = damper(&long);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("290 coordinates"), "{err}");
    assert!(std::fs::metadata(&out).unwrap().len() > 1_000_000);
    let _ = std::fs::remove_dir_all(&dir);
}
