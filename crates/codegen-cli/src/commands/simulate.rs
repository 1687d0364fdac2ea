//! `damper simulate SCENARIO [-o DIR]`: the main job.
//!
//! A `kind = "damper"` scenario is a preset of the hybrid scenario (the loader rewrites it,
//! [`crate::scenario::preset`]); it and every `kind = "hybrid"` scenario run through
//! [`crate::run_hybrid`]: the system as described and the comparison runs of `[output]
//! compare` (`generator_disconnected`: every generator's circuit open, the mechanism and
//! rotor inertia still attached; `bare_beam`: the beam alone, read at the attachments'
//! points), writing `time_history.csv` and `time_history_<comparison>.csv` (entity-prefixed
//! columns, units in every header: [`crate::report::hybrid::Columns`]), `summary.json`
//! ([`crate::report::hybrid::HybridSummary`], with a `comparisons` block per comparison
//! run), `beam_displacement.svg` and `damping_vs_amplitude.svg`.
//!
//! A `kind = "mechanism"` scenario is a plain closed-loop mechanism (paper section 2.2,
//! eqs. 14–25): it writes `<stem>.csv` (`t`, every coordinate, every velocity
//! `<name>_dot`, `kinetic_energy`, `potential_energy`, `total_energy`,
//! `constraint_residual_norm`, `cond_jv`, units in brackets), `<stem>_summary.json` and
//! `<stem>.svg` (the coordinates against time, at most 20,000 rows plotted) (backend, settings,
//! energy drift, largest constraint residual, partition changes, steps, wall time, status).
//! When such a run stops (a singular configuration, a step size too small, the step limit)
//! nothing is written, as for every kind: the command fails with that error, naming the
//! scenario file and the time reached.
//!
//! The CSV time histories are streamed row by row to temporary files next to their final
//! names while the runs go ([`crate::report::stream`]); a run keeps only running figures
//! and its plot points decimated to at most 20,000 a series ([`crate::report::digest`]),
//! so memory does not grow with `t_end`. All
//! files of a run are committed together by the one atomic writer, or none; a run that
//! fails (or errors before the integration starts) leaves no file, no temporary file and
//! no output directory it created.

use std::path::{Path, PathBuf};
use std::time::Instant;

use hybrid_core::closed_loop::Method;

use crate::Error;
use crate::budget::{self, Estimate};
use crate::report::csv::MechanismCsv;
use crate::report::plot::plot_series_svg;
use crate::report::summary::{
    ChangeSummary, DriftSummary, FinalState, IntegratorSummary, MechanismSettings,
    MechanismSummary, PartitionSummary, Requested, json_bytes,
};
use crate::report::{OutputFile, OutputLock, ReportError, StreamFile, commit};
use crate::run::{self, MechanismOutcome};
use crate::scenario::{self, MechanismScenario, Override, OverrideRecord, Scenario};

/// Arguments of `damper simulate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scenario file (`kind = "damper"`, `"hybrid"` or `"mechanism"`).
    pub scenario: PathBuf,
    /// Output directory (default: `out/<scenario name>`).
    #[arg(short = 'o', long = "out")]
    pub out: Option<PathBuf>,
    /// No progress bar even on a terminal.
    #[arg(long)]
    pub quiet: bool,
    /// Run even when the estimated steps, output rows or memory are above the limits
    /// (`codegen_cli::budget`: 2e7 steps, 2e6 rows, 1 GiB).
    #[arg(long)]
    pub allow_long: bool,
    /// Override a field of the scenario file: `--set PATH=VALUE` (repeatable, applied in
    /// order), PATH with dots and indices (`mechanism.half_angle_deg`,
    /// `beam.segment[0].elements`), VALUE a TOML value (a bare word is a string).
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub set: Vec<Override>,
}

/// Runs `damper simulate`.
pub fn run(args: Args) -> Result<(), Error> {
    let started = Instant::now();
    let loaded = scenario::load_with(&args.scenario, &args.set)?;
    crate::budget::structure(
        &loaded.scenario,
        &args.scenario.display().to_string(),
        args.allow_long,
    )?;
    let overrides = loaded.applied.records();
    let stem = args
        .scenario
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned());
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(stem.clone().unwrap_or_else(|| "run".into())));
    let progress = !args.quiet;
    check_out_dir(&out)?;
    // One run at a time into a directory; the files a killed run left are removed here.
    let _lock = OutputLock::acquire(&out).map_err(ReportError::from)?;
    // Problems found later (checks against the model) name the `--set` they come from.
    let remap = |e: Error| match e {
        Error::Input(d) => Error::Input(loaded.remap(d)),
        e => e,
    };
    match &loaded.scenario {
        Scenario::Mechanism(sc) => {
            let stem = stem.unwrap_or_else(|| "mechanism".into());
            mechanism(
                sc,
                &out,
                &stem,
                progress,
                started,
                args.allow_long,
                overrides,
            )
        }
        Scenario::Hybrid(sc) => {
            crate::run_hybrid::simulate(sc, &out, progress, args.allow_long, overrides)
        }
    }
    .map_err(remap)
}

/// Checks before any work that the output directory can be used: it is a directory or does
/// not exist yet (it is created by the commit, when the run has its outputs).
fn check_out_dir(out: &Path) -> Result<(), Error> {
    match std::fs::metadata(out) {
        Ok(m) if !m.is_dir() => Err(Error::Usage(format!(
            "output directory {} is not a directory",
            out.display()
        ))),
        _ => Ok(()),
    }
}

/// A CSV row that could not be written: the file named when it is an I/O error.
fn csv_error(path: &Path, e: ::csv::Error) -> Error {
    crate::report::csv_error(path, e).into()
}

fn mechanism(
    sc: &MechanismScenario,
    out: &Path,
    stem: &str,
    progress: bool,
    started: Instant,
    allow_long: bool,
    overrides: Vec<OverrideRecord>,
) -> Result<(), Error> {
    let model = mbs_symbolic::model::load(&sc.model)?;
    let csv_path = out.join(format!("{stem}.csv"));
    let summary_path = out.join(format!("{stem}_summary.json"));
    // The rows stream to the file as the run goes; the header needs the names, so the
    // CSV starts with the first row.
    let mut stream = Some(StreamFile::create(&csv_path).map_err(ReportError::from)?);
    let mut csv: Option<MechanismCsv<StreamFile>> = None;
    let mut csv_failed: Option<::csv::Error> = None;
    let mut plotted = Thinned::default();
    // A run that stopped commits nothing: the streamed CSV's temporary file is removed
    // when its stream is dropped.
    let (sc, outcome) = mechanism_run(
        sc,
        &model,
        progress,
        allow_long,
        &mut |names, units, row| {
            plotted.push(row.t, &row.q);
            if csv_failed.is_some() {
                return;
            }
            let pushed = match (&mut csv, stream.take()) {
                (Some(w), _) => w.push(row),
                (None, Some(s)) => {
                    MechanismCsv::to_writer(names, units, s).and_then(|w| csv.insert(w).push(row))
                }
                (None, None) => Ok(()), // the header failed: reported below
            };
            if let Err(e) = pushed {
                csv_failed = Some(e);
            }
        },
    )?;
    let sc = &sc;
    if let Some(e) = csv_failed {
        return Err(csv_error(&csv_path, e));
    }
    let csv = match (csv, stream) {
        (Some(w), _) => w,
        (None, Some(s)) => MechanismCsv::to_writer(&outcome.names, &outcome.units, s)
            .map_err(|e| csv_error(&csv_path, e))?,
        (None, None) => unreachable!("the stream is in the CSV or still here"),
    };
    let rows = csv.rows();
    let summary = mechanism_summary(
        sc,
        &model,
        &outcome,
        rows,
        started.elapsed().as_secs_f64(),
        overrides,
    );
    let stream = csv.into_inner().map_err(|e| csv_error(&csv_path, e))?;
    let labels: Vec<String> = outcome
        .names
        .iter()
        .zip(&outcome.units)
        .map(|(n, u)| format!("{n} [{}]", u.symbol()))
        .collect();
    let lines: Vec<Vec<(f64, f64)>> = (0..outcome.names.len())
        .map(|c| plotted.rows.iter().map(|(t, q)| (*t, q[c])).collect())
        .collect();
    let series: Vec<(&str, &[(f64, f64)])> = labels
        .iter()
        .zip(&lines)
        .map(|(l, p)| (l.as_str(), &p[..]))
        .collect();
    let title = format!(
        "Coordinates: {}",
        sc.description.as_deref().unwrap_or(&model.name)
    );
    let files = vec![
        OutputFile {
            path: summary_path.clone(),
            bytes: json_bytes(&summary).map_err(ReportError::from)?,
        },
        OutputFile {
            path: out.join(format!("{stem}.svg")),
            bytes: plot_series_svg(&title, "coordinate [rad or m]", &series)
                .map_err(ReportError::from)?,
        },
    ];
    commit(vec![stream], &files).map_err(ReportError::from)?;
    let stats = &outcome.stats;
    eprintln!(
        "wrote {} ({rows} rows) and {}: {} steps ({} rejected), {} partition change(s), max |h| {:.2e}",
        csv_path.display(),
        summary_path.display(),
        stats.steps_accepted,
        stats.steps_rejected,
        outcome.changes.len(),
        stats.max_residual
    );
    Ok(())
}

/// Runs a closed-loop mechanism scenario within the step limit of [`crate::budget`] (unless
/// `allow_long`), every output row to `observer`; a run that stopped is the error (naming
/// the time reached). Returns the scenario as run (its step limit capped) and the outcome.
fn mechanism_run(
    sc: &MechanismScenario,
    model: &mbs_symbolic::model::Model,
    progress: bool,
    allow_long: bool,
    observer: &mut run::RowObserver<'_>,
) -> Result<(MechanismScenario, MechanismOutcome), Error> {
    let estimate = Estimate::mechanism(sc, model.dof());
    estimate.check(&sc.file, allow_long)?;
    // The adaptive step count is only estimated: the step limit is the guard that holds.
    let capped = budget::capped_max_steps(sc.settings.max_steps, allow_long);
    let was_capped = capped < sc.settings.max_steps;
    let mut sc = sc.clone();
    sc.settings.max_steps = capped;
    let mut outcome = run::mechanism(&sc, model, progress, &mut |names, units, row| {
        if !crate::interrupt::stop_requested() {
            observer(names, units, row)
        }
    })?;
    if crate::interrupt::stop_requested() {
        return Err(Error::Interrupted);
    }
    if let Err(error) = std::mem::replace(&mut outcome.result, Ok(())) {
        let t = outcome
            .last_row
            .as_ref()
            .map_or(outcome.settings.t_start, |r| r.t);
        return Err(match error {
            hybrid_core::closed_loop::SimError::TooManySteps { .. } if was_capped => {
                Error::TooLong(format!(
                    "{}: simulation stopped at t = {t} (nothing written): {error}, above the estimate ({estimate}); pass --allow-long to lift the limit of {:.0e} steps",
                    sc.file,
                    budget::MAX_STEPS
                ))
            }
            error => Error::Stopped {
                file: sc.file.clone(),
                t,
                error,
            },
        });
    }
    Ok((sc, outcome))
}

/// A closed-loop mechanism scenario run as `damper simulate` runs it, held in memory (no file
/// written, no plot drawn): `<stem>_summary.json` byte for byte and the columns of
/// `<stem>.csv` ([`crate::report::csv::mechanism_header`]). [`Error::Interrupted`] when
/// [`crate::interrupt::StopToken::stop`] is called during the run.
pub fn mechanism_in_memory(
    sc: &MechanismScenario,
    allow_long: bool,
    overrides: Vec<OverrideRecord>,
) -> Result<crate::run_hybrid::InMemory, Error> {
    use crate::report::rows::{ColumnRows, RowSink};
    let started = Instant::now();
    let model = mbs_symbolic::model::load(&sc.model)?;
    let mut rows: Option<ColumnRows> = None;
    let mut cells = vec![];
    let (sc, outcome) = mechanism_run(sc, &model, false, allow_long, &mut |names, units, row| {
        let sink = rows.get_or_insert_with(|| {
            ColumnRows::new(&crate::report::csv::mechanism_header(names, units))
        });
        crate::report::csv::mechanism_cells(row, &mut cells);
        let _ = sink.write_row(&cells);
    })?;
    let rows = rows.unwrap_or_else(|| {
        ColumnRows::new(&crate::report::csv::mechanism_header(
            &outcome.names,
            &outcome.units,
        ))
    });
    let summary = mechanism_summary(
        &sc,
        &model,
        &outcome,
        rows.rows() as usize,
        started.elapsed().as_secs_f64(),
        overrides,
    );
    Ok(crate::run_hybrid::InMemory {
        summary: json_bytes(&summary).map_err(ReportError::from)?,
        rows,
        comparisons: vec![],
    })
}

/// Most rows a mechanism plot keeps.
const MAX_PLOT_ROWS: usize = 20_000;

/// A uniform subsample of the output rows for the plot, bounded by [`MAX_PLOT_ROWS`]: every
/// `stride`-th row, the stride doubled (and every other kept row dropped) when full.
#[derive(Default)]
struct Thinned {
    rows: Vec<(f64, Vec<f64>)>,
    stride: usize,
    seen: usize,
}

impl Thinned {
    fn push(&mut self, t: f64, q: &[f64]) {
        self.stride = self.stride.max(1);
        if self.seen % self.stride == 0 {
            if self.rows.len() == MAX_PLOT_ROWS {
                let mut k = 0;
                self.rows.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
                self.stride *= 2;
            }
            if self.seen % self.stride == 0 {
                self.rows.push((t, q.to_vec()));
            }
        }
        self.seen += 1;
    }
}

/// The summary of a closed-loop mechanism run.
fn mechanism_summary(
    sc: &MechanismScenario,
    model: &mbs_symbolic::model::Model,
    o: &MechanismOutcome,
    rows: usize,
    wall: f64,
    overrides: Vec<OverrideRecord>,
) -> MechanismSummary {
    let (stats, settings, names) = (&o.stats, &o.settings, &o.names);
    let integrator = match settings.method {
        Method::Dopri5 {
            rtol,
            atol,
            initial_step,
            max_step,
        } => IntegratorSummary::Dopri5 {
            rtol,
            atol,
            initial_step,
            max_step,
        },
        Method::Rk4 { step } => IntegratorSummary::Rk4 { step },
    };
    let ps = &settings.partition;
    let independent = match &ps.independent {
        Some(idx) => Requested::Names(idx.iter().map(|&i| names[i].clone()).collect()),
        None => Requested::Automatic("automatic"),
    };
    let e0 = stats.initial_energy;
    let scale = e0.map(|e| e.abs().max(stats.max_kinetic_energy));
    let final_drift = match (o.last_row.as_ref().and_then(|r| r.total_energy()), e0) {
        (Some(e), Some(e0)) => Some(e - e0),
        _ => None,
    };
    let max_relative_drift = match (stats.max_energy_error, scale) {
        (Some(d), Some(s)) if s > 0.0 => Some(d / s),
        // No energy at all (no gravity, at rest): nothing drifted; 0/0 is not reported.
        (Some(0.0), Some(_)) => Some(0.0),
        _ => None,
    };
    let named = |values: &[f64]| names.iter().cloned().zip(values.iter().copied()).collect();
    let final_state = match &o.last_row {
        Some(r) => FinalState {
            t: r.t,
            q: named(&r.q),
            qd: named(&r.qd),
        },
        None => FinalState {
            t: settings.t_start,
            q: Default::default(),
            qd: Default::default(),
        },
    };
    MechanismSummary {
        scenario: sc.file.clone(),
        overrides,
        description: sc.description.clone(),
        model: sc.model.display().to_string(),
        model_name: model.name.clone(),
        model_hash: model.source.hash.clone(),
        backend: o.backend,
        status: if o.result.is_ok() {
            "completed"
        } else {
            "stopped"
        },
        error: o.result.as_ref().err().map(|e| e.to_string()),
        settings: MechanismSettings {
            integrator,
            t_start: settings.t_start,
            t_end: settings.t_end,
            output_step: settings.output_step,
            projection_tol: settings.projection_tol,
            max_steps: settings.max_steps,
            partition: PartitionSummary {
                independent,
                allow_redundant: ps.allow_redundant,
                repartition: ps.repartition,
                switch_ratio: ps.switch_ratio,
                max_condition: ps.max_condition,
                singular_condition: ps.singular_condition,
                rank_tol: ps.rank_tol,
            },
        },
        initial_independent: o.initial_independent.clone(),
        final_independent: o.final_independent.clone(),
        dropped_constraint_rows: o.dropped.clone(),
        partition_changes: o
            .changes
            .iter()
            .map(|c| ChangeSummary {
                t: c.t,
                from: c.from.clone(),
                to: c.to.clone(),
                cond_before: c.cond_before,
                cond_after: c.cond_after,
                log: c.to_string(),
            })
            .collect(),
        energy: DriftSummary {
            initial_total: e0,
            max_abs_drift: stats.max_energy_error,
            max_relative_drift,
            relative_to: "max(|E(t_start)|, max kinetic energy)",
            final_drift,
        },
        max_constraint_residual_norm: stats.max_residual,
        steps_accepted: stats.steps_accepted,
        steps_rejected: stats.steps_rejected,
        rhs_evaluations: stats.rhs_evaluations,
        newton_iterations: stats.newton_iterations,
        min_step: stats.min_step,
        max_step: stats.max_step,
        output_rows: rows,
        final_time: stats.final_time,
        final_state,
        wall_time_s: wall,
    }
}
