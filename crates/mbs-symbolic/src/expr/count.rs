//! Operation counts of sets of expressions (shared nodes counted once).

use std::fmt;
use std::ops::Add;

use super::{Dag, Id, Node};

/// Arithmetic operations needed to evaluate a set of expressions once, every shared
/// intermediate computed a single time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct OpCount {
    /// Additions and subtractions.
    pub adds: usize,
    /// Multiplications.
    pub muls: usize,
    /// Divisions.
    pub divs: usize,
    /// Function calls (sin, cos, sqrt, powf, ...).
    pub funcs: usize,
    /// Stand-alone negations (a negation feeding an addition is a subtraction and is free).
    pub negs: usize,
}

impl OpCount {
    /// Total number of operations.
    pub fn total(&self) -> usize {
        self.adds + self.muls + self.divs + self.funcs + self.negs
    }
}

impl Add for OpCount {
    type Output = OpCount;
    fn add(self, o: OpCount) -> OpCount {
        OpCount {
            adds: self.adds + o.adds,
            muls: self.muls + o.muls,
            divs: self.divs + o.divs,
            funcs: self.funcs + o.funcs,
            negs: self.negs + o.negs,
        }
    }
}

impl fmt::Display for OpCount {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} ops ({} add, {} mul, {} div, {} fn, {} neg)",
            self.total(),
            self.adds,
            self.muls,
            self.divs,
            self.funcs,
            self.negs
        )
    }
}

impl Dag {
    /// Counts the operations needed to evaluate all of `roots` once. Negations are counted
    /// only where they cannot be merged into a surrounding operation: a negated output, or a
    /// negation used as a factor or function argument.
    pub fn op_count(&self, roots: &[Id]) -> OpCount {
        let order = self.reachable(roots);
        let mut c = OpCount::default();
        for &id in &order {
            match self.node(id) {
                Node::Const(_) | Node::Var(_) | Node::Neg(_) => {}
                Node::Add(..) | Node::Sub(..) => c.adds += 1,
                Node::Mul(..) => c.muls += 1,
                Node::Div(..) => c.divs += 1,
                Node::Pow(..) | Node::Fun(..) => c.funcs += 1,
            }
        }
        // A negation is free when every use is as an operand of +/- (a - b) or another
        // negation; otherwise it costs one operation.
        let mut costly = vec![false; self.len()];
        for &r in roots {
            if matches!(self.node(r), Node::Neg(_)) {
                costly[r.index()] = true;
            }
        }
        for &id in &order {
            match self.node(id) {
                Node::Add(..) | Node::Sub(..) | Node::Neg(_) => {}
                n => {
                    for ch in n.children() {
                        if matches!(self.node(ch), Node::Neg(_)) {
                            costly[ch.index()] = true;
                        }
                    }
                }
            }
        }
        c.negs = costly.iter().filter(|x| **x).count();
        c
    }
}
