//! Benchmarks of the paper's damper as the product runs it (the damper preset loaded by the
//! one scenario loader, built and integrated by the one engine): the whole default scenario
//! (5 s at dt = 1e-4, 50,000 steps, with its comparison runs' summaries) and the cost of 1000
//! steps at 20, 200 and 2,000 beam elements (which must grow linearly), with one double bar
//! and with three (at x = 0.5, 0.75 and 1 m).
#![allow(missing_docs)] // criterion's macros generate undocumented items

use std::hint::black_box;
use std::path::PathBuf;

use codegen_cli::scenario::{self, HybridScenario, Scenario};
use criterion::{BatchSize, BenchmarkId, Criterion, criterion_group, criterion_main};
use hybrid_core::hybrid::Integrator;

fn path() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/damper.toml"
    ))
}

fn hybrid(text: &str) -> HybridScenario {
    match scenario::parse(text, &path()).unwrap_or_else(|e| panic!("{e}")) {
        Scenario::Hybrid(sc) => *sc,
        _ => unreachable!("a damper scenario loads as the hybrid scenario it means"),
    }
}

/// The bundled damper scenario with `elements` beam elements and `mechanisms` double bars
/// (the bundled one at the tip; more at x = 0.5 and 0.75 m, the same damper).
fn damper(elements: usize, mechanisms: usize) -> HybridScenario {
    let mut text = std::fs::read_to_string(path())
        .unwrap()
        .replace("elements = 20", &format!("elements = {elements}"));
    if mechanisms > 1 {
        // The preset written out, with the extra dampers appended as hybrid tables.
        let beam = text
            .split("[mechanism]")
            .next()
            .unwrap()
            .replace("kind = \"damper\"", "kind = \"hybrid\"");
        let mut h = beam;
        for (k, x) in [1.0, 0.5, 0.75].into_iter().take(mechanisms).enumerate() {
            h.push_str(&format!(
                r#"
[[mechanism]]
name = "damper{k}"
model = "../models/double_bar.toml"
placement = {{ attachment = "pin{k}", half_angle_deg = 10.0 }}
max_condition = 1e4
[[attachment]]
name = "pin{k}"
mechanism = "damper{k}"
point = "tip"
kind = "pin"
x = {x}
[[force]]
name = "generator{k}"
mechanism = "damper{k}"
joint = "crank"
kind = "generator"
kt = 0.0235
ke = 0.0235
armature_resistance = 1.5
load_resistance = 3.5
inductance = 0.0
gear_ratio = 5.0
rotor_inertia = 1e-6
"#
            ));
        }
        h.push_str(
            "[initial]\ndisplacement = 0.001\nx = 1.0\n[integrator]\ndt = 1e-4\nt_end = 5.0\n",
        );
        text = h;
    }
    hybrid(&text)
}

fn whole_run(c: &mut Criterion) {
    let mut g = c.benchmark_group("damper_run");
    g.sample_size(10);
    let sc = damper(20, 1);
    g.bench_function("default_5s_dt1e-4", |b| {
        b.iter(|| {
            let built = codegen_cli::setup::build(&sc).unwrap();
            let run =
                codegen_cli::run_hybrid::evaluate(&sc, &built, &[], None, vec![], false).unwrap();
            black_box(run.summary.steps)
        })
    });
    g.finish();
}

fn step_cost(c: &mut Criterion) {
    for mechanisms in [1usize, 3] {
        let mut g = c.benchmark_group(format!("step_1000/{mechanisms}_mechanisms"));
        for elements in [20usize, 200, 2000] {
            let sc = damper(elements, mechanisms);
            let built = codegen_cli::setup::build(&sc).unwrap();
            let (model, state) = (&built.model, &built.state);
            let integ = Integrator::new(model, sc.method, sc.integrator.dt, state).unwrap();
            g.bench_with_input(BenchmarkId::from_parameter(elements), &elements, |b, _| {
                b.iter_batched(
                    || (integ.clone(), state.clone()),
                    |(mut integ, mut state)| {
                        for _ in 0..1000 {
                            integ.step(model, &mut state).unwrap();
                        }
                        black_box(state.t)
                    },
                    BatchSize::LargeInput,
                )
            });
        }
        g.finish();
    }
}

criterion_group!(benches, whole_run, step_cost);
criterion_main!(benches);
