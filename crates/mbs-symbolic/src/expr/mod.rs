//! The expression DAG: a hash-consed arena of scalar expressions.
//!
//! Nodes live in one flat vector addressed by [`Id`]; a node's children always have smaller
//! ids than the node (children before parents), so evaluating the arena in order evaluates
//! every node after its operands. Building a node that already exists returns the existing
//! id (hash-consing), so shared subexpressions stay shared and nothing is ever expanded: the
//! recursive Newton–Euler formulation (eqs. 1–13) becomes a DAG whose size grows with the
//! recursion, not with the expanded closed form.
//!
//! Leaves are constants, named run-time parameters, joint coordinates `q_i`, velocities `q'_i`,
//! accelerations `q''_i` and time. Sines and cosines of joint angles (and of sums of angles of
//! consecutive parallel revolute joints) are function nodes of a coordinate expression: this
//! is ROBOTRAN's trigonometric substitution, each evaluated once and then reused.
//!
//! Construction folds constants and eliminates `0` and `±1` (`x + 0 = x`, `x * 1 = x`,
//! `x * 0 = 0`, `-(-x) = x`, `c1 * (c2 * x) = (c1 c2) * x`, ...), and orders the operands of
//! commutative operations by id so that `a + b` and `b + a` are the same node. Sums also
//! merge constants and collect like terms with constant coefficients ([`algebra`]; common
//! constant factors and reciprocals of inexact divisors are opt-in:
//! [`Dag::set_factor_constants`], [`Dag::set_reciprocal_constants`]).
//!
//! Submodules: [`algebra`] (the algebra of sums), [`diff`] (symbolic differentiation, time
//! derivatives along the motion), [`eval`] (the interpreter), [`count`] (operation counts),
//! [`sexpr`] (s-expression display and parsing, for table-style tests); `hash` (the
//! deterministic FxHash-style hasher of the hash-consing index and the derivative memos).

use std::fmt;

pub mod algebra;
pub mod count;
pub mod diff;
pub mod eval;
mod hash;
pub mod sexpr;

pub use count::OpCount;
pub use eval::{EvalInput, Tape};

/// Index of a node in a [`Dag`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Id(pub u32);

impl Id {
    /// The node index as `usize`.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// A unary function node: the same functions as the model's parameter expressions.
pub use crate::model::Func as Fun;

/// A variable (leaf) of the DAG.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Var {
    /// Joint coordinate `q_i`.
    Q(u32),
    /// Joint velocity `q'_i`.
    Qd(u32),
    /// Joint acceleration `q''_i`.
    Qdd(u32),
    /// Time `t`.
    Time,
    /// Run-time parameter number `k` (index into the model's parameter list).
    Param(u32),
}

/// One node of the DAG.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Node {
    /// A constant; stored as the bits of a finite `f64` (`-0.0` is normalised to `0.0`).
    Const(u64),
    /// A leaf variable.
    Var(Var),
    /// `-a`
    Neg(Id),
    /// `a + b`, operands ordered by id.
    Add(Id, Id),
    /// `a - b`
    Sub(Id, Id),
    /// `a * b`, operands ordered by id.
    Mul(Id, Id),
    /// `a / b`
    Div(Id, Id),
    /// `a ^ b` for a non-integer or non-constant exponent (`f64::powf`).
    Pow(Id, Id),
    /// `f(a)`
    Fun(Fun, Id),
}

impl Node {
    /// The node's operands (zero, one or two ids).
    pub fn children(&self) -> impl Iterator<Item = Id> {
        let (a, b) = match *self {
            Node::Const(_) | Node::Var(_) => (None, None),
            Node::Neg(a) | Node::Fun(_, a) => (Some(a), None),
            Node::Add(a, b)
            | Node::Sub(a, b)
            | Node::Mul(a, b)
            | Node::Div(a, b)
            | Node::Pow(a, b) => (Some(a), Some(b)),
        };
        a.into_iter().chain(b)
    }
}

/// A hash-consed expression arena. See the module documentation.
#[derive(Clone, Default)]
pub struct Dag {
    nodes: Vec<Node>,
    index: hash::FxHashMap<Node, Id>,
    /// Number of nodes built so far with this node as an operand (the algebra of sums
    /// rewrites only subtrees nobody else uses yet, so that it cannot undo sharing).
    parents: Vec<u32>,
    /// See [`Dag::set_reciprocal_constants`].
    reciprocal_constants: bool,
    /// See [`Dag::set_factor_constants`].
    factor_constants: bool,
}

impl fmt::Debug for Dag {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Dag({} nodes)", self.nodes.len())
    }
}

impl Dag {
    /// An empty DAG.
    pub fn new() -> Dag {
        Dag::default()
    }

    /// Opt-in: divisions by a constant `c` whose reciprocal is inexact (`x / 3`, `x / 12`)
    /// become multiplications by `1/c` (rounded), which are several times cheaper. Off by
    /// default: `x * (1/c)` can differ from `x / c` by one unit in the last place, so the
    /// generated code is then no longer bit-faithful to the model's written divisions
    /// (the deviation is far below the 1e-12 agreement of the tests). Divisions by powers
    /// of two are always multiplications (exact). Applies to nodes built after the call.
    pub fn set_reciprocal_constants(&mut self, on: bool) {
        self.reciprocal_constants = on;
    }

    /// Opt-in: extraction of common constant factors, `c x + c y = c (x + y)` (and
    /// `x / c + y / c = (x + y) / c`), when the sum is built. Off by default: measured on
    /// the planar chains it adds operations (the products `c x` are often used elsewhere
    /// as well, and then computed anyway). Applies to sums built after the call.
    pub fn set_factor_constants(&mut self, on: bool) {
        self.factor_constants = on;
    }

    /// Number of nodes in the arena.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// True when the arena holds no node.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The node with this id.
    pub fn node(&self, id: Id) -> Node {
        self.nodes[id.index()]
    }

    /// All nodes, children before parents.
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    fn intern(&mut self, node: Node) -> Id {
        if let Some(&id) = self.index.get(&node) {
            return id;
        }
        let id = Id(u32::try_from(self.nodes.len()).expect("expression DAG exceeds 2^32 nodes"));
        for c in node.children() {
            self.parents[c.index()] += 1;
        }
        self.nodes.push(node);
        self.parents.push(0);
        self.index.insert(node, id);
        id
    }

    /// The constant value of a node, if it is a constant.
    pub fn as_const(&self, id: Id) -> Option<f64> {
        match self.node(id) {
            Node::Const(bits) => Some(f64::from_bits(bits)),
            _ => None,
        }
    }

    /// True when the node is the constant `v`.
    pub fn is_const(&self, id: Id, v: f64) -> bool {
        self.as_const(id) == Some(v)
    }

    /// A constant. Non-finite values are kept as they are (they only arise from user data the
    /// model validation rejects).
    pub fn constant(&mut self, v: f64) -> Id {
        let v = if v == 0.0 { 0.0 } else { v };
        self.intern(Node::Const(v.to_bits()))
    }

    /// The constant 0.
    pub fn zero(&mut self) -> Id {
        self.constant(0.0)
    }

    /// The constant 1.
    pub fn one(&mut self) -> Id {
        self.constant(1.0)
    }

    /// A leaf variable.
    pub fn var(&mut self, v: Var) -> Id {
        self.intern(Node::Var(v))
    }

    /// `q_i`
    pub fn q(&mut self, i: usize) -> Id {
        self.var(Var::Q(i as u32))
    }

    /// `q'_i`
    pub fn qd(&mut self, i: usize) -> Id {
        self.var(Var::Qd(i as u32))
    }

    /// `q''_i`
    pub fn qdd(&mut self, i: usize) -> Id {
        self.var(Var::Qdd(i as u32))
    }

    /// `-a`, folded.
    pub fn neg(&mut self, a: Id) -> Id {
        match self.node(a) {
            Node::Const(bits) => self.constant(-f64::from_bits(bits)),
            Node::Neg(x) => x,
            Node::Sub(x, y) => self.intern(Node::Sub(y, x)),
            _ => self.intern(Node::Neg(a)),
        }
    }

    /// `a + b`, folded, with like terms, constants and common constant factors collected
    /// (see [`algebra`]).
    pub fn add(&mut self, a: Id, b: Id) -> Id {
        self.add_impl(a, b, true)
    }

    /// `a - b`, folded, with like terms, constants and common constant factors collected
    /// (see [`algebra`]).
    pub fn sub(&mut self, a: Id, b: Id) -> Id {
        self.sub_impl(a, b, true)
    }

    /// `a + b` with the local folds only (zeros, constants, negations); the rebuilding
    /// step of [`algebra`].
    fn add_folded(&mut self, a: Id, b: Id) -> Id {
        self.add_impl(a, b, false)
    }

    /// `a - b` with the local folds only.
    fn sub_folded(&mut self, a: Id, b: Id) -> Id {
        self.sub_impl(a, b, false)
    }

    fn add_impl(&mut self, a: Id, b: Id, collect: bool) -> Id {
        match (self.node(a), self.node(b)) {
            (Node::Const(x), Node::Const(y)) => {
                return self.constant(f64::from_bits(x) + f64::from_bits(y));
            }
            (Node::Const(x), _) if f64::from_bits(x) == 0.0 => return b,
            (_, Node::Const(y)) if f64::from_bits(y) == 0.0 => return a,
            (Node::Neg(x), Node::Neg(y)) => {
                let s = self.add_impl(x, y, collect);
                return self.neg(s);
            }
            (_, Node::Neg(y)) => return self.sub_impl(a, y, collect),
            (Node::Neg(x), _) => return self.sub_impl(b, x, collect),
            _ => {}
        }
        if a == b {
            let two = self.constant(2.0);
            return self.mul(two, a);
        }
        if collect {
            if let Some(r) = self.collect_sum(a, b, false) {
                return r;
            }
        }
        let (a, b) = if a <= b { (a, b) } else { (b, a) };
        self.intern(Node::Add(a, b))
    }

    fn sub_impl(&mut self, a: Id, b: Id, collect: bool) -> Id {
        if a == b {
            return self.zero();
        }
        match (self.node(a), self.node(b)) {
            (Node::Const(x), Node::Const(y)) => {
                return self.constant(f64::from_bits(x) - f64::from_bits(y));
            }
            (_, Node::Const(y)) if f64::from_bits(y) == 0.0 => return a,
            (Node::Const(x), _) if f64::from_bits(x) == 0.0 => return self.neg(b),
            (_, Node::Neg(y)) => return self.add_impl(a, y, collect),
            (Node::Neg(x), _) => {
                let s = self.add_impl(x, b, collect);
                return self.neg(s);
            }
            _ => {}
        }
        if collect {
            if let Some(r) = self.collect_sum(a, b, true) {
                return r;
            }
        }
        self.intern(Node::Sub(a, b))
    }

    /// `a * b`, folded: constants multiplied out, `0`, `1` and `-1` eliminated, negations
    /// pulled out, and a constant factor merged into a product that already has one.
    pub fn mul(&mut self, a: Id, b: Id) -> Id {
        // Constant first.
        let (a, b) = if self.as_const(b).is_some() && self.as_const(a).is_none() {
            (b, a)
        } else {
            (a, b)
        };
        match (self.node(a), self.node(b)) {
            (Node::Const(x), Node::Const(y)) => {
                return self.constant(f64::from_bits(x) * f64::from_bits(y));
            }
            (Node::Const(x), _) => {
                let c = f64::from_bits(x);
                if c == 0.0 {
                    return self.zero();
                }
                if c == 1.0 {
                    return b;
                }
                if c == -1.0 {
                    return self.neg(b);
                }
                if c < 0.0 {
                    let p = self.constant(-c);
                    let m = self.mul(p, b);
                    return self.neg(m);
                }
                match self.node(b) {
                    Node::Neg(y) => {
                        let m = self.mul(a, y);
                        return self.neg(m);
                    }
                    // c1 * (c2 * y) = (c1 c2) * y
                    Node::Mul(y1, y2) if self.as_const(y1).is_some() => {
                        let c2 = self.as_const(y1).unwrap_or(1.0);
                        let k = self.constant(c * c2);
                        return self.mul(k, y2);
                    }
                    _ => {}
                }
            }
            (Node::Neg(x), Node::Neg(y)) => return self.mul(x, y),
            (Node::Neg(x), _) => {
                let m = self.mul(x, b);
                return self.neg(m);
            }
            (_, Node::Neg(y)) => {
                let m = self.mul(a, y);
                return self.neg(m);
            }
            _ => {}
        }
        // x * (c * y) = c * (x * y): keep constants outermost so they merge.
        if self.as_const(a).is_none() {
            if let Node::Mul(y1, y2) = self.node(b) {
                if let Some(c) = self.as_const(y1) {
                    let inner = self.mul(a, y2);
                    let k = self.constant(c);
                    return self.mul(k, inner);
                }
            }
            if let Node::Mul(x1, x2) = self.node(a) {
                if let Some(c) = self.as_const(x1) {
                    let inner = self.mul(x2, b);
                    let k = self.constant(c);
                    return self.mul(k, inner);
                }
            }
        }
        let (a, b) = if a <= b || self.as_const(a).is_some() {
            (a, b)
        } else {
            (b, a)
        };
        self.intern(Node::Mul(a, b))
    }

    /// `a / b`, folded (`b` a nonzero constant becomes a multiplication by its inverse only
    /// when the inverse is exact, to keep evaluation bit-faithful).
    pub fn div(&mut self, a: Id, b: Id) -> Id {
        match (self.node(a), self.node(b)) {
            (_, Node::Const(y)) if f64::from_bits(y) == 1.0 => a,
            (_, Node::Const(y)) if f64::from_bits(y) == -1.0 => self.neg(a),
            (Node::Const(x), _) if f64::from_bits(x) == 0.0 => self.zero(),
            (Node::Const(x), Node::Const(y)) if f64::from_bits(y) != 0.0 => {
                self.constant(f64::from_bits(x) / f64::from_bits(y))
            }
            // x / 2^k = x * 2^-k exactly (one rounding either way): a multiplication is cheaper.
            (_, Node::Const(y)) if exact_reciprocal(f64::from_bits(y)).is_some() => {
                let r = exact_reciprocal(f64::from_bits(y)).unwrap_or(1.0);
                let k = self.constant(r);
                self.mul(k, a)
            }
            // Any other nonzero finite constant when the user opted in (rounded reciprocal).
            (_, Node::Const(y))
                if self.reciprocal_constants
                    && f64::from_bits(y) != 0.0
                    && (1.0 / f64::from_bits(y)).is_normal() =>
            {
                let k = self.constant(1.0 / f64::from_bits(y));
                self.mul(k, a)
            }
            (Node::Neg(x), _) => {
                let d = self.div(x, b);
                self.neg(d)
            }
            (_, Node::Neg(y)) => {
                let d = self.div(a, y);
                self.neg(d)
            }
            _ => {
                if a == b {
                    return self.one();
                }
                self.intern(Node::Div(a, b))
            }
        }
    }

    /// `a ^ b`: a small non-negative integer constant exponent becomes multiplications,
    /// `0.5` a square root; anything else a `powf` node.
    pub fn pow(&mut self, a: Id, b: Id) -> Id {
        if let Some(e) = self.as_const(b) {
            if let Some(x) = self.as_const(a) {
                return self.constant(x.powf(e));
            }
            if e == 0.0 {
                return self.one();
            }
            if e.fract() == 0.0 && (1.0..=16.0).contains(&e) {
                return self.powi(a, e as u32);
            }
            if e.fract() == 0.0 && (-16.0..=-1.0).contains(&e) {
                let p = self.powi(a, (-e) as u32);
                let one = self.one();
                return self.div(one, p);
            }
            if e == 0.5 {
                return self.fun(Fun::Sqrt, a);
            }
        }
        self.intern(Node::Pow(a, b))
    }

    /// `a ^ n` by repeated squaring.
    pub fn powi(&mut self, a: Id, n: u32) -> Id {
        match n {
            0 => self.one(),
            1 => a,
            _ => {
                let h = self.powi(a, n / 2);
                let sq = self.mul(h, h);
                if n % 2 == 1 { self.mul(sq, a) } else { sq }
            }
        }
    }

    /// `f(a)`, folded for constant arguments (and `sin(-x) = -sin x`, `cos(-x) = cos x`).
    pub fn fun(&mut self, f: Fun, a: Id) -> Id {
        if let Some(x) = self.as_const(a) {
            return self.constant(f.apply(x));
        }
        if let Node::Neg(x) = self.node(a) {
            match f {
                Fun::Sin | Fun::Tan => {
                    let s = self.fun(f, x);
                    return self.neg(s);
                }
                Fun::Cos | Fun::Abs => return self.fun(f, x),
                _ => {}
            }
        }
        self.intern(Node::Fun(f, a))
    }

    /// `sin a`
    pub fn sin(&mut self, a: Id) -> Id {
        self.fun(Fun::Sin, a)
    }

    /// `cos a`
    pub fn cos(&mut self, a: Id) -> Id {
        self.fun(Fun::Cos, a)
    }

    /// Sum of several terms (zero when empty).
    pub fn sum(&mut self, terms: impl IntoIterator<Item = Id>) -> Id {
        let mut acc = self.zero();
        for t in terms {
            acc = self.add(acc, t);
        }
        acc
    }

    /// Converts a model parameter expression into the DAG. Parameters with
    /// `runtime == true` become [`Var::Param`] leaves; the others are folded to their value.
    pub fn scalar(&mut self, s: &crate::model::Scalar, params: &[crate::model::Parameter]) -> Id {
        use crate::model::{BinOp, Scalar};
        match s {
            Scalar::Num(v) => self.constant(*v),
            Scalar::Param(k) => {
                let p = &params[*k];
                if p.runtime {
                    self.var(Var::Param(*k as u32))
                } else {
                    self.constant(p.value)
                }
            }
            Scalar::Neg(a) => {
                let a = self.scalar(a, params);
                self.neg(a)
            }
            Scalar::Bin(op, a, b) => {
                let a = self.scalar(a, params);
                let b = self.scalar(b, params);
                match op {
                    BinOp::Add => self.add(a, b),
                    BinOp::Sub => self.sub(a, b),
                    BinOp::Mul => self.mul(a, b),
                    BinOp::Div => self.div(a, b),
                    BinOp::Pow => self.pow(a, b),
                }
            }
            Scalar::Call(f, a) => {
                let a = self.scalar(a, params);
                self.fun(*f, a)
            }
        }
    }

    /// Ids of all nodes reachable from `roots` (each once), in increasing order — the
    /// evaluation order.
    pub fn reachable(&self, roots: &[Id]) -> Vec<Id> {
        let mut mark = vec![false; self.nodes.len()];
        let mut stack: Vec<Id> = roots.to_vec();
        while let Some(id) = stack.pop() {
            if mark[id.index()] {
                continue;
            }
            mark[id.index()] = true;
            stack.extend(self.node(id).children());
        }
        mark.iter()
            .enumerate()
            .filter(|(_, m)| **m)
            .map(|(i, _)| Id(i as u32))
            .collect()
    }
}

/// `1/c` when it is exact: `c` a (normal) power of two whose reciprocal is normal too.
fn exact_reciprocal(c: f64) -> Option<f64> {
    const MANTISSA: u64 = (1 << 52) - 1;
    let r = 1.0 / c;
    let normal = |x: f64| x.is_normal() && x.to_bits() & MANTISSA == 0;
    (normal(c) && normal(r)).then_some(r)
}

impl fmt::Display for Var {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Var::Q(i) => write!(f, "q{i}"),
            Var::Qd(i) => write!(f, "qd{i}"),
            Var::Qdd(i) => write!(f, "qdd{i}"),
            Var::Time => write!(f, "t"),
            Var::Param(k) => write!(f, "p{k}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(build: impl FnOnce(&mut Dag) -> Id, expected: &str) {
        let mut d = Dag::new();
        let id = build(&mut d);
        assert_eq!(d.sexpr(id), expected);
    }

    #[test]
    fn folding_table() {
        check(
            |d| {
                let x = d.q(0);
                let z = d.zero();
                d.add(x, z)
            },
            "q0",
        );
        check(
            |d| {
                let x = d.q(0);
                let o = d.one();
                d.mul(o, x)
            },
            "q0",
        );
        check(
            |d| {
                let x = d.q(0);
                let z = d.zero();
                d.mul(x, z)
            },
            "0",
        );
        check(
            |d| {
                let x = d.q(0);
                let m = d.constant(-1.0);
                d.mul(x, m)
            },
            "(- q0)",
        );
        check(
            |d| {
                let x = d.q(0);
                let n = d.neg(x);
                d.neg(n)
            },
            "q0",
        );
        check(
            |d| {
                let a = d.constant(2.0);
                let b = d.constant(3.0);
                d.add(a, b)
            },
            "5",
        );
        check(
            |d| {
                let x = d.q(0);
                d.sub(x, x)
            },
            "0",
        );
        check(
            |d| {
                let x = d.q(0);
                let y = d.qd(1);
                let n = d.neg(y);
                d.add(x, n)
            },
            "(- q0 qd1)",
        );
        check(
            |d| {
                let x = d.q(0);
                let c2 = d.constant(2.0);
                let c3 = d.constant(3.0);
                let m = d.mul(c3, x);
                d.mul(c2, m)
            },
            "(* 6 q0)",
        );
        check(
            |d| {
                let x = d.q(0);
                let y = d.q(1);
                let c3 = d.constant(3.0);
                let m = d.mul(c3, x);
                d.mul(y, m)
            },
            "(* 3 (* q0 q1))",
        );
        check(
            |d| {
                let x = d.q(0);
                let c = d.constant(-2.0);
                d.mul(c, x)
            },
            "(- (* 2 q0))",
        );
        check(
            |d| {
                let x = d.q(0);
                let c = d.constant(0.0);
                d.sin(c);
                let s = d.neg(x);
                d.cos(s)
            },
            "(cos q0)",
        );
        check(
            |d| {
                let x = d.q(0);
                let n = d.neg(x);
                d.sin(n)
            },
            "(- (sin q0))",
        );
        check(
            |d| {
                let x = d.q(0);
                let c = d.constant(2.0);
                d.pow(x, c)
            },
            "(* q0 q0)",
        );
        check(
            |d| {
                let x = d.q(0);
                let c = d.constant(0.5);
                d.pow(x, c)
            },
            "(sqrt q0)",
        );
        check(
            |d| {
                let x = d.q(0);
                let o = d.one();
                d.div(x, o)
            },
            "q0",
        );
        check(
            |d| {
                let x = d.q(0);
                let (c1, c2) = (d.constant(1.5), d.constant(2.0));
                let s = d.add(c1, x);
                d.add(c2, s)
            },
            "(+ q0 3.5)",
        );
    }

    #[test]
    fn division_by_a_power_of_two_becomes_an_exact_multiplication() {
        for (c, expected) in [
            (2.0, "(* 0.5 q0)"),
            (-0.25, "(- (* 4 q0))"),
            (12.0, "(/ q0 12)"),
            (3.0, "(/ q0 3)"),
        ] {
            check(
                |d| {
                    let x = d.q(0);
                    let k = d.constant(c);
                    d.div(x, k)
                },
                expected,
            );
        }
        for x in [1.0f64, -3.7, 1e-300, 5e-324, 1.7e308] {
            assert_eq!(x / 2.0, x * 0.5);
            assert_eq!(x / 1024.0, x * (1.0 / 1024.0));
        }
    }

    #[test]
    fn hash_consing_shares_and_commutes() {
        let mut d = Dag::new();
        let x = d.q(0);
        let y = d.qd(0);
        let a = d.add(x, y);
        let b = d.add(y, x);
        assert_eq!(a, b);
        let m1 = d.mul(a, x);
        let m2 = d.mul(x, b);
        assert_eq!(m1, m2);
        let n = d.len();
        let _ = d.mul(x, a);
        assert_eq!(
            d.len(),
            n,
            "rebuilding an existing node must not grow the arena"
        );
    }

    #[test]
    fn children_precede_parents() {
        let mut d = Dag::new();
        let x = d.q(0);
        let s = d.sin(x);
        let c = d.cos(x);
        let p = d.mul(s, c);
        let _ = d.add(p, x);
        for (i, n) in d.nodes().iter().enumerate() {
            for c in n.children() {
                assert!(c.index() < i);
            }
        }
    }
}
