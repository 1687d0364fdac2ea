//! Benchmarks on the bundled frame (scenarios/frame: 1990 equations exported from
//! scikit-fem): loading the files into an [`ImportedStructure`] (read, parse, check, both
//! Cholesky factorisations of the positive-definiteness check), the Craig–Bampton
//! reduction with 30 fixed-interface modes (interface: the damper node's and the load
//! node's ux, uy) and the 10 lowest modes of the full model; and the 30 lowest modes of a
//! 500-element steel cantilever written as matrices (1,000 equations, a stiffness with
//! `cond ~ 1e13`: the case that did not converge before the projection without products
//! with `K`).
//!
//! Run with `cargo bench -p fem-structure --bench frame -- --warm-up-time 1 --measurement-time 5`;
//! the figures measured are in scenarios/frame/README.md.

#![allow(missing_docs)] // criterion's macros generate undocumented items

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{Criterion, criterion_group, criterion_main};

use fem_structure::tables::NodeDof;
use fem_structure::{DampingInput, ImportedStructure, MatrixFiles, craig_bampton, lowest_modes};

fn files() -> MatrixFiles {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/frame");
    MatrixFiles::in_directory(&d, DampingInput::None)
}

fn frame(c: &mut Criterion) {
    let f = files();
    let s = ImportedStructure::from_files(&f).expect("the bundled frame");
    let interface: Vec<usize> = [
        (613, NodeDof::Ux),
        (613, NodeDof::Uy),
        (741, NodeDof::Ux),
        (741, NodeDof::Uy),
    ]
    .iter()
    .map(|k| s.dofs.equation[k])
    .collect();
    let mut g = c.benchmark_group("frame");
    g.sample_size(10);
    g.bench_function("load", |b| {
        b.iter(|| ImportedStructure::from_files(black_box(&f)).unwrap())
    });
    g.bench_function("craig_bampton_30", |b| {
        b.iter(|| craig_bampton(&s.stiffness, &s.mass, None, black_box(&interface), 30).unwrap())
    });
    g.bench_function("lowest_modes_10", |b| {
        b.iter(|| lowest_modes(&s.stiffness, &s.mass, black_box(10)).unwrap())
    });
    g.finish();
}

fn long_beam(c: &mut Criterion) {
    let b = fem_beam::Beam::from_toml_str(
        "[[segment]]\nlength = 1.0\nyoungs_modulus = 210e9\ndensity = 7850.0\nwidth = 0.04\nheight = 0.008\nelements = 500\n\n[[support]]\nx = 0.0\nkind = \"clamped\"\n",
        "cantilever.toml",
    )
    .expect("a valid beam");
    let beam = fem_beam::BeamModel::new(&b).expect("a valid beam");
    let d = std::env::temp_dir().join(format!("fem-structure-bench-{}", std::process::id()));
    let mut f = fem_structure::beam_structure_files(&beam)
        .write_to(&d)
        .expect("a writable temporary directory");
    f.damping = DampingInput::None;
    let s = ImportedStructure::from_files(&f).expect("the exported beam");
    std::fs::remove_dir_all(&d).expect("the temporary directory");
    let mut g = c.benchmark_group("long_beam");
    g.sample_size(10);
    g.bench_function("lowest_modes_30", |b| {
        b.iter(|| lowest_modes(&s.stiffness, &s.mass, black_box(30)).unwrap())
    });
    g.finish();
}

criterion_group!(benches, frame, long_beam);
criterion_main!(benches);
