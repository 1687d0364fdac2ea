//! The Matrix Market reader: `%%MatrixMarket matrix coordinate real symmetric|general`,
//! 1-based indices, one entry a line.
//!
//! Written here rather than taken from `nalgebra-sparse` because every problem must name
//! the file and the line (an index out of range, a NaN, an entry of a symmetric file above
//! the diagonal, an asymmetric `general` file) and because the entry count of the size
//! line is checked against [`MAX_ENTRIES`] before anything else is read. A `symmetric`
//! file holds one triangle (either; duplicates are summed as the format says); a `general`
//! file must be symmetric to round-off, `|a_ij - a_ji| <= 1e-12 max|a|`.

use std::path::Path;

use diagnostic::{Diagnostic, Diagnostics, Kind};

/// Most entries a matrix file may declare (the size line's third number): 5 * 10^6, far
/// above the 10^5-equation models the tool is for, and below the memory and time budgets.
pub const MAX_ENTRIES: usize = 5_000_000;

/// Relative tolerance of the symmetry check of a `general` file.
pub const SYMMETRY_TOL: f64 = 1e-12;

/// A symmetric matrix read from a file: its size and its lower-triangle entries
/// `(row, column, value)`, 0-based, `column <= row`, duplicates summed, sorted by column
/// then row.
#[derive(Clone, Debug, PartialEq)]
pub struct SymTriplets {
    /// Number of rows (= columns).
    pub n: usize,
    /// Lower-triangle entries, sorted by `(column, row)`, no duplicates.
    pub lower: Vec<(usize, usize, f64)>,
}

/// The size line of a Matrix Market file, `(rows, declared entries)`, read from its first
/// lines only (the work estimates' look at a structure before it is loaded); `None` when
/// the file cannot be opened or has no size line within its first 64 KiB (the loader
/// reports why).
pub fn read_size(path: &Path) -> Option<(usize, usize)> {
    use std::io::Read;
    let mut head = Vec::with_capacity(1 << 16);
    std::fs::File::open(path)
        .ok()?
        .take(1 << 16)
        .read_to_end(&mut head)
        .ok()?;
    let text = String::from_utf8_lossy(&head);
    let mut lines = text.lines();
    lines.next()?.starts_with("%%").then_some(())?;
    let size = lines.find(|l| {
        let t = l.trim();
        !t.is_empty() && !t.starts_with('%')
    })?;
    let v: Vec<usize> = size
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()
        .ok()?;
    match v[..] {
        [rows, _, entries] => Some((rows, entries)),
        _ => None,
    }
}

/// Reads a Matrix Market file (size-capped by [`diagnostic::read_input`]).
pub fn read_matrix_market(path: &Path) -> Result<SymTriplets, Diagnostics> {
    let text = diagnostic::read_input(path, "matrix file")?;
    parse_matrix_market(&text, &path.display().to_string())
}

/// Parses the text of a Matrix Market file named `file` in messages.
pub fn parse_matrix_market(text: &str, file: &str) -> Result<SymTriplets, Diagnostics> {
    let err = |line: usize, message: String| -> Diagnostics {
        Diagnostic::new(Kind::InvalidValue, file, message)
            .at_line(Some(line))
            .into()
    };
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    let Some((_, header)) = lines.next() else {
        return Err(err(
            1,
            "empty file: expected a %%MatrixMarket header".into(),
        ));
    };
    let words: Vec<String> = header
        .split_whitespace()
        .map(str::to_ascii_lowercase)
        .collect();
    let ok_start = words.first().is_some_and(|w| w == "%%matrixmarket")
        && words.get(1).is_some_and(|w| w == "matrix")
        && words.get(2).is_some_and(|w| w == "coordinate");
    let field_ok = words.get(3).is_some_and(|w| w == "real" || w == "integer");
    let symmetric = match words.get(4).map(String::as_str) {
        Some("symmetric") => true,
        Some("general") => false,
        _ => {
            return Err(err(
                1,
                format!(
                    "unsupported header `{header}`: expected `%%MatrixMarket matrix coordinate real symmetric` or `... general`"
                ),
            ));
        }
    };
    if !ok_start || !field_ok || words.len() != 5 {
        return Err(err(
            1,
            format!(
                "unsupported header `{header}`: expected `%%MatrixMarket matrix coordinate real symmetric` or `... general`"
            ),
        ));
    }
    // Size line: the first line that is neither a comment nor blank.
    let (size_line, rows, cols, entries) = loop {
        let Some((no, l)) = lines.next() else {
            return Err(err(1, "no size line `ROWS COLUMNS ENTRIES`".into()));
        };
        let l = l.trim();
        if l.is_empty() || l.starts_with('%') {
            continue;
        }
        let v: Vec<Option<usize>> = l.split_whitespace().map(|w| w.parse().ok()).collect();
        match v.as_slice() {
            [Some(r), Some(c), Some(e)] => break (no, *r, *c, *e),
            _ => {
                return Err(err(
                    no,
                    format!(
                        "size line `{l}`: expected three non-negative integers `ROWS COLUMNS ENTRIES`"
                    ),
                ));
            }
        }
    };
    if rows != cols || rows == 0 {
        return Err(err(
            size_line,
            format!("the matrix is {rows} x {cols}: expected a square matrix of at least one row"),
        ));
    }
    if entries > MAX_ENTRIES {
        return Err(err(
            size_line,
            format!("{entries} entries declared: more than the {MAX_ENTRIES} this tool reads"),
        ));
    }
    let mut raw: Vec<(usize, usize, f64, usize)> = Vec::with_capacity(entries);
    for (no, l) in lines {
        let t = l.trim();
        if t.is_empty() || t.starts_with('%') {
            continue;
        }
        if raw.len() == entries {
            return Err(err(
                no,
                format!("more entries than the {entries} the size line declares"),
            ));
        }
        let w: Vec<&str> = t.split_whitespace().collect();
        let (Some(i), Some(j), Some(v), 3) = (
            w.first().and_then(|x| x.parse::<usize>().ok()),
            w.get(1).and_then(|x| x.parse::<usize>().ok()),
            w.get(2).and_then(|x| x.parse::<f64>().ok()),
            w.len(),
        ) else {
            return Err(err(
                no,
                format!("entry `{t}`: expected `ROW COLUMN VALUE` (1-based integers, a real)"),
            ));
        };
        if i == 0 || j == 0 || i > rows || j > rows {
            return Err(err(
                no,
                format!(
                    "entry ({i}, {j}) outside the {rows} x {rows} matrix (indices are 1-based)"
                ),
            ));
        }
        if !v.is_finite() {
            return Err(err(
                no,
                format!("entry ({i}, {j}) is {v} (not a finite number)"),
            ));
        }
        if symmetric && j > i {
            return Err(err(
                no,
                format!(
                    "entry ({i}, {j}) above the diagonal in a `symmetric` file (it holds the lower triangle)"
                ),
            ));
        }
        raw.push((i - 1, j - 1, v, no));
    }
    if raw.len() < entries {
        return Err(err(
            size_line,
            format!("{} entries found, {entries} declared", raw.len()),
        ));
    }
    let merged = sum_duplicates(raw);
    let lower = if symmetric {
        merged.into_iter().map(|(i, j, v, _)| (i, j, v)).collect()
    } else {
        general_lower(merged).map_err(|m| {
            err(
                m.tag,
                format!(
                    "the matrix is not symmetric: entry ({}, {}) = {:e} but ({}, {}) = {:e}",
                    m.row + 1,
                    m.column + 1,
                    m.value,
                    m.column + 1,
                    m.row + 1,
                    m.mirror
                ),
            )
        })?
    };
    Ok(SymTriplets { n: rows, lower })
}

/// A general matrix's entry whose mirror differs (`|a_ij - a_ji| > SYMMETRY_TOL max|a|`).
struct Mismatch<T> {
    row: usize,
    column: usize,
    value: f64,
    mirror: f64,
    tag: T,
}

/// The lower triangle of a general matrix's merged entries ([`sum_duplicates`]), after
/// checking that it is symmetric to [`SYMMETRY_TOL`] of its largest entry (an entry whose
/// mirror is absent is checked against 0); the first mismatch in `(column, row)` order.
fn general_lower<T: Copy>(
    merged: Vec<(usize, usize, f64, T)>,
) -> Result<Vec<(usize, usize, f64)>, Mismatch<T>> {
    let scale = merged.iter().fold(0.0f64, |m, e| m.max(e.2.abs()));
    let find = |i: usize, j: usize| {
        merged
            .binary_search_by_key(&(j, i), |&(r, c, _, _)| (c, r))
            .ok()
            .map(|k| merged[k].2)
    };
    let mut lower = Vec::new();
    for &(row, column, value, tag) in &merged {
        let mirror = find(column, row).unwrap_or(0.0);
        if (value - mirror).abs() > SYMMETRY_TOL * scale {
            return Err(Mismatch {
                row,
                column,
                value,
                mirror,
                tag,
            });
        }
        if column <= row {
            lower.push((row, column, value));
        }
    }
    Ok(lower)
}

/// A symmetric matrix given in memory (the Python package's `Structure.from_matrices`):
/// `n` rows and its entries `(row, column, value)`, 0-based, both triangles as in a
/// `general` file (duplicates summed, symmetric to [`SYMMETRY_TOL`] of the largest entry),
/// at most [`MAX_ENTRIES`]. Every problem names `name` (e.g. `Structure.from_matrices: M`)
/// and the entry's 0-based position `[row, column]`.
pub fn from_entries(
    n: usize,
    entries: &[(usize, usize, f64)],
    name: &str,
) -> Result<SymTriplets, Diagnostics> {
    let err = |message: String| -> Diagnostics {
        Diagnostic::new(Kind::InvalidValue, name, message).into()
    };
    if n == 0 {
        return Err(err("the matrix has no rows".into()));
    }
    if entries.len() > MAX_ENTRIES {
        return Err(err(format!(
            "{} entries: more than the {MAX_ENTRIES} this tool reads",
            entries.len()
        )));
    }
    let mut raw = Vec::with_capacity(entries.len());
    for &(i, j, v) in entries {
        if i >= n || j >= n {
            return Err(err(format!(
                "entry [{i}, {j}] outside the {n} x {n} matrix (indices are 0-based)"
            )));
        }
        if !v.is_finite() {
            return Err(err(format!(
                "entry [{i}, {j}] is {v} (not a finite number)"
            )));
        }
        raw.push((i, j, v, ()));
    }
    let lower = general_lower(sum_duplicates(raw)).map_err(|m| {
        err(format!(
            "the matrix is not symmetric: entry [{}, {}] = {:e} but [{}, {}] = {:e} (give both triangles)",
            m.row, m.column, m.value, m.column, m.row, m.mirror
        ))
    })?;
    Ok(SymTriplets { n, lower })
}

/// Entries `(row, column, value, tag)` sorted by `(column, row)`, the values of equal
/// positions summed (the first entry's tag kept).
pub(crate) fn sum_duplicates<T>(
    mut raw: Vec<(usize, usize, f64, T)>,
) -> Vec<(usize, usize, f64, T)> {
    raw.sort_by_key(|&(i, j, _, _)| (j, i));
    let mut merged: Vec<(usize, usize, f64, T)> = Vec::with_capacity(raw.len());
    for e in raw {
        match merged.last_mut() {
            Some(last) if last.0 == e.0 && last.1 == e.1 => last.2 += e.2,
            _ => merged.push(e),
        }
    }
    merged
}

/// Writes a symmetric matrix as a `coordinate real symmetric` Matrix Market text (lower
/// triangle, 1-based, values in shortest round-trip form so that reading it back gives the
/// same numbers).
pub fn write_matrix_market(m: &SymTriplets) -> String {
    let mut s = String::from("%%MatrixMarket matrix coordinate real symmetric\n");
    s.push_str(&format!("{} {} {}\n", m.n, m.n, m.lower.len()));
    for &(i, j, v) in &m.lower {
        s.push_str(&format!("{} {} {v:e}\n", i + 1, j + 1));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line_of(r: Result<SymTriplets, Diagnostics>) -> (Option<usize>, String) {
        let e = r.unwrap_err();
        (e.0[0].line, e.to_string())
    }

    #[test]
    fn reads_symmetric_and_general_and_round_trips() {
        let s = "%%MatrixMarket matrix coordinate real symmetric\n% c\n3 3 4\n1 1 2.0\n2 1 -1\n2 2 2\n3 3 1e-3\n";
        let m = parse_matrix_market(s, "K.mtx").unwrap();
        assert_eq!(m.n, 3);
        assert_eq!(
            m.lower,
            vec![(0, 0, 2.0), (1, 0, -1.0), (1, 1, 2.0), (2, 2, 1e-3)]
        );
        let g = "%%MatrixMarket matrix coordinate real general\n3 3 5\n1 1 2.0\n2 1 -1\n1 2 -1\n2 2 2\n3 3 1e-3\n";
        assert_eq!(parse_matrix_market(g, "K.mtx").unwrap(), m);
        assert_eq!(
            parse_matrix_market(&write_matrix_market(&m), "x").unwrap(),
            m
        );
    }

    #[test]
    fn each_problem_names_its_line() {
        let h = "%%MatrixMarket matrix coordinate real general\n";
        let (l, msg) = line_of(parse_matrix_market(
            &format!("{h}2 2 3\n1 1 1\n1 2 0.5\n2 2 1\n"),
            "K.mtx",
        ));
        assert_eq!(l, Some(4), "{msg}");
        assert!(
            msg.starts_with("K.mtx:4: the matrix is not symmetric"),
            "{msg}"
        );
        let (l, msg) = line_of(parse_matrix_market(
            &format!("{h}2 2 1\n1 1 nan\n"),
            "M.mtx",
        ));
        assert_eq!(l, Some(3));
        assert!(msg.contains("not a finite number"), "{msg}");
        let (l, msg) = line_of(parse_matrix_market(&format!("{h}2 2 1\n3 1 1\n"), "M.mtx"));
        assert_eq!(l, Some(3));
        assert!(msg.contains("outside the 2 x 2"), "{msg}");
        let (l, msg) = line_of(parse_matrix_market(&format!("{h}2 2 10000000\n"), "M.mtx"));
        assert_eq!(l, Some(2));
        assert!(msg.contains("10000000 entries declared"), "{msg}");
        let (_, msg) = line_of(parse_matrix_market(
            "%%MatrixMarket matrix array real general\n",
            "M.mtx",
        ));
        assert!(msg.contains("unsupported header"), "{msg}");
        let (l, msg) = line_of(parse_matrix_market(&format!("{h}2 2 2\n1 1 1\n"), "M.mtx"));
        assert_eq!(l, Some(2));
        assert!(msg.contains("1 entries found, 2 declared"), "{msg}");
        let s = "%%MatrixMarket matrix coordinate real symmetric\n2 2 1\n1 2 1\n";
        let (l, msg) = line_of(parse_matrix_market(s, "M.mtx"));
        assert_eq!(l, Some(3));
        assert!(msg.contains("above the diagonal"), "{msg}");
    }
}
