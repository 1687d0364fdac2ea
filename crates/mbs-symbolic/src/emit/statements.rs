//! DAG expressions to Rust statements: the nodes a function's outputs need, in DAG order
//! (children before parents), become scalar intermediates (`let ([s1, s2], [c1, c2]) =
//! rt::sin_cos([q[0], q[1]]);`, `let x12 = ...;`) when they are shared, trigonometric, named angle
//! sums (`s12`, `c12`), or would nest too deeply; every other node is inlined into its single
//! user. Parameter-only subexpressions hoisted into the struct's cache are read from it
//! (`self.hoisted[3]`) and never recomputed. Outputs are assigned to their destinations
//! (`m[0][1] = ...;`).
//!
//! The statements are written as text directly (see `printer.rs`), not as tokens to be
//! re-parsed: the bodies are most of a generated file.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use super::printer::{E, MAX_WIDTH, write_statement};
use crate::expr::{Dag, Fun, Id, Node, Var};

/// Where a function's output value goes (the text before ` = `).
#[derive(Clone)]
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
    /// Path of the runtime module (`::mbs_symbolic::runtime`), for its `sin_cos`.
    pub runtime: &'a str,
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

    /// Emits the body of a function computing `outputs` into their destinations: one
    /// statement per line (possibly broken over several lines), each line indented by
    /// [`BODY_INDENT`] spaces, ending with a newline.
    /// `order` is the result of [`FnEmitter::reachable`] on the outputs.
    pub fn body(&self, outputs: &[(Id, Dest)], order: &[Id]) -> String {
        let dag = self.dag;
        let roots: Vec<Id> = outputs.iter().map(|(id, _)| *id).collect();
        // Per-node data indexed by position in `order`.
        let mut pos = vec![u32::MAX; dag.len()];
        for (k, id) in order.iter().enumerate() {
            pos[id.index()] = k as u32;
        }
        let at = |id: Id| pos[id.index()] as usize;
        let mut uses = vec![0u32; order.len()];
        // sin and cos of the same argument: computed together (the coordinates' in one batched
        // `runtime::sin_cos` call at the top of the body, any other argument in a one-lane call).
        let mut sin_of: BTreeMap<Id, Id> = BTreeMap::new();
        let mut cos_of: BTreeMap<Id, Id> = BTreeMap::new();
        for &id in order {
            if self.hoisted_index(id).is_some() {
                continue;
            }
            let node = dag.node(id);
            for c in node.children() {
                uses[at(c)] += 1;
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
        for &r in &roots {
            uses[at(r)] += 1;
        }
        // Decide which nodes get a `let`: shared nodes, trigonometric leaves, named nodes,
        // and nodes whose inlined expression would grow too deep.
        let mut named: Vec<Option<String>> = vec![None; order.len()];
        let mut depth = vec![0u32; order.len()];
        let mut taken: BTreeSet<String> = BTreeSet::new();
        let mut text = String::new();
        let mut tmp = 0usize;
        // The temporaries `x1`, `x2`, ... are unique by construction; the other names
        // (sines, cosines: `s`, `c` and digits, `_`) are checked among themselves.
        let unique = |base: String, taken: &mut BTreeSet<String>| {
            let mut name = base.clone();
            let mut k = 1;
            while !taken.insert(name.clone()) {
                k += 1;
                name = format!("{base}_{k}");
            }
            name
        };
        // The sines and cosines of the coordinates, all at once first: `let ([s1, s2], [c1,
        // c2]) = rt::sin_cos([q[0], q[1]]);` (the lanes of one branch-free kernel, about
        // the time of one libm `sincos` for two angles; `runtime/trig.rs`). A coordinate
        // of which only the sine or only the cosine is used still goes through the kernel
        // (cheaper than a lone libm call); the unused value is bound to `_`.
        {
            let mut angles: Vec<(Option<Id>, Option<Id>, usize)> = Vec::new();
            let mut seen: BTreeSet<Id> = BTreeSet::new();
            for &id in order {
                if self.hoisted_index(id).is_some() {
                    continue;
                }
                if let Node::Fun(Fun::Sin | Fun::Cos, a) = dag.node(id)
                    && let Node::Var(Var::Q(i)) = dag.node(a)
                    && seen.insert(a)
                {
                    angles.push((sin_of.get(&a).copied(), cos_of.get(&a).copied(), i as usize));
                }
            }
            if !angles.is_empty() {
                let mut bind = |t: Option<Id>, taken: &mut BTreeSet<String>| match t {
                    Some(t) => {
                        let name = unique(self.name_of(t), taken);
                        named[at(t)] = Some(name.clone());
                        name
                    }
                    None => "_".to_string(),
                };
                let mut sines = Vec::new();
                let mut cosines = Vec::new();
                let mut args = Vec::new();
                for &(s, c, i) in &angles {
                    sines.push(bind(s, &mut taken));
                    cosines.push(bind(c, &mut taken));
                    args.push(format!("q[{i}]"));
                }
                write_sin_cos(&mut text, self.runtime, &sines, &cosines, &args);
            }
        }
        for (k, &id) in order.iter().enumerate() {
            if self.hoisted_index(id).is_some() {
                continue;
            }
            let node = dag.node(id);
            if matches!(node, Node::Const(_) | Node::Var(_)) {
                continue;
            }
            if named[k].is_some() {
                // The cosine of a `sin_cos` pair, named with its sine.
                continue;
            }
            let names = Names {
                pos: &pos,
                named: &named,
            };
            // Sine and cosine of any other argument, both needed: one lane of the same kernel
            // (`let ([s12], [c12]) = rt::sin_cos([(q[0] + q[1])]);`). A lone sine or cosine
            // of such an argument stays a libm call.
            if let Node::Fun(Fun::Sin | Fun::Cos, a) = node
                && let (Some(&s), Some(&c)) = (sin_of.get(&a), cos_of.get(&a))
            {
                let sname = unique(self.name_of(s), &mut taken);
                let cname = unique(self.name_of(c), &mut taken);
                let head = format!("let ([{sname}], [{cname}]) = ");
                let call = E::call(
                    &format!("{}::sin_cos", self.runtime),
                    vec![E::array(vec![self.expr(a, &names)])],
                );
                write_statement(&mut text, BODY_INDENT, &head, &call);
                named[at(s)] = Some(sname);
                named[at(c)] = Some(cname);
                continue;
            }
            let d = 1 + node.children().map(|c| depth[at(c)]).max().unwrap_or(0);
            let trig = trig_name(dag, id);
            let shared = uses[k] > 1;
            let preset = self.names.contains_key(&id);
            if shared || trig.is_some() || preset || d > 12 {
                let name = match self.names.get(&id).cloned().or(trig) {
                    Some(base) => unique(base, &mut taken),
                    None => {
                        tmp += 1;
                        format!("x{tmp}")
                    }
                };
                let head = format!("let {name} = ");
                self.statement(&mut text, &head, id, &names);
                named[k] = Some(name);
                depth[k] = 0;
            } else {
                depth[k] = d;
            }
        }
        let names = Names {
            pos: &pos,
            named: &named,
        };
        for (id, dest) in outputs {
            let head = format!("{} = ", dest.text());
            self.statement(&mut text, &head, *id, &names);
        }
        text
    }

    /// The inputs read by the nodes of `order` (a result of [`FnEmitter::reachable`]):
    /// `"q"`, `"qd"`, `"qdd"`, `"t"`, `"self"`.
    pub fn inputs(&self, order: &[Id]) -> BTreeSet<&'static str> {
        let mut inputs = BTreeSet::new();
        for &id in order {
            if self.hoisted_index(id).is_some() {
                inputs.insert("self");
            } else if let Node::Var(v) = self.dag.node(id) {
                inputs.insert(match v {
                    Var::Q(_) => "q",
                    Var::Qd(_) => "qd",
                    Var::Qdd(_) => "qdd",
                    Var::Time => "t",
                    Var::Param(_) => "self",
                });
            }
        }
        inputs
    }

    /// Appends the statement `{head}{expression of id};`: written flat directly when it
    /// fits on one line (most statements), else laid out by the printer.
    fn statement(&self, text: &mut String, head: &str, id: Id, names: &Names<'_>) {
        let start = text.len();
        text.extend(std::iter::repeat_n(' ', BODY_INDENT));
        text.push_str(head);
        self.flat(id, names, text);
        text.push_str(";\n");
        if text.len() - start - 1 > MAX_WIDTH {
            text.truncate(start);
            write_statement(text, BODY_INDENT, head, &self.expr(id, names));
        }
    }

    /// The one-line text of a node's expression, appended to `out`.
    fn flat(&self, id: Id, names: &Names<'_>, out: &mut String) {
        if let Some(n) = names.get(id) {
            out.push_str(n);
            return;
        }
        if let Some(k) = self.hoisted_index(id) {
            let _ = write!(out, "self.{}[{k}]", self.cache_field);
            return;
        }
        let bin = |a: Id, op: &str, b: Id, out: &mut String| {
            out.push('(');
            self.flat(a, names, out);
            out.push(' ');
            out.push_str(op);
            out.push(' ');
            self.flat(b, names, out);
            out.push(')');
        };
        match self.dag.node(id) {
            Node::Const(bits) => push_float(f64::from_bits(bits), out),
            Node::Var(Var::Q(i)) => {
                let _ = write!(out, "q[{i}]");
            }
            Node::Var(Var::Qd(i)) => {
                let _ = write!(out, "qd[{i}]");
            }
            Node::Var(Var::Qdd(i)) => {
                let _ = write!(out, "qdd[{i}]");
            }
            Node::Var(Var::Time) => out.push('t'),
            Node::Var(Var::Param(k)) => {
                out.push_str("self.");
                out.push_str(&self.params[k as usize]);
            }
            Node::Neg(a) => {
                out.push_str("(-");
                self.flat(a, names, out);
                out.push(')');
            }
            Node::Add(a, b) => bin(a, "+", b, out),
            Node::Sub(a, b) => bin(a, "-", b, out),
            Node::Mul(a, b) => bin(a, "*", b, out),
            Node::Div(a, b) => bin(a, "/", b, out),
            Node::Pow(a, b) => {
                out.push_str("f64::powf(");
                self.flat(a, names, out);
                out.push_str(", ");
                self.flat(b, names, out);
                out.push(')');
            }
            Node::Fun(f, a) => {
                out.push_str("f64::");
                out.push_str(f.name());
                out.push('(');
                self.flat(a, names, out);
                out.push(')');
            }
        }
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
    fn expr(&self, id: Id, names: &Names<'_>) -> E {
        if let Some(n) = names.get(id) {
            return E::atom(n.to_string());
        }
        if let Some(k) = self.hoisted_index(id) {
            return E::atom(format!("self.{}[{k}]", self.cache_field));
        }
        let sub = |c: Id| self.expr(c, names);
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

/// Writes `let ([s1, s2], [c1, c2]) = rt::sin_cos([q[0], q[1]]);` on one line when it fits
/// in [`MAX_WIDTH`], else with one name or argument per line (rustfmt's vertical layout).
fn write_sin_cos(
    text: &mut String,
    runtime: &str,
    sines: &[String],
    cosines: &[String],
    args: &[String],
) {
    let pad = " ".repeat(BODY_INDENT);
    let line = format!(
        "{pad}let ([{}], [{}]) = {runtime}::sin_cos([{}]);",
        sines.join(", "),
        cosines.join(", "),
        args.join(", ")
    );
    if line.len() <= MAX_WIDTH {
        text.push_str(&line);
        text.push('\n');
        return;
    }
    let list = |items: &[String], indent: usize, text: &mut String| {
        let inner = " ".repeat(indent + 4);
        for item in items {
            let _ = writeln!(text, "{inner}{item},");
        }
        text.push_str(&" ".repeat(indent));
    };
    let _ = writeln!(text, "{pad}let (");
    let _ = writeln!(text, "{pad}    [");
    list(sines, BODY_INDENT + 4, text);
    text.push_str("],\n");
    let _ = writeln!(text, "{pad}    [");
    list(cosines, BODY_INDENT + 4, text);
    text.push_str("],\n");
    let _ = writeln!(text, "{pad}) = {runtime}::sin_cos([");
    list(args, BODY_INDENT, text);
    text.push_str("]);\n");
}

/// The names given so far in one body, by node.
struct Names<'a> {
    /// Position of each node in the body's evaluation order (`u32::MAX`: not in it).
    pos: &'a [u32],
    /// The name of each node of the order that has one.
    named: &'a [Option<String>],
}

impl Names<'_> {
    fn get(&self, id: Id) -> Option<&str> {
        let k = *self.pos.get(id.index())?;
        self.named.get(k as usize)?.as_deref()
    }
}

/// A float literal that round-trips exactly (negative values parenthesised).
fn float_literal(v: f64) -> E {
    let mut s = String::new();
    push_float(v, &mut s);
    E::atom(s)
}

/// Appends a float literal that round-trips exactly (negative values parenthesised).
fn push_float(v: f64, out: &mut String) {
    if v.is_nan() {
        out.push_str("f64::NAN");
    } else if v.is_infinite() {
        out.push_str(if v > 0.0 {
            "f64::INFINITY"
        } else {
            "f64::NEG_INFINITY"
        });
    } else if v < 0.0 {
        // `{:?}` is the shortest representation that reads back to the same value, always
        // with a `.` or an exponent (a float literal).
        let _ = write!(out, "(-{:?})", -v);
    } else {
        let _ = write!(out, "{v:?}");
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
