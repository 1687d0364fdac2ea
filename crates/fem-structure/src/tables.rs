//! The node and DOF tables: `nodes.csv` (`id,x,y[,z]`), `dofs.csv` (`eq,node,dof`, `eq`
//! the 0-based row of the matrices, `dof` one of `ux uy uz rx ry rz`) and, for drawing
//! only, `elements.csv` (`node1,node2`: lines between nodes). Every problem names the file
//! and the line.

use std::collections::BTreeMap;
use std::path::Path;

use diagnostic::{Diagnostic, Diagnostics, Kind};

/// A node: its id and position (m; `z = 0` for a planar model).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    /// The id the tables use.
    pub id: u64,
    /// Position `(x, y, z)` (m).
    pub position: [f64; 3],
}

/// A nodal degree of freedom.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum NodeDof {
    /// Translation along x.
    Ux,
    /// Translation along y.
    Uy,
    /// Translation along z.
    Uz,
    /// Rotation about x.
    Rx,
    /// Rotation about y.
    Ry,
    /// Rotation about z.
    Rz,
}

impl NodeDof {
    /// All, in table order.
    pub const ALL: [NodeDof; 6] = [
        NodeDof::Ux,
        NodeDof::Uy,
        NodeDof::Uz,
        NodeDof::Rx,
        NodeDof::Ry,
        NodeDof::Rz,
    ];

    /// `"ux"`, ...
    pub fn as_str(self) -> &'static str {
        match self {
            NodeDof::Ux => "ux",
            NodeDof::Uy => "uy",
            NodeDof::Uz => "uz",
            NodeDof::Rx => "rx",
            NodeDof::Ry => "ry",
            NodeDof::Rz => "rz",
        }
    }

    /// Parses `ux` ... `rz`.
    pub fn parse(s: &str) -> Option<NodeDof> {
        NodeDof::ALL.into_iter().find(|d| d.as_str() == s)
    }

    /// The unit axis of a translation (`None` for a rotation).
    pub fn axis(self) -> Option<[f64; 3]> {
        match self {
            NodeDof::Ux => Some([1.0, 0.0, 0.0]),
            NodeDof::Uy => Some([0.0, 1.0, 0.0]),
            NodeDof::Uz => Some([0.0, 0.0, 1.0]),
            _ => None,
        }
    }
}

/// The DOF table: for each equation, its node and DOF, and the reverse map.
#[derive(Clone, Debug, PartialEq)]
pub struct DofTable {
    /// `(node id, dof)` of each equation `0..n`.
    pub of_equation: Vec<(u64, NodeDof)>,
    /// Equation of each `(node id, dof)`.
    pub equation: BTreeMap<(u64, NodeDof), usize>,
}

/// Where a table's rows come from, as its messages name them.
#[derive(Clone, Copy, Debug)]
pub enum Place<'a> {
    /// A CSV file: a row is named by its 1-based line.
    File(&'a str),
    /// Rows given in memory (the Python package's `Structure.from_matrices`), named e.g.
    /// `Structure.from_matrices: nodes`: a row is named by its 0-based index.
    Rows(&'a str),
}

impl Place<'_> {
    /// What a row's number counts.
    fn unit(self) -> &'static str {
        match self {
            Place::File(_) => "line",
            Place::Rows(_) => "row",
        }
    }
}

fn diag(place: Place<'_>, line: Option<u64>, message: String) -> Diagnostic {
    match place {
        Place::File(file) => {
            Diagnostic::new(Kind::InvalidValue, file, message).at_line(line.map(|l| l as usize))
        }
        Place::Rows(name) => {
            let message = match line {
                Some(row) => format!("row {row}: {message}"),
                None => message,
            };
            Diagnostic::new(Kind::InvalidValue, name, message)
        }
    }
}

/// Rows given in memory as the records of a table: each row's fields, its 0-based index.
fn rows_in_memory(rows: Vec<Vec<String>>) -> Vec<(Option<u64>, csv::StringRecord)> {
    rows.into_iter()
        .enumerate()
        .map(|(k, r)| (Some(k as u64), csv::StringRecord::from(r)))
        .collect()
}

/// The header and the records (with their 1-based lines) of a CSV table named `file`.
type Records = (Vec<String>, Vec<(Option<u64>, csv::StringRecord)>);

fn records(text: &str, file: &str) -> Result<Records, Diagnostics> {
    let mut rd = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let header: Vec<String> = rd
        .headers()
        .map_err(|e| diag(Place::File(file), Some(1), format!("{e}")))?
        .iter()
        .map(str::to_string)
        .collect();
    let mut out = Vec::new();
    for rec in rd.records() {
        match rec {
            Ok(r) => out.push((r.position().map(|p| p.line()), r)),
            Err(e) => {
                let line = e.position().map(|p| p.line());
                return Err(diag(Place::File(file), line, format!("{e}")).into());
            }
        }
    }
    Ok((header, out))
}

/// Reads `nodes.csv`.
pub fn read_nodes(path: &Path) -> Result<Vec<Node>, Diagnostics> {
    let text = diagnostic::read_input(path, "node table")?;
    parse_nodes(&text, &path.display().to_string())
}

/// Parses a node table named `file` in messages: header `id,x,y` or `id,x,y,z`.
pub fn parse_nodes(text: &str, file: &str) -> Result<Vec<Node>, Diagnostics> {
    let (header, rows) = records(text, file)?;
    let three = header == ["id", "x", "y", "z"];
    if header != ["id", "x", "y"] && !three {
        return Err(diag(
            Place::File(file),
            Some(1),
            format!(
                "header `{}`: expected `id,x,y` or `id,x,y,z`",
                header.join(",")
            ),
        )
        .into());
    }
    node_records(rows, three, Place::File(file))
}

/// The node table given in memory, rows `[id, x, y]` or `[id, x, y, z]` (each a number's
/// text), checked as [`parse_nodes`] checks a file.
pub fn nodes_from_rows(rows: Vec<Vec<String>>, name: &str) -> Result<Vec<Node>, Diagnostics> {
    let place = Place::Rows(name);
    let width = rows.first().map_or(3, Vec::len);
    if let Some(k) = rows
        .iter()
        .position(|r| r.len() != width || !(3..=4).contains(&r.len()))
    {
        let msg = format!(
            "{} values: expected [id, x, y] or [id, x, y, z], every row alike",
            rows[k].len()
        );
        return Err(diag(place, Some(k as u64), msg).into());
    }
    node_records(rows_in_memory(rows), width == 4, place)
}

/// The nodes of a table's records (`three`: with `z`), every problem at its row.
fn node_records(
    rows: Vec<(Option<u64>, csv::StringRecord)>,
    three: bool,
    file: Place<'_>,
) -> Result<Vec<Node>, Diagnostics> {
    let mut out = Vec::new();
    let mut seen = BTreeMap::new();
    let mut problems = Diagnostics::default();
    for (line, rec) in rows {
        let id = rec.get(0).and_then(|s| s.parse::<u64>().ok());
        let xs: Vec<Option<f64>> = (1..rec.len())
            .map(|k| rec.get(k).and_then(|s| s.parse::<f64>().ok()))
            .collect();
        let (Some(id), true) = (id, xs.iter().all(|x| x.is_some_and(f64::is_finite))) else {
            problems.push(diag(
                file,
                line,
                "expected a non-negative integer id and finite coordinates".into(),
            ));
            continue;
        };
        if let Some(first) = seen.insert(id, line) {
            problems.push(diag(
                file,
                line,
                format!(
                    "node {id} defined twice (first on {} {})",
                    file.unit(),
                    first.unwrap_or(0)
                ),
            ));
            continue;
        }
        let z = if three { xs[2].unwrap_or(0.0) } else { 0.0 };
        out.push(Node {
            id,
            position: [xs[0].unwrap_or(0.0), xs[1].unwrap_or(0.0), z],
        });
    }
    problems.into_result(out)
}

/// Reads `dofs.csv` for matrices of `n` equations over `nodes`.
pub fn read_dofs(path: &Path, n: usize, nodes: &[Node]) -> Result<DofTable, Diagnostics> {
    let text = diagnostic::read_input(path, "DOF table")?;
    parse_dofs(&text, &path.display().to_string(), n, nodes)
}

/// Parses a DOF table named `file`: header `eq,node,dof`; every equation `0..n` exactly
/// once, known nodes, each `(node, dof)` once.
pub fn parse_dofs(
    text: &str,
    file: &str,
    n: usize,
    nodes: &[Node],
) -> Result<DofTable, Diagnostics> {
    let (header, rows) = records(text, file)?;
    if header != ["eq", "node", "dof"] {
        return Err(diag(
            Place::File(file),
            Some(1),
            format!("header `{}`: expected `eq,node,dof`", header.join(",")),
        )
        .into());
    }
    dof_records(rows, Place::File(file), n, nodes)
}

/// The DOF table given in memory, rows `[eq, node, dof]` (texts), checked as
/// [`parse_dofs`] checks a file.
pub fn dofs_from_rows(
    rows: Vec<Vec<String>>,
    name: &str,
    n: usize,
    nodes: &[Node],
) -> Result<DofTable, Diagnostics> {
    let place = Place::Rows(name);
    if let Some(k) = rows.iter().position(|r| r.len() != 3) {
        let msg = format!("{} values: expected [eq, node, dof]", rows[k].len());
        return Err(diag(place, Some(k as u64), msg).into());
    }
    dof_records(rows_in_memory(rows), place, n, nodes)
}

/// The DOF table of a table's records, every problem at its row.
fn dof_records(
    rows: Vec<(Option<u64>, csv::StringRecord)>,
    file: Place<'_>,
    n: usize,
    nodes: &[Node],
) -> Result<DofTable, Diagnostics> {
    let known: std::collections::BTreeSet<u64> = nodes.iter().map(|n| n.id).collect();
    let mut of_eq: Vec<Option<(u64, NodeDof)>> = vec![None; n];
    let mut line_of_eq: Vec<Option<u64>> = vec![None; n];
    let mut equation = BTreeMap::new();
    let mut problems = Diagnostics::default();
    for (line, rec) in rows {
        let eq = rec.get(0).and_then(|s| s.parse::<usize>().ok());
        let node = rec.get(1).and_then(|s| s.parse::<u64>().ok());
        let dof = rec.get(2).and_then(NodeDof::parse);
        let (Some(eq), Some(node), Some(dof)) = (eq, node, dof) else {
            problems.push(diag(
                file,
                line,
                "expected `eq,node,dof`: a 0-based equation, a node id, one of ux uy uz rx ry rz"
                    .into(),
            ));
            continue;
        };
        if eq >= n {
            problems.push(diag(
                file,
                line,
                format!("equation {eq} outside the matrices' {n} rows (0-based)"),
            ));
            continue;
        }
        if !known.contains(&node) {
            problems.push(diag(file, line, format!("unknown node {node}")));
            continue;
        }
        if let Some(first) = line_of_eq[eq] {
            problems.push(diag(
                file,
                line,
                format!(
                    "equation {eq} listed twice (first on {} {first})",
                    file.unit()
                ),
            ));
            continue;
        }
        if equation.insert((node, dof), eq).is_some() {
            problems.push(diag(
                file,
                line,
                format!("node {node} {} listed twice", dof.as_str()),
            ));
            continue;
        }
        of_eq[eq] = Some((node, dof));
        line_of_eq[eq] = line;
    }
    let missing: Vec<usize> = (0..n).filter(|&e| of_eq[e].is_none()).collect();
    if !missing.is_empty() && problems.is_empty() {
        let shown: Vec<String> = missing.iter().take(5).map(|e| e.to_string()).collect();
        problems.push(diag(
            file,
            None,
            format!(
                "{} equation(s) of the matrices have no row: {}{}",
                missing.len(),
                shown.join(", "),
                if missing.len() > 5 { ", ..." } else { "" }
            ),
        ));
    }
    problems.into_result(())?;
    Ok(DofTable {
        of_equation: of_eq.into_iter().map(|e| e.expect("checked")).collect(),
        equation,
    })
}

/// Reads `elements.csv` over `nodes`.
pub fn read_elements(path: &Path, nodes: &[Node]) -> Result<Vec<(u64, u64)>, Diagnostics> {
    let text = diagnostic::read_input(path, "element table")?;
    parse_elements(&text, &path.display().to_string(), nodes)
}

/// Parses an element table named `file` (drawing only): header `node1,node2`, one line
/// between two known nodes a row, in file order.
pub fn parse_elements(
    text: &str,
    file: &str,
    nodes: &[Node],
) -> Result<Vec<(u64, u64)>, Diagnostics> {
    let (header, rows) = records(text, file)?;
    if header != ["node1", "node2"] {
        return Err(diag(
            Place::File(file),
            Some(1),
            format!("header `{}`: expected `node1,node2`", header.join(",")),
        )
        .into());
    }
    let known: std::collections::BTreeSet<u64> = nodes.iter().map(|n| n.id).collect();
    let mut out = Vec::with_capacity(rows.len());
    let mut problems = Diagnostics::default();
    for (line, rec) in rows {
        let id = |k: usize| rec.get(k).and_then(|s| s.parse::<u64>().ok());
        let (Some(a), Some(b), 2) = (id(0), id(1), rec.len()) else {
            problems.push(diag(
                Place::File(file),
                line,
                "expected two node ids `node1,node2`".into(),
            ));
            continue;
        };
        match [a, b].into_iter().find(|n| !known.contains(n)) {
            Some(n) => problems.push(diag(Place::File(file), line, format!("unknown node {n}"))),
            None => out.push((a, b)),
        }
    }
    problems.into_result(out)
}
