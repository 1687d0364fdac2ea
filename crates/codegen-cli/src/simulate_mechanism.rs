//! `damper simulate` for a plain closed-loop mechanism (`kind = "mechanism"` scenario; paper
//! section 2.2, eqs. 14–25; format in `hybrid_core::closed_loop::scenario`).
//!
//! Loads the scenario and its model, picks the backend — the compiled-in generated code
//! when the model file's content hash equals that of a bundled model, the DAG interpreter
//! otherwise (said on stderr) — assembles the initial state, integrates in independent
//! coordinates with automatic re-partitioning, and writes into the output directory:
//!
//! - `<stem>.csv`: `t`, every coordinate, every velocity (`<name>_dot`), `kinetic_energy`,
//!   `potential_energy`, `total_energy`, `constraint_residual_norm`, `cond_jv`;
//! - `<stem>_summary.json`: backend, settings, energy drift, largest constraint residual,
//!   partition changes, accepted and rejected steps, wall time, and the status.
//!
//! Each file is written to `NAME.tmp` in the same directory and renamed when complete, so
//! it exists completely or not at all. When the run stops on a singular configuration (or
//! diverges) the samples computed up to that point are still written, the summary says
//! `"status": "stopped"` with the error, and the command fails with that error (non-zero
//! exit). Errors before the integration starts (scenario, model, assembly) write nothing.

use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, anyhow};
use hybrid_core::closed_loop::scenario::{self, MechanismScenario};
use hybrid_core::closed_loop::{
    AssemblyOptions, Event, Method, OutputRow, Settings, Simulator, System, assemble,
};
use indicatif::{ProgressBar, ProgressStyle};
use mbs_symbolic::model::{self, Model};
use serde_json::{Value, json};

/// Runs a `kind = "mechanism"` scenario and writes `<stem>.csv` and `<stem>_summary.json`
/// into `out_dir` (created if missing). `progress`: show a progress bar (only honoured
/// when standard error is a terminal).
pub fn run(scenario_path: &Path, out_dir: &Path, progress: bool) -> Result<()> {
    let started = Instant::now();
    let sc = scenario::load(scenario_path).map_err(|e| anyhow!("{e}"))?;
    let model = model::load(&sc.model).map_err(|e| anyhow!("{e}"))?;
    let (sys, backend_note) = build_system(&model)?;
    eprintln!("{}: {backend_note}", sc.model.display());
    let resolved = sc
        .resolve(sys.coordinate_names())
        .map_err(|e| anyhow!("{e}"))?;
    let (q0, qd0) = assemble(
        &*sys,
        &resolved.q0,
        &resolved.fixed,
        &resolved.qd0,
        &resolved.qd_given,
        &AssemblyOptions::default(),
    )
    .with_context(|| format!("{}: initial conditions", sc.file))?;
    let settings = resolved.settings.clone();
    let mut sim = Simulator::new(&*sys, settings.clone(), &q0, &qd0)
        .with_context(|| format!("{}: cannot start the simulation", sc.file))?;

    std::fs::create_dir_all(out_dir)
        .with_context(|| format!("cannot create the output directory {}", out_dir.display()))?;
    let stem = scenario_path.file_stem().map_or_else(
        || "mechanism".to_string(),
        |s| s.to_string_lossy().into_owned(),
    );
    let csv_path = out_dir.join(format!("{stem}.csv"));
    let summary_path = out_dir.join(format!("{stem}_summary.json"));
    let csv_tmp = tmp_path(&csv_path);
    let mut csv = BufWriter::new(
        File::create(&csv_tmp).with_context(|| format!("cannot write {}", csv_tmp.display()))?,
    );
    let header = csv_header(sys.coordinate_names());
    let mut io_error: Option<std::io::Error> = None;
    if let Err(e) = writeln!(csv, "{header}") {
        io_error = Some(e);
    }

    let bar = progress_bar(progress, &settings);
    let span = settings.t_end - settings.t_start;
    let mut last_row: Option<OutputRow> = None;
    let mut rows = 0usize;
    let result = sim.run(&mut |event| match event {
        Event::Output(row) => {
            if io_error.is_none() {
                if let Err(e) = writeln!(csv, "{}", csv_line(row)) {
                    io_error = Some(e);
                }
            }
            rows += 1;
            last_row = Some(row.clone());
        }
        Event::PartitionChanged(change) => match &bar {
            Some(b) => b.println(change.to_string()),
            None => eprintln!("{change}"),
        },
        Event::Step { t } => {
            if let Some(b) = &bar {
                b.set_position(
                    (((t - settings.t_start) / span) * 1000.0).clamp(0.0, 1000.0) as u64,
                );
            }
        }
    });
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let finish = (|| -> Result<()> {
        if let Some(e) = io_error.take() {
            return Err(e).with_context(|| format!("cannot write {}", csv_tmp.display()));
        }
        csv.flush()
            .with_context(|| format!("cannot write {}", csv_tmp.display()))?;
        drop(csv);
        let summary = summary_json(
            &sc,
            &model,
            &*sys,
            &settings,
            &sim,
            &result,
            last_row.as_ref(),
            rows,
            started.elapsed().as_secs_f64(),
        );
        let text = serde_json::to_string_pretty(&summary)? + "\n";
        write_atomically(&summary_path, text.as_bytes())?;
        std::fs::rename(&csv_tmp, &csv_path).with_context(|| {
            format!(
                "cannot rename {} to {}",
                csv_tmp.display(),
                csv_path.display()
            )
        })?;
        Ok(())
    })();
    if let Err(e) = finish {
        let _ = std::fs::remove_file(&csv_tmp);
        return Err(e);
    }
    let stats = sim.stats();
    eprintln!(
        "wrote {} ({rows} rows) and {}: {} steps ({} rejected), {} partition change(s), max |h| {:.2e}",
        csv_path.display(),
        summary_path.display(),
        stats.steps_accepted,
        stats.steps_rejected,
        sim.changes().len(),
        stats.max_residual
    );
    result.with_context(|| {
        format!(
            "{}: simulation stopped (samples up to t = {} written)",
            sc.file,
            last_row.as_ref().map_or(settings.t_start, |r| r.t)
        )
    })
}

/// The backend for a model, through the one registry: the compiled-in generated code when
/// the file is byte-identical to a model under `models/` (same FNV-1a content hash), else the
/// DAG interpreter.
fn build_system(model: &Model) -> Result<(Box<dyn System>, String)> {
    let hash = model.source.hash.as_str();
    let resolved = model_registry::system_for(model, None)?;
    let note = match resolved.compiled {
        Some(c) => format!(
            "backend: generated code (compiled-in `{}`, hash {hash})",
            c.name
        ),
        None => format!("backend: DAG interpreter (model not compiled in, hash {hash})"),
    };
    Ok((resolved.system, note))
}

fn tmp_path(path: &Path) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".tmp");
    path.with_file_name(name)
}

/// Writes `bytes` to `path` through `path.tmp` and a rename.
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = tmp_path(path);
    let res = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    if res.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    res.with_context(|| format!("cannot write {}", path.display()))
}

fn progress_bar(requested: bool, settings: &Settings) -> Option<ProgressBar> {
    use std::io::IsTerminal;
    if !(requested && std::io::stderr().is_terminal()) {
        return None;
    }
    let pb = ProgressBar::new(1000);
    pb.set_style(
        ProgressStyle::with_template("simulate [{bar:40}] {percent:>3}% ETA {eta} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(format!("t_end = {} s", settings.t_end));
    Some(pb)
}

/// A CSV field: quoted when it holds a comma, a quote or a line break.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn csv_header(names: &[String]) -> String {
    let mut cols = vec!["t".to_string()];
    cols.extend(names.iter().map(|n| field(n)));
    cols.extend(names.iter().map(|n| field(&format!("{n}_dot"))));
    cols.extend(
        [
            "kinetic_energy",
            "potential_energy",
            "total_energy",
            "constraint_residual_norm",
            "cond_jv",
        ]
        .map(String::from),
    );
    cols.join(",")
}

/// A number in shortest round-trip form (scientific notation outside [1e-4, 1e15), no
/// negative zero).
fn fmt_num(out: &mut String, x: f64) {
    let x = x + 0.0;
    if x == 0.0 || (1e-4..1e15).contains(&x.abs()) {
        let _ = write!(out, "{x}");
    } else {
        let _ = write!(out, "{x:e}");
    }
}

/// A comma and a number; an empty cell when unknown or not finite.
fn num(out: &mut String, x: Option<f64>) {
    out.push(',');
    if let Some(x) = x.filter(|x| x.is_finite()) {
        fmt_num(out, x);
    }
}

fn csv_line(r: &OutputRow) -> String {
    let mut s = String::with_capacity(256);
    fmt_num(&mut s, r.t);
    for v in r.q.iter().chain(&r.qd) {
        num(&mut s, Some(*v));
    }
    num(&mut s, Some(r.kinetic_energy));
    num(&mut s, r.potential_energy);
    num(&mut s, r.total_energy());
    num(&mut s, Some(r.residual_norm));
    num(&mut s, Some(r.cond_jv));
    s
}

fn finite(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

fn named(names: &[String], values: &[f64]) -> Value {
    let map: serde_json::Map<String, Value> = names
        .iter()
        .zip(values)
        .map(|(n, v)| (n.clone(), finite(*v)))
        .collect();
    Value::Object(map)
}

fn summary_json(
    sc: &MechanismScenario,
    model: &Model,
    sys: &dyn System,
    settings: &Settings,
    sim: &Simulator<'_, dyn System>,
    result: &Result<(), hybrid_core::closed_loop::SimError>,
    last: Option<&OutputRow>,
    rows: usize,
    wall: f64,
) -> Value {
    let stats = sim.stats();
    let method = match settings.method {
        Method::Dopri5 {
            rtol,
            atol,
            initial_step,
            max_step,
        } => json!({
            "method": "dopri5", "rtol": rtol, "atol": atol,
            "initial_step": initial_step, "max_step": max_step,
        }),
        Method::Rk4 { step } => json!({ "method": "rk4", "step": step }),
    };
    let ps = &settings.partition;
    let names = sys.coordinate_names();
    let requested: Value = match &ps.independent {
        Some(idx) => json!(idx.iter().map(|&i| names[i].clone()).collect::<Vec<_>>()),
        None => json!("automatic"),
    };
    let e0 = stats.initial_energy;
    let scale = e0.map(|e| e.abs().max(stats.max_kinetic_energy));
    let final_drift = match (last.and_then(OutputRow::total_energy), e0) {
        (Some(e), Some(e0)) => finite(e - e0),
        _ => Value::Null,
    };
    let rel = match (stats.max_energy_error, scale) {
        (Some(d), Some(s)) if s > 0.0 => finite(d / s),
        _ => Value::Null,
    };
    let (last_t, last_q, last_qd) = match last {
        Some(r) => (r.t, r.q.clone(), r.qd.clone()),
        None => (settings.t_start, vec![], vec![]),
    };
    json!({
        "scenario": sc.file,
        "description": sc.description,
        "model": sc.model.display().to_string(),
        "model_name": model.name,
        "model_hash": model.source.hash,
        "backend": sys.backend().as_str(),
        "status": if result.is_ok() { "completed" } else { "stopped" },
        "error": result.as_ref().err().map(|e| e.to_string()),
        "settings": {
            "integrator": method,
            "t_start": settings.t_start,
            "t_end": settings.t_end,
            "output_step": settings.output_step,
            "projection_tol": settings.projection_tol,
            "max_steps": settings.max_steps,
            "partition": {
                "independent": requested,
                "allow_redundant": ps.allow_redundant,
                "repartition": ps.repartition,
                "switch_ratio": ps.switch_ratio,
                "max_condition": ps.max_condition,
                "singular_condition": ps.singular_condition,
                "rank_tol": ps.rank_tol,
            },
        },
        "initial_independent": sim.initial_independent(),
        "final_independent": sim.independent_names(),
        "dropped_constraint_rows": sim.dropped_rows(),
        "partition_changes": sim.changes().iter().map(|c| json!({
            "t": c.t,
            "from": c.from,
            "to": c.to,
            "cond_before": finite(c.cond_before),
            "cond_after": finite(c.cond_after),
            "log": c.to_string(),
        })).collect::<Vec<_>>(),
        "energy": {
            "initial_total": e0,
            "max_abs_drift": stats.max_energy_error,
            "max_relative_drift": rel,
            "relative_to": "max(|E(t_start)|, max kinetic energy)",
            "final_drift": final_drift,
        },
        "max_constraint_residual_norm": finite(stats.max_residual),
        "steps_accepted": stats.steps_accepted,
        "steps_rejected": stats.steps_rejected,
        "rhs_evaluations": stats.rhs_evaluations,
        "newton_iterations": stats.newton_iterations,
        "min_step": finite(stats.min_step),
        "max_step": finite(stats.max_step),
        "output_rows": rows,
        "final_time": stats.final_time,
        "final_state": { "t": last_t, "q": named(names, &last_q), "qd": named(names, &last_qd) },
        "wall_time_s": wall,
    })
}
