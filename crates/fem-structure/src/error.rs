//! Errors of the linear algebra on imported structures (file problems are
//! [`diagnostic::Diagnostics`]).

/// Why an operation on an imported structure failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StructureError {
    /// A Cholesky factorisation met a pivot that is not positive.
    #[error(
        "the {what} is not positive definite (a non-positive pivot in its Cholesky factorisation)"
    )]
    NotPositiveDefinite {
        /// The matrix, as the user knows it (`mass matrix`, `stiffness matrix`, ...).
        what: String,
    },
    /// A complex combination of the matrices (a dynamic stiffness at a shift) is singular.
    #[error("the dynamic stiffness is singular (a shift on an eigenvalue of the structure)")]
    Singular,
    /// The sparse library refused an operation (allocation, index overflow).
    #[error("sparse linear algebra: {0}")]
    Sparse(String),
    /// An iteration did not converge within its cap.
    #[error("{what}: no convergence after {iterations} iterations")]
    NoConvergence {
        /// What was iterated.
        what: &'static str,
        /// Iterations done.
        iterations: usize,
    },
    /// More modes asked for than the matrix has rows.
    #[error("{count} modes asked for a problem of {n} equations")]
    TooManyModes {
        /// Modes asked for.
        count: usize,
        /// Equations.
        n: usize,
    },
}
