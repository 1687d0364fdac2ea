//! Running a scenario: scenario → model → hybrid-core → observer.
//!
//! - [`damper`]: the coupled beam + double bar + generator (eqs. 45–58), on the model's
//!   compiled-in generated code when the model registry has it (content hash) and the DAG
//!   interpreter otherwise; the run with the generator and, in parallel, the comparison runs
//!   (generator disconnected; bare beam), each streaming its samples to a sink and keeping
//!   only their digest ([`crate::report::digest`]);
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
use hybrid_core::decay::ModalFilter;
use hybrid_core::hybrid::{HybridModel, HybridState, Integrator};
use hybrid_core::study::{
    Probe, RunEnd, RunError, Sample, prepare, prepare_bare_beam, run_streaming,
};
use indicatif::{MultiProgress, ProgressBar};
use mbs_symbolic::model::Model;
use mbs_symbolic::runtime::CoordinateUnit;

use crate::Error;
use crate::report::digest::SampleDigest;
use crate::scenario::damper::Comparison;
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
    /// The comparison runs, in the scenario's order (`[output] compare`).
    pub comparisons: Vec<(Comparison, DamperRun)>,
    /// First natural frequency of the bare beam (Hz).
    pub beam_first_frequency_hz: Option<f64>,
    /// Largest |tip displacement| with the generator (m).
    pub peak: f64,
}

impl DamperOutcome {
    /// The comparison run `c`, if the scenario asked for it.
    pub fn comparison(&self, c: Comparison) -> Option<&DamperRun> {
        self.comparisons
            .iter()
            .find(|(k, _)| *k == c)
            .map(|(_, r)| r)
    }
}

/// Where a damper run's samples go, one at a time, as they are taken (an error stops the
/// run).
pub type SampleSink<'a> = &'a mut (dyn FnMut(&Sample) -> Result<(), Error> + Send);

fn bar(multi: &MultiProgress, label: &str, show: bool) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let pb = multi.add(ProgressBar::new(1000));
    pb.set_style(crate::progress::style(
        "{prefix:>22} [{bar:40}] {percent:>3}% ETA {eta}",
    ));
    pb.set_prefix(label.to_string());
    pb
}

/// Runs a damper scenario whose mechanism model is `model`; `progress`: progress bars (only
/// when standard error is a terminal). The samples of the run with the generator go to
/// `with`, those of the comparison runs (`[output] compare`, in that order) to
/// `comparisons`, one sink each.
///
/// The damping estimates read the tip displacement. To read the first mode instead, pass
/// its [`hybrid_core::decay::ModalFilter`] as the `filter` of the probe in `stream_damper` (the
/// samples' `signal` then is the modal coordinate, and every estimate follows).
///
/// # Panics
///
/// When `comparisons` does not have one sink per comparison run.
pub fn damper(
    sc: &DamperScenario,
    model: &Model,
    progress: bool,
    with: SampleSink<'_>,
    comparisons: &mut [SampleSink<'_>],
) -> Result<DamperOutcome, Error> {
    assert_eq!(
        comparisons.len(),
        sc.spec.output.compare.len(),
        "run::damper: one sink per comparison run"
    );
    let progress = progress && std::io::stderr().is_terminal();
    let resolved = crate::system_for(model, None)?;
    // A stale model (an edited bundled one) was announced by the registry.
    if resolved.compiled.is_none() && resolved.stale.is_none() {
        eprintln!(
            "note: {} is not compiled in (hash {}); using the DAG interpreter (slower). Put it under models/ and rebuild to compile it in.",
            sc.model_path.display(),
            model.source.hash
        );
    }
    let backend = resolved.system.backend().as_str();
    runs(
        sc,
        model,
        resolved.system,
        backend,
        progress,
        with,
        comparisons,
    )
}

/// The run with the generator and every comparison run, each in its own thread; the results
/// do not depend on the thread schedule (each run is independent and deterministic).
fn runs<M: System + Clone + Send>(
    sc: &DamperScenario,
    model: &Model,
    mech: M,
    backend: &'static str,
    progress: bool,
    with_sink: SampleSink<'_>,
    sinks: &mut [SampleSink<'_>],
) -> Result<DamperOutcome, Error> {
    let multi = MultiProgress::new();
    let pa = bar(&multi, "with generator", progress);
    let (with, others) = std::thread::scope(|s| {
        let handles: Vec<_> = sc
            .spec
            .output
            .compare
            .iter()
            .zip(sinks.iter_mut())
            .map(|(&c, sink)| {
                let pb = bar(&multi, c.key(), progress);
                let m2 = mech.clone();
                s.spawn(move || {
                    let progress = &mut |f: f64| pb.set_position((f * 1000.0) as u64);
                    let run = match c {
                        Comparison::GeneratorDisconnected => {
                            stream_damper(sc, model, m2, false, progress, *sink).map(|r| r.1)
                        }
                        Comparison::BareBeam => stream_bare_beam(sc, progress, *sink),
                    };
                    (c, run)
                })
            })
            .collect();
        let with = stream_damper(
            sc,
            model,
            mech,
            true,
            &mut |f| pa.set_position((f * 1000.0) as u64),
            with_sink,
        );
        let others: Vec<_> = handles.into_iter().map(|h| h.join()).collect();
        (with, others)
    });
    let (coupled, with) = with?;
    let mut comparisons = vec![];
    for r in others {
        match r {
            Ok((c, run)) => comparisons.push((c, run?)),
            Err(_) => return Err(Error::ComparisonPanicked),
        }
    }
    let peak = with.digest.peak();
    let beam_first_frequency_hz = coupled.beam.modes(1).ok().map(|m| m.frequencies_hz()[0]);
    Ok(DamperOutcome {
        backend,
        with,
        comparisons,
        beam_first_frequency_hz,
        peak,
    })
}

fn run_error(sc: &DamperScenario) -> impl Fn(RunError) -> Error + '_ {
    move |e: RunError| match e {
        RunError::Setup(e) => Error::Input(sc.diagnostic(&e).into()),
        RunError::Sim(error) => Error::Damper {
            file: sc.path.display().to_string(),
            error,
        },
        RunError::Stopped => unreachable!("handled with the sink's own error"),
    }
}

/// One damper run of the scenario (generator `connected` or not), its samples streamed to
/// `sink` through `hybrid_core::study::run_streaming` (the loop `run_setup` uses too): the
/// same steps, the same samples, the same energy account, bit for bit (pinned by a test
/// against `run_setup`); only a digest is kept.
fn stream_damper<M: System>(
    sc: &DamperScenario,
    model: &Model,
    mechanism: M,
    connected: bool,
    progress: &mut dyn FnMut(f64),
    sink: &mut (dyn FnMut(&Sample) -> Result<(), Error> + Send),
) -> Result<(DamperModel<M>, DamperRun), Error> {
    let mut p = prepare(&sc.setup, model, mechanism, connected).map_err(run_error(sc))?;
    // The first mode's decay is read through the modal filter of the linearised system's
    // first mode (with or without the generator, as this run), free of the higher modes.
    if let Err(why) = &p.filter {
        eprintln!(
            "note: {}: no modal filter ({why}); the damping is estimated from the beam point's displacement",
            sc.path.display()
        );
    }
    let probe = Probe {
        point: &p.point,
        filter: p.filter.as_ref().ok(),
    };
    let run = stream(
        sc,
        (&p.hybrid, &mut p.integrator, p.state),
        probe,
        progress,
        sink,
    )?;
    Ok((p.coupled, run))
}

/// The bare beam of the scenario (no mechanism), read at the damper's beam point.
fn stream_bare_beam(
    sc: &DamperScenario,
    progress: &mut dyn FnMut(f64),
    sink: &mut (dyn FnMut(&Sample) -> Result<(), Error> + Send),
) -> Result<DamperRun, Error> {
    let mut b = prepare_bare_beam(&sc.setup).map_err(run_error(sc))?;
    // The bare beam's first mode is fem-beam's: its decay is read through the modal filter
    // of that shape (scaled to 1 at the beam point, so the signal is the mode's share of the
    // point's displacement), free of the higher modes the initial shape holds.
    let beam = b.hybrid.beam.as_ref().expect("the bare beam has a beam");
    let filter = beam.modes(1).ok().and_then(|m| {
        let phi = m.shape(0);
        let at = b.point.value(phi);
        let phi: Vec<f64> = phi.iter().map(|p| p / at).collect();
        ModalFilter::new(&phi, beam.mass()).ok()
    });
    let probe = Probe {
        point: &b.point,
        filter: filter.as_ref(),
    };
    stream(
        sc,
        (&b.hybrid, &mut b.integrator, b.state),
        probe,
        progress,
        sink,
    )
}

/// A prepared run streamed to `sink`, keeping its digest; `probe`: where it is read (and
/// the modal filter of the damping estimate, when there is one).
fn stream(
    sc: &DamperScenario,
    (hybrid, integrator, state): (&HybridModel, &mut Integrator, HybridState),
    probe: Probe<'_>,
    progress: &mut dyn FnMut(f64),
    sink: &mut (dyn FnMut(&Sample) -> Result<(), Error> + Send),
) -> Result<DamperRun, Error> {
    let setup = &sc.setup;
    let every = setup.every.max(1) as u64;
    let steps = (setup.t_end / integrator.step_size()).round() as u64;
    let mut digest = SampleDigest::new(1 + steps / every + u64::from(steps % every != 0));
    let mut failed = None;
    let figures = run_streaming(
        hybrid,
        integrator,
        state,
        probe,
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
        (r, None) => r.map_err(run_error(sc))?,
    };
    Ok(DamperRun {
        digest,
        state: figures.state,
        initial_energy: figures.initial_energy,
        energy_balance_rel_error: figures.energy_balance_rel_error,
        wall: figures.wall,
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
