//! The files of a closed-loop mechanism run (`kind = "mechanism"`): `<stem>.csv` streamed
//! row by row, `<stem>_summary.json` and `<stem>.svg` (the coordinates against time, at
//! most 20,000 rows plotted), committed together by the one atomic writer, or none.

use std::path::Path;
use std::time::Instant;

use crate::Error;
use crate::report::csv::MechanismCsv;
use crate::report::plot::plot_series_svg;
use crate::report::summary::json_bytes;
use crate::report::{OutputFile, ReportError, StreamFile, commit};
use crate::run::{mechanism_run, mechanism_summary};
use crate::scenario::{MechanismScenario, OverrideRecord};

/// A CSV row that could not be written: the file named when it is an I/O error.
fn csv_error(path: &Path, e: ::csv::Error) -> Error {
    crate::report::csv_error(path, e).into()
}

/// Runs a closed-loop mechanism scenario as `damper simulate` does and writes its files
/// into `out` (`stem`: the scenario file's); `overrides`: the `--set` options applied,
/// recorded in the summary.
pub fn simulate(
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
