//! Benchmarks of the symbolic engine: derivation time of `M^b` and `F^b` for planar and
//! spatial N-link chains (N = 2..32). The operation counts are printed once per model (they
//! are deterministic, not timed).
#![allow(missing_docs)] // criterion's macros generate undocumented items

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use mbs_symbolic::dynamics::Symbolic;
use mbs_symbolic::samples::{planar_chain, spatial_chain};
use std::hint::black_box;

fn derive(c: &mut Criterion) {
    let mut group = c.benchmark_group("derive");
    for n in [2usize, 4, 8, 16, 32] {
        for (kind, model) in [("planar", planar_chain(n)), ("spatial", spatial_chain(n))] {
            let sym = Symbolic::derive(&model);
            eprintln!(
                "ops {kind} N={n}: M+F {} (M {}, F {}), DAG nodes {}",
                sym.op_count_mf().total(),
                sym.op_count_m().total(),
                sym.op_count_f().total(),
                sym.dag.len()
            );
            group.bench_with_input(BenchmarkId::new(kind, n), &model, |b, m| {
                b.iter(|| black_box(Symbolic::derive(black_box(m))))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, derive);
criterion_main!(benches);
