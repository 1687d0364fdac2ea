//! DAG expressions to Rust statements: the nodes a function's outputs need, in DAG order
//! (children before parents), become scalar intermediates (`let s1 = f64::sin(q[0]);`,
//! `let x12 = ...;`) when they are shared, trigonometric, or would nest too deeply; every
//! other node is inlined into its single user. Outputs are assigned to their destinations
//! (`m[0][1] = ...;`).

use std::collections::{BTreeMap, BTreeSet};

use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::{format_ident, quote};

use crate::expr::{Dag, Fun, Id, Node, Var};

/// Where a function's output value goes.
pub(super) enum Dest {
    /// `name`
    Scalar(Ident),
    /// `name[i]`
    Vec(Ident, usize),
    /// `name[i][j]`
    Mat(Ident, usize, usize),
}

/// Turns the DAG nodes an emitted function needs into `let` statements and assignments.
pub(super) struct FnEmitter<'a> {
    /// The expression arena.
    pub dag: &'a Dag,
    /// Field names of the parameters, by parameter index (`self.<name>`).
    pub params: &'a [Ident],
}

impl FnEmitter<'_> {
    /// Emits the body of a function computing `outputs` into their destinations.
    pub fn body(&self, outputs: &[(Id, Dest)]) -> (TokenStream, BTreeSet<&'static str>) {
        let dag = self.dag;
        let roots: Vec<Id> = outputs.iter().map(|(id, _)| *id).collect();
        let order = dag.reachable(&roots);
        let mut uses: BTreeMap<Id, usize> = BTreeMap::new();
        for &id in &order {
            for c in dag.node(id).children() {
                *uses.entry(c).or_default() += 1;
            }
        }
        for r in &roots {
            *uses.entry(*r).or_default() += 1;
        }
        // Decide which nodes get a `let`: shared nodes, trigonometric leaves, and nodes whose
        // inlined expression would grow too deep.
        let mut named: BTreeMap<Id, Ident> = BTreeMap::new();
        let mut depth: BTreeMap<Id, usize> = BTreeMap::new();
        let mut taken: BTreeSet<String> = BTreeSet::new();
        let mut inputs: BTreeSet<&'static str> = BTreeSet::new();
        let mut stmts = TokenStream::new();
        let mut tmp = 0usize;
        for &id in &order {
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
            let d = 1 + node
                .children()
                .map(|c| depth.get(&c).copied().unwrap_or(0))
                .max()
                .unwrap_or(0);
            let trig = trig_name(dag, id);
            let shared = uses.get(&id).copied().unwrap_or(0) > 1;
            if shared || trig.is_some() || d > 12 {
                let base = trig.unwrap_or_else(|| {
                    tmp += 1;
                    format!("x{tmp}")
                });
                let mut name = base.clone();
                let mut k = 1;
                while !taken.insert(name.clone()) {
                    k += 1;
                    name = format!("{base}_{k}");
                }
                let ident = Ident::new(&name, Span::call_site());
                let expr = self.expr(id, &named);
                stmts.extend(quote! { let #ident = #expr; });
                named.insert(id, ident);
                depth.insert(id, 0);
            } else {
                depth.insert(id, d);
            }
        }
        for (id, dest) in outputs {
            let e = self.expr(*id, &named);
            stmts.extend(match dest {
                Dest::Scalar(name) => quote! { #name = #e; },
                Dest::Vec(name, i) => {
                    let i = Literal::usize_unsuffixed(*i);
                    quote! { #name[#i] = #e; }
                }
                Dest::Mat(name, i, j) => {
                    let (i, j) = (Literal::usize_unsuffixed(*i), Literal::usize_unsuffixed(*j));
                    quote! { #name[#i][#j] = #e; }
                }
            });
        }
        (stmts, inputs)
    }

    /// The expression of a node: its name if it has one, else built from its children.
    fn expr(&self, id: Id, named: &BTreeMap<Id, Ident>) -> TokenStream {
        if let Some(n) = named.get(&id) {
            return quote! { #n };
        }
        let sub = |c: Id| self.expr(c, named);
        match self.dag.node(id) {
            Node::Const(bits) => float_literal(f64::from_bits(bits)),
            Node::Var(Var::Q(i)) => {
                let i = Literal::usize_unsuffixed(i as usize);
                quote! { q[#i] }
            }
            Node::Var(Var::Qd(i)) => {
                let i = Literal::usize_unsuffixed(i as usize);
                quote! { qd[#i] }
            }
            Node::Var(Var::Qdd(i)) => {
                let i = Literal::usize_unsuffixed(i as usize);
                quote! { qdd[#i] }
            }
            Node::Var(Var::Time) => quote! { t },
            Node::Var(Var::Param(k)) => {
                let p = &self.params[k as usize];
                quote! { self.#p }
            }
            Node::Neg(a) => {
                let a = sub(a);
                quote! { (-#a) }
            }
            Node::Add(a, b) => {
                let (a, b) = (sub(a), sub(b));
                quote! { (#a + #b) }
            }
            Node::Sub(a, b) => {
                let (a, b) = (sub(a), sub(b));
                quote! { (#a - #b) }
            }
            Node::Mul(a, b) => {
                let (a, b) = (sub(a), sub(b));
                quote! { (#a * #b) }
            }
            Node::Div(a, b) => {
                let (a, b) = (sub(a), sub(b));
                quote! { (#a / #b) }
            }
            Node::Pow(a, b) => {
                let (a, b) = (sub(a), sub(b));
                quote! { f64::powf(#a, #b) }
            }
            Node::Fun(f, a) => {
                let a = sub(a);
                let name = format_ident!("{}", f.name());
                quote! { f64::#name(#a) }
            }
        }
    }
}

/// A float literal that round-trips exactly (negative values parenthesised).
pub(super) fn float_literal(v: f64) -> TokenStream {
    if v.is_nan() {
        return quote! { f64::NAN };
    }
    if v.is_infinite() {
        return if v > 0.0 {
            quote! { f64::INFINITY }
        } else {
            quote! { f64::NEG_INFINITY }
        };
    }
    let lit = Literal::f64_unsuffixed(v.abs());
    if v < 0.0 {
        quote! { (-#lit) }
    } else {
        quote! { #lit }
    }
}

/// ROBOTRAN-style names for sines and cosines of coordinates: `s1 = sin q1`,
/// `c12 = cos(q1 + q2)` (1-based coordinate numbers, `_` between them past 9).
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
            Node::Var(Var::Q(i)) => coords.push(i as usize + 1),
            Node::Add(x, y) => {
                stack.push(y);
                stack.push(x);
            }
            _ => return None,
        }
    }
    coords.sort_unstable();
    let sep = if coords.iter().any(|&c| c > 9) {
        "_"
    } else {
        ""
    };
    let body: Vec<String> = coords.iter().map(usize::to_string).collect();
    Some(format!("{prefix}{}", body.join(sep)))
}
