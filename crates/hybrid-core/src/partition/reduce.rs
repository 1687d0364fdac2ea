//! The reduced equations (22)–(25) of one partition, and the solves with `J_v` of
//! eqs. (18) and (19), on reusable scratch space: the hot path allocates nothing once the
//! workspace has its shapes.

use nalgebra::{DMatrix, DVector};

use super::dense::{
    cholesky_in_place, cholesky_solve, lu_in_place, lu_solve, norm1, resize, resize_v,
};
use super::{Partition, PartitionError, SINGULAR_CONDITION};

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
}

/// Reusable scratch space for [`reduce_into`] and [`Reduced::accelerations_into`].
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

/// Dependent accelerations from eq. (19): `J_v v'' = -J_u u'' - A`.
///
/// `j` holds the non-redundant constraint rows and `a` the bias `A = J' q'` (eq. 16) of the
/// same rows; `udd` the independent accelerations in the order of `p.independent`. The
/// result follows the order of `p.dependent`.
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
/// projection, docs/theory.md §3). Returns the condition number of `J_v`.
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
}
