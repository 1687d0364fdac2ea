//! The full constrained model (eqs. 51–54), solved as one system — the reference the
//! reduction is checked against. Dense and allocating: for tests and small beams only.

use mbs_symbolic::runtime::System;
use nalgebra::{DMatrix, DVector};

use super::damper::DamperModel;

/// Solution of the full system at one state.
#[derive(Clone, Debug)]
pub struct FullAccelerations {
    /// Beam accelerations `q^c''`.
    pub beam: DVector<f64>,
    /// Mechanism accelerations `q^b''`.
    pub mechanism: [f64; 2],
}

/// The full model's pieces at a state `(q^c, v^c, q^b, q^b')`, with the generator
/// current taken quasi-static from `q^b'`: `(M_full, rhs_dyn, J, A)` with
/// `M_full = blockdiag(A^c, M^b)`, `rhs_dyn = [P - B v - C q; -(F + Q)]`,
/// `J = [J^c J^b]` and the constraint bias `A^b`.
#[allow(clippy::type_complexity)]
pub fn pieces<M: System>(
    model: &DamperModel<M>,
    t: f64,
    q: &[f64],
    v: &[f64],
    qb: [f64; 2],
    qbd: [f64; 2],
) -> (DMatrix<f64>, DVector<f64>, DMatrix<f64>, DVector<f64>) {
    let n = q.len();
    let nt = n + 2;
    let mut mf = DMatrix::zeros(nt, nt);
    mf.view_mut((0, 0), (n, n))
        .copy_from(&model.beam.mass().to_dense());
    let gj = model.link.generator_joint;
    let g = &model.generator;
    let (mb, f, qv) = model
        .link
        .equations(&qb, &qbd, t, g, g.quasi_static_current(qbd[gj]));
    for i in 0..2 {
        for j in 0..2 {
            mf[(n + i, n + j)] = mb[i][j];
        }
    }
    let mut rhs = DVector::zeros(nt);
    let mut p = vec![0.0; n];
    model.beam.load_into(t, &mut p);
    let (bd, cd) = (
        model.beam.damping().to_dense(),
        model.beam.stiffness().to_dense(),
    );
    let (vv, qq) = (DVector::from_column_slice(v), DVector::from_column_slice(q));
    let lin = DVector::from_vec(p) - bd * vv - cd * qq;
    rhs.rows_mut(0, n).copy_from(&lin);
    rhs[n] = -(f[0] + qv[0]);
    rhs[n + 1] = -(f[1] + qv[1]);
    // Constraints (45)-(46): rows y, x; J^c = [-n^T; 0] (54), J^b = [dp_y; dp_x] (49).
    let (_, pj, pa) = model.link.point(&qb, &qbd);
    let mut j = DMatrix::zeros(2, nt);
    for &(k, w) in &model.coupling {
        j[(0, k)] = -w;
    }
    for c in 0..2 {
        j[(0, n + c)] = pj[1][c];
        j[(1, n + c)] = pj[0][c];
    }
    let a = DVector::from_vec(vec![pa[1], pa[0]]);
    (mf, rhs, j, a)
}

/// Solves `[M J^T; J 0] [q''; lambda] = [rhs; -A]` (eqs. 51–53 with the acceleration
/// constraint 16) by a dense LU.
pub fn accelerations<M: System>(
    model: &DamperModel<M>,
    t: f64,
    q: &[f64],
    v: &[f64],
    qb: [f64; 2],
    qbd: [f64; 2],
) -> Option<FullAccelerations> {
    let n = q.len();
    let (mf, rhs, j, a) = pieces(model, t, q, v, qb, qbd);
    let nt = n + 2;
    let mut kkt = DMatrix::zeros(nt + 2, nt + 2);
    kkt.view_mut((0, 0), (nt, nt)).copy_from(&mf);
    kkt.view_mut((0, nt), (nt, 2)).copy_from(&j.transpose());
    kkt.view_mut((nt, 0), (2, nt)).copy_from(&j);
    let mut b = DVector::zeros(nt + 2);
    b.rows_mut(0, nt).copy_from(&rhs);
    b[nt] = -a[0];
    b[nt + 1] = -a[1];
    let x = kkt.lu().solve(&b)?;
    Some(FullAccelerations {
        beam: x.rows(0, n).into_owned(),
        mechanism: [x[n], x[n + 1]],
    })
}
