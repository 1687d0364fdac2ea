//! The one check of a plot the tool writes, by reading its SVG text (plotters' SVG backend:
//! one element per line, `<text ...>` with its content on the next line): a title, axis
//! labels with units in brackets, tick labels of at most 4 significant digits, log axes
//! ticked at 1-2-5 values, every text and every coordinate inside the view box, no NaN or
//! infinity anywhere.

/// One `<text>` element: content (entities decoded), anchor, font size, rotation.
#[derive(Clone, Debug)]
pub struct Text {
    /// The text.
    pub content: String,
    /// Anchor point.
    pub x: f64,
    /// Anchor point.
    pub y: f64,
    /// Font size (px).
    pub size: f64,
    /// `start`, `middle` or `end`.
    pub anchor: String,
    /// Rotated by a quarter turn (`rotate(270, ...)` or `rotate(90, ...)`).
    pub rotated: bool,
}

/// A parsed plot.
#[derive(Clone, Debug)]
pub struct Svg {
    /// The SVG text.
    pub text: String,
    /// View box width and height.
    pub size: (f64, f64),
    /// Every `<text>`.
    pub texts: Vec<Text>,
}

fn attr(tag: &str, name: &str) -> Option<String> {
    let key = format!(" {name}=\"");
    let (_, rest) = tag.split_once(key.as_str())?;
    Some(rest.split_once('"')?.0.to_string())
}

fn num(tag: &str, name: &str) -> Option<f64> {
    attr(tag, name)?.trim().parse().ok()
}

fn decode(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

/// Parses an SVG written by the tool (panics with the file's name on anything malformed).
pub fn parse(name: &str, text: &str) -> Svg {
    assert!(text.starts_with("<svg"), "{name}: not an SVG");
    let head = text.split_once('>').expect("svg tag").0;
    let vb: Vec<f64> = attr(head, "viewBox")
        .unwrap_or_else(|| panic!("{name}: no viewBox"))
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(vb.len(), 4, "{name}: viewBox");
    assert_eq!(
        (num(head, "width"), num(head, "height")),
        (Some(vb[2]), Some(vb[3])),
        "{name}: width and height are the view box's"
    );
    let texts = text
        .split("<text")
        .skip(1)
        .map(|t| {
            let (tag, rest) = t.split_once('>').expect("text tag");
            let (content, _) = rest.split_once("</text>").expect("</text>");
            Text {
                content: decode(content.trim()),
                x: num(tag, "x").unwrap_or_else(|| panic!("{name}: text without x")),
                y: num(tag, "y").unwrap_or_else(|| panic!("{name}: text without y")),
                size: num(tag, "font-size").unwrap_or(12.0),
                anchor: attr(tag, "text-anchor").unwrap_or_else(|| "start".into()),
                rotated: attr(tag, "transform").is_some_and(|t| t.starts_with("rotate(")),
            }
        })
        .collect();
    Svg {
        text: text.to_string(),
        size: (vb[2], vb[3]),
        texts,
    }
}

/// A tick label: a plain number (`0.5`, `-2`, `1e-5`).
fn number(s: &str) -> Option<f64> {
    let plain = s
        .chars()
        .all(|c| c.is_ascii_digit() || matches!(c, '.' | '-' | 'e' | '+'));
    (plain && !s.is_empty()).then(|| s.parse().ok()).flatten()
}

/// Significant digits of a number as written (`0.007066` has 4, `1.5e-5` has 2).
fn significant(s: &str) -> usize {
    let mantissa = s.split(['e', 'E']).next().unwrap_or(s);
    let digits: String = mantissa.chars().filter(char::is_ascii_digit).collect();
    let digits = digits.trim_start_matches('0');
    if mantissa.contains('.') {
        digits.len()
    } else {
        digits.trim_end_matches('0').len().max(1)
    }
}

/// Whether `v` is a 1-2-5 value (`m 10^k`, m in {1, 2, 5}).
fn one_two_five(v: f64) -> bool {
    let m = v.abs() / 10f64.powf(v.abs().log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .any(|t| (m - t).abs() < 1e-6 * t)
}

/// The numbers of an attribute value (`points`, `d`, coordinates).
fn numbers(s: &str) -> impl Iterator<Item = &str> {
    s.split(|c: char| c.is_whitespace() || matches!(c, ',' | 'M' | 'L' | 'Z' | 'C' | 'H' | 'V'))
        .filter(|t| !t.is_empty())
}

/// Checks a plot the tool wrote (see the module documentation) and returns it parsed;
/// `axes` are the axis labels expected (each ends with its unit in brackets).
pub fn check(name: &str, text: &str, axes: &[&str]) -> Svg {
    let svg = parse(name, text);
    let (w, h) = svg.size;
    let lower = text.to_ascii_lowercase();
    for bad in ["nan", "inf\"", "\"inf", "-inf", "infinity"] {
        assert!(!lower.contains(bad), "{name}: `{bad}` in the SVG");
    }
    // The title: a text at the top.
    assert!(
        svg.texts
            .iter()
            .any(|t| !t.content.is_empty() && t.y < 0.1 * h && !t.rotated),
        "{name}: no title at the top"
    );
    for a in axes {
        assert!(
            svg.texts.iter().any(|t| t.content == *a),
            "{name}: no axis label {a:?} in {:?}",
            svg.texts.iter().map(|t| &t.content).collect::<Vec<_>>()
        );
        assert!(
            a.ends_with(']') && a.contains(" ["),
            "{name}: axis label {a:?} has no unit in brackets"
        );
    }
    // Every text inside the view box (0.6 em per character, one em high).
    for t in &svg.texts {
        let len = 0.6 * t.size * t.content.chars().count() as f64;
        let (lo, hi) = match t.anchor.as_str() {
            "middle" => (-len / 2.0, len / 2.0),
            "end" => (-len, 0.0),
            _ => (0.0, len),
        };
        let (x0, x1, y0, y1) = if t.rotated {
            (t.x - t.size, t.x + t.size, t.y + lo, t.y + hi)
        } else {
            (t.x + lo, t.x + hi, t.y - t.size, t.y + t.size)
        };
        assert!(
            x0 >= -1.0 && x1 <= w + 1.0 && y0 >= -t.size && y1 <= h + 1.0,
            "{name}: text {:?} at ({}, {}) (extent x {x0:.0}..{x1:.0}, y {y0:.0}..{y1:.0}) leaves the {w}x{h} view box",
            t.content,
            t.x,
            t.y
        );
    }
    // Every coordinate of every shape inside the view box.
    for element in text.split('<').skip(1) {
        let tag = element.split_once('>').map_or(element, |(t, _)| t);
        let kind = tag.split_whitespace().next().unwrap_or("");
        let coordinates: Vec<(&str, bool)> = match kind {
            "line" => vec![("x1", true), ("x2", true), ("y1", false), ("y2", false)],
            "circle" => vec![("cx", true), ("cy", false)],
            "rect" => vec![("x", true), ("y", false)],
            _ => vec![],
        };
        for (a, is_x) in coordinates {
            if let Some(v) = num(tag, a) {
                let limit = if is_x { w } else { h };
                assert!(
                    (-1.0..=limit + 1.0).contains(&v),
                    "{name}: <{kind} {a}={v}> outside the view box"
                );
            }
        }
        if kind == "polyline" || kind == "path" || kind == "polygon" {
            let list = attr(tag, "points")
                .or_else(|| attr(tag, "d"))
                .unwrap_or_default();
            for (k, v) in numbers(&list).enumerate() {
                let v: f64 = v
                    .parse()
                    .unwrap_or_else(|_| panic!("{name}: <{kind}> coordinate {v:?}"));
                let limit = if k % 2 == 0 { w } else { h };
                assert!(
                    (-1.0..=limit + 1.0).contains(&v),
                    "{name}: <{kind}> coordinate {v} outside the view box"
                );
            }
        }
    }
    // Tick labels: at most 4 significant digits, never `-0`.
    let ticks: Vec<&Text> = svg
        .texts
        .iter()
        .filter(|t| number(&t.content).is_some())
        .collect();
    for t in &ticks {
        assert!(
            significant(&t.content) <= 4,
            "{name}: tick label {:?} has more than 4 significant digits",
            t.content
        );
        assert!(
            number(&t.content) != Some(0.0) || t.content == "0",
            "{name}: zero written {:?}",
            t.content
        );
    }
    // An axis's ticks: numeric labels in one row (same y) or one column (same x and anchor).
    // A row or column whose steps are not equal is logarithmic: its ticks are 1-2-5 values.
    let mut groups: Vec<Vec<f64>> = vec![];
    for same in [true, false] {
        let mut keys: Vec<(i64, String)> = ticks
            .iter()
            .map(|t| {
                let at = if same { t.y } else { t.x };
                (
                    at.round() as i64,
                    if same {
                        String::new()
                    } else {
                        t.anchor.clone()
                    },
                )
            })
            .collect();
        keys.sort();
        keys.dedup();
        for k in keys {
            let values: Vec<f64> = ticks
                .iter()
                .filter(|t| {
                    let at = if same { t.y } else { t.x };
                    at.round() as i64 == k.0 && (same || t.anchor == k.1)
                })
                .filter_map(|t| number(&t.content))
                .collect();
            if values.len() >= 3 {
                groups.push(values);
            }
        }
    }
    for mut g in groups {
        g.sort_by(f64::total_cmp);
        let steps: Vec<f64> = g.windows(2).map(|p| p[1] - p[0]).collect();
        let span = g[g.len() - 1] - g[0];
        let equal = steps.iter().all(|s| (s - steps[0]).abs() <= 1e-3 * span);
        if !equal {
            assert!(
                g.iter().all(|v| *v > 0.0 && one_two_five(*v)),
                "{name}: log axis ticks {g:?} are not all 1-2-5 values"
            );
        }
    }
    svg
}

/// Reads the plot at `path` and [`check`]s it.
pub fn checked(path: &std::path::Path, axes: &[&str]) -> Svg {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    check(&path.display().to_string(), &text, axes)
}

#[test]
fn the_checker_reads_numbers_and_1_2_5_values() {
    assert_eq!(significant("0.007066"), 4);
    assert_eq!(significant("12.5"), 3);
    assert_eq!(significant("1.5e-5"), 2);
    assert_eq!(significant("10000"), 1);
    assert_eq!(significant("0.06795"), 4);
    assert_eq!(significant("3.14159"), 6);
    assert!(one_two_five(0.2) && one_two_five(5e-7) && one_two_five(100.0));
    assert!(!one_two_five(3.0) && !one_two_five(0.2246));
    assert_eq!(number("-0.15"), Some(-0.15));
    assert_eq!(number("tip_pin"), None);
    // A text past the right edge is caught.
    let svg = "<svg width=\"100\" height=\"50\" viewBox=\"0 0 100 50\" xmlns=\"\">\n<text x=\"50\" y=\"2\" font-size=\"10\">\nA long title past the edge\n</text>\n</svg>";
    assert!(std::panic::catch_unwind(|| check("t.svg", svg, &[])).is_err());
}
