//! The deformed-shape plots of a node-based structure with an element list (issue #30,
//! item 5), on the bundled frame (its `elements = "frame/elements.csv"`): `damper linearize
//! -o DIR` draws `mode_shape.svg`, `damper simulate` draws `deformed_shape.svg`. The SVG is
//! read back: one line per element for the undeformed frame and for each shape; the pixel
//! map fitted to the undeformed lines has equal scales along x and y; the deformed lines
//! lie at `x + s u_x`, `y + s u_y` with `u` the JSON mode shape (real part) and `s` the
//! stated magnification, which puts the largest displacement at 10 % of the frame's size.
//! A bad element table is one line naming the file and line; without `elements` no plot.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::common::{assert_bad_input, damper, root};

const ELEMENTS: usize = 396;

/// A scratch copy of the bundled frame (without its `elements` line unless `elements`), the model path absolute; the
/// scenario's path.
fn frame(name: &str, elements: bool, t_end: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shape_plot_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("frame")).unwrap();
    let src = root().join("scenarios/frame");
    for f in ["M.mtx", "K.mtx", "nodes.csv", "dofs.csv", "elements.csv"] {
        std::fs::copy(src.join(f), d.join("frame").join(f)).unwrap();
    }
    let model = root().join("models/double_bar.toml");
    let mut text = std::fs::read_to_string(root().join("scenarios/frame.toml"))
        .unwrap()
        .replace(
            "model = \"../models/double_bar.toml\"",
            &format!("model = {:?}", model.display().to_string()),
        )
        .replace("t_end = 1.0 ", &format!("t_end = {t_end} "));
    // The bundled frame draws its shapes; without `elements` there is nothing to draw.
    assert!(text.contains("\nelements = \"frame/elements.csv\""));
    if !elements {
        text = text.replace("\nelements = \"frame/elements.csv\"", "\n#");
    }
    let path = d.join("frame.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// A scenario and its output directory, as paths and as texts.
type ScenarioAndOut = (PathBuf, String, PathBuf, String);

/// [`frame`] and its output directory `out` beside it, both also as texts for the command line.
fn frame_and_out(name: &str, elements: bool, t_end: &str) -> ScenarioAndOut {
    let scenario = frame(name, elements, t_end);
    let out = scenario.parent().unwrap().join("out");
    let (s, o) = (scenario.display().to_string(), out.display().to_string());
    (scenario, s, out, o)
}

/// Node positions by id and the element list.
type Tables = (BTreeMap<u64, [f64; 2]>, Vec<(u64, u64)>);

/// `(id -> (x, y))` of `nodes.csv` and the `(node1, node2)` rows of `elements.csv`.
fn tables(dir: &Path) -> Tables {
    let read = |f: &str| std::fs::read_to_string(dir.join(f)).unwrap();
    let nodes = read("nodes.csv")
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            (
                v[0].parse().unwrap(),
                [v[1].parse().unwrap(), v[2].parse().unwrap()],
            )
        })
        .collect();
    let elements = read("elements.csv")
        .lines()
        .skip(1)
        .map(|l| {
            let (a, b) = l.split_once(',').unwrap();
            (a.parse().unwrap(), b.parse().unwrap())
        })
        .collect();
    (nodes, elements)
}

/// The 2-point polylines of `svg` stroked in `color`, in file order: `[(px, py); 2]`.
fn lines(svg: &str, color: &str) -> Vec<[[f64; 2]; 2]> {
    svg.lines()
        .filter(|l| l.starts_with("<polyline") && l.contains(&format!("stroke=\"{color}\"")))
        .map(|l| {
            let pts = l
                .split_once("points=\"")
                .unwrap()
                .1
                .split('"')
                .next()
                .unwrap();
            let p: Vec<[f64; 2]> = pts
                .split_whitespace()
                .map(|xy| {
                    let (x, y) = xy.split_once(',').unwrap();
                    [x.parse().unwrap(), y.parse().unwrap()]
                })
                .collect();
            assert_eq!(p.len(), 2, "{l}");
            [p[0], p[1]]
        })
        .collect()
}

/// Least-squares `pixel = a + b value` over pairs `(value, pixel)`: `(a, b, largest
/// residual)`.
fn fit(pairs: &[(f64, f64)]) -> (f64, f64, f64) {
    let n = pairs.len() as f64;
    let (mx, my) = pairs
        .iter()
        .fold((0.0, 0.0), |(a, b), p| (a + p.0 / n, b + p.1 / n));
    let sxy: f64 = pairs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pairs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let b = sxy / sxx;
    let a = my - b * mx;
    let r = pairs
        .iter()
        .map(|p| (a + b * p.0 - p.1).abs())
        .fold(0.0, f64::max);
    (a, b, r)
}

/// The pixel map of a panel from its undeformed lines: `(ax, bx, ay, by)`; asserts equal
/// scales (`by = -bx` to the pixel rounding) and a residual within a pixel.
fn pixel_map(
    undeformed: &[[[f64; 2]; 2]],
    nodes: &BTreeMap<u64, [f64; 2]>,
    elements: &[(u64, u64)],
) -> [f64; 4] {
    let mut xs = vec![];
    let mut ys = vec![];
    for (seg, &(a, b)) in undeformed.iter().zip(elements) {
        for (p, n) in seg.iter().zip([a, b]) {
            xs.push((nodes[&n][0], p[0]));
            ys.push((nodes[&n][1], p[1]));
        }
    }
    let (ax, bx, rx) = fit(&xs);
    let (ay, by, ry) = fit(&ys);
    assert!(rx <= 1.0 && ry <= 1.0, "residuals {rx}, {ry} px");
    // 0.8 m over ~500 px: a pixel of rounding is 2e-3 of the scale at most.
    assert!(
        ((bx + by) / bx).abs() < 3e-3,
        "unequal scales: {bx} px/m across, {} px/m up",
        -by
    );
    [ax, bx, ay, by]
}

/// The magnification stated in the legend row starting with `label`.
fn stated_scale(svg: &str, label: &str) -> f64 {
    let row = svg
        .lines()
        .find(|l| l.starts_with(label) && l.contains("displacements × "))
        .unwrap_or_else(|| panic!("no legend row {label}"));
    let s = row.split_once("displacements × ").unwrap().1;
    s.split_whitespace().next().unwrap().parse().unwrap()
}

/// Checks the deformed lines of one shape: at `x + s u` mapped by the panel's pixel map,
/// within a pixel; `s` as stated and putting the largest displacement at 10 % of 0.8 m.
fn check_shape(
    drawn: &[[[f64; 2]; 2]],
    map: [f64; 4],
    u: &BTreeMap<u64, [f64; 2]>,
    stated: f64,
    nodes: &BTreeMap<u64, [f64; 2]>,
    elements: &[(u64, u64)],
) {
    let largest = u.values().map(|v| v[0].hypot(v[1])).fold(0.0, f64::max);
    let s = 0.1 * 0.8 / largest;
    assert!(
        (stated - s).abs() <= 5e-4 * s,
        "stated {stated}, expected {s}"
    );
    let mut worst: f64 = 0.0;
    for (seg, &(a, b)) in drawn.iter().zip(elements) {
        for (p, n) in seg.iter().zip([a, b]) {
            let d = u.get(&n).copied().unwrap_or([0.0; 2]);
            let x = nodes[&n][0] + s * d[0];
            let y = nodes[&n][1] + s * d[1];
            let e = (map[0] + map[1] * x - p[0])
                .abs()
                .max((map[2] + map[3] * y - p[1]).abs());
            worst = worst.max(e);
        }
    }
    assert!(worst <= 1.0, "deformed node off by {worst} px");
}

/// Real parts `(u_x, u_y)` per node of a mode's `structure_shape`.
fn real_shape(mode: &Value) -> BTreeMap<u64, [f64; 2]> {
    mode["structure_shape"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            let r: Vec<f64> = r
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            (r[0] as u64, [r[1], r[3]])
        })
        .collect()
}

#[test]
fn linearize_draws_the_first_mode_shapes_of_the_frame() {
    let (scenario, s, out, o) = frame_and_out("linearize", true, "1.0");
    let dir = scenario.parent().unwrap();
    let (code, stdout, err) = damper(&["linearize", &s, "--json", "-o", &o]);
    assert_eq!(code, 0, "{err}");
    let report: Value = serde_json::from_str(&stdout).unwrap();
    let written: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("linearize.json")).unwrap())
            .unwrap();
    assert_eq!(report, written, "linearize.json is the --json report");
    let svg = std::fs::read_to_string(out.join("mode_shape.svg")).unwrap();
    crate::common::svg::parse("mode_shape.svg", &svg);
    assert!(!svg.contains("NaN"));
    let (nodes, elements) = tables(&dir.join("frame"));
    assert_eq!(elements.len(), ELEMENTS);
    // Two panels of the undeformed frame, one shape each; the last line of each colour is
    // its legend swatch.
    let grey = lines(&svg, "#A0A0A0");
    let red = lines(&svg, "#C81E1E");
    let blue = lines(&svg, "#1E50C8");
    assert_eq!(grey.len(), 2 * ELEMENTS + 1);
    assert_eq!(red.len(), ELEMENTS + 1);
    assert_eq!(blue.len(), ELEMENTS + 1);
    let left = pixel_map(&grey[..ELEMENTS], &nodes, &elements);
    let right = pixel_map(&grey[ELEMENTS..2 * ELEMENTS], &nodes, &elements);
    assert!(
        (left[1] - right[1]).abs() < 1e-9 * left[1],
        "the panels share a scale"
    );
    check_shape(
        &red[..ELEMENTS],
        left,
        &real_shape(&report["modes"][0]),
        stated_scale(&svg, "first mode with the generator(s) connected"),
        &nodes,
        &elements,
    );
    check_shape(
        &blue[..ELEMENTS],
        right,
        &real_shape(&report["bare_structure"][0]),
        stated_scale(&svg, "bare structure&apos;s first mode"),
        &nodes,
        &elements,
    );
    assert!(
        svg.contains("pin (node 613)"),
        "the attachment node is marked"
    );
}

#[test]
fn simulate_draws_the_frame_at_its_largest_attachment_displacement() {
    let (scenario, s, out, o) = frame_and_out("simulate", true, "0.05");
    let (code, _, err) = damper(&["simulate", &s, "-o", &o]);
    assert_eq!(code, 0, "{err}");
    let svg = std::fs::read_to_string(out.join("deformed_shape.svg")).unwrap();
    crate::common::svg::parse("deformed_shape.svg", &svg);
    assert!(!svg.contains("NaN"));
    assert_eq!(lines(&svg, "#A0A0A0").len(), ELEMENTS + 1);
    assert_eq!(lines(&svg, "#C81E1E").len(), ELEMENTS + 1);
    let stated = stated_scale(&svg, "deformed at t = ");
    assert!(stated > 0.0 && stated.is_finite());
    // The instant drawn is an output row's.
    let t: f64 = svg
        .lines()
        .find(|l| l.starts_with("deformed at t = "))
        .unwrap()
        .trim_start_matches("deformed at t = ")
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    // The instant drawn is the output row where the pin's displacement |(ux, uy)| (the
    // time history's columns, read through the attachment's point) is largest.
    let csv = std::fs::read_to_string(out.join("time_history.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (ux, uy) = (col("pin.ux [m]"), col("pin.uy [m]"));
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let peak = rows
        .iter()
        .max_by(|a, b| a[ux].hypot(a[uy]).total_cmp(&b[ux].hypot(b[uy])))
        .unwrap();
    assert!(
        (peak[0] - t).abs() < 1e-6,
        "drawn at t = {t}, peak at {}",
        peak[0]
    );
    // Node 613's drawn position is its node plus the stated magnification times the pin's
    // columns at that row (within a pixel of the undeformed lines' pixel map).
    let (nodes, elements) = tables(&scenario.parent().unwrap().join("frame"));
    let grey = lines(&svg, "#A0A0A0");
    let red = lines(&svg, "#C81E1E");
    let map = pixel_map(&grey[..ELEMENTS], &nodes, &elements);
    let pin = 613;
    let (x, y) = (
        nodes[&pin][0] + stated * peak[ux],
        nodes[&pin][1] + stated * peak[uy],
    );
    let mut seen = 0;
    for (seg, &(a, b)) in red[..ELEMENTS].iter().zip(&elements) {
        for (p, n) in seg.iter().zip([a, b]) {
            if n == pin {
                seen += 1;
                let e = (map[0] + map[1] * x - p[0])
                    .abs()
                    .max((map[2] + map[3] * y - p[1]).abs());
                assert!(e <= 1.0, "node {pin} drawn {e} px off its time history");
            }
        }
    }
    assert!(seen > 0, "node {pin} is in the element list");
    // The pin moves by at most the largest displacement, drawn at 10 % of 0.8 m.
    assert!(stated * peak[ux].hypot(peak[uy]) <= 0.08 * (1.0 + 5e-4));
}

#[test]
fn no_elements_no_shape_plot() {
    let (_, s, out, o) = frame_and_out("none", false, "0.01");
    let (code, stdout, err) = damper(&["linearize", &s, "-o", &o]);
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("outputs in"), "{stdout}");
    assert!(out.join("linearize.json").is_file());
    assert!(!out.join("mode_shape.svg").exists());
    let (code, _, err) = damper(&["simulate", &s, "-o", &o]);
    assert_eq!(code, 0, "{err}");
    assert!(!out.join("deformed_shape.svg").exists());
}

#[test]
fn a_bad_element_table_is_one_line_naming_its_file_and_line() {
    let scenario = frame("bad", true, "0.01");
    let table = scenario.parent().unwrap().join("frame/elements.csv");
    let good = std::fs::read_to_string(&table).unwrap();
    let s = scenario.display().to_string();
    std::fs::write(&table, format!("{good}1,99999\n")).unwrap();
    assert_bad_input(
        &["linearize", &s],
        &["elements.csv:398", "unknown node 99999"],
    );
    std::fs::write(&table, format!("{good}1,2,3\n")).unwrap();
    assert_bad_input(&["simulate", &s], &["elements.csv:398"]);
    std::fs::write(&table, format!("{good}1,x\n")).unwrap();
    assert_bad_input(&["linearize", &s], &["elements.csv:398", "node1,node2"]);
}
