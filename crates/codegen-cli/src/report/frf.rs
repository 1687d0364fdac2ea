//! The report of `damper frf`: `frf.csv`, `frf_nonlinear.csv` (the one CSV writer,
//! [`crate::report::rows::CsvRows`]), `frf.json`, `frf.svg` ([`plot_receptance_svg`]) and, when a mechanism has
//! a reach, `frf_max_force.svg` ([`plot_xy_svg`]), in memory, for the one atomic writer.

use std::path::Path;

use hybrid_core::hybrid::Linearization;
use serde::Serialize;

use crate::Error;
use crate::analysis::frf::{Frf, FrfRequest, Io, LinearRow, NonlinearRow};
use crate::report::plot::{PlotError, plot_receptance_svg, plot_xy_svg};
use crate::report::rows::{Cells, Table, TableColumn};
use crate::report::summary::json_bytes;
use crate::report::{OutputFile, ReportError};
use crate::scenario;
use crate::setup::Linearizable;

/// `frf.json`.
#[derive(Serialize)]
struct FrfJson<'a> {
    scenario: String,
    overrides: Vec<scenario::OverrideRecord>,
    output: &'a str,
    response_unit: &'a str,
    force_unit: &'a str,
    excitation: &'a str,
    force_amplitude: f64,
    phase_convention: &'static str,
    from_hz: f64,
    to_hz: f64,
    points: usize,
    log: bool,
    equilibrium_newton_iterations: usize,
    generators: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    nonlinear_settings: Option<NonlinearSettings>,
    /// The admissible load: per mechanism its reach and attachment point (the values are
    /// `max_force` of every linear row, in this order).
    load_limits: Vec<LoadLimitJson<'a>>,
    /// The largest response at an edge of the band (the peak may lie outside it).
    warnings: &'a [&'a str],
    linear: &'a [LinearRow],
    #[serde(skip_serializing_if = "Option::is_none")]
    nonlinear: Option<&'a [NonlinearRow]>,
}

/// A mechanism's admissible load in `frf.json`.
#[derive(Serialize)]
struct LoadLimitJson<'a> {
    mechanism: &'a str,
    /// Remaining reach at the equilibrium (m).
    reach: f64,
    /// Abscissa of its first attachment's beam point (m).
    attachment_x: f64,
    /// `reach / |H_att|`, in the force unit.
    definition: &'static str,
    /// The smallest value over the band and its frequency.
    min_max_force: f64,
    min_f_hz: f64,
}

#[derive(Serialize)]
struct NonlinearSettings {
    steps_per_period: usize,
    tolerance: f64,
    max_periods: usize,
    method: &'static str,
}

/// A plot could not be drawn (the file, plotters' message).
#[derive(Debug, thiserror::Error)]
#[error("cannot draw {0}: {1}")]
struct PlotFailed(&'static str, String);

impl From<PlotFailed> for Error {
    fn from(PlotFailed(file, message): PlotFailed) -> Error {
        ReportError::Draw { file, message }.into()
    }
}

/// The table of `frf.csv`: every linear value under its name and unit (`f [Hz]`, `|H|` and
/// phase with the generator and disconnected, real and imaginary parts, the admissible
/// loads, per connected generator its current, voltage and load power per unit force).
fn linear_table(io: &Io, linear: &[LinearRow]) -> Table {
    let unit = io.unit();
    let force_unit = io.force_unit;
    let column = |name: String, unit: &str, of: &dyn Fn(&LinearRow) -> f64| {
        TableColumn::new(
            name,
            Some(unit),
            Cells::Numbers(linear.iter().map(|r| Some(of(r))).collect()),
        )
    };
    let mut columns = vec![
        column("f".into(), "Hz", &|r| r.f_hz),
        column("|H| with generator".into(), &unit, &|r| {
            r.with_generator.magnitude
        }),
        column("phase with generator".into(), "deg", &|r| {
            r.with_generator.phase_deg
        }),
        column("|H| generator disconnected".into(), &unit, &|r| {
            r.generator_disconnected.magnitude
        }),
        column("phase generator disconnected".into(), "deg", &|r| {
            r.generator_disconnected.phase_deg
        }),
        column("Re H with generator".into(), &unit, &|r| {
            r.with_generator.re
        }),
        column("Im H with generator".into(), &unit, &|r| {
            r.with_generator.im
        }),
        column("Re H generator disconnected".into(), &unit, &|r| {
            r.generator_disconnected.re
        }),
        column("Im H generator disconnected".into(), &unit, &|r| {
            r.generator_disconnected.im
        }),
    ];
    for (k, l) in io.limits.iter().enumerate() {
        let name = if io.limits.len() == 1 {
            "max_force".to_string()
        } else {
            format!("{}.max_force", l.name)
        };
        columns.push(column(name, force_unit, &|r| r.max_force[k]));
    }
    // Per connected generator: current, terminal voltage and load power per unit force
    // (`A/N`, `V/N`, `W/N^2`; `W/(N m)^2` for a torque).
    let per = |what: &str| -> String {
        if force_unit.contains(' ') {
            format!("{what}/({force_unit})")
        } else {
            format!("{what}/{force_unit}")
        }
    };
    let names: Vec<String> = linear
        .first()
        .map(|r| r.generators.iter().map(|g| g.name.clone()).collect())
        .unwrap_or_default();
    for (k, name) in names.iter().enumerate() {
        columns.push(column(format!("{name}.current"), &per("A"), &|r| {
            r.generators[k].current
        }));
        columns.push(column(format!("{name}.voltage"), &per("V"), &|r| {
            r.generators[k].voltage
        }));
        columns.push(column(
            format!("{name}.load_power"),
            &format!("{}^2", per("W")),
            &|r| r.generators[k].load_power,
        ));
    }
    Table::new(columns)
}

/// A number as the CSVs print it.
fn number(v: f64) -> String {
    format!("{v:e}")
}

/// The table of `frf_nonlinear.csv`: the frequency, the measured amplitude, `|H|` and
/// phase, the linear ones at the same frequency, periods, settled, distortion, time step,
/// per connected generator the measured and linear load powers, and the error (an empty
/// number: the run stopped, or did not settle for the measured load powers).
fn nonlinear_table(io: &Io, linear: &[LinearRow], nl: &[NonlinearRow]) -> Table {
    let unit = io.unit();
    let numbers = |name: String, unit: &str, of: &dyn Fn(&NonlinearRow) -> Option<f64>| {
        TableColumn::new(
            name,
            Some(unit),
            Cells::Numbers(nl.iter().map(of).collect()),
        )
    };
    let mut columns = vec![
        numbers("f".into(), "Hz", &|r| Some(r.f_hz)),
        numbers("amplitude".into(), io.response_unit, &|r| r.amplitude),
        numbers("|H|".into(), &unit, &|r| r.magnitude),
        numbers("phase".into(), "deg", &|r| r.phase_deg),
        numbers("|H| linear".into(), &unit, &|r| Some(r.linear.magnitude)),
        numbers("phase linear".into(), "deg", &|r| Some(r.linear.phase_deg)),
        TableColumn::new(
            "periods",
            None,
            Cells::Counts(nl.iter().map(|r| r.periods).collect()),
        ),
        TableColumn::new(
            "settled",
            None,
            Cells::Flags(nl.iter().map(|r| r.settled).collect()),
        ),
        numbers("distortion".into(), "-", &|r| r.distortion),
        numbers("dt".into(), "s", &|r| Some(r.dt)),
    ];
    let names: Vec<&str> = linear
        .first()
        .map(|r| r.generators.iter().map(|g| g.name.as_str()).collect())
        .unwrap_or_default();
    for (k, name) in names.iter().enumerate() {
        columns.push(numbers(format!("{name}.load_power"), "W", &|r| {
            r.load_power.get(k).copied()
        }));
        columns.push(numbers(format!("{name}.load_power linear"), "W", &|r| {
            Some(r.load_power_linear[k])
        }));
    }
    columns.push(TableColumn::new(
        "error",
        None,
        Cells::Texts(nl.iter().map(|r| r.error.clone()).collect()),
    ));
    Table::new(columns)
}

impl Frf {
    /// The table of `frf.csv` (built by the code that writes the file), one row per
    /// frequency.
    pub fn table(&self) -> Table {
        linear_table(&self.io, &self.linear)
    }

    /// With `nonlinear`, the table of `frf_nonlinear.csv` (built by the code that writes
    /// the file), one row per frequency of the runs, typed as the cells read (numbers with
    /// `None` for an empty cell, `periods` as counts, `settled` as flags, `error` as text).
    pub fn nonlinear_table(&self) -> Option<Table> {
        let nl = self.nonlinear.as_deref()?;
        Some(nonlinear_table(&self.io, &self.linear, nl))
    }
}

/// Every output file of `frf` (computed for `args`, the scenario loaded with `overrides`)
/// into the directory `out`, in memory.
pub fn outputs(
    args: &FrfRequest,
    overrides: Vec<scenario::OverrideRecord>,
    out: &Path,
    frf: &Frf,
) -> Result<Vec<OutputFile>, Error> {
    let file = args.file.as_str();
    let (lz, lin, io): (&Linearizable, &Linearization, &Io) = (&frf.lz, &frf.lin, &frf.io);
    let linear = &frf.linear[..];
    let nonlinear = frf.nonlinear.as_deref();
    let generators = frf.generators();
    let warnings: Vec<&str> = frf
        .warnings
        .iter()
        .filter(|w| !w.note)
        .map(|w| w.message.as_str())
        .collect();
    let unit = io.unit();
    let csv_error = |e: ::csv::Error| Error::from(ReportError::from(e));
    let mut files = vec![OutputFile {
        path: out.join("frf.csv"),
        bytes: frf.table().csv(&number).map_err(csv_error)?,
    }];
    if let Some(table) = frf.nonlinear_table() {
        files.push(OutputFile {
            path: out.join("frf_nonlinear.csv"),
            bytes: table.csv(&number).map_err(csv_error)?,
        });
    }
    let json = FrfJson {
        scenario: file.to_string(),
        overrides,
        output: &io.output_label,
        response_unit: io.response_unit,
        force_unit: io.force_unit,
        excitation: &io.excitation.name,
        force_amplitude: io.excitation.amplitude,
        phase_convention: "response = |H| F sin(omega t + phi_excitation + phase)",
        from_hz: args.from,
        to_hz: args.to,
        points: args.points,
        log: args.log,
        equilibrium_newton_iterations: lin.equilibrium.iterations,
        generators,
        nonlinear_settings: nonlinear.map(|_| NonlinearSettings {
            steps_per_period: args.steps_per_period,
            tolerance: args.tolerance,
            max_periods: args.max_periods,
            method: match lz.method {
                hybrid_core::hybrid::Method::Newmark => "newmark",
                _ => "hht",
            },
        }),
        load_limits: io
            .limits
            .iter()
            .enumerate()
            .map(|(k, l)| {
                let (f, v) = smallest(linear, k);
                LoadLimitJson {
                    mechanism: &l.name,
                    reach: l.reach,
                    attachment_x: l.point.x,
                    definition: "max_force = reach / |H_att|: the largest harmonic force amplitude keeping the attachment's linear amplitude within the reach",
                    min_max_force: v,
                    min_f_hz: f,
                }
            })
            .collect(),
        warnings: &warnings,
        linear,
        nonlinear,
    };
    files.push(OutputFile {
        path: out.join("frf.json"),
        bytes: json_bytes(&json).map_err(ReportError::from)?,
    });
    let stem = Path::new(file)
        .file_stem()
        .map_or_else(|| file.to_string(), |s| s.to_string_lossy().into_owned());
    let mut title = format!(
        "{stem}: receptance {} / {} ({})",
        io.output_label, io.excitation.name, unit
    );
    if nonlinear.is_some() {
        title += &format!(
            "; nonlinear at |F| = {:.3e} {}, {} steps/period",
            io.excitation.amplitude.abs(),
            io.force_unit,
            args.steps_per_period
        );
    }
    let magnitudes = |of: fn(&LinearRow) -> f64| -> Vec<(f64, f64)> {
        linear.iter().map(|r| (r.f_hz, of(r))).collect()
    };
    let markers: Option<Vec<(f64, f64, bool)>> = nonlinear.map(|nl| {
        nl.iter()
            .filter_map(|r| Some((r.f_hz, r.magnitude?, r.settled)))
            .collect()
    });
    let svg = plot_receptance_svg(
        &title,
        &unit,
        (args.from, args.to, args.log),
        &magnitudes(|r| r.with_generator.magnitude),
        &magnitudes(|r| r.generator_disconnected.magnitude),
        markers.as_deref(),
    )
    .map_err(|e: PlotError| PlotFailed("frf.svg", e.message().to_string()))?;
    files.push(OutputFile {
        path: out.join("frf.svg"),
        bytes: svg,
    });
    if !io.limits.is_empty() {
        files.push(OutputFile {
            path: out.join("frf_max_force.svg"),
            bytes: max_force_svg(args, &stem, io, linear)?,
        });
    }
    Ok(files)
}

/// The smallest admissible load of limit `k` over the band: `(f (Hz), max_force)`.
pub fn smallest(linear: &[LinearRow], k: usize) -> (f64, f64) {
    linear
        .iter()
        .map(|r| (r.f_hz, r.max_force[k]))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .expect("at least two frequencies")
}

/// `frf_max_force.svg`: the admissible load of every mechanism against the frequency (on a
/// log axis: it spans decades), and the excitation's own amplitude as a horizontal line (the design fails where a curve
/// goes below it).
fn max_force_svg(
    args: &FrfRequest,
    stem: &str,
    io: &Io,
    linear: &[LinearRow],
) -> Result<Vec<u8>, Error> {
    let curves: Vec<(String, Vec<(f64, f64)>)> = io
        .limits
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let pts = linear
                .iter()
                .map(|r| (r.f_hz, r.max_force[k]))
                .filter(|p| p.1.is_finite())
                .collect();
            (
                format!("max force, {} (reach {:.3e} m)", l.name, l.reach),
                pts,
            )
        })
        .collect();
    let amplitude = io.excitation.amplitude.abs();
    let reference = [(args.from, amplitude), (args.to, amplitude)];
    let reference_label = format!(
        "|F| of {} = {amplitude:.3e} {}",
        io.excitation.name, io.force_unit
    );
    let mut series: Vec<(&str, &[(f64, f64)])> = curves
        .iter()
        .map(|(label, pts)| (label.as_str(), pts.as_slice()))
        .collect();
    series.push((&reference_label, &reference));
    let title = format!(
        "{stem}: admissible load (reach / |H_att|) for {}",
        io.excitation.name
    );
    plot_xy_svg(
        &title,
        "f [Hz]",
        &format!("max force amplitude [{}]", io.force_unit),
        &series,
        (args.log, true),
        true,
    )
    .map_err(|e: PlotError| PlotFailed("frf_max_force.svg", e.message().to_string()).into())
}

/// The line `damper frf` prints: the peaks, the smallest admissible loads, the nonlinear
/// runs' outcome and the output directory.
pub fn summary(req: &FrfRequest, out: &std::path::Path, frf: &Frf) -> String {
    let Frf {
        io,
        freqs,
        linear,
        nonlinear,
        ..
    } = frf;
    let peak_of = |of: fn(&LinearRow) -> f64| {
        linear
            .iter()
            .max_by(|a, b| of(a).total_cmp(&of(b)))
            .expect("at least two frequencies")
    };
    let peak = peak_of(|r| r.with_generator.magnitude);
    let peak_off = peak_of(|r| r.generator_disconnected.magnitude);
    let unit = io.unit();
    let mut text = format!(
        "{}: {} frequencies {}-{} Hz; peak |H| with generator {:.4e} {unit} at {:.4} Hz, generator disconnected {:.4e} {unit} at {:.4} Hz",
        req.file,
        freqs.len(),
        req.from,
        req.to,
        peak.with_generator.magnitude,
        peak.f_hz,
        peak_off.generator_disconnected.magnitude,
        peak_off.f_hz
    );
    for (k, l) in io.limits.iter().enumerate() {
        let (f, v) = smallest(linear, k);
        text += &format!(
            "; smallest max force ({}, reach {:.4e} m) {v:.4e} {} at {f:.4} Hz",
            l.name, l.reach, io.force_unit
        );
    }
    if let Some(rows) = nonlinear {
        let settled = rows.iter().filter(|r| r.settled).count();
        let failed = rows.iter().filter(|r| r.error.is_some()).count();
        text += &format!(
            "; nonlinear: {} frequencies, {settled} settled, {failed} stopped",
            rows.len()
        );
    }
    text + &format!("; outputs in {}\n", out.display())
}
