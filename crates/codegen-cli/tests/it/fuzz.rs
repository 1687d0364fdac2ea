//! Fuzz harness (issue "Bad input, signals and special files", item 6): the bundled model,
//! scenario and beam files mutated (token deletion and duplication, type changes, extreme
//! numbers, long strings, unicode) and fed to the library entry points — parse and validate,
//! parameter checks, code generation, beam modes, and a few damper time steps.
//!
//! Asserted for every case: no panic; every error of a file names that file; every Ok
//! result is finite. The budget in `cargo test` is small (a few seconds in release);
//! `fuzz_long` (ignored) runs `DAMPER_FUZZ_CASES` cases (default 100,000).

use crate::common;

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Inputs accepted (Ok) per kind: model, scenario, beam, damper runs — so the long run can
/// report that the mutations do not only produce errors.
static ACCEPTED: [AtomicUsize; 4] = [const { AtomicUsize::new(0) }; 4];

fn accepted(kind: usize) {
    ACCEPTED[kind].fetch_add(1, Ordering::Relaxed);
}

use codegen_cli::scenario::{self, Scenario};
use mbs_symbolic::emit::{EmitOptions, generate};
use mbs_symbolic::model::{self, Format};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

/// The bundled inputs, by kind.
const MODELS: [&str; 3] = [
    "models/double_bar.toml",
    "models/four_bar.toml",
    "models/slider_crank.toml",
];
const SCENARIOS: [&str; 7] = [
    "scenarios/damper.toml",
    "scenarios/four_bar.toml",
    "scenarios/slider_crank.toml",
    "scenarios/two_dampers.toml",
    "scenarios/pendulum_absorber.toml",
    "scenarios/slider_crank_damper.toml",
    "scenarios/forced_damper.toml",
];
const BEAMS: [&str; 1] = ["beams/cantilever.toml"];

/// Replacement tokens: extreme numbers, type changes, long strings, unicode.
const REPLACEMENTS: [&str; 22] = [
    "0",
    "-1",
    "1e308",
    "-1e308",
    "5e-324",
    "1e300",
    "nan",
    "inf",
    "-inf",
    "1e-12",
    "1e9",
    "\"x\"",
    "[]",
    "{}",
    "true",
    "\"mechanizm\"",
    "\"é漢🦀\u{202e}\"",
    "=",
    "[[bodies]]",
    "\"\\u0000\"",
    "9999999999999999999999",
    "\"LONG\"",
];

/// One edit of a token list.
#[derive(Clone, Debug)]
enum Mutation {
    Delete(usize),
    Duplicate(usize),
    Replace(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        any::<usize>().prop_map(Mutation::Delete),
        any::<usize>().prop_map(Mutation::Duplicate),
        (any::<usize>(), 0..REPLACEMENTS.len()).prop_map(|(i, r)| Mutation::Replace(i, r)),
    ]
}

/// Splits into tokens that keep the separators (so unmutated text is unchanged).
fn tokens(text: &str) -> Vec<String> {
    let mut out = vec![];
    let mut cur = String::new();
    for c in text.chars() {
        let sep = c.is_whitespace() || ",[]{}=".contains(c);
        if sep {
            if !cur.is_empty() {
                out.push(std::mem::take(&mut cur));
            }
            out.push(c.to_string());
        } else {
            cur.push(c);
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

fn mutate(text: &str, edits: &[Mutation]) -> String {
    let mut t = tokens(text);
    for e in edits {
        if t.is_empty() {
            break;
        }
        let n = t.len();
        match *e {
            Mutation::Delete(i) => {
                t.remove(i % n);
            }
            Mutation::Duplicate(i) => {
                let x = t[i % n].clone();
                t.insert(i % n, x);
            }
            Mutation::Replace(i, r) => {
                t[i % n] = match REPLACEMENTS[r] {
                    "\"LONG\"" => format!("\"{}\"", "w".repeat(70_000)),
                    other => other.to_string(),
                };
            }
        }
    }
    t.concat()
}

/// Asserts that an error message names the file (the message is also kept short: one line
/// per problem, echoed input truncated).
fn names_file(what: &str, message: &str, file: &str) {
    assert!(
        message.contains(file),
        "{what}: error without the file: {message}"
    );
}

fn check_model(text: &str) {
    match model::parse_str(text, "fuzz_model.toml", Format::Toml) {
        Err(d) => names_file("model", &d.to_string(), "fuzz_model.toml"),
        Ok(m) => {
            accepted(0);
            // A validated model passes the parameter checks at its defaults.
            model::check_parameter_values(&m, &m.default_params(), "fuzz_model.toml")
                .unwrap_or_else(|e| panic!("validated model fails its own checks: {e}"));
            if m.dof() <= 8 {
                if let Ok(g) = generate(&m, &EmitOptions::default()) {
                    assert!(!g.source.is_empty());
                }
            }
        }
    }
}

fn check_beam(text: &str) {
    match fem_beam::Beam::from_toml_str(text, "fuzz_beam.toml") {
        Err(e) => names_file("beam", &e.to_string(), "fuzz_beam.toml"),
        Ok(beam) => {
            accepted(2);
            let elements: usize = beam.segments().iter().map(|s| s.elements).sum();
            if elements > 400 {
                return; // the budget: assembling is O(n), the eigen-solve is not
            }
            if let Ok(model) = fem_beam::BeamModel::new(&beam) {
                if let Ok(modes) = model.modes(3.min(model.dof_count())) {
                    for f in modes.frequencies_hz() {
                        assert!(f.is_finite(), "non-finite frequency {f}");
                    }
                }
            }
        }
    }
}

fn check_scenario(text: &str, base: &Path) {
    match scenario::parse_in(text, "fuzz_scenario.toml", base) {
        Err(d) => names_file("scenario", &d.to_string(), "fuzz_scenario.toml"),
        Ok(Scenario::Damper(mut sc)) => {
            accepted(1);
            let Ok(m) = model::load(&sc.model_path) else {
                return;
            };
            if sc.check_parameters(&m).is_err() {
                return;
            }
            // A few time steps only.
            sc.setup.t_end = sc.setup.t_end.min(20.0 * sc.setup.dt);
            sc.spec.output.compare = vec![];
            let mut finite = |s: &hybrid_core::study::Sample| {
                assert!(s.t.is_finite() && s.tip_displacement.is_finite(), "{s:?}");
                Ok(())
            };
            if let Ok(o) = codegen_cli::run::damper(&sc, &m, false, &mut finite, &mut []) {
                accepted(3);
                assert!(o.peak.is_finite(), "peak {}", o.peak);
            }
        }
        Ok(Scenario::Hybrid(sc)) => {
            accepted(1);
            // Models, names and geometry are checked by `build`: a typed error naming the
            // scenario file, or a state to step from.
            let built = match sc.build() {
                Err(d) => return names_file("hybrid build", &d.to_string(), "fuzz_scenario.toml"),
                Ok(b) => b,
            };
            let (model, mut state) = (&built.model, built.state.clone());
            let dt = sc.integrator.dt;
            let Ok(mut integ) = hybrid_core::hybrid::Integrator::new(model, sc.method, dt, &state)
            else {
                return;
            };
            // A few time steps only; a stop is a typed error (singular position, divergence).
            for _ in 0..20 {
                if integ.step(model, &mut state).is_err() {
                    return;
                }
                assert!(
                    state.q.iter().chain(&state.v).all(|x| x.is_finite())
                        && state
                            .mechanisms
                            .iter()
                            .all(|m| m.q.iter().all(|x| x.is_finite())),
                    "non-finite hybrid state at t = {}",
                    state.t
                );
            }
            accepted(3);
        }
        Ok(Scenario::Mechanism(sc)) => {
            accepted(1);
            let s = &sc.settings;
            assert!(s.t_end.is_finite() && s.output_step.is_finite() && s.output_step > 0.0);
        }
    }
}

/// Runs `cases` mutated inputs of every kind; returns the number run.
fn run(cases: u32) -> u32 {
    let root = common::root();
    let read = |p: &str| std::fs::read_to_string(root.join(p)).unwrap();
    let models: Vec<String> = MODELS.iter().map(|p| read(p)).collect();
    let scenarios: Vec<String> = SCENARIOS.iter().map(|p| read(p)).collect();
    let beams: Vec<String> = BEAMS.iter().map(|p| read(p)).collect();
    let base = root.join("scenarios");
    let mut runner = TestRunner::new(Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    });
    let strategy = (
        0..3usize,
        0..3usize,
        prop::collection::vec(mutation(), 1..5),
    );
    runner
        .run(&strategy, |(kind, file, edits)| {
            match kind {
                0 => check_model(&mutate(&models[file], &edits)),
                1 => check_scenario(&mutate(&scenarios[file], &edits), &base),
                _ => check_beam(&mutate(&beams[file % beams.len()], &edits)),
            }
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
    cases
}

#[test]
fn fuzz_bundled_files_bounded() {
    run(3000);
}

#[test]
#[ignore = "long run: DAMPER_FUZZ_CASES cases (default 100000)"]
fn fuzz_long() {
    let cases = std::env::var("DAMPER_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100_000);
    let started = std::time::Instant::now();
    let n = run(cases);
    let ok: Vec<usize> = ACCEPTED.iter().map(|a| a.load(Ordering::Relaxed)).collect();
    eprintln!(
        "fuzz_long: {n} cases in {:.1} s; accepted: {} models, {} scenarios, {} beams, {} damper runs",
        started.elapsed().as_secs_f64(),
        ok[0],
        ok[1],
        ok[2],
        ok[3]
    );
}
