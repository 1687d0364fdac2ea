//! A fixed-free spring–mass chain: `n` masses `m`, `n` springs `k` (the first to the
//! ground). Its eigenvalues are known in closed form:
//!
//! ```text
//! omega_j^2 = 4 k / m sin^2((2 j - 1) pi / (2 (2 n + 1))),   j = 1..n
//! ```

use fem_structure::mtx::SymTriplets;
use fem_structure::{SparseSym, lowest_modes};

/// `(K, M)` of the chain.
pub fn chain(n: usize, k: f64, m: f64) -> (SparseSym, SparseSym) {
    let mut kl = Vec::new();
    for i in 0..n {
        let d = if i + 1 < n { 2.0 * k } else { k };
        kl.push((i, i, d));
        if i + 1 < n {
            kl.push((i + 1, i, -k));
        }
    }
    let ml = (0..n).map(|i| (i, i, m)).collect();
    (
        SparseSym::from_lower(&SymTriplets { n, lower: kl }).unwrap(),
        SparseSym::from_lower(&SymTriplets { n, lower: ml }).unwrap(),
    )
}

/// The closed-form eigenvalue `j` (1-based).
pub fn exact(n: usize, k: f64, m: f64, j: usize) -> f64 {
    let s = ((2 * j - 1) as f64 * std::f64::consts::PI / (2.0 * (2 * n + 1) as f64)).sin();
    4.0 * k / m * s * s
}

#[test]
fn modes_of_a_chain_match_the_closed_form() {
    let (n, k, m) = (200, 1e5, 2.0);
    let (ks, ms) = chain(n, k, m);
    let modes = lowest_modes(&ks, &ms, 6).unwrap();
    for j in 1..=6 {
        let e = exact(n, k, m, j);
        let rel = (modes.eigenvalues[j - 1] - e).abs() / e;
        assert!(
            rel < 1e-10,
            "mode {j}: {} vs {e} ({rel:e})",
            modes.eigenvalues[j - 1]
        );
        let phi = modes.shapes.column(j - 1);
        assert!((ms.quadratic_form(phi.as_slice()) - 1.0).abs() < 1e-12);
    }
    assert!(modes.iterations < fem_structure::MAX_ITERATIONS);
}

#[test]
fn all_modes_of_a_small_chain_in_one_projection() {
    let (n, k, m) = (12, 3.0, 0.5);
    let (ks, ms) = chain(n, k, m);
    let modes = lowest_modes(&ks, &ms, n).unwrap();
    for j in 1..=n {
        let e = exact(n, k, m, j);
        assert!((modes.eigenvalues[j - 1] - e).abs() < 1e-12 * exact(n, k, m, n));
    }
    assert!(lowest_modes(&ks, &ms, n + 1).is_err());
}
