//! Running a rigid closed-loop mechanism scenario (`kind = "mechanism"`, eqs. 14–25):
//! scenario → model → hybrid-core → observer, on the compiled-in generated code or the DAG
//! interpreter, every output row passed to an observer. (Damper and hybrid scenarios run
//! through [`crate::run_hybrid`].)

use hybrid_core::closed_loop::{
    self, AssemblyOptions, Event, OutputRow, PartitionChange, Settings, Simulator, Stats, System,
    assemble,
};

use indicatif::ProgressBar;
use mbs_symbolic::model::Model;
use mbs_symbolic::runtime::CoordinateUnit;

use crate::Error;
use crate::scenario::MechanismScenario;

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
