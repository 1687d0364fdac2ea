//! The built-in beam written as a `matrices` structure (docs/theory.md section 13.1): its
//! reduced mass `A`, stiffness `C` and damping `B` (supports eliminated, eq. 44) as Matrix
//! Market files in the beam's own DOF order, and the node and DOF tables, so that the same
//! structure can be run as a beam and as imported matrices and the results compared.
//!
//! ```text
//! nodes.csv   id,x,y      id = the beam's node index (0 at x = 0), y = 0
//! dofs.csv    eq,node,dof eq = the beam's reduced DOF index; uy = transverse q_2, rz = rotation q_6
//! M.mtx, K.mtx, C.mtx     lower triangles of A, C, B (C.mtx only for a damped beam)
//! ```
//!
//! Nodes whose DOFs are all locked (a clamped end) are listed in `nodes.csv` too, with no
//! row in `dofs.csv`. The values are written in shortest round-trip form, so the files
//! read back to the beam's matrices entry for entry.

use std::path::Path;

use fem_beam::{BandedSym, BeamModel, Dof};

use crate::model::{DampingInput, MatrixFiles};
use crate::mtx::{SymTriplets, write_matrix_market};
use crate::tables::NodeDof;

/// The texts of a `matrices` structure's files.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StructureFiles {
    /// `M.mtx`.
    pub mass: String,
    /// `K.mtx`.
    pub stiffness: String,
    /// `C.mtx` (`None`: undamped).
    pub damping: Option<String>,
    /// `nodes.csv`.
    pub nodes: String,
    /// `dofs.csv`.
    pub dofs: String,
}

impl StructureFiles {
    /// Writes the files into `dir` (created if missing) as `M.mtx`, `K.mtx`, `C.mtx` (when
    /// damped), `nodes.csv`, `dofs.csv`, and returns their paths as a [`MatrixFiles`] (the
    /// damping as [`DampingInput::Matrix`], or [`DampingInput::None`]).
    pub fn write_to(&self, dir: &Path) -> std::io::Result<MatrixFiles> {
        std::fs::create_dir_all(dir)?;
        let damping = match &self.damping {
            Some(c) => {
                let p = dir.join("C.mtx");
                std::fs::write(&p, c)?;
                DampingInput::Matrix(p)
            }
            None => DampingInput::None,
        };
        let files = MatrixFiles::in_directory(dir, damping);
        std::fs::write(&files.mass, &self.mass)?;
        std::fs::write(&files.stiffness, &self.stiffness)?;
        std::fs::write(&files.nodes, &self.nodes)?;
        std::fs::write(&files.dofs, &self.dofs)?;
        Ok(files)
    }
}

fn mtx(a: &BandedSym) -> String {
    write_matrix_market(&SymTriplets {
        n: a.size(),
        lower: a.lower_triplets(),
    })
}

/// The files of a beam model: its reduced `A`, `C` (and `B` when the beam is damped, i.e.
/// its Rayleigh coefficients are not both zero) in the beam's reduced DOF order, its nodes
/// along x (ids = node indices) and the DOF table (`uy` transverse, `rz` rotation).
pub fn beam_structure_files(beam: &BeamModel) -> StructureFiles {
    let mut nodes = String::from("id,x,y\n");
    for (i, x) in beam.beam().node_positions().iter().enumerate() {
        nodes.push_str(&format!("{i},{x:?},0.0\n"));
    }
    let mut dofs = String::from("eq,node,dof\n");
    for eq in 0..beam.dof_count() {
        let (node, dof) = beam
            .dofs()
            .node_dof(eq)
            .expect("a reduced index below the count");
        let name = match dof {
            Dof::Transverse => NodeDof::Uy,
            Dof::Rotation => NodeDof::Rz,
        };
        dofs.push_str(&format!("{eq},{node},{}\n", name.as_str()));
    }
    let (alpha, beta) = beam.rayleigh_coefficients();
    StructureFiles {
        mass: mtx(beam.mass()),
        stiffness: mtx(beam.stiffness()),
        damping: (alpha != 0.0 || beta != 0.0).then(|| mtx(beam.damping())),
        nodes,
        dofs,
    }
}
