//! The files of a complete sweep: `sweep.csv`, `sweep.json` (the same bytes whether the
//! results come from one run or merged parts), the line plots against the first swept
//! field and, with two swept numeric fields, the design map.

use std::path::Path;

use serde::Serialize;
use toml_edit::Value;

use crate::Error;
use crate::analysis::sweep::grid::number;
use crate::analysis::sweep::{Design, Grid, PointResult, SweepSpec, figure_heads, margin};
use crate::report::csv::cell;
use crate::report::rows::{Cells, Table, TableColumn};
use crate::report::{OutputFile, ReportError};
use crate::scenario::overrides::{json_value, value_text};

/// Pretty-printed JSON with a final newline (`null` for an absent figure or no error).
pub fn pretty<T: Serialize>(value: &T) -> Result<Vec<u8>, Error> {
    let mut v = serde_json::to_vec_pretty(value).map_err(ReportError::from)?;
    v.push(b'\n');
    Ok(v)
}

/// `sweep.json`.
#[derive(Serialize)]
struct SweepJson<'a> {
    #[serde(flatten)]
    spec: &'a SweepSpec,
    parameters: Vec<&'a str>,
    figures: Vec<FigureHead<'a>>,
    failed: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    time_domain_failed: Option<usize>,
    /// The best feasible point (`null` when no point satisfies the constraints).
    best: Option<BestJson>,
    points: Vec<PointJson<'a>>,
}

/// The best feasible point of a sweep.
#[derive(Serialize)]
struct BestJson {
    index: usize,
    parameters: Vec<serde_json::Value>,
    figure: String,
    value: f64,
}

#[derive(Serialize)]
struct FigureHead<'a> {
    name: &'a str,
    unit: &'a str,
}

#[derive(Serialize)]
struct PointJson<'a> {
    index: usize,
    parameters: Vec<serde_json::Value>,
    figures: Vec<Option<f64>>,
    error: Option<&'a str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    time_domain_error: Option<&'a str>,
}

/// The files of a complete sweep (`sweep.csv`, `sweep.json`) from the results of every point
/// (in any order); the same bytes whether the results come from one run or merged parts.
pub fn outputs(
    out: &Path,
    spec: &SweepSpec,
    grid: &Grid,
    results: &[PointResult],
) -> Result<Vec<OutputFile>, Error> {
    let mut rows: Vec<&PointResult> = results.iter().collect();
    rows.sort_by_key(|r| r.index);
    if rows.len() != grid.len() || rows.iter().enumerate().any(|(i, r)| r.index != i) {
        return Err(ReportError::Uncovered { points: grid.len() }.into());
    }
    // The figure columns: every figure name in order of first appearance, in grid order.
    let heads = figure_heads(&rows);
    let value_of = |r: &PointResult, name: &str| {
        r.figures
            .iter()
            .find(|f| f.name == name)
            .and_then(|f| f.value)
    };
    let design = Design::of(spec, &rows)?;
    let csv = table(grid, spec.time_domain, &rows)
        .csv(&|x| cell(Some(x)))
        .map_err(|e| Error::from(ReportError::from(e)))?;
    let points = rows
        .iter()
        .map(|r| PointJson {
            index: r.index,
            parameters: grid.point(r.index).iter().map(|v| json_value(v)).collect(),
            figures: heads.iter().map(|(n, _)| value_of(r, n)).collect(),
            error: r.error.as_deref(),
            time_domain_error: r.time_domain_error.as_deref(),
        })
        .collect();
    let json = SweepJson {
        spec,
        parameters: grid.axes.iter().map(|a| a.path.as_str()).collect(),
        figures: heads
            .iter()
            .map(|(name, unit)| FigureHead { name, unit })
            .collect(),
        failed: rows.iter().filter(|r| r.error.is_some()).count(),
        best: design.best.map(|(index, value)| BestJson {
            index,
            parameters: grid.point(index).iter().map(|v| json_value(v)).collect(),
            figure: spec.map.clone(),
            value,
        }),
        time_domain_failed: spec.time_domain.then(|| {
            rows.iter()
                .filter(|r| r.time_domain_error.is_some())
                .count()
        }),
        points,
    };
    let mut files = vec![
        OutputFile {
            path: out.join("sweep.csv"),
            bytes: csv,
        },
        OutputFile {
            path: out.join("sweep.json"),
            bytes: pretty(&json)?,
        },
    ];
    files.extend(plots(out, spec, grid, &rows)?);
    files.extend(design_map(out, spec, grid, &rows, &design)?);
    Ok(files)
}

/// The table of `sweep.csv` (what Python's `Scenario.sweep` returns): `index`, each swept
/// PATH (its values as written), every figure under its name and unit in order of first
/// appearance over `rows` (in grid order; an empty cell where a point does not give it),
/// `error` and, with `time_domain`, `time_domain_error`; one row per point of `rows`, in
/// their order.
pub fn table(grid: &Grid, time_domain: bool, rows: &[&PointResult]) -> Table {
    let mut columns = vec![TableColumn::new(
        "index",
        None,
        Cells::Counts(rows.iter().map(|r| r.index).collect()),
    )];
    for (k, axis) in grid.axes.iter().enumerate() {
        let values = rows
            .iter()
            .map(|r| grid.point(r.index)[k].clone())
            .collect();
        columns.push(TableColumn::new(&axis.path, None, Cells::Values(values)));
    }
    for (name, unit) in figure_heads(rows) {
        let values = rows
            .iter()
            .map(|r| {
                r.figures
                    .iter()
                    .find(|f| f.name == name)
                    .and_then(|f| f.value)
            })
            .collect();
        columns.push(TableColumn::new(name, Some(unit), Cells::Numbers(values)));
    }
    let texts = |of: &dyn Fn(&PointResult) -> Option<String>| {
        Cells::Texts(rows.iter().map(|r| of(r)).collect())
    };
    columns.push(TableColumn::new("error", None, texts(&|r| r.error.clone())));
    if time_domain {
        columns.push(TableColumn::new(
            "time_domain_error",
            None,
            texts(&|r| r.time_domain_error.clone()),
        ));
    }
    Table::new(columns)
}

/// `sweep_map_<FIGURE>.svg` of a sweep with exactly two swept fields of more than one
/// numeric, monotonic value ([`crate::report::map`]): the map's figure over the grid, the
/// contour of every constraint, the infeasible points hatched, the best feasible point
/// marked. None otherwise.
fn design_map(
    out: &Path,
    spec: &SweepSpec,
    grid: &Grid,
    rows: &[&PointResult],
    design: &Design,
) -> Result<Option<OutputFile>, Error> {
    use crate::report::map::{DesignMap, MapAxis, is_monotonic, plot_map_svg};
    use crate::report::plot::tick_label;
    let varying: Vec<usize> = (0..grid.axes.len())
        .filter(|&a| grid.axes[a].values.len() > 1)
        .collect();
    let [ax, ay] = varying[..] else {
        return Ok(None);
    };
    let values = |a: usize| -> Option<Vec<f64>> {
        grid.axes[a]
            .values
            .iter()
            .map(number)
            .collect::<Option<Vec<f64>>>()
    };
    let (Some(xs), Some(ys)) = (values(ax), values(ay)) else {
        return Ok(None);
    };
    if !(is_monotonic(&xs) && is_monotonic(&ys)) {
        return Ok(None);
    }
    // Grid index of (i, j): the other axes have one value each.
    let stride =
        |a: usize| -> usize { grid.axes[a + 1..].iter().map(|x| x.values.len()).product() };
    let (sx, sy) = (stride(ax), stride(ay));
    let at = |i: usize, j: usize| i * sx + j * sy;
    let (nx, ny) = (xs.len(), ys.len());
    let per_point = |f: &dyn Fn(&PointResult) -> Option<f64>| -> Vec<Option<f64>> {
        (0..nx)
            .flat_map(|i| (0..ny).map(move |j| (i, j)))
            .map(|(i, j)| f(rows[at(i, j)]))
            .collect()
    };
    let map_values = per_point(&|r| {
        r.figures
            .iter()
            .find(|f| f.name == spec.map)
            .and_then(|f| f.value)
    });
    if map_values.iter().all(Option::is_none) {
        return Ok(None);
    }
    let feasible: Vec<bool> = (0..nx)
        .flat_map(|i| (0..ny).map(move |j| (i, j)))
        .map(|(i, j)| design.feasible[at(i, j)])
        .collect();
    let contours: Vec<(String, Vec<Option<f64>>)> = design
        .constraints
        .iter()
        .map(|c| (c.text.clone(), per_point(&|r| margin(c, r))))
        .collect();
    // The figure's unit as its column has it; numbers in the legend to 4 digits.
    let unit = figure_heads(rows)
        .into_iter()
        .find(|(n, _)| *n == spec.map)
        .map_or("-", |(_, u)| u);
    let short = |v: &Value| number(v).map_or_else(|| value_text(v), tick_label);
    let best_label;
    let best = match design.best {
        Some((index, value)) => {
            let p = grid.point(index);
            let (bx, by) = (number(p[ax]), number(p[ay]));
            best_label = format!(
                "{} = {}, {} = {}: {} = {}{}",
                grid.axes[ax].path,
                short(p[ax]),
                grid.axes[ay].path,
                short(p[ay]),
                spec.map,
                tick_label(value),
                if unit == "-" {
                    String::new()
                } else {
                    format!(" {unit}")
                }
            );
            bx.zip(by).map(|b| (b, best_label.as_str()))
        }
        None => None,
    };
    let fixed = grid.fixed_text();
    let title = format!(
        "{} over {} and {}: {}{}",
        spec.map,
        grid.axes[ax].path,
        grid.axes[ay].path,
        spec.scenario,
        if fixed.is_empty() {
            String::new()
        } else {
            format!(" ({fixed})")
        }
    );
    let (x_label, y_label) = (
        crate::scenario::units::field_label(&grid.axes[ax].path),
        crate::scenario::units::field_label(&grid.axes[ay].path),
    );
    let figure = format!("{} [{unit}]", spec.map);
    let bytes = plot_map_svg(&DesignMap {
        title: &title,
        x: MapAxis {
            label: &x_label,
            values: &xs,
        },
        y: MapAxis {
            label: &y_label,
            values: &ys,
        },
        figure: &figure,
        values: &map_values,
        feasible: &feasible,
        contours: &contours,
        best,
    })
    .map_err(ReportError::from)?;
    Ok(Some(OutputFile {
        path: out.join(format!("sweep_map_{}.svg", spec.map)),
        bytes,
    }))
}

/// Most lines of a sweep's line plots: a sweep with more combinations of its other varying
/// fields draws its design map instead (two fields) or no line plot.
const MAX_LINES: usize = 10;

/// A figure read from a point's results.
type FigureOf<'a> = dyn Fn(&PointResult) -> Option<f64> + 'a;

/// The plots of a sweep against its first swept parameter (when its values are numbers),
/// one line per combination of the other parameters: `sweep_damping.svg` (first-mode damping
/// ratio with the generator, disconnected, and from the time domain when run),
/// `sweep_frequency.svg` (first-mode frequency, the same variants and the bare beam) and,
/// with `--time-domain`, `sweep_harvested.svg` (the fraction of the dissipated energy
/// harvested in the load). Failed points are left out of the lines.
fn plots(
    out: &Path,
    spec: &SweepSpec,
    grid: &Grid,
    rows: &[&PointResult],
) -> Result<Vec<OutputFile>, Error> {
    // The x axis: the first swept field with more than one value (a fixed `--set` is
    // never an axis); one line per combination of the other varying fields.
    let varying: Vec<usize> = (0..grid.axes.len())
        .filter(|&a| grid.axes[a].values.len() > 1)
        .collect();
    let Some((&x_axis, others)) = varying.split_first() else {
        return Ok(vec![]);
    };
    let axis = &grid.axes[x_axis];
    if axis.values.iter().any(|v| number(v).is_none()) {
        return Ok(vec![]);
    }
    let lines: usize = others.iter().map(|&a| grid.axes[a].values.len()).product();
    if lines > MAX_LINES {
        return Ok(vec![]);
    }
    let value = |r: &PointResult, name: &str| {
        r.figures
            .iter()
            .find(|f| f.name == name)
            .and_then(|f| f.value)
    };
    // Groups: the values of the other axes, in grid order.
    let mut groups: Vec<(String, Vec<&PointResult>)> = vec![];
    for r in rows {
        let values = grid.point(r.index);
        let key: Vec<String> = others
            .iter()
            .map(|&a| format!("{}={}", grid.axes[a].path, value_text(values[a])))
            .collect();
        let key = key.join(", ");
        match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, g)) => g.push(r),
            None => groups.push((key, vec![r])),
        }
    }
    let x_of = |r: &PointResult| number(grid.point(r.index)[x_axis]).expect("checked numeric");
    let line = |g: &[&PointResult], f: &dyn Fn(&PointResult) -> Option<f64>| -> Vec<(f64, f64)> {
        g.iter()
            .filter_map(|r| f(r).map(|y| (x_of(r), y)))
            .collect()
    };
    let label = |key: &str, what: &str| {
        if key.is_empty() {
            what.to_string()
        } else {
            format!("{key}: {what}")
        }
    };
    let log_x = axis.path.ends_with("resistance");
    let fixed = grid.fixed_text();
    let title = |what: &str| {
        if fixed.is_empty() {
            format!("{what} vs {}: {}", axis.path, spec.scenario)
        } else {
            format!("{what} vs {}: {} ({fixed})", axis.path, spec.scenario)
        }
    };
    let x_label = crate::scenario::units::field_label(&axis.path);
    let mut files = vec![];
    let mut draw = |file: &str,
                    what: &str,
                    y_desc: &str,
                    variants: &[(&str, &FigureOf<'_>)]|
     -> Result<(), Error> {
        let mut series: Vec<(String, Vec<(f64, f64)>)> = vec![];
        for (key, g) in &groups {
            for (name, f) in variants {
                let pts = line(g, *f);
                if !pts.is_empty() {
                    series.push((label(key, name), pts));
                }
            }
        }
        if series.is_empty() {
            return Ok(());
        }
        let refs: Vec<(&str, &[(f64, f64)])> =
            series.iter().map(|(l, p)| (l.as_str(), &p[..])).collect();
        let bytes = crate::report::plot::plot_xy_svg(
            &title(what),
            &x_label,
            y_desc,
            &refs,
            (log_x, false),
            true,
        )
        .map_err(ReportError::from)?;
        files.push(OutputFile {
            path: out.join(file),
            bytes,
        });
        Ok(())
    };
    let pct = |name: &'static str| move |r: &PointResult| value(r, name).map(|z| 100.0 * z);
    let (zw, zd, zt) = (
        pct("linear.zeta1"),
        pct("linear.zeta1_generator_disconnected"),
        pct("damping_ratio"),
    );
    draw(
        "sweep_damping.svg",
        "First-mode damping ratio",
        "damping ratio [%]",
        &[
            ("with generator (linearised)", &zw),
            ("generator disconnected (linearised)", &zd),
            ("with generator (time domain, filtered decay)", &zt),
        ],
    )?;
    let hz = |name: &'static str| move |r: &PointResult| value(r, name);
    let (fw, fd, fb) = (
        hz("linear.f1"),
        hz("linear.f1_generator_disconnected"),
        hz("linear.f1_bare_beam"),
    );
    draw(
        "sweep_frequency.svg",
        "First-mode natural frequency",
        "frequency [Hz]",
        &[
            ("with generator", &fw),
            ("generator disconnected (mechanism + rotor attached)", &fd),
            ("bare beam (no mechanism)", &fb),
        ],
    )?;
    let harvested = |r: &PointResult| {
        let h = value(r, "energy.harvested_in_load")?;
        let d =
            value(r, "energy.dissipated_generators")? + value(r, "energy.dissipated_structure")?;
        (d > 0.0).then(|| 100.0 * h / d)
    };
    draw(
        "sweep_harvested.svg",
        "Energy harvested in the load / energy dissipated (time domain)",
        "harvested fraction [%]",
        &[("harvested in the load", &harvested)],
    )?;
    Ok(files)
}
