//! General coordinate partitioning (paper section 2.2, eqs. 18–25; THEORY.md §3).
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
//! (the corrected forms of THEORY.md §3; `-J_u^T J_v^-T = B^T`). The reduction is the
//! projection of eq. (17) on the tangent space of the constraint manifold, spanned by the
//! columns of `[I; B]`, which removes the multipliers `lambda`.
//!
//! [`choose_partition`] picks the dependent coordinates as the pivot columns of an LU
//! factorisation of `J` with full (complete) pivoting: the best-conditioned
//! square block it can find greedily, the usual automatic choice (Wehage–Haug). It also
//! finds the rank of `J` and the constraint rows that depend on the others (redundant
//! closures). [`reduce`] evaluates eqs. (23)–(25) for a given partition;
//! [`dependent_velocities`] and [`dependent_accelerations`] solve eqs. (18) and (19).
//!
//! Condition numbers are 1-norm condition numbers, `cond_1(X) = |X|_1 |X^-1|_1`, computed
//! from the explicit inverse (the blocks are small: one row per constraint). The same
//! measure is used everywhere, so thresholds compare like with like.
//!
//! Everything here is dense nalgebra and small; the hot path [`reduce_into`] writes into a
//! caller-owned [`Reduced`] through a reusable [`ReduceWorkspace`] and allocates nothing
//! once the workspace has the right shape. [`reduce`] is the allocating convenience form.

use nalgebra::{DMatrix, DVector};

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

/// Errors of the partitioning routines. Each carries the data needed to explain it.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
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

/// The reduced equations (22)–(25) of one partition at one state.
#[derive(Clone, Debug, PartialEq)]
pub struct Reduced {
    /// `M^R` (eq. 23), `nu x nu`.
    pub m: DMatrix<f64>,
    /// `F^R` (eq. 24).
    pub f: DVector<f64>,
    /// `Q^R` (eq. 25).
    pub q: DVector<f64>,
    /// `B = -J_v^-1 J_u` (`nv x nu`): `v' = B u'` (eq. 18).
    pub b: DMatrix<f64>,
    /// 1-norm condition number of `J_v`.
    pub jv_condition: f64,
}

impl Reduced {
    /// An empty result to be filled by [`reduce_into`].
    pub fn empty() -> Reduced {
        Reduced {
            m: DMatrix::zeros(0, 0),
            f: DVector::zeros(0),
            q: DVector::zeros(0),
            b: DMatrix::zeros(0, 0),
            jv_condition: 1.0,
        }
    }

    /// Independent accelerations `u''` from eq. (22): `M^R u'' = -(F^R + Q^R)` (Cholesky).
    pub fn accelerations(&self) -> Result<DVector<f64>, PartitionError> {
        let mut ws = ReduceWorkspace::new();
        let mut out = DVector::zeros(self.f.len());
        self.accelerations_into(&mut ws, &mut out)?;
        Ok(out)
    }

    /// [`Reduced::accelerations`] into a caller-owned vector, with the workspace's scratch.
    pub fn accelerations_into(
        &self,
        ws: &mut ReduceWorkspace,
        out: &mut DVector<f64>,
    ) -> Result<(), PartitionError> {
        let nu = self.f.len();
        if out.len() != nu {
            return Err(PartitionError::Dimensions {
                what: "u'' length",
                expected: nu,
                found: out.len(),
            });
        }
        resize(&mut ws.chol, nu, nu);
        ws.chol.copy_from(&self.m);
        cholesky_in_place(&mut ws.chol)?;
        for i in 0..nu {
            out[i] = -(self.f[i] + self.q[i]);
        }
        cholesky_solve(&ws.chol, out);
        Ok(())
    }

    /// Dependent velocities `v' = B u'` (eq. 18).
    pub fn dependent_velocities(&self, ud: &DVector<f64>) -> DVector<f64> {
        &self.b * ud
    }
}

/// Reusable scratch space for [`reduce_into`] and [`Reduced::accelerations_into`].
///
/// After a successful [`reduce_into`], [`ReduceWorkspace::dependent_bias`] holds
/// `-J_v^-1 A`, so that `v'' = B u'' - J_v^-1 A` (eq. 19) costs one matrix-vector product.
#[derive(Clone, Debug)]
pub struct ReduceWorkspace {
    jv: DMatrix<f64>,
    piv: Vec<usize>,
    jinv: DMatrix<f64>,
    col: DVector<f64>,
    c: DVector<f64>,
    w: DVector<f64>,
    tmp: DMatrix<f64>,
    chol: DMatrix<f64>,
}

impl Default for ReduceWorkspace {
    fn default() -> Self {
        Self::new()
    }
}

impl ReduceWorkspace {
    /// An empty workspace; it takes its shapes on first use.
    pub fn new() -> ReduceWorkspace {
        ReduceWorkspace {
            jv: DMatrix::zeros(0, 0),
            piv: Vec::new(),
            jinv: DMatrix::zeros(0, 0),
            col: DVector::zeros(0),
            c: DVector::zeros(0),
            w: DVector::zeros(0),
            tmp: DMatrix::zeros(0, 0),
            chol: DMatrix::zeros(0, 0),
        }
    }

    /// `-J_v^-1 A` from the last successful [`reduce_into`] (eq. 19 with `u'' = 0`).
    pub fn dependent_bias(&self) -> &DVector<f64> {
        &self.c
    }
}

/// Resizes a matrix buffer only when its shape differs (contents are then unspecified).
fn resize(m: &mut DMatrix<f64>, r: usize, c: usize) {
    if m.shape() != (r, c) {
        *m = DMatrix::zeros(r, c);
    }
}

fn resize_v(v: &mut DVector<f64>, n: usize) {
    if v.len() != n {
        *v = DVector::zeros(n);
    }
}

/// 1-norm of a matrix: the largest column sum of absolute values.
fn norm1(a: &DMatrix<f64>) -> f64 {
    a.column_iter()
        .map(|c| c.iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// LU factorisation with partial (row) pivoting in place: `P a = L U`, unit lower `L`
/// below the diagonal, `U` on and above. Returns `false` on an exactly zero pivot.
fn lu_in_place(a: &mut DMatrix<f64>, piv: &mut Vec<usize>) -> bool {
    let n = a.nrows();
    piv.clear();
    for k in 0..n {
        let mut p = k;
        let mut best = a[(k, k)].abs();
        for i in k + 1..n {
            if a[(i, k)].abs() > best {
                best = a[(i, k)].abs();
                p = i;
            }
        }
        piv.push(p);
        if best == 0.0 || !best.is_finite() {
            return false;
        }
        if p != k {
            a.swap_rows(k, p);
        }
        let d = a[(k, k)];
        for i in k + 1..n {
            let l = a[(i, k)] / d;
            a[(i, k)] = l;
            for j in k + 1..n {
                a[(i, j)] -= l * a[(k, j)];
            }
        }
    }
    true
}

/// Solves `A x = b` in place with the factors of [`lu_in_place`].
fn lu_solve(lu: &DMatrix<f64>, piv: &[usize], b: &mut DVector<f64>) {
    let n = lu.nrows();
    for (k, &p) in piv.iter().enumerate() {
        if p != k {
            b.swap_rows(k, p);
        }
    }
    for i in 0..n {
        let mut s = b[i];
        for j in 0..i {
            s -= lu[(i, j)] * b[j];
        }
        b[i] = s;
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for j in i + 1..n {
            s -= lu[(i, j)] * b[j];
        }
        b[i] = s / lu[(i, i)];
    }
}

/// Cholesky factorisation in place (lower triangle; the upper one is left untouched and
/// ignored). Fails on a non-positive pivot.
fn cholesky_in_place(a: &mut DMatrix<f64>) -> Result<(), PartitionError> {
    let n = a.nrows();
    for j in 0..n {
        let mut d = a[(j, j)];
        for k in 0..j {
            d -= a[(j, k)] * a[(j, k)];
        }
        if d.is_nan() || d <= 0.0 {
            return Err(PartitionError::NotPositiveDefinite { row: j, pivot: d });
        }
        let d = d.sqrt();
        a[(j, j)] = d;
        for i in j + 1..n {
            let mut s = a[(i, j)];
            for k in 0..j {
                s -= a[(i, k)] * a[(j, k)];
            }
            a[(i, j)] = s / d;
        }
    }
    Ok(())
}

/// Solves `L L^T x = b` in place with the factor of [`cholesky_in_place`].
fn cholesky_solve(l: &DMatrix<f64>, b: &mut DVector<f64>) {
    let n = l.nrows();
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[(i, k)] * b[k];
        }
        b[i] = s / l[(i, i)];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[(k, i)] * b[k];
        }
        b[i] = s / l[(i, i)];
    }
}

/// 1-norm condition number `|X|_1 |X^-1|_1` of a square matrix (1 for an empty one,
/// infinity for an exactly singular or non-finite one). Never NaN.
pub fn condition_number(x: &DMatrix<f64>) -> f64 {
    let mut ws = ReduceWorkspace::new();
    resize(&mut ws.jv, x.nrows(), x.ncols());
    ws.jv.copy_from(x);
    factor_and_invert(&mut ws).unwrap_or(f64::INFINITY)
}

/// Factors `ws.jv` in place, writes its inverse into `ws.jinv` and returns the 1-norm
/// condition number; `None` when a pivot is exactly zero or something is not finite.
fn factor_and_invert(ws: &mut ReduceWorkspace) -> Option<f64> {
    let r = ws.jv.nrows();
    if r == 0 {
        resize(&mut ws.jinv, 0, 0);
        return Some(1.0);
    }
    let n1 = norm1(&ws.jv);
    if !n1.is_finite() {
        return None;
    }
    if !lu_in_place(&mut ws.jv, &mut ws.piv) {
        return None;
    }
    resize(&mut ws.jinv, r, r);
    resize_v(&mut ws.col, r);
    for k in 0..r {
        ws.col.fill(0.0);
        ws.col[k] = 1.0;
        lu_solve(&ws.jv, &ws.piv, &mut ws.col);
        ws.jinv.set_column(k, &ws.col);
    }
    let cond = n1 * norm1(&ws.jinv);
    if cond.is_finite() { Some(cond) } else { None }
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

fn check_dims(what: &'static str, expected: usize, found: usize) -> Result<(), PartitionError> {
    if expected == found {
        Ok(())
    } else {
        Err(PartitionError::Dimensions {
            what,
            expected,
            found,
        })
    }
}

/// Checks the shapes of the inputs of [`reduce_into`] and the partition.
fn check_inputs(
    m: &DMatrix<f64>,
    f: &DVector<f64>,
    q: &DVector<f64>,
    j: &DMatrix<f64>,
    a: &DVector<f64>,
    p: &Partition,
) -> Result<(), PartitionError> {
    let n = m.nrows();
    check_dims("M columns", n, m.ncols())?;
    check_dims("F length", n, f.len())?;
    check_dims("Q length", n, q.len())?;
    check_dims("J columns", n, j.ncols())?;
    check_dims("A length", j.nrows(), a.len())?;
    check_dims(
        "J rows (one per dependent coordinate)",
        p.dependent.len(),
        j.nrows(),
    )?;
    p.validate(n)
}

/// The reduced equations (22)–(25) for partition `p`: `M^R`, `F^R`, `Q^R`, `B` and the
/// condition of `J_v`.
///
/// `j` and `a` must hold exactly the non-redundant constraint rows (one per dependent
/// coordinate). Errors: [`PartitionError::SingularJv`] when `J_v` is singular or its
/// condition exceeds [`SINGULAR_CONDITION`]; [`PartitionError::Dimensions`] and friends on
/// inconsistent sizes. Allocating wrapper of [`reduce_into`].
pub fn reduce(
    m: &DMatrix<f64>,
    f: &DVector<f64>,
    q: &DVector<f64>,
    j: &DMatrix<f64>,
    a: &DVector<f64>,
    p: &Partition,
) -> Result<Reduced, PartitionError> {
    let mut out = Reduced::empty();
    reduce_into(m, f, q, j, a, p, &mut ReduceWorkspace::new(), &mut out)?;
    Ok(out)
}

/// [`reduce`] into a caller-owned result, with reusable scratch space.
///
/// ```text
/// B   = -J_v^-1 J_u,   c = -J_v^-1 A                       (18), (19)
/// M^R = M_uu + M_uv B + B^T (M_vu + M_vv B)                (23)
/// F^R = F_u + M_uv c + B^T (F_v + M_vv c)                  (24)
/// Q^R = Q_u + B^T Q_v                                      (25)
/// ```
pub fn reduce_into(
    m: &DMatrix<f64>,
    f: &DVector<f64>,
    q: &DVector<f64>,
    j: &DMatrix<f64>,
    a: &DVector<f64>,
    p: &Partition,
    ws: &mut ReduceWorkspace,
    out: &mut Reduced,
) -> Result<(), PartitionError> {
    check_inputs(m, f, q, j, a, p)?;
    let (ind, dep) = (&p.independent, &p.dependent);
    let (nu, nv) = (ind.len(), dep.len());
    resize(&mut ws.jv, nv, nv);
    for r in 0..nv {
        for (c, &k) in dep.iter().enumerate() {
            ws.jv[(r, c)] = j[(r, k)];
        }
    }
    let condition = factor_and_invert(ws).unwrap_or(f64::INFINITY);
    if condition > SINGULAR_CONDITION {
        return Err(PartitionError::SingularJv { condition });
    }
    // B = -J_v^-1 J_u and c = -J_v^-1 A.
    resize(&mut out.b, nv, nu);
    resize_v(&mut ws.c, nv);
    for k in 0..nv {
        for (l, &il) in ind.iter().enumerate() {
            let mut s = 0.0;
            for i in 0..nv {
                s += ws.jinv[(k, i)] * j[(i, il)];
            }
            out.b[(k, l)] = -s;
        }
        let mut s = 0.0;
        for i in 0..nv {
            s += ws.jinv[(k, i)] * a[i];
        }
        ws.c[k] = -s;
    }
    // tmp = M_vu + M_vv B (nv x nu), eq. (23).
    resize(&mut ws.tmp, nv, nu);
    for (k, &dk) in dep.iter().enumerate() {
        for (l, &il) in ind.iter().enumerate() {
            let mut s = m[(dk, il)];
            for (k2, &dk2) in dep.iter().enumerate() {
                s += m[(dk, dk2)] * out.b[(k2, l)];
            }
            ws.tmp[(k, l)] = s;
        }
    }
    resize(&mut out.m, nu, nu);
    for (l1, &i1) in ind.iter().enumerate() {
        for (l2, &i2) in ind.iter().enumerate() {
            let mut s = m[(i1, i2)];
            for (k, &dk) in dep.iter().enumerate() {
                s += m[(i1, dk)] * out.b[(k, l2)] + out.b[(k, l1)] * ws.tmp[(k, l2)];
            }
            out.m[(l1, l2)] = s;
        }
    }
    // Exact symmetry (the two triangles differ by rounding only).
    for l1 in 0..nu {
        for l2 in 0..l1 {
            let s = 0.5 * (out.m[(l1, l2)] + out.m[(l2, l1)]);
            out.m[(l1, l2)] = s;
            out.m[(l2, l1)] = s;
        }
    }
    // w = F_v + M_vv c, eq. (24).
    resize_v(&mut ws.w, nv);
    for (k, &dk) in dep.iter().enumerate() {
        let mut s = f[dk];
        for (k2, &dk2) in dep.iter().enumerate() {
            s += m[(dk, dk2)] * ws.c[k2];
        }
        ws.w[k] = s;
    }
    resize_v(&mut out.f, nu);
    resize_v(&mut out.q, nu);
    for (l, &il) in ind.iter().enumerate() {
        let mut sf = f[il];
        let mut sq = q[il];
        for (k, &dk) in dep.iter().enumerate() {
            sf += m[(il, dk)] * ws.c[k] + out.b[(k, l)] * ws.w[k];
            sq += out.b[(k, l)] * q[dk];
        }
        out.f[l] = sf;
        out.q[l] = sq;
    }
    out.jv_condition = condition;
    if out
        .m
        .iter()
        .chain(out.f.iter())
        .chain(out.q.iter())
        .any(|x| !x.is_finite())
    {
        return Err(PartitionError::NonFinite {
            what: "the reduced equations",
        });
    }
    Ok(())
}

/// Factors `J_v` of partition `p` into the workspace (for the two solves below).
fn factor_jv(
    j: &DMatrix<f64>,
    p: &Partition,
    ws: &mut ReduceWorkspace,
) -> Result<f64, PartitionError> {
    p.validate(j.ncols())?;
    check_dims(
        "J rows (one per dependent coordinate)",
        p.dependent.len(),
        j.nrows(),
    )?;
    let nv = p.dependent.len();
    resize(&mut ws.jv, nv, nv);
    for r in 0..nv {
        for (c, &k) in p.dependent.iter().enumerate() {
            ws.jv[(r, c)] = j[(r, k)];
        }
    }
    let condition = factor_and_invert(ws).unwrap_or(f64::INFINITY);
    if condition > SINGULAR_CONDITION {
        return Err(PartitionError::SingularJv { condition });
    }
    Ok(condition)
}

/// Solves `J_v x = rhs` with the factors left in the workspace by [`factor_jv`].
fn solve_jv(ws: &mut ReduceWorkspace, rhs: &mut DVector<f64>) {
    lu_solve(&ws.jv, &ws.piv, rhs);
}

/// Dependent velocities from eq. (18): `J_v v' = -J_u u'`.
///
/// `j` holds the non-redundant constraint rows; `ud` the independent velocities in the
/// order of `p.independent`. The result follows the order of `p.dependent`.
pub fn dependent_velocities(
    j: &DMatrix<f64>,
    p: &Partition,
    ud: &DVector<f64>,
) -> Result<DVector<f64>, PartitionError> {
    let mut out = DVector::zeros(p.dependent.len());
    dependent_velocities_into(j, p, ud, &mut ReduceWorkspace::new(), &mut out)?;
    Ok(out)
}

/// [`dependent_velocities`] into a caller-owned vector (length `p.dependent.len()`).
pub fn dependent_velocities_into(
    j: &DMatrix<f64>,
    p: &Partition,
    ud: &DVector<f64>,
    ws: &mut ReduceWorkspace,
    out: &mut DVector<f64>,
) -> Result<(), PartitionError> {
    check_dims("u' length", p.independent.len(), ud.len())?;
    check_dims("v' length", p.dependent.len(), out.len())?;
    factor_jv(j, p, ws)?;
    for r in 0..p.dependent.len() {
        let mut s = 0.0;
        for (l, &il) in p.independent.iter().enumerate() {
            s += j[(r, il)] * ud[l];
        }
        out[r] = -s;
    }
    solve_jv(ws, out);
    Ok(())
}

/// Dependent accelerations from eq. (19): `J_v v'' = -J_u u'' - A`.
///
/// Same conventions as [`dependent_velocities`]; `a` is the bias `A = J' q'` (eq. 16) of
/// the same rows.
pub fn dependent_accelerations(
    j: &DMatrix<f64>,
    a: &DVector<f64>,
    p: &Partition,
    udd: &DVector<f64>,
) -> Result<DVector<f64>, PartitionError> {
    check_dims("u'' length", p.independent.len(), udd.len())?;
    check_dims("A length", j.nrows(), a.len())?;
    let mut ws = ReduceWorkspace::new();
    factor_jv(j, p, &mut ws)?;
    let mut out = DVector::zeros(p.dependent.len());
    for r in 0..p.dependent.len() {
        let mut s = a[r];
        for (l, &il) in p.independent.iter().enumerate() {
            s += j[(r, il)] * udd[l];
        }
        out[r] = -s;
    }
    solve_jv(&mut ws, &mut out);
    Ok(out)
}

/// Solves `J_v dv = rhs` for an already evaluated `J` (Newton step of the position
/// projection, THEORY.md §3). Returns the condition number of `J_v`.
pub fn solve_dependent_into(
    j: &DMatrix<f64>,
    p: &Partition,
    ws: &mut ReduceWorkspace,
    rhs: &mut DVector<f64>,
) -> Result<f64, PartitionError> {
    check_dims("right-hand side length", p.dependent.len(), rhs.len())?;
    let condition = factor_jv(j, p, ws)?;
    solve_jv(ws, rhs);
    Ok(condition)
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

    #[test]
    fn singular_jv_is_an_error_with_the_condition() {
        let m = DMatrix::identity(3, 3);
        let f = DVector::zeros(3);
        let j = DMatrix::from_row_slice(2, 3, &[1.0, 2.0, 0.0, 2.0, 4.0, 1.0]);
        let a = DVector::zeros(2);
        let p = Partition::from_independent(3, &[2]).unwrap();
        match reduce(&m, &f, &f, &j, &a, &p) {
            Err(PartitionError::SingularJv { condition }) => assert!(condition > 1e12),
            other => panic!("expected SingularJv, got {other:?}"),
        }
    }

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
