//! Sweep throughput (issue #11): 40 operating angles of the paper's damper, each point
//! loaded with its override and linearised (`codegen_cli::sweep_point::evaluate`, what
//! `damper sweep` runs per point), on a rayon pool of 1 and of 2 threads; compare the two
//! (the ratio is the parallel speed-up on this machine).
#![allow(missing_docs)] // criterion's macros generate undocumented items

use std::path::Path;

use codegen_cli::scenario::Override;
use codegen_cli::sweep_point::{PointOptions, evaluate};
use criterion::{Criterion, criterion_group, criterion_main};
use rayon::prelude::*;

fn sweep(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let path = root.join("scenarios/damper.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let points: Vec<Vec<Override>> = (0..40)
        .map(|k| {
            let a = 2.0 + 18.0 * k as f64 / 39.0;
            vec![Override::new("mechanism.half_angle_deg", a.into(), &a.to_string()).unwrap()]
        })
        .collect();
    // Relative model paths resolve against the scenario's directory.
    let options = PointOptions::default();
    let mut g = c.benchmark_group("sweep");
    g.sample_size(10);
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        g.bench_function(
            format!("damper_40_angles_linearised_{threads}_threads"),
            |b| {
                b.iter(|| {
                    pool.install(|| {
                        let r: Vec<_> = points
                            .par_iter()
                            .map(|o| evaluate(&path, &text, o, &options))
                            .collect();
                        assert!(r.iter().all(Result::is_ok));
                        r
                    })
                })
            },
        );
    }
    g.finish();
}

criterion_group!(benches, sweep);
criterion_main!(benches);
