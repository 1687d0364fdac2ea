//! The plots of a run (plotters, SVG backend, no system fonts needed): displacements
//! against time — a run's beam points and those of its comparison runs —, the damping ratio of each cycle against its amplitude, and
//! a mechanism's coordinates against time.
//!
//! Every plot has its main settings in the title and its legend in a band below the plot
//! area, never on the traces.

use plotters::coord::Shift;
use plotters::prelude::*;

/// The plot could not be drawn (plotters' message).
#[derive(Debug, thiserror::Error)]
#[error("cannot draw the plot: {0}")]
pub struct PlotError(String);

impl PlotError {
    fn of<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> PlotError {
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

/// Draws `draw` on a plot area above a legend band with one row per label, and returns the
/// SVG text.
fn with_legend(
    labels: &[&str],
    draw: impl FnOnce(&DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), PlotError>,
) -> Result<Vec<u8>, PlotError> {
    let mut svg = String::new();
    {
        let band = 10 + LEGEND_ROW * labels.len() as u32;
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT + band)).into_drawing_area();
        root.fill(&WHITE).map_err(PlotError::of)?;
        let (plot, legend) = root.split_vertically(HEIGHT);
        draw(&plot)?;
        for (k, label) in labels.iter().enumerate() {
            let y = 5 + (LEGEND_ROW * k as u32 + LEGEND_ROW / 2) as i32;
            let c = color(k);
            legend
                .draw(&PathElement::new(
                    vec![(80, y), (120, y)],
                    c.stroke_width(2),
                ))
                .map_err(PlotError::of)?;
            legend
                .draw(&Text::new(
                    label.to_string(),
                    (130, y - 8),
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
        let mut chart = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 18))
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(t0..t1, lo..hi)
            .map_err(PlotError::of)?;
        chart
            .configure_mesh()
            .x_desc("time [s]")
            .y_desc(y_desc)
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
        let z_hi = all().map(|p| p.1 * 100.0).fold(0.0, f64::max);
        let z_lo = all().map(|p| p.1 * 100.0).fold(0.0, f64::min);
        let z_hi = if z_hi > z_lo { z_hi * 1.1 } else { 1.0 };
        let mut chart = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 18))
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d((a_lo..a_hi).log_scale(), z_lo..z_hi)
            .map_err(PlotError::of)?;
        chart
            .configure_mesh()
            .x_desc("cycle amplitude of the tip [mm] (geometric mean of its bounding peaks)")
            .y_desc("damping ratio of the cycle [%]")
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

/// SVG plot of labelled series of points `(x, y)` joined by lines, with markers (a
/// parameter study: a figure against a swept parameter); the x axis logarithmic when
/// `log_x` and every x is positive. Series with fewer than one finite point are left out of
/// the plot area but keep their legend row.
pub fn plot_xy_svg(
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[(&str, &[(f64, f64)])],
    log_x: bool,
) -> Result<Vec<u8>, PlotError> {
    let labels: Vec<&str> = series.iter().map(|s| s.0).collect();
    with_legend(&labels, |area| {
        let (x0, x1, y0, y1) = extent(series);
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
        let (y0, y1) = pad(y0, y1);
        let caption = (title, ("sans-serif", 18));
        let draw_points = |k: usize, pts: &[(f64, f64)]| {
            pts.iter()
                .copied()
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .map(move |p| Circle::new(p, 3, color(k).filled()))
                .collect::<Vec<_>>()
        };
        let finite_line = |pts: &[(f64, f64)]| {
            pts.iter()
                .copied()
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .collect::<Vec<_>>()
        };
        // The same chart on a logarithmic or a linear x axis (different coordinate types).
        macro_rules! chart_on {
            ($x:expr) => {{
                let mut chart = ChartBuilder::on(area)
                    .caption(caption.0, caption.1)
                    .margin(15)
                    .x_label_area_size(40)
                    .y_label_area_size(80)
                    .build_cartesian_2d($x, y0..y1)
                    .map_err(PlotError::of)?;
                chart
                    .configure_mesh()
                    .x_desc(x_desc)
                    .y_desc(y_desc)
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
        if log_x && log_range(x0, x1) {
            chart_on!((x0 / 1.1..x1 * 1.1).log_scale());
        } else {
            let (x0, x1) = pad(x0, x1);
            chart_on!(x0..x1);
        }
        Ok(())
    })
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
