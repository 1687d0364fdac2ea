//! Right-hand-side evaluations per second of the reduced equations of the four-bar
//! (eqs. 22–25): one evaluation is `M, F, Q, h, J, A` from the backend, the reduction
//! `M^R, F^R, Q^R` for the partition u = [q1], and the Cholesky solve for `u''` — what the
//! integrator does per stage after the position projection. Generated code, the DAG
//! interpreter and the numeric recursive reference on the same model, in one run (criterion
//! reports elements/s = evaluations/s; compare the ratios). Also the reduction and solve alone,
//! and the choice of partition by LU with full pivoting of `J`.
#![allow(missing_docs)] // criterion's macros generate undocumented items

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use hybrid_core::closed_loop::{
    AssemblyOptions, InterpretedSystem, NumericSystem, System, assemble,
};
use hybrid_core::partition::{Partition, ReduceWorkspace, Reduced, choose_partition, reduce_into};
use nalgebra::DVector;

/// Consistent four-bar states around a full crank turn, with seeded crank speeds.
fn states(sys: &dyn System) -> Vec<(Vec<f64>, Vec<f64>)> {
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let mut guess = (0.0, 1.6);
    (0..64)
        .map(|k| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let w = (seed >> 11) as f64 / (1u64 << 53) as f64 * 20.0 - 10.0;
            let q1 = k as f64 * std::f64::consts::TAU / 64.0;
            let (q, qd) = assemble(
                sys,
                &[q1, guess.0, guess.1],
                &[0],
                &[w, 0.0, 0.0],
                &[0],
                &AssemblyOptions::default(),
            )
            .expect("four-bar assembles");
            guess = (q[1], q[2]);
            (q, qd)
        })
        .collect()
}

fn bench_backend<S: System>(
    c: &mut Criterion,
    name: &str,
    sys: &S,
    states: &[(Vec<f64>, Vec<f64>)],
) {
    let p = Partition::from_independent(3, &[0]).unwrap();
    let mut ws = sys.workspace();
    let mut rws = ReduceWorkspace::new();
    let mut red = Reduced::empty();
    let mut udd = DVector::zeros(1);
    let mut group = c.benchmark_group("closed_loop_rhs");
    group.throughput(Throughput::Elements(1));
    let mut k = 0;
    group.bench_function(name, |b| {
        b.iter(|| {
            let (q, qd) = &states[k % states.len()];
            k += 1;
            sys.evaluate(black_box(q), black_box(qd), 0.0, &mut ws);
            reduce_into(&ws.m, &ws.f, &ws.q, &ws.j, &ws.a, &p, &mut rws, &mut red).unwrap();
            red.accelerations_into(&mut rws, &mut udd).unwrap();
            black_box(udd[0])
        })
    });
    group.finish();
    // The backend's share alone (same states, no reduction).
    let mut group = c.benchmark_group("closed_loop_evaluate");
    group.throughput(Throughput::Elements(1));
    group.bench_function(name, |b| {
        b.iter(|| {
            let (q, qd) = &states[k % states.len()];
            k += 1;
            sys.evaluate(black_box(q), black_box(qd), 0.0, &mut ws);
            black_box(ws.f[0])
        })
    });
    group.finish();
}

/// The reduction (23)–(25) and the solve of (22) alone, on one evaluated state.
fn bench_reduction<S: System>(c: &mut Criterion, sys: &S, states: &[(Vec<f64>, Vec<f64>)]) {
    let p = Partition::from_independent(3, &[0]).unwrap();
    let mut ws = sys.workspace();
    let (q, qd) = &states[5];
    sys.evaluate(q, qd, 0.0, &mut ws);
    let mut rws = ReduceWorkspace::new();
    let mut red = Reduced::empty();
    let mut udd = DVector::zeros(1);
    let mut group = c.benchmark_group("closed_loop_reduce");
    group.throughput(Throughput::Elements(1));
    group.bench_function("reduce_and_solve", |b| {
        b.iter(|| {
            reduce_into(
                black_box(&ws.m),
                &ws.f,
                &ws.q,
                &ws.j,
                &ws.a,
                &p,
                &mut rws,
                &mut red,
            )
            .unwrap();
            red.accelerations_into(&mut rws, &mut udd).unwrap();
            black_box(udd[0])
        })
    });
    group.finish();
}

/// The choice of partition by LU with full pivoting of `J` (done after every accepted step),
/// on the evaluated states of a crank turn.
fn bench_choice<S: System>(c: &mut Criterion, sys: &S, states: &[(Vec<f64>, Vec<f64>)]) {
    let jacobians: Vec<_> = states
        .iter()
        .map(|(q, _)| {
            let mut ws = sys.workspace();
            sys.evaluate_positions(q, &mut ws);
            ws.j
        })
        .collect();
    let mut group = c.benchmark_group("closed_loop_partition");
    group.throughput(Throughput::Elements(1));
    let mut k = 0;
    group.bench_function("choose_full_pivot_lu", |b| {
        b.iter(|| {
            let j = &jacobians[k % jacobians.len()];
            k += 1;
            black_box(choose_partition(black_box(j), 1e-9).rank)
        })
    });
    group.finish();
}

fn closed_loop_rhs(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/four_bar.toml");
    let model = mbs_symbolic::model::load(&path).expect("four_bar.toml loads");
    // As the product runs it: the registry's generated code behind the dynamic interface.
    let generated = model_registry::find_by_name("four_bar")
        .expect("models/four_bar.toml is compiled in")
        .system();
    let interpreter = InterpretedSystem::new(&model);
    let numeric = NumericSystem::new(&model);
    let states = states(&generated);
    bench_backend(c, "generated", &generated, &states);
    bench_backend(c, "interpreter", &interpreter, &states);
    bench_backend(c, "numeric", &numeric, &states);
    bench_reduction(c, &generated, &states);
    bench_choice(c, &generated, &states);
}

criterion_group! {
    name = benches;
    config = Criterion::default().measurement_time(std::time::Duration::from_secs(3));
    targets = closed_loop_rhs
}
criterion_main!(benches);
