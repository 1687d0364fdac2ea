//! Benchmarks of the coupled damper simulation: the whole default scenario (5 s at
//! dt = 1e-4, 50,000 steps) and the cost of one step at 20, 200 and 2,000 beam elements
//! (which must grow linearly).
#![allow(missing_docs)] // criterion's macros generate undocumented items

use std::hint::black_box;
use std::path::PathBuf;

use codegen_cli::scenario::DamperScenario as Scenario;
use criterion::{BatchSize, BenchmarkId, Criterion, criterion_group, criterion_main};
use hybrid_core::damper::Integrator;
use hybrid_core::damper::Method;
use hybrid_core::hybrid::{Integrator as HybridIntegrator, initial_state};
use hybrid_core::study::{build_model, hybrid_of, run_setup};

fn scenario(elements: usize, t_end: f64) -> Scenario {
    let path = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/damper.toml"
    ));
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("elements = 20", &format!("elements = {elements}"))
        .replace("t_end = 5.0", &format!("t_end = {t_end}"));
    Scenario::from_str(&text, &path).unwrap()
}

/// The paper's double bar from the model registry, as the product runs it.
fn double_bar() -> Box<dyn mbs_symbolic::runtime::System> {
    model_registry::find_by_name("double_bar")
        .expect("models/double_bar.toml is compiled in")
        .system()
}

fn whole_run(c: &mut Criterion) {
    let mut g = c.benchmark_group("damper_run");
    g.sample_size(10);
    let sc = scenario(20, 5.0);
    g.bench_function("default_5s_dt1e-4", |b| {
        b.iter(|| {
            black_box(
                run_setup(
                    &sc.setup,
                    &double_bar_model(),
                    double_bar(),
                    true,
                    &mut |_| {},
                )
                .unwrap()
                .1
                .state
                .hybrid
                .t,
            )
        })
    });
    g.finish();
}

fn step_cost(c: &mut Criterion) {
    let mut g = c.benchmark_group("step_1000");
    for elements in [20usize, 200, 2000] {
        let sc = scenario(elements, 5.0);
        let (model, guess) =
            build_model(&sc.setup, &double_bar_model(), double_bar(), true).unwrap();
        let state = model.initial_state(1e-3, guess).unwrap();
        let integ = Integrator::new(&model, sc.setup.method, 1e-4).unwrap();
        g.bench_with_input(BenchmarkId::from_parameter(elements), &elements, |b, _| {
            b.iter_batched(
                || (integ.clone(), state.clone()),
                |(mut integ, mut state)| {
                    for _ in 0..1000 {
                        integ.step(&model, &mut state).unwrap();
                    }
                    black_box(state.t)
                },
                BatchSize::LargeInput,
            )
        });
    }
    g.finish();
}

/// The paper's damper as a general hybrid system, and with two more double bars at
/// x = 0.5 and 0.75 (three mechanisms): `(model, initial beam state)`.
fn hybrid(elements: usize, mechanisms: usize) -> (hybrid_core::hybrid::HybridModel, Vec<f64>) {
    let sc = scenario(elements, 5.0);
    let (model, guess) = build_model(&sc.setup, &double_bar_model(), double_bar(), true).unwrap();
    let (mut hm, q0) = hybrid_of(&sc.setup, &model, guess).unwrap();
    for (k, x) in [0.5, 0.75].into_iter().take(mechanisms - 1).enumerate() {
        let mut setup = sc.setup.clone();
        setup.x = x;
        let (m, g) = build_model(&setup, &double_bar_model(), double_bar(), true).unwrap();
        let (extra, _) = hybrid_of(&setup, &m, g).unwrap();
        let i = hm.mechanisms.len();
        let mut mech = extra.mechanisms[0].clone();
        mech.name = format!("damper{}", k + 2);
        hm.mechanisms.push(mech);
        let mut a = extra.attachments[0].clone();
        a.mechanism = i;
        hm.attachments.push(a);
        let mut f = extra.forces[0].clone();
        f.mechanism = i;
        hm.forces.push(f);
    }
    (hm, q0)
}

fn hybrid_step_cost(c: &mut Criterion) {
    for mechanisms in [1usize, 3] {
        let mut g = c.benchmark_group(format!("hybrid_step_1000/{mechanisms}_mechanisms"));
        for elements in [20usize, 200, 2000] {
            let (model, q0) = hybrid(elements, mechanisms);
            let n = q0.len();
            let state = initial_state(&model, q0, vec![0.0; n]).unwrap();
            let integ = HybridIntegrator::new(&model, Method::Newmark, 1e-4, &state).unwrap();
            g.bench_with_input(BenchmarkId::from_parameter(elements), &elements, |b, _| {
                b.iter_batched(
                    || (integ.clone(), state.clone()),
                    |(mut integ, mut state)| {
                        for _ in 0..1000 {
                            integ.step(&model, &mut state).unwrap();
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

criterion_group!(benches, whole_run, step_cost, hybrid_step_cost);
criterion_main!(benches);

/// The bundled double bar's model description (body names for the generator joint).
fn double_bar_model() -> mbs_symbolic::model::Model {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/double_bar.toml");
    mbs_symbolic::model::load(std::path::Path::new(path)).unwrap_or_else(|e| panic!("{e}"))
}
