//! The built-in beam written as a `matrices` structure and read back: the same matrices
//! entry for entry, the beam's modes (fem-beam's own modal analysis) from our sparse
//! eigen-solver.

use fem_beam::{Beam, BeamModel, Dof};
use fem_structure::tables::NodeDof;
use fem_structure::{DampingInput, ImportedStructure, beam_structure_files, lowest_modes};

/// A damped two-segment steel beam, clamped at x = 0 and pinned at x = 1.2: its root node
/// has no DOFs, its pinned node only a rotation.
fn beam() -> BeamModel {
    let b = Beam::from_toml_str(
        r#"
        [[segment]]
        length = 0.8
        youngs_modulus = 210e9
        density = 7850.0
        width = 0.04
        height = 0.008
        elements = 16

        [[segment]]
        length = 0.6
        youngs_modulus = 70e9
        density = 2700.0
        width = 0.04
        height = 0.012
        elements = 12

        [[support]]
        x = 0.0
        kind = "clamped"

        [[support]]
        x = 1.2
        kind = "pinned"

        [damping]
        ratios = [{ mode = 1, ratio = 0.01 }, { mode = 3, ratio = 0.02 }]
        "#,
        "export.toml",
    )
    .unwrap();
    BeamModel::new(&b).unwrap()
}

#[test]
fn the_beam_as_matrices_reads_back_entry_for_entry() {
    let model = beam();
    let files = beam_structure_files(&model);
    assert_eq!(files, beam_structure_files(&model), "deterministic");
    let d = std::env::temp_dir().join(format!("fem-structure-{}-beam", std::process::id()));
    let paths = files.write_to(&d).unwrap();
    assert!(matches!(paths.damping, DampingInput::Matrix(_)));
    let s = ImportedStructure::from_files(&paths).unwrap();
    std::fs::remove_dir_all(&d).unwrap();

    let n = model.dof_count();
    assert_eq!(s.dof_count(), n);
    assert_eq!(s.nodes.len(), 29);
    for (node, x) in s.nodes.iter().zip(model.beam().node_positions()) {
        assert_eq!(node.position, [*x, 0.0, 0.0]);
    }
    // The DOF table is the beam's own order.
    for eq in 0..n {
        let (node, dof) = model.dofs().node_dof(eq).unwrap();
        let want = match dof {
            Dof::Transverse => NodeDof::Uy,
            Dof::Rotation => NodeDof::Rz,
        };
        assert_eq!(s.dofs.of_equation[eq], (node as u64, want), "equation {eq}");
    }
    assert_eq!(s.dofs.equation.get(&(0, NodeDof::Uy)), None, "clamped root");
    assert_eq!(
        s.dofs.equation[&(24, NodeDof::Rz)],
        model.dof_index(24, Dof::Rotation).unwrap()
    );
    // Identical matrices (the pattern too: no entry lost or added).
    let b = s.damping.as_ref().unwrap();
    for (ours, theirs) in [
        (&s.mass, model.mass()),
        (&s.stiffness, model.stiffness()),
        (b, model.damping()),
    ] {
        assert_eq!(ours.nnz(), 2 * theirs.lower_triplets().len() - n);
        for i in 0..n {
            for j in 0..n {
                assert_eq!(
                    ours.get(i, j).to_bits(),
                    theirs.get(i, j).to_bits(),
                    "({i}, {j})"
                );
            }
        }
    }
}

/// The beam's modes from the exported matrices: frequencies to 1e-10 relative against
/// fem-beam's modal analysis (refined solves, exact to rounding), shapes (unit modal mass)
/// up to sign to 1e-9 of their largest component. Our solves are plain sparse Cholesky
/// ones of the beam's ill-conditioned stiffness (`cond ~ n^4`), whose rounding reaches the
/// low eigenvalues as about `n^3 eps` (4e-11 at these 55 equations; measured: 5e-13 on the
/// frequencies, 1.2e-11 on the shapes).
#[test]
fn the_beam_as_matrices_has_the_beams_modes() {
    let model = beam();
    let d = std::env::temp_dir().join(format!("fem-structure-{}-beam-modes", std::process::id()));
    let s =
        ImportedStructure::from_files(&beam_structure_files(&model).write_to(&d).unwrap()).unwrap();
    std::fs::remove_dir_all(&d).unwrap();
    let count = 6;
    let theirs = model.modes(count).unwrap();
    let ours = lowest_modes(&s.stiffness, &s.mass, count).unwrap();
    let (fo, ft) = (ours.frequencies_hz(), theirs.frequencies_hz());
    let (mut worst_f, mut worst_shape) = (0.0f64, 0.0f64);
    for i in 0..count {
        let rel = (fo[i] - ft[i]).abs() / ft[i];
        worst_f = worst_f.max(rel);
        assert!(
            rel < 1e-10,
            "mode {}: {} vs {} Hz ({rel:e})",
            i + 1,
            fo[i],
            ft[i]
        );
        let a = ours.shapes.column(i);
        let b = theirs.shape(i);
        let sign = if a.dot(&nalgebra::DVector::from_column_slice(b)) < 0.0 {
            -1.0
        } else {
            1.0
        };
        let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (x, y) in a.iter().zip(b) {
            let e = (sign * x - y).abs() / scale;
            worst_shape = worst_shape.max(e);
            assert!(e < 1e-9, "mode {} shape: {x} vs {y}", i + 1);
        }
    }
    eprintln!(
        "beam as matrices: {count} modes, worst frequency difference {worst_f:e}, worst shape difference {worst_shape:e}"
    );
}

/// An undamped beam has no damping file.
#[test]
fn an_undamped_beam_has_no_damping_file() {
    let b = Beam::from_toml_str(
        "[[segment]]\nlength = 1.0\nyoungs_modulus = 210e9\ndensity = 7850.0\nwidth = 0.04\nheight = 0.008\nelements = 4\n\n[[support]]\nx = 0.0\nkind = \"clamped\"\n",
        "u.toml",
    )
    .unwrap();
    let f = beam_structure_files(&BeamModel::new(&b).unwrap());
    assert_eq!(f.damping, None);
    assert_eq!(f.dofs.lines().nth(1), Some("0,1,uy"));
    assert_eq!(f.nodes.lines().nth(5), Some("4,1.0,0.0"));
}
