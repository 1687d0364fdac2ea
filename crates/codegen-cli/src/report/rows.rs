//! Where the rows of a time history go: a CSV writer over any [`std::io::Write`], so that a
//! run fills its rows the same way whether they are held in memory (committed with the other
//! files by [`super::commit_files`]) or streamed to disk; or, for library users that want
//! the numbers themselves (the Python package), [`ColumnRows`]: one buffer of `f64` per
//! column under the same header, the numbers as computed (the CSV prints them in shortest
//! round-trip form, so they read back bit for bit; a non-finite number, an empty CSV cell,
//! is kept as it is).

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

/// Rows kept in memory, one buffer per column (see the module documentation).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ColumnRows {
    header: Vec<String>,
    columns: Vec<Vec<f64>>,
    rows: u64,
}

impl ColumnRows {
    /// Empty columns under this header.
    pub fn new(header: &[String]) -> ColumnRows {
        ColumnRows {
            header: header.to_vec(),
            columns: vec![vec![]; header.len()],
            rows: 0,
        }
    }

    /// The header, as the CSV's.
    pub fn header(&self) -> &[String] {
        &self.header
    }

    /// Every column with its header name, in header order (the buffers moved out).
    pub fn into_columns(self) -> Vec<(String, Vec<f64>)> {
        self.header.into_iter().zip(self.columns).collect()
    }
}

impl RowSink for ColumnRows {
    fn write_row(&mut self, cells: &[f64]) -> Result<(), csv::Error> {
        assert_eq!(
            cells.len(),
            self.columns.len(),
            "ColumnRows: one cell per column"
        );
        for (c, &x) in self.columns.iter_mut().zip(cells) {
            c.push(x);
        }
        self.rows += 1;
        Ok(())
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

    #[test]
    fn column_rows_hold_the_same_numbers_the_csv_prints() {
        let header = vec!["t [s]".to_string(), "w [m]".to_string()];
        let rows = [[0.0, 1e-5], [0.5, f64::NAN], [0.1 + 0.2, -3.25e-7]];
        let mut csv = CsvRows::new(Vec::new(), &header).unwrap();
        let mut cols = ColumnRows::new(&header);
        for r in &rows {
            csv.write_row(r).unwrap();
            cols.write_row(r).unwrap();
        }
        assert_eq!(cols.rows(), 3);
        let text = String::from_utf8(csv.into_inner().unwrap()).unwrap();
        let columns = cols.into_columns();
        assert_eq!(columns[0].0, "t [s]");
        assert_eq!(columns[1].0, "w [m]");
        // Every CSV cell reads back to the column's number bit for bit (empty: not finite).
        for (i, line) in text.lines().skip(1).enumerate() {
            for (j, cell) in line.split(',').enumerate() {
                let x = columns[j].1[i];
                match cell {
                    "" => assert!(!x.is_finite()),
                    c => assert_eq!(c.parse::<f64>().unwrap().to_bits(), x.to_bits()),
                }
            }
        }
    }
}
