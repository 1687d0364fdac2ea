//! First use: a run of a model that takes a compiled-in model's place (same file name) with
//! other content — a bundled model copied and edited — announces once on stderr, before it
//! runs on the interpreter, which file, why (its content hash against the compiled one) and
//! how to compile it in; an unedited copy runs the generated code without a word.

use crate::common;

use std::path::{Path, PathBuf};

use common::{damper, root};

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("stale_model_cli_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Copies `models/double_bar.toml` into `dir` (with `extra` appended) and the bundled
/// scenario `scenario` next to it, pointing at the copy; returns (scenario, model) paths.
fn setup(dir: &Path, scenario: &str, extra: &str) -> (PathBuf, PathBuf) {
    let model = dir.join("double_bar.toml");
    let text = std::fs::read_to_string(root().join("models/double_bar.toml")).unwrap();
    std::fs::write(&model, text + extra).unwrap();
    let sc = std::fs::read_to_string(root().join("scenarios").join(scenario)).unwrap();
    assert!(sc.contains("\"../models/double_bar.toml\""));
    let sc = sc.replace("\"../models/double_bar.toml\"", "\"double_bar.toml\"");
    let path = dir.join(scenario);
    std::fs::write(&path, sc).unwrap();
    (path, model)
}

/// The stale-model notices in `stderr`.
fn notices(stderr: &str) -> Vec<&str> {
    stderr
        .lines()
        .filter(|l| l.contains("double_bar.toml") && l.contains("DAG interpreter"))
        .collect()
}

#[test]
fn an_edited_copy_of_a_bundled_model_is_announced_exactly_once_per_run() {
    // The damper kind resolves its model for the run, each comparison run and the modal
    // filter's linearisation; the hybrid kind once per mechanism (two here); `linearize`
    // for the equilibrium and the tangents. One notice each.
    for (scenario, command, extra) in [
        (
            "damper.toml",
            "simulate",
            vec!["--set", "integrator.t_end=0.05"],
        ),
        (
            "two_dampers.toml",
            "simulate",
            vec!["--set", "integrator.t_end=0.05"],
        ),
        ("damper.toml", "linearize", vec![]),
    ] {
        let dir = temp(&format!("{command}_{}", scenario.replace('.', "_")));
        let (path, model) = setup(
            &dir,
            scenario,
            "\n# edited: a comment changes the content hash\n",
        );
        let out = dir.join("out");
        let mut args = vec![command, path.to_str().unwrap()];
        if command == "simulate" {
            args.extend(["-o", out.to_str().unwrap(), "--quiet"]);
        }
        args.extend(extra);
        let (code, stdout, stderr) = damper(&args);
        assert_eq!(code, 0, "damper {args:?}: {stderr}");
        let found = notices(&stderr);
        assert_eq!(
            found.len(),
            1,
            "damper {args:?}: one notice expected, stderr:\n{stderr}"
        );
        let notice = found[0];
        let hash = {
            let m = mbs_symbolic::model::load(&model).unwrap();
            m.source.hash
        };
        let compiled = model_registry::find_by_name("double_bar").unwrap();
        for part in [
            model.to_str().unwrap(),
            "not the compiled-in models/double_bar.toml",
            hash.as_str(),
            compiled.hash,
            "cargo build --release -p codegen-cli",
        ] {
            assert!(
                notice.contains(part),
                "{part:?} not in the notice {notice:?}"
            );
        }
        if command == "simulate" {
            // Before the run's own output, which then says it ran on the interpreter.
            let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
            assert!(summary.contains("interpreter"), "{summary}");
        } else {
            assert!(!stdout.is_empty());
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn an_unedited_copy_runs_the_generated_code_without_a_notice() {
    let dir = temp("unedited");
    let (path, _) = setup(&dir, "damper.toml", "");
    let out = dir.join("out");
    let (code, stdout, stderr) = damper(&[
        "simulate",
        path.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--quiet",
        "--set",
        "integrator.t_end=0.05",
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(notices(&stderr).is_empty(), "{stderr}");
    assert!(stdout.contains("1 mechanism(s) (generated)"), "{stdout}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A model of another name is not stale (nothing compiled in could stand for it): no
/// stale notice, whatever it contains.
#[test]
fn a_model_of_another_name_is_not_announced_as_stale() {
    let dir = temp("renamed");
    let (path, model) = setup(&dir, "damper.toml", "\n# edited\n");
    let renamed = dir.join("my_bar.toml");
    std::fs::rename(&model, &renamed).unwrap();
    let sc = std::fs::read_to_string(&path)
        .unwrap()
        .replace("\"double_bar.toml\"", "\"my_bar.toml\"");
    std::fs::write(&path, sc).unwrap();
    let (code, _, stderr) = damper(&[
        "simulate",
        path.to_str().unwrap(),
        "-o",
        dir.join("out").to_str().unwrap(),
        "--quiet",
        "--set",
        "integrator.t_end=0.05",
    ]);
    assert_eq!(code, 0, "{stderr}");
    assert!(!stderr.contains("not the compiled-in"), "{stderr}");
    assert!(!stderr.contains("changed since this build"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}
