//! Running a hybrid scenario (`kind = "hybrid"`): scenario → models → `hybrid_core::hybrid`
//! → rows and figures → files.
//!
//! `damper simulate scenario.toml -o DIR` writes into DIR (all together, or nothing):
//!
//! - `time_history.csv`: the columns of [`crate::report::hybrid`] (mechanism coordinates,
//!   rates and cond(J_d), beam point displacements and velocities, amplifications dq/dw
//!   (and speed ratios where they differ from them),
//!   generator currents, powers and harvested energies, excitation values and work, the
//!   energy account, constraint residuals), a row every `[output] every` steps;
//! - `summary.json` ([`HybridSummary`]);
//! - `beam_displacement.svg`: the displacement of every attached beam point (only when there
//!   are attachments), and of the first one in every comparison run;
//! - per `[output] compare` entry, `time_history_<key>.csv` of that comparison run (the
//!   system with every generator disconnected, or the bare beam read at the attachments'
//!   beam points as probes) and its block in the summary's `comparisons`;
//! - `deformed_shape.svg` (a `[structure]` with `elements` and an attachment): the
//!   structure at the output step of the largest displacement of the first attachment's
//!   point, magnified, over the undeformed structure ([`crate::report::shape`]);
//! - `damping_vs_amplitude.svg` (free decay with comparisons): the damping ratio of each
//!   cycle against its amplitude, one series per run;
//! - `random_rms.svg` (under random excitation): the beam points' RMS against time over
//!   windows of 1/100 of the run, the stationary RMS and where the stationary part starts;
//! - `random_psd.csv` and `random_psd.svg` (under random excitation, a stationary part of
//!   at least 16 averages): the response PSD of every output of the summary's `random`
//!   block, a Welch estimate from every step of the stationary part beside the linear
//!   prediction ([`crate::report::random_psd`]).
//!
//! Rows go through a [`RowSink`] into a [`StreamFile`] (`<name>.tmp-<pid>`, or written
//! directly to a fifo or device) while the run goes, and are committed with the other files
//! by the one writer at the end; a run that fails leaves nothing. What the summary and the
//! plot need is kept row by row in memory independent of `t_end` (running peaks and sums,
//! the online decay estimate, the plot's min/max decimation: [`crate::report::digest`]).

use crate::report::random_psd::{RandomPsd, Welch, segment_length};
use crate::report::random_run::{
    BATCHES, BatchStats, GeneratorEstimate, RandomRunReport, RealisationReport, RmsEstimate,
    RmsHistory, stationary_start,
};
use std::collections::BTreeMap;
use std::path::Path;

use hybrid_core::decay::DecayTracker;
use hybrid_core::hybrid::{
    BeamPoint, HybridModel, HybridState, Integrator, Linearization, RunError, RunOptions, Stored,
    run_observed,
};
use indicatif::ProgressBar;

use crate::Error;
use crate::budget::Estimate;
use crate::report::digest::Decimator;
use crate::report::hybrid::{
    AttachmentReport, Columns, ComparisonReport, EnergySplit, ExcitationReport, GeneratorReport,
    HybridEnergy, HybridSummary, MechanismReport, PointReport, RepartitionReport, amplifications,
};
use crate::report::pipe::PipedRows;
use crate::report::plot::{plot_damping_vs_amplitude_svg, plot_displacements_svg, tick_label};
use crate::report::rows::{ColumnRows, CsvRows, RowSink};
use crate::report::steady_power::SteadyPowerTracker;
use crate::report::summary::json_bytes;
use crate::report::{OutputFile, ReportError, StreamFile, commit, csv_error};
use crate::scenario::OverrideRecord;
use crate::scenario::{Comparison, HybridScenario};
use crate::setup::{Built, comparison};

fn progress_bar(show: bool) -> ProgressBar {
    crate::progress::bar_or_hidden(show, 1000, "simulate [{bar:40}] {percent:>3}% ETA {eta}")
}

/// What the summary and the plot need of the output rows, in memory independent of the
/// number of rows (the rows themselves are streamed to the CSV).
struct Tracks {
    /// `(t, w)` of every attachment, decimated for the plot.
    w: Vec<Decimator<(f64, f64)>>,
    /// Largest |w| of every attachment.
    peak: Vec<f64>,
    /// Largest |w| of every attachment from `final_from` on.
    final_amplitude: Vec<f64>,
    /// The start of the last tenth of the run (s).
    final_from: f64,
    /// Sum of squared generator joint speeds and beam point speeds, per attachment.
    speeds: Vec<(f64, f64)>,
    max_condition: Vec<f64>,
    max_residual: Vec<f64>,
    peak_current: Vec<f64>,
    /// Largest |u| and largest |u| from `final_from` on of every node reading and output
    /// point (the summary's `points`).
    read: Vec<(f64, f64)>,
}

/// A finished hybrid run as kept in memory: its summary and the displacement of every
/// attached beam point, decimated for the plot (memory independent of `t_end`).
pub struct HybridRun<'a> {
    /// `summary.json`.
    pub summary: HybridSummary<'a>,
    /// `(t, w)` of every attachment at the output steps, min/max decimated to at most
    /// [`crate::report::digest::MAX_PLOT_POINTS`] points ([`Decimator`]).
    pub displacements: Vec<Vec<(f64, f64)>>,
    /// Under random excitation, the response spectra of the stationary part beside the
    /// linear prediction (`random_psd.csv`), when the part holds enough samples.
    pub psd: Option<RandomPsd>,
    /// On a structure with elements (`deformed_shape.svg`), `(t, q)`: the structure's
    /// coordinates at the output step of the largest displacement of the first attachment.
    pub deformed: Option<(f64, Vec<f64>)>,
}

/// Where the rows of a hybrid run go: the columns and a row sink.
pub type Rows<'r> = (&'r mut Columns, &'r mut dyn RowSink);

/// Every run of a hybrid scenario: the run as described, then each comparison run of
/// `[output] compare`, each one's rows going to the sink `open` makes for it (`None`: the run
/// as described) under its columns' header; `fail` names the destination in an error of
/// that run's sink. Returns the runs (the comparisons with their key) and their sinks, in
/// that order.
fn runs<'a, S: RowSink>(
    sc: &'a HybridScenario,
    built: &Built,
    overrides: Vec<OverrideRecord>,
    progress: bool,
    open: &mut Open<'_, S>,
    fail: &dyn Fn(Option<Comparison>, Error) -> Error,
) -> Result<Runs<'a, S>, Error> {
    let file = sc.path.display().to_string();
    let model = &built.model;
    let mut columns = Columns::new(model, &built.state)
        .with_model_elements(model, &built.models)
        .with_points(&built.points);
    let mut sink = open(None, columns.header())?;
    let run = evaluate(
        sc,
        built,
        &[],
        Some((&mut columns, &mut sink)),
        overrides,
        progress,
    )
    .map_err(|e| fail(None, e))?;
    let mut sinks = vec![sink];
    let mut compared = vec![];
    for &c in &sc.compare {
        let Some((variant, probes)) = comparison(&file, built, c)? else {
            continue;
        };
        let mut columns = Columns::new(&variant.model, &variant.state)
            .with_probes(&variant.model, &probes)
            .with_model_elements(&variant.model, &variant.models)
            .with_points(&variant.points);
        let mut sink = open(Some(c), columns.header())?;
        let r = evaluate(
            sc,
            &variant,
            &probes,
            Some((&mut columns, &mut sink)),
            vec![],
            progress,
        )
        .map_err(|e| fail(Some(c), e))?;
        sinks.push(sink);
        compared.push((c, r));
    }
    Ok(Runs {
        run,
        compared,
        sinks,
    })
}

/// What opens the row sink of a run (`None`: the run as described) under its header.
type Open<'o, S> = dyn FnMut(Option<Comparison>, &[String]) -> Result<S, Error> + 'o;

/// What [`runs`] gives: the run as described, the comparison runs, every run's sink.
struct Runs<'a, S> {
    run: HybridRun<'a>,
    compared: Vec<(Comparison, HybridRun<'a>)>,
    sinks: Vec<S>,
}

impl<'a, S> Runs<'a, S> {
    /// The run as described with every comparison run's summary in its `comparisons`
    /// block, and the sinks (the run's first); `each` sees every comparison run before.
    fn fold(self, mut each: impl FnMut(Comparison, &HybridRun<'a>)) -> (HybridRun<'a>, Vec<S>) {
        let Runs {
            mut run,
            compared,
            sinks,
        } = self;
        for (c, r) in compared {
            each(c, &r);
            run.summary
                .comparisons
                .insert(c.key(), ComparisonReport::of(c.legend(), r.summary));
        }
        (run, sinks)
    }
}

/// The runs of a hybrid scenario held in memory, no file written ([`in_memory`]).
#[derive(Debug)]
pub struct InMemory {
    /// `summary.json`, byte for byte as `damper simulate` writes it (its `comparisons`
    /// block included).
    pub summary: Vec<u8>,
    /// The columns of `time_history.csv`.
    pub rows: ColumnRows,
    /// Per comparison run of `[output] compare`: its key and the columns of
    /// `time_history_<key>.csv`.
    pub comparisons: Vec<(&'static str, ColumnRows)>,
    /// Under random excitation, the table of `random_psd.csv` (the response spectra beside
    /// the linear prediction), when the stationary part is long enough.
    pub psd: Option<crate::report::rows::Table>,
}

/// Runs a hybrid scenario as `damper simulate` does, its time histories kept in memory
/// ([`ColumnRows`], the same header as the CSVs) and its summary as `summary.json` holds it;
/// no file is written and no plot drawn. Above the limits of [`crate::budget`] unless
/// `allow_long`; [`Error::Interrupted`] when [`crate::interrupt::StopToken::stop`] is called
/// during the runs.
pub fn in_memory(
    sc: &HybridScenario,
    allow_long: bool,
    overrides: Vec<OverrideRecord>,
) -> Result<InMemory, Error> {
    let file = sc.path.display().to_string();
    let built = crate::setup::build(sc)?;
    let columns = Columns::new(&built.model, &built.state).with_points(&built.points);
    Estimate::hybrid(sc, columns.header().len(), built.model.attachments.len())
        .check(&file, allow_long)?;
    let mut keys: Vec<&'static str> = vec![];
    let (run, sinks) = runs(
        sc,
        &built,
        overrides,
        false,
        &mut |_, header| Ok(ColumnRows::new(header)),
        &|_, e| e,
    )?
    .fold(|c, _| keys.push(c.key()));
    let mut sinks = sinks.into_iter();
    let rows = sinks.next().expect("the run as described has its rows");
    Ok(InMemory {
        summary: json_bytes(&run.summary).map_err(ReportError::from)?,
        rows,
        comparisons: keys.into_iter().zip(sinks).collect(),
        psd: run.psd.as_ref().map(RandomPsd::table),
    })
}

/// Runs `damper simulate` on a hybrid scenario and writes its files into `out`;
/// `overrides`: the `--set` options applied, recorded in the summary.
pub fn simulate(
    sc: &HybridScenario,
    out: &Path,
    progress: bool,
    allow_long: bool,
    overrides: Vec<OverrideRecord>,
) -> Result<(), Error> {
    let file = sc.path.display().to_string();
    let built = crate::setup::build(sc)?;
    let model = &built.model;
    let columns = Columns::new(model, &built.state)
        .with_model_elements(model, &built.models)
        .with_points(&built.points);
    // The run as described and each comparison run.
    Estimate::hybrid(sc, columns.header().len(), model.attachments.len())
        .check(&file, allow_long)?;
    // The time histories stream to `<name>.tmp-<pid>` as the runs go and are committed with
    // the other files at the end (or removed when a run fails): memory stays flat.
    let path_of = |c: Option<Comparison>| match c {
        None => out.join("time_history.csv"),
        Some(c) => out.join(format!("time_history_{}.csv", c.key())),
    };
    let cycles = |d: &Option<hybrid_core::decay::DecayEstimate>| -> Vec<(f64, f64)> {
        d.as_ref()
            .map(|d| d.cycles().iter().map(|c| (c.amplitude, c.zeta)).collect())
            .unwrap_or_default()
    };
    let mut compared: Vec<Comparison> = vec![];
    let mut damping_series: Vec<(&str, Vec<(f64, f64)>)> = vec![];
    let mut comparison_lines: Vec<(String, Vec<(f64, f64)>)> = vec![];
    let (run, mut sinks) = runs(
        sc,
        &built,
        overrides,
        progress,
        &mut |c, header| {
            let path = path_of(c);
            let stream = StreamFile::create(&path).map_err(ReportError::from)?;
            let csv = CsvRows::new(stream, header).map_err(|e| csv_error(&path, e))?;
            Ok(PipedRows::new(csv, header.len()))
        },
        // The only CSV error of `evaluate` is its row sink's: this file (a full disk).
        &|c, e| match e {
            Error::Report(ReportError::Csv(e)) => csv_error(&path_of(c), e).into(),
            e => e,
        },
    )?
    .fold(|c, r| {
        compared.push(c);
        damping_series.push((c.legend(), cycles(&r.summary.decay)));
        if let (Some(a), Some(w)) = (r.summary.attachments.first(), r.displacements.first()) {
            comparison_lines.push((format!("{} ({})", a.name, c.legend()), w.clone()));
        }
    });
    damping_series.insert(0, ("as described", cycles(&run.summary.decay)));
    // The rows' threads write their last rows while the summary and the plots are made.
    sinks.iter_mut().for_each(PipedRows::close);
    let summary = &run.summary;
    if let Some(w) = summary.random.as_ref().and_then(|r| r.warning.as_ref()) {
        eprintln!("{file}: warning: {w}");
    }
    let reduction = summary
        .structure
        .as_ref()
        .and_then(|s| s.reduction.as_ref());
    if let Some(w) = reduction.and_then(|r| r.warning.as_ref()) {
        eprintln!("{file}: warning: {w}");
    }
    let na = model.attachments.len();
    let mut files = vec![OutputFile {
        path: out.join("summary.json"),
        bytes: json_bytes(summary).map_err(ReportError::from)?,
    }];
    if na > 0 {
        let lines: Vec<(&str, &[(f64, f64)])> = model
            .attachments
            .iter()
            .zip(&run.displacements)
            .map(|(a, w)| (a.name.as_str(), &w[..]))
            .chain(comparison_lines.iter().map(|(l, w)| (l.as_str(), &w[..])))
            .collect();
        files.push(OutputFile {
            path: out.join("beam_displacement.svg"),
            bytes: plot_displacements_svg(
                &format!("Beam point displacements: {}", sc.title()),
                "displacement [mm]",
                &lines,
            )
            .map_err(ReportError::from)?,
        });
    }
    if let (Some(drawing), Some((t, q))) = (
        sc.structure.as_ref().and_then(|s| s.drawing.as_ref()),
        &run.deformed,
    ) {
        let translations = model
            .structure
            .as_ref()
            .map_or_else(Vec::new, |st| crate::linear::node_translations(st, q));
        let svg = crate::report::shape::deformed_shape(sc, drawing, *t, &translations)
            .map_err(ReportError::from)?;
        files.push(OutputFile {
            path: out.join("deformed_shape.svg"),
            bytes: svg,
        });
    }
    if let Some(random) = &summary.random {
        files.extend(random_rms_plot(out, sc, random)?);
    }
    if let Some(psd) = &run.psd {
        files.push(OutputFile {
            path: out.join(psd.report.file),
            bytes: psd
                .table()
                .csv(&|x| crate::report::csv::cell(Some(x)))
                .map_err(|e| csv_error(&out.join(psd.report.file), e))?,
        });
        files.extend(random_psd_plot(out, sc, psd)?);
    }
    if summary.decay.is_some() && !summary.comparisons.is_empty() {
        let series: Vec<(&str, &[(f64, f64)])> =
            damping_series.iter().map(|(l, p)| (*l, &p[..])).collect();
        files.push(OutputFile {
            path: out.join("damping_vs_amplitude.svg"),
            bytes: plot_damping_vs_amplitude_svg(
                &format!("Damping ratio per cycle vs amplitude: {}", sc.title()),
                &series,
            )
            .map_err(ReportError::from)?,
        });
    }
    let paths = std::iter::once(None)
        .chain(compared.iter().map(|c| Some(*c)))
        .map(path_of);
    let streams = sinks
        .into_iter()
        .zip(paths)
        .map(|(rows, path)| {
            rows.into_inner()
                .and_then(CsvRows::into_inner)
                .map_err(|e| csv_error(&path, e))
        })
        .collect::<Result<Vec<_>, _>>()?;
    commit(streams, &files).map_err(ReportError::from)?;
    let pct = |d: &Option<hybrid_core::decay::DecayEstimate>| match d
        .as_ref()
        .map(|d| (d.zeta(), d.frequency_hz()))
    {
        Some((Some(z), Some(f))) => format!("{:.3} % at {f:.3} Hz", z * 100.0),
        Some((Some(z), None)) => format!("{:.3} %", z * 100.0),
        _ => "n/a".to_string(),
    };
    let zeta = pct(&summary.decay);
    let others: String = sc
        .compare
        .iter()
        .filter_map(|c| summary.comparisons.get(c.key()))
        .map(|c| format!("; {}: zeta {}", c.label, pct(&c.decay)))
        .collect();
    // The backends of the mechanisms: generated code, or the interpreter of a model edited
    // since the build.
    let mut kinds: Vec<&str> = summary.mechanisms.iter().map(|m| m.backend).collect();
    kinds.dedup();
    let backends = if kinds.is_empty() {
        String::new()
    } else {
        format!(" ({})", kinds.join(", "))
    };
    // A forced run: the steady-state load power instead of the free decay's damping.
    let zeta = match (&summary.steady_power, &summary.decay) {
        (Some(p), None) => {
            let load: f64 = p.generators.iter().map(|g| g.mean_power_load).sum();
            if p.settled {
                format!(
                    "n/a (forced); steady load power {load:.4e} W over the last {} periods",
                    p.settled_periods
                )
            } else {
                format!("n/a (forced); load power {load:.4e} W in the last period (not settled)")
            }
        }
        _ => zeta,
    };
    let mut random = summary
        .random
        .as_ref()
        .map_or_else(String::new, |r| r.lines());
    if let Some(psd) = &run.psd {
        random.push_str(&psd.line());
    }
    crate::print(&format!(
        "{file}: {} steps in {:.3} s ({} mechanism(s){backends}, {} attachment(s), {} repartition(s)); peak {}; zeta {zeta}{others}; energy balance error {:.1e}; outputs in {}\n{random}",
        summary.steps,
        summary.wall_seconds,
        model.mechanisms.len(),
        na,
        summary.repartitions.len(),
        summary
            .peak_amplitude
            .map_or("n/a".to_string(), |p| format!("{:.3} mm", p * 1e3)),
        summary.energy_balance_rel_error,
        out.display()
    ))
}

/// Integrates a built hybrid scenario and makes its summary; every output row goes to
/// `rows` when given (nothing is written otherwise). `overrides` are recorded in the
/// summary. `probes`: beam points read as the attachments are, without being attached (a
/// comparison run's bare beam read where the attachments were), after the attachments.
pub fn evaluate<'a>(
    sc: &'a HybridScenario,
    built: &Built,
    probes: &[(String, BeamPoint)],
    mut rows: Option<Rows<'_>>,
    overrides: Vec<OverrideRecord>,
    progress: bool,
) -> Result<HybridRun<'a>, Error> {
    let file = sc.path.display().to_string();
    let model = &built.model;
    let mut integrator = Integrator::new(model, sc.method, sc.integrator.dt, &built.state)
        .map_err(|error| Error::Hybrid {
            file: file.clone(),
            error,
        })?;
    let initial = built.state.clone();
    let na = model.attachments.len();
    // Every beam point read: the attachments', then the probes.
    let points: Vec<&BeamPoint> = model
        .attachments
        .iter()
        .map(|a| &a.beam)
        .chain(probes.iter().map(|p| &p.1))
        .collect();
    let np = points.len();
    // Every node reading (the attachments' and the probes' `ux`, `uy`) and output point,
    // for the summary's `points`.
    let read: crate::setup::Probes = match model.beam() {
        Some(_) => vec![],
        None => model
            .attachments
            .iter()
            .map(|a| (&a.name, &a.beam))
            .chain(probes.iter().map(|(n, p)| (n, p)))
            .flat_map(|(n, p)| crate::setup::build::readings(model, n, p))
            .collect(),
    }
    .into_iter()
    .chain(built.points.iter().cloned())
    .collect();
    // The steps and rows `run` makes (its own rounding), for the plot's decimation and the
    // last tenth of the run.
    let dt = integrator.step_size();
    let steps = if dt > 0.0 {
        ((sc.integrator.t_end - initial.t) / dt).round().max(0.0)
    } else {
        0.0
    };
    let expected_rows = (steps / sc.every.max(1) as f64).floor() as u64 + 2;
    let mut tracks = Tracks {
        w: (0..np).map(|_| Decimator::new(expected_rows)).collect(),
        peak: vec![0.0; np],
        final_amplitude: vec![0.0; np],
        final_from: 0.9 * (initial.t + steps * dt),
        speeds: vec![(0.0, 0.0); na],
        max_condition: vec![0.0; model.mechanisms.len()],
        max_residual: vec![0.0; model.mechanisms.len()],
        peak_current: vec![0.0; model.forces.len()],
        read: vec![(0.0, 0.0); read.len()],
    };
    // A free decay is read through the modal filter of the first linearised mode (the
    // system's own first mode, free of the others), scaled to the first attachment's beam
    // point; without one (no attachment, no equilibrium) the attachment's displacement.
    let free = model.excitations.is_empty()
        && sc
            .beam
            .as_ref()
            .is_none_or(|(b, _)| b.loads.is_empty() && b.distributed_loads.is_empty());
    let filter = if free && np > 0 {
        first_mode_filter(sc, built, points[0])
    } else {
        None
    };
    // The decay of the first mode, estimated online from the modal filter's output (or the
    // first attachment's displacement): the same estimate as of the whole series.
    let mut decay = DecayTracker::default();
    // A periodic forcing's steady-state mean powers, read from the rows.
    let mut steady = SteadyPowerTracker::new(model, initial.t, dt * sc.every.max(1) as f64);
    let mut decay_samples: u64 = 0;
    let (mut z, mut zd) = (
        vec![0.0; model.structure_dofs()],
        vec![0.0; model.structure_dofs()],
    );
    let mut e0 = None;
    let mut output_rows: u64 = 0;
    // Under random excitation: the stationary statistics (report::random_run), their names.
    let random_points = crate::random::attachment_outputs(model);
    let random_signals = random_signal_names(model, &random_points);
    let random = model
        .excitations
        .iter()
        .any(|e| matches!(e.time, fem_beam::TimeFunction::Sampled(_)));
    // The linearisation of a run under random excitation: its slowest decay rate and the
    // linear prediction of the response spectra.
    let lin = random.then(|| linearisation(sc, built)).flatten();
    let random_start = random.then(|| {
        let slowest = lin.as_ref().and_then(slowest_decay_rate);
        let (from, warning) = stationary_start(sc.integrator.t_end, slowest);
        (from, slowest, warning)
    });
    let mut random_stats = random_start
        .as_ref()
        .map(|(from, _, _)| BatchStats::new(random_signals.len(), *from, sc.integrator.t_end));
    // The response spectra: every step of the stationary part (report::random_psd), in
    // segments chosen for at least 16 averages (none when the part is too short for that).
    let mut welch = random_start.as_ref().and_then(|(from, _, _)| {
        let first = ((from - initial.t) / dt).ceil().max(0.0);
        let samples = (steps - first + 1.0).max(0.0) as u64;
        segment_length(samples).map(|len| (*from, Welch::new(random_signals.len(), len, 1.0 / dt)))
    });
    // The signals' values at a step, for the spectra and at the rows for the statistics.
    let mut signals = vec![0.0; random_signals.len()];
    let mut signals_at_rows = signals.clone();
    let mut amplification = Vec::with_capacity(na);
    // The deformed shape to draw: `(|u|, t, q)` at the largest displacement magnitude of the
    // first attachment's point (a pin's `|(u_x, u_y)|`, a roller's along its direction),
    // copied into a buffer allocated once, on structures with elements only.
    let drawn = sc.structure.as_ref().is_some_and(|s| s.drawing.is_some());
    let mut deformed =
        (drawn && na > 0).then(|| (-1.0, 0.0, Vec::with_capacity(model.structure_dofs())));
    let bar = progress_bar(progress);
    let shown = !bar.is_hidden();
    // What is done at the output rows.
    let mut sink =
        |state: &HybridState, stored: &Stored, integrator: &mut Integrator| -> Result<(), Halt> {
            let e0 = *e0.get_or_insert(stored.total());
            amplifications(model, state, integrator, &mut amplification);
            if let Some((f, free)) = &filter {
                // z, z' as the linearisation orders them (its partition, whatever the run's).
                z.clear();
                z.extend_from_slice(&state.q);
                zd.clear();
                zd.extend_from_slice(&state.v);
                for (m, free) in state.mechanisms.iter().zip(free) {
                    z.extend(free.iter().map(|&c| m.q[c]));
                    zd.extend(free.iter().map(|&c| m.qd[c]));
                }
                decay.push(state.t, f.apply_state(&z, &zd, &state.currents));
                decay_samples += 1;
            }
            if let Some((peak, t, q)) = &mut deformed {
                let p = points[0];
                let u = p.value(&state.q).hypot(p.value_along(true, &state.q));
                if u > *peak {
                    (*peak, *t) = (u, state.t);
                    q.clear();
                    q.extend_from_slice(&state.q);
                }
            }
            for (k, p) in points.iter().enumerate() {
                let w = p.value(&state.q);
                if k == 0 && filter.is_none() {
                    decay.push(state.t, w);
                    decay_samples += 1;
                }
                tracks.w[k].push((state.t, w));
                tracks.peak[k] = tracks.peak[k].max(w.abs());
                if state.t >= tracks.final_from {
                    tracks.final_amplitude[k] = tracks.final_amplitude[k].max(w.abs());
                }
            }
            for ((_, p), (peak, last)) in read.iter().zip(&mut tracks.read) {
                let u = p.value(&state.q).abs();
                *peak = peak.max(u);
                if state.t >= tracks.final_from {
                    *last = last.max(u);
                }
            }
            for (k, a) in model.attachments.iter().enumerate() {
                let wd = a.beam.value(&state.v);
                if let Some(f) = model
                    .forces
                    .iter()
                    .find(|f| f.mechanism == a.mechanism && f.generator().is_some())
                {
                    let qd = state.mechanisms[f.mechanism].qd[f.joint];
                    tracks.speeds[k].0 += qd * qd;
                    tracks.speeds[k].1 += wd * wd;
                }
            }
            for (i, ms) in state.mechanisms.iter().enumerate() {
                tracks.max_condition[i] = tracks.max_condition[i].max(ms.condition);
                tracks.max_residual[i] = tracks.max_residual[i].max(ms.residual);
            }
            for (k, i) in state.currents.iter().enumerate() {
                tracks.peak_current[k] = tracks.peak_current[k].max(i.abs());
            }
            if let Some(s) = &mut steady {
                s.push(state);
            }
            if let Some(st) = &mut random_stats {
                random_signals_into(model, &random_points, state, &mut signals_at_rows);
                st.push(state.t, signals_at_rows.iter().copied());
            }
            output_rows += 1;
            if crate::interrupt::stop_requested() {
                return Err(Halt::Interrupted);
            }
            match &mut rows {
                Some((columns, sink)) => sink
                    .write_row(columns.row(model, state, stored, e0, &amplification))
                    .map_err(Halt::Csv),
                None => Ok(()),
            }
        };
    // A hidden bar (`--quiet`, no terminal) is not updated at all.
    let mut report = |f: f64| {
        if shown {
            bar.set_position((f * 1000.0) as u64);
        }
    };
    let options = RunOptions {
        t_end: sc.integrator.t_end,
        every: sc.every,
    };
    // Every step observed only for the spectra (random excitation, a stationary part long
    // enough): otherwise no observer, not even a test a step.
    let outcome = match &mut welch {
        Some((from, w)) => run_observed(
            model,
            &mut integrator,
            built.state.clone(),
            options,
            &mut |state| {
                if state.t >= *from {
                    random_signals_into(model, &random_points, state, &mut signals);
                    w.push(&signals);
                }
            },
            &mut sink,
            &mut report,
        ),
        None => hybrid_core::hybrid::run(
            model,
            &mut integrator,
            built.state.clone(),
            options,
            &mut sink,
            &mut report,
        ),
    };
    bar.finish_and_clear();
    let outcome = match outcome {
        Ok(o) => o,
        Err(RunError::Hybrid(error)) => return Err(Error::Hybrid { file, error }),
        Err(RunError::Sink(Halt::Csv(e))) => return Err(ReportError::from(e).into()),
        Err(RunError::Sink(Halt::Interrupted)) => return Err(Error::Interrupted),
    };
    let fig = &outcome.figures;
    let state = &outcome.state;

    // The summary.
    let coordinate = |m: usize, c: usize| model.mechanisms[m].system.coordinate_names()[c].clone();
    let named = |m: usize, q: &[f64]| -> BTreeMap<String, f64> {
        q.iter()
            .enumerate()
            .map(|(c, v)| (coordinate(m, c), *v))
            .collect()
    };
    let mechanisms = model
        .mechanisms
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let mm = &built.models[i];
            MechanismReport {
                name: m.name.clone(),
                model: mm.name.clone(),
                model_file: mm.source.path.clone(),
                model_hash: mm.source.hash.clone(),
                backend: m.system.backend().as_str(),
                initial_free: initial.mechanisms[i]
                    .free
                    .iter()
                    .map(|&c| coordinate(i, c))
                    .collect(),
                final_free: state.mechanisms[i]
                    .free
                    .iter()
                    .map(|&c| coordinate(i, c))
                    .collect(),
                initial_q: named(i, &initial.mechanisms[i].q),
                final_q: named(i, &state.mechanisms[i].q),
                max_condition: tracks.max_condition[i],
                max_constraint_residual: tracks.max_residual[i],
            }
        })
        .collect();
    let t_end = state.t;
    let attachments: Vec<AttachmentReport> = model
        .attachments
        .iter()
        .enumerate()
        .map(|(k, a)| {
            let (s_q, s_w) = tracks.speeds[k];
            AttachmentReport {
                name: a.name.clone(),
                kind: a.kind.as_str(),
                x: a.beam.x,
                peak_displacement: tracks.peak[k],
                final_amplitude: tracks.final_amplitude[k],
                speed_ratio_rms: (s_w > 0.0).then(|| (s_q / s_w).sqrt()),
            }
        })
        .chain(
            probes
                .iter()
                .enumerate()
                .map(|(j, (name, p))| AttachmentReport {
                    name: name.clone(),
                    kind: "probe",
                    x: p.x,
                    peak_displacement: tracks.peak[na + j],
                    final_amplitude: tracks.final_amplitude[na + j],
                    speed_ratio_rms: None,
                }),
        )
        .collect();
    // Per mechanism whose own model has force elements, by name.
    let model_elements = |per_mechanism: &[f64]| -> BTreeMap<String, f64> {
        model
            .mechanisms
            .iter()
            .zip(&built.models)
            .zip(per_mechanism)
            .filter(|((_, mm), _)| !mm.forces.is_empty())
            .map(|((m, _), v)| (m.name.clone(), *v))
            .collect()
    };
    let generators = model
        .forces
        .iter()
        .enumerate()
        .filter_map(|(k, f)| {
            let g = f.generator()?;
            let d = state.account.dissipated[k];
            let gearbox = state.account.gearbox_loss[k];
            let electrical = state.account.circuit_dissipated(k);
            let harvested = g.load_part(electrical);
            let copper = electrical * g.armature_resistance / g.resistance();
            let mechanical = state.account.mechanical_input[k];
            let q = state.mechanisms[f.mechanism].q[f.joint];
            let magnetic = f.stored_energy(q, state.currents[k]);
            let conversion = state.account.conversion[k];
            Some(GeneratorReport {
                name: f.name.clone(),
                mechanism: model.mechanisms[f.mechanism].name.clone(),
                dissipated: d,
                harvested_in_load: harvested,
                mean_load_power: if t_end > 0.0 { harvested / t_end } else { 0.0 },
                peak_current: tracks.peak_current[k],
                energy_split: EnergySplit {
                    mechanical_input: mechanical,
                    copper_loss: copper,
                    gearbox_loss: gearbox,
                    load_energy: harvested,
                    magnetic_change: magnetic,
                    conversion,
                    residual: mechanical - (copper + gearbox + harvested + magnetic + conversion),
                },
                settings: g.clone(),
            })
        })
        .collect();
    let excitations = model
        .excitations
        .iter()
        .zip(&state.account.excitation_work)
        .map(|(e, w)| ExcitationReport {
            name: e.name.clone(),
            work: *w,
            supports: e.target.is_base(),
        })
        .collect();
    let psd = welch
        .filter(|(_, w)| w.segments() > 0)
        .map(|(_, w)| random_psd(&file, sc, model, lin.as_ref(), &random_signals, &w));
    let decay = (free && decay_samples > 0).then(|| decay.estimate());
    let damping_ratio = decay.as_ref().and_then(|d| d.zeta());
    let summary = HybridSummary {
        scenario: file.clone(),
        overrides,
        description: sc.description.as_deref(),
        generator_version: mbs_symbolic::emit::GENERATOR_VERSION,
        integrator: &sc.integrator,
        every: sc.every,
        steps: fig.steps,
        output_rows,
        wall_seconds: fig.wall.as_secs_f64(),
        steps_per_second: fig.steps as f64 / fig.wall.as_secs_f64().max(1e-12),
        beam_first_frequency_hz: model
            .beam()
            .and_then(|b| b.modes(1).ok())
            .map(|m| m.frequencies_hz()[0]),
        structure: crate::report::structure::StructureReport::of(model),
        peak_amplitude: attachments.first().map(|a| a.peak_displacement),
        damping_ratio,
        decay,
        decay_signal: match (&filter, free && np > 0) {
            (Some(_), _) => {
                Some("modal filter of the first linearised mode, scaled to the first attachment")
            }
            (None, true) => Some("first attachment's displacement (no linearised mode)"),
            (None, false) => None,
        },
        mechanisms,
        attachments,
        points: read
            .iter()
            .zip(&tracks.read)
            .map(|((name, _), &(peak, last))| PointReport {
                name: name.clone(),
                peak_displacement: peak,
                final_amplitude: last,
            })
            .collect(),
        generators,
        excitations,
        steady_power: steady.as_ref().and_then(|s| s.finish(model)),
        energy: HybridEnergy {
            initial: fig.initial_energy,
            final_stored: outcome.stored.total(),
            dissipated_structure: state.account.dissipated_structure,
            dissipated_elements: model
                .forces
                .iter()
                .zip(&state.account.dissipated)
                .map(|(f, d)| (f.name.clone(), *d))
                .collect(),
            dissipated_model: model_elements(&state.account.dissipated_model),
            model_work: model_elements(&state.account.model_input_work),
            beam_load_work: state.account.beam_load_work,
            excitation_work: model
                .excitations
                .iter()
                .zip(&state.account.excitation_work)
                .map(|(e, w)| (e.name.clone(), *w))
                .collect(),
            max_balance_error: fig.max_balance_error,
            relative_to: "max(initial energy, stored energy, |input work|) at the output steps",
            scale: fig.energy_scale,
        },
        energy_balance_rel_error: fig.balance_rel_error,
        repartitions: fig
            .repartitions
            .iter()
            .map(|r| RepartitionReport {
                t: r.t,
                mechanism: model.mechanisms[r.mechanism].name.clone(),
                from: r.from.iter().map(|&c| coordinate(r.mechanism, c)).collect(),
                to: r.to.iter().map(|&c| coordinate(r.mechanism, c)).collect(),
                cond_before: r.condition.0,
                cond_after: r.condition.1,
            })
            .collect(),
        random: random_stats
            .zip(random_start)
            .map(|(st, (_, slowest, warning))| RandomRunReport {
                slowest_decay_rate: slowest,
                warning,
                psd: psd.as_ref().map(|p| p.report.clone()),
                ..random_report(model, &random_signals, &st)
            }),
        comparisons: BTreeMap::new(),
    };

    Ok(HybridRun {
        summary,
        displacements: tracks.w.iter().map(Decimator::points).collect(),
        psd,
        deformed: deformed.map(|(_, t, q)| (t, q)),
    })
}

/// Why the row sink of [`evaluate`] stopped a run.
enum Halt {
    /// A row could not be written.
    Csv(::csv::Error),
    /// [`crate::interrupt::StopToken::stop`] was called.
    Interrupted,
}

/// The signals of a run under random excitation, as `damper random` names them and in its
/// order (the linear prediction is paired with them by position), with their units and
/// whether they are centred: every attachment's displacements and rates
/// ([`crate::random::attachment_outputs`]: a beam point's `w`, a node's `ux` and `uy`),
/// every mechanism coordinate and rate, every generator's current (not centred) and rotor
/// speed.
fn random_signal_names(
    model: &HybridModel,
    displacements: &[(String, BeamPoint)],
) -> Vec<(String, String, bool)> {
    let mut out = vec![];
    for (label, _) in displacements {
        out.push((label.clone(), "m".to_string(), true));
        out.push((format!("{label}'"), "m/s".to_string(), true));
    }
    for m in &model.mechanisms {
        let units = m.system.coordinate_units();
        for (j, n) in m.system.coordinate_names().iter().enumerate() {
            let u = units[j].symbol();
            out.push((format!("{}/{n}", m.name), u.to_string(), true));
            out.push((format!("{}/{n}'", m.name), format!("{u}/s"), true));
        }
    }
    for f in model.forces.iter().filter(|f| f.generator().is_some()) {
        out.push((format!("{}.current", f.name), "A".to_string(), false));
        out.push((format!("{}.rotor_speed", f.name), "rad/s".to_string(), true));
    }
    out
}

/// The values of [`random_signal_names`] in a state, written into `out` (one per name; the
/// step's observer: plain loops, no allocation).
fn random_signals_into(
    model: &HybridModel,
    displacements: &[(String, BeamPoint)],
    state: &hybrid_core::hybrid::HybridState,
    out: &mut [f64],
) {
    let mut k = 0;
    let mut put = |v: f64| {
        out[k] = v;
        k += 1;
    };
    for (_, p) in displacements {
        put(p.value(&state.q));
        put(p.value(&state.v));
    }
    for m in &state.mechanisms {
        for (q, qd) in m.q.iter().zip(&m.qd) {
            put(*q);
            put(*qd);
        }
    }
    for (f, i) in model.forces.iter().zip(&state.currents) {
        if let Some(g) = f.generator() {
            put(*i);
            put(g.gear_ratio * state.mechanisms[f.mechanism].qd[f.joint]);
        }
    }
}

/// `random_rms.svg` of a run under random excitation: the RMS against time of its
/// displacement outputs (unit m: the attachments' beam points) over windows of 1/100 of the
/// run, each with its stationary RMS as a level over the stationary part and the start of
/// that part marked; `None` without such an output.
fn random_rms_plot(
    out: &Path,
    sc: &HybridScenario,
    random: &RandomRunReport,
) -> Result<Option<OutputFile>, Error> {
    let shown: Vec<&RmsHistory> = random.history.iter().filter(|h| h.unit == "m").collect();
    if shown.is_empty() {
        return Ok(None);
    }
    let t_end = sc.integrator.t_end;
    let mut series: Vec<(String, Vec<(f64, f64)>)> = vec![];
    let mut top: f64 = 0.0;
    for h in &shown {
        top = h.points.iter().fold(top, |m, p| m.max(p.1));
        series.push((
            format!(
                "{}: RMS over windows of {} s",
                h.name,
                tick_label(t_end / 100.0)
            ),
            h.points.clone(),
        ));
        if let Some(o) = random.outputs.iter().find(|o| o.name == h.name) {
            series.push((
                format!(
                    "{}: stationary RMS {} ± {} m",
                    h.name,
                    tick_label(o.rms.value),
                    tick_label(o.rms.standard_error)
                ),
                vec![(random.from, o.rms.value), (t_end, o.rms.value)],
            ));
        }
    }
    series.push((
        format!(
            "start of the stationary part, {} s",
            tick_label(random.from)
        ),
        vec![(random.from, 0.0), (random.from, top)],
    ));
    let refs: Vec<(&str, &[(f64, f64)])> =
        series.iter().map(|(l, p)| (l.as_str(), &p[..])).collect();
    let title = format!("RMS against time under random excitation: {}", sc.title());
    let bytes =
        crate::report::plot::plot_xy_svg(&title, "t [s]", "RMS [m]", &refs, (false, false), true)
            .map_err(ReportError::from)?;
    Ok(Some(OutputFile {
        path: out.join("random_rms.svg"),
        bytes,
    }))
}

/// `random_psd.svg` of a run under random excitation: the response PSD of its displacement
/// outputs (unit m: the attachments' beam points), the Welch estimate beside the linear
/// prediction on log–log axes, over the frequencies where the prediction is positive (the
/// excitations' bands; every frequency above zero without a prediction); `None` without
/// such an output or a positive value to draw.
fn random_psd_plot(
    out: &Path,
    sc: &HybridScenario,
    psd: &RandomPsd,
) -> Result<Option<OutputFile>, Error> {
    let shown: Vec<_> = psd.outputs.iter().filter(|o| o.unit == "m").collect();
    let drawn = |k: usize| {
        psd.frequencies[k] > 0.0
            && shown
                .iter()
                .all(|o| o.prediction.as_ref().is_none_or(|p| p[k] > 0.0))
    };
    let keep: Vec<usize> = (0..psd.frequencies.len()).filter(|&k| drawn(k)).collect();
    let positive = |v: &[f64]| -> Vec<(f64, f64)> {
        keep.iter()
            .filter(|&&k| v[k] > 0.0 && v[k].is_finite())
            .map(|&k| (psd.frequencies[k], v[k]))
            .collect()
    };
    let r = &psd.report;
    let mut series: Vec<(String, Vec<(f64, f64)>)> = vec![];
    // The prediction first: drawn on top of the estimate's scatter.
    for o in &shown {
        if let Some(p) = &o.prediction {
            series.push((format!("{}: linear prediction", o.name), positive(p)));
        }
        series.push((
            format!(
                "{}: Welch estimate, {} averages, resolution {} Hz, relative standard error {}",
                o.name,
                r.averages,
                tick_label(r.resolution_hz),
                tick_label(r.relative_standard_error)
            ),
            positive(&o.estimate),
        ));
    }
    if series.iter().all(|(_, p)| p.is_empty()) {
        return Ok(None);
    }
    let refs: Vec<(&str, &[(f64, f64)])> =
        series.iter().map(|(l, p)| (l.as_str(), &p[..])).collect();
    let title = format!("Response PSD against the linear prediction: {}", sc.title());
    let bytes = crate::report::plot::plot_xy_svg(
        &title,
        "f [Hz]",
        "PSD [m^2/Hz]",
        &refs,
        (true, true),
        false,
    )
    .map_err(ReportError::from)?;
    Ok(Some(OutputFile {
        path: out.join("random_psd.svg"),
        bytes,
    }))
}

/// The `random` block of the summary from the run's batch sums.
fn random_report(
    model: &HybridModel,
    names: &[(String, String, bool)],
    st: &BatchStats,
) -> RandomRunReport {
    let realisations = model
        .excitations
        .iter()
        .filter_map(|e| match &e.time {
            fem_beam::TimeFunction::Sampled(s) => Some(RealisationReport {
                excitation: e.name.clone(),
                seed: s.seed(),
                period: s.period(),
                mean_square: s.mean_square(),
                psd_mean_square: s.psd_mean_square(),
            }),
            _ => None,
        })
        .collect();
    let ngen = model
        .forces
        .iter()
        .filter(|f| f.generator().is_some())
        .count();
    let nout = names.len() - 2 * ngen;
    let mut outputs: Vec<RmsEstimate> = names[..nout]
        .iter()
        .enumerate()
        .map(|(k, (name, unit, centred))| RmsEstimate {
            name: name.clone(),
            unit: unit.clone(),
            rms: st.rms(k, *centred).into(),
        })
        .collect();
    let history = names[..nout]
        .iter()
        .enumerate()
        .map(|(k, (name, unit, centred))| RmsHistory {
            name: name.clone(),
            unit: unit.clone(),
            points: st.history(k, *centred),
        })
        .collect();
    let mut generators = vec![];
    for (j, f) in model
        .forces
        .iter()
        .filter(|f| f.generator().is_some())
        .enumerate()
    {
        let g = f.generator().expect("filtered on generators");
        let (ki, ks) = (nout + 2 * j, nout + 2 * j + 1);
        let [ms, se] = st.second_moment(ki, false);
        outputs.push(RmsEstimate {
            name: names[ks].0.clone(),
            unit: names[ks].1.clone(),
            rms: st.rms(ks, true).into(),
        });
        generators.push(GeneratorEstimate {
            name: f.name.clone(),
            rms_current: st.rms(ki, false).into(),
            mean_power_dissipated: [g.resistance() * ms, g.resistance() * se].into(),
            mean_power_load: [g.load_resistance * ms, g.load_resistance * se].into(),
        });
    }
    RandomRunReport {
        realisations,
        from: st.from(),
        slowest_decay_rate: None,
        warning: None,
        psd: None,
        batches: BATCHES,
        samples: st.samples(),
        outputs,
        generators,
        history,
    }
}

/// Modes read for the slowest decay rate of a run under random excitation.
const DECAY_MODES: usize = 10;

/// The linearisation of a built hybrid scenario about its static equilibrium, `None` where
/// there is none.
fn linearisation(sc: &HybridScenario, built: &Built) -> Option<Linearization> {
    let tangents = crate::setup::hybrid_tangents(sc, &built.models).ok()?;
    let refs: Vec<_> = tangents.iter().collect();
    Linearization::new(
        &built.model,
        &refs,
        hybrid_core::hybrid::EquilibriumOptions::default(),
    )
    .ok()
}

/// The response spectra of a run of `sc` from its Welch sums `welch` over the signals
/// `names` ([`random_signal_names`]), with the linear prediction at the same frequencies
/// from `lin` and the scenario's excitations as written (none without a linearisation, or
/// where its harmonic solves fail).
fn random_psd(
    file: &str,
    sc: &HybridScenario,
    model: &HybridModel,
    lin: Option<&Linearization>,
    names: &[(String, String, bool)],
    welch: &Welch,
) -> RandomPsd {
    // The excitations as written (the run's model holds their realisations).
    let written = crate::setup::build_model(sc)
        .ok()
        .map(|(m, _)| m.excitations);
    let prediction = lin.zip(written).and_then(|(lin, written)| {
        crate::random::response_psd(file, model, lin, &written, &welch.frequencies()).ok()
    });
    let names: Vec<(String, String)> = names
        .iter()
        .map(|(n, u, _)| (n.clone(), u.clone()))
        .collect();
    RandomPsd::of(welch, &names, prediction)
}

/// The smallest decay rate `-Re lambda` (1/s) of the first [`DECAY_MODES`] linearised modes
/// of a linearised hybrid scenario, `None` without a stable mode.
fn slowest_decay_rate(lin: &Linearization) -> Option<f64> {
    let k = DECAY_MODES.min(lin.dim());
    let found = hybrid_core::hybrid::modes(lin, k, hybrid_core::hybrid::EigenMethod::Auto).ok()?;
    found
        .iter()
        .map(|m| m.decay_rate)
        .reduce(f64::min)
        .filter(|r| *r > 0.0)
}

/// The modal filter of the first linearised mode of a built hybrid scenario
/// ([`hybrid_core::decay::ModalFilter::of_mode`], scaled to the first attachment's beam
/// point) with the free coordinates of each mechanism it reads (after the beam DOFs), or
/// `None` when it cannot be linearised.
fn first_mode_filter(
    sc: &HybridScenario,
    built: &Built,
    point: &BeamPoint,
) -> Option<(hybrid_core::decay::ModalFilter, Vec<Vec<usize>>)> {
    let tangents = crate::setup::hybrid_tangents(sc, &built.models).ok()?;
    let refs: Vec<_> = tangents.iter().collect();
    hybrid_core::decay::ModalFilter::first_mode(&built.model, &refs, point).ok()
}
