//! Sines and cosines of sums of angles by the angle-addition formulas.
//!
//! ROBOTRAN's angle grouping (`dynamics/joint.rs`) gives the orientation of a body at the end
//! of parallel revolute joints as `Rot(q1 + q2 + ...)`, so the DAG holds `sin(q1 + q2)` and
//! `cos(q1 + q2)` next to the joints' own `sin q2`, `cos q2`. When the sines and cosines of
//! both parts are computed anyway,
//!
//! ```text
//! sin(a + b) = sin a cos b + cos a sin b
//! cos(a + b) = cos a cos b - sin a sin b
//! ```
//!
//! costs 4 multiplications and 2 additions for both, against one libm `sincos` of the sum
//! (about 20 ns on the development machine, the time of ~20 flops; 2–3 ns for the
//! formulas). The DAG keeps the `sin`/`cos` nodes (their derivatives stay compact:
//! `d sin(a + b) = cos(a + b) (a' + b')`); the emitter rewrites the expressions it emits.
//!
//! The rewrite is decided once per model, over everything any emitted function computes,
//! and applied to every function: the fused entry points and the separate methods then
//! evaluate the same operations and stay bit-identical. A sum is rewritten when the formulas
//! cost less than the call, counting one more `sincos` (~20 flops) for a part whose sine and
//! cosine would not be computed otherwise.

use std::collections::BTreeMap;

use crate::expr::{Dag, Fun, Id, Node, Var};

/// Cost of one libm `sin`, `cos` or `sincos` call, in flops (measured: about 20 ns for a
/// `sincos`, 17 ns for a lone `sin`, against ~1 ns per flop).
const LIBM_FLOPS: usize = 20;

/// The result of the rewrite: every original node's replacement.
pub(super) struct Rewrite {
    new: Vec<Id>,
    /// ROBOTRAN names (`s12`, `c12`) of the rewritten sines and cosines of sums.
    pub names: BTreeMap<Id, String>,
}

impl Rewrite {
    /// The replacement of an original node (itself when nothing below it changed).
    pub fn map(&self, id: Id) -> Id {
        self.new.get(id.index()).copied().unwrap_or(id)
    }

    /// [`Rewrite::map`] on a list.
    pub fn map_all(&self, ids: &mut [Id]) {
        for id in ids {
            *id = self.map(*id);
        }
    }
}

/// The coordinates of an angle that is a sum of coordinates (`q1 + q2 + ...`), if it is one.
fn coords(dag: &Dag, angle: Id) -> Option<Vec<usize>> {
    let mut out = vec![];
    let mut stack = vec![angle];
    while let Some(a) = stack.pop() {
        match dag.node(a) {
            Node::Var(Var::Q(i)) => out.push(i as usize),
            Node::Add(x, y) => {
                stack.push(y);
                stack.push(x);
            }
            _ => return None,
        }
    }
    Some(out)
}

/// Which of `sin`, `cos` of an angle are computed.
#[derive(Clone, Copy, Default)]
struct Need {
    sin: bool,
    cos: bool,
}

impl Need {
    fn any(self) -> bool {
        self.sin || self.cos
    }
}

/// Plans and applies the angle-addition rewrite over everything reachable from `roots`.
pub(super) fn angle_addition(dag: &mut Dag, roots: &[Id]) -> Rewrite {
    let order = dag.reachable(roots);
    let mut need: BTreeMap<Id, Need> = BTreeMap::new();
    for &id in &order {
        match dag.node(id) {
            Node::Fun(Fun::Sin, a) => need.entry(a).or_default().sin = true,
            Node::Fun(Fun::Cos, a) => need.entry(a).or_default().cos = true,
            _ => {}
        }
    }
    // Decide bottom-up (an angle's parts have smaller ids): `derived[a] = (x, y)` for
    // `a = x + y` computed from the sines and cosines of `x` and `y` (both then needed).
    let mut derived: BTreeMap<Id, (Id, Id)> = BTreeMap::new();
    let angles: Vec<Id> = need.keys().copied().collect();
    for a in angles {
        decide(a, dag, &mut need, &mut derived);
    }
    if derived.is_empty() {
        return Rewrite {
            new: Vec::new(),
            names: BTreeMap::new(),
        };
    }
    // Build the replacements in increasing angle order (parts first).
    let mut subst: BTreeMap<Id, Id> = BTreeMap::new();
    let mut names = BTreeMap::new();
    let mut sin_cos: BTreeMap<Id, (Id, Id)> = BTreeMap::new();
    let trig = |dag: &mut Dag, x: Id, sin_cos: &BTreeMap<Id, (Id, Id)>| {
        sin_cos
            .get(&x)
            .copied()
            .unwrap_or_else(|| (dag.sin(x), dag.cos(x)))
    };
    for (&a, &(x, y)) in &derived {
        let (sx, cx) = trig(dag, x, &sin_cos);
        let (sy, cy) = trig(dag, y, &sin_cos);
        let (sxcy, cxsy) = (dag.mul(sx, cy), dag.mul(cx, sy));
        let (cxcy, sxsy) = (dag.mul(cx, cy), dag.mul(sx, sy));
        let (s, c) = (dag.add(sxcy, cxsy), dag.sub(cxcy, sxsy));
        sin_cos.insert(a, (s, c));
        let (old_s, old_c) = (dag.sin(a), dag.cos(a));
        subst.insert(old_s, s);
        subst.insert(old_c, c);
        if let Some(cs) = coords(dag, a) {
            names.insert(s, super::statements::angle_name("s", &cs));
            names.insert(c, super::statements::angle_name("c", &cs));
        }
    }
    let new = substitute(dag, &order, &subst);
    Rewrite { new, names }
}

/// Decides whether the sine and cosine of `a` are derived from those of its parts: when
/// the formulas cost less than a call. A part whose sine or cosine is not computed anyway
/// would cost one more call, so then the formulas never win.
fn decide(a: Id, dag: &Dag, need: &mut BTreeMap<Id, Need>, derived: &mut BTreeMap<Id, (Id, Id)>) {
    let Node::Add(x, y) = dag.node(a) else {
        return;
    };
    let wanted = need.get(&a).copied().unwrap_or_default();
    let outputs = usize::from(wanted.sin) + usize::from(wanted.cos);
    // Formulas: 2 multiplications and 1 addition per output needed.
    let extra = |p: Id| {
        if need.get(&p).is_some_and(|n| n.any()) {
            0
        } else {
            LIBM_FLOPS
        }
    };
    if 3 * outputs + extra(x) + extra(y) >= LIBM_FLOPS {
        return;
    }
    derived.insert(a, (x, y));
    for p in [x, y] {
        need.insert(
            p,
            Need {
                sin: true,
                cos: true,
            },
        );
    }
}

/// Rebuilds the nodes of `order` (increasing ids, closed under children) with the nodes of
/// `subst` replaced, through the DAG's folding constructors. Returns the replacement of
/// every node (by index; itself when unchanged).
fn substitute(dag: &mut Dag, order: &[Id], subst: &BTreeMap<Id, Id>) -> Vec<Id> {
    let mut new: Vec<Id> = (0..dag.len() as u32).map(Id).collect();
    for &id in order {
        if let Some(&s) = subst.get(&id) {
            new[id.index()] = s;
            continue;
        }
        let node = dag.node(id);
        if node.children().all(|c| new[c.index()] == c) {
            continue;
        }
        let m = |c: Id| new[c.index()];
        new[id.index()] = match node {
            Node::Const(_) | Node::Var(_) => id,
            Node::Neg(a) => dag.neg(m(a)),
            Node::Add(a, b) => dag.add(m(a), m(b)),
            Node::Sub(a, b) => dag.sub(m(a), m(b)),
            Node::Mul(a, b) => dag.mul(m(a), m(b)),
            Node::Div(a, b) => dag.div(m(a), m(b)),
            Node::Pow(a, b) => dag.pow(m(a), m(b)),
            Node::Fun(f, a) => dag.fun(f, m(a)),
        };
    }
    new
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::EvalInput;

    #[test]
    fn sums_of_angles_use_the_parts_sines_and_cosines() {
        let mut d = Dag::new();
        let (q1, q2, q3) = (d.q(0), d.q(1), d.q(2));
        let (s1, c1, s2, c2, s3, c3) = (
            d.sin(q1),
            d.cos(q1),
            d.sin(q2),
            d.cos(q2),
            d.sin(q3),
            d.cos(q3),
        );
        let a12 = d.add(q1, q2);
        let a123 = d.add(a12, q3);
        let (s12, c123) = (d.sin(a12), d.cos(a123));
        let parts = [s1, c1, s2, c2, s3, c3];
        let p = d.sum(parts);
        let r1 = d.mul(s12, p);
        let r2 = d.mul(c123, s12);
        let roots = [r1, r2];
        let rw = angle_addition(&mut d, &roots);
        let new = [rw.map(r1), rw.map(r2)];
        // No libm call of a sum is left.
        for id in d.reachable(&new) {
            if let Node::Fun(_, a) = d.node(id) {
                assert!(matches!(d.node(a), Node::Var(Var::Q(_))), "{}", d.sexpr(id));
            }
        }
        assert_eq!(rw.names.values().filter(|n| n.starts_with('s')).count(), 2);
        assert!(rw.names.values().any(|n| n == "c123"));
        // Same values within round-off.
        let q = [0.3, -1.2, 2.5];
        let input = EvalInput {
            q: &q,
            qd: &[],
            qdd: &[],
            t: 0.0,
            params: &[],
        };
        let eval = |r: &[Id]| crate::expr::Tape::new(&d, r).eval_vec(&input);
        let (before, after) = (eval(&roots), eval(&new));
        for (b, a) in before.iter().zip(&after) {
            assert!((b - a).abs() <= 1e-15 * b.abs().max(1.0), "{b} vs {a}");
        }
    }

    #[test]
    fn a_sum_whose_parts_are_not_needed_keeps_its_call() {
        let mut d = Dag::new();
        let (q1, q2) = (d.q(0), d.q(1));
        let a12 = d.add(q1, q2);
        let s12 = d.sin(a12);
        let rw = angle_addition(&mut d, &[s12]);
        assert_eq!(rw.map(s12), s12);
        assert!(rw.names.is_empty());
    }
}
