//! Regression: 30 modes of a 500-element cantilever written as matrices (1,000 equations).
//! Its stiffness is badly conditioned (`cond ~ n^4` and the rotations' scale), so the
//! inverse-iteration residual of a converged mode stalls at the solves' rounding floor far
//! above any fixed tolerance; the stopping rule must accept the modes there
//! (docs/theory.md section 13.1) and they must be the pencil's: compared with a dense
//! symmetric eigen-solution of `L^-1 K L^-T` (`M = L L^T`, nalgebra).

use fem_beam::{Beam, BeamModel};
use fem_structure::{DampingInput, ImportedStructure};
use fem_structure::{SparseSym, beam_structure_files, lowest_modes, rounding_floor};
use nalgebra::DMatrix;

/// The cantilever: steel, 1 m, 40 x 8 mm, `elements` elements, clamped at x = 0.
pub fn cantilever(elements: usize) -> BeamModel {
    let b = Beam::from_toml_str(
        &format!(
            "[[segment]]\nlength = 1.0\nyoungs_modulus = 210e9\ndensity = 7850.0\nwidth = 0.04\nheight = 0.008\nelements = {elements}\n\n[[support]]\nx = 0.0\nkind = \"clamped\"\n"
        ),
        "cantilever.toml",
    )
    .unwrap();
    BeamModel::new(&b).unwrap()
}

/// The cantilever read back from its files.
pub fn cantilever_structure(elements: usize) -> ImportedStructure {
    let d = std::env::temp_dir().join(format!(
        "fem-structure-{}-cantilever-{elements}",
        std::process::id()
    ));
    let mut files = beam_structure_files(&cantilever(elements))
        .write_to(&d)
        .unwrap();
    files.damping = DampingInput::None;
    let s = ImportedStructure::from_files(&files).unwrap();
    std::fs::remove_dir_all(&d).unwrap();
    s
}

fn dense(a: &SparseSym) -> DMatrix<f64> {
    let n = a.n();
    let mut d = DMatrix::zeros(n, n);
    for j in 0..n {
        for (i, v) in a.column(j) {
            d[(i, j)] = v;
        }
    }
    d
}

/// All 30 modes converge (the stall rule at the solves' rounding floor, scaled by each
/// mode's [`rounding_floor`]) and equal two independent solutions of the same pencil.
///
/// What "equal" can mean is set by the data: a rounding of every stored entry of `K`, `M`
/// by one part in `1/eps` moves `lambda_i` by up to `eps (|x|^T|K||x| + lambda |x|^T|M||x|)`
/// ([`rounding_floor`] times `lambda`): 5.4e-5 relative for the first mode of this
/// beam, 1e-11 for the 30th. The eigenvalues are compared to that bound with
/// - a dense symmetric eigen-solution of the inverted pencil `L^-1 M L^-T v = v / lambda`
///   (`K = L L^T` by nalgebra's Cholesky), whose low modes are its largest eigenvalues
///   and so carry the solver's normwise error `eps / lambda_1` relatively lightly (the
///   form `L^-1 K L^-T` with `M = L L^T` carries `eps lambda_max`, measured up to 3.5
///   times the bound for modes 3 to 5, so it is not used);
/// - fem-beam's own modal analysis of the beam (banded, refined solves).
///
/// Shapes: a perturbation `dK` moves the unit-modal-mass shape by about `|dK x| / gap`, so
/// each shape is compared to the dense one to 10 x that bound with `|dK x| = eps
/// |x|^T|K||x|`, the gap being the distance to the nearest other eigenvalue.
///
/// Measured (one run): 17 iterations; before the fix (Rayleigh–Ritz with `Y^T K Y`
/// computed from products with `K`, whose rounding is `eps lambda_max`, and a fixed
/// 1e-8 floor) the first Ritz value wandered by 4e-7 and the residual stalled at 2e-6:
/// NoConvergence after 500 iterations.
#[test]
fn thirty_modes_of_a_500_element_beam_converge_to_the_dense_solution() {
    let s = cantilever_structure(500);
    assert_eq!(s.dof_count(), 1000);
    let count = 30;
    let start = std::time::Instant::now();
    let ours = lowest_modes(&s.stiffness, &s.mass, count).unwrap();
    let took = start.elapsed();
    assert!(ours.iterations < 60, "{} iterations", ours.iterations);
    let (k, m) = (dense(&s.stiffness), dense(&s.mass));
    let li = k.clone().cholesky().unwrap().l().try_inverse().unwrap();
    let b = &li * &m * li.transpose();
    let e = ((&b + b.transpose()) * 0.5).symmetric_eigen();
    let mut order: Vec<usize> = (0..1000).collect();
    order.sort_by(|&i, &j| e.eigenvalues[j].total_cmp(&e.eigenvalues[i]));
    let dense_lambda: Vec<f64> = order.iter().map(|&o| 1.0 / e.eigenvalues[o]).collect();
    let beam = cantilever(500).modes(count).unwrap().frequencies_hz();
    let (mut worst_dense, mut worst_beam, mut worst_shape) = (0.0f64, 0.0f64, 0.0f64);
    for c in 0..count {
        let l = ours.eigenvalues[c];
        let x = ours.shapes.column(c);
        let bound = rounding_floor(&s.stiffness, &s.mass, l, x.as_slice());
        let rel = (l - dense_lambda[c]).abs() / l / bound;
        let w = 2.0 * std::f64::consts::PI * beam[c];
        let rel_beam = (l - w * w).abs() / l / bound;
        assert!(
            rel <= 1.0,
            "mode {}: {l} vs dense {} ({rel} of the bound {bound:e})",
            c + 1,
            dense_lambda[c]
        );
        assert!(
            rel_beam <= 1.0,
            "mode {}: {l} vs fem-beam {} ({rel_beam} of the bound)",
            c + 1,
            w * w
        );
        worst_dense = worst_dense.max(rel);
        worst_beam = worst_beam.max(rel_beam);
        let o = order[c];
        let phi = li.transpose() * e.eigenvectors.column(o) / e.eigenvalues[o].sqrt();
        let sign = x.dot(&(&m * &phi)).signum();
        let gap = [c.checked_sub(1), Some(c + 1)]
            .into_iter()
            .flatten()
            .map(|j| (dense_lambda[j] - l).abs())
            .fold(f64::INFINITY, f64::min);
        let dk = f64::EPSILON * s.stiffness.abs_quadratic_form(x.as_slice());
        let shape_bound = 10.0 * dk / gap * phi.amax();
        let d = (x - &phi * sign).amax() / shape_bound;
        assert!(
            d <= 1.0,
            "mode {} shape: {d} of the bound {shape_bound:e}",
            c + 1
        );
        worst_shape = worst_shape.max(d);
    }
    eprintln!(
        "500-element cantilever, {count} modes in {took:?} ({} iterations); eigenvalue differences at most {worst_dense:.3} (dense) and {worst_beam:.3} (fem-beam) of the data's rounding bound, shapes at most {worst_shape:.3} of theirs",
        ours.iterations
    );
}
