//! General coordinate partitioning (paper section 2.2, eqs. 18–25; docs/theory.md §3).
//!
//! A mechanism described by `n` coordinates `q` and `m` constraint rows `h(q) = 0`
//! (eq. 14), with Jacobian `J = dh/dq` (eq. 15) and bias `A = J' q'` (eq. 16), moves
//! according to `M q'' + F + Q + J^T lambda = 0` (eq. 17). Splitting `q` into independent
//! coordinates `u` and dependent coordinates `v` (`J_v` square and invertible) gives
//!
//! ```text
//! J_v v'  + J_u u'  = 0                                               (18)
//! J_v v'' + J_u u'' = -A                                              (19)
//! B = -J_v^-1 J_u            so that  v' = B u',  v'' = B u'' - J_v^-1 A
//! M^R = M_uu + M_uv B + B^T (M_vu + M_vv B)                           (23)
//! F^R = F_u - M_uv J_v^-1 A - J_u^T J_v^-T (F_v - M_vv J_v^-1 A)      (24)
//! Q^R = Q_u - J_u^T J_v^-T Q_v                                        (25)
//! M^R u'' + F^R + Q^R = 0                                             (22)
//! ```
//!
//! (the corrected forms of docs/theory.md §3; `-J_u^T J_v^-T = B^T`). The reduction is the
//! projection of eq. (17) on the tangent space of the constraint manifold, spanned by the
//! columns of `[I; B]`, which removes the multipliers `lambda`.
//!
//! Two concepts, one file each:
//!
//! - choosing the partition ([`choose_partition`], `choice.rs`): the dependent coordinates
//!   are the pivot columns of an LU factorisation of `J` with full (complete) pivoting, the
//!   best-conditioned square block it can find greedily, the usual automatic choice
//!   (Wehage–Haug); it also finds the rank of `J` and the constraint rows that depend on the
//!   others (redundant closures);
//! - the reduction for a given partition (`reduce.rs`): [`reduce`] evaluates eqs. (23)–(25),
//!   [`solve_dependent_into`] and [`dependent_accelerations`] solve with `J_v` (eqs. 18
//!   and 19), on the small dense kernels of `dense.rs`.
//!
//! Condition numbers are 1-norm condition numbers, `cond_1(X) = |X|_1 |X^-1|_1`, computed
//! from the explicit inverse (the blocks are small: one row per constraint). The same
//! measure is used everywhere, so thresholds compare like with like.
//!
//! Everything here is dense nalgebra and small; the hot path [`reduce_into`] writes into a
//! caller-owned [`Reduced`] through a reusable [`ReduceWorkspace`] and allocates nothing
//! once the workspace has the right shape. [`reduce`] is the allocating convenience form.

mod choice;
pub(crate) mod dense;
mod reduce;

pub use choice::{PartitionChoice, choose_partition};
pub use reduce::{
    ReduceWorkspace, Reduced, condition_number, dependent_accelerations, reduce, reduce_into,
    solve_dependent_into,
};

/// Condition number of `J_v` (1-norm) above which [`reduce`] treats it as singular.
///
/// Beyond it, `J_v^-1` amplifies rounding errors of `J` by more than 1e12: the dependent
/// accelerations have fewer than four significant digits left.
pub const SINGULAR_CONDITION: f64 = 1e12;

/// A split of the coordinate indices `0..n` into independent `u` and dependent `v`
/// coordinates (eq. 18).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Partition {
    /// Indices of the independent coordinates `u`, sorted.
    pub independent: Vec<usize>,
    /// Indices of the dependent coordinates `v`, sorted.
    pub dependent: Vec<usize>,
}

impl Partition {
    /// The partition of `0..n` whose independent coordinates are `independent` (any order,
    /// no duplicates); the others are dependent.
    pub fn from_independent(n: usize, independent: &[usize]) -> Result<Partition, PartitionError> {
        let mut is_indep = vec![false; n];
        for &i in independent {
            if i >= n {
                return Err(PartitionError::IndexOutOfRange { index: i, n });
            }
            if is_indep[i] {
                return Err(PartitionError::DuplicateIndex { index: i });
            }
            is_indep[i] = true;
        }
        Ok(Partition {
            independent: (0..n).filter(|&i| is_indep[i]).collect(),
            dependent: (0..n).filter(|&i| !is_indep[i]).collect(),
        })
    }

    /// Total number of coordinates `n`.
    pub fn len(&self) -> usize {
        self.independent.len() + self.dependent.len()
    }

    /// `true` when there are no coordinates at all.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Checks that the two index lists are sorted, disjoint and cover `0..n`.
    pub fn validate(&self, n: usize) -> Result<(), PartitionError> {
        if self.len() != n {
            return Err(PartitionError::Dimensions {
                what: "partition size",
                expected: n,
                found: self.len(),
            });
        }
        // Both lists sorted: a merge walk checks that together they are exactly 0..n,
        // without allocating (this runs on every reduction).
        for list in [&self.independent, &self.dependent] {
            for w in list.windows(2) {
                if w[0] >= w[1] {
                    return Err(PartitionError::Unsorted);
                }
            }
            if let Some(&i) = list.last().filter(|&&i| i >= n) {
                return Err(PartitionError::IndexOutOfRange { index: i, n });
            }
        }
        let (mut a, mut b) = (0, 0);
        for k in 0..n {
            let in_a = self.independent.get(a) == Some(&k);
            let in_b = self.dependent.get(b) == Some(&k);
            match (in_a, in_b) {
                (true, true) => return Err(PartitionError::DuplicateIndex { index: k }),
                (true, false) => a += 1,
                (false, true) => b += 1,
                // Missing index k: with the total length n, some other index repeats.
                (false, false) => {
                    let dup = self
                        .independent
                        .iter()
                        .find(|i| self.dependent.contains(i))
                        .copied()
                        .unwrap_or(k);
                    return Err(PartitionError::DuplicateIndex { index: dup });
                }
            }
        }
        Ok(())
    }
}

/// Errors of the partitioning routines. Each carries the data needed to explain it.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PartitionError {
    /// `J_v` is singular or too badly conditioned to be inverted (condition above
    /// [`SINGULAR_CONDITION`]; infinite when a pivot is exactly zero).
    #[error("J_v is singular: 1-norm condition number {condition:.3e}")]
    SingularJv {
        /// 1-norm condition number of `J_v`.
        condition: f64,
    },
    /// The reduced mass matrix `M^R` (eq. 23) is not positive definite.
    #[error(
        "the reduced mass matrix M^R is not positive definite (pivot {pivot:.3e} at row {row})"
    )]
    NotPositiveDefinite {
        /// Row of the failing Cholesky pivot.
        row: usize,
        /// The pivot value.
        pivot: f64,
    },
    /// An argument has the wrong size.
    #[error("{what}: expected {expected}, found {found}")]
    Dimensions {
        /// Which size.
        what: &'static str,
        /// Expected size.
        expected: usize,
        /// Size found.
        found: usize,
    },
    /// A coordinate index is not below the number of coordinates.
    #[error("coordinate index {index} out of range (the mechanism has {n} coordinates)")]
    IndexOutOfRange {
        /// The index.
        index: usize,
        /// Number of coordinates.
        n: usize,
    },
    /// A coordinate index appears twice.
    #[error("coordinate index {index} appears more than once in the partition")]
    DuplicateIndex {
        /// The index.
        index: usize,
    },
    /// The index lists of a partition are not sorted.
    #[error("partition index lists must be sorted")]
    Unsorted,
    /// An input contains NaN or an infinity.
    #[error("{what} contains a non-finite value")]
    NonFinite {
        /// Which input.
        what: &'static str,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_partitions_are_rejected() {
        assert_eq!(
            Partition::from_independent(2, &[2]),
            Err(PartitionError::IndexOutOfRange { index: 2, n: 2 })
        );
        assert_eq!(
            Partition::from_independent(3, &[1, 1]),
            Err(PartitionError::DuplicateIndex { index: 1 })
        );
    }
}
