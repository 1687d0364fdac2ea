//! Issue #22: the optimiser's gradients ([`codegen_cli::sensitivity::gradients`]) — the
//! adjoint ones of the linear figures (`zeta1`, `f1`, `decay1`, `max_force`, `peak:`,
//! `harmonic.load_power`, `random.rms:`) and the differences of the others — equal central differences of the
//! figures re-evaluated from the scenario (Richardson-extrapolated, the steps of the smaller
//! error estimate among 1e-3 and 1e-2 of the variable's range) to 1e-6 of the gradient's norm, at two random points
//! (fixed seed) of every bundled damper and hybrid scenario, over a variable that moves the
//! static equilibrium and the geometry (half-angle, spring, gear) and one of the circuit.

use crate::common::root;
use codegen_cli::analysis::figures::Constraint;
use codegen_cli::optimize::{Problem, Variable, evaluate};
use codegen_cli::sensitivity::{Method, gradients};
use mbs_symbolic::samples::SplitMix64;

/// A scenario, its variables `(path, lo, hi)` and the figures checked.
type Case = (
    &'static str,
    Vec<(&'static str, f64, f64)>,
    Vec<&'static str>,
);

/// The bundled damper and hybrid scenarios.
fn cases() -> Vec<Case> {
    let damper_kind = vec![
        ("mechanism.half_angle_deg", 8.0, 12.0),
        ("generator.load_resistance", 2.0, 6.0),
    ];
    let hybrid = vec![
        ("mechanism[0].placement.half_angle_deg", 8.0, 12.0),
        ("force[0].load_resistance", 2.0, 6.0),
    ];
    let free = vec![
        "linear.f1",
        "linear.decay1",
        "linear.reach",
        "linear.amplification",
    ];
    let forced = [
        free.clone(),
        vec!["linear.max_force", "peak:1.0:3:12", "harmonic.load_power"],
    ]
    .concat();
    vec![
        ("damper.toml", damper_kind.clone(), free.clone()),
        ("aluminium_cantilever.toml", damper_kind, free.clone()),
        ("forced_damper.toml", hybrid.clone(), forced.clone()),
        ("base_damper.toml", hybrid.clone(), forced),
        (
            "random_damper.toml",
            hybrid.clone(),
            [
                free.clone(),
                vec![
                    "random.rms:1.0",
                    "linear.max_force",
                    "random.load_power",
                    "random.power",
                    "random.rms_current:generator",
                    "random.reach_sigma:damper",
                ],
            ]
            .concat(),
        ),
        (
            "random_base_damper.toml",
            hybrid,
            [free.clone(), vec!["random.rms:1.0"]].concat(),
        ),
        (
            "two_dampers.toml",
            vec![
                ("mechanism[1].placement.half_angle_deg", 8.0, 12.0),
                ("force[0].load_resistance", 2.0, 6.0),
            ],
            free.clone(),
        ),
        (
            "pendulum_absorber.toml",
            vec![
                ("force[0].k", 0.5, 0.7),
                ("force[1].load_resistance", 2.0, 6.0),
            ],
            vec!["linear.f1", "linear.decay1", "linear.amplification"],
        ),
        (
            "slider_crank_damper.toml",
            vec![
                ("force[0].gear_ratio", 4.0, 6.0),
                ("force[0].load_resistance", 2.0, 6.0),
            ],
            vec!["linear.f1", "linear.decay1", "linear.amplification"],
        ),
    ]
}

#[test]
fn gradients_equal_central_differences_of_the_figures_on_every_bundled_hybrid_scenario() {
    let mut rng = SplitMix64::new(22);
    for (file, vars, figures) in cases() {
        let path = root().join("scenarios").join(file);
        let text = std::fs::read_to_string(&path).unwrap();
        check(file, &path, &text, &vars, &figures, &mut rng);
    }
}

/// Every random figure, `random.toggle_rate` included, where the toggle is near: the paper's
/// damper under a white-noise tip force 225 times `random_damper.toml`'s PSD (the reach
/// about 2 RMS of the tip's motion, so the toggle rate is about 0.1 of the first mode's
/// frequency and its gradient is not lost in `exp(-a^2 / 2 sigma^2)`), with the ratio
/// constraint's figures.
#[test]
fn gradients_of_every_random_figure_equal_extrapolated_differences_near_the_toggle() {
    let mut rng = SplitMix64::new(29);
    let path = root().join("scenarios/random_damper.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("psd = 1e-4,", "psd = 2.25e-2,");
    assert!(text.contains("psd = 2.25e-2,"));
    let vars = vec![
        ("mechanism[0].placement.half_angle_deg", 8.0, 12.0),
        ("force[0].load_resistance", 2.0, 6.0),
    ];
    let figures = vec![
        "random.rms:1.0",
        "random.load_power",
        "random.power",
        "random.load_power:generator",
        "random.rms_current:generator",
        "random.reach_sigma:damper",
        "random.toggle_rate:damper",
    ];
    check(
        "random_damper.toml (225 G)",
        &path,
        &text,
        &vars,
        &figures,
        &mut rng,
    );
}

/// The gradients of `figures` (as constraints `FIGURE>=0`) over `vars` at two random points
/// against Richardson-extrapolated central differences (module documentation).
fn check(
    file: &str,
    path: &std::path::Path,
    text: &str,
    vars: &[(&str, f64, f64)],
    figures: &[&str],
    rng: &mut SplitMix64,
) {
    {
        let (path, text) = (path.to_path_buf(), text.to_string());
        let variables: Vec<Variable> = vars
            .iter()
            .map(|&(p, lo, hi)| Variable {
                path: p.to_string(),
                lo,
                hi,
            })
            .collect();
        let constraints: Vec<Constraint> = figures
            .iter()
            .map(|f| format!("{f}>=0").parse().unwrap())
            .collect();
        let problem = Problem {
            path: &path,
            text: &text,
            fixed: &[],
            variables: &variables,
            objective: "linear.zeta1".into(),
            maximize: true,
            constraints: &constraints,
            grid: 2,
            method: Default::default(),
        };
        for _ in 0..2 {
            // Inside the bounds by more than the reference's steps.
            let x: Vec<f64> = variables
                .iter()
                .map(|v| v.lo + (v.hi - v.lo) * (0.1 + 0.8 * rng.next_f64()))
                .collect();
            let got = gradients(&problem, &x).unwrap_or_else(|e| panic!("{file}: {e}"));
            // The reference: every figure re-evaluated from the scenario.
            let read = |x: &[f64]| {
                let e = evaluate(&problem, x, "test");
                assert!(e.error.is_none(), "{file} at {x:?}: {:?}", e.error);
                let mut v = vec![e.objective.unwrap()];
                v.extend(e.values.iter().map(|v| v.unwrap()));
                v
            };
            let at = read(&x);
            // Per figure and variable: Richardson's extrapolation of central differences at
            // steps (h, 2h) and its error estimate against (2h, 4h) (O(h^4) truncation), for
            // h = 1e-3 and 1e-2 of the range; the one of the smaller estimate (small steps
            // where the figure curves fast, large ones where its rounding dominates).
            let mut reference = vec![vec![0.0; variables.len()]; at.len()];
            for (k, v) in variables.iter().enumerate() {
                let diff = |h: f64| {
                    let (mut up, mut dn) = (x.clone(), x.clone());
                    up[k] += h;
                    dn[k] -= h;
                    let (a, b) = (read(&up), read(&dn));
                    a.iter()
                        .zip(&b)
                        .map(|(a, b)| (a - b) / (2.0 * h))
                        .collect::<Vec<_>>()
                };
                let mut best = vec![(f64::INFINITY, 0.0); at.len()];
                for scale in [1e-3, 1e-2] {
                    let h = scale * (v.hi - v.lo);
                    let (d1, d2, d4) = (diff(h), diff(2.0 * h), diff(4.0 * h));
                    for f in 0..at.len() {
                        let r1 = (4.0 * d1[f] - d2[f]) / 3.0;
                        let r2 = (4.0 * d2[f] - d4[f]) / 3.0;
                        let estimate = (r1 - r2).abs() / 15.0;
                        if estimate < best[f].0 {
                            best[f] = (estimate, r1);
                        }
                    }
                }
                for (f, (_, r)) in best.iter().enumerate() {
                    reference[f][k] = *r;
                }
            }
            for (f, g) in got.iter().enumerate() {
                let norm = reference[f].iter().map(|v| v * v).sum::<f64>().sqrt();
                // (A figure that does not depend on the variables: both exactly zero.)
                let err = g
                    .gradient
                    .iter()
                    .zip(&reference[f])
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
                    / if norm > 0.0 { norm } else { 1.0 };
                println!(
                    "{file} {:?}: {} = {:e} ({:?}), gradient {:?} vs {:?}: {err:e}",
                    x, g.figure, g.value, g.method, g.gradient, reference[f]
                );
                assert!(
                    (g.value - at[f]).abs() <= 1e-9 * at[f].abs(),
                    "{file} {}: value {} vs {}",
                    g.figure,
                    g.value,
                    at[f]
                );
                assert!(err < 1e-6, "{file} {}: {err:e}", g.figure);
                let linear = [
                    "linear.zeta1",
                    "linear.f1",
                    "linear.decay1",
                    "linear.max_force",
                ];
                let adjoint = linear.contains(&g.figure.as_str())
                    || g.figure.starts_with("peak:")
                    || g.figure.starts_with("random.rms:")
                    || g.figure == "harmonic.load_power";
                assert_eq!(
                    g.method == Method::Adjoint,
                    adjoint,
                    "{file} {}: {:?}",
                    g.figure,
                    g.method
                );
            }
        }
    }
}
