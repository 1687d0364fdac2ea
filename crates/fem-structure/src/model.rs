//! An imported structure: sparse `M`, `K`, damping `B` (Rayleigh from two modal ratios, as
//! `[beam.damping]`, or a matrix file) and the node and DOF tables, checked before any
//! work: sizes agree, the tables cover every equation once, `M` and `K` are positive
//! definite (supports eliminated in the matrices).

use std::path::{Path, PathBuf};

use diagnostic::{Diagnostic, Diagnostics, Kind};

use crate::modes::lowest_modes;
use crate::mtx::from_entries;
use crate::mtx::{SymTriplets, read_matrix_market};
use crate::sparse::SparseSym;
use crate::tables::{DofTable, Node, dofs_from_rows, nodes_from_rows, read_dofs, read_nodes};

/// How the structure is damped.
#[derive(Clone, Debug, PartialEq)]
pub enum DampingInput {
    /// Undamped.
    None,
    /// Rayleigh `B = a M + b K` giving ratio `zeta` at two modes `(mode (1-based), zeta)`.
    Ratios([(usize, f64); 2]),
    /// A matrix file.
    Matrix(PathBuf),
}

/// The files of a `matrices` structure.
#[derive(Clone, Debug, PartialEq)]
pub struct MatrixFiles {
    /// Mass matrix (Matrix Market).
    pub mass: PathBuf,
    /// Stiffness matrix (Matrix Market).
    pub stiffness: PathBuf,
    /// `nodes.csv`.
    pub nodes: PathBuf,
    /// `dofs.csv`.
    pub dofs: PathBuf,
    /// Damping.
    pub damping: DampingInput,
}

impl MatrixFiles {
    /// The files of a structure under their usual names in `dir`: `M.mtx`, `K.mtx`,
    /// `nodes.csv`, `dofs.csv` (the names the bundled frame and
    /// [`crate::StructureFiles::write_to`] use).
    pub fn in_directory(dir: &Path, damping: DampingInput) -> MatrixFiles {
        MatrixFiles {
            mass: dir.join("M.mtx"),
            stiffness: dir.join("K.mtx"),
            nodes: dir.join("nodes.csv"),
            dofs: dir.join("dofs.csv"),
            damping,
        }
    }
}

/// A structure's matrices and tables given in memory instead of files (the Python package's
/// `Structure.from_matrices`), each checked as its file would be ([`from_entries`],
/// [`nodes_from_rows`], [`dofs_from_rows`]); messages name `name` and the argument
/// (`NAME: M`, `NAME: nodes` row 3).
#[derive(Clone, Debug)]
pub struct StructureParts {
    /// What messages call it (e.g. `Structure.from_matrices`).
    pub name: String,
    /// `M`.
    pub mass: SymTriplets,
    /// `K`.
    pub stiffness: SymTriplets,
    /// A damping matrix `C`, if given.
    pub damping: Option<SymTriplets>,
    /// The nodes.
    pub nodes: Vec<Node>,
    /// The DOF table.
    pub dofs: DofTable,
}

/// A matrix given in memory: its rows and its 0-based entries `(row, column, value)`.
pub type Entries<'a> = (usize, &'a [(usize, usize, f64)]);

impl StructureParts {
    /// Checks matrices and tables given in memory (sizes agree, symmetric, every equation in
    /// the DOF table once, known nodes) and that `M` and `K` are positive definite
    /// ([`ImportedStructure::from_parts`]); nothing else is computed.
    pub fn new(
        name: &str,
        mass: Entries<'_>,
        stiffness: Entries<'_>,
        damping: Option<Entries<'_>>,
        nodes: Vec<Vec<String>>,
        dofs: Vec<Vec<String>>,
    ) -> Result<StructureParts, Diagnostics> {
        let arg = |a: &str| format!("{name}: {a}");
        let m = from_entries(mass.0, mass.1, &arg("M"))?;
        let same = |what: &str, n: usize| -> Result<(), Diagnostics> {
            if n == m.n {
                return Ok(());
            }
            let msg = format!("{n} rows, but M has {}", m.n);
            Err(Diagnostic::new(Kind::InvalidValue, arg(what), msg).into())
        };
        same("K", stiffness.0)?;
        let k = from_entries(stiffness.0, stiffness.1, &arg("K"))?;
        let c = match damping {
            Some(c) => {
                same("C", c.0)?;
                Some(from_entries(c.0, c.1, &arg("C"))?)
            }
            None => None,
        };
        let nodes = nodes_from_rows(nodes, &arg("nodes"))?;
        let dofs = dofs_from_rows(dofs, &arg("dofs"), m.n, &nodes)?;
        let parts = StructureParts {
            name: name.to_string(),
            mass: m,
            stiffness: k,
            damping: c,
            nodes,
            dofs,
        };
        parts.model(&DampingInput::None)?;
        Ok(parts)
    }

    /// The structure of these parts damped by `damping` (`DampingInput::Matrix`: the given
    /// `C`, whatever its path), checked as [`ImportedStructure::from_parts`] does.
    pub fn model(&self, damping: &DampingInput) -> Result<ImportedStructure, Diagnostics> {
        let name = |a: &str| PathBuf::from(format!("{}: {a}", self.name));
        let (damping, c) = match (damping, &self.damping) {
            (DampingInput::Matrix(_), Some(c)) => {
                (DampingInput::Matrix(name("C")), Some(c.clone()))
            }
            (DampingInput::Matrix(_), None) => {
                let msg = "damping by a matrix, but no C was given";
                return Err(Diagnostic::new(Kind::InvalidValue, self.name.clone(), msg).into());
            }
            (d, _) => (d.clone(), None),
        };
        ImportedStructure::from_parts(
            self.mass.clone(),
            self.stiffness.clone(),
            c,
            &damping,
            self.nodes.clone(),
            self.dofs.clone(),
            (&name("M"), &name("K")),
        )
    }
}

/// A structure read from matrices and tables.
#[derive(Clone, Debug)]
pub struct ImportedStructure {
    /// `M`.
    pub mass: SparseSym,
    /// `K`.
    pub stiffness: SparseSym,
    /// `B` (`None`: undamped).
    pub damping: Option<SparseSym>,
    /// The Rayleigh coefficients `(a, b)` when the damping was given as ratios.
    pub rayleigh: Option<(f64, f64)>,
    /// The nodes.
    pub nodes: Vec<Node>,
    /// The DOF table.
    pub dofs: DofTable,
}

fn whole_file(file: &Path, message: String) -> Diagnostics {
    Diagnostic::new(Kind::InvalidValue, file.display().to_string(), message).into()
}

impl ImportedStructure {
    /// Reads and checks the files.
    pub fn from_files(f: &MatrixFiles) -> Result<ImportedStructure, Diagnostics> {
        let mass = read_matrix_market(&f.mass)?;
        let stiffness = read_matrix_market(&f.stiffness)?;
        if stiffness.n != mass.n {
            return Err(whole_file(
                &f.stiffness,
                format!(
                    "{} rows, but the mass matrix {} has {}",
                    stiffness.n,
                    f.mass.display(),
                    mass.n
                ),
            ));
        }
        let nodes = read_nodes(&f.nodes)?;
        let dofs = read_dofs(&f.dofs, mass.n, &nodes)?;
        let damping = match &f.damping {
            DampingInput::Matrix(p) => {
                let c = read_matrix_market(p)?;
                if c.n != mass.n {
                    return Err(whole_file(
                        p,
                        format!("{} rows, but the mass matrix has {}", c.n, mass.n),
                    ));
                }
                Some(c)
            }
            _ => None,
        };
        Self::from_parts(
            mass,
            stiffness,
            damping,
            &f.damping,
            nodes,
            dofs,
            (&f.mass, &f.stiffness),
        )
    }

    /// Builds and checks a structure from matrices already read (`files` name `M` and `K`
    /// in messages).
    pub fn from_parts(
        mass: SymTriplets,
        stiffness: SymTriplets,
        damping_matrix: Option<SymTriplets>,
        damping: &DampingInput,
        nodes: Vec<Node>,
        dofs: DofTable,
        files: (&Path, &Path),
    ) -> Result<ImportedStructure, Diagnostics> {
        let sparse = |t: &SymTriplets, file: &Path| {
            SparseSym::from_lower(t).map_err(|e| whole_file(file, e.to_string()))
        };
        let m = sparse(&mass, files.0)?;
        let k = sparse(&stiffness, files.1)?;
        m.factorize("mass matrix")
            .map_err(|e| whole_file(files.0, e.to_string()))?;
        k.factorize("stiffness matrix (supports must be eliminated from it)")
            .map_err(|e| whole_file(files.1, e.to_string()))?;
        let (b, rayleigh) = match damping {
            DampingInput::None => (None, None),
            DampingInput::Matrix(p) => {
                let c = damping_matrix.expect("read with the input");
                (Some(sparse(&c, p)?), None)
            }
            &DampingInput::Ratios([(m1, z1), (m2, z2)]) => {
                let top = m1.max(m2);
                if m1 == 0 || m2 == 0 || m1 == m2 || top > m.n() {
                    return Err(whole_file(
                        files.1,
                        format!(
                            "damping ratios at modes {m1} and {m2}: expected two different modes between 1 and {}",
                            m.n()
                        ),
                    ));
                }
                let modes =
                    lowest_modes(&k, &m, top).map_err(|e| whole_file(files.1, e.to_string()))?;
                let w = |i: usize| modes.eigenvalues[i - 1].sqrt();
                let (a, bb) = fem_beam::rayleigh_from_ratios([w(m1), w(m2)], [z1, z2]);
                (Some(m.combination(a, &k, bb)), Some((a, bb)))
            }
        };
        Ok(ImportedStructure {
            mass: m,
            stiffness: k,
            damping: b,
            rayleigh,
            nodes,
            dofs,
        })
    }

    /// Number of equations.
    pub fn dof_count(&self) -> usize {
        self.mass.n()
    }
}
