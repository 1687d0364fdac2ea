//! Rust source emission (Fisette–Samin / ROBOTRAN style) and the `build.rs` entry point.
//!
//! The symbolic equations ([`crate::dynamics::Symbolic`], [`crate::constraints`]) become one
//! Rust module: a struct holding the model's run-time parameters and methods that evaluate
//! `M^b`, `F^b`, `Q^b` (eqs. 11–13), `h`, `J`, `A` (eqs. 14–16) and point kinematics
//! (eqs. 49–50) into caller-owned fixed-size arrays. Each method computes only the nodes its
//! outputs need, as scalar intermediate variables (`s1 = q[0].sin()`, `x12 = ...`); a node
//! used once is inlined into its user, zero terms were never built. Only `core` float
//! arithmetic is used: no allocation, no panics (all indices are constants into fixed-size
//! arrays), no `unsafe`.
//!
//! Tokens are built with `quote`, parsed as a `syn::File` (a failure reports the tokens) and
//! formatted with `prettyplease`; the same model always produces byte-identical source.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::{format_ident, quote};

use crate::constraints::{self, ConstraintExprs, PointExprs};
use crate::dynamics::Symbolic;
use crate::expr::{Dag, Id, Node, OpCount, Var};
use crate::model::Model;

/// Version of the generator, written into every `@generated` header.
pub const GENERATOR_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Errors of code generation.
#[derive(Debug, thiserror::Error)]
pub enum EmitError {
    /// The model file could not be read or is invalid.
    #[error("{0}")]
    Model(#[from] crate::model::ModelErrors),
    /// Two parameters or points sanitise to the same Rust identifier.
    #[error("{file}: {what} {a:?} and {b:?} both become the Rust identifier `{ident}`")]
    IdentClash {
        /// Model file.
        file: String,
        /// "parameters" or "points".
        what: &'static str,
        /// First name.
        a: String,
        /// Second name.
        b: String,
        /// The identifier.
        ident: String,
    },
    /// The requested struct name (`EmitOptions::struct_name`) is not a Rust identifier.
    #[error(
        "struct name {name:?} is not a Rust identifier (ASCII letters, digits and `_`, not starting with a digit, not a keyword)"
    )]
    StructName {
        /// The rejected name.
        name: String,
    },
    /// The emitted tokens did not parse as Rust (a generator bug); carries the tokens.
    #[error("internal error: generated tokens do not parse as Rust ({message}); tokens: {tokens}")]
    Parse {
        /// The parser's message.
        message: String,
        /// The offending tokens.
        tokens: String,
    },
    /// Writing the output failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
}

/// Options of the emitter.
#[derive(Clone, Debug)]
pub struct EmitOptions {
    /// Name of the generated struct (default: the model name in UpperCamelCase).
    pub struct_name: Option<String>,
    /// Path of the runtime module in the crate that includes the code.
    pub runtime_path: String,
}

impl Default for EmitOptions {
    fn default() -> Self {
        EmitOptions {
            struct_name: None,
            runtime_path: "::mbs_symbolic::runtime".into(),
        }
    }
}

/// Generated source and statistics.
#[derive(Clone, Debug)]
pub struct Generated {
    /// The formatted Rust source.
    pub source: String,
    /// Name of the generated struct.
    pub struct_name: String,
    /// Operation count of each generated function, in emission order.
    pub stats: Vec<(String, OpCount)>,
}

/// Turns a model name into a Rust identifier: ASCII letters, digits and `_`, not starting
/// with a digit, not a keyword.
pub fn sanitize_ident(name: &str) -> String {
    let mut s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.starts_with(|c: char| c.is_ascii_digit()) {
        s.insert(0, '_');
    }
    if syn::parse_str::<Ident>(&s).is_err() || s == "_" || s == "self" || s == "Self" {
        s.push('_');
    }
    s
}

fn camel_case(name: &str) -> String {
    let mut out = String::new();
    for part in name
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|p| !p.is_empty())
    {
        let mut cs = part.chars();
        if let Some(f) = cs.next() {
            out.push(f.to_ascii_uppercase());
            out.extend(cs);
        }
    }
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, 'M');
    }
    sanitize_ident(&out)
}

/// Where a function's output value goes.
enum Dest {
    /// `name`
    Scalar(Ident),
    /// `name[i]`
    Vec(Ident, usize),
    /// `name[i][j]`
    Mat(Ident, usize, usize),
}

struct FnEmitter<'a> {
    dag: &'a Dag,
    params: &'a [Ident],
}

impl FnEmitter<'_> {
    /// Emits the body of a function computing `outputs` into their destinations.
    fn body(&self, outputs: &[(Id, Dest)]) -> (TokenStream, BTreeSet<&'static str>) {
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
fn float_literal(v: f64) -> TokenStream {
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
        crate::expr::Fun::Sin => "s",
        crate::expr::Fun::Cos => "c",
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

/// Generates the Rust module for a model.
pub fn generate(model: &Model, opts: &EmitOptions) -> Result<Generated, EmitError> {
    let n = model.dof();
    let mut sym = Symbolic::derive(model);
    let pts: Vec<PointExprs> = constraints::points(model, &mut sym);
    let cons: ConstraintExprs = constraints::constraints(model, &mut sym);
    let nc = cons.h.len();

    // Run-time parameters become struct fields.
    let mut param_idents: Vec<Ident> = Vec::with_capacity(model.parameters.len());
    let mut seen: BTreeMap<String, String> = BTreeMap::new();
    for p in &model.parameters {
        let id = sanitize_ident(&p.name);
        if p.runtime {
            if let Some(prev) = seen.insert(id.clone(), p.name.clone()) {
                return Err(EmitError::IdentClash {
                    file: model.source.path.clone(),
                    what: "parameters",
                    a: prev,
                    b: p.name.clone(),
                    ident: id,
                });
            }
        }
        param_idents.push(Ident::new(&id, Span::call_site()));
    }
    let mut point_fns: Vec<Ident> = Vec::new();
    let mut seen_pts: BTreeMap<String, String> = BTreeMap::new();
    for p in &model.points {
        let id = sanitize_ident(&format!("point_{}", p.name.to_lowercase()));
        if let Some(prev) = seen_pts.insert(id.clone(), p.name.clone()) {
            return Err(EmitError::IdentClash {
                file: model.source.path.clone(),
                what: "points",
                a: prev,
                b: p.name.clone(),
                ident: id,
            });
        }
        point_fns.push(Ident::new(&id, Span::call_site()));
    }

    let em = FnEmitter {
        dag: &sym.dag,
        params: &param_idents,
    };
    let struct_name = match &opts.struct_name {
        // `Ident::new` panics on a string that is no identifier (or a raw `r#` one) and
        // accepts keywords, which would only fail later as an internal parse error: check
        // with syn's parser and allow plain ASCII identifiers only.
        Some(name) => match syn::parse_str::<Ident>(name) {
            Ok(_) if name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') => name.clone(),
            _ => return Err(EmitError::StructName { name: name.clone() }),
        },
        None => camel_case(&model.name),
    };
    let sname = Ident::new(&struct_name, Span::call_site());
    let rt: syn::Path = syn::parse_str(&opts.runtime_path).map_err(|e| EmitError::Parse {
        message: e.to_string(),
        tokens: opts.runtime_path.clone(),
    })?;
    let nl = Literal::usize_unsuffixed(n);
    let ncl = Literal::usize_unsuffixed(nc);
    let mut stats = Vec::new();
    let m_id = format_ident!("m");
    let f_id = format_ident!("f");
    let out_id = format_ident!("out");
    let h_id = format_ident!("h");
    let j_id = format_ident!("j");
    let a_id = format_ident!("a");

    // Prefixes an input with `_` when the body does not read it.
    let arg = |inputs: &BTreeSet<&str>, name: &str| -> Ident {
        if inputs.contains(name) {
            format_ident!("{}", name)
        } else {
            format_ident!("_{}", name)
        }
    };
    let mut methods = TokenStream::new();
    let mut record =
        |name: &str, roots: &[Id], dag: &Dag| stats.push((name.to_string(), dag.op_count(roots)));

    // M (symmetric: the lower triangle copies the upper one).
    let mut outs = vec![];
    for i in 0..n {
        for j in i..n {
            outs.push((sym.mass[i * n + j], Dest::Mat(m_id.clone(), i, j)));
        }
    }
    record(
        "mass_matrix",
        &outs.iter().map(|o| o.0).collect::<Vec<_>>(),
        &sym.dag,
    );
    let (body, inputs) = em.body(&outs);
    let mut mirror = TokenStream::new();
    for i in 0..n {
        for j in 0..i {
            let (il, jl) = (Literal::usize_unsuffixed(i), Literal::usize_unsuffixed(j));
            mirror.extend(quote! { m[#il][#jl] = m[#jl][#il]; });
        }
    }
    let q = arg(&inputs, "q");
    methods.extend(quote! {
        /// Mass matrix `M^b(q)` (eq. 11).
        pub fn mass_matrix(&self, #q: &[f64; #nl], m: &mut [[f64; #nl]; #nl]) { #body #mirror }
    });

    let vec_fn = |roots: &[Id], dest: &Ident| -> Vec<(Id, Dest)> {
        roots
            .iter()
            .enumerate()
            .map(|(i, &r)| (r, Dest::Vec(dest.clone(), i)))
            .collect()
    };
    // F
    record("f_vector", &sym.f, &sym.dag);
    let (body, inputs) = em.body(&vec_fn(&sym.f, &f_id));
    let (q, qd) = (arg(&inputs, "q"), arg(&inputs, "qd"));
    methods.extend(quote! {
        /// Velocity and gravity terms `F^b(q, q')` (eq. 12).
        pub fn f_vector(&self, #q: &[f64; #nl], #qd: &[f64; #nl], f: &mut [f64; #nl]) { #body }
    });
    // Q
    record("q_vector", &sym.q, &sym.dag);
    let (body, inputs) = em.body(&vec_fn(&sym.q, &out_id));
    let (q, qd, t) = (arg(&inputs, "q"), arg(&inputs, "qd"), arg(&inputs, "t"));
    methods.extend(quote! {
        /// Force-element terms `Q^b(q, q', t)`, paper sign (eq. 13).
        pub fn q_vector(&self, #q: &[f64; #nl], #qd: &[f64; #nl], #t: f64, out: &mut [f64; #nl]) { #body }
    });
    // h, J, A
    record("constraints", &cons.h, &sym.dag);
    let (body, inputs) = em.body(&vec_fn(&cons.h, &h_id));
    let (q, h) = (
        arg(&inputs, "q"),
        if nc == 0 {
            format_ident!("_h")
        } else {
            h_id.clone()
        },
    );
    methods.extend(quote! {
        /// Constraints `h(q)` (eq. 14).
        pub fn constraints(&self, #q: &[f64; #nl], #h: &mut [f64; #ncl]) { #body }
    });
    let mut outs = vec![];
    for (r, row) in cons.j.iter().enumerate() {
        for (c, &e) in row.iter().enumerate() {
            outs.push((e, Dest::Mat(j_id.clone(), r, c)));
        }
    }
    record(
        "constraint_jacobian",
        &outs.iter().map(|o| o.0).collect::<Vec<_>>(),
        &sym.dag,
    );
    let (body, inputs) = em.body(&outs);
    let (q, j) = (
        arg(&inputs, "q"),
        if nc == 0 {
            format_ident!("_j")
        } else {
            j_id.clone()
        },
    );
    methods.extend(quote! {
        /// Constraint Jacobian `J(q) = dh/dq` (eq. 15).
        pub fn constraint_jacobian(&self, #q: &[f64; #nl], #j: &mut [[f64; #nl]; #ncl]) { #body }
    });
    record("constraint_bias", &cons.a, &sym.dag);
    let (body, inputs) = em.body(&vec_fn(&cons.a, &a_id));
    let (q, qd, a) = (
        arg(&inputs, "q"),
        arg(&inputs, "qd"),
        if nc == 0 {
            format_ident!("_a")
        } else {
            a_id.clone()
        },
    );
    methods.extend(quote! {
        /// Constraint bias `A(q, q') = J' q'` (eq. 16).
        pub fn constraint_bias(&self, #q: &[f64; #nl], #qd: &[f64; #nl], #a: &mut [f64; #ncl]) { #body }
    });
    // V(q)
    record("potential_energy", &[sym.potential], &sym.dag);
    let v_id = format_ident!("v");
    let (body, inputs) = em.body(&[(sym.potential, Dest::Scalar(v_id.clone()))]);
    let q = arg(&inputs, "q");
    methods.extend(quote! {
        /// Potential energy `V(q)`: gravity and the springs of the force elements.
        pub fn potential_energy(&self, #q: &[f64; #nl]) -> f64 {
            let v: f64;
            #body
            v
        }
    });
    // Everything at once (Mechanism::evaluate): one body, every intermediate computed once.
    let (mass_id, qf_id) = (format_ident!("mass"), format_ident!("qf"));
    let mut outs: Vec<(Id, Dest)> = vec![];
    for i in 0..n {
        for j in i..n {
            outs.push((sym.mass[i * n + j], Dest::Mat(mass_id.clone(), i, j)));
        }
    }
    outs.extend(vec_fn(&sym.f, &f_id));
    outs.extend(vec_fn(&sym.q, &qf_id));
    outs.extend(vec_fn(&cons.h, &h_id));
    for (r, row) in cons.j.iter().enumerate() {
        for (c, &e) in row.iter().enumerate() {
            outs.push((e, Dest::Mat(j_id.clone(), r, c)));
        }
    }
    outs.extend(vec_fn(&cons.a, &a_id));
    record(
        "evaluate",
        &outs.iter().map(|o| o.0).collect::<Vec<_>>(),
        &sym.dag,
    );
    let (body, inputs) = em.body(&outs);
    let (q, qd, t) = (arg(&inputs, "q"), arg(&inputs, "qd"), arg(&inputs, "t"));
    let mut mirror = TokenStream::new();
    for i in 0..n {
        for j in 0..i {
            let (il, jl) = (Literal::usize_unsuffixed(i), Literal::usize_unsuffixed(j));
            mirror.extend(quote! { mass[#il][#jl] = mass[#jl][#il]; });
        }
    }
    methods.extend(quote! {
        /// `M^b`, `F^b`, `Q^b`, `h`, `J` and `A` at once (eqs. 11–16): one body in which every
        /// intermediate is computed once; bit-identical to the separate methods.
        #[allow(unused_variables)]
        pub fn evaluate(&self, #q: &[f64; #nl], #qd: &[f64; #nl], #t: f64, out: &mut #rt::Evaluation<#nl, #ncl>) {
            let #rt::Evaluation { mass, f, q: qf, h, j, a } = out;
            #body
            #mirror
        }
    });
    // Points
    let mut point_arms = TokenStream::new();
    for (k, (pt, fname)) in pts.iter().zip(&point_fns).enumerate() {
        let p_id = format_ident!("p");
        let mut outs: Vec<(Id, Dest)> = vec![];
        for c in 0..3 {
            outs.push((pt.p[c], Dest::Vec(p_id.clone(), c)));
        }
        for c in 0..3 {
            for (col, &e) in pt.j[c].iter().enumerate() {
                outs.push((e, Dest::Mat(j_id.clone(), c, col)));
            }
        }
        for c in 0..3 {
            outs.push((pt.a[c], Dest::Vec(a_id.clone(), c)));
        }
        record(
            &format!("point_{}", pt.name),
            &outs.iter().map(|o| o.0).collect::<Vec<_>>(),
            &sym.dag,
        );
        let (body, inputs) = em.body(&outs);
        let (q, qd) = (arg(&inputs, "q"), arg(&inputs, "qd"));
        let doc = format!(
            " Position, Jacobian and bias of point `{}` (eqs. 49–50).",
            pt.name
        );
        methods.extend(quote! {
            #[doc = #doc]
            pub fn #fname(&self, #q: &[f64; #nl], #qd: &[f64; #nl], out: &mut #rt::PointKinematics<#nl>) {
                let #rt::PointKinematics { p, j, a } = out;
                #body
            }
        });
        let kl = Literal::usize_unsuffixed(k);
        point_arms.extend(quote! { #kl => self.#fname(q, qd, out), });
    }

    // Struct, defaults, names.
    let mut fields = TokenStream::new();
    let mut defaults = TokenStream::new();
    let mut setters = TokenStream::new();
    let mut runtime_names = vec![];
    for (p, id) in model.parameters.iter().zip(&param_idents) {
        if !p.runtime {
            continue;
        }
        let doc = format!(" Parameter `{}` (default {}).", p.name, p.value);
        let v = float_literal(p.value);
        fields.extend(quote! { #[doc = #doc] pub #id: f64, });
        defaults.extend(quote! { #id: #v, });
        let name = &p.name;
        setters.extend(quote! { #name => self.#id = value, });
        runtime_names.push(p.name.clone());
    }
    let npar = Literal::usize_unsuffixed(runtime_names.len());
    // Without run-time parameters `set_param` never reads the value.
    let value_arg = if runtime_names.is_empty() {
        format_ident!("_value")
    } else {
        format_ident!("value")
    };
    let npts = Literal::usize_unsuffixed(model.points.len());
    let point_names: Vec<&str> = model.points.iter().map(|p| p.name.as_str()).collect();
    let coord_names: Vec<&str> = model.bodies.iter().map(|b| b.coordinate.as_str()).collect();
    let cons_names: Vec<&str> = cons.names.iter().map(String::as_str).collect();
    let struct_doc = format!(
        " Generated equations of the `{}` mechanism: {} coordinates, {} constraint rows. Fields are the run-time parameters.",
        model.name, n, nc
    );
    let tokens = quote! {
        #[doc = #struct_doc]
        #[derive(Clone, Copy, Debug, PartialEq)]
        #[allow(non_snake_case)]
        pub struct #sname { #fields }

        // Fully qualified: a model named `default` gives a struct `Default`, which would
        // shadow the prelude trait. (Derivable when there are no run-time parameters.)
        #[allow(clippy::all)]
        impl ::core::default::Default for #sname {
            fn default() -> Self { Self { #defaults } }
        }

        #[allow(non_snake_case, unused_parens, clippy::all)]
        impl #sname {
            /// Number of joint coordinates.
            pub const DOF: usize = #nl;
            /// Number of constraint rows.
            pub const CONSTRAINTS: usize = #ncl;
            /// Names of the run-time parameters.
            pub const PARAM_NAMES: [&'static str; #npar] = [#(#runtime_names),*];
            /// Names of the named points.
            pub const POINT_NAMES: [&'static str; #npts] = [#(#point_names),*];
            /// Names of the joint coordinates.
            pub const COORDINATE_NAMES: [&'static str; #nl] = [#(#coord_names),*];
            /// Names of the constraint rows.
            pub const CONSTRAINT_NAMES: [&'static str; #ncl] = [#(#cons_names),*];
            #methods
        }

        #[allow(clippy::all)]
        impl #rt::Mechanism<#nl, #ncl> for #sname {
            fn param_names(&self) -> &[&'static str] { &Self::PARAM_NAMES }
            fn set_param(&mut self, name: &str, #value_arg: f64) -> bool {
                match name { #setters _ => return false, }
                #[allow(unreachable_code)]
                true
            }
            fn point_names(&self) -> &[&'static str] { &Self::POINT_NAMES }
            fn mass_matrix(&self, q: &[f64; #nl], m: &mut [[f64; #nl]; #nl]) { #sname::mass_matrix(self, q, m) }
            fn f_vector(&self, q: &[f64; #nl], qd: &[f64; #nl], f: &mut [f64; #nl]) { #sname::f_vector(self, q, qd, f) }
            fn q_vector(&self, q: &[f64; #nl], qd: &[f64; #nl], t: f64, out: &mut [f64; #nl]) { #sname::q_vector(self, q, qd, t, out) }
            fn constraints(&self, q: &[f64; #nl], h: &mut [f64; #ncl]) { #sname::constraints(self, q, h) }
            fn constraint_jacobian(&self, q: &[f64; #nl], j: &mut [[f64; #nl]; #ncl]) { #sname::constraint_jacobian(self, q, j) }
            fn constraint_bias(&self, q: &[f64; #nl], qd: &[f64; #nl], a: &mut [f64; #ncl]) { #sname::constraint_bias(self, q, qd, a) }
            fn evaluate(&self, q: &[f64; #nl], qd: &[f64; #nl], t: f64, out: &mut #rt::Evaluation<#nl, #ncl>) { #sname::evaluate(self, q, qd, t, out) }
            fn potential_energy(&self, q: &[f64; #nl]) -> f64 { #sname::potential_energy(self, q) }
            fn point_kinematics(&self, k: usize, q: &[f64; #nl], qd: &[f64; #nl], out: &mut #rt::PointKinematics<#nl>) -> bool {
                match k { #point_arms _ => return false, }
                #[allow(unreachable_code)]
                true
            }
        }
    };
    let file: syn::File = syn::parse2(tokens.clone()).map_err(|e| EmitError::Parse {
        message: e.to_string(),
        tokens: tokens.to_string(),
    })?;
    let mut source = String::new();
    // Only the file name: the header must not depend on where the checkout lives.
    let file_name = Path::new(&model.source.path).file_name().map_or_else(
        || model.source.path.clone(),
        |f| f.to_string_lossy().into_owned(),
    );
    let _ = writeln!(
        source,
        "// @generated by mbs-symbolic {GENERATOR_VERSION} from `{file_name}` (content FNV-1a 64: {}).",
        model.source.hash
    );
    let _ = writeln!(
        source,
        "// Do not edit: edit the model file and regenerate."
    );
    let _ = writeln!(source, "//");
    let _ = writeln!(source, "// Operation counts per function:");
    for (name, c) in &stats {
        let _ = writeln!(source, "//   {name}: {c}");
    }
    source.push('\n');
    source.push_str(&prettyplease::unparse(&file));
    Ok(Generated {
        source,
        struct_name,
        stats,
    })
}

/// Writes `contents` to `path` only if the file does not already hold exactly these bytes
/// (so unchanged output does not trigger rebuilds). The write goes through a temporary file
/// and a rename, so a reader never sees a half-written file. Returns whether it wrote.
pub fn write_if_changed(path: &Path, contents: &str) -> Result<bool, EmitError> {
    if std::fs::read(path).ok().as_deref() == Some(contents.as_bytes()) {
        return Ok(false);
    }
    let io = |e| EmitError::Io {
        path: path.display().to_string(),
        source: e,
    };
    let tmp = path.with_extension("rs.tmp");
    let written = std::fs::write(&tmp, contents).and_then(|()| std::fs::rename(&tmp, path));
    if let Err(e) = written {
        // Leave nothing behind: neither a partial output nor the temporary file.
        let _ = std::fs::remove_file(&tmp);
        return Err(io(e));
    }
    Ok(true)
}

/// `build.rs` entry point (prost-build style): reads the model at `model_path`, generates its
/// module into `out_dir/<file_name>` if the content changed, and prints
/// `cargo:rerun-if-changed` for the model. Returns the path of the generated file, to be
/// included with `include!(concat!(env!("OUT_DIR"), "/<file_name>"))`.
pub fn compile_model(
    model_path: &Path,
    out_dir: &Path,
    file_name: &str,
    opts: &EmitOptions,
) -> Result<PathBuf, EmitError> {
    println!("cargo:rerun-if-changed={}", model_path.display());
    let model = crate::model::load(model_path)?;
    let generated = generate(&model, opts)?;
    let out = out_dir.join(file_name);
    write_if_changed(&out, &generated.source)?;
    Ok(out)
}
