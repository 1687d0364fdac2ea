//! The evaluation methods of the generated struct, one function per emitted method: `M^b`,
//! `F^b`, `Q^b` (eqs. 11–13), `h`, `J`, `A` (eqs. 14–16), `V`, all of them at once
//! (`evaluate`), and the kinematics of each named point (eqs. 49–50). Each records the
//! operation count of its outputs.

use std::collections::BTreeSet;

use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

use super::statements::{Dest, FnEmitter};
use crate::constraints::{ConstraintExprs, PointExprs};
use crate::dynamics::Symbolic;
use crate::expr::{Id, OpCount};

/// Emits the methods of one model and collects their operation counts.
pub(super) struct Methods<'a> {
    /// Statement emitter over the model's DAG.
    pub em: FnEmitter<'a>,
    /// Number of coordinates.
    pub n: usize,
    /// Number of constraint rows.
    pub nc: usize,
    /// Path of the runtime module.
    pub rt: &'a syn::Path,
    /// Operation count of each emitted function, in emission order.
    pub stats: Vec<(String, OpCount)>,
}

/// The input `name`, prefixed with `_` when the body does not read it.
fn arg(inputs: &BTreeSet<&str>, name: &str) -> Ident {
    if inputs.contains(name) {
        format_ident!("{}", name)
    } else {
        format_ident!("_{}", name)
    }
}

/// The output `name`, prefixed with `_` when there are no constraint rows to write.
fn constraint_out(nc: usize, name: &str) -> Ident {
    if nc == 0 {
        format_ident!("_{}", name)
    } else {
        format_ident!("{}", name)
    }
}

/// The upper triangle of `M^b` (row by row) into `dest[i][j]`.
fn mass_outputs(sym: &Symbolic, dest: &Ident) -> Vec<(Id, Dest)> {
    let n = sym.n;
    let mut outs = vec![];
    for i in 0..n {
        for j in i..n {
            outs.push((sym.mass[i * n + j], Dest::Mat(dest.clone(), i, j)));
        }
    }
    outs
}

/// `roots[i]` into `dest[i]`.
fn vec_outputs(roots: &[Id], dest: &Ident) -> Vec<(Id, Dest)> {
    roots
        .iter()
        .enumerate()
        .map(|(i, &r)| (r, Dest::Vec(dest.clone(), i)))
        .collect()
}

/// `rows[r][c]` into `dest[r][c]`.
fn matrix_outputs<R: AsRef<[Id]>>(rows: &[R], dest: &Ident) -> Vec<(Id, Dest)> {
    let mut outs = vec![];
    for (r, row) in rows.iter().enumerate() {
        for (c, &e) in row.as_ref().iter().enumerate() {
            outs.push((e, Dest::Mat(dest.clone(), r, c)));
        }
    }
    outs
}

/// `name[i][j] = name[j][i];` for the lower triangle (the mass matrix is symmetric).
fn mirror(n: usize, name: &Ident) -> TokenStream {
    let mut mirror = TokenStream::new();
    for i in 0..n {
        for j in 0..i {
            let (il, jl) = (Literal::usize_unsuffixed(i), Literal::usize_unsuffixed(j));
            mirror.extend(quote! { #name[#il][#jl] = #name[#jl][#il]; });
        }
    }
    mirror
}

impl Methods<'_> {
    /// Records the operation count of `outs` under `name` and emits their statements.
    fn body(&mut self, name: &str, outs: &[(Id, Dest)]) -> (TokenStream, BTreeSet<&'static str>) {
        let roots: Vec<Id> = outs.iter().map(|o| o.0).collect();
        self.stats
            .push((name.to_string(), self.em.dag.op_count(&roots)));
        self.em.body(outs)
    }

    fn nl(&self) -> Literal {
        Literal::usize_unsuffixed(self.n)
    }

    fn ncl(&self) -> Literal {
        Literal::usize_unsuffixed(self.nc)
    }

    /// `mass_matrix`: `M^b(q)` (eq. 11), the lower triangle copied from the upper one.
    pub fn mass_matrix(&mut self, sym: &Symbolic) -> TokenStream {
        let m_id = format_ident!("m");
        let (body, inputs) = self.body("mass_matrix", &mass_outputs(sym, &m_id));
        let mirror = mirror(self.n, &m_id);
        let (q, nl) = (arg(&inputs, "q"), self.nl());
        quote! {
            /// Mass matrix `M^b(q)` (eq. 11).
            pub fn mass_matrix(&self, #q: &[f64; #nl], m: &mut [[f64; #nl]; #nl]) { #body #mirror }
        }
    }

    /// `f_vector`: `F^b(q, q')` (eq. 12).
    pub fn f_vector(&mut self, sym: &Symbolic) -> TokenStream {
        let (body, inputs) = self.body("f_vector", &vec_outputs(&sym.f, &format_ident!("f")));
        let (q, qd, nl) = (arg(&inputs, "q"), arg(&inputs, "qd"), self.nl());
        quote! {
            /// Velocity and gravity terms `F^b(q, q')` (eq. 12).
            pub fn f_vector(&self, #q: &[f64; #nl], #qd: &[f64; #nl], f: &mut [f64; #nl]) { #body }
        }
    }

    /// `q_vector`: `Q^b(q, q', t)` (eq. 13).
    pub fn q_vector(&mut self, sym: &Symbolic) -> TokenStream {
        let (body, inputs) = self.body("q_vector", &vec_outputs(&sym.q, &format_ident!("out")));
        let (q, qd, t) = (arg(&inputs, "q"), arg(&inputs, "qd"), arg(&inputs, "t"));
        let nl = self.nl();
        quote! {
            /// Force-element terms `Q^b(q, q', t)`, paper sign (eq. 13).
            pub fn q_vector(&self, #q: &[f64; #nl], #qd: &[f64; #nl], #t: f64, out: &mut [f64; #nl]) { #body }
        }
    }

    /// `constraints`: `h(q)` (eq. 14).
    pub fn constraints(&mut self, cons: &ConstraintExprs) -> TokenStream {
        let (body, inputs) = self.body("constraints", &vec_outputs(&cons.h, &format_ident!("h")));
        let (q, h) = (arg(&inputs, "q"), constraint_out(self.nc, "h"));
        let (nl, ncl) = (self.nl(), self.ncl());
        quote! {
            /// Constraints `h(q)` (eq. 14).
            pub fn constraints(&self, #q: &[f64; #nl], #h: &mut [f64; #ncl]) { #body }
        }
    }

    /// `constraint_jacobian`: `J(q)` (eq. 15).
    pub fn constraint_jacobian(&mut self, cons: &ConstraintExprs) -> TokenStream {
        let outs = matrix_outputs(&cons.j, &format_ident!("j"));
        let (body, inputs) = self.body("constraint_jacobian", &outs);
        let (q, j) = (arg(&inputs, "q"), constraint_out(self.nc, "j"));
        let (nl, ncl) = (self.nl(), self.ncl());
        quote! {
            /// Constraint Jacobian `J(q) = dh/dq` (eq. 15).
            pub fn constraint_jacobian(&self, #q: &[f64; #nl], #j: &mut [[f64; #nl]; #ncl]) { #body }
        }
    }

    /// `constraint_bias`: `A(q, q')` (eq. 16).
    pub fn constraint_bias(&mut self, cons: &ConstraintExprs) -> TokenStream {
        let outs = vec_outputs(&cons.a, &format_ident!("a"));
        let (body, inputs) = self.body("constraint_bias", &outs);
        let (q, qd) = (arg(&inputs, "q"), arg(&inputs, "qd"));
        let a = constraint_out(self.nc, "a");
        let (nl, ncl) = (self.nl(), self.ncl());
        quote! {
            /// Constraint bias `A(q, q') = J' q'` (eq. 16).
            pub fn constraint_bias(&self, #q: &[f64; #nl], #qd: &[f64; #nl], #a: &mut [f64; #ncl]) { #body }
        }
    }

    /// `potential_energy`: `V(q)`.
    pub fn potential_energy(&mut self, sym: &Symbolic) -> TokenStream {
        let outs = [(sym.potential, Dest::Scalar(format_ident!("v")))];
        let (body, inputs) = self.body("potential_energy", &outs);
        let (q, nl) = (arg(&inputs, "q"), self.nl());
        quote! {
            /// Potential energy `V(q)`: gravity and the springs of the force elements.
            pub fn potential_energy(&self, #q: &[f64; #nl]) -> f64 {
                let v: f64;
                #body
                v
            }
        }
    }

    /// `evaluate`: everything of eqs. 11–16 in one body, every intermediate computed once.
    pub fn evaluate(&mut self, sym: &Symbolic, cons: &ConstraintExprs) -> TokenStream {
        let mass_id = format_ident!("mass");
        let mut outs = mass_outputs(sym, &mass_id);
        outs.extend(vec_outputs(&sym.f, &format_ident!("f")));
        outs.extend(vec_outputs(&sym.q, &format_ident!("qf")));
        outs.extend(vec_outputs(&cons.h, &format_ident!("h")));
        outs.extend(matrix_outputs(&cons.j, &format_ident!("j")));
        outs.extend(vec_outputs(&cons.a, &format_ident!("a")));
        let (body, inputs) = self.body("evaluate", &outs);
        let (q, qd, t) = (arg(&inputs, "q"), arg(&inputs, "qd"), arg(&inputs, "t"));
        let mirror = mirror(self.n, &mass_id);
        let (nl, ncl, rt) = (self.nl(), self.ncl(), self.rt);
        quote! {
            /// `M^b`, `F^b`, `Q^b`, `h`, `J` and `A` at once (eqs. 11–16): one body in which every
            /// intermediate is computed once; bit-identical to the separate methods.
            #[allow(unused_variables)]
            pub fn evaluate(&self, #q: &[f64; #nl], #qd: &[f64; #nl], #t: f64, out: &mut #rt::Evaluation<#nl, #ncl>) {
                let #rt::Evaluation { mass, f, q: qf, h, j, a } = out;
                #body
                #mirror
            }
        }
    }

    /// `point_<name>`: position, Jacobian and bias of one named point (eqs. 49–50).
    pub fn point(&mut self, pt: &PointExprs, fname: &Ident) -> TokenStream {
        let mut outs = vec_outputs(&pt.p, &format_ident!("p"));
        outs.extend(matrix_outputs(&pt.j, &format_ident!("j")));
        outs.extend(vec_outputs(&pt.a, &format_ident!("a")));
        let (body, inputs) = self.body(&format!("point_{}", pt.name), &outs);
        let (q, qd) = (arg(&inputs, "q"), arg(&inputs, "qd"));
        let doc = format!(
            " Position, Jacobian and bias of point `{}` (eqs. 49–50).",
            pt.name
        );
        let (nl, rt) = (self.nl(), self.rt);
        quote! {
            #[doc = #doc]
            pub fn #fname(&self, #q: &[f64; #nl], #qd: &[f64; #nl], out: &mut #rt::PointKinematics<#nl>) {
                let #rt::PointKinematics { p, j, a } = out;
                #body
            }
        }
    }
}
