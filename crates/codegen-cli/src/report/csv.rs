//! CSV time histories (the `csv` crate): the damper's samples, one serialised row each, and
//! a closed-loop mechanism's output rows with one column per coordinate and velocity. Both
//! are written row by row to any writer — a [`super::stream::StreamFile`] in a run, so the
//! history is never held in memory.

use std::fmt::Write as _;
use std::io::Write;

use hybrid_core::closed_loop::OutputRow;
use hybrid_core::study::Sample;

/// The damper's CSV time history, row by row: a header naming every column (written with
/// the first row), one row per sample.
pub struct SamplesCsv<W: Write> {
    w: csv::Writer<W>,
}

impl<W: Write> SamplesCsv<W> {
    /// A CSV writing to `out`.
    pub fn new(out: W) -> SamplesCsv<W> {
        SamplesCsv {
            w: csv::Writer::from_writer(out),
        }
    }

    /// Appends one sample.
    pub fn push(&mut self, s: &Sample) -> Result<(), csv::Error> {
        self.w.serialize(s)
    }

    /// Flushes and returns the writer.
    pub fn into_inner(self) -> Result<W, csv::Error> {
        self.w.into_inner().map_err(|e| e.into_error().into())
    }
}

/// The damper's CSV time history of `samples`, in memory.
pub fn samples_csv(samples: &[Sample]) -> Result<Vec<u8>, csv::Error> {
    let mut w = SamplesCsv::new(Vec::new());
    for s in samples {
        w.push(s)?;
    }
    w.into_inner()
}

/// A closed-loop mechanism's CSV, filled row by row: `t`, every coordinate, every velocity
/// (`<name>_dot`), `kinetic_energy`, `potential_energy`, `total_energy`,
/// `constraint_residual_norm`, `cond_jv`. Numbers in shortest round-trip form (scientific
/// outside [1e-4, 1e15), no negative zero); an empty cell when unknown or not finite.
pub struct MechanismCsv<W: Write = Vec<u8>> {
    w: csv::Writer<W>,
    record: Vec<String>,
    rows: usize,
}

impl MechanismCsv {
    /// A CSV in memory with the header for these coordinate names.
    pub fn new(names: &[String]) -> Result<MechanismCsv, csv::Error> {
        MechanismCsv::to_writer(names, Vec::new())
    }

    /// The CSV text.
    pub fn into_bytes(self) -> Result<Vec<u8>, csv::Error> {
        self.into_inner()
    }
}

impl<W: Write> MechanismCsv<W> {
    /// A CSV writing to `out`, starting with the header for these coordinate names.
    pub fn to_writer(names: &[String], out: W) -> Result<MechanismCsv<W>, csv::Error> {
        let mut w = csv::Writer::from_writer(out);
        let mut header = vec!["t".to_string()];
        header.extend(names.iter().cloned());
        header.extend(names.iter().map(|n| format!("{n}_dot")));
        header.extend(
            [
                "kinetic_energy",
                "potential_energy",
                "total_energy",
                "constraint_residual_norm",
                "cond_jv",
            ]
            .map(String::from),
        );
        w.write_record(&header)?;
        Ok(MechanismCsv {
            w,
            record: vec![],
            rows: 0,
        })
    }

    /// Appends one output row.
    pub fn push(&mut self, r: &OutputRow) -> Result<(), csv::Error> {
        self.record.clear();
        self.record.push(number(r.t));
        for v in r.q.iter().chain(&r.qd) {
            self.record.push(cell(Some(*v)));
        }
        self.record.push(cell(Some(r.kinetic_energy)));
        self.record.push(cell(r.potential_energy));
        self.record.push(cell(r.total_energy()));
        self.record.push(cell(Some(r.residual_norm)));
        self.record.push(cell(Some(r.cond_jv)));
        self.rows += 1;
        self.w.write_record(&self.record)
    }

    /// Rows written.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Flushes and returns the writer.
    pub fn into_inner(self) -> Result<W, csv::Error> {
        self.w.into_inner().map_err(|e| e.into_error().into())
    }
}

/// A number in shortest round-trip form (scientific notation outside [1e-4, 1e15), no
/// negative zero).
fn number(x: f64) -> String {
    let x = x + 0.0;
    let mut out = String::new();
    if x == 0.0 || (1e-4..1e15).contains(&x.abs()) {
        let _ = write!(out, "{x}");
    } else {
        let _ = write!(out, "{x:e}");
    }
    out
}

/// A number; an empty cell when unknown or not finite.
pub(crate) fn cell(x: Option<f64>) -> String {
    x.filter(|x| x.is_finite()).map(number).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_shortest_round_trip_without_negative_zero() {
        assert_eq!(number(-0.0), "0");
        assert_eq!(number(0.5), "0.5");
        assert_eq!(number(1e-5), "1e-5");
        assert_eq!(number(2e15), "2e15");
        assert_eq!(cell(Some(f64::NAN)), "");
        assert_eq!(cell(None), "");
    }
}
