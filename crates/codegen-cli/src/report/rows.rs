//! Where the rows of a time history go: a CSV writer over any [`std::io::Write`], so that a
//! run fills its rows the same way whether they are held in memory (committed with the other
//! files by [`super::commit_files`]) or streamed to disk; or, for library users that want
//! the numbers themselves (the Python package), [`ColumnRows`]: one buffer of `f64` per
//! column under the same header, the numbers as computed (the CSV prints them in shortest
//! round-trip form, so they read back bit for bit; a non-finite number, an empty CSV cell,
//! is kept as it is).
//!
//! A table of results (`sweep.csv`, `frf.csv`, `frf_nonlinear.csv`, the optimiser's
//! history) is a [`Table`]: typed columns, each with its name and unit, built once by the
//! report and either written as the CSV ([`Table::csv`]) or handed to the Python package as
//! they are — so the file and Python's result have the same columns, by construction.

use std::io::Write;

use toml_edit::Value;

use super::csv::write_cell;
use crate::scenario::overrides::value_text;

/// A time history's destination: a header once, then one row of numbers at a time.
pub trait RowSink {
    /// Appends one row (one number per header column; an empty cell for a non-finite one).
    fn write_row(&mut self, cells: &[f64]) -> Result<(), csv::Error>;
    /// Rows written so far.
    fn rows(&self) -> u64;
    /// The rows are over (none follows): what the sink buffers goes out now, ahead of the
    /// commit. Nothing by default.
    fn end(&mut self) -> Result<(), csv::Error> {
        Ok(())
    }
}

/// CSV rows written into `W`: the header and rows of text through the `csv` crate (its
/// quoting), rows of numbers (shortest round-trip form, an empty cell when not finite) as
/// the `csv` crate would write them, each line made in one reused buffer.
pub struct CsvRows<W: Write> {
    out: W,
    /// The line of a row of numbers, the buffer reused by every row.
    line: String,
    columns: usize,
    rows: u64,
}

/// One record as the `csv` crate writes it (default settings: `,`, `"` quotes doubled,
/// `\n`; a field quoted when it holds one of these or `\r`, a record of one empty field as
/// `""`).
fn record<T: AsRef<[u8]>>(fields: &[T]) -> Result<Vec<u8>, csv::Error> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(fields)?;
    w.into_inner().map_err(|e| e.into_error().into())
}

impl<W: Write> CsvRows<W> {
    /// A CSV with this header, written into `inner`.
    pub fn new(mut inner: W, header: &[String]) -> Result<CsvRows<W>, csv::Error> {
        inner.write_all(&record(header)?)?;
        Ok(CsvRows {
            out: inner,
            line: String::with_capacity(32 * header.len()),
            columns: header.len(),
            rows: 0,
        })
    }

    /// Appends one row of cells already formatted (one per header column: a table of
    /// results with its own number format, flags and messages), quoted by the `csv` crate.
    pub fn write_text_row(&mut self, cells: &[String]) -> Result<(), csv::Error> {
        assert_eq!(cells.len(), self.columns, "CsvRows: one cell per column");
        self.rows += 1;
        self.out.write_all(&record(cells)?)?;
        Ok(())
    }

    /// The writer, flushed.
    pub fn into_inner(mut self) -> Result<W, csv::Error> {
        self.out.flush()?;
        Ok(self.out)
    }
}

impl<W: Write> RowSink for CsvRows<W> {
    /// The line as the `csv` crate writes the record of the cells' texts: a number's text
    /// (digits, `.`, `-`, `e`) never needs quotes, and an empty line (a row of one empty
    /// cell) is written `""` (the test `rows_are_the_records_of_their_cells`).
    fn write_row(&mut self, cells: &[f64]) -> Result<(), csv::Error> {
        assert_eq!(cells.len(), self.columns, "CsvRows: one cell per column");
        self.line.clear();
        for (i, &x) in cells.iter().enumerate() {
            if i > 0 {
                self.line.push(',');
            }
            write_cell(x, &mut self.line);
        }
        if self.line.is_empty() {
            self.line.push_str("\"\"");
        }
        self.line.push('\n');
        self.rows += 1;
        self.out.write_all(self.line.as_bytes())?;
        Ok(())
    }

    fn rows(&self) -> u64 {
        self.rows
    }

    /// Flushes the writer (a [`super::StreamFile`] then syncs its data in the background).
    fn end(&mut self) -> Result<(), csv::Error> {
        self.out.flush()?;
        Ok(())
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

/// The cells of one column of a [`Table`], typed as they read.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub enum Cells {
    /// Numbers; `None`, an empty cell (absent, or the run stopped).
    Numbers(Vec<Option<f64>>),
    /// Counts (a sweep's `index`, the nonlinear runs' `periods`).
    Counts(Vec<usize>),
    /// Yes or no (`true` / `false`).
    Flags(Vec<bool>),
    /// Text; `None`, an empty cell (`error`: the point did not fail).
    Texts(Vec<Option<String>>),
    /// Scenario values (a sweep's axis: numbers, integers, strings as the `--set` wrote
    /// them).
    Values(Vec<Value>),
}

impl Cells {
    /// The number of cells.
    pub fn len(&self) -> usize {
        match self {
            Cells::Numbers(v) => v.len(),
            Cells::Counts(v) => v.len(),
            Cells::Flags(v) => v.len(),
            Cells::Texts(v) => v.len(),
            Cells::Values(v) => v.len(),
        }
    }

    /// No cells.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Cell `i` as the CSV prints it, numbers (and float values) by `number`.
    fn cell(&self, i: usize, number: &dyn Fn(f64) -> String) -> String {
        match self {
            Cells::Numbers(v) => v[i].map_or_else(String::new, number),
            Cells::Counts(v) => v[i].to_string(),
            Cells::Flags(v) => v[i].to_string(),
            Cells::Texts(v) => v[i].clone().unwrap_or_default(),
            Cells::Values(v) => match &v[i] {
                Value::Float(f) => number(*f.value()),
                Value::Integer(n) => n.value().to_string(),
                Value::String(s) => s.value().clone(),
                v => value_text(v),
            },
        }
    }
}

/// One column of a [`Table`]: its CSV header is `name [unit]`, or `name` without a unit.
#[derive(Clone, Debug)]
pub struct TableColumn {
    /// The name (a figure's, a field's PATH, `index`, `error`).
    pub name: String,
    /// The unit (`-` for a ratio), `None` for a column without one.
    pub unit: Option<String>,
    /// The cells, one per row.
    pub cells: Cells,
}

impl TableColumn {
    /// A column of `cells` named `name`, in `unit`.
    pub fn new(name: impl Into<String>, unit: Option<&str>, cells: Cells) -> TableColumn {
        TableColumn {
            name: name.into(),
            unit: unit.map(str::to_string),
            cells,
        }
    }

    /// The CSV header: `name [unit]`, or `name`.
    pub fn header(&self) -> String {
        match &self.unit {
            Some(u) => format!("{} [{u}]", self.name),
            None => self.name.clone(),
        }
    }
}

/// A table of results: typed columns of equal length (see the module documentation).
#[derive(Clone, Debug, Default)]
pub struct Table {
    /// The columns, in the CSV's order.
    pub columns: Vec<TableColumn>,
}

impl Table {
    /// The table of these columns.
    ///
    /// # Panics
    ///
    /// When the columns differ in length (a bug of the report that builds them).
    pub fn new(columns: Vec<TableColumn>) -> Table {
        let rows = columns.first().map_or(0, |c| c.cells.len());
        assert!(
            columns.iter().all(|c| c.cells.len() == rows),
            "Table: columns of different lengths"
        );
        Table { columns }
    }

    /// The number of rows.
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, |c| c.cells.len())
    }

    /// The CSV header.
    pub fn header(&self) -> Vec<String> {
        self.columns.iter().map(TableColumn::header).collect()
    }

    /// The CSV text through the one CSV writer ([`CsvRows`]), numbers printed by `number`.
    pub fn csv(&self, number: &dyn Fn(f64) -> String) -> Result<Vec<u8>, csv::Error> {
        let mut w = CsvRows::new(Vec::new(), &self.header())?;
        let mut row = Vec::with_capacity(self.columns.len());
        for i in 0..self.rows() {
            row.clear();
            row.extend(self.columns.iter().map(|c| c.cells.cell(i, number)));
            w.write_text_row(&row)?;
        }
        w.into_inner()
    }
}

/// A time history's header split into the name and the unit (`"t [s]"` → `("t", Some("s"))`,
/// `"index"` → `("index", None)`), as [`TableColumn::header`] joins them.
pub fn split_header(header: &str) -> (&str, Option<&str>) {
    header
        .strip_suffix(']')
        .and_then(|h| h.rsplit_once(" ["))
        .map_or((header, None), |(n, u)| (n, Some(u)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::csv::cell;

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

    /// The rows as the `csv` crate writes a record of [`cell`] strings (the form before the
    /// reused buffer), byte for byte: one column and several, empty cells (a row of one
    /// empty cell is `""`), every form of number.
    #[test]
    fn rows_are_the_records_of_their_cells() {
        let rows: [&[f64]; 6] = [
            &[0.0, -0.0, 1.0, -2.5],
            &[f64::NAN, 1e-5, 1e15, 123.456],
            &[f64::INFINITY, f64::NAN, f64::NEG_INFINITY, f64::NAN],
            &[
                6.505213034913027e-19,
                0.0010000000000000002,
                35.10989052568544,
                1e300,
            ],
            &[f64::MIN_POSITIVE, f64::MAX, -1e-4, 9.999999999999999e14],
            &[0.1 + 0.2, 1.0 / 3.0, 2e-4, -7e22],
        ];
        for columns in [1, 4] {
            let header: Vec<String> = (0..columns).map(|c| format!("c{c} [m]")).collect();
            let mut fast = CsvRows::new(Vec::new(), &header).unwrap();
            let mut reference = csv::Writer::from_writer(Vec::new());
            reference.write_record(&header).unwrap();
            for r in rows {
                for chunk in r.chunks(columns) {
                    fast.write_row(chunk).unwrap();
                    let texts: Vec<String> = chunk.iter().map(|&x| cell(Some(x))).collect();
                    reference.write_record(&texts).unwrap();
                }
            }
            let fast = fast.into_inner().unwrap();
            let reference = reference.into_inner().unwrap();
            assert_eq!(
                String::from_utf8(fast).unwrap(),
                String::from_utf8(reference).unwrap()
            );
        }
        let mut none = CsvRows::new(Vec::new(), &[]).unwrap();
        none.write_row(&[]).unwrap();
        assert_eq!(
            none.into_inner().unwrap(),
            record(&[] as &[&[u8]]).unwrap().repeat(2)
        );
        let mut one = CsvRows::new(Vec::new(), &["w [m]".to_string()]).unwrap();
        one.write_row(&[f64::NAN]).unwrap();
        assert_eq!(one.into_inner().unwrap(), b"w [m]\n\"\"\n");
    }

    #[test]
    fn a_table_prints_every_kind_of_cell_and_its_headers_split_back() {
        let table = Table::new(vec![
            TableColumn::new("index", None, Cells::Counts(vec![0, 1])),
            TableColumn::new(
                "a.b",
                None,
                Cells::Values(vec![Value::from(2.5), Value::from(3)]),
            ),
            TableColumn::new(
                "linear.zeta1",
                Some("-"),
                Cells::Numbers(vec![Some(0.1), None]),
            ),
            TableColumn::new("settled", None, Cells::Flags(vec![true, false])),
            TableColumn::new(
                "error",
                None,
                Cells::Texts(vec![None, Some("no, \"this\"".into())]),
            ),
        ]);
        let text = String::from_utf8(table.csv(&|x| cell(Some(x))).unwrap()).unwrap();
        assert_eq!(
            text,
            "index,a.b,linear.zeta1 [-],settled,error\n0,2.5,0.1,true,\n1,3,,false,\"no, \"\"this\"\"\"\n"
        );
        for c in &table.columns {
            let h = c.header();
            assert_eq!(split_header(&h), (c.name.as_str(), c.unit.as_deref()));
        }
        assert_eq!(split_header("x [m] y"), ("x [m] y", None));
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
