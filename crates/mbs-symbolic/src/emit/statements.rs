//! DAG expressions to Rust statements: the nodes a function's outputs need, in DAG order
//! (children before parents), become scalar intermediates (`let (s1, c1) =
//! f64::sin_cos(q[0]);`, `let x12 = ...;`) when they are shared, trigonometric, named angle
//! sums (`s12`, `c12`), or would nest too deeply; every other node is inlined into its single
//! user. Parameter-only subexpressions hoisted into the struct's cache are read from it
//! (`self.hoisted[3]`) and never recomputed. Outputs are assigned to their destinations
//! (`m[0][1] = ...;`).
//!
//! The statements are written as text directly (see `printer.rs`), not as tokens to be
//! re-parsed: the bodies are most of a generated file.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use super::printer::{E, write_statement};
use crate::expr::{Dag, Fun, Id, Node, Var};

/// Where a function's output value goes (the text before ` = `).
pub(super) enum Dest {
    /// `name`
    Scalar(String),
    /// `name[i]`
    Vec(String, usize),
    /// `name[i][j]`
    Mat(String, usize, usize),
}

impl Dest {
    fn text(&self) -> String {
        match self {
            Dest::Scalar(n) => n.clone(),
            Dest::Vec(n, i) => format!("{n}[{i}]"),
            Dest::Mat(n, i, j) => format!("{n}[{i}][{j}]"),
        }
    }
}

/// The statements of one function body and the inputs they read.
pub(super) struct Body {
    /// One statement per line (possibly broken over several lines), each line indented by
    /// [`BODY_INDENT`] spaces, ending with a newline.
    pub text: String,
    /// The inputs read: `"q"`, `"qd"`, `"qdd"`, `"t"`, `"self"`.
    pub inputs: BTreeSet<&'static str>,
}

/// Indentation of the statements of a method body inside an `impl` block.
pub(super) const BODY_INDENT: usize = 8;

/// Turns the DAG nodes an emitted function needs into `let` statements and assignments.
#[derive(Clone, Copy)]
pub(super) struct FnEmitter<'a> {
    /// The expression arena.
    pub dag: &'a Dag,
    /// Field names of the parameters, by parameter index (`self.<name>`).
    pub params: &'a [String],
    /// Preset names of nodes (the angle sums `s12`, `c12`); such nodes always get a `let`.
    pub names: &'a BTreeMap<Id, String>,
    /// Hoisted parameter-only nodes: index into the struct's cache field, by node index
    /// (`u32::MAX` = not hoisted). Empty: nothing hoisted.
    pub hoisted: &'a [u32],
    /// Name of the cache field.
    pub cache_field: &'a str,
}

/// Marker of a node that is not hoisted.
pub(super) const NOT_HOISTED: u32 = u32::MAX;

impl FnEmitter<'_> {
    fn hoisted_index(&self, id: Id) -> Option<u32> {
        self.hoisted
            .get(id.index())
            .copied()
            .filter(|&k| k != NOT_HOISTED)
    }

    /// Nodes reachable from `roots` without entering hoisted nodes (which are leaves here),
    /// in increasing id order.
    pub fn reachable(&self, roots: &[Id]) -> Vec<Id> {
        let mut mark = vec![false; self.dag.len()];
        let mut stack: Vec<Id> = roots.to_vec();
        while let Some(id) = stack.pop() {
            if std::mem::replace(&mut mark[id.index()], true) {
                continue;
            }
            if self.hoisted_index(id).is_none() {
                stack.extend(self.dag.node(id).children());
            }
        }
        mark.iter()
            .enumerate()
            .filter(|(_, m)| **m)
            .map(|(i, _)| Id(i as u32))
            .collect()
    }

    /// The hoisted nodes among `order` (a result of [`FnEmitter::reachable`]).
    pub fn hoisted_in(&self, order: &[Id]) -> Vec<Id> {
        order
            .iter()
            .copied()
            .filter(|&id| self.hoisted_index(id).is_some())
            .collect()
    }

    /// Emits the body of a function computing `outputs` into their destinations.
    pub fn body(&self, outputs: &[(Id, Dest)]) -> Body {
        let dag = self.dag;
        let roots: Vec<Id> = outputs.iter().map(|(id, _)| *id).collect();
        let order = self.reachable(&roots);
        let mut uses = vec![0u32; dag.len()];
        // sin and cos of the same argument: computed together by one `f64::sin_cos`.
        let mut sin_of: BTreeMap<Id, Id> = BTreeMap::new();
        let mut cos_of: BTreeMap<Id, Id> = BTreeMap::new();
        for &id in &order {
            if self.hoisted_index(id).is_some() {
                continue;
            }
            let node = dag.node(id);
            for c in node.children() {
                uses[c.index()] += 1;
            }
            match node {
                Node::Fun(Fun::Sin, a) => {
                    sin_of.insert(a, id);
                }
                Node::Fun(Fun::Cos, a) => {
                    cos_of.insert(a, id);
                }
                _ => {}
            }
        }
        for r in &roots {
            uses[r.index()] += 1;
        }
        // Decide which nodes get a `let`: shared nodes, trigonometric leaves, named nodes,
        // and nodes whose inlined expression would grow too deep.
        let mut named: Vec<Option<String>> = vec![None; dag.len()];
        let mut depth = vec![0usize; dag.len()];
        let mut taken: BTreeSet<String> = BTreeSet::new();
        let mut inputs: BTreeSet<&'static str> = BTreeSet::new();
        let mut text = String::new();
        let mut tmp = 0usize;
        let unique = |base: String, taken: &mut BTreeSet<String>| {
            let mut name = base.clone();
            let mut k = 1;
            while !taken.insert(name.clone()) {
                k += 1;
                name = format!("{base}_{k}");
            }
            name
        };
        for &id in &order {
            if self.hoisted_index(id).is_some() {
                inputs.insert("self");
                continue;
            }
            let node = dag.node(id);
            match node {
                Node::Const(_) => continue,
                Node::Var(v) => {
                    inputs.insert(match v {
                        Var::Q(_) => "q",
                        Var::Qd(_) => "qd",
                        Var::Qdd(_) => "qdd",
                        Var::Time => "t",
                        Var::Param(_) => "self",
                    });
                    continue;
                }
                _ => {}
            }
            if named[id.index()].is_some() {
                // The cosine of a `sin_cos` pair, named with its sine.
                continue;
            }
            // `let (s1, c1) = f64::sin_cos(q[0]);` when both are needed: one libm `sincos`.
            // (LLVM merges separate `sin` and `cos` calls of one argument into the same
            // `sincos` call; measured on the development machine: 47 ns for two angles
            // with `sin_cos`, 48 ns with separate calls, 39 ns for two `sin` alone. The pair
            // makes the single evaluation explicit; a lone sine or cosine stays a single
            // call, which is cheaper than `sincos`.)
            if let Node::Fun(Fun::Sin | Fun::Cos, a) = node {
                if let (Some(&s), Some(&c)) = (sin_of.get(&a), cos_of.get(&a)) {
                    let sname = unique(self.name_of(s), &mut taken);
                    let cname = unique(self.name_of(c), &mut taken);
                    let arg = self.expr(a, &named);
                    let mut line = String::new();
                    let _ = write!(line, "let ({sname}, {cname}) = ");
                    write_statement(
                        &mut text,
                        BODY_INDENT,
                        &line,
                        &E::call("f64::sin_cos", vec![arg]),
                    );
                    named[s.index()] = Some(sname);
                    named[c.index()] = Some(cname);
                    continue;
                }
            }
            let d = 1 + node.children().map(|c| depth[c.index()]).max().unwrap_or(0);
            let trig = trig_name(dag, id);
            let shared = uses[id.index()] > 1;
            let preset = self.names.contains_key(&id);
            if shared || trig.is_some() || preset || d > 12 {
                let base = self.names.get(&id).cloned().or(trig).unwrap_or_else(|| {
                    tmp += 1;
                    format!("x{tmp}")
                });
                let name = unique(base, &mut taken);
                let e = self.expr(id, &named);
                write_statement(&mut text, BODY_INDENT, &format!("let {name} = "), &e);
                named[id.index()] = Some(name);
                depth[id.index()] = 0;
            } else {
                depth[id.index()] = d;
            }
        }
        for (id, dest) in outputs {
            let e = self.expr(*id, &named);
            write_statement(&mut text, BODY_INDENT, &format!("{} = ", dest.text()), &e);
        }
        Body { text, inputs }
    }

    /// The base name of a trigonometric node (`s1`, `c12`, or `x` for other arguments).
    fn name_of(&self, id: Id) -> String {
        self.names
            .get(&id)
            .cloned()
            .or_else(|| trig_name(self.dag, id))
            .unwrap_or_else(|| "x".into())
    }

    /// The expression of a node: its name if it has one, else built from its children.
    fn expr(&self, id: Id, named: &[Option<String>]) -> E {
        if let Some(n) = &named[id.index()] {
            return E::atom(n.clone());
        }
        if let Some(k) = self.hoisted_index(id) {
            return E::atom(format!("self.{}[{k}]", self.cache_field));
        }
        let sub = |c: Id| self.expr(c, named);
        match self.dag.node(id) {
            Node::Const(bits) => float_literal(f64::from_bits(bits)),
            Node::Var(Var::Q(i)) => E::atom(format!("q[{i}]")),
            Node::Var(Var::Qd(i)) => E::atom(format!("qd[{i}]")),
            Node::Var(Var::Qdd(i)) => E::atom(format!("qdd[{i}]")),
            Node::Var(Var::Time) => E::atom("t".into()),
            Node::Var(Var::Param(k)) => E::atom(format!("self.{}", self.params[k as usize])),
            Node::Neg(a) => E::neg(sub(a)),
            Node::Add(a, b) => E::bin(sub(a), "+", sub(b)),
            Node::Sub(a, b) => E::bin(sub(a), "-", sub(b)),
            Node::Mul(a, b) => E::bin(sub(a), "*", sub(b)),
            Node::Div(a, b) => E::bin(sub(a), "/", sub(b)),
            Node::Pow(a, b) => E::call("f64::powf", vec![sub(a), sub(b)]),
            Node::Fun(f, a) => E::call(&format!("f64::{}", f.name()), vec![sub(a)]),
        }
    }
}

/// A float literal that round-trips exactly (negative values parenthesised).
fn float_literal(v: f64) -> E {
    if v.is_nan() {
        return E::atom("f64::NAN".into());
    }
    if v.is_infinite() {
        return E::atom(
            if v > 0.0 {
                "f64::INFINITY"
            } else {
                "f64::NEG_INFINITY"
            }
            .into(),
        );
    }
    // `{:?}` is the shortest representation that reads back to the same value, always
    // with a `.` or an exponent (a float literal).
    let lit = format!("{:?}", v.abs());
    if v < 0.0 {
        E::atom(format!("(-{lit})"))
    } else {
        E::atom(lit)
    }
}

/// ROBOTRAN-style names: `s1 = sin q1`, `c12` for the cosine of `q1 + q2` (1-based
/// coordinate numbers, `_` between them past 9).
pub(super) fn angle_name(prefix: &str, coords: &[usize]) -> String {
    let mut coords: Vec<usize> = coords.iter().map(|c| c + 1).collect();
    coords.sort_unstable();
    let sep = if coords.iter().any(|&c| c > 9) {
        "_"
    } else {
        ""
    };
    let body: Vec<String> = coords.iter().map(usize::to_string).collect();
    format!("{prefix}{}", body.join(sep))
}

/// The name of a sine or cosine of a coordinate or of a sum of coordinates.
fn trig_name(dag: &Dag, id: Id) -> Option<String> {
    let Node::Fun(f, arg) = dag.node(id) else {
        return None;
    };
    let prefix = match f {
        Fun::Sin => "s",
        Fun::Cos => "c",
        _ => return None,
    };
    let mut coords = vec![];
    let mut stack = vec![arg];
    while let Some(a) = stack.pop() {
        match dag.node(a) {
            Node::Var(Var::Q(i)) => coords.push(i as usize),
            Node::Add(x, y) => {
                stack.push(y);
                stack.push(x);
            }
            _ => return None,
        }
    }
    Some(angle_name(prefix, &coords))
}
