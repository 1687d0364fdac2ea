//! Running a scenario: scenario → model → hybrid-core → observer.
//!
//! - [`damper`]: the coupled beam + double bar + generator (eqs. 45–58), on the model's
//!   compiled-in generated code when the model registry has it (content hash) and the DAG
//!   interpreter otherwise; the run with the generator and, in parallel, the comparison run
//!   with it disconnected, each streaming its samples to a sink and keeping only their
//!   digest ([`crate::report::digest`]);
//! - [`mechanism`]: a rigid closed-loop mechanism (eqs. 14–25) on the compiled-in generated
//!   code or the DAG interpreter, every output row passed to an observer.

use std::io::IsTerminal;
use std::time::Duration;

use hybrid_core::closed_loop::{
    self, AssemblyOptions, Event, OutputRow, PartitionChange, Settings, Simulator, Stats, System,
    assemble,
};
use std::ops::ControlFlow;

use hybrid_core::damper::DamperModel;
use hybrid_core::study::{RunEnd, RunError, Sample, prepare, run_streaming};
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use mbs_symbolic::model::Model;

use crate::Error;
use crate::report::digest::SampleDigest;
use crate::scenario::{DamperScenario, MechanismScenario};

/// A damper run as kept in memory: the final state, the energy account and the digest of
/// its samples; the samples themselves went to the run's sink (the streamed CSV) as they
/// were taken, so memory does not grow with `t_end`.
#[derive(Clone, Debug)]
pub struct DamperRun {
    /// First sample, peak, damping ratio and the decimated plot points.
    pub digest: SampleDigest,
    /// The final state.
    pub state: RunEnd,
    /// Stored energy at t = 0.
    pub initial_energy: f64,
    /// Largest |energy balance error| / initial energy over the run.
    pub energy_balance_rel_error: f64,
    /// Wall-clock time of the integration.
    pub wall: Duration,
}

/// The runs of a damper scenario.
#[derive(Clone, Debug)]
pub struct DamperOutcome {
    /// `generated` or `interpreter`.
    pub backend: &'static str,
    /// The run with the generator.
    pub with: DamperRun,
    /// The run with the generator disconnected, when asked for.
    pub without: Option<DamperRun>,
    /// First natural frequency of the bare beam (Hz).
    pub beam_first_frequency_hz: Option<f64>,
    /// Equivalent damping ratio with the generator.
    pub zeta_with: Option<f64>,
    /// ... and without.
    pub zeta_without: Option<f64>,
    /// Largest |tip displacement| with the generator (m).
    pub peak: f64,
}

/// Where a damper run's samples go, one at a time, as they are taken (an error stops the
/// run).
pub type SampleSink<'a> = &'a mut (dyn FnMut(&Sample) -> Result<(), Error> + Send);

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

/// Runs a damper scenario whose mechanism model is `model`; `progress`: progress bars (only
/// when standard error is a terminal). The samples of the run with the generator go to
/// `with`, those of the comparison run (when the scenario asks for it) to `without`.
pub fn damper(
    sc: &DamperScenario,
    model: &Model,
    progress: bool,
    with: SampleSink<'_>,
    without: SampleSink<'_>,
) -> Result<DamperOutcome, Error> {
    let progress = progress && std::io::stderr().is_terminal();
    let resolved = model_registry::system_for(model, None)?;
    if resolved.compiled.is_none() {
        eprintln!(
            "note: {} is not compiled in (hash {}); using the DAG interpreter (slower). Put it under models/ and rebuild to compile it in.",
            sc.model_path.display(),
            model.source.hash
        );
    }
    let backend = resolved.system.backend().as_str();
    pair(
        sc,
        model,
        resolved.system,
        backend,
        progress,
        [with, without],
    )
}

/// Both runs (with and without the generator) in parallel threads; the results do not depend
/// on the thread schedule (each run is independent and deterministic).
fn pair<M: System + Clone + Send>(
    sc: &DamperScenario,
    model: &Model,
    mech: M,
    backend: &'static str,
    progress: bool,
    [with_sink, without_sink]: [SampleSink<'_>; 2],
) -> Result<DamperOutcome, Error> {
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
                stream_run(
                    sc,
                    model,
                    m2,
                    false,
                    &mut |f| pb.set_position((f * 1000.0) as u64),
                    without_sink,
                )
            })
        });
        let with = stream_run(
            sc,
            model,
            mech,
            true,
            &mut |f| pa.set_position((f * 1000.0) as u64),
            with_sink,
        );
        let without = other.map(|h| h.join());
        (with, without)
    });
    let (coupled, with) = with?;
    let without = match without {
        None => None,
        Some(Ok(r)) => Some(r?.1),
        Some(Err(_)) => return Err(Error::ComparisonPanicked),
    };
    let zeta_with = with.digest.damping_ratio();
    let zeta_without = without.as_ref().and_then(|r| r.digest.damping_ratio());
    let peak = with.digest.peak();
    let beam_first_frequency_hz = coupled.beam.modes(1).ok().map(|m| m.frequencies_hz()[0]);
    Ok(DamperOutcome {
        backend,
        with,
        without,
        beam_first_frequency_hz,
        zeta_with,
        zeta_without,
        peak,
    })
}

/// One damper run of the scenario (generator `connected` or not), its samples streamed to
/// `sink` through `hybrid_core::study::run_streaming` (the loop `run_setup` uses too): the
/// same steps, the same samples, the same energy account, bit for bit (pinned by a test
/// against `run_setup`); only a digest is kept.
fn stream_run<M: System>(
    sc: &DamperScenario,
    model: &Model,
    mechanism: M,
    connected: bool,
    progress: &mut dyn FnMut(f64),
    sink: &mut (dyn FnMut(&Sample) -> Result<(), Error> + Send),
) -> Result<(DamperModel<M>, DamperRun), Error> {
    let setup = &sc.setup;
    let run_error = |e: RunError| match e {
        RunError::Setup(e) => Error::Input(sc.diagnostic(&e).into()),
        RunError::Sim(e) => Error::Damper(e),
        RunError::Stopped => unreachable!("handled with the sink's own error"),
    };
    let mut p = prepare(setup, model, mechanism, connected).map_err(run_error)?;
    let every = setup.every.max(1) as u64;
    let steps = (setup.t_end / p.integrator.step_size()).round() as u64;
    let mut digest = SampleDigest::new(1 + steps / every + u64::from(steps % every != 0));
    let mut failed = None;
    let figures = run_streaming(
        &p.hybrid,
        &mut p.integrator,
        p.state,
        setup.t_end,
        setup.every,
        progress,
        &mut |s| {
            digest.push(s);
            match sink(s) {
                Ok(()) => ControlFlow::Continue(()),
                Err(e) => {
                    failed = Some(e);
                    ControlFlow::Break(())
                }
            }
        },
    );
    let figures = match (figures, failed) {
        (_, Some(e)) => return Err(e),
        (r, None) => r.map_err(run_error)?,
    };
    Ok((
        p.coupled,
        DamperRun {
            digest,
            state: figures.state,
            initial_energy: figures.initial_energy,
            energy_balance_rel_error: figures.energy_balance_rel_error,
            wall: figures.wall,
        },
    ))
}

/// A finished (or stopped) closed-loop mechanism run.
#[derive(Debug)]
pub struct MechanismOutcome {
    /// The model's coordinate names.
    pub names: Vec<String>,
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

fn progress_bar(requested: bool, settings: &Settings) -> Option<ProgressBar> {
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

/// Runs a closed-loop mechanism scenario whose model is `model`: resolves the names,
/// assembles the initial state, integrates, and passes every output row to `observer`
/// with the coordinate names (also the rows before a stop). Errors before the integration starts are returned; how
/// the integration ended is in [`MechanismOutcome::result`].
pub fn mechanism(
    sc: &MechanismScenario,
    model: &Model,
    progress: bool,
    observer: &mut dyn FnMut(&[String], &OutputRow),
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
    let names = sys.coordinate_names().to_vec();
    let bar = progress_bar(progress, &settings);
    let span = settings.t_end - settings.t_start;
    let mut last_row: Option<OutputRow> = None;
    let result = sim.run(&mut |event| match event {
        Event::Output(row) => {
            observer(&names, row);
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
