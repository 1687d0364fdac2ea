//! CSV time histories (the `csv` crate): the damper's samples, one serialised row each, and
//! a closed-loop mechanism's output rows with one column per coordinate and velocity. Both
//! are written row by row to any writer — a [`super::stream::StreamFile`] in a run, so the
//! history is never held in memory.

use std::fmt::Write as _;
use std::io::Write;

use mbs_symbolic::runtime::CoordinateUnit;

use hybrid_core::closed_loop::OutputRow;
use hybrid_core::study::Sample;

/// A column of the damper's time history: header (name and unit) and value.
type SampleColumn = (&'static str, fn(&Sample) -> f64);

/// Every column of a damper run, units in brackets (`[-]`: dimensionless).
const DAMPER_COLUMNS: [SampleColumn; 20] = [
    ("t [s]", |s| s.t),
    ("tip_displacement [m]", |s| s.tip_displacement),
    ("tip_velocity [m/s]", |s| s.tip_velocity),
    ("crank_angle [rad]", |s| s.crank_angle),
    ("coupler_angle [rad]", |s| s.coupler_angle),
    ("crank_rate [rad/s]", |s| s.crank_rate),
    ("coupler_rate [rad/s]", |s| s.coupler_rate),
    ("amplification [rad/m]", |s| s.amplification),
    ("current [A]", |s| s.current),
    ("generator_power [W]", |s| s.generator_power),
    ("load_power [W]", |s| s.load_power),
    ("beam_kinetic_energy [J]", |s| s.beam_kinetic_energy),
    ("beam_potential_energy [J]", |s| s.beam_potential_energy),
    ("mechanism_kinetic_energy [J]", |s| {
        s.mechanism_kinetic_energy
    }),
    ("mechanism_potential_energy [J]", |s| {
        s.mechanism_potential_energy
    }),
    ("total_energy [J]", |s| s.total_energy),
    ("dissipated_structure [J]", |s| s.dissipated_structure),
    ("dissipated_generator [J]", |s| s.dissipated_generator),
    ("energy_balance_error [J]", |s| s.energy_balance_error),
    ("constraint_residual [m]", |s| s.constraint_residual),
];

/// The columns of the bare beam (no mechanism, no generator).
const BEAM_COLUMNS: [SampleColumn; 8] = [
    DAMPER_COLUMNS[0],
    DAMPER_COLUMNS[1],
    DAMPER_COLUMNS[2],
    DAMPER_COLUMNS[11],
    DAMPER_COLUMNS[12],
    DAMPER_COLUMNS[15],
    DAMPER_COLUMNS[16],
    DAMPER_COLUMNS[18],
];

/// cond(J^b), the last column of a damper run.
const CONDITION: SampleColumn = ("jacobian_condition [-]", |s| s.jacobian_condition);

/// Which columns a damper time history has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleLayout {
    /// The damper (with or without generator): every column.
    Damper,
    /// The bare beam: time, tip displacement and velocity, beam energies, dissipation,
    /// balance error.
    BareBeam,
}

impl SampleLayout {
    fn columns(self) -> impl Iterator<Item = &'static SampleColumn> {
        let (main, last): (&'static [SampleColumn], &'static [SampleColumn]) = match self {
            SampleLayout::Damper => (&DAMPER_COLUMNS, std::slice::from_ref(&CONDITION)),
            SampleLayout::BareBeam => (&BEAM_COLUMNS, &[]),
        };
        main.iter().chain(last)
    }

    /// The header (units in brackets).
    pub fn header(self) -> Vec<&'static str> {
        self.columns().map(|c| c.0).collect()
    }
}

/// The damper's CSV time history, row by row: a header naming every column with its unit
/// (`t [s]`, `tip_displacement [m]`, ...), one row per sample; numbers in shortest
/// round-trip form, an empty cell when not finite (the bare beam's amplification).
pub struct SamplesCsv<W: Write> {
    w: csv::Writer<W>,
    layout: SampleLayout,
    record: Vec<String>,
}

impl<W: Write> SamplesCsv<W> {
    /// A CSV of `layout` writing to `out` (the header is written with the first row).
    pub fn new(out: W, layout: SampleLayout) -> SamplesCsv<W> {
        SamplesCsv {
            w: csv::Writer::from_writer(out),
            layout,
            record: vec![],
        }
    }

    /// Appends one sample.
    pub fn push(&mut self, s: &Sample) -> Result<(), csv::Error> {
        if self.record.is_empty() {
            self.w.write_record(self.layout.header())?;
        }
        self.record.clear();
        self.record
            .extend(self.layout.columns().map(|c| cell(Some((c.1)(s)))));
        self.w.write_record(&self.record)
    }

    /// Flushes and returns the writer.
    pub fn into_inner(self) -> Result<W, csv::Error> {
        self.w.into_inner().map_err(|e| e.into_error().into())
    }
}

/// The damper's CSV time history of `samples`, in memory.
pub fn samples_csv(samples: &[Sample], layout: SampleLayout) -> Result<Vec<u8>, csv::Error> {
    let mut w = SamplesCsv::new(Vec::new(), layout);
    for s in samples {
        w.push(s)?;
    }
    w.into_inner()
}

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
