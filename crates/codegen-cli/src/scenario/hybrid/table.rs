//! Time functions of excitations: a [`TimeFunction`] as fem-beam reads it, or a table of
//! `t,value` rows read from a CSV file ([`read_table`]).

use std::path::Path;

use diagnostic::{Diagnostic, Diagnostics, Kind};
use fem_beam::TimeFunction;
use toml::Spanned;
use toml::de::DeValue;

use super::checks::{de, split};
use crate::scenario::Doc;

/// An excitation's `time`: a [`TimeFunction`] as fem-beam reads it, or
/// `{ kind = "table", file = "..." }` read from a CSV file of `t,value` rows, or
/// `{ kind = "psd", file = "...", seed = ... }` from a CSV file of `f,G` rows.
pub(super) fn time_function<'a>(
    doc: &mut Doc<'a>,
    t: Spanned<DeValue<'a>>,
    entity: &str,
) -> Option<TimeFunction> {
    let (mut file, rest) = split(&t, &["file"]);
    let time = match file.remove("file") {
        Some(f) => {
            let span = f.span();
            let name = de::<String>(doc, f, entity)?;
            let (mut kind, extra) = split(&rest, &["kind"]);
            let kind = kind.remove("kind").and_then(|k| match k.get_ref() {
                DeValue::String(s) => Some(s.to_string()),
                _ => None,
            });
            let (mut seed, extra) = split(&extra, &["seed"]);
            let extra_empty = matches!(extra.get_ref(), DeValue::Table(t) if t.is_empty());
            let seed_ok = seed.is_empty() || kind.as_deref() == Some("psd");
            if !matches!(kind.as_deref(), Some("table" | "psd")) || !extra_empty || !seed_ok {
                let msg = "time: `file` goes with kind = \"table\" (and nothing else) or kind = \"psd\" (and an optional seed)";
                doc.push(Kind::InvalidValue, Some(span), Some(entity), msg);
                return None;
            }
            let seed = match seed.remove("seed") {
                Some(s) => Some(de::<u64>(doc, s, entity)?),
                None => None,
            };
            let path = doc.base().join(&name);
            match read_table(&path) {
                Ok(points) if kind.as_deref() == Some("psd") => TimeFunction::Psd {
                    table: points,
                    seed,
                },
                Ok(points) => TimeFunction::Table { points },
                Err(d) => {
                    doc.diags.0.extend(d.0);
                    return None;
                }
            }
        }
        None => de::<TimeFunction>(doc, t.clone(), entity)?,
    };
    let problems = time.problems();
    for e in &problems {
        doc.push(
            Kind::InvalidValue,
            Some(t.span()),
            Some(entity),
            format!("time: {e}"),
        );
    }
    problems.is_empty().then_some(time)
}

/// Reads a time table: `t,value` rows (a header line is allowed), every bad row reported
/// with the table file's name and line.
pub fn read_table(path: &Path) -> Result<Vec<[f64; 2]>, Diagnostics> {
    let file = path.display().to_string();
    let text = diagnostic::read_input_bytes(path, "time table").map_err(Diagnostics::from)?;
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_slice());
    let mut points: Vec<[f64; 2]> = vec![];
    let mut diags = vec![];
    for (k, record) in reader.records().enumerate() {
        let bad = |line: Option<u64>, msg: String| {
            Diagnostic::new(Kind::InvalidValue, file.clone(), msg).at_line(line.map(|l| l as usize))
        };
        let record = match record {
            Ok(r) => r,
            Err(e) => {
                let line = e.position().map(|p| p.line());
                diags.push(bad(line, format!("cannot read the row: {e}")));
                continue;
            }
        };
        let line = record.position().map(|p| p.line());
        if record.iter().all(str::is_empty) {
            continue;
        }
        let numbers: Vec<Option<f64>> = record.iter().map(|c| c.parse::<f64>().ok()).collect();
        if k == 0 && numbers.iter().all(Option::is_none) {
            continue; // a header line
        }
        match numbers[..] {
            [Some(t), Some(v)] if t.is_finite() && v.is_finite() => {
                if let Some(&[prev, _]) = points.last() {
                    if t <= prev {
                        diags.push(bad(
                            line,
                            format!(
                                "time {t} does not come after {prev} (times must increase strictly)"
                            ),
                        ));
                        continue;
                    }
                }
                points.push([t, v]);
            }
            _ => diags.push(bad(
                line,
                format!(
                    "expected two finite numbers `t,value`, got {:?}",
                    diagnostic::truncate(&record.iter().collect::<Vec<_>>().join(","), 60)
                ),
            )),
        }
    }
    if diags.is_empty() && points.is_empty() {
        diags.push(Diagnostic::new(
            Kind::InvalidValue,
            file,
            "the time table has no `t,value` row",
        ));
    }
    if diags.is_empty() {
        Ok(points)
    } else {
        Err(Diagnostics(diags))
    }
}
