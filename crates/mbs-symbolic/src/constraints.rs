//! Point kinematics ("sensors") and constraints `h(q) = 0` (eqs. 14–16 and 45–50).
//!
//! For a point fixed on a body, the position `p(q) = x_Oi + T^i r` comes from the forward
//! recursion (eq. 1). Its velocity `v = J q'` is the derivative of `p` along `q'`; the
//! Jacobian `J = dp/dq` is read off `v` as `dv/dq'` (eq. 49), and the bias
//! `A = d(J q')/dq q'` (eq. 50) is the derivative of `v` along `q'` with `q'` held fixed —
//! all symbolic, on the same DAG as the dynamics, so the trigonometric leaves and the
//! rotation products are shared.
//!
//! Constraint rows are stacked in declaration order (eq. 14); `J = dh/dq` (eq. 15) and
//! `A = J' q'` (eq. 16) follow the same rows and signs. Rows of point constraints can take
//! the points' lever-arm Jacobians instead (O(N) per point): [`constraints`] keeps the
//! cheaper form.

use crate::dynamics::vec3::V3;
use crate::dynamics::{self, Symbolic};
use crate::expr::{Id, Var};
use crate::model::{Constraint, Model};

/// Symbolic kinematics of one named point.
#[derive(Clone, Debug)]
pub struct PointExprs {
    /// The point's name.
    pub name: String,
    /// Position in the ground frame.
    pub p: V3,
    /// Jacobian `dp/dq`, 3 rows of `n`.
    pub j: [Vec<Id>; 3],
    /// Bias `J' q'`.
    pub a: V3,
}

/// Symbolic constraint quantities.
#[derive(Clone, Debug, Default)]
pub struct ConstraintExprs {
    /// Row names: `"<constraint>.<component>"` (`.x`, `.y`, `.z`) or the constraint name for
    /// an angle closure.
    pub names: Vec<String>,
    /// `h(q)` (eq. 14).
    pub h: Vec<Id>,
    /// `J = dh/dq`, one row of `n` per constraint row (eq. 15).
    pub j: Vec<Vec<Id>>,
    /// `A = J' q'` (eq. 16).
    pub a: Vec<Id>,
}

/// Given position-level expressions, returns (Jacobian rows, bias).
fn jacobian_and_bias(sym: &mut Symbolic, pos: &[Id]) -> (Vec<Vec<Id>>, Vec<Id>) {
    let n = sym.n;
    let vel = sym.dag.velocity_derivative_many(pos);
    let bias = sym.dag.velocity_derivative_many(&vel);
    let mut rows = vec![Vec::with_capacity(n); pos.len()];
    for j in 0..n {
        let col = sym.dag.diff_many(&vel, Var::Qd(j as u32));
        for (r, c) in rows.iter_mut().zip(col) {
            r.push(c);
        }
    }
    (rows, bias)
}

/// The model's equations, constraint rows and point kinematics, derived in that order on
/// one DAG (what the interpreter and the tangents evaluate).
pub fn derive_all(model: &Model) -> (Symbolic, ConstraintExprs, Vec<PointExprs>) {
    let mut sym = Symbolic::derive(model);
    let cons = constraints(model, &mut sym);
    let pts = points(model, &mut sym);
    (sym, cons, pts)
}

/// Point kinematics of every named point of the model, in declaration order.
///
/// The Jacobian is built by columns from shared lever arms (O(N) per point, see
/// [`Symbolic::point_jacobian`]), its bias from the forward recursion's acceleration
/// remainders without the base acceleration (eq. 3) or as the derivative of `J q'` along
/// the motion (eq. 50); for a short path the derivative of `p` per coordinate (eq. 49,
/// O(N^2)) with its bias can be cheaper. Of these formulations the one with the fewest
/// operations counted twice — alone (the point's own method) and together with the
/// dynamics (the fused entry point) — is kept. Every one of them makes each term of the
/// bias a product with a joint rate, so the bias is exactly zero at `q' = 0`.
pub fn points(model: &Model, sym: &mut Symbolic) -> Vec<PointExprs> {
    let context: Vec<Id> = sym.mf_roots().into_iter().chain(sym.q.clone()).collect();
    points_in_context(model, sym, &context)
}

/// [`points`], with `context` the other outputs computed together with the points (`M`,
/// `F`, `Q` and the constraint rows of `evaluate_with_points`).
pub fn points_in_context(model: &Model, sym: &mut Symbolic, context: &[Id]) -> Vec<PointExprs> {
    model
        .points
        .iter()
        .map(|pt| {
            let r = [0, 1, 2].map(|c| sym.dag.scalar(&pt.position[c], &model.parameters));
            let p = sym.point_position(pt.body, r);
            let j = sym.point_jacobian(pt.body, r);
            let (jd, ad) = jacobian_and_bias(sym, &p);
            let jd: [Vec<Id>; 3] = jd.try_into().unwrap_or_else(|_| unreachable!());
            let candidates = [
                (j.clone(), sym.point_bias(pt.body, r)),
                (j.clone(), velocity_bias(sym, &j)),
                (jd, [ad[0], ad[1], ad[2]]),
            ];
            let cost = |(j, a): &([Vec<Id>; 3], V3), sym: &Symbolic| {
                let roots = p.iter().chain(j.iter().flatten()).chain(a);
                cost_alone_and_with(sym, roots.copied().collect(), context)
            };
            let costs: Vec<_> = candidates.iter().map(|c| cost(c, sym)).collect();
            let best = (0..candidates.len()).min_by_key(|&k| costs[k]).unwrap_or(0);
            let (j, a) = candidates[best].clone();
            PointExprs {
                name: pt.name.clone(),
                p,
                j,
                a,
            }
        })
        .collect()
}

/// The cost by which a formulation is chosen: the operations of `roots` alone (their own
/// function) plus those of `roots` together with `context` (the fused entry point).
fn cost_alone_and_with(sym: &Symbolic, mut roots: Vec<Id>, context: &[Id]) -> usize {
    let alone = sym.dag.op_count(&roots).total();
    roots.extend(context);
    alone + sym.dag.op_count(&roots).total()
}

/// `A = d(J q')/dq q'` (eq. 50) from the Jacobian's rows.
fn velocity_bias(sym: &mut Symbolic, j: &[Vec<Id>; 3]) -> V3 {
    let vel = j.clone().map(|row| {
        let terms: Vec<Id> = row
            .iter()
            .enumerate()
            .map(|(k, &c)| {
                let qd = sym.dag.qd(k);
                sym.dag.mul(c, qd)
            })
            .collect();
        sym.dag.sum(terms)
    });
    let a = sym.dag.velocity_derivative_many(&vel);
    [a[0], a[1], a[2]]
}

/// Path of bodies from `body` up to the root (inclusive of `body`, exclusive of ground).
fn chain_to_root(model: &Model, mut body: Option<usize>) -> Vec<usize> {
    let mut out = vec![];
    while let Some(b) = body {
        out.push(b);
        body = model.bodies[b].parent;
    }
    out
}

/// Where a constraint row comes from: component `k` of point `b` minus the same component
/// of point `a` (if any), or an angle closure.
#[derive(Clone, Copy)]
enum RowSource {
    Points {
        a: Option<usize>,
        b: usize,
        k: usize,
    },
    Angle,
}

/// The constraint rows of the model.
///
/// `J` and `A` of the rows are formed two ways and the cheaper kept (operations counted
/// alone and together with `M`, `F`, `Q`, as for [`points`]): by differentiating `h`
/// (eqs. 15–16), or, for the rows of point constraints, from the points' Jacobians built
/// from shared lever arms and their biases from the forward recursion (eqs. 49–50).
pub fn constraints(model: &Model, sym: &mut Symbolic) -> ConstraintExprs {
    let mut out = ConstraintExprs::default();
    let mut sources = vec![];
    let point_pos = |sym: &mut Symbolic, k: usize| {
        let pt = &model.points[k];
        let r = [0, 1, 2].map(|c| sym.dag.scalar(&pt.position[c], &model.parameters));
        sym.point_position(pt.body, r)
    };
    for c in &model.constraints {
        match c {
            Constraint::Loop {
                name,
                a,
                b,
                components,
            } => {
                let pa = point_pos(sym, *a);
                let pb = point_pos(sym, *b);
                for ax in components {
                    let k = ax.index();
                    out.h.push(sym.dag.sub(pb[k], pa[k]));
                    out.names.push(format!("{name}.{ax}"));
                    sources.push(RowSource::Points {
                        a: Some(*a),
                        b: *b,
                        k,
                    });
                }
            }
            Constraint::Fixed {
                name,
                point,
                position,
                components,
            } => {
                let p = point_pos(sym, *point);
                for ax in components {
                    let k = ax.index();
                    let target = sym.dag.scalar(&position[k], &model.parameters);
                    out.h.push(sym.dag.sub(p[k], target));
                    out.names.push(format!("{name}.{ax}"));
                    sources.push(RowSource::Points {
                        a: None,
                        b: *point,
                        k,
                    });
                }
            }
            Constraint::Angle {
                name, a, b, offset, ..
            } => {
                // Angle of b relative to a = sum of the revolute coordinates from the common
                // ancestor down to b minus those down to a (validated: all about `axis`).
                let pa = chain_to_root(model, *a);
                let pb = chain_to_root(model, *b);
                let mut h = sym.dag.zero();
                for &k in pb.iter().filter(|k| !pa.contains(k)) {
                    if dynamics::is_rotation(&model.bodies[k].joint) {
                        let q = sym.dag.q(k);
                        h = sym.dag.add(h, q);
                    }
                }
                for &k in pa.iter().filter(|k| !pb.contains(k)) {
                    if dynamics::is_rotation(&model.bodies[k].joint) {
                        let q = sym.dag.q(k);
                        h = sym.dag.sub(h, q);
                    }
                }
                let off = sym.dag.scalar(offset, &model.parameters);
                out.h.push(sym.dag.sub(h, off));
                out.names.push(name.clone());
                sources.push(RowSource::Angle);
            }
        }
    }
    let h = out.h.clone();
    let derived = jacobian_and_bias(sym, &h);
    let mut candidates = vec![derived.clone()];
    if sources
        .iter()
        .any(|s| matches!(s, RowSource::Points { .. }))
    {
        candidates.push(lever_rows(model, sym, &sources, &derived));
    }
    let context: Vec<Id> = sym.mf_roots().into_iter().chain(sym.q.clone()).collect();
    let cost = |(j, a): &(Vec<Vec<Id>>, Vec<Id>), sym: &Symbolic| {
        let roots = j.iter().flatten().chain(a).copied().collect();
        cost_alone_and_with(sym, roots, &context)
    };
    let costs: Vec<usize> = candidates.iter().map(|c| cost(c, sym)).collect();
    let best = (0..candidates.len()).min_by_key(|&k| costs[k]).unwrap_or(0);
    (out.j, out.a) = candidates.swap_remove(best);
    out
}

/// `J` and `A` of the constraint rows with the point rows from the points' lever-arm
/// Jacobians and forward-recursion biases ([`Symbolic::point_bias`]); angle rows keep their
/// rows from `derived`.
fn lever_rows(
    model: &Model,
    sym: &mut Symbolic,
    sources: &[RowSource],
    derived: &(Vec<Vec<Id>>, Vec<Id>),
) -> (Vec<Vec<Id>>, Vec<Id>) {
    let kin = |sym: &mut Symbolic, k: usize| {
        let pt = &model.points[k];
        let r = [0, 1, 2].map(|c| sym.dag.scalar(&pt.position[c], &model.parameters));
        (sym.point_jacobian(pt.body, r), sym.point_bias(pt.body, r))
    };
    let mut rows = Vec::with_capacity(sources.len());
    let mut bias = Vec::with_capacity(sources.len());
    for (row, src) in sources.iter().enumerate() {
        match *src {
            RowSource::Angle => {
                rows.push(derived.0[row].clone());
                bias.push(derived.1[row]);
            }
            RowSource::Points { a, b, k } => {
                let (jb, ab) = kin(sym, b);
                let (mut jr, mut ar) = (jb[k].clone(), ab[k]);
                if let Some(a) = a {
                    let (ja, aa) = kin(sym, a);
                    for (x, y) in jr.iter_mut().zip(&ja[k]) {
                        *x = sym.dag.sub(*x, *y);
                    }
                    ar = sym.dag.sub(ar, aa[k]);
                }
                rows.push(jr);
                bias.push(ar);
            }
        }
    }
    (rows, bias)
}
