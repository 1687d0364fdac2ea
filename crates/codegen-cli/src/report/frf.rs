//! The report of `damper frf`: `frf.csv`, `frf_nonlinear.csv` (the one CSV writer,
//! [`CsvRows`]), `frf.json`, `frf.svg` ([`plot_receptance_svg`]) and, when a mechanism has
//! a reach, `frf_max_force.svg` ([`plot_xy_svg`]), in memory, for the one atomic writer.

use std::path::Path;

use hybrid_core::hybrid::Linearization;
use serde::Serialize;

use crate::Error;
use crate::analysis::frf::{Frf, FrfRequest, Io, LinearRow, NonlinearRow};
use crate::report::plot::{PlotError, plot_receptance_svg, plot_xy_svg};
use crate::report::rows::CsvRows;
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

/// The columns of `frf.csv`: every linear value under its header (`f [Hz]`, `|H|` and phase
/// with the generator and disconnected, real and imaginary parts, the admissible loads).
fn linear_columns(io: &Io, linear: &[LinearRow]) -> Vec<(String, Vec<f64>)> {
    let unit = io.unit();
    let force_unit = io.force_unit;
    let column = |name: String, of: &dyn Fn(&LinearRow) -> f64| -> (String, Vec<f64>) {
        (name, linear.iter().map(of).collect())
    };
    let mut columns = vec![
        column("f [Hz]".into(), &|r| r.f_hz),
        column(format!("|H| with generator [{unit}]"), &|r| {
            r.with_generator.magnitude
        }),
        column("phase with generator [deg]".into(), &|r| {
            r.with_generator.phase_deg
        }),
        column(format!("|H| generator disconnected [{unit}]"), &|r| {
            r.generator_disconnected.magnitude
        }),
        column("phase generator disconnected [deg]".into(), &|r| {
            r.generator_disconnected.phase_deg
        }),
        column(format!("Re H with generator [{unit}]"), &|r| {
            r.with_generator.re
        }),
        column(format!("Im H with generator [{unit}]"), &|r| {
            r.with_generator.im
        }),
        column(format!("Re H generator disconnected [{unit}]"), &|r| {
            r.generator_disconnected.re
        }),
        column(format!("Im H generator disconnected [{unit}]"), &|r| {
            r.generator_disconnected.im
        }),
    ];
    for (k, l) in io.limits.iter().enumerate() {
        let name = if io.limits.len() == 1 {
            format!("max_force [{force_unit}]")
        } else {
            format!("{}.max_force [{force_unit}]", l.name)
        };
        columns.push(column(name, &|r| r.max_force[k]));
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
        columns.push(column(format!("{name}.current [{}]", per("A")), &|r| {
            r.generators[k].current
        }));
        columns.push(column(format!("{name}.voltage [{}]", per("V")), &|r| {
            r.generators[k].voltage
        }));
        columns.push(column(
            format!("{name}.load_power [{}^2]", per("W")),
            &|r| r.generators[k].load_power,
        ));
    }
    columns
}

/// A number as the CSVs print it.
fn number(v: f64) -> String {
    format!("{v:e}")
}

/// A column of `frf_nonlinear.csv`, typed as its cells read.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum NonlinearColumn {
    /// Numbers (`{:e}`); `None`, an empty cell: the run stopped (or did not settle, for
    /// the measured load powers).
    Numbers(Vec<Option<f64>>),
    /// Counts (`periods`).
    Counts(Vec<usize>),
    /// Yes or no (`settled`: `true` / `false`).
    Flags(Vec<bool>),
    /// Text (`error`: why the run stopped; `None`, an empty cell: it did not).
    Texts(Vec<Option<String>>),
}

impl NonlinearColumn {
    /// Row `i`'s cell as the CSV prints it.
    fn cell(&self, i: usize) -> String {
        match self {
            NonlinearColumn::Numbers(v) => v[i].map_or_else(String::new, number),
            NonlinearColumn::Counts(v) => v[i].to_string(),
            NonlinearColumn::Flags(v) => v[i].to_string(),
            NonlinearColumn::Texts(v) => v[i].clone().unwrap_or_default(),
        }
    }
}

/// The columns of `frf_nonlinear.csv`: the frequency, the measured amplitude, `|H|` and
/// phase, the linear ones at the same frequency, periods, settled, distortion, time step,
/// per connected generator the measured and linear load powers, and the error.
fn nonlinear_columns(
    io: &Io,
    linear: &[LinearRow],
    nl: &[NonlinearRow],
) -> Vec<(String, NonlinearColumn)> {
    let unit = io.unit();
    let numbers = |name: String, of: &dyn Fn(&NonlinearRow) -> Option<f64>| {
        (name, NonlinearColumn::Numbers(nl.iter().map(of).collect()))
    };
    let mut columns = vec![
        numbers("f [Hz]".into(), &|r| Some(r.f_hz)),
        numbers(format!("amplitude [{}]", io.response_unit), &|r| {
            r.amplitude
        }),
        numbers(format!("|H| [{unit}]"), &|r| r.magnitude),
        numbers("phase [deg]".into(), &|r| r.phase_deg),
        numbers(format!("|H| linear [{unit}]"), &|r| {
            Some(r.linear.magnitude)
        }),
        numbers("phase linear [deg]".into(), &|r| Some(r.linear.phase_deg)),
        (
            "periods".into(),
            NonlinearColumn::Counts(nl.iter().map(|r| r.periods).collect()),
        ),
        (
            "settled".into(),
            NonlinearColumn::Flags(nl.iter().map(|r| r.settled).collect()),
        ),
        numbers("distortion [-]".into(), &|r| r.distortion),
        numbers("dt [s]".into(), &|r| Some(r.dt)),
    ];
    let names: Vec<&str> = linear
        .first()
        .map(|r| r.generators.iter().map(|g| g.name.as_str()).collect())
        .unwrap_or_default();
    for (k, name) in names.iter().enumerate() {
        columns.push(numbers(format!("{name}.load_power [W]"), &|r| {
            r.load_power.get(k).copied()
        }));
        columns.push(numbers(format!("{name}.load_power linear [W]"), &|r| {
            Some(r.load_power_linear[k])
        }));
    }
    columns.push((
        "error".into(),
        NonlinearColumn::Texts(nl.iter().map(|r| r.error.clone()).collect()),
    ));
    columns
}

/// The CSV of `columns` (`rows` rows, row `i` of a column printed by `cell`) through the
/// one CSV writer.
fn columns_bytes<C>(
    columns: &[(String, C)],
    rows: usize,
    cell: impl Fn(&C, usize) -> String,
) -> Result<Vec<u8>, ReportError> {
    let header: Vec<String> = columns.iter().map(|(h, _)| h.clone()).collect();
    let mut w = CsvRows::new(Vec::new(), &header)?;
    for i in 0..rows {
        let row: Vec<String> = columns.iter().map(|(_, c)| cell(c, i)).collect();
        w.write_text_row(&row)?;
    }
    Ok(w.into_inner()?)
}

impl Frf {
    /// The columns of `frf.csv` (the same headers), one number per frequency.
    pub fn columns(&self) -> Vec<(String, Vec<f64>)> {
        linear_columns(&self.io, &self.linear)
    }

    /// With `nonlinear`, the columns of `frf_nonlinear.csv` (the same headers, the same
    /// values; built by the code that writes the file), one cell per frequency, typed as
    /// the cells read ([`NonlinearColumn`]: numbers with `None` for an empty cell, `periods`
    /// as counts, `settled` as flags, `error` as text).
    pub fn nonlinear_columns(&self) -> Option<Vec<(String, NonlinearColumn)>> {
        let nl = self.nonlinear.as_deref()?;
        Some(nonlinear_columns(&self.io, &self.linear, nl))
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
    let columns = linear_columns(io, linear);
    let mut files = vec![OutputFile {
        path: out.join("frf.csv"),
        bytes: columns_bytes(&columns, linear.len(), |c: &Vec<f64>, i| number(c[i]))
            .map_err(Error::from)?,
    }];
    if let Some(nl) = nonlinear {
        let columns = nonlinear_columns(io, linear, nl);
        files.push(OutputFile {
            path: out.join("frf_nonlinear.csv"),
            bytes: columns_bytes(&columns, nl.len(), NonlinearColumn::cell).map_err(Error::from)?,
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
