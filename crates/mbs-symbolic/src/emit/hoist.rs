//! Parameter hoisting: the subexpressions that depend on run-time parameters only (such as
//! `L1*L1*m2/12`) change only when a parameter is set, so they are computed once, by the
//! struct's constructor and `set_param`, into a private cache field, and every evaluation
//! method reads them from there. Folded parameters are constants in the DAG and stay folded.
//!
//! What is hoisted is the *frontier* of the parameter-only part of the DAG as seen from the
//! outputs: a parameter-only operation used by an operation that also depends on the state
//! (or an output that is parameter-only). Leaves (parameters, constants) are not hoisted:
//! reading a field costs the same as reading the cache; nor are negations, which are free
//! inside a subtraction (their operand is hoisted instead). The cached values are computed
//! by the same expressions, so results are bit-identical to computing them per call.

use super::statements::NOT_HOISTED;
use crate::expr::{Dag, Id, Node, Var};

/// The hoisted nodes.
pub(super) struct Hoisting {
    /// The hoisted nodes in increasing id order; position = index in the cache.
    pub frontier: Vec<Id>,
    /// Cache index by node index (`NOT_HOISTED` for the other nodes).
    pub index: Vec<u32>,
}

/// Finds the parameter-only frontier of everything reachable from `roots`.
pub(super) fn hoist(dag: &Dag, roots: &[Id]) -> Hoisting {
    // Parameter-only: constants, parameters, and operations on parameter-only operands
    // (children come before parents, so one pass suffices).
    let mut param_only = vec![false; dag.len()];
    for (i, node) in dag.nodes().iter().enumerate() {
        param_only[i] = match node {
            Node::Const(_) | Node::Var(Var::Param(_)) => true,
            Node::Var(_) => false,
            n => n.children().all(|c| param_only[c.index()]),
        };
    }
    let hoistable = |id: Id| {
        param_only[id.index()]
            && !matches!(dag.node(id), Node::Const(_) | Node::Var(_) | Node::Neg(_))
    };
    let mut seen = vec![false; dag.len()];
    let mut index = vec![NOT_HOISTED; dag.len()];
    let mut stack: Vec<Id> = roots.to_vec();
    let mut frontier = Vec::new();
    while let Some(id) = stack.pop() {
        if std::mem::replace(&mut seen[id.index()], true) {
            continue;
        }
        if hoistable(id) {
            frontier.push(id);
        } else {
            stack.extend(dag.node(id).children());
        }
    }
    frontier.sort_unstable();
    for (k, id) in frontier.iter().enumerate() {
        index[id.index()] = k as u32;
    }
    Hoisting { frontier, index }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hoists_the_parameter_only_frontier() {
        let mut d = Dag::new();
        let (l, m) = (d.var(Var::Param(0)), d.var(Var::Param(1)));
        let ll = d.mul(l, l);
        let mll = d.mul(m, ll);
        let c2 = {
            let q = d.q(1);
            d.cos(q)
        };
        let out1 = d.mul(c2, mll);
        // A negated parameter-only product: the product is hoisted, not the negation.
        let nl = d.neg(ll);
        let out2 = d.mul(c2, nl);
        // A bare parameter is read from its field.
        let out3 = d.mul(c2, l);
        let h = hoist(&d, &[out1, out2, out3, mll]);
        assert_eq!(h.frontier, vec![ll, mll]);
        assert_eq!(h.index[ll.index()], 0);
        assert_eq!(h.index[mll.index()], 1);
        assert_eq!(h.index[l.index()], NOT_HOISTED);
        assert_eq!(h.index[out1.index()], NOT_HOISTED);
    }
}
