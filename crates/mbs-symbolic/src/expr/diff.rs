//! Symbolic differentiation on the DAG.
//!
//! Both derivatives are forward-mode passes memoised per node, so the derivative of a DAG
//! is itself a DAG of comparable size that shares the original's nodes (no expression
//! swell). They implement `J = dh/dq` (eq. 15) and `A = J' q'` (eq. 16).

use super::hash::FxHashMap as HashMap;
use super::{Dag, Fun, Id, Node, Var};

impl Dag {
    /// Partial derivative of `e` with respect to the leaf `v`.
    pub fn diff(&mut self, e: Id, v: Var) -> Id {
        let mut memo = HashMap::default();
        self.diff_memo(
            e,
            &mut |_, var| if var == v { Some(1.0) } else { None },
            &mut memo,
        )
    }

    /// Partial derivatives of several expressions with respect to `v`, sharing one memo.
    pub fn diff_many(&mut self, es: &[Id], v: Var) -> Vec<Id> {
        let mut memo = HashMap::default();
        es.iter()
            .map(|&e| {
                self.diff_memo(
                    e,
                    &mut |_, var| if var == v { Some(1.0) } else { None },
                    &mut memo,
                )
            })
            .collect()
    }

    /// Total time derivative along the motion:
    /// `de/dt = sum_i (de/dq_i q'_i + de/dq'_i q''_i) + de/dt`.
    /// Parameters are constant. Applied to `J q'` this gives `J q'' + A` (eq. 16).
    pub fn time_derivative(&mut self, e: Id) -> Id {
        let mut memo = HashMap::default();
        self.time_derivative_memo(e, &mut memo)
    }

    /// [`Dag::time_derivative`] of several expressions sharing one memo.
    pub fn time_derivative_many(&mut self, es: &[Id]) -> Vec<Id> {
        let mut memo = HashMap::default();
        es.iter()
            .map(|&e| self.time_derivative_memo(e, &mut memo))
            .collect()
    }

    /// Derivative along the velocity with `q'` held fixed: `sum_i de/dq_i q'_i`.
    ///
    /// Applied to a position `p(q)` it gives the velocity `J q'`; applied to `J q'` it gives
    /// the bias `A = d(J q')/dq q'` of eqs. (16) and (50).
    pub fn velocity_derivative_many(&mut self, es: &[Id]) -> Vec<Id> {
        let mut memo = HashMap::default();
        es.iter()
            .map(|&e| {
                self.forward(e, &mut memo, &mut |dag, v| match v {
                    Var::Q(i) => dag.var(Var::Qd(i)),
                    _ => dag.zero(),
                })
            })
            .collect()
    }

    fn time_derivative_memo(&mut self, e: Id, memo: &mut HashMap<Id, Id>) -> Id {
        // Leaf derivatives: q -> q', q' -> q'', t -> 1; q'' has no derivative here (it would
        // need jerk) and must not appear in the differentiated expression.
        self.forward(e, memo, &mut |dag, v| match v {
            Var::Q(i) => dag.var(Var::Qd(i)),
            Var::Qd(i) => dag.var(Var::Qdd(i)),
            Var::Time => dag.one(),
            Var::Param(_) => dag.zero(),
            Var::Qdd(_) => panic!("time derivative of an expression containing q''"),
        })
    }

    fn diff_memo(
        &mut self,
        e: Id,
        seed: &mut dyn FnMut(&mut Dag, Var) -> Option<f64>,
        memo: &mut HashMap<Id, Id>,
    ) -> Id {
        self.forward(e, memo, &mut |dag, v| match seed(dag, v) {
            Some(c) => dag.constant(c),
            None => dag.zero(),
        })
    }

    /// Forward-mode derivative: `leaf(v)` gives the derivative of each leaf variable.
    /// Iterative (post-order with an explicit stack) so deep DAGs cannot overflow the stack.
    fn forward(
        &mut self,
        root: Id,
        memo: &mut HashMap<Id, Id>,
        leaf: &mut dyn FnMut(&mut Dag, Var) -> Id,
    ) -> Id {
        let mut stack = vec![(root, false)];
        while let Some((e, expanded)) = stack.pop() {
            if memo.contains_key(&e) {
                continue;
            }
            let node = self.node(e);
            if !expanded {
                stack.push((e, true));
                for c in node.children() {
                    if !memo.contains_key(&c) {
                        stack.push((c, false));
                    }
                }
                continue;
            }
            let d = |memo: &HashMap<Id, Id>, c: Id| memo[&c];
            let de = match node {
                Node::Const(_) => self.zero(),
                Node::Var(v) => leaf(self, v),
                Node::Neg(a) => {
                    let da = d(memo, a);
                    self.neg(da)
                }
                Node::Add(a, b) => {
                    let (da, db) = (d(memo, a), d(memo, b));
                    self.add(da, db)
                }
                Node::Sub(a, b) => {
                    let (da, db) = (d(memo, a), d(memo, b));
                    self.sub(da, db)
                }
                Node::Mul(a, b) => {
                    let (da, db) = (d(memo, a), d(memo, b));
                    let t1 = self.mul(da, b);
                    let t2 = self.mul(a, db);
                    self.add(t1, t2)
                }
                Node::Div(a, b) => {
                    // (a/b)' = (a' - (a/b) b') / b
                    let (da, db) = (d(memo, a), d(memo, b));
                    let t = self.mul(e, db);
                    let n = self.sub(da, t);
                    self.div(n, b)
                }
                Node::Pow(a, b) => {
                    // (a^b)' = a^b (b' ln a + b a'/a)
                    let (da, db) = (d(memo, a), d(memo, b));
                    let ln = self.fun(Fun::Ln, a);
                    let t1 = self.mul(db, ln);
                    let q = self.div(da, a);
                    let t2 = self.mul(b, q);
                    let s = self.add(t1, t2);
                    self.mul(e, s)
                }
                Node::Fun(f, a) => {
                    let da = d(memo, a);
                    let fprime = match f {
                        Fun::Sin => self.cos(a),
                        Fun::Cos => {
                            let s = self.sin(a);
                            self.neg(s)
                        }
                        Fun::Tan => {
                            // 1 + tan^2
                            let sq = self.mul(e, e);
                            let one = self.one();
                            self.add(one, sq)
                        }
                        Fun::Sqrt => {
                            let two = self.constant(2.0);
                            let den = self.mul(two, e);
                            let one = self.one();
                            self.div(one, den)
                        }
                        Fun::Exp => e,
                        Fun::Ln => {
                            let one = self.one();
                            self.div(one, a)
                        }
                        Fun::Abs => {
                            // sign(a) = a / |a| (undefined at 0, like the function itself)
                            self.div(a, e)
                        }
                    };
                    self.mul(fprime, da)
                }
            };
            memo.insert(e, de);
        }
        memo[&root]
    }
}

#[cfg(test)]
mod tests {
    use super::super::eval::{EvalInput, Tape};
    use super::*;

    fn eval(d: &Dag, e: Id, q: &[f64], qd: &[f64], qdd: &[f64]) -> f64 {
        let tape = Tape::new(d, &[e]);
        let mut out = [0.0];
        let mut scratch = vec![0.0; tape.scratch_len()];
        tape.eval(
            &EvalInput {
                q,
                qd,
                qdd,
                t: 0.3,
                params: &[],
            },
            &mut scratch,
            &mut out,
        );
        out[0]
    }

    #[test]
    fn derivative_matches_central_differences() {
        let mut d = Dag::new();
        let (x, y) = (d.q(0), d.q(1));
        let s = d.sin(x);
        let c = d.cos(y);
        let p = d.mul(s, c);
        let xy = d.add(x, y);
        let sxy = d.sin(xy);
        let den = d_add_const(&mut d, sxy, 3.0);
        let q = d.div(p, den);
        let x2 = d_add_const(&mut d, x, 2.0);
        let sq = d.fun(Fun::Sqrt, x2);
        let e = d.add(q, sq);
        let de = d.diff(e, Var::Q(0));
        let q0 = [0.4, -1.1];
        let h = 1e-6;
        let fp = eval(&d, e, &[q0[0] + h, q0[1]], &[0.0; 2], &[0.0; 2]);
        let fm = eval(&d, e, &[q0[0] - h, q0[1]], &[0.0; 2], &[0.0; 2]);
        let fd = (fp - fm) / (2.0 * h);
        let an = eval(&d, de, &q0, &[0.0; 2], &[0.0; 2]);
        assert!((fd - an).abs() < 1e-8, "{fd} vs {an}");
    }

    fn d_add_const(d: &mut Dag, e: Id, c: f64) -> Id {
        let k = d.constant(c);
        d.add(e, k)
    }

    #[test]
    fn time_derivative_is_chain_rule() {
        // e = q0 * qd1 -> de/dt = qd0 * qd1 + q0 * qdd1
        let mut d = Dag::new();
        let (q0, qd1) = (d.q(0), d.qd(1));
        let e = d.mul(q0, qd1);
        let de = d.time_derivative(e);
        let v = eval(&d, de, &[2.0, 0.0], &[3.0, 5.0], &[0.0, 7.0]);
        assert_eq!(v, 3.0 * 5.0 + 2.0 * 7.0);
    }
}
