//! Why a hybrid run stopped.

/// Why a hybrid run stopped. Every message is one line naming the time and the mechanism.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum HybridError {
    /// A mechanism reached (or came too close to) a singular position.
    #[error(
        "t = {t:.6} s, mechanism \"{mechanism}\", beam point displacement {displacement:.6e} m: singular position: cond(J_d) = {condition:.3e}, smallest singular value {sigma_min:.3e}{}",
        reach_note(*reach)
    )]
    Singular {
        /// Time (s).
        t: f64,
        /// The mechanism.
        mechanism: String,
        /// Displacement of its first attached beam point (m; 0 without attachment).
        displacement: f64,
        /// 2-norm condition number of its dependent Jacobian.
        condition: f64,
        /// Smallest singular value of its dependent Jacobian.
        sigma_min: f64,
        /// Remaining travel of the beam point before the mechanism is stretched (m), where
        /// the geometry gives it.
        reach: Option<f64>,
    },
    /// A mechanism could not be assembled (out of reach).
    #[error(
        "t = {t:.6} s, mechanism \"{mechanism}\", beam point displacement {displacement:.6e} m: the mechanism cannot reach the beam point: {}|h| = {residual:.3e} after {iterations} Newton iterations",
        reach_limit(*reach, *displacement)
    )]
    NoAssembly {
        /// Time (s).
        t: f64,
        /// The mechanism.
        mechanism: String,
        /// Displacement of its first attached beam point (m).
        displacement: f64,
        /// Constraint residual norm at the last iterate.
        residual: f64,
        /// Newton iterations made.
        iterations: usize,
        /// How far the beam point can move from its undeformed position (m), where the
        /// geometry gives it.
        reach: Option<f64>,
    },
    /// The implicit step's iteration did not converge.
    #[error(
        "t = {t:.6} s, mechanism \"{mechanism}\", beam point displacement {displacement:.6e} m: the implicit step did not converge (residual {residual:.3e} after {iterations} iterations); {}",
        if *condition > 100.0 {
            format!("the mechanism is close to its singular position: cond(J_d) = {condition:.3e}, smallest singular value {sigma_min:.3e}")
        } else {
            format!("cond(J_d) = {condition:.3e}: reduce the time step")
        }
    )]
    NoConvergence {
        /// Time (s).
        t: f64,
        /// Last residual norm.
        residual: f64,
        /// Iterations made.
        iterations: usize,
        /// The worst-conditioned mechanism.
        mechanism: String,
        /// Displacement of its first attached beam point at the last iterate (m).
        displacement: f64,
        /// Its condition number.
        condition: f64,
        /// Its smallest singular value of `J_d`.
        sigma_min: f64,
    },
    /// The state became non-finite.
    #[error("t = {t:.6} s: the solution diverged (non-finite state); reduce the time step")]
    Diverged {
        /// Time (s).
        t: f64,
    },
    /// The constraints of a mechanism have no full-rank dependent block at the start.
    #[error(
        "mechanism \"{mechanism}\": its {rows} constraint rows (loops and attachments) have rank {rank} at the initial configuration: over-constrained or at a singular position"
    )]
    Partition {
        /// The mechanism.
        mechanism: String,
        /// Its constraint rows.
        rows: usize,
        /// Their rank.
        rank: usize,
    },
    /// The structure's Newmark matrix could not be factorised (the typed cause: for the
    /// beam the pivot or the non-finite entry, with its index).
    #[error("structure matrix factorisation failed: {0}")]
    Factorization(super::structure::StructureError),
}

fn reach_note(reach: Option<f64>) -> String {
    match reach {
        Some(r) => format!("; remaining reach {r:.3e} m"),
        None => String::new(),
    }
}

fn reach_limit(reach: Option<f64>, _displacement: f64) -> String {
    match reach {
        Some(r) => format!(
            "it reaches at most {r:.6e} m from the undeformed position (2 L (1 - cos a0) for a double bar of equal bars L at half-angle a0); "
        ),
        None => String::new(),
    }
}
