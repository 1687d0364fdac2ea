//! The deformed-shape plot of a node-based structure (issue #30): the structure drawn from
//! its element list (`[structure] elements`, lines between nodes, drawing only), undeformed
//! in thin grey lines, and one or more deformed shapes over it — `damper linearize`'s first
//! coupled mode and the bare structure's first mode (`mode_shape.svg`), `damper
//! simulate`'s displacement at one instant (`deformed_shape.svg`) — with the mechanisms'
//! attachment nodes marked.
//!
//! Each shape is drawn magnified: a node at `(x, y)` displaced by `(u_x, u_y)` is drawn at
//!
//! ```text
//! (x + s u_x, y + s u_y),    s = f L / max_nodes |(u_x, u_y)|
//! ```
//!
//! `L` the structure's size (the larger side of its nodes' bounding box) and `f`
//! ([`SHAPE_FRACTION`], 10 %) the fraction of it that the largest displacement is drawn
//! as; each shape has its own `s`, written in its legend row. The axes have equal scales
//! (a metre is as long across as up, so a frame does not look sheared), both ticked at
//! one 1-2-5 step.

use std::collections::BTreeMap;

use fem_structure::tables::Node;
use plotters::prelude::*;

use crate::linear::{LinearReport, ModeReport};
use crate::scenario::hybrid::{HybridScenario, StructureDrawing};

use super::plot::{PlotError, Ticked, linear_ticks, tick_label, titled, with_swatches};

/// The fraction of the structure's size that a shape's largest displacement is drawn as.
pub const SHAPE_FRACTION: f64 = 0.1;

/// One deformed shape to draw: its legend text and each node's in-plane displacement
/// `(u_x, u_y)` (a node left out does not move: its translations are held).
#[derive(Clone, Debug)]
pub struct Deformation {
    /// What the shape is (the legend row adds the magnification).
    pub label: String,
    /// `node id -> (u_x, u_y)` (m, or a mode's normalised units).
    pub displacement: BTreeMap<u64, [f64; 2]>,
}

/// A segment between two points `[(x, y), (x, y)]` (m).
pub type Segment = [[f64; 2]; 2];

/// A deformed shape as drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct DrawnShape {
    /// Its panel's caption: the shape's label.
    pub caption: String,
    /// The legend row: the shape's label and its magnification.
    pub label: String,
    /// The magnification `s` (0 for a shape that does not move).
    pub scale: f64,
    /// Its largest nodal displacement `max |(u_x, u_y)|`.
    pub largest: f64,
    /// One segment per element: its nodes at `(x + s u_x, y + s u_y)`.
    pub segments: Vec<Segment>,
    /// The marked nodes at their displaced positions, as [`ShapeDrawing::marks`].
    pub marks: Vec<[f64; 2]>,
}

/// What the plot draws, in structure coordinates (m).
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeDrawing {
    /// The larger side of the nodes' bounding box (m).
    pub size: f64,
    /// One segment per element, undeformed.
    pub undeformed: Vec<Segment>,
    /// The deformed shapes, in the order given.
    pub shapes: Vec<DrawnShape>,
    /// The marked nodes: their legend text and undeformed position.
    pub marks: Vec<(String, [f64; 2])>,
}

/// The segments of the undeformed structure and of each deformed shape magnified by its
/// own `s = fraction L / max |u|` (see the module's doc), and the marked nodes `(label,
/// node)`. Every element's node and every marked node is one of `nodes` (the element table
/// was checked against them when read; an unknown one is left out here).
pub fn drawing(
    nodes: &[Node],
    elements: &[(u64, u64)],
    shapes: &[Deformation],
    marked: &[(String, u64)],
    fraction: f64,
) -> ShapeDrawing {
    let at: BTreeMap<u64, [f64; 2]> = nodes
        .iter()
        .map(|n| (n.id, [n.position[0], n.position[1]]))
        .collect();
    let (lo, hi) = at.values().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        },
    );
    let size = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let size = if size.is_finite() { size } else { 0.0 };
    let segments = |moved: &dyn Fn(u64) -> Option<[f64; 2]>| -> Vec<Segment> {
        elements
            .iter()
            .filter_map(|&(a, b)| Some([moved(a)?, moved(b)?]))
            .collect()
    };
    let undeformed = segments(&|n| at.get(&n).copied());
    let shapes = shapes
        .iter()
        .map(|d| {
            let largest = d
                .displacement
                .iter()
                .filter(|(n, _)| at.contains_key(n))
                .map(|(_, u)| u[0].hypot(u[1]))
                .fold(0.0, f64::max);
            let scale = if largest > 0.0 && largest.is_finite() && size > 0.0 {
                fraction * size / largest
            } else {
                0.0
            };
            let moved = |n: u64| -> Option<[f64; 2]> {
                let p = at.get(&n)?;
                let u = d.displacement.get(&n).copied().unwrap_or([0.0; 2]);
                let u = if u[0].is_finite() && u[1].is_finite() {
                    u
                } else {
                    [0.0; 2]
                };
                Some([p[0] + scale * u[0], p[1] + scale * u[1]])
            };
            DrawnShape {
                caption: d.label.clone(),
                label: format!(
                    "{}: displacements × {} (largest {} = {} % of the structure's size {} m)",
                    d.label,
                    tick_label(scale),
                    tick_label(largest),
                    tick_label(fraction * 100.0),
                    tick_label(size)
                ),
                scale,
                largest,
                segments: segments(&moved),
                marks: marked.iter().filter_map(|(_, n)| moved(*n)).collect(),
            }
        })
        .collect();
    ShapeDrawing {
        size,
        undeformed,
        shapes,
        marks: marked
            .iter()
            .filter_map(|(l, n)| Some((l.clone(), *at.get(n)?)))
            .collect(),
    }
}

/// Colours of the deformed shapes (red, blue, green, ...), the undeformed structure's grey
/// and the marks' black.
const SHAPE_COLORS: [RGBColor; 3] = [
    RGBColor(200, 30, 30),
    RGBColor(30, 80, 200),
    RGBColor(20, 140, 60),
];
const GREY: RGBColor = RGBColor(160, 160, 160);
const BLACK: RGBColor = RGBColor(0, 0, 0);

/// The colour of deformed shape `k`.
fn shape_color(k: usize) -> RGBColor {
    SHAPE_COLORS[k % SHAPE_COLORS.len()]
}

/// `[lo, hi]` of every drawn point of `d`, padded by 5 % of the larger side.
fn extent(d: &ShapeDrawing) -> ([f64; 2], [f64; 2]) {
    let points = d
        .undeformed
        .iter()
        .chain(d.shapes.iter().flat_map(|s| &s.segments))
        .flatten();
    let (lo, hi) = points.fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        },
    );
    if !(lo[0] <= hi[0] && lo[1] <= hi[1]) {
        return ([-1.0; 2], [1.0; 2]);
    }
    let side = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let pad = if side > 0.0 {
        0.05 * side
    } else {
        1e-3 * lo[0].abs().max(lo[1].abs()).max(1.0)
    };
    ([lo[0] - pad, lo[1] - pad], [hi[0] + pad, hi[1] + pad])
}

/// The ranges of the two axes over `[lo, hi]` widened so that a unit is as many pixels
/// along x as along y on a plotting area of `(width, height)` pixels, and their ticks: the
/// multiples inside each of one 1-2-5 step (that of the wider range).
fn equal_axes(lo: [f64; 2], hi: [f64; 2], (width, height): (u32, u32)) -> (Ticked, Ticked) {
    let (w, h) = (f64::from(width.max(1)), f64::from(height.max(1)));
    let per_pixel = ((hi[0] - lo[0]) / w).max((hi[1] - lo[1]) / h);
    let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let x = (centre[0] - per_pixel * w / 2.0)..(centre[0] + per_pixel * w / 2.0);
    let y = (centre[1] - per_pixel * h / 2.0)..(centre[1] + per_pixel * h / 2.0);
    let wide = if x.end - x.start >= y.end - y.start {
        &x
    } else {
        &y
    };
    let ticks = linear_ticks(wide.start, wide.end);
    let step = match ticks[..] {
        [a, b, ..] => b - a,
        _ => 0.0,
    };
    let on = |r: &std::ops::Range<f64>| -> Vec<f64> {
        if step.is_nan() || step <= 0.0 {
            return vec![];
        }
        let first = (r.start / step).ceil() as i64;
        let last = (r.end / step).floor() as i64;
        (first..=last.min(first + 40))
            .map(|k| k as f64 * step)
            .collect()
    };
    (
        Ticked {
            range: x.clone(),
            ticks: on(&x),
        },
        Ticked {
            range: y.clone(),
            ticks: on(&y),
        },
    )
}

/// The SVG of `d`: one panel per deformed shape, side by side, each with the undeformed
/// structure in thin grey lines, the shape in its colour (captioned with its label), the
/// marked nodes as black circles (undeformed) and filled dots in the shape's colour
/// (displaced), labelled; every panel with the same ranges and equal axis scales; a legend
/// band below with one row per shape (its magnification), the undeformed structure and the
/// marks.
pub fn shape_svg(title: &str, d: &ShapeDrawing) -> Result<Vec<u8>, PlotError> {
    let marks = d
        .marks
        .iter()
        .map(|(l, _)| l.as_str())
        .collect::<Vec<_>>()
        .join(", ");
    let marks_row = format!("attachment nodes (circles: undeformed; dots: displaced): {marks}");
    let mut rows: Vec<(&str, RGBColor)> = d
        .shapes
        .iter()
        .enumerate()
        .map(|(k, s)| (s.label.as_str(), shape_color(k)))
        .collect();
    rows.push(("undeformed", GREY));
    if !d.marks.is_empty() {
        rows.push((marks_row.as_str(), BLACK));
    }
    with_swatches(&rows, |area| {
        let below = titled(area, title)?;
        let (lo, hi) = extent(d);
        let panels = below.split_evenly((1, d.shapes.len().max(1)));
        for (k, panel) in panels.iter().enumerate() {
            let shape = d.shapes.get(k);
            let mut builder = ChartBuilder::on(panel);
            builder
                .margin(15)
                .x_label_area_size(40)
                .y_label_area_size(60);
            if let Some(s) = shape {
                builder.caption(&s.caption, ("sans-serif", 14));
            }
            // The plotting area's size, for the equal scales (the ranges do not change it).
            let pixels = builder
                .build_cartesian_2d(0.0..1.0, 0.0..1.0)
                .map_err(PlotError::of)?
                .plotting_area()
                .dim_in_pixel();
            let (x, y) = equal_axes(lo, hi, pixels);
            let mut chart = builder.build_cartesian_2d(x, y).map_err(PlotError::of)?;
            chart
                .configure_mesh()
                .x_desc("x [m]")
                .y_desc("y [m]")
                .x_label_formatter(&|v| tick_label(*v))
                .y_label_formatter(&|v| tick_label(*v))
                .draw()
                .map_err(PlotError::of)?;
            let line = |s: &Segment, style: ShapeStyle| {
                PathElement::new(vec![(s[0][0], s[0][1]), (s[1][0], s[1][1])], style)
            };
            chart
                .draw_series(d.undeformed.iter().map(|s| line(s, GREY.stroke_width(1))))
                .map_err(PlotError::of)?;
            if let Some(shape) = shape {
                let c = shape_color(k);
                chart
                    .draw_series(shape.segments.iter().map(|s| line(s, c.stroke_width(2))))
                    .map_err(PlotError::of)?;
                chart
                    .draw_series(
                        shape
                            .marks
                            .iter()
                            .map(|p| Circle::new((p[0], p[1]), 4, c.filled())),
                    )
                    .map_err(PlotError::of)?;
            }
            chart
                .draw_series(d.marks.iter().map(|(l, p)| {
                    EmptyElement::at((p[0], p[1]))
                        + Circle::new((0, 0), 6, BLACK.stroke_width(2))
                        + Text::new(l.clone(), (8, 6), ("sans-serif", 13).into_font())
                }))
                .map_err(PlotError::of)?;
        }
        Ok(())
    })
}

/// The SVG of `shapes` over `structure` under the title `heading: SCENARIO`, the scenario's
/// attachment nodes marked (each `NAME (node N)`), each shape magnified by its own
/// [`SHAPE_FRACTION`] scale.
fn plot(
    sc: &HybridScenario,
    structure: &StructureDrawing,
    shapes: &[Deformation],
    heading: &str,
) -> Result<Vec<u8>, PlotError> {
    let marks: Vec<(String, u64)> = sc
        .attachments
        .iter()
        .filter_map(|a| Some((format!("{} (node {})", a.name, a.node?), a.node?)))
        .collect();
    let d = drawing(
        &structure.nodes,
        &structure.elements,
        shapes,
        &marks,
        SHAPE_FRACTION,
    );
    shape_svg(&format!("{heading}: {}", sc.title()), &d)
}

/// The real part of a mode's `structure_shape` (the mode at the phase where its normalising
/// entry peaks) as a deformation labelled `label`.
fn mode_deformation(label: String, m: &ModeReport) -> Deformation {
    Deformation {
        label: format!(
            "{label}: {:.3} Hz, zeta {:.3} %",
            m.natural_frequency_hz,
            100.0 * m.damping_ratio
        ),
        displacement: m
            .structure_shape
            .iter()
            .map(|r| (r[0] as u64, [r[1], r[3]]))
            .collect(),
    }
}

/// `mode_shape.svg` of `damper linearize` on a structure with elements: the drawing of the
/// first mode with the generators connected (or of the first mode, without mechanisms) and
/// of the bare structure's first mode, the real parts of their `structure_shape`s, over the
/// undeformed structure, the attachment nodes marked.
pub fn mode_shape(
    sc: &HybridScenario,
    structure: &StructureDrawing,
    report: &LinearReport,
) -> Result<Vec<u8>, PlotError> {
    let coupled = if report.bare_structure.is_some() {
        "first mode with the generator(s) connected"
    } else {
        "first mode"
    };
    let shapes: Vec<Deformation> = report
        .modes
        .first()
        .map(|m| mode_deformation(coupled.into(), m))
        .into_iter()
        .chain(
            report
                .bare_structure
                .as_ref()
                .and_then(|b| b.first())
                .map(|m| mode_deformation("bare structure's first mode".into(), m)),
        )
        .collect();
    plot(
        sc,
        structure,
        &shapes,
        "First mode shapes (real parts, magnified)",
    )
}

/// `deformed_shape.svg` of `damper simulate` on a structure with elements: the structure's
/// displacement `translations` (per node, [`crate::linear::node_translations`]) at time
/// `t`, the instant of the largest displacement of the first attachment, over the
/// undeformed structure, the attachment nodes marked.
pub fn deformed_shape(
    sc: &HybridScenario,
    structure: &StructureDrawing,
    t: f64,
    translations: &[(u64, [f64; 2])],
) -> Result<Vec<u8>, PlotError> {
    let shape = Deformation {
        label: format!("deformed at t = {t:.6} s"),
        displacement: translations.iter().copied().collect(),
    };
    plot(
        sc,
        structure,
        &[shape],
        "Deformed shape at the largest displacement of the first attachment (magnified)",
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node(id: u64, x: f64, y: f64) -> Node {
        Node {
            id,
            position: [x, y, 0.0],
        }
    }

    /// A portal (two columns, a girder) swaying: the drawn nodes are `x + s u`, `s` puts the
    /// largest displacement at the fraction of the size; a held node does not move.
    #[test]
    fn deformed_nodes_are_moved_by_the_stated_scale() {
        let nodes = [
            node(1, 0.0, 0.0),
            node(2, 0.0, 3.0),
            node(3, 4.0, 3.0),
            node(4, 4.0, 0.0),
        ];
        let elements = [(1, 2), (2, 3), (3, 4)];
        let sway = Deformation {
            label: "sway".into(),
            displacement: [(2, [0.02, 0.0]), (3, [0.02, -0.015])].into(),
        };
        let d = drawing(
            &nodes,
            &elements,
            &[sway],
            &[("pin".into(), 3)],
            SHAPE_FRACTION,
        );
        assert_eq!(d.size, 4.0);
        assert_eq!(d.undeformed.len(), 3);
        assert_eq!(d.undeformed[1], [[0.0, 3.0], [4.0, 3.0]]);
        let s = &d.shapes[0];
        assert_eq!(s.largest, 0.025);
        assert!((s.scale - 0.4 / 0.025).abs() < 1e-12);
        assert_eq!(s.segments[0][0], [0.0, 0.0]);
        let moved = s.segments[1][1];
        assert!((moved[0] - (4.0 + s.scale * 0.02)).abs() < 1e-12);
        assert!((moved[1] - (3.0 - s.scale * 0.015)).abs() < 1e-12);
        assert_eq!(s.marks, vec![moved]);
        assert_eq!(d.marks, vec![("pin".to_string(), [4.0, 3.0])]);
        assert!(s.label.contains("× 16 "), "{}", s.label);
    }

    /// A shape that does not move is drawn undeformed (no division by zero, no NaN).
    #[test]
    fn a_shape_at_rest_is_drawn_undeformed() {
        let nodes = [node(1, 0.0, 0.0), node(2, 1.0, 0.0)];
        let rest = Deformation {
            label: "rest".into(),
            displacement: BTreeMap::new(),
        };
        let d = drawing(&nodes, &[(1, 2)], &[rest], &[], SHAPE_FRACTION);
        assert_eq!(d.shapes[0].scale, 0.0);
        assert_eq!(d.shapes[0].segments, d.undeformed);
        let svg = String::from_utf8(shape_svg("t", &d).unwrap()).unwrap();
        assert!(!svg.contains("NaN"));
    }

    /// Equal scales: the ranges have the plotting area's aspect ratio, and both axes tick
    /// at the same step.
    #[test]
    fn the_axes_have_equal_scales_and_one_step() {
        let (x, y) = equal_axes([0.0, 0.0], [0.8, 0.6], (900, 400));
        let (dx, dy) = (x.range.end - x.range.start, y.range.end - y.range.start);
        assert!((dx / 900.0 - dy / 400.0).abs() < 1e-15);
        assert!(dy >= 0.6 && dx >= 0.8);
        let step = |t: &[f64]| t[1] - t[0];
        assert!((step(&x.ticks) - step(&y.ticks)).abs() < 1e-12);
        assert!(y.ticks.contains(&0.0) && y.ticks.len() >= 2);
    }
}
