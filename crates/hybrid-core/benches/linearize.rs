//! Linearised modes of the paper's damper (issue #11 benchmarks): the static equilibrium,
//! the exact reduced tangents and the first five modes for 100 operating angles of the
//! 20-element damper (target: under 1 s in total), and for a 2,000-element beam with the
//! damper (target: under 50 ms), on one core.
#![allow(missing_docs)] // criterion's macros generate undocumented items

#[path = "../tests/it/common/mod.rs"]
mod common;

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use hybrid_core::hybrid::{EigenMethod, EquilibriumOptions, Linearization, modes};

fn operating_angles(c: &mut Criterion) {
    let angles: Vec<f64> = (0..100).map(|k| 2.0 + 18.0 * k as f64 / 99.0).collect();
    let models: Vec<_> = angles
        .iter()
        .map(|&a| common::paper_damper_at(20, true, true, 0.0, a).0)
        .collect();
    let tangents = common::tangents(&models[0], &[]);
    let refs: Vec<_> = tangents.iter().collect();
    let mut g = c.benchmark_group("linearize");
    g.sample_size(10);
    g.bench_function("damper_20_elements_100_angles_5_modes", |b| {
        b.iter(|| {
            for m in &models {
                let lin = Linearization::new(m, &refs, EquilibriumOptions::default()).unwrap();
                black_box(modes(&lin, 5, EigenMethod::Auto).unwrap());
            }
        })
    });
    let (big, _) = common::paper_damper_at(2000, true, true, 0.0, 10.0);
    let lin = Linearization::new(&big, &refs, EquilibriumOptions::default()).unwrap();
    g.bench_function("damper_2000_elements_5_modes", |b| {
        b.iter(|| black_box(modes(&lin, 5, EigenMethod::ShiftInvert).unwrap()))
    });
    g.bench_function("damper_2000_elements_equilibrium_and_5_modes", |b| {
        b.iter(|| {
            let lin = Linearization::new(&big, &refs, EquilibriumOptions::default()).unwrap();
            black_box(modes(&lin, 5, EigenMethod::ShiftInvert).unwrap())
        })
    });
    g.finish();
}

criterion_group!(benches, operating_angles);
criterion_main!(benches);
