//! Gradient cost (issue #22): the adjoint gradient of an objective over two design variables
//! (`codegen_cli::sensitivity::gradients`: one analysis at the point, the pencil's
//! derivative from the linearisations of the difference formula) against central
//! differences of the objective alone, re-evaluated from the scenario at the four points
//! (load, linearise, analyse: what a finite-difference gradient costs). Three objectives of
//! the paper's damper: the first-mode damping (`zeta1`, one eigenvalue), the receptance peak
//! (`peak:1.0:3:12`, a frequency search), the RMS tip response under white noise
//! (`rms:1.0`, a Lyapunov solution). Compare each pair (the ratio is the speed-up).
#![allow(missing_docs)] // criterion's macros generate undocumented items

use std::path::{Path, PathBuf};

use codegen_cli::optimize::{Problem, Variable, overrides_at};
use codegen_cli::scenario::parse_with;
use codegen_cli::sensitivity::gradients;
use criterion::{Criterion, criterion_group, criterion_main};
use hybrid_core::hybrid::{EigenMethod, modes};

/// The objective alone at `x`.
fn objective(path: &Path, text: &str, vars: &[Variable], x: &[f64], name: &str) -> f64 {
    let overrides = overrides_at(&[], vars.iter().map(|v| v.path.as_str()).zip(x));
    let sc = parse_with(text, path, &overrides).unwrap().scenario;
    let file = path.display().to_string();
    if let Some(spec) = codegen_cli::linear::PeakSpec::parse(name) {
        return codegen_cli::linear::receptance_peak(&file, &sc, &spec)
            .unwrap()
            .1;
    }
    if let Some(out) = name.strip_prefix("rms:") {
        return codegen_cli::random::output_rms(&file, &sc, out).unwrap().0;
    }
    let (_, lin) = codegen_cli::linear::linearise_scenario(&file, &sc).unwrap();
    modes(&lin, 1, EigenMethod::Auto).unwrap()[0].damping_ratio
}

fn sensitivity(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let var = |path: &str, lo, hi| Variable {
        path: path.into(),
        lo,
        hi,
    };
    let damper = vec![
        var("mechanism.half_angle_deg", 3.0, 25.0),
        var("generator.load_resistance", 0.5, 20.0),
    ];
    let hybrid = vec![
        var("mechanism[0].placement.half_angle_deg", 3.0, 25.0),
        var("force[0].load_resistance", 0.5, 20.0),
    ];
    let cases: Vec<(&str, PathBuf, Vec<Variable>, &str)> = vec![
        (
            "zeta1",
            root.join("scenarios/damper.toml"),
            damper,
            "linear.zeta1",
        ),
        (
            "peak",
            root.join("scenarios/forced_damper.toml"),
            hybrid.clone(),
            "peak:1.0:3:12",
        ),
        (
            "rms",
            root.join("scenarios/random_damper.toml"),
            hybrid,
            "rms:1.0",
        ),
    ];
    let x = [10.0, 3.5];
    let mut g = c.benchmark_group("gradient");
    g.sample_size(10);
    for (name, path, vars, figure) in &cases {
        let text = std::fs::read_to_string(path).unwrap();
        let problem = Problem {
            path,
            text: &text,
            fixed: &[],
            variables: vars,
            objective: figure.to_string(),
            maximize: true,
            constraints: &[],
            grid: 2,
            method: Default::default(),
        };
        g.bench_function(format!("{name}_adjoint"), |b| {
            b.iter(|| gradients(&problem, &x).unwrap())
        });
        g.bench_function(format!("{name}_central_differences"), |b| {
            b.iter(|| {
                (0..2)
                    .map(|k| {
                        let h = 1e-4 * (vars[k].hi - vars[k].lo);
                        let (mut up, mut dn) = (x, x);
                        up[k] += h;
                        dn[k] -= h;
                        (objective(path, &text, vars, &up, figure)
                            - objective(path, &text, vars, &dn, figure))
                            / (2.0 * h)
                    })
                    .collect::<Vec<f64>>()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, sensitivity);
criterion_main!(benches);
