//! The plots of a run (plotters, SVG backend, no system fonts needed): displacements
//! against time — a run's beam points and those of its comparison runs —, the damping ratio
//! of each cycle against its amplitude, a mechanism's coordinates against time, a figure
//! against a swept parameter, and receptances against frequency (`damper frf`).
//!
//! Every plot has its main settings in the title and its legend in a band below the plot
//! area (the receptance plot: in a panel right of it), never on the traces.

use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

/// The plot could not be drawn (plotters' message).
#[derive(Debug, thiserror::Error)]
#[error("cannot draw the plot: {0}")]
pub struct PlotError(String);

impl PlotError {
    /// Plotters' message.
    pub fn message(&self) -> &str {
        &self.0
    }

    pub(crate) fn of<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> PlotError {
        PlotError(e.to_string())
    }
}

/// Size of every plot (pixels).
const WIDTH: u32 = 1000;
/// Height of the plot area, without the legend band (pixels).
const HEIGHT: u32 = 500;
/// Height of one legend row (pixels).
const LEGEND_ROW: u32 = 22;

const COLORS: [RGBColor; 10] = [
    RGBColor(200, 30, 30),
    RGBColor(30, 80, 200),
    RGBColor(20, 140, 60),
    RGBColor(150, 60, 170),
    RGBColor(200, 130, 0),
    RGBColor(0, 150, 170),
    RGBColor(120, 80, 30),
    RGBColor(230, 90, 160),
    RGBColor(90, 90, 90),
    RGBColor(150, 170, 20),
];

fn color(k: usize) -> RGBColor {
    COLORS[k % COLORS.len()]
}

/// The most characters of a legend row or a title line (15 px and 18 px sans-serif across
/// the 1000 px figure, right of the legend's swatch): longer texts wrap at spaces.
pub(crate) const LINE_CHARS: usize = 100;

/// `text` broken at spaces into lines of at most `max` characters (a word longer than
/// `max` stands on a line of its own; `name = value` is never split at its `=`); at least
/// one line.
pub(crate) fn wrap(text: &str, max: usize) -> Vec<String> {
    const GLUE: char = '\u{a0}';
    let glued = text.replace(" = ", "\u{a0}=\u{a0}");
    let mut lines: Vec<String> = vec![];
    let mut line = String::new();
    for word in glued.split(' ').filter(|w| !w.is_empty()) {
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > max {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    lines.push(line);
    lines.into_iter().map(|l| l.replace(GLUE, " ")).collect()
}

/// Draws `title` centred at the top of `area`, wrapped (18 px; `LINE_CHARS` less a fifth a
/// line), and returns the area below it for the chart.
pub(crate) fn titled<'a>(
    area: &DrawingArea<SVGBackend<'a>, Shift>,
    title: &str,
) -> Result<DrawingArea<SVGBackend<'a>, Shift>, PlotError> {
    let lines = wrap(title, LINE_CHARS * 4 / 5);
    let width = area.dim_in_pixel().0 as i32;
    let style = TextStyle::from(("sans-serif", 18).into_font()).pos(
        plotters::style::text_anchor::Pos::new(
            plotters::style::text_anchor::HPos::Center,
            plotters::style::text_anchor::VPos::Top,
        ),
    );
    for (k, line) in lines.iter().enumerate() {
        area.draw(&Text::new(
            line.clone(),
            (width / 2, 8 + 22 * k as i32),
            style.clone(),
        ))
        .map_err(PlotError::of)?;
    }
    let (_, below) = area.split_vertically(14 + 22 * lines.len() as u32);
    Ok(below)
}

/// Draws `draw` on a plot area above a legend band with one row per label line (labels
/// longer than [`LINE_CHARS`] wrap onto indented rows without a swatch), and returns the
/// SVG text.
fn with_legend(
    labels: &[&str],
    draw: impl FnOnce(&DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), PlotError>,
) -> Result<Vec<u8>, PlotError> {
    let swatches: Vec<(&str, RGBColor)> = labels
        .iter()
        .enumerate()
        .map(|(k, l)| (*l, color(k)))
        .collect();
    with_swatches(&swatches, draw)
}

/// [`with_legend`] with each label's swatch in a colour of its own.
pub(crate) fn with_swatches(
    labels: &[(&str, RGBColor)],
    draw: impl FnOnce(&DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), PlotError>,
) -> Result<Vec<u8>, PlotError> {
    let rows: Vec<(Option<RGBColor>, String)> = labels
        .iter()
        .flat_map(|(label, c)| {
            wrap(label, LINE_CHARS)
                .into_iter()
                .enumerate()
                .map(move |(i, line)| ((i == 0).then_some(*c), line))
        })
        .collect();
    let mut svg = String::new();
    {
        let band = 10 + LEGEND_ROW * rows.len() as u32;
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT + band)).into_drawing_area();
        root.fill(&WHITE).map_err(PlotError::of)?;
        let (plot, legend) = root.split_vertically(HEIGHT);
        draw(&plot)?;
        for (row, (series, line)) in rows.iter().enumerate() {
            let y = 5 + (LEGEND_ROW * row as u32 + LEGEND_ROW / 2) as i32;
            if let Some(c) = series {
                legend
                    .draw(&PathElement::new(
                        vec![(80, y), (120, y)],
                        c.stroke_width(2),
                    ))
                    .map_err(PlotError::of)?;
            }
            let indent = if series.is_some() { 130 } else { 150 };
            legend
                .draw(&Text::new(
                    line.clone(),
                    (indent, y - 8),
                    ("sans-serif", 15).into_font(),
                ))
                .map_err(PlotError::of)?;
        }
        root.present().map_err(PlotError::of)?;
    }
    Ok(svg.into_bytes())
}

/// SVG plot of displacements `(t (s), y (m))`, drawn in mm against time, one line per
/// labelled series (the first on top).
pub fn plot_displacements_svg(
    title: &str,
    y_desc: &str,
    series: &[(&str, &[(f64, f64)])],
) -> Result<Vec<u8>, PlotError> {
    let mm: Vec<(&str, Vec<(f64, f64)>)> = series
        .iter()
        .map(|(l, s)| (*l, s.iter().map(|&(t, y)| (t, y * 1e3)).collect()))
        .collect();
    let mm: Vec<(&str, &[(f64, f64)])> = mm.iter().map(|(l, p)| (*l, &p[..])).collect();
    plot_series_svg(title, y_desc, &mm)
}

/// The extent `(x0, x1, y0, y1)` of the finite points of `series` (infinities when there is
/// none: the callers fall back to a default range).
fn extent(series: &[(&str, &[(f64, f64)])]) -> (f64, f64, f64, f64) {
    series
        .iter()
        .flat_map(|(_, s)| s.iter())
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .fold(
            (
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
            ),
            |(x0, x1, y0, y1), p| (x0.min(p.0), x1.max(p.0), y0.min(p.1), y1.max(p.1)),
        )
}

/// SVG plot of series `(t (s), y)` against time, one line per labelled series (the first on
/// top), the y axis symmetric about zero when the data change sign.
pub fn plot_series_svg(
    title: &str,
    y_desc: &str,
    series: &[(&str, &[(f64, f64)])],
) -> Result<Vec<u8>, PlotError> {
    let labels: Vec<&str> = series.iter().map(|s| s.0).collect();
    with_legend(&labels, |area| {
        let (t0, t1, lo, hi) = extent(series);
        let (t0, t1) = if t0 < t1 { (t0, t1) } else { (0.0, 1e-9) };
        let (lo, hi) = if lo <= hi { (lo, hi) } else { (-1.0, 1.0) };
        let (lo, hi) = if lo < 0.0 && hi > 0.0 {
            let m = lo.abs().max(hi) * 1.05;
            (-m, m)
        } else {
            let pad = ((hi - lo) * 0.05).max(1e-9 * hi.abs().max(1e-300));
            (lo - pad, hi + pad)
        };
        let below = titled(area, title)?;
        let mut chart = ChartBuilder::on(&below)
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(linear(t0, t1), linear(lo, hi))
            .map_err(PlotError::of)?;
        chart
            .configure_mesh()
            .x_desc("time [s]")
            .y_desc(y_desc)
            .x_label_formatter(&|v| tick_label(*v))
            .y_label_formatter(&|v| tick_label(*v))
            .draw()
            .map_err(PlotError::of)?;
        // Drawn last to first, so that the first series is on top.
        for (k, (_, points)) in series.iter().enumerate().rev() {
            chart
                .draw_series(LineSeries::new(
                    points.iter().copied().filter(|p| p.1.is_finite()),
                    color(k).stroke_width(1),
                ))
                .map_err(PlotError::of)?;
        }
        Ok(())
    })
}

/// Whether `lo..hi` can be drawn on a logarithmic axis: both normal positive numbers, `lo <
/// hi`, at most 60 decades apart (plotters' logarithmic key points never end on subnormal
/// or overflowing bounds, and more decades are unreadable anyway).
fn log_range(lo: f64, hi: f64) -> bool {
    lo >= f64::MIN_POSITIVE && hi > lo && hi < f64::MAX / 2.0 && (hi / lo).log10() <= 60.0
}

/// SVG plot of the damping ratio of each cycle (%) against the cycle's amplitude (mm, log
/// scale), one marked line per labelled run (`(amplitude (m), zeta)` points).
pub fn plot_damping_vs_amplitude_svg(
    title: &str,
    series: &[(&str, &[(f64, f64)])],
) -> Result<Vec<u8>, PlotError> {
    let labels: Vec<&str> = series.iter().map(|s| s.0).collect();
    with_legend(&labels, |area| {
        let all = || series.iter().flat_map(|(_, s)| s.iter());
        let a_lo = all().map(|p| p.0 * 1e3).fold(f64::INFINITY, f64::min);
        let a_hi = all().map(|p| p.0 * 1e3).fold(f64::NEG_INFINITY, f64::max);
        let (a_lo, a_hi) = if log_range(a_lo, a_hi) {
            (a_lo / 1.2, a_hi * 1.2)
        } else if (f64::MIN_POSITIVE..f64::MAX / 2.0).contains(&a_lo) {
            (a_lo / 2.0, a_lo * 2.0)
        } else {
            (1e-3, 1.0)
        };
        let (a_lo, a_hi) = log_span(a_lo, a_hi);
        let z_hi = all().map(|p| p.1 * 100.0).fold(0.0, f64::max);
        let z_lo = all().map(|p| p.1 * 100.0).fold(0.0, f64::min);
        let z_hi = if z_hi > z_lo { z_hi * 1.1 } else { 1.0 };
        let below = titled(area, title)?;
        let mut chart = ChartBuilder::on(&below)
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                (a_lo..a_hi)
                    .log_scale()
                    .with_key_points(log_ticks(a_lo, a_hi)),
                linear(z_lo, z_hi),
            )
            .map_err(PlotError::of)?;
        chart
            .configure_mesh()
            .x_desc("cycle amplitude of the tip [mm] (geometric mean of its bounding peaks)")
            .y_desc("damping ratio of the cycle [%]")
            .x_label_formatter(&|v| tick_label(*v))
            .y_label_formatter(&|v| tick_label(*v))
            .draw()
            .map_err(PlotError::of)?;
        for (k, (_, points)) in series.iter().enumerate().rev() {
            let c = color(k);
            let pts: Vec<(f64, f64)> = points.iter().map(|&(a, z)| (a * 1e3, z * 100.0)).collect();
            chart
                .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(1)))
                .map_err(PlotError::of)?;
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled())))
                .map_err(PlotError::of)?;
        }
        Ok(())
    })
}

/// SVG plot of labelled series of points `(x, y)` joined by lines, with markers when
/// `markers` (a parameter study: a figure against a swept parameter; lines alone for a
/// spectrum's thousands of points); an axis logarithmic when asked (`(log_x, log_y)`) and
/// its every value is positive. Series with fewer than one finite point are left out of
/// the plot area but keep their legend row.
pub fn plot_xy_svg(
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[(&str, &[(f64, f64)])],
    (log_x, log_y): (bool, bool),
    markers: bool,
) -> Result<Vec<u8>, PlotError> {
    let labels: Vec<&str> = series.iter().map(|s| s.0).collect();
    with_legend(&labels, |area| {
        let (x0, x1, y_lo, y_hi) = extent(series);
        let pad = |lo: f64, hi: f64| {
            if lo < hi {
                let p = 0.05 * (hi - lo);
                (lo - p, hi + p)
            } else if lo.is_finite() {
                let p = 0.05 * lo.abs().max(1e-12);
                (lo - p, lo + p)
            } else {
                (0.0, 1.0)
            }
        };
        let (y0, y1) = pad(y_lo, y_hi);
        let draw_points = |k: usize, pts: &[(f64, f64)]| {
            pts.iter()
                .copied()
                .filter(|p| markers && p.0.is_finite() && p.1.is_finite())
                .map(move |p| Circle::new(p, 3, color(k).filled()))
                .collect::<Vec<_>>()
        };
        let finite_line = |pts: &[(f64, f64)]| {
            pts.iter()
                .copied()
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .collect::<Vec<_>>()
        };
        // The same chart on logarithmic or linear axes (different coordinate types).
        macro_rules! chart_on {
            ($x:expr, $y:expr) => {{
                let below = titled(area, title)?;
                let mut chart = ChartBuilder::on(&below)
                    .margin(15)
                    .x_label_area_size(40)
                    .y_label_area_size(80)
                    .build_cartesian_2d($x, $y)
                    .map_err(PlotError::of)?;
                chart
                    .configure_mesh()
                    .x_desc(x_desc)
                    .y_desc(y_desc)
                    .x_label_formatter(&|v| tick_label(*v))
                    .y_label_formatter(&|v| tick_label(*v))
                    .draw()
                    .map_err(PlotError::of)?;
                for (k, (_, pts)) in series.iter().enumerate().rev() {
                    chart
                        .draw_series(LineSeries::new(finite_line(pts), color(k).stroke_width(1)))
                        .map_err(PlotError::of)?;
                    chart
                        .draw_series(draw_points(k, pts))
                        .map_err(PlotError::of)?;
                }
            }};
        }
        let log_y = log_y && log_range(y_lo, y_hi);
        let y_log = || {
            let (a, b) = log_span(y_lo / 1.2, y_hi * 1.2);
            (a..b).log_scale().with_key_points(log_ticks(a, b))
        };
        if log_x && log_range(x0, x1) {
            let (a, b) = log_span(x0 / 1.1, x1 * 1.1);
            let x = (a..b).log_scale().with_key_points(log_ticks(a, b));
            if log_y {
                chart_on!(x, y_log());
            } else {
                chart_on!(x, linear(y0, y1));
            }
        } else {
            let (x0, x1) = pad(x0, x1);
            if log_y {
                chart_on!(linear(x0, x1), y_log());
            } else {
                chart_on!(linear(x0, x1), linear(y0, y1));
            }
        }
        Ok(())
    })
}

/// SVG plot of receptances against frequency (Hz, from `from` to `to`: a linear axis, or a
/// logarithmic one with 1-2-5 ticks when `log`): `|H|` (`unit`) on a log axis, the linear
/// responses with the generator and with it disconnected as lines (`(f, |H|)` points), the
/// nonlinear steady states as markers (`(f, |H|, settled)`: filled when settled); the
/// legend in a panel of its own right of the chart (off the traces).
pub fn plot_receptance_svg(
    title: &str,
    unit: &str,
    (from, to, log): (f64, f64, bool),
    with_generator: &[(f64, f64)],
    disconnected: &[(f64, f64)],
    nonlinear: Option<&[(f64, f64, bool)]>,
) -> Result<Vec<u8>, PlotError> {
    if log {
        receptance_on(
            title,
            unit,
            {
                let (from, to) = log_span(from, to);
                (from..to).log_scale().with_key_points(log_ticks(from, to))
            },
            with_generator,
            disconnected,
            nonlinear,
        )
    } else {
        receptance_on(
            title,
            unit,
            linear(from, to),
            with_generator,
            disconnected,
            nonlinear,
        )
    }
}

/// Tick values of a log axis over `[a, b]` (`0 < a < b`): the 1-2-5 values of every
/// decade, thinned to the decades, then to every k-th decade, when they would give more
/// than 12 ticks; only 1-2-5 values (widen a narrow axis with [`log_span`] first).
pub(crate) fn log_ticks(a: f64, b: f64) -> Vec<f64> {
    // Not a logarithmic range (a bound at or below zero, not finite, reversed): no ticks —
    // never a loop over the decades down to log10(0).
    if !(a > 0.0 && a <= b && b.is_finite()) {
        return vec![];
    }
    let (lo, hi) = (a.log10().floor() as i32, b.log10().ceil() as i32);
    let inside = |mantissas: &[f64], every: usize| -> Vec<f64> {
        (lo..=hi)
            .filter(|e| e.rem_euclid(every as i32) == 0)
            .flat_map(|e| mantissas.iter().map(move |m| m * 10f64.powi(e)))
            .filter(|v| *v >= a * (1.0 - 1e-12) && *v <= b * (1.0 + 1e-12))
            .collect()
    };
    let ticks = inside(&[1.0, 2.0, 5.0], 1);
    if ticks.len() <= 12 {
        return ticks;
    }
    // At most 61 decades (`log_range`): every k-th one, k = 1..=6, gives at most 12.
    (1..=6)
        .map(|every| inside(&[1.0], every))
        .find(|t| t.len() <= 12)
        .unwrap_or_default()
}

/// `[a, b]` widened, when fewer than two 1-2-5 values fall inside, to the nearest 1-2-5
/// values around it, so that a log axis has at least two ticks ([`log_ticks`]); `(a, b)`
/// unchanged when it is not a logarithmic range.
pub(crate) fn log_span(a: f64, b: f64) -> (f64, f64) {
    if !log_range(a, b) || log_ticks(a, b).len() >= 2 {
        return (a, b);
    }
    let below = |v: f64| {
        let e = v.log10().floor() as i32;
        [5.0, 2.0, 1.0]
            .iter()
            .map(|m| m * 10f64.powi(e))
            .find(|t| *t <= v * (1.0 + 1e-12))
            .unwrap_or(10f64.powi(e))
    };
    let above = |v: f64| {
        let e = v.log10().floor() as i32;
        [1.0, 2.0, 5.0, 10.0]
            .iter()
            .map(|m| m * 10f64.powi(e))
            .find(|t| *t >= v * (1.0 - 1e-12))
            .unwrap_or(10f64.powi(e + 1))
    };
    let (a, b) = (below(a), above(b));
    if log_ticks(a, b).len() >= 2 {
        (a, b)
    } else {
        // [a, a]: one 1-2-5 value; the next one up.
        (a, above(b * 1.5))
    }
}

/// A linear axis over `lo..hi` ticked at [`linear_ticks`] (exact multiples of a 1-2-5 step,
/// so zero is `0`, never `-0.0` or `5.6e-17`).
pub(crate) fn linear(lo: f64, hi: f64) -> Ticked {
    Ticked {
        range: lo..hi,
        ticks: linear_ticks(lo, hi),
    }
}

/// A tick label: at most four significant digits, no trailing zeros (`2`, `0.5`, `12.5`);
/// scientific outside [1e-3, 1e6), its mantissa trimmed the same way (`1.5e-5`, `2e7`).
pub(crate) fn tick_label(v: f64) -> String {
    fn trimmed(s: &str) -> &str {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.')
        } else {
            s
        }
    }
    if v == 0.0 {
        return "0".to_string();
    }
    if !v.is_finite() {
        return format!("{v}");
    }
    if !(-3..6).contains(&(v.abs().log10().floor() as i32)) {
        let s = format!("{v:.3e}");
        let (mantissa, exponent) = s.split_once('e').unwrap_or((&s, "0"));
        return format!("{}e{exponent}", trimmed(mantissa));
    }
    let digits = (3 - v.abs().log10().floor() as i32).clamp(0, 12) as usize;
    trimmed(&format!("{v:.digits$}")).to_string()
}

/// A linear axis `range` whose ticks (labels and bold mesh lines) are `ticks`: plotters'
/// own key points are for decimal ranges, and a geometric axis drawn in `ln v` needs the
/// 1-2-5 values at their logarithms.
pub(crate) struct Ticked {
    /// The axis.
    pub range: std::ops::Range<f64>,
    /// The tick values, inside `range`.
    pub ticks: Vec<f64>,
}

impl Ranged for Ticked {
    type FormatOption = plotters::coord::ranged1d::DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let r = &self.range;
        let t = (value - r.start) / (r.end - r.start);
        limit.0 + (t * f64::from(limit.1 - limit.0)).round() as i32
    }

    fn key_points<Hint: plotters::coord::ranged1d::KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        // The light mesh lines asked for by plotters are left out; labels go on the ticks.
        if hint.max_num_points() == 0 || hint.weight().allow_light_points() {
            return vec![];
        }
        self.ticks.clone()
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.range.clone()
    }
}

/// Tick values of a linear axis over `[a, b]` (`a < b`): the multiples inside it of the
/// 1-2-5 step that gives 4 to 10 ticks.
pub(crate) fn linear_ticks(a: f64, b: f64) -> Vec<f64> {
    if !(a.is_finite() && b.is_finite() && a < b) {
        return vec![];
    }
    let exponent = ((b - a) / 4.0).log10().floor() as i32;
    // k m 10^e, computed as (k m) / 10^-e for e < 0 so that 0.6 prints as 0.6.
    let value = |k: i64, m: f64| {
        if exponent >= 0 {
            k as f64 * m * 10f64.powi(exponent)
        } else {
            k as f64 * m / 10f64.powi(-exponent)
        }
    };
    let m = [5.0, 2.0, 1.0, 0.5]
        .into_iter()
        .find(|&m| (b - a) / value(1, m) >= 4.0)
        .unwrap_or(1.0);
    let step = value(1, m);
    let first = (a / step).ceil() as i64;
    let last = (b / step).floor() as i64;
    (first..=last.min(first + 20))
        .map(|k| value(k, m))
        .collect()
}

/// The SVG plot: `|H|` on a log axis against frequency (`x`: a linear or log range), the
/// linear responses as lines, the nonlinear steady states as markers; the legend in a panel
/// of its own right of the chart (off the traces).
fn receptance_on<X>(
    title: &str,
    unit: &str,
    x: X,
    with_generator: &[(f64, f64)],
    disconnected: &[(f64, f64)],
    nonlinear: Option<&[(f64, f64, bool)]>,
) -> Result<Vec<u8>, PlotError>
where
    X: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
{
    let err = |e: &dyn std::fmt::Display| PlotError(e.to_string());
    let mut values: Vec<f64> = with_generator
        .iter()
        .zip(disconnected)
        .flat_map(|(a, b)| [a.1, b.1])
        .chain(nonlinear.into_iter().flatten().map(|r| r.1))
        .filter(|v| *v > 0.0 && v.is_finite())
        .collect();
    if values.is_empty() {
        values.push(1.0);
    }
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min) / 1.5;
    let hi = values.iter().copied().fold(0.0, f64::max) * 1.5;
    let (lo, hi) = log_span(lo, hi);
    let red = RGBColor(200, 30, 30);
    let blue = RGBColor(30, 80, 200);
    let black = RGBColor(0, 0, 0);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1100, 560)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let root = titled(&root, title)?;
        let (left, right) = root.split_horizontally(840);
        let mut chart = ChartBuilder::on(&left)
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(x, (lo..hi).log_scale().with_key_points(log_ticks(lo, hi)))
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("frequency [Hz]")
            .x_labels(12)
            .x_label_formatter(&|v| tick_label(*v))
            .y_desc(format!("|H| [{unit}]"))
            .y_label_formatter(&|v| tick_label(*v))
            .draw()
            .map_err(|e| err(&e))?;
        chart
            .draw_series(LineSeries::new(
                disconnected.iter().copied(),
                blue.stroke_width(2),
            ))
            .map_err(|e| err(&e))?;
        chart
            .draw_series(LineSeries::new(
                with_generator.iter().copied(),
                red.stroke_width(2),
            ))
            .map_err(|e| err(&e))?;
        if let Some(nl) = nonlinear {
            chart
                .draw_series(nl.iter().filter(|p| p.1 > 0.0).map(|&(f, m, settled)| {
                    Circle::new(
                        (f, m),
                        4,
                        if settled {
                            black.filled()
                        } else {
                            black.stroke_width(1)
                        },
                    )
                }))
                .map_err(|e| err(&e))?;
        }
        // The legend, in its own panel.
        let mut entries: Vec<(&str, ShapeStyle, bool)> = vec![
            ("linear, with generator", red.stroke_width(2), false),
            (
                "linear, generator disconnected",
                blue.stroke_width(2),
                false,
            ),
        ];
        if nonlinear.is_some() {
            entries.push(("nonlinear steady state", black.filled(), true));
            entries.push(("(open: not settled)", black.stroke_width(1), true));
        }
        for (k, (label, style, marker)) in entries.into_iter().enumerate() {
            let y = 40 + 26 * k as i32;
            if marker {
                right
                    .draw(&Circle::new((18, y), 4, style))
                    .map_err(|e| err(&e))?;
            } else {
                right
                    .draw(&PathElement::new(vec![(5, y), (30, y)], style))
                    .map_err(|e| err(&e))?;
            }
            right
                .draw(&Text::new(label, (38, y - 7), ("sans-serif", 14)))
                .map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg.into_bytes())
}

/// The texts of an SVG (`<text ...>CONTENT</text>`), with their anchor `(x, y)`.
#[cfg(test)]
pub(crate) fn svg_texts(svg: &str) -> Vec<(String, f64, f64)> {
    let attr = |tag: &str, name: &str| -> f64 {
        let key = format!(" {name}=\"");
        tag.split_once(key.as_str())
            .and_then(|(_, rest)| rest.split_once('"'))
            .and_then(|(v, _)| v.parse().ok())
            .unwrap_or(f64::NAN)
    };
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let (tag, rest) = t.split_once('>')?;
            let (content, _) = rest.split_once("</text>")?;
            Some((content.trim().to_string(), attr(tag, "x"), attr(tag, "y")))
        })
        .collect()
}

#[cfg(test)]
mod log_range_tests {
    use super::log_range;

    #[test]
    fn subnormal_or_too_wide_ranges_are_not_logarithmic() {
        assert!(log_range(1e-3, 10.0));
        assert!(!log_range(5e-324, 1.0), "subnormal bound");
        assert!(!log_range(1e-300, 1e10), "310 decades");
        assert!(!log_range(1.0, 1.0));
        assert!(!log_range(0.0, 1.0));
        assert!(!log_range(1.0, f64::MAX));
        assert!(!log_range(f64::NAN, 1.0));
    }
}

#[cfg(test)]
mod receptance_tests {
    use super::{log_ticks, tick_label};

    #[test]
    fn log_ticks_follow_1_2_5_and_thin_out() {
        assert_eq!(log_ticks(2.0, 20.0), vec![2.0, 5.0, 10.0, 20.0]);
        assert_eq!(
            log_ticks(0.1, 100.0),
            vec![0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0]
        );
        // Six decades: 1-2-5 would give 19, so the decades alone; 30 decades: every 3rd.
        assert_eq!(
            log_ticks(1.0, 1e6),
            vec![1.0, 10.0, 100.0, 1e3, 1e4, 1e5, 1e6]
        );
        assert_eq!(log_ticks(1.0, 1e30).len(), 11);
        // Only 1-2-5 values; a narrow axis is widened to two of them first.
        assert_eq!(log_ticks(5.5, 7.5), Vec::<f64>::new());
        assert_eq!(log_ticks(4.5, 9.0), vec![5.0]);
        assert_eq!(super::log_span(5.5, 7.5), (5.0, 10.0));
        assert_eq!(super::log_span(4.5, 9.0), (2.0, 10.0));
        assert_eq!(super::log_span(0.2246, 1.167), (0.2246, 1.167));
        assert_eq!(super::log_span(2.0, 20.0), (2.0, 20.0));
    }

    /// A series that touches zero on a linear axis draws at once: the log axis it does not
    /// use is not ticked (log10(0) once made that a loop over 2^31 decades), and a
    /// non-logarithmic range has no log ticks.
    #[test]
    fn a_series_through_zero_draws_without_log_ticks() {
        assert!(super::log_ticks(0.0, 1.0).is_empty());
        assert!(super::log_ticks(-1.0, 1.0).is_empty());
        assert!(super::log_ticks(1.0, f64::INFINITY).is_empty());
        let line = [(0.0, 0.0), (1.0, 2e-4), (2.0, 1e-4)];
        let svg =
            super::plot_xy_svg("t", "x", "y", &[("a", &line[..])], (false, false), true).unwrap();
        assert!(!svg.is_empty());
        let svg =
            super::plot_xy_svg("t", "x", "y", &[("a", &line[..])], (false, true), true).unwrap();
        assert!(!svg.is_empty());
    }

    #[test]
    fn tick_labels_are_short() {
        let labels: Vec<String> = [2.0, 0.5, 12.5, 100.0, 6.425, 0.002, 1e5]
            .into_iter()
            .map(tick_label)
            .collect();
        assert_eq!(
            labels,
            ["2", "0.5", "12.5", "100", "6.425", "0.002", "100000"]
        );
        let small: Vec<String> = [1.5e-5, 2e7, 1.23456e-9, -2e-4]
            .into_iter()
            .map(tick_label)
            .collect();
        assert_eq!(small, ["1.5e-5", "2e7", "1.235e-9", "-2e-4"]);
    }

    #[test]
    fn linear_ticks_are_multiples_of_a_1_2_5_step() {
        assert_eq!(
            super::linear_ticks(0.0, 1.0),
            vec![0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
        );
        assert_eq!(
            super::linear_ticks(3.0, 25.0),
            vec![5.0, 10.0, 15.0, 20.0, 25.0]
        );
        assert_eq!(super::linear_ticks(-1.0, 1.0).len(), 5);
        assert!(super::linear_ticks(1.0, 1.0).is_empty());
    }

    /// The x-y and damping plots tick their logarithmic axes at 1-2-5 values.
    #[test]
    fn log_axes_of_the_xy_and_damping_plots_tick_at_1_2_5_values() {
        let pts: Vec<(f64, f64)> = (0..6)
            .map(|i| (0.5 * 2f64.powi(i), 1e-4 * 3f64.powi(i)))
            .collect();
        let xy = super::plot_xy_svg("t", "x [ohm]", "y [m]", &[("a", &pts)], (true, true), true)
            .unwrap();
        let damping: Vec<(f64, f64)> = pts.iter().map(|p| (p.0 * 1e-3, 0.01 * p.0)).collect();
        let dz = super::plot_damping_vs_amplitude_svg("t", &[("a", &damping)]).unwrap();
        for svg in [xy, dz] {
            let svg = String::from_utf8(svg).unwrap();
            let texts = super::svg_texts(&svg);
            let shown: Vec<&str> = texts.iter().map(|t| t.0.as_str()).collect();
            for tick in ["0.5", "1", "2", "5", "10"] {
                assert!(shown.contains(&tick), "tick {tick} missing from {shown:?}");
            }
            for e in ["0.6065", "1.649", "2.718", "4.482", "7.389"] {
                assert!(!shown.contains(&e), "tick at a power of e: {e}");
            }
        }
    }
}
