//! The planar Euler–Bernoulli beam element (paper section 3, eqs. 26–41).
//!
//! Element coordinates (26) and loads (27), local = global (41):
//!
//! ```text
//!   q_e = col(q_i2, q_i6, q_j2, q_j6)     transverse displacement and rotation of nodes i, j
//!   P_e = col(P_i2, P_i6, P_j2, P_j6)     transverse forces and moments
//! ```

/// A 4 x 4 element matrix in the order of (26).
pub type ElementMatrix = [[f64; 4]; 4];

/// Cubic Hermite shape functions, eq. (35): row 0 gives the transverse displacement, row 1
/// the rotation (the x-derivative of row 0) at `zeta = x / l` along an element of length
/// `l`, as weights of the element coordinates (26):
///
/// ```text
///   [ 2z^3-3z^2+1     l(z^3-2z^2+z)   -2z^3+3z^2    l(z^3-z^2) ]
///   [ 6(z^2-z)/l      3z^2-4z+1        6(z-z^2)/l   3z^2-2z    ]
/// ```
pub fn shape_functions(zeta: f64, l: f64) -> [[f64; 4]; 2] {
    let z = zeta;
    let (z2, z3) = (z * z, z * z * z);
    [
        [
            2.0 * z3 - 3.0 * z2 + 1.0,
            l * (z3 - 2.0 * z2 + z),
            -2.0 * z3 + 3.0 * z2,
            l * (z3 - z2),
        ],
        [
            6.0 * (z2 - z) / l,
            3.0 * z2 - 4.0 * z + 1.0,
            6.0 * (z - z2) / l,
            3.0 * z2 - 2.0 * z,
        ],
    ]
}

/// Consistent mass matrix, eq. (38), of an element with density `rho`, cross-section area
/// `area` and length `l`:
///
/// ```text
///   rho A l / 420 * [ 156    22l    54    -13l  ]
///                   [ 22l    4l^2   13l   -3l^2 ]
///                   [ 54     13l    156   -22l  ]
///                   [ -13l   -3l^2  -22l  4l^2  ]
/// ```
pub fn mass_matrix(rho: f64, area: f64, l: f64) -> ElementMatrix {
    let c = rho * area * l / 420.0;
    let l2 = l * l;
    [
        [156.0 * c, 22.0 * l * c, 54.0 * c, -13.0 * l * c],
        [22.0 * l * c, 4.0 * l2 * c, 13.0 * l * c, -3.0 * l2 * c],
        [54.0 * c, 13.0 * l * c, 156.0 * c, -22.0 * l * c],
        [-13.0 * l * c, -3.0 * l2 * c, -22.0 * l * c, 4.0 * l2 * c],
    ]
}

/// Stiffness matrix, eq. (39), of an element with Young's modulus `e`, second moment of area
/// `i` and length `l`:
///
/// ```text
///   E I / l^3 * [ 12    6l     -12   6l    ]
///               [ 6l    4l^2   -6l   2l^2  ]
///               [ -12   -6l    12    -6l   ]
///               [ 6l    2l^2   -6l   4l^2  ]
/// ```
pub fn stiffness_matrix(e: f64, i: f64, l: f64) -> ElementMatrix {
    let c = e * i / (l * l * l);
    let l2 = l * l;
    [
        [12.0 * c, 6.0 * l * c, -12.0 * c, 6.0 * l * c],
        [6.0 * l * c, 4.0 * l2 * c, -6.0 * l * c, 2.0 * l2 * c],
        [-12.0 * c, -6.0 * l * c, 12.0 * c, -6.0 * l * c],
        [6.0 * l * c, 2.0 * l2 * c, -6.0 * l * c, 4.0 * l2 * c],
    ]
}

/// Largest eigenvalue of an element's stiffness (39) against its consistent mass (38),
/// `C_e phi = lambda A_e phi`, in units of `E J / (rho A l^4)` (the others are 0, 0 and 720).
/// By the element eigenvalue bound (Irons and Treharne), no `omega^2` of an assembled beam
/// exceeds the largest element value, so validation uses it to keep frequencies finite.
pub const ELEMENT_EIGENVALUE_MAX: f64 = 8400.0;

/// Rayleigh damping matrix, eq. (40): `B_e = alpha A_e + beta C_e`.
pub fn damping_matrix(
    alpha: f64,
    beta: f64,
    mass: &ElementMatrix,
    stiffness: &ElementMatrix,
) -> ElementMatrix {
    let mut b = [[0.0; 4]; 4];
    for r in 0..4 {
        for c in 0..4 {
            b[r][c] = alpha * mass[r][c] + beta * stiffness[r][c];
        }
    }
    b
}

/// Consistent nodal loads of a uniformly distributed transverse load `q` (force per length)
/// on an element of length `l`: `integral of N^T q` over the element with the shape
/// functions (35), i.e. `q l [1/2, l/12, 1/2, -l/12]`.
pub fn uniform_load(q: f64, l: f64) -> [f64; 4] {
    [
        q * l / 2.0,
        q * l * l / 12.0,
        q * l / 2.0,
        -q * l * l / 12.0,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gauss–Legendre with 4 points integrates polynomials of degree 7 exactly: enough for
    /// N^T N (degree 6) and N''^T N'' (degree 2).
    fn gauss4() -> [(f64, f64); 4] {
        let a = (3.0 / 7.0 - 2.0 / 7.0 * (6.0f64 / 5.0).sqrt()).sqrt();
        let b = (3.0 / 7.0 + 2.0 / 7.0 * (6.0f64 / 5.0).sqrt()).sqrt();
        let wa = (18.0 + 30.0f64.sqrt()) / 36.0;
        let wb = (18.0 - 30.0f64.sqrt()) / 36.0;
        // Mapped to [0, 1]: nodes (1 + t) / 2, weights w / 2.
        [
            ((1.0 - b) / 2.0, wb / 2.0),
            ((1.0 - a) / 2.0, wa / 2.0),
            ((1.0 + a) / 2.0, wa / 2.0),
            ((1.0 + b) / 2.0, wb / 2.0),
        ]
    }

    #[test]
    fn mass_matrix_is_the_integral_of_n_transpose_n() {
        // Eq. (33) with the shape functions (35): A_e = rho A l * int_0^1 N^T N dzeta.
        let (rho, area, l) = (7850.0, 3.2e-4, 0.37);
        let m = mass_matrix(rho, area, l);
        let mut q = [[0.0; 4]; 4];
        for (z, w) in gauss4() {
            let n = shape_functions(z, l)[0];
            for r in 0..4 {
                for c in 0..4 {
                    q[r][c] += w * rho * area * l * n[r] * n[c];
                }
            }
        }
        for r in 0..4 {
            for c in 0..4 {
                // Quadrature is exact; the difference is rounding of ~10 terms.
                assert!((m[r][c] - q[r][c]).abs() < 1e-13 * m[0][0], "({r},{c})");
            }
        }
    }

    #[test]
    fn stiffness_matrix_is_the_integral_of_curvatures() {
        // Eq. (34) for a beam: C_e = E I int_0^l N''^T N'' dx, N'' from differentiating (35).
        let (e, i, l) = (210e9, 1.7e-9, 0.37);
        let c = stiffness_matrix(e, i, l);
        let mut q = [[0.0; 4]; 4];
        for (z, w) in gauss4() {
            let d2 = [
                (12.0 * z - 6.0) / (l * l),
                (6.0 * z - 4.0) / l,
                (6.0 - 12.0 * z) / (l * l),
                (6.0 * z - 2.0) / l,
            ];
            for r in 0..4 {
                for s in 0..4 {
                    q[r][s] += w * l * e * i * d2[r] * d2[s];
                }
            }
        }
        for r in 0..4 {
            for s in 0..4 {
                assert!((c[r][s] - q[r][s]).abs() < 1e-12 * c[0][0], "({r},{s})");
            }
        }
    }

    #[test]
    fn rotation_row_is_the_derivative_of_the_displacement_row() {
        let l = 0.8;
        let h = 1e-6;
        for &z in &[0.0, 0.3, 0.71, 1.0] {
            let n = shape_functions(z, l);
            let (zp, zm) = ((z + h).min(1.0), (z - h).max(0.0));
            let (np, nm) = (shape_functions(zp, l)[0], shape_functions(zm, l)[0]);
            for k in 0..4 {
                let fd = (np[k] - nm[k]) / ((zp - zm) * l);
                // Central/one-sided differences of a cubic: error O(h) at the ends.
                assert!((fd - n[1][k]).abs() < 1e-5, "zeta {z}, k {k}");
            }
        }
        // Interpolation: nodal values reproduced at the ends.
        assert_eq!(
            shape_functions(0.0, l),
            [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]]
        );
        assert_eq!(
            shape_functions(1.0, l),
            [[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
        );
    }

    #[test]
    fn uniform_load_is_the_integral_of_n() {
        let (q, l) = (-37.0, 0.4);
        let p = uniform_load(q, l);
        let mut s = [0.0; 4];
        for (z, w) in gauss4() {
            let n = shape_functions(z, l)[0];
            for k in 0..4 {
                s[k] += w * l * q * n[k];
            }
        }
        for k in 0..4 {
            assert!((p[k] - s[k]).abs() < 1e-14 * q.abs() * l, "{k}");
        }
    }

    #[test]
    fn element_eigenvalues_are_0_0_720_8400() {
        // C_e phi = lambda A_e phi with E J = rho A = l = 1: Cholesky A_e = L L^T, then the
        // symmetric eigenvalues of L^-1 C_e L^-T.
        let dense = |m: ElementMatrix| nalgebra::Matrix4::from_fn(|r, c| m[r][c]);
        let l = dense(mass_matrix(1.0, 1.0, 1.0)).cholesky().unwrap().l();
        let li = l.try_inverse().unwrap();
        let s = li * dense(stiffness_matrix(1.0, 1.0, 1.0)) * li.transpose();
        let mut ev: Vec<f64> = nalgebra::SymmetricEigen::new(s)
            .eigenvalues
            .iter()
            .copied()
            .collect();
        ev.sort_by(f64::total_cmp);
        for (got, want) in ev.iter().zip([0.0, 0.0, 720.0, ELEMENT_EIGENVALUE_MAX]) {
            assert!((got - want).abs() < 1e-9 * ELEMENT_EIGENVALUE_MAX, "{ev:?}");
        }
    }
}
