//! The files: a structure read back from files, Rayleigh damping from ratios, and each
//! kind of bad input as one line naming the file (and line).

use std::path::{Path, PathBuf};

use fem_structure::mtx::write_matrix_market;
use fem_structure::{DampingInput, ImportedStructure, MatrixFiles, lowest_modes};

use crate::chain::chain;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fem-structure-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(d: &Path, name: &str, text: &str) -> PathBuf {
    let p = d.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A 4-mass chain written out, its nodes along x, one `ux` each.
fn files(d: &Path) -> MatrixFiles {
    let (k, m) = chain(4, 100.0, 2.0);
    MatrixFiles {
        mass: write(d, "M.mtx", &write_matrix_market(&m.lower())),
        stiffness: write(d, "K.mtx", &write_matrix_market(&k.lower())),
        nodes: write(d, "nodes.csv", "id,x,y\n1,0,0\n2,1,0\n3,2,0\n4,3,0\n"),
        dofs: write(
            d,
            "dofs.csv",
            "eq,node,dof\n0,1,ux\n1,2,ux\n2,3,ux\n3,4,ux\n",
        ),
        damping: DampingInput::Ratios([(1, 0.01), (2, 0.03)]),
    }
}

#[test]
fn a_structure_from_files_with_rayleigh_damping() {
    let d = dir("ok");
    let s = ImportedStructure::from_files(&files(&d)).unwrap();
    assert_eq!(s.dof_count(), 4);
    assert_eq!(s.dofs.equation[&(3, fem_structure::tables::NodeDof::Ux)], 2);
    let modes = lowest_modes(&s.stiffness, &s.mass, 2).unwrap();
    let b = s.damping.as_ref().unwrap();
    for (i, z) in [(0, 0.01), (1, 0.03)] {
        let phi = modes.shapes.column(i);
        let zeta = b.quadratic_form(phi.as_slice()) / (2.0 * modes.eigenvalues[i].sqrt());
        assert!((zeta - z).abs() < 1e-12, "{zeta} vs {z}");
    }
    std::fs::remove_dir_all(d).unwrap();
}

#[test]
fn an_element_table_names_known_nodes() {
    let nodes = fem_structure::tables::parse_nodes("id,x,y\n1,0,0\n2,1,0\n", "n.csv").unwrap();
    let p = |t: &str| fem_structure::tables::parse_elements(t, "e.csv", &nodes);
    assert_eq!(p("node1,node2\n1,2\n").unwrap(), vec![(1, 2)]);
    let e = p("node1,node2\n1,2\n2,3\n").unwrap_err().to_string();
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.contains("e.csv:3: unknown node 3"), "{e}");
    let e = p("a,b\n1,2\n").unwrap_err().to_string();
    assert!(
        e.contains("e.csv:1: header `a,b`: expected `node1,node2`"),
        "{e}"
    );
}

fn error(f: &MatrixFiles) -> String {
    let e = ImportedStructure::from_files(f).unwrap_err().to_string();
    assert!(!e.contains('\n'), "one line: {e}");
    e
}

/// The files are refused with one line containing `want`.
fn expect(f: &MatrixFiles, want: &str) {
    let e = error(f);
    assert!(e.contains(want), "{e}");
}

#[test]
fn bad_input_is_one_line_naming_file_and_line() {
    let d = dir("bad");
    let good = files(&d);
    let h = "%%MatrixMarket matrix coordinate real symmetric\n";
    let f = MatrixFiles {
        mass: write(
            &d,
            "Mneg.mtx",
            &format!("{h}4 4 4\n1 1 1\n2 2 -1\n3 3 1\n4 4 1\n"),
        ),
        ..good.clone()
    };
    expect(&f, "Mneg.mtx: the mass matrix is not positive definite");
    let f = MatrixFiles {
        stiffness: write(&d, "K3.mtx", &format!("{h}3 3 3\n1 1 1\n2 2 1\n3 3 1\n")),
        ..good.clone()
    };
    expect(&f, "K3.mtx: 3 rows, but the mass matrix");
    let f = MatrixFiles {
        dofs: write(
            &d,
            "d1.csv",
            "eq,node,dof\n0,1,ux\n1,2,ux\n1,3,ux\n3,4,ux\n",
        ),
        ..good.clone()
    };
    expect(&f, "d1.csv:4: equation 1 listed twice (first on line 3)");
    let f = MatrixFiles {
        dofs: write(&d, "d2.csv", "eq,node,dof\n0,1,ux\n1,2,ux\n3,4,ux\n"),
        ..good.clone()
    };
    expect(&f, "d2.csv: 1 equation(s) of the matrices have no row: 2");
    let f = MatrixFiles {
        dofs: write(
            &d,
            "d3.csv",
            "eq,node,dof\n0,1,ux\n1,2,ux\n2,9,ux\n3,4,ux\n",
        ),
        ..good.clone()
    };
    expect(&f, "d3.csv:4: unknown node 9");
    let f = MatrixFiles {
        stiffness: write(
            &d,
            "Kg.mtx",
            "%%MatrixMarket matrix coordinate real general\n4 4 2\n1 1 1\n1 2 0.5\n",
        ),
        ..good.clone()
    };
    expect(&f, "Kg.mtx:4: the matrix is not symmetric");
    // Refused from the size line: the entries after it (here not even entries) are never
    // read, and the message names the declared count and the limit.
    let f = MatrixFiles {
        mass: write(
            &d,
            "Mbig.mtx",
            &format!("{h}4000 4000 10000000\n1 1 1\nnot an entry\n"),
        ),
        ..good.clone()
    };
    expect(
        &f,
        "Mbig.mtx:2: 10000000 entries declared: more than the 5000000",
    );
    let f = MatrixFiles {
        stiffness: write(
            &d,
            "Knan.mtx",
            &format!("{h}4 4 4\n1 1 1\n2 2 1\n3 3 NaN\n4 4 1\n"),
        ),
        ..good.clone()
    };
    expect(&f, "Knan.mtx:5: entry (3, 3) is NaN (not a finite number)");
    // A free-free chain: the supports were not eliminated, K is singular.
    let f = MatrixFiles {
        stiffness: write(
            &d,
            "Kfree.mtx",
            &format!("{h}4 4 7\n1 1 1\n2 1 -1\n2 2 2\n3 2 -1\n3 3 2\n4 3 -1\n4 4 1\n"),
        ),
        ..good.clone()
    };
    expect(
        &f,
        "Kfree.mtx: the stiffness matrix (supports must be eliminated from it) is not positive definite",
    );
    let f = MatrixFiles {
        dofs: write(
            &d,
            "d4.csv",
            "eq,node,dof\n0,1,ux\n1,2,ux\n2,2,ux\n3,4,ux\n",
        ),
        ..good.clone()
    };
    expect(&f, "d4.csv:4: node 2 ux listed twice");
    let f = MatrixFiles {
        nodes: write(&d, "n1.csv", "id,x,y\n1,0,0\n2,1,0\n3,2,nan\n4,3,0\n"),
        ..good.clone()
    };
    expect(
        &f,
        "n1.csv:4: expected a non-negative integer id and finite coordinates",
    );
    std::fs::remove_dir_all(d).unwrap();
}

/// The same chain given in memory (both triangles, rows of texts) is the structure its files
/// are, bit for bit; the in-memory checks name the argument and the row or entry.
#[test]
fn a_structure_given_in_memory_is_its_files() {
    use fem_structure::StructureParts;
    let d = dir("given");
    let f = files(&d);
    let from_files = ImportedStructure::from_files(&f).unwrap();
    let (k, m) = chain(4, 100.0, 2.0);
    let both = |t: &fem_structure::mtx::SymTriplets| -> Vec<(usize, usize, f64)> {
        t.lower
            .iter()
            .flat_map(|&(i, j, v)| {
                let mirror = (i != j).then_some((j, i, v));
                std::iter::once((i, j, v)).chain(mirror)
            })
            .collect()
    };
    let (me, ke) = (both(&m.lower()), both(&k.lower()));
    let rows = |t: &[&[&str]]| -> Vec<Vec<String>> {
        t.iter()
            .map(|r| r.iter().map(|s| s.to_string()).collect())
            .collect()
    };
    let nodes = rows(&[
        &["1", "0", "0"],
        &["2", "1", "0"],
        &["3", "2", "0"],
        &["4", "3", "0"],
    ]);
    let dofs = rows(&[
        &["0", "1", "ux"],
        &["1", "2", "ux"],
        &["2", "3", "ux"],
        &["3", "4", "ux"],
    ]);
    let parts = StructureParts::new(
        "given",
        (4, &me),
        (4, &ke),
        None,
        nodes.clone(),
        dofs.clone(),
    )
    .unwrap();
    let given = parts.model(&f.damping).unwrap();
    assert_eq!(given.mass.lower(), from_files.mass.lower());
    assert_eq!(given.stiffness.lower(), from_files.stiffness.lower());
    let b = |s: &ImportedStructure| s.damping.as_ref().unwrap().lower();
    assert_eq!(b(&given), b(&from_files));
    assert_eq!(given.rayleigh, from_files.rayleigh);
    assert_eq!(given.nodes, from_files.nodes);
    assert_eq!(given.dofs, from_files.dofs);

    let err = |m: &[(usize, usize, f64)], nodes: Vec<Vec<String>>, dofs: Vec<Vec<String>>| {
        StructureParts::new("given", (4, m), (4, &ke), None, nodes, dofs)
            .unwrap_err()
            .to_string()
    };
    // One triangle only (of K, given as M): not symmetric, the entry named 0-based.
    let lower: Vec<_> = k.lower().lower.clone();
    let e = err(&lower, nodes.clone(), dofs.clone());
    assert!(
        e.starts_with(
            "given: M: the matrix is not symmetric: entry [1, 0] = -1e2 but [0, 1] = 0e0"
        ),
        "{e}"
    );
    let mut outside = me.clone();
    outside.push((4, 0, 1.0));
    let e = err(&outside, nodes.clone(), dofs.clone());
    assert_eq!(
        e,
        "given: M: entry [4, 0] outside the 4 x 4 matrix (indices are 0-based)"
    );
    let mut unknown = dofs.clone();
    unknown[2][1] = "9".into();
    let e = err(&me, nodes.clone(), unknown);
    assert_eq!(e, "given: dofs: row 2: unknown node 9");
    let mut twice = nodes.clone();
    twice[3][0] = "1".into();
    let e = err(&me, twice, dofs.clone());
    assert!(
        e.starts_with("given: nodes: row 3: node 1 defined twice (first on row 0)"),
        "{e}"
    );
    let negative: Vec<_> = me.iter().map(|&(i, j, v)| (i, j, -v)).collect();
    let e = err(&negative, nodes, dofs);
    assert!(e.starts_with("given: M: "), "{e}");
}
