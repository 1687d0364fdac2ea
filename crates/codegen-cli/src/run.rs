//! Running a rigid closed-loop mechanism scenario (`kind = "mechanism"`, eqs. 14–25):
//! scenario → model → hybrid-core → observer, on the compiled-in generated code or the DAG
//! interpreter, every output row passed to an observer. (Damper and hybrid scenarios run
//! through [`crate::run_hybrid`].) The run of a loaded scenario in memory, either kind, is
//! [`simulate_in_memory`].

use hybrid_core::closed_loop::{
    self, AssemblyOptions, Event, OutputRow, PartitionChange, Settings, Simulator, Stats, System,
    assemble,
};

use indicatif::ProgressBar;
use mbs_symbolic::model::Model;
use mbs_symbolic::runtime::CoordinateUnit;

use std::time::Instant;

use hybrid_core::closed_loop::Method;

use crate::Error;
use crate::budget::{self, Estimate};
use crate::report::ReportError;
use crate::report::summary::{
    ChangeSummary, DriftSummary, FinalState, IntegratorSummary, MechanismSettings,
    MechanismSummary, PartitionSummary, Requested, json_bytes,
};
use crate::run_hybrid::InMemory;
use crate::scenario::{Loaded, MechanismScenario, OverrideRecord, Scenario};

/// What to run: a loaded scenario as `damper simulate` runs it, held in memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SimulateRequest {
    /// Run even above the limits of [`crate::budget`] (steps, rows, memory).
    pub allow_long: bool,
}

/// Runs the loaded scenario (its structure already within the budget) as `damper simulate`
/// does, in memory: the summary's bytes, the columns of the time history and of every
/// comparison run ([`crate::run_hybrid::in_memory`], [`mechanism_in_memory`]); a problem
/// found against the model names the file and the overrides the user wrote.
pub fn simulate_in_memory(req: &SimulateRequest, loaded: &Loaded) -> Result<InMemory, Error> {
    let records = loaded.applied.records();
    match &loaded.scenario {
        Scenario::Hybrid(sc) => crate::run_hybrid::in_memory(sc, req.allow_long, records),
        Scenario::Mechanism(sc) => mechanism_in_memory(sc, req.allow_long, records),
    }
    .map_err(|e| match e {
        Error::Input(d) => Error::Input(loaded.remap(d)),
        e => e,
    })
}

/// A finished (or stopped) closed-loop mechanism run.
#[derive(Debug)]
pub struct MechanismOutcome {
    /// The model's coordinate names.
    pub names: Vec<String>,
    /// What each coordinate measures (from the backend's names).
    pub units: Vec<CoordinateUnit>,
    /// The backend's name.
    pub backend: &'static str,
    /// The settings used (independent coordinates resolved).
    pub settings: Settings,
    /// Counters and extremes.
    pub stats: Stats,
    /// Every change of partition.
    pub changes: Vec<PartitionChange>,
    /// Redundant constraint rows dropped.
    pub dropped: Vec<String>,
    /// Independent coordinates at the start.
    pub initial_independent: Vec<String>,
    /// ... and at the end.
    pub final_independent: Vec<String>,
    /// The last output row.
    pub last_row: Option<OutputRow>,
    /// How the integration ended.
    pub result: Result<(), closed_loop::SimError>,
}

/// The backend for a model, through the one model registry: the compiled-in generated code
/// when the file is byte-identical to a model under `models/` (same FNV-1a content hash),
/// else the documented fallback, the DAG interpreter.
fn system(model: &Model) -> Result<(Box<dyn System>, String), Error> {
    let hash = model.source.hash.as_str();
    let resolved = crate::system_for(model, None)?;
    let note = match resolved.compiled {
        Some(c) => format!(
            "backend: generated code (compiled-in `{}`, hash {hash})",
            c.name
        ),
        None => format!("backend: DAG interpreter (model not compiled in, hash {hash})"),
    };
    Ok((resolved.system, note))
}

fn progress_bar(requested: bool, settings: &Settings) -> Option<ProgressBar> {
    let pb = crate::progress::bar(
        requested,
        1000,
        "simulate [{bar:40}] {percent:>3}% ETA {eta} {msg}",
    )?;
    pb.set_message(format!("t_end = {} s", settings.t_end));
    Some(pb)
}

/// What receives every output row of a mechanism run, with the coordinate names and units.
pub type RowObserver<'a> = dyn FnMut(&[String], &[CoordinateUnit], &OutputRow) + 'a;

/// Runs a closed-loop mechanism scenario whose model is `model`: resolves the names,
/// assembles the initial state, integrates, and passes every output row to `observer`
/// with the coordinate names (also the rows before a stop). Errors before the integration starts are returned; how
/// the integration ended is in [`MechanismOutcome::result`].
pub fn mechanism(
    sc: &MechanismScenario,
    model: &Model,
    progress: bool,
    observer: &mut RowObserver<'_>,
) -> Result<MechanismOutcome, Error> {
    let (sys, backend_note) = system(model)?;
    eprintln!("{}: {backend_note}", sc.model.display());
    let resolved = sc.resolve(sys.coordinate_names())?;
    let (q0, qd0) = assemble(
        &*sys,
        &resolved.q0,
        &resolved.fixed,
        &resolved.qd0,
        &resolved.qd_given,
        &AssemblyOptions::default(),
    )
    .map_err(|error| Error::Assembly {
        file: sc.file.clone(),
        error,
    })?;
    let settings = resolved.settings.clone();
    let mut sim =
        Simulator::new(&*sys, settings.clone(), &q0, &qd0).map_err(|error| Error::Start {
            file: sc.file.clone(),
            error,
        })?;
    // An interrupt (SIGINT, SIGTERM, Ctrl-C in Python) ends the run at its next step.
    sim.set_stop(crate::interrupt::stop_requested);
    let names = sys.coordinate_names().to_vec();
    let units = sys.coordinate_units().to_vec();
    let bar = progress_bar(progress, &settings);
    let span = settings.t_end - settings.t_start;
    let mut last_row: Option<OutputRow> = None;
    let result = sim.run(&mut |event| match event {
        Event::Output(row) => {
            observer(&names, &units, row);
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
    Ok(MechanismOutcome {
        names,
        units,
        backend: sys.backend().as_str(),
        settings,
        stats: sim.stats().clone(),
        changes: sim.changes().to_vec(),
        dropped: sim.dropped_rows().to_vec(),
        initial_independent: sim.initial_independent().to_vec(),
        final_independent: sim.independent_names(),
        last_row,
        result,
    })
}

/// Runs a closed-loop mechanism scenario within the step limit of [`crate::budget`] (unless
/// `allow_long`), every output row to `observer`; a run that stopped is the error (naming
/// the time reached). Returns the scenario as run (its step limit capped) and the outcome.
pub fn mechanism_run(
    sc: &MechanismScenario,
    model: &mbs_symbolic::model::Model,
    progress: bool,
    allow_long: bool,
    observer: &mut RowObserver<'_>,
) -> Result<(MechanismScenario, MechanismOutcome), Error> {
    let estimate = Estimate::mechanism(sc, model.dof());
    estimate.check(&sc.file, allow_long)?;
    // The adaptive step count is only estimated: the step limit is the guard that holds.
    let capped = budget::capped_max_steps(sc.settings.max_steps, allow_long);
    let was_capped = capped < sc.settings.max_steps;
    let mut sc = sc.clone();
    sc.settings.max_steps = capped;
    let mut outcome = mechanism(&sc, model, progress, &mut |names, units, row| {
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
        psd: None,
    })
}

/// The summary of a closed-loop mechanism run.
pub fn mechanism_summary(
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
