//! The SVG plots of a run (plotters, SVG backend, no system fonts needed): displacements
//! against time — the damper's tip with and without the generator, a hybrid run's beam
//! points.

use plotters::prelude::*;

use hybrid_core::study::Sample;

/// The plot could not be drawn (plotters' message).
#[derive(Debug, thiserror::Error)]
#[error("cannot draw the plot: {0}")]
pub struct PlotError(String);

impl PlotError {
    fn of<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> PlotError {
        PlotError(e.to_string())
    }
}

/// SVG plot of the tip displacement (mm) against time for each labelled series (the first
/// on top).
pub fn plot_svg(title: &str, series: &[(&str, &[Sample])]) -> Result<Vec<u8>, PlotError> {
    let lines: Vec<(&str, Vec<(f64, f64)>)> = series
        .iter()
        .map(|(label, s)| {
            (
                *label,
                s.iter().map(|x| (x.t, x.tip_displacement)).collect(),
            )
        })
        .collect();
    let lines: Vec<(&str, &[(f64, f64)])> = lines.iter().map(|(l, p)| (*l, &p[..])).collect();
    plot_displacements_svg(title, "tip displacement (mm)", &lines)
}

/// SVG plot of displacements `(t (s), y (m))`, drawn in mm against time, one line per
/// labelled series (the first on top).
pub fn plot_displacements_svg(
    title: &str,
    y_desc: &str,
    series: &[(&str, &[(f64, f64)])],
) -> Result<Vec<u8>, PlotError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1000, 500)).into_drawing_area();
        root.fill(&WHITE).map_err(PlotError::of)?;
        let t_end = series
            .iter()
            .filter_map(|(_, s)| s.last().map(|x| x.0))
            .fold(0.0, f64::max)
            .max(1e-9);
        let ymax = series
            .iter()
            .flat_map(|(_, s)| s.iter().map(|x| x.1.abs() * 1e3))
            .fold(0.0, f64::max)
            .max(1e-9)
            * 1.05;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..t_end, -ymax..ymax)
            .map_err(PlotError::of)?;
        chart
            .configure_mesh()
            .x_desc("time (s)")
            .y_desc(y_desc)
            .draw()
            .map_err(PlotError::of)?;
        let colors = [
            RGBColor(200, 30, 30),
            RGBColor(30, 80, 200),
            RGBColor(20, 140, 60),
        ];
        // Drawn last to first, so that the first series is on top.
        for (k, (label, points)) in series.iter().enumerate().rev() {
            let color = colors[k % colors.len()];
            chart
                .draw_series(LineSeries::new(
                    points.iter().map(|&(t, y)| (t, y * 1e3)),
                    color.stroke_width(1),
                ))
                .map_err(PlotError::of)?
                .label(*label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(PlotError::of)?;
        root.present().map_err(PlotError::of)?;
    }
    Ok(svg.into_bytes())
}
