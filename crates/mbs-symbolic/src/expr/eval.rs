//! The DAG interpreter: a compiled evaluation tape.
//!
//! [`Tape::new`] keeps only the nodes reachable from the requested outputs, renumbers them
//! into a dense slot array (children before parents) and records the operations; evaluation
//! is one pass over that array with no allocation (the caller owns the scratch slots).

use super::{Dag, Fun, Id, Node, Var};

/// The values of the leaves for one evaluation.
#[derive(Clone, Copy, Debug)]
pub struct EvalInput<'a> {
    /// Joint coordinates `q`.
    pub q: &'a [f64],
    /// Joint velocities `q'`.
    pub qd: &'a [f64],
    /// Joint accelerations `q''` (may be empty when no output depends on them).
    pub qdd: &'a [f64],
    /// Time.
    pub t: f64,
    /// All model parameter values, indexed like the model's parameter list.
    pub params: &'a [f64],
}

#[derive(Clone, Copy, Debug)]
enum Op {
    Const(f64),
    Var(Var),
    Neg(u32),
    Add(u32, u32),
    Sub(u32, u32),
    Mul(u32, u32),
    Div(u32, u32),
    Pow(u32, u32),
    Fun(Fun, u32),
}

/// A compiled evaluation program for a fixed list of output expressions.
#[derive(Clone, Debug)]
pub struct Tape {
    ops: Vec<Op>,
    outputs: Vec<u32>,
}

impl Tape {
    /// Compiles the tape that evaluates `outputs` (in this order).
    pub fn new(dag: &Dag, outputs: &[Id]) -> Tape {
        let order = dag.reachable(outputs);
        let mut slot = vec![u32::MAX; dag.len()];
        let mut ops = Vec::with_capacity(order.len());
        for (k, &id) in order.iter().enumerate() {
            slot[id.index()] = k as u32;
            let s = |c: Id| slot[c.index()];
            ops.push(match dag.node(id) {
                Node::Const(bits) => Op::Const(f64::from_bits(bits)),
                Node::Var(v) => Op::Var(v),
                Node::Neg(a) => Op::Neg(s(a)),
                Node::Add(a, b) => Op::Add(s(a), s(b)),
                Node::Sub(a, b) => Op::Sub(s(a), s(b)),
                Node::Mul(a, b) => Op::Mul(s(a), s(b)),
                Node::Div(a, b) => Op::Div(s(a), s(b)),
                Node::Pow(a, b) => Op::Pow(s(a), s(b)),
                Node::Fun(f, a) => Op::Fun(f, s(a)),
            });
        }
        let outputs = outputs.iter().map(|o| slot[o.index()]).collect();
        Tape { ops, outputs }
    }

    /// Number of scratch slots [`Tape::eval`] needs.
    pub fn scratch_len(&self) -> usize {
        self.ops.len()
    }

    /// Number of outputs.
    pub fn output_len(&self) -> usize {
        self.outputs.len()
    }

    /// Evaluates all outputs into `out` using `scratch` (at least [`Tape::scratch_len`] long)
    /// for the intermediate values. Allocates nothing.
    ///
    /// # Panics
    /// If `scratch` or `out` is too short, or an input slice is shorter than the largest
    /// index the expressions use.
    pub fn eval(&self, input: &EvalInput<'_>, scratch: &mut [f64], out: &mut [f64]) {
        assert!(scratch.len() >= self.ops.len(), "scratch too short");
        assert!(out.len() >= self.outputs.len(), "output too short");
        for k in 0..self.ops.len() {
            let v = match self.ops[k] {
                Op::Const(c) => c,
                Op::Var(Var::Q(i)) => input.q[i as usize],
                Op::Var(Var::Qd(i)) => input.qd[i as usize],
                Op::Var(Var::Qdd(i)) => input.qdd[i as usize],
                Op::Var(Var::Time) => input.t,
                Op::Var(Var::Param(i)) => input.params[i as usize],
                Op::Neg(a) => -scratch[a as usize],
                Op::Add(a, b) => scratch[a as usize] + scratch[b as usize],
                Op::Sub(a, b) => scratch[a as usize] - scratch[b as usize],
                Op::Mul(a, b) => scratch[a as usize] * scratch[b as usize],
                Op::Div(a, b) => scratch[a as usize] / scratch[b as usize],
                Op::Pow(a, b) => scratch[a as usize].powf(scratch[b as usize]),
                Op::Fun(f, a) => f.apply(scratch[a as usize]),
            };
            scratch[k] = v;
        }
        for (o, &s) in out.iter_mut().zip(&self.outputs) {
            *o = scratch[s as usize];
        }
    }

    /// Allocating convenience wrapper around [`Tape::eval`].
    pub fn eval_vec(&self, input: &EvalInput<'_>) -> Vec<f64> {
        let mut scratch = vec![0.0; self.scratch_len()];
        let mut out = vec![0.0; self.output_len()];
        self.eval(input, &mut scratch, &mut out);
        out
    }
}
