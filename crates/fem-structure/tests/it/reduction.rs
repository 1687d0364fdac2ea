//! Craig–Bampton against the full model.

use fem_structure::craig_bampton;
use nalgebra::{DMatrix, DVector};

use crate::chain::{chain, exact};

/// Eigenvalues of a small dense generalized problem, ascending.
pub fn dense_eigenvalues(k: &DMatrix<f64>, m: &DMatrix<f64>) -> Vec<f64> {
    let l = m.clone().cholesky().unwrap();
    let li = l.l().try_inverse().unwrap();
    let a = &li * k * li.transpose();
    let a = (&a + a.transpose()) * 0.5;
    let mut e: Vec<f64> = a.symmetric_eigen().eigenvalues.iter().copied().collect();
    e.sort_by(f64::total_cmp);
    e
}

/// With every fixed-interface mode kept `T` is square: the reduced model has the full
/// model's eigenvalues (closed form) to round-off.
#[test]
fn craig_bampton_with_all_modes_equals_the_full_model() {
    let (n, k, m) = (30, 4.0e3, 1.5);
    let (ks, ms) = chain(n, k, m);
    let r = craig_bampton(&ks, &ms, None, &[29, 0, 14, 14], n).unwrap();
    assert_eq!(r.interface, vec![0, 14, 29]);
    assert_eq!(r.dof_count(), n);
    let e = dense_eigenvalues(&r.stiffness, &r.mass);
    let top = exact(n, k, m, n);
    for j in 1..=n {
        let d = (e[j - 1] - exact(n, k, m, j)).abs();
        assert!(
            d < 1e-12 * top,
            "mode {j}: {} vs {}",
            e[j - 1],
            exact(n, k, m, j)
        );
    }
}

/// Loads on the interface: the reduced static response is the full one whatever the
/// number of modes (the constraint modes are the static shapes).
#[test]
fn static_interface_loads_are_exact_with_few_modes() {
    let (n, k, m) = (40, 1.0e4, 1.0);
    let (ks, ms) = chain(n, k, m);
    let r = craig_bampton(&ks, &ms, None, &[10, 39], 2).unwrap();
    let mut f = vec![0.0; n];
    f[10] = 3.0;
    f[39] = -1.0;
    let mut full = f.clone();
    ks.factorize("K").unwrap().solve_in_place(&mut full);
    let fr = r.transform.transpose() * DVector::from_column_slice(&f);
    let z = r.stiffness.clone().lu().solve(&fr).unwrap();
    let q = r.expand(z.as_slice());
    let scale = full.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    for (a, b) in q.iter().zip(&full) {
        assert!((a - b).abs() < 1e-12 * scale, "{a} vs {b}");
    }
}

/// 15, 30 and 60 fixed-interface modes on 1,200 equations. Craig–Bampton is a
/// Rayleigh–Ritz method with nested subspaces, so each reduced eigenvalue lies above the
/// exact one (closed form) and comes down as modes are added; on a chain (a string, the
/// densest spectrum there is) the error falls at least fourfold when the modes double.
#[test]
fn more_modes_bring_the_frequencies_down_to_the_exact_ones() {
    let (n, k, m) = (1200, 1.0e6, 0.1);
    let (ks, ms) = chain(n, k, m);
    let mut last = [f64::INFINITY; 3];
    for modes in [15, 30, 60] {
        let start = std::time::Instant::now();
        let r = craig_bampton(&ks, &ms, None, &[300, 799, 1199], modes).unwrap();
        let took = start.elapsed();
        assert_eq!(r.dof_count(), 3 + modes);
        let e = dense_eigenvalues(&r.stiffness, &r.mass);
        for j in 1..=3 {
            let x = exact(n, k, m, j);
            let err = (e[j - 1] - x) / x;
            assert!(err > -1e-12, "mode {j} below the exact value: {err:e}");
            assert!(
                4.0 * err < last[j - 1],
                "modes {modes}, mode {j}: {err:e} after {:e}",
                last[j - 1]
            );
            last[j - 1] = err;
        }
        eprintln!(
            "craig_bampton 1200 equations, 3 interface DOFs, {modes} modes: {took:?}, first-mode eigenvalue error {:e}",
            last[0]
        );
    }
}
