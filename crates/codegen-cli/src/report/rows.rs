//! Where the rows of a time history go: a CSV writer over any [`std::io::Write`], so that a
//! run fills its rows the same way whether they are held in memory (committed with the other
//! files by [`super::commit_files`]) or streamed to disk.

use std::io::Write;

use super::csv::cell;

/// A time history's destination: a header once, then one row of numbers at a time.
pub trait RowSink {
    /// Appends one row (one number per header column; an empty cell for a non-finite one).
    fn write_row(&mut self, cells: &[f64]) -> Result<(), csv::Error>;
    /// Rows written so far.
    fn rows(&self) -> u64;
}

/// CSV rows written through the `csv` crate into `W` (numbers in shortest round-trip form,
/// an empty cell when not finite).
pub struct CsvRows<W: Write> {
    w: csv::Writer<W>,
    record: Vec<String>,
    columns: usize,
    rows: u64,
}

impl<W: Write> CsvRows<W> {
    /// A CSV with this header, written into `inner`.
    pub fn new(inner: W, header: &[String]) -> Result<CsvRows<W>, csv::Error> {
        let mut w = csv::Writer::from_writer(inner);
        w.write_record(header)?;
        Ok(CsvRows {
            w,
            record: Vec::with_capacity(header.len()),
            columns: header.len(),
            rows: 0,
        })
    }

    /// Appends one row of cells already formatted (one per header column: a table of
    /// results with its own number format, flags and messages).
    pub fn write_text_row(&mut self, cells: &[String]) -> Result<(), csv::Error> {
        assert_eq!(cells.len(), self.columns, "CsvRows: one cell per column");
        self.rows += 1;
        self.w.write_record(cells)
    }

    /// The writer, flushed.
    pub fn into_inner(self) -> Result<W, csv::Error> {
        self.w.into_inner().map_err(|e| e.into_error().into())
    }
}

impl<W: Write> RowSink for CsvRows<W> {
    fn write_row(&mut self, cells: &[f64]) -> Result<(), csv::Error> {
        assert_eq!(cells.len(), self.columns, "CsvRows: one cell per column");
        self.record.clear();
        self.record.extend(cells.iter().map(|&x| cell(Some(x))));
        self.rows += 1;
        self.w.write_record(&self.record)
    }

    fn rows(&self) -> u64 {
        self.rows
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_written_under_the_header_with_empty_cells_for_non_finite_numbers() {
        let header = vec!["t [s]".to_string(), "w [m]".to_string()];
        let mut rows = CsvRows::new(Vec::new(), &header).unwrap();
        rows.write_row(&[0.0, 1e-5]).unwrap();
        rows.write_row(&[0.5, f64::NAN]).unwrap();
        assert_eq!(rows.rows(), 2);
        let text = String::from_utf8(rows.into_inner().unwrap()).unwrap();
        assert_eq!(text, "t [s],w [m]\n0,1e-5\n0.5,\n");
    }
}
