//! Benchmarks of the beam: O(n) assembly, factorisation and solves, and the modal analysis
//! of a large mesh.
//!
//! Report the ratio time(10,000) / time(1,000) of the `static` group (linear cost: ~10) and
//! the absolute 10,000-element figure; run with
//! `cargo bench -p fem-beam -- --warm-up-time 1 --measurement-time 3`.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};

use fem_beam::{Beam, BeamModel, BeamSpec, NodalLoadSpec, SegmentSpec, SupportKind, SupportSpec};

/// The damper's cantilever meshed into `n` elements, with a tip load.
fn cantilever(n: usize) -> Beam {
    Beam::new(&BeamSpec {
        segments: vec![SegmentSpec::rectangular(1.0, 210e9, 7850.0, 0.04, 0.008, n)],
        supports: vec![SupportSpec::at_x(0.0, SupportKind::Clamped)],
        loads: vec![NodalLoadSpec {
            x: Some(1.0),
            force: -10.0,
            ..Default::default()
        }],
        ..Default::default()
    })
    .expect("valid beam")
}

fn statics(c: &mut Criterion) {
    let mut g = c.benchmark_group("static");
    for n in [100usize, 1_000, 10_000] {
        let beam = cantilever(n);
        // Assembly (42)-(44) + LDL^T factorisation + solve (refined, as `static_deflection`).
        g.bench_with_input(
            BenchmarkId::new("assemble_factorize_solve", n),
            &beam,
            |b, beam| {
                b.iter(|| {
                    let model = BeamModel::new(black_box(beam)).unwrap();
                    model.static_deflection_at(0.0).unwrap()
                })
            },
        );
        // The same with a single plain solve (no refinement).
        g.bench_with_input(
            BenchmarkId::new("assemble_factorize_plain_solve", n),
            &beam,
            |b, beam| {
                b.iter(|| {
                    let model = BeamModel::new(black_box(beam)).unwrap();
                    let factor = model.factorize(model.stiffness()).unwrap();
                    let mut p = model.load(0.0);
                    factor.solve_in_place(&mut p);
                    p
                })
            },
        );
    }
    g.finish();
}

fn per_step(c: &mut Criterion) {
    // What the coupled simulation does every step, on prebuilt data: A v, a solve with a
    // reused factor, the load vector at time t.
    let mut g = c.benchmark_group("per_step");
    for n in [1_000usize, 10_000] {
        let model = BeamModel::new(&cantilever(n)).unwrap();
        let factor = model.mass().factorize().unwrap();
        let v: Vec<f64> = (0..model.dof_count()).map(|i| (i as f64).sin()).collect();
        let mut out = vec![0.0; model.dof_count()];
        g.bench_function(BenchmarkId::new("mass_times_vector", n), |b| {
            b.iter(|| model.mass().mul_vec_into(black_box(&v), &mut out))
        });
        g.bench_function(BenchmarkId::new("solve_in_place", n), |b| {
            b.iter(|| {
                out.copy_from_slice(&v);
                factor.solve_in_place(black_box(&mut out));
            })
        });
        g.bench_function(BenchmarkId::new("load_into", n), |b| {
            b.iter(|| model.load_into(black_box(0.1), &mut out))
        });
    }
    g.finish();
}

fn modal(c: &mut Criterion) {
    let mut g = c.benchmark_group("modes");
    g.sample_size(10);
    let model = BeamModel::new(&cantilever(2_000)).unwrap();
    g.bench_function("first_10_modes_2000_elements", |b| {
        b.iter(|| model.modes(black_box(10)).unwrap())
    });
    g.finish();
}

/// The benchmark group (the macro's generated function carries no documentation).
#[allow(missing_docs)]
mod group {
    use super::*;
    criterion_group!(benches, statics, per_step, modal);
}
criterion_main!(group::benches);
