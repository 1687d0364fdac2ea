//! Every plot kind the tool writes, produced by its command and checked by reading its SVG
//! ([`crate::common::svg::check`]): a title, axis labels with units in brackets, tick labels
//! of at most 4 significant digits, log axes at 1-2-5 values, everything inside the view box,
//! no NaN or infinity.

use std::path::{Path, PathBuf};

use crate::common::damper;
use crate::common::svg::checked;

fn out(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("damper-plots-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn run(args: &[&str]) {
    let (code, _, err) = damper(args);
    assert_eq!(code, 0, "{args:?}: {err}");
}

fn plots(dir: &Path, expected: &[(&str, &[&str])]) {
    for (file, axes) in expected {
        checked(&dir.join(file), axes);
    }
    let svgs = std::fs::read_dir(dir)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "svg")
        })
        .count();
    assert_eq!(
        svgs,
        expected.len(),
        "{}: every plot checked",
        dir.display()
    );
    std::fs::remove_dir_all(dir).unwrap();
}

/// `simulate`: a free decay (displacements, damping against amplitude), a forced run, a
/// random run (displacements, RMS against time, response PSD against the linear
/// prediction), a rigid mechanism (coordinates).
#[test]
fn every_plot_of_simulate_reads_at_a_glance() {
    let d = out("free");
    run(&[
        "simulate",
        "scenarios/damper.toml",
        "--set",
        "integrator.t_end=1",
        "-o",
        d.to_str().unwrap(),
    ]);
    plots(
        &d,
        &[
            ("beam_displacement.svg", &["displacement [mm]", "time [s]"]),
            (
                "damping_vs_amplitude.svg",
                &["damping ratio of the cycle [%]"],
            ),
        ],
    );
    let d = out("forced");
    run(&[
        "simulate",
        "scenarios/forced_damper.toml",
        "--set",
        "integrator.t_end=0.5",
        "-o",
        d.to_str().unwrap(),
    ]);
    plots(
        &d,
        &[("beam_displacement.svg", &["displacement [mm]", "time [s]"])],
    );
    let d = out("random");
    run(&[
        "simulate",
        "scenarios/random_damper.toml",
        "--set",
        "integrator.t_end=3",
        "-o",
        d.to_str().unwrap(),
    ]);
    plots(
        &d,
        &[
            ("beam_displacement.svg", &["displacement [mm]", "time [s]"]),
            ("random_rms.svg", &["RMS [m]", "t [s]"]),
            ("random_psd.svg", &["PSD [m^2/Hz]", "f [Hz]"]),
        ],
    );
    let d = out("mechanism");
    run(&[
        "simulate",
        "scenarios/four_bar.toml",
        "-o",
        d.to_str().unwrap(),
    ]);
    plots(
        &d,
        &[("four_bar.svg", &["coordinate [rad or m]", "time [s]"])],
    );
}

/// `frf`: receptances on linear and log frequency axes (with nonlinear points), and the
/// admissible load.
#[test]
fn every_plot_of_frf_reads_at_a_glance() {
    for log in [true, false] {
        let d = out(if log { "frf-log" } else { "frf-lin" });
        let mut args = vec![
            "frf",
            "scenarios/forced_damper.toml",
            "--output",
            "1.0",
            "--from",
            "2",
            "--to",
            "200",
            "--points",
            "60",
            "-o",
            d.to_str().unwrap(),
        ];
        if log {
            args.extend(["--log", "--nonlinear", "2"]);
        }
        run(&args);
        plots(
            &d,
            &[
                ("frf.svg", &["|H| [m/N]", "frequency [Hz]"]),
                ("frf_max_force.svg", &["max force amplitude [N]", "f [Hz]"]),
            ],
        );
    }
}

/// `sweep`: a 1-D sweep (figures against the parameter), a 2-D one (its map with a colour
/// bar and contour) and a forced one (harvested power).
#[test]
fn every_plot_of_sweep_reads_at_a_glance() {
    let d = out("sweep1");
    run(&[
        "sweep",
        "scenarios/damper.toml",
        "--set",
        "mechanism.half_angle_deg=5:20:4",
        "--time-domain",
        "--t-end",
        "0.5",
        "-o",
        d.to_str().unwrap(),
    ]);
    plots(
        &d,
        &[
            (
                "sweep_damping.svg",
                &["damping ratio [%]", "mechanism.half_angle_deg [deg]"],
            ),
            (
                "sweep_frequency.svg",
                &["frequency [Hz]", "mechanism.half_angle_deg [deg]"],
            ),
            ("sweep_harvested.svg", &["mechanism.half_angle_deg [deg]"]),
        ],
    );
    let d = out("sweep2");
    run(&[
        "sweep",
        "scenarios/damper.toml",
        "--set",
        "mechanism.half_angle_deg=5:20:4",
        "--set",
        "generator.load_resistance=1:9:3",
        "--constraint",
        "linear.reach>=0.002",
        "-o",
        d.to_str().unwrap(),
    ]);
    plots(
        &d,
        &[
            ("sweep_damping.svg", &["damping ratio [%]"]),
            ("sweep_frequency.svg", &["frequency [Hz]"]),
            (
                "sweep_map_linear.zeta1.svg",
                &[
                    "linear.zeta1 [-]",
                    "generator.load_resistance [ohm]",
                    "mechanism.half_angle_deg [deg]",
                ],
            ),
        ],
    );
}
