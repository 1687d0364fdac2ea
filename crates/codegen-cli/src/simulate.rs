//! `damper simulate SCENARIO [-o DIR]`: the main job.
//!
//! A `kind = "damper"` scenario couples the beam and the generated double bar with its
//! generator (hybrid-core), integrates it, runs the same scenario with the generator
//! disconnected for comparison, and writes into DIR:
//!
//! - `time_history.csv` (and `time_history_without_generator.csv`): time, tip displacement
//!   and velocity, crank and coupler angles and rates, amplification q1'/y', generator
//!   current and power, energies, constraint residual, cond(J^b);
//! - `summary.json`: model hash, generator version, settings, peak amplitude, equivalent
//!   damping ratios `zeta_with_generator` / `zeta_without_generator`, energy account and
//!   `energy_balance_rel_error`;
//! - `tip_displacement.svg`: the tip displacement with and without the generator.
//!
//! A `kind = "mechanism"` scenario is a plain closed-loop mechanism (see
//! `simulate_mechanism`). All files are written completely or not at all.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use hybrid_core::damper::DamperModel;
use hybrid_core::output::{OutputFile, commit_files, csv_bytes, json_bytes, plot_svg};
use hybrid_core::scenario::Scenario;
use hybrid_core::study::{Run, damping_ratio, run_scenario};
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use mbs_symbolic::runtime::System;
use serde_json::json;

/// Arguments of `damper simulate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scenario file (`kind = "damper"` or `kind = "mechanism"`).
    pub scenario: PathBuf,
    /// Output directory (default: `out/<scenario name>`).
    #[arg(short = 'o', long = "out")]
    pub out: Option<PathBuf>,
    /// No progress bar even on a terminal.
    #[arg(long)]
    pub quiet: bool,
}

/// Runs `damper simulate`.
pub fn run(args: Args) -> Result<()> {
    let text = std::fs::read_to_string(&args.scenario)
        .with_context(|| format!("cannot read {}", args.scenario.display()))?;
    let kind = text
        .parse::<toml::Table>()
        .ok()
        .and_then(|t| t.get("kind").and_then(|k| k.as_str()).map(str::to_owned))
        .unwrap_or_default();
    let stem = args
        .scenario
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "run".into());
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&stem));
    let progress = !args.quiet && std::io::stderr().is_terminal();
    match kind.as_str() {
        "mechanism" => crate::simulate_mechanism::run(&args.scenario, &out, progress),
        _ => damper(&args.scenario, &out, progress),
    }
}

fn bar(multi: &MultiProgress, label: &str, show: bool) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let pb = multi.add(ProgressBar::new(1000));
    pb.set_style(
        ProgressStyle::with_template("{prefix:>18} [{bar:40}] {percent:>3}% ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_prefix(label.to_string());
    pb
}

/// The coupled model and its runs with and without the generator.
struct Pair<M> {
    model: DamperModel<M>,
    with: Run,
    without: Option<Run>,
}

/// Both runs (with and without the generator) in parallel threads; the results do not depend
/// on the thread schedule (each run is independent and deterministic).
fn run_pair<M: System + Clone>(sc: &Scenario, mech: M, progress: bool) -> Result<Pair<M>> {
    let multi = MultiProgress::new();
    let compare = sc.spec.output.compare_without_generator;
    let (pa, pb) = (
        bar(&multi, "with generator", progress),
        bar(&multi, "without generator", progress && compare),
    );
    let (with, without) = std::thread::scope(|s| {
        let m2 = mech.clone();
        let other = compare.then(|| {
            s.spawn(move || {
                run_scenario(sc, m2, false, &mut |f| pb.set_position((f * 1000.0) as u64))
            })
        });
        let with = run_scenario(sc, mech, true, &mut |f| {
            pa.set_position((f * 1000.0) as u64)
        });
        let without = other.map(|h| h.join());
        (with, without)
    });
    let (model, with) = with?;
    let without = match without {
        None => None,
        Some(Ok(r)) => Some(r?.1),
        Some(Err(_)) => bail!("the comparison run without generator panicked"),
    };
    Ok(Pair {
        model,
        with,
        without,
    })
}

fn damper(path: &Path, out: &Path, progress: bool) -> Result<()> {
    let sc = Scenario::load(path)?;
    let model_file = mbs_symbolic::model::load(&sc.model_path)
        .map_err(|e| anyhow::anyhow!("{}", e.to_string().replace('\n', "; ")))?;
    if !out.is_dir() {
        std::fs::create_dir_all(out)
            .with_context(|| format!("cannot create the output directory {}", out.display()))?;
    }
    let resolved = model_registry::system_for(&model_file, None)?;
    if resolved.compiled.is_none() {
        eprintln!(
            "note: {} is not compiled in (hash {}); using the DAG interpreter (slower). Put it under models/ and rebuild to compile it in.",
            sc.model_path.display(),
            model_file.source.hash
        );
    }
    let backend = resolved.system.backend().as_str();
    let pair = run_pair(&sc, resolved.system, progress)?;
    report(path, out, &sc, &model_file, backend, pair)
}

/// Figures of merit and output files of a finished pair of runs.
fn report<M: System>(
    path: &Path,
    out: &Path,
    sc: &Scenario,
    model_file: &mbs_symbolic::model::Model,
    backend: &str,
    Pair {
        model,
        with,
        without,
    }: Pair<M>,
) -> Result<()> {
    let zeta_with = damping_ratio(&with.samples);
    let zeta_without = without.as_ref().and_then(|r| damping_ratio(&r.samples));
    let peak = with
        .samples
        .iter()
        .map(|s| s.tip_displacement.abs())
        .fold(0.0, f64::max);
    let e = with.state.energy;
    let f1 = model.beam.modes(1).ok().map(|m| m.frequencies_hz()[0]);
    let s0 = &with.samples[0];
    let steps = with.state.steps;
    let summary = json!({
        "scenario": path.display().to_string(),
        "model": model_file.name,
        "model_file": sc.model_path.display().to_string(),
        "model_hash": model_file.source.hash,
        "generator_version": mbs_symbolic::emit::GENERATOR_VERSION,
        "mechanism_backend": backend,
        "settings": sc.spec,
        "steps": steps,
        "wall_seconds": with.wall.as_secs_f64(),
        "steps_per_second": steps as f64 / with.wall.as_secs_f64().max(1e-12),
        "beam_first_frequency_hz": f1,
        "initial": {
            "tip_displacement": s0.tip_displacement,
            "crank_angle_deg": s0.crank_angle.to_degrees(),
            "coupler_angle_deg": s0.coupler_angle.to_degrees(),
            "amplification_rad_per_m": s0.amplification,
            "jacobian_condition": s0.jacobian_condition,
        },
        "peak_amplitude": peak,
        "zeta_with_generator": zeta_with,
        "zeta_without_generator": zeta_without,
        "energy": {
            "initial": with.initial_energy,
            "final_stored": e.total(),
            "dissipated_generator": e.dissipated_armature + e.dissipated_load,
            "dissipated_armature": e.dissipated_armature,
            "harvested_in_load": e.dissipated_load,
            "dissipated_structure": e.dissipated_structure,
            "external_work": e.external_work,
            "without_generator": without.as_ref().map(|r| json!({
                "dissipated_structure": r.state.energy.dissipated_structure,
                "final_stored": r.state.energy.total(),
            })),
        },
        "energy_balance_rel_error": with.energy_balance_rel_error,
    });
    let mut files = vec![
        OutputFile {
            path: out.join("time_history.csv"),
            bytes: csv_bytes(&with.samples).map_err(anyhow::Error::msg)?,
        },
        OutputFile {
            path: out.join("summary.json"),
            bytes: json_bytes(&summary).map_err(anyhow::Error::msg)?,
        },
    ];
    let mut series: Vec<(&str, &[hybrid_core::study::Sample])> =
        vec![("with generator", &with.samples)];
    if let Some(w) = &without {
        files.push(OutputFile {
            path: out.join("time_history_without_generator.csv"),
            bytes: csv_bytes(&w.samples).map_err(anyhow::Error::msg)?,
        });
        series.push(("generator disconnected", &w.samples));
    }
    files.push(OutputFile {
        path: out.join("tip_displacement.svg"),
        bytes: plot_svg("Beam tip displacement", &series).map_err(anyhow::Error::msg)?,
    });
    commit_files(&files).map_err(anyhow::Error::msg)?;
    let fmt_zeta = |z: Option<f64>| z.map_or("n/a".to_string(), |z| format!("{:.3} %", z * 100.0));
    println!(
        "{}: {steps} steps in {:.3} s ({backend} mechanism); zeta with generator {}, without {}; peak {:.3} mm; energy balance error {:.1e}; outputs in {}",
        path.display(),
        with.wall.as_secs_f64(),
        fmt_zeta(zeta_with),
        fmt_zeta(zeta_without),
        peak * 1e3,
        with.energy_balance_rel_error,
        out.display()
    );
    Ok(())
}
