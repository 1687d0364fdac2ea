//! An imported structure: sparse `M`, `K`, damping `B` (Rayleigh from two modal ratios, as
//! `[beam.damping]`, or a matrix file) and the node and DOF tables, checked before any
//! work: sizes agree, the tables cover every equation once, `M` and `K` are positive
//! definite (supports eliminated in the matrices).

use std::path::{Path, PathBuf};

use diagnostic::{Diagnostic, Diagnostics, Kind};

use crate::modes::lowest_modes;
use crate::mtx::{SymTriplets, read_matrix_market};
use crate::sparse::SparseSym;
use crate::tables::{DofTable, Node, read_dofs, read_nodes};

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
