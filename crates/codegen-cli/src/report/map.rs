//! The design map of a two-axis sweep (plotters, SVG): a figure over the grid of two swept
//! fields as coloured cells with a colour bar, the contour of every design constraint
//! (marching squares on the constraint's margin, linear interpolation between grid points),
//! the cells that break a constraint hatched and the best feasible grid point marked.
//!
//! Each grid point is the centre of its cell; cell edges lie half-way between neighbouring
//! values (in the logarithm of the values on a logarithmic axis, chosen when the values are
//! a geometric progression over more than a decade).

use plotters::prelude::*;

use super::plot::{
    LINE_CHARS, PlotError, Ticked, linear_ticks, log_ticks, tick_label as tick, titled, wrap,
};

/// Size of the map (pixels).
const WIDTH: u32 = 1000;
/// Height of the map area, without the legend band (pixels).
const HEIGHT: u32 = 600;
/// Height of one legend row (pixels).
const LEGEND_ROW: u32 = 22;
/// Width of the colour bar panel (pixels).
const BAR: u32 = 130;

/// One axis of the map: its label and the swept values (strictly monotonic).
#[derive(Clone, Copy, Debug)]
pub struct MapAxis<'a> {
    /// The label (the swept PATH).
    pub label: &'a str,
    /// The values, in grid order.
    pub values: &'a [f64],
}

/// A design map: the figure at every grid point, feasibility, the constraints' margins and
/// the best feasible point. Grid point `(i, j)` (`i` along x, `j` along y) is entry
/// `i * ny + j` of every per-point slice.
#[derive(Clone, Copy, Debug)]
pub struct DesignMap<'a> {
    /// Title (the figure and the scenario).
    pub title: &'a str,
    /// The x axis.
    pub x: MapAxis<'a>,
    /// The y axis.
    pub y: MapAxis<'a>,
    /// Label of the figure (colour bar).
    pub figure: &'a str,
    /// The figure at each grid point (`None`: the point failed or does not give it).
    pub values: &'a [Option<f64>],
    /// Whether each grid point satisfies every constraint.
    pub feasible: &'a [bool],
    /// Per constraint its label and its margin at each grid point (`>= 0`: satisfied);
    /// drawn as the contour where the margin is zero.
    pub contours: &'a [(String, Vec<Option<f64>>)],
    /// The best feasible grid point `(x, y)`, if any, and its label.
    pub best: Option<((f64, f64), &'a str)>,
}

/// Whether the values call for a logarithmic axis: positive, a geometric progression
/// (ratios equal to 1e-6) over more than a decade.
pub fn is_geometric(values: &[f64]) -> bool {
    if values.len() < 3 || values.iter().any(|v| v.is_nan() || *v <= 0.0) {
        return false;
    }
    let r = values[1] / values[0];
    let span = values[values.len() - 1] / values[0];
    values
        .windows(2)
        .all(|w| ((w[1] / w[0]) / r - 1.0).abs() < 1e-6)
        && (span.max(1.0 / span)) > 10.0
}

/// Whether the values are strictly increasing or strictly decreasing (and finite).
pub fn is_monotonic(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
        && (values.windows(2).all(|w| w[0] < w[1]) || values.windows(2).all(|w| w[0] > w[1]))
}

/// A viridis-like colour for `t` in [0, 1] (piecewise linear between five stops).
fn colormap(t: f64) -> RGBColor {
    const STOPS: [(u8, u8, u8); 5] = [
        (68, 1, 84),
        (59, 82, 139),
        (33, 145, 140),
        (94, 201, 98),
        (253, 231, 37),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = t * (STOPS.len() - 1) as f64;
    let k = (s.floor() as usize).min(STOPS.len() - 2);
    let f = s - k as f64;
    let mix = |a: u8, b: u8| (a as f64 + (b as f64 - a as f64) * f).round() as u8;
    let (a, b) = (STOPS[k], STOPS[k + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// Colours of the constraint contours.
const CONTOUR: [RGBColor; 4] = [
    RGBColor(220, 30, 30),
    RGBColor(255, 255, 255),
    RGBColor(255, 140, 0),
    RGBColor(0, 200, 255),
];

/// Cell edges of grid coordinates `c` (transformed): half-way between neighbours, half a
/// spacing beyond the ends.
fn edges(c: &[f64]) -> Vec<(f64, f64)> {
    let n = c.len();
    (0..n)
        .map(|i| {
            let lo = if i > 0 {
                0.5 * (c[i - 1] + c[i])
            } else if n > 1 {
                c[0] - 0.5 * (c[1] - c[0])
            } else {
                c[0] - 0.5
            };
            let hi = if i + 1 < n {
                0.5 * (c[i] + c[i + 1])
            } else if n > 1 {
                c[n - 1] + 0.5 * (c[n - 1] - c[n - 2])
            } else {
                c[0] + 0.5
            };
            (lo, hi)
        })
        .collect()
}

/// The zero contour of `m` over the grid of nodes `(x[i], y[j])` (`m[i * ny + j]`) as
/// segments: marching squares with linear interpolation along the cell edges; cells with a
/// missing corner are skipped; a saddle (four crossings) pairs them in edge order.
pub fn zero_contour(x: &[f64], y: &[f64], m: &[Option<f64>]) -> Vec<[(f64, f64); 2]> {
    let ny = y.len();
    let mut segments = vec![];
    for i in 0..x.len().saturating_sub(1) {
        for j in 0..ny.saturating_sub(1) {
            let corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
            let values: Option<Vec<f64>> = corners.iter().map(|&(a, b)| m[a * ny + b]).collect();
            let Some(v) = values else { continue };
            let mut crossings = vec![];
            for e in 0..4 {
                let (p, q) = (corners[e], corners[(e + 1) % 4]);
                let (a, b) = (v[e], v[(e + 1) % 4]);
                if (a >= 0.0) != (b >= 0.0) {
                    let t = a / (a - b);
                    crossings.push((
                        x[p.0] + t * (x[q.0] - x[p.0]),
                        y[p.1] + t * (y[q.1] - y[p.1]),
                    ));
                }
            }
            for pair in crossings.chunks_exact(2) {
                segments.push([pair[0], pair[1]]);
            }
        }
    }
    segments
}

/// A straight piece of a contour, between two points in the map's coordinates.
type Segment = [(f64, f64); 2];

/// Draws the design map (see the module documentation) and returns the SVG text.
pub fn plot_map_svg(map: &DesignMap<'_>) -> Result<Vec<u8>, PlotError> {
    let (nx, ny) = (map.x.values.len(), map.y.values.len());
    debug_assert_eq!(map.values.len(), nx * ny);
    let log = (is_geometric(map.x.values), is_geometric(map.y.values));
    let tx = |v: f64| if log.0 { v.ln() } else { v };
    let ty = |v: f64| if log.1 { v.ln() } else { v };
    let cx: Vec<f64> = map.x.values.iter().map(|&v| tx(v)).collect();
    let cy: Vec<f64> = map.y.values.iter().map(|&v| ty(v)).collect();
    let (ex, ey) = (edges(&cx), edges(&cy));
    let range = |e: &[(f64, f64)]| {
        e.iter()
            .flat_map(|&(a, b)| [a, b])
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            })
    };
    let ((x0, x1), (y0, y1)) = (range(&ex), range(&ey));
    let (zmin, zmax) = map
        .values
        .iter()
        .flatten()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    let zspan = if zmax > zmin { zmax - zmin } else { 1.0 };
    let z_of = |v: f64| (v - zmin) / zspan;
    let label = |l: bool| move |v: &f64| tick(if l { v.exp() } else { *v });
    // A geometric axis is drawn in ln v: its ticks are the 1-2-5 values, at their logarithms.
    let ticks = |lo: f64, hi: f64, l: bool| {
        if l {
            log_ticks(lo.exp(), hi.exp())
                .into_iter()
                .map(f64::ln)
                .collect()
        } else {
            linear_ticks(lo, hi)
        }
    };
    // The contours, computed before the legend: a constraint whose margin does not change
    // sign on the grid draws no line and has no legend entry.
    let contour_lines: Vec<(usize, Vec<Segment>)> = map
        .contours
        .iter()
        .enumerate()
        .map(|(k, (_, margins))| (k, zero_contour(&cx, &cy, margins)))
        .filter(|(_, segments)| !segments.is_empty())
        .collect();
    // Legend entries: (text, swatch); a swatch is a contour's line or the best point's mark.
    enum Swatch {
        None,
        Line(RGBColor),
        Cross,
    }
    let mut legend: Vec<(String, Swatch)> = vec![(
        "hatched: breaks a constraint; grey: no value (the point failed)".into(),
        Swatch::None,
    )];
    for (k, _) in &contour_lines {
        legend.push((
            format!("contour of {}", map.contours[*k].0),
            Swatch::Line(CONTOUR[k % CONTOUR.len()]),
        ));
    }
    if let Some((_, l)) = map.best {
        legend.push((format!("best feasible point: {l}"), Swatch::Cross));
    }
    // One row per wrapped line; the swatch on an entry's first row.
    let rows: Vec<(String, &Swatch)> = legend
        .iter()
        .flat_map(|(text, swatch)| {
            wrap(text, LINE_CHARS)
                .into_iter()
                .enumerate()
                .map(move |(i, line)| (line, if i == 0 { swatch } else { &Swatch::None }))
        })
        .collect();
    let mut svg = String::new();
    {
        let band = 10 + LEGEND_ROW * rows.len() as u32;
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT + band)).into_drawing_area();
        root.fill(&WHITE).map_err(PlotError::of)?;
        let (main, legend_area) = root.split_vertically(HEIGHT);
        let (plot, bar) = main.split_horizontally(WIDTH - BAR);
        let plot = titled(&plot, map.title)?;
        let mut chart = ChartBuilder::on(&plot)
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d(
                Ticked {
                    range: x0..x1,
                    ticks: ticks(x0, x1, log.0),
                },
                Ticked {
                    range: y0..y1,
                    ticks: ticks(y0, y1, log.1),
                },
            )
            .map_err(PlotError::of)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(map.x.label)
            .y_desc(map.y.label)
            .x_label_formatter(&label(log.0))
            .y_label_formatter(&label(log.1))
            .draw()
            .map_err(PlotError::of)?;
        let grey = RGBColor(200, 200, 200);
        let mut cells = vec![];
        let mut hatch = vec![];
        for i in 0..nx {
            for j in 0..ny {
                let ((xl, xh), (yl, yh)) = (ex[i], ey[j]);
                let k = i * ny + j;
                let fill = match map.values[k] {
                    Some(v) if v.is_finite() => colormap(z_of(v)),
                    _ => grey,
                };
                cells.push(Rectangle::new([(xl, yl), (xh, yh)], fill.filled()));
                if !map.feasible[k] {
                    let (xm, ym) = (0.5 * (xl + xh), 0.5 * (yl + yh));
                    for seg in [
                        [(xl, yl), (xh, yh)],
                        [(xl, ym), (xm, yh)],
                        [(xm, yl), (xh, ym)],
                    ] {
                        hatch.push(PathElement::new(
                            seg.to_vec(),
                            BLACK.mix(0.55).stroke_width(1),
                        ));
                    }
                }
            }
        }
        chart.draw_series(cells).map_err(PlotError::of)?;
        chart.draw_series(hatch).map_err(PlotError::of)?;
        for (k, segments) in &contour_lines {
            let c = CONTOUR[k % CONTOUR.len()];
            chart
                .draw_series(
                    segments
                        .iter()
                        .map(|s| PathElement::new(s.to_vec(), c.stroke_width(3))),
                )
                .map_err(PlotError::of)?;
        }
        if let Some(((bx, by), _)) = map.best {
            let p = (tx(bx), ty(by));
            chart
                .draw_series([
                    Cross::new(p, 9, BLACK.stroke_width(4)),
                    Cross::new(p, 7, WHITE.stroke_width(2)),
                ])
                .map_err(PlotError::of)?;
        }
        // The colour bar: the figure's range top to bottom.
        let (top, bottom) = (60i32, HEIGHT as i32 - 70);
        let steps = 120;
        for s in 0..steps {
            let y_a = top + (bottom - top) * s / steps;
            let y_b = top + (bottom - top) * (s + 1) / steps;
            let t = 1.0 - s as f64 / (steps - 1) as f64;
            bar.draw(&Rectangle::new(
                [(10, y_a), (35, y_b)],
                colormap(t).filled(),
            ))
            .map_err(PlotError::of)?;
        }
        // The figure and its unit above the bar, right-aligned on the figure's edge (a long
        // name reaches left over the plot's margin, not out of the view).
        root.draw(&Text::new(
            map.figure.to_string(),
            (WIDTH as i32 - 8, top - 30),
            TextStyle::from(("sans-serif", 14).into_font()).pos(
                plotters::style::text_anchor::Pos::new(
                    plotters::style::text_anchor::HPos::Right,
                    plotters::style::text_anchor::VPos::Top,
                ),
            ),
        ))
        .map_err(PlotError::of)?;
        if zmin.is_finite() {
            for k in 0..=4 {
                let v = zmax - (zmax - zmin) * k as f64 / 4.0;
                let y = top + (bottom - top) * k / 4;
                bar.draw(&Text::new(
                    tick(v),
                    (40, y - 7),
                    ("sans-serif", 13).into_font(),
                ))
                .map_err(PlotError::of)?;
            }
        }
        for (row, (text, swatch)) in rows.iter().enumerate() {
            let y = 5 + (LEGEND_ROW * row as u32 + LEGEND_ROW / 2) as i32;
            match swatch {
                Swatch::None => {}
                // A dark edge under the colour: a white contour shows on the white band.
                Swatch::Line(c) => {
                    for (colour, width) in [(RGBColor(60, 60, 60), 5), (*c, 3)] {
                        legend_area
                            .draw(&PathElement::new(
                                vec![(80, y), (120, y)],
                                colour.stroke_width(width),
                            ))
                            .map_err(PlotError::of)?;
                    }
                }
                Swatch::Cross => {
                    legend_area
                        .draw(&Cross::new((100, y), 7, BLACK.stroke_width(3)))
                        .map_err(PlotError::of)?;
                }
            }
            legend_area
                .draw(&Text::new(
                    text.clone(),
                    (130, y - 8),
                    ("sans-serif", 15).into_font(),
                ))
                .map_err(PlotError::of)?;
        }
        root.present().map_err(PlotError::of)?;
    }
    Ok(svg.into_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The zero contour of a plane `x + y - 1` on a grid is the line `x + y = 1`.
    #[test]
    fn the_contour_of_a_plane_is_its_zero_line() {
        let x: Vec<f64> = (0..6).map(|i| i as f64 * 0.2).collect();
        let y = x.clone();
        let m: Vec<Option<f64>> = x
            .iter()
            .flat_map(|a| y.iter().map(move |b| Some(a + b - 1.0)))
            .collect();
        let segments = zero_contour(&x, &y, &m);
        assert!(!segments.is_empty());
        for s in &segments {
            for p in s {
                assert!((p.0 + p.1 - 1.0).abs() < 1e-12, "{p:?}");
            }
        }
        // A missing corner drops its cells only.
        let mut holes = m.clone();
        holes[2 * 6 + 3] = None;
        assert!(zero_contour(&x, &y, &holes).len() < segments.len());
    }

    #[test]
    fn log_axes_are_chosen_for_geometric_values_over_a_decade() {
        assert!(is_geometric(&[0.5, 1.0, 2.0, 4.0, 8.0, 16.0]));
        assert!(!is_geometric(&[1.0, 2.0, 3.0, 4.0]));
        assert!(!is_geometric(&[1.0, 1.5, 2.25]));
        assert!(is_monotonic(&[3.0, 2.0, 1.0]) && !is_monotonic(&[1.0, 3.0, 2.0]));
    }

    /// A geometric axis ticks at 1-2-5 values (not at e^(k/2): 0.6065, 1.649, ...), a linear
    /// one at multiples of a 1-2-5 step; every number printed has at most 4 significant
    /// digits; every text is anchored inside the view box.
    #[test]
    fn map_axes_tick_at_1_2_5_values_with_short_labels_inside_the_view() {
        let x: Vec<f64> = (0..6).map(|i| 0.5 * 2f64.powi(i)).collect();
        let y: Vec<f64> = (0..5).map(|j| 3.0 + 5.5 * f64::from(j)).collect();
        let values: Vec<Option<f64>> = x
            .iter()
            .flat_map(|a| y.iter().map(move |b| Some(a.ln() * b / 7.0)))
            .collect();
        let feasible = vec![true; values.len()];
        let map = DesignMap {
            title: "t",
            x: MapAxis {
                label: "load resistance [ohm]",
                values: &x,
            },
            y: MapAxis {
                label: "half-angle [deg]",
                values: &y,
            },
            figure: "f [-]",
            values: &values,
            feasible: &feasible,
            contours: &[],
            best: None,
        };
        let svg = String::from_utf8(plot_map_svg(&map).unwrap()).unwrap();
        let texts = crate::report::plot::svg_texts(&svg);
        let shown: Vec<&str> = texts.iter().map(|t| t.0.as_str()).collect();
        for tick in [
            "0.5", "1", "2", "5", "10", "20", "5", "10", "15", "20", "25",
        ] {
            assert!(shown.contains(&tick), "tick {tick} missing from {shown:?}");
        }
        for (text, px, py) in &texts {
            if let Ok(v) = text.parse::<f64>() {
                let digits = text
                    .split(['e', 'E'])
                    .next()
                    .unwrap_or_default()
                    .chars()
                    .filter(char::is_ascii_digit)
                    .collect::<String>();
                let significant = digits.trim_start_matches('0').len();
                assert!(significant <= 4, "label {text} ({v}) has too many digits");
            }
            assert!(
                (0.0..=f64::from(WIDTH)).contains(px) && *py >= 0.0,
                "text {text} anchored outside the view at ({px}, {py})"
            );
        }
        assert!(!shown.iter().any(|t| *t == "1.649" || *t == "0.6065"));
    }

    /// The legend names only the contours drawn (a constraint satisfied everywhere has none),
    /// long entries (the best point of many digits, a long constraint) wrap inside the view,
    /// and a long title wraps onto a second line with the fixed parameters.
    #[test]
    fn legend_lists_drawn_contours_only_and_wraps_inside_the_view() {
        let x: Vec<f64> = (0..5).map(|i| f64::from(i) + 1.0).collect();
        let y = x.clone();
        let values: Vec<Option<f64>> = x
            .iter()
            .flat_map(|a| y.iter().map(move |b| Some(a * b)))
            .collect();
        let feasible = vec![true; values.len()];
        let crossing: Vec<Option<f64>> = values.iter().map(|v| v.map(|v| v - 6.0)).collect();
        let everywhere: Vec<Option<f64>> = values.iter().map(|v| v.map(|v| v + 1.0)).collect();
        let contours = vec![
            ("product>=6".to_string(), crossing),
            ("product>=-1".to_string(), everywhere),
        ];
        let best = format!(
            "a.very.long.swept.path.of.a.mechanism = 5, another.long.swept.path.of.a.generator = 5: {}",
            "linear.zeta1 = 0.1196 with words enough to need a second legend row beyond the width"
        );
        let title = "linear.zeta1 over a.very.long.swept.path.of.a.mechanism and another.long.swept.path: scenarios/some_scenario.toml (generator.gear_ratio = 20)";
        let map = DesignMap {
            title,
            x: MapAxis {
                label: "a [m]",
                values: &x,
            },
            y: MapAxis {
                label: "b [ohm]",
                values: &y,
            },
            figure: "random.toggle_rate:damper [1/s]",
            values: &values,
            feasible: &feasible,
            contours: &contours,
            best: Some(((5.0, 5.0), &best)),
        };
        let svg = String::from_utf8(plot_map_svg(&map).unwrap()).unwrap();
        let texts = crate::report::plot::svg_texts(&svg);
        let shown: Vec<&str> = texts.iter().map(|t| t.0.as_str()).collect();
        assert!(
            shown.contains(&"contour of product&gt;=6") || shown.contains(&"contour of product>=6"),
            "{shown:?}"
        );
        assert!(
            !shown
                .iter()
                .any(|t| t.contains("product&gt;=-1") || t.contains("product>=-1")),
            "{shown:?}"
        );
        assert!(shown.iter().any(|t| t.starts_with("best feasible point: ")));
        assert!(shown.contains(&"random.toggle_rate:damper [1/s]"));
        // The title's lines, in order, are the title.
        let first = shown.iter().position(|t| title.starts_with(*t)).unwrap();
        assert_eq!(shown[first..first + 3].join(" "), title, "{shown:?}");
        for (text, px, py) in &texts {
            assert!(
                text.chars().count() <= LINE_CHARS,
                "{text:?} is longer than a row"
            );
            assert!(
                (0.0..=f64::from(WIDTH)).contains(px) && *py >= 0.0,
                "text {text} anchored outside the view at ({px}, {py})"
            );
        }
        // The view box holds every legend row.
        let height: f64 = svg
            .split_once("height=\"")
            .and_then(|(_, r)| r.split_once('"'))
            .and_then(|(h, _)| h.parse().ok())
            .unwrap();
        assert!(texts.iter().all(|t| t.2 < height), "{height}");
    }
}
