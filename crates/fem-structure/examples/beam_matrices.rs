//! Writes a pinned–pinned steel beam (1 m, 40 x 8 mm, the beam of the structure tests) of
//! ELEMENTS elements as a `matrices` structure ([`fem_structure::beam_structure_files`]):
//! `M.mtx`, `K.mtx`, `nodes.csv` (ids 0..=ELEMENTS along x), `dofs.csv` (`uy`, `rz`) into
//! DIR, undamped (a scenario gives its damping as modal ratios). Prints the equations and
//! the stored entries of `K` (both triangles). Used by `scripts/structure-scaling`.
//!
//! ```text
//! cargo run --release -p fem-structure --example beam_matrices -- ELEMENTS DIR
//! ```

use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [elements, dir] = args.as_slice() else {
        eprintln!("usage: beam_matrices ELEMENTS DIR");
        return ExitCode::from(2);
    };
    let Ok(elements) = elements.parse::<usize>() else {
        eprintln!("beam_matrices: ELEMENTS must be a positive integer, not {elements:?}");
        return ExitCode::from(2);
    };
    let spec = format!(
        "[[segment]]\nlength = 1.0\nyoungs_modulus = 210e9\ndensity = 7850.0\nwidth = 0.040\n\
         height = 0.008\nelements = {elements}\n[[support]]\nx = 0.0\nkind = \"pinned\"\n\
         [[support]]\nx = 1.0\nkind = \"pinned\"\n"
    );
    let model = fem_beam::Beam::from_toml_str(&spec, "beam_matrices")
        .map_err(|e| e.to_string())
        .and_then(|b| fem_beam::BeamModel::new(&b).map_err(|e| e.to_string()));
    let model = match model {
        Ok(m) => m,
        Err(e) => {
            eprintln!("beam_matrices: {e}");
            return ExitCode::FAILURE;
        }
    };
    let files = fem_structure::beam_structure_files(&model);
    if let Err(e) = files.write_to(std::path::Path::new(dir)) {
        eprintln!("beam_matrices: {dir}: {e}");
        return ExitCode::FAILURE;
    }
    // Entry lines of the one-triangle file: the diagonal once, the rest twice in K.
    let (mut diagonal, mut off) = (0usize, 0usize);
    for line in files
        .stiffness
        .lines()
        .filter(|l| !l.starts_with('%'))
        .skip(1)
    {
        let mut f = line.split_whitespace();
        match (f.next(), f.next()) {
            (Some(i), Some(j)) if i == j => diagonal += 1,
            (Some(_), Some(_)) => off += 1,
            _ => {}
        }
    }
    println!(
        "equations {} nnz_k {}",
        model.dof_count(),
        diagonal + 2 * off
    );
    ExitCode::SUCCESS
}
