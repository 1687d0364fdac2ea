//! CSV time histories (the `csv` crate) of a closed-loop mechanism: its output rows with one
//! column per coordinate and velocity, written row by row to any writer — a [`super::stream::StreamFile`] in a run, so the
//! history is never held in memory.

use std::fmt::Write as _;
use std::io::Write;

use mbs_symbolic::runtime::CoordinateUnit;

use hybrid_core::closed_loop::OutputRow;

/// A closed-loop mechanism's CSV, filled row by row: `t [s]`, every coordinate
/// (`<name> [rad]` or `[m]`), every velocity (`<name>_dot [rad/s]` or `[m/s]`),
/// `kinetic_energy [J]`, `potential_energy [J]`, `total_energy [J]`,
/// `constraint_residual_norm [m]`, `cond_jv [-]`. Numbers in shortest round-trip form (scientific
/// outside [1e-4, 1e15), no negative zero); an empty cell when unknown or not finite.
pub struct MechanismCsv<W: Write = Vec<u8>> {
    w: csv::Writer<W>,
    record: Vec<String>,
    rows: usize,
}

impl MechanismCsv {
    /// A CSV in memory with the header for these coordinate names and units.
    pub fn new(names: &[String], units: &[CoordinateUnit]) -> Result<MechanismCsv, csv::Error> {
        MechanismCsv::to_writer(names, units, Vec::new())
    }

    /// The CSV text.
    pub fn into_bytes(self) -> Result<Vec<u8>, csv::Error> {
        self.into_inner()
    }
}

impl<W: Write> MechanismCsv<W> {
    /// A CSV writing to `out`, starting with the header for these coordinate names and
    /// units.
    ///
    /// # Panics
    ///
    /// When `names` and `units` have different lengths.
    pub fn to_writer(
        names: &[String],
        units: &[CoordinateUnit],
        out: W,
    ) -> Result<MechanismCsv<W>, csv::Error> {
        assert_eq!(names.len(), units.len(), "one unit per coordinate");
        let mut w = csv::Writer::from_writer(out);
        let header = mechanism_header(names, units);
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

/// The header of a closed-loop mechanism's time history (see [`MechanismCsv`]).
pub fn mechanism_header(names: &[String], units: &[CoordinateUnit]) -> Vec<String> {
    let mut header = vec!["t [s]".to_string()];
    header.extend(
        names
            .iter()
            .zip(units)
            .map(|(n, u)| format!("{n} [{}]", u.symbol())),
    );
    header.extend(
        names
            .iter()
            .zip(units)
            .map(|(n, u)| format!("{n}_dot [{}]", u.rate())),
    );
    header.extend(
        [
            "kinetic_energy [J]",
            "potential_energy [J]",
            "total_energy [J]",
            "constraint_residual_norm [m]",
            "cond_jv [-]",
        ]
        .map(String::from),
    );
    header
}

/// The numbers of one output row under [`mechanism_header`] (NaN where unknown: an empty
/// cell of the CSV).
pub fn mechanism_cells(r: &OutputRow, out: &mut Vec<f64>) {
    out.clear();
    out.push(r.t);
    out.extend(r.q.iter().chain(&r.qd));
    out.push(r.kinetic_energy);
    out.push(r.potential_energy.unwrap_or(f64::NAN));
    out.push(r.total_energy().unwrap_or(f64::NAN));
    out.push(r.residual_norm);
    out.push(r.cond_jv);
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
