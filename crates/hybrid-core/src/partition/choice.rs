//! Choosing the independent coordinates: LU with full pivoting of `J` (eq. 18), which also
//! gives the numerical rank of `J` and the redundant constraint rows.

use nalgebra::DMatrix;

use super::{Partition, condition_number};

/// The result of [`choose_partition`].
#[derive(Clone, Debug, PartialEq)]
pub struct PartitionChoice {
    /// The chosen partition: `dependent` are the pivot columns, `rank` of them.
    pub partition: Partition,
    /// Numerical rank of `J`.
    pub rank: usize,
    /// Constraint rows (indices into the rows of `J`, sorted) that are linear combinations
    /// of the other rows at this configuration: `J.nrows() - rank` of them.
    pub redundant_rows: Vec<usize>,
    /// 1-norm condition number of `J_v` restricted to the non-redundant rows (1 when there
    /// is no dependent coordinate).
    pub condition: f64,
}

impl PartitionChoice {
    /// The non-redundant rows (the complement of [`PartitionChoice::redundant_rows`] in
    /// `0..rows`), sorted.
    pub fn independent_rows(&self, rows: usize) -> Vec<usize> {
        (0..rows)
            .filter(|r| self.redundant_rows.binary_search(r).is_err())
            .collect()
    }
}

/// Chooses the dependent coordinates from `J` (rows = constraints, columns = coordinates)
/// by Gaussian elimination with full pivoting.
///
/// At each step the entry of largest magnitude of the remaining block is the pivot; its
/// column becomes a dependent coordinate and its row a kept constraint row. Elimination
/// stops when the largest remaining entry is at most `tol * max|J_ij|` (e.g. `tol = 1e-9`):
/// the number of pivots is the numerical rank, the rows never pivoted are
/// [`PartitionChoice::redundant_rows`], the columns never pivoted the independent
/// coordinates `u` (eq. 18). The condition reported is that of the resulting `J_v` on the
/// kept rows. Non-finite entries give rank 0 and an infinite condition.
pub fn choose_partition(j: &DMatrix<f64>, tol: f64) -> PartitionChoice {
    let (m, n) = j.shape();
    let all_free = |condition: f64| PartitionChoice {
        partition: Partition {
            independent: (0..n).collect(),
            dependent: vec![],
        },
        rank: 0,
        redundant_rows: (0..m).collect(),
        condition,
    };
    if j.iter().any(|x| !x.is_finite()) {
        return all_free(f64::INFINITY);
    }
    let scale = j.iter().fold(0.0f64, |s, x| s.max(x.abs()));
    if scale == 0.0 {
        return all_free(1.0);
    }
    let threshold = tol.max(0.0) * scale;
    // Hand-written rather than `nalgebra::linalg::FullPivLU`: with FullPivLU (rank from the
    // leading |U_kk| above the threshold, row and column orders from its permutations) the
    // bench `closed_loop_partition/choose_full_pivot_lu` (four-bar `J`) went from 590 ns to
    // 727 ns (+37 %), same machine, same session; FullPivLU also has no rank tolerance
    // (it eliminates to the end) and multiplies by the reciprocal of the pivot where this
    // divides.
    let mut a = j.clone();
    let mut rows: Vec<usize> = (0..m).collect();
    let mut cols: Vec<usize> = (0..n).collect();
    let mut rank = 0;
    for k in 0..m.min(n) {
        let (mut pi, mut pj, mut best) = (k, k, -1.0);
        for jj in k..n {
            for ii in k..m {
                let v = a[(ii, jj)].abs();
                if v > best {
                    best = v;
                    pi = ii;
                    pj = jj;
                }
            }
        }
        if best <= threshold {
            break;
        }
        a.swap_rows(k, pi);
        rows.swap(k, pi);
        a.swap_columns(k, pj);
        cols.swap(k, pj);
        let d = a[(k, k)];
        for ii in k + 1..m {
            let l = a[(ii, k)] / d;
            a[(ii, k)] = 0.0;
            for jj in k + 1..n {
                a[(ii, jj)] -= l * a[(k, jj)];
            }
        }
        rank += 1;
    }
    let mut dependent: Vec<usize> = cols[..rank].to_vec();
    dependent.sort_unstable();
    let mut independent: Vec<usize> = cols[rank..].to_vec();
    independent.sort_unstable();
    let mut kept: Vec<usize> = rows[..rank].to_vec();
    kept.sort_unstable();
    let mut redundant_rows: Vec<usize> = rows[rank..].to_vec();
    redundant_rows.sort_unstable();
    let jv = DMatrix::from_fn(rank, rank, |r, c| j[(kept[r], dependent[c])]);
    PartitionChoice {
        partition: Partition {
            independent,
            dependent,
        },
        rank,
        redundant_rows,
        condition: condition_number(&jv),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_pivoting_picks_the_large_block() {
        // Column 2 is tiny: it must be independent.
        let j = DMatrix::from_row_slice(2, 3, &[1.0, 0.5, 1e-6, -0.3, 2.0, 0.0]);
        let c = choose_partition(&j, 1e-9);
        assert_eq!(c.partition.independent, vec![2]);
        assert_eq!(c.partition.dependent, vec![0, 1]);
        assert_eq!(c.rank, 2);
        assert!(c.redundant_rows.is_empty());
        assert!(c.condition >= 1.0 && c.condition < 10.0);
    }

    #[test]
    fn duplicate_row_is_redundant() {
        let j = DMatrix::from_row_slice(3, 3, &[1.0, 2.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2.0, 0.0]);
        let c = choose_partition(&j, 1e-9);
        assert_eq!(c.rank, 2);
        assert_eq!(c.redundant_rows.len(), 1);
        assert!(c.redundant_rows[0] == 0 || c.redundant_rows[0] == 2);
        assert_eq!(c.independent_rows(3).len(), 2);
    }

    #[test]
    fn zero_and_non_finite_jacobians_do_not_panic() {
        let z = DMatrix::zeros(2, 3);
        let c = choose_partition(&z, 1e-9);
        assert_eq!((c.rank, c.condition), (0, 1.0));
        let mut n = DMatrix::from_element(2, 3, 1.0);
        n[(0, 0)] = f64::NAN;
        let c = choose_partition(&n, 1e-9);
        assert_eq!(c.rank, 0);
        assert!(c.condition.is_infinite());
    }
}
