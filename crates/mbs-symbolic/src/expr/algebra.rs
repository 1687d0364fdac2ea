//! Algebra of sums, applied when a sum or difference is built ([`Dag::add`], [`Dag::sub`]).
//!
//! A sum is seen as a tree of `+`, `-` and unary `-` over *terms* `k * b`: a constant
//! (`b` absent), `c * b` (a product with a constant factor), `b / c` (coefficient `1/c`), or
//! any other node `b` (coefficient 1). Building `a ± b` tries, in this order:
//!
//! 1. **Like terms and constants**: a term operand is *absorbed* into a term of the other
//!    operand with the same base (`x/12 + 0.25 x` becomes `(1/3) x`, `c1 + (y + c2)` becomes
//!    `y + (c1 + c2)`, `(x + y) - x` becomes `y`). The coefficients are added in floating
//!    point (one rounding) and the term rebuilt as `(k1 + k2) * b`, which vanishes when they
//!    cancel exactly.
//! 2. **Common constant factors** (opt-in, [`Dag::set_factor_constants`]): a term `c * x`
//!    meets a term `c * y` (or `x / c` meets `y / c`) with the same `|c|`: both become
//!    `c * (x ± y)` (or `(x ± y) / c`), one multiplication fewer.
//!
//! Absorbing rebuilds only the sum nodes on the path from the operand down to the term it
//! lands in; sibling subtrees are kept as they are (their sharing survives, no term is
//! reordered). Sharing decides how far it may go, because a rebuilt sum that something else
//! uses is then computed twice:
//!
//! * a sum node is rebuilt only if no other node uses it yet (the DAG counts each node's
//!   parents), and the search goes one sum level below the operand at most — deeper
//!   rewrites were measured to cost more than they save on the planar chains, where inner
//!   composite-body sums are reused later by other entries of `M`;
//! * an operand already used elsewhere is only rewritten when the partner is one of its own
//!   terms and merging creates no node (constants merging, terms cancelling): one addition,
//!   as much as the plain sum.
//!
//! Every rewrite preserves the value exactly in real arithmetic: `tree + t` is replaced by
//! `tree'` in which one term `k b` became `(k + k') b`. In floating point the result may
//! differ by a few rounding errors of the terms involved (re-association of a sum), far
//! below the 1e-12 relative agreement the tests require; nothing is cancelled that was not
//! equal in the DAG.

use super::{Dag, Id, Node};

/// Nodes of a sum tree visited when looking for a partner term.
const SEARCH_BUDGET: usize = 8;

/// A fresh search budget.
fn budget() -> usize {
    SEARCH_BUDGET
}

/// Sum levels below an operand searched for a partner term. Deeper rewrites were measured
/// to cost more than they save: a rebuilt inner sum that turns out to be used elsewhere later
/// (a composite-body sum reused by several entries of `M`) is then computed twice.
const MAX_DEPTH: u32 = 1;

/// A term `coef * base` of a sum (`base == None`: the constant `coef`).
#[derive(Clone, Copy, Debug)]
struct Term {
    coef: f64,
    base: Option<Id>,
    /// How the coefficient is written: `c * base` (`Some(false)`), `base / c`
    /// (`Some(true)`, `coef = ±1/c`), or a bare node (`None`).
    form: Option<Factor>,
}

/// The constant factor of a term as written in the DAG.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Factor {
    /// `c * base`: the magnitude `c`.
    Mul(u64),
    /// `base / c`: the divisor `c`.
    Div(u64),
}

/// What absorbing looks for.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// A term with the same base (or a constant for a constant).
    LikeTerm,
    /// A term with the same constant factor and another base.
    CommonFactor,
}

impl Term {
    fn negated(self) -> Term {
        Term {
            coef: -self.coef,
            ..self
        }
    }
}

impl Dag {
    /// The term a node stands for, with its sign folded into the coefficient.
    fn term_of(&self, id: Id, sign: f64) -> Term {
        match self.node(id) {
            Node::Const(bits) => Term {
                coef: sign * f64::from_bits(bits),
                base: None,
                form: None,
            },
            Node::Neg(x) => self.term_of(x, -sign),
            Node::Mul(c, x) if self.as_const(c).is_some() => {
                let c = self.as_const(c).unwrap_or(1.0);
                Term {
                    coef: sign * c,
                    base: Some(x),
                    form: Some(Factor::Mul(c.abs().to_bits())),
                }
            }
            Node::Div(x, c) if self.as_const(c).is_some() => {
                let c = self.as_const(c).unwrap_or(1.0);
                Term {
                    coef: sign / c,
                    base: Some(x),
                    form: Some(Factor::Div(c.abs().to_bits())),
                }
            }
            _ => Term {
                coef: sign,
                base: Some(id),
                form: None,
            },
        }
    }

    /// True when the node is a sum or difference (possibly negated).
    fn is_sum(&self, id: Id) -> bool {
        match self.node(id) {
            Node::Add(..) | Node::Sub(..) => true,
            Node::Neg(x) => matches!(self.node(x), Node::Add(..) | Node::Sub(..)),
            _ => false,
        }
    }

    /// The value `coef * base` as a node.
    fn build_term(&mut self, coef: f64, base: Option<Id>) -> Id {
        let k = self.constant(coef);
        match base {
            None => k,
            Some(b) => self.mul(k, b),
        }
    }

    /// Merges `t` into the single term `u` (a node that is not a sum), if `mode` allows.
    fn merge_terms(&mut self, u: Term, t: Term, mode: Mode) -> Option<Id> {
        match mode {
            Mode::LikeTerm => (u.base == t.base).then(|| self.build_term(u.coef + t.coef, u.base)),
            Mode::CommonFactor => {
                let (ub, tb) = (u.base?, t.base?);
                let f = u.form?;
                if ub == tb || t.form != Some(f) {
                    return None;
                }
                // u.coef = su * m, t.coef = st * m with m = c (Mul) or 1/c (Div).
                let inner = if (u.coef < 0.0) == (t.coef < 0.0) {
                    self.add_folded(ub, tb)
                } else {
                    self.sub_folded(ub, tb)
                };
                let (mag, div) = match f {
                    Factor::Mul(bits) | Factor::Div(bits) => (
                        self.constant(f64::from_bits(bits)),
                        matches!(f, Factor::Div(_)),
                    ),
                };
                let v = if div {
                    self.div(inner, mag)
                } else {
                    self.mul(mag, inner)
                };
                Some(if u.coef < 0.0 { self.neg(v) } else { v })
            }
        }
    }

    /// `tree + t` with `t` merged into a term of `tree` (the path to that term rebuilt), or
    /// `None` when no term of `tree` within the search budget takes it.
    fn absorb(&mut self, tree: Id, t: Term, mode: Mode, budget: &mut usize) -> Option<Id> {
        if self.is_sum(tree) && self.parents[tree.index()] > 0 {
            // The operand is used elsewhere and stays: rebuilding it costs one addition,
            // no more than the plain sum, only when the partner is one of its own terms
            // and merging creates no new node (constants merging, terms cancelling).
            return self.absorb_shallow(tree, t);
        }
        self.absorb_at(tree, t, mode, budget, 0)
    }

    /// Absorbing `t` into a direct term of the shared sum `tree` when the merge creates no
    /// node: `c1 + (c2 + y) = (c1 + c2) + y`, `x + (y - x) = y`.
    fn absorb_shallow(&mut self, tree: Id, t: Term) -> Option<Id> {
        let free = |dag: &Dag, side: Id, t: Term| {
            let u = dag.term_of(side, 1.0);
            !dag.is_sum(side) && u.base == t.base && (u.base.is_none() || u.coef + t.coef == 0.0)
        };
        match self.node(tree) {
            Node::Add(x, y) => {
                if free(self, x, t) {
                    let x2 = self.merge_terms(self.term_of(x, 1.0), t, Mode::LikeTerm)?;
                    return Some(self.add_folded(x2, y));
                }
                if free(self, y, t) {
                    let y2 = self.merge_terms(self.term_of(y, 1.0), t, Mode::LikeTerm)?;
                    return Some(self.add_folded(x, y2));
                }
                None
            }
            Node::Sub(x, y) => {
                if free(self, x, t) {
                    let x2 = self.merge_terms(self.term_of(x, 1.0), t, Mode::LikeTerm)?;
                    return Some(self.sub_folded(x2, y));
                }
                if free(self, y, t.negated()) {
                    let y2 = self.merge_terms(self.term_of(y, 1.0), t.negated(), Mode::LikeTerm)?;
                    return Some(self.sub_folded(x, y2));
                }
                None
            }
            Node::Neg(x) => {
                let x2 = self.absorb_shallow(x, t.negated())?;
                Some(self.neg(x2))
            }
            _ => None,
        }
    }

    /// [`Dag::absorb`] into `tree`, which has `owners` parents on the path from the
    /// operand: a sum node is rewritten only when nothing else uses it.
    fn absorb_at(
        &mut self,
        tree: Id,
        t: Term,
        mode: Mode,
        budget: &mut usize,
        owners: u32,
    ) -> Option<Id> {
        if *budget == 0 || owners > MAX_DEPTH {
            return None;
        }
        *budget -= 1;
        // A sum node used elsewhere stays alive: rebuilding it would duplicate it. A leaf
        // term may be shared when merging like terms (the merged term replaces it at no
        // extra cost), not when factoring (`c x` would be computed twice).
        let shared = self.parents[tree.index()] > owners.min(1);
        if shared && (self.is_sum(tree) || mode == Mode::CommonFactor) {
            return None;
        }
        match self.node(tree) {
            Node::Add(x, y) => {
                if let Some(x2) = self.absorb_at(x, t, mode, budget, owners + 1) {
                    return Some(self.add_folded(x2, y));
                }
                let y2 = self.absorb_at(y, t, mode, budget, owners + 1)?;
                Some(self.add_folded(x, y2))
            }
            Node::Sub(x, y) => {
                if let Some(x2) = self.absorb_at(x, t, mode, budget, owners + 1) {
                    return Some(self.sub_folded(x2, y));
                }
                let y2 = self.absorb_at(y, t.negated(), mode, budget, owners + 1)?;
                Some(self.sub_folded(x, y2))
            }
            Node::Neg(x) if matches!(self.node(x), Node::Add(..) | Node::Sub(..)) => {
                let x2 = self.absorb_at(x, t.negated(), mode, budget, owners + 1)?;
                Some(self.neg(x2))
            }
            _ => {
                let u = self.term_of(tree, 1.0);
                self.merge_terms(u, t, mode)
            }
        }
    }

    /// The algebra of the module documentation for `a + b` (`negate_b`: `a - b`), or
    /// `None` when nothing applies and the plain node is to be built.
    pub(super) fn collect_sum(&mut self, a: Id, b: Id, negate_b: bool) -> Option<Id> {
        let sb = if negate_b { -1.0 } else { 1.0 };
        let modes: &[Mode] = if self.factor_constants {
            &[Mode::LikeTerm, Mode::CommonFactor]
        } else {
            &[Mode::LikeTerm]
        };
        for &mode in modes {
            // A single term into the other operand (the sum, if either is one).
            if !self.is_sum(b) {
                let t = self.term_of(b, sb);
                if let Some(r) = self.absorb(a, t, mode, &mut budget()) {
                    return Some(r);
                }
            }
            if !self.is_sum(a) {
                let t = self.term_of(a, sb);
                if let Some(r) = self.absorb(b, t, mode, &mut budget()) {
                    return Some(if negate_b { self.neg(r) } else { r });
                }
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::super::Dag;

    /// Builds `src` through the constructors and compares the printed result.
    fn table(dag: impl Fn() -> Dag, rows: &[(&str, &str)]) {
        for (src, expected) in rows {
            let mut d = dag();
            let id = d.parse_sexpr(src).unwrap_or_else(|e| panic!("{src}: {e}"));
            assert_eq!(d.sexpr(id), *expected, "{src}");
        }
    }

    #[test]
    fn constants_merge_across_sums() {
        table(
            Dag::new,
            &[
                ("(+ 0.5 (+ q0 0.25))", "(+ q0 0.75)"),
                ("(+ 1 (- q0 3))", "(- q0 2)"),
                ("(- (+ q0 2) 2)", "q0"),
                ("(+ 2 (- (+ q0 1)))", "(- (+ q0 -1))"),
                // Negative: no constant in the sum, nothing to merge.
                ("(+ 0.5 (+ q0 q1))", "(+ 0.5 (+ q0 q1))"),
                // Negative: the constant is two sum levels down (see MAX_DEPTH).
                (
                    "(+ 0.5 (+ (* 2 q1) (+ q0 0.25)))",
                    "(+ 0.5 (+ (* 2 q1) (+ q0 0.25)))",
                ),
            ],
        );
    }

    #[test]
    fn like_terms_collect_with_constant_coefficients() {
        table(
            Dag::new,
            &[
                ("(+ (/ q0 12) (* 0.25 q0))", "(* 0.3333333333333333 q0)"),
                ("(+ q0 (* 2 q0))", "(* 3 q0)"),
                ("(- (+ q0 q1) q0)", "q1"),
                ("(+ (* 0.5 q0) (- q1 (* 0.5 q0)))", "q1"),
                ("(- (* 3 q0) (* 3 q0))", "0"),
                ("(+ (- q0) (+ q1 (* 3 q0)))", "(+ q1 (* 2 q0))"),
                // Negative: different bases stay apart.
                ("(+ (* 2 q0) (* 3 q1))", "(+ (* 2 q0) (* 3 q1))"),
                // Negative: q0 * q1 is not a constant multiple of q0.
                ("(+ q0 (* q0 q1))", "(+ q0 (* q0 q1))"),
            ],
        );
    }

    #[test]
    fn a_shared_sum_is_not_rebuilt() {
        // (q0 + 2 q1) is used by another node: absorbing q1 into it would compute it twice.
        let mut d = Dag::new();
        let s = d.parse_sexpr("(+ q0 (* 2 q1))").unwrap();
        let _other = d.parse_sexpr("(sin (+ q0 (* 2 q1)))").unwrap();
        let q1 = d.q(1);
        let r = d.add(s, q1);
        assert_eq!(d.sexpr(r), "(+ q1 (+ q0 (* 2 q1)))");
        // A constant still merges into a shared sum's own constant: one addition either way.
        let c = d.parse_sexpr("(+ q0 2)").unwrap();
        let _use = d.parse_sexpr("(cos (+ q0 2))").unwrap();
        let one = d.one();
        let r = d.add(c, one);
        assert_eq!(d.sexpr(r), "(+ q0 3)");
    }

    #[test]
    fn common_constant_factors_are_opt_in() {
        let factoring = || {
            let mut d = Dag::new();
            d.set_factor_constants(true);
            d
        };
        table(
            factoring,
            &[
                ("(+ (* 0.08 q0) (* 0.08 q1))", "(* 0.08 (+ q0 q1))"),
                ("(- (* 0.08 q0) (* 0.08 q1))", "(* 0.08 (- q0 q1))"),
                ("(+ (/ q0 3) (/ q1 3))", "(/ (+ q0 q1) 3)"),
                // Negative: different factors.
                ("(+ (* 0.08 q0) (* 0.07 q1))", "(+ (* 0.08 q0) (* 0.07 q1))"),
                // Negative: a product and a quotient by the same constant.
                ("(+ (* 3 q0) (/ q1 3))", "(+ (* 3 q0) (/ q1 3))"),
            ],
        );
        // Negative: off by default.
        table(
            Dag::new,
            &[("(+ (* 0.08 q0) (* 0.08 q1))", "(+ (* 0.08 q0) (* 0.08 q1))")],
        );
    }

    #[test]
    fn reciprocal_of_any_constant_is_opt_in() {
        let reciprocal = || {
            let mut d = Dag::new();
            d.set_reciprocal_constants(true);
            d
        };
        table(
            reciprocal,
            &[
                ("(/ q0 3)", "(* 0.3333333333333333 q0)"),
                ("(/ q0 -12)", "(- (* 0.08333333333333333 q0))"),
                ("(/ q0 4)", "(* 0.25 q0)"),
                // Negative: a non-constant divisor.
                ("(/ q0 q1)", "(/ q0 q1)"),
            ],
        );
        // Negative: off by default, only powers of two.
        table(
            Dag::new,
            &[("(/ q0 3)", "(/ q0 3)"), ("(/ q0 4)", "(* 0.25 q0)")],
        );
    }

    #[test]
    fn sexpr_round_trips() {
        for src in ["(+ q0 (* 2 qd1))", "(- (sin q0) p3)", "(/ t (^ qdd2 1.5))"] {
            let mut d = Dag::new();
            let id = d.parse_sexpr(src).unwrap();
            assert_eq!(d.sexpr(id), src);
        }
        let mut d = Dag::new();
        assert!(d.parse_sexpr("(+ q0").is_err());
        assert!(d.parse_sexpr("(foo q0)").is_err());
        assert!(d.parse_sexpr("x").is_err());
    }
}
