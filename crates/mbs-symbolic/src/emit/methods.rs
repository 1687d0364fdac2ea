//! The evaluation methods of the generated struct, one function per emitted method: `M^b`,
//! `F^b`, `Q^b` (eqs. 11–13), `h`, `J`, `A` (eqs. 14–16), `V`, the elements' power `[D, P]`,
//! all of them at once
//! (`evaluate`), the kinematics of each named point (eqs. 49–50) and its position and
//! Jacobian alone (eq. 49, `position_<name>`), everything including the
//! points at once (`evaluate_with_points`), and the cache of parameter-only subexpressions
//! (`hoisted_values`). Each records the operation count of its outputs per call (hoisted
//! subexpressions excluded).
//!
//! The methods are token skeletons whose bodies are a marker statement `__mbs_body!(k);`;
//! the bodies themselves are text (`statements.rs`), spliced in after the small skeleton is
//! formatted (see `mod.rs`).

use std::collections::BTreeSet;
use std::fmt::Write as _;

use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

use super::statements::{Dest, FnEmitter};
use crate::constraints::{ConstraintExprs, PointExprs};
use crate::dynamics::Symbolic;
use crate::expr::{Dag, Id, OpCount};

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
    /// The body of each marker, by marker index, to be written by [`write_bodies`].
    pub jobs: Vec<Job<'a>>,
}

/// One function body to write: its statements, then `tail` (lines already written).
pub(super) struct Job<'a> {
    em: FnEmitter<'a>,
    outs: Vec<(Id, Dest)>,
    /// The nodes the outputs need, in evaluation order.
    order: Vec<Id>,
    tail: String,
}

/// Writes the bodies of `jobs` (by index) on the available cores: the bodies are
/// independent, and each is written by one thread, so the text does not depend on the
/// scheduling.
pub(super) fn write_bodies(jobs: &[Job<'_>]) -> Vec<String> {
    let write = |job: &Job<'_>| {
        let mut text = job.em.body(&job.outs, &job.order);
        text.push_str(&job.tail);
        text
    };
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(jobs.len());
    if threads <= 1 {
        return jobs.iter().map(write).collect();
    }
    // Largest bodies first, so that the threads finish together.
    let mut by_size: Vec<usize> = (0..jobs.len()).collect();
    by_size.sort_by_key(|&k| std::cmp::Reverse(jobs[k].order.len()));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut bodies: Vec<String> = vec![String::new(); jobs.len()];
    let done: Vec<Vec<(usize, String)>> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                s.spawn(|| {
                    let mut mine = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(&k) = by_size.get(i) else { break };
                        mine.push((k, write(&jobs[k])));
                    }
                    mine
                })
            })
            .collect();
        workers
            .into_iter()
            .map(|w| w.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect()
    });
    for (k, text) in done.into_iter().flatten() {
        bodies[k] = text;
    }
    bodies
}

/// The marker statement standing for body `k` in the token skeleton.
pub(super) const MARKER: &str = "__mbs_body!(";

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
fn mass_outputs(sym: &Symbolic, dest: &str) -> Vec<(Id, Dest)> {
    let n = sym.n;
    let mut outs = vec![];
    for i in 0..n {
        for j in i..n {
            outs.push((sym.mass[i * n + j], Dest::Mat(dest.into(), i, j)));
        }
    }
    outs
}

/// `roots[i]` into `dest[i]`.
fn vec_outputs(roots: &[Id], dest: &str) -> Vec<(Id, Dest)> {
    roots
        .iter()
        .enumerate()
        .map(|(i, &r)| (r, Dest::Vec(dest.into(), i)))
        .collect()
}

/// `rows[r][c]` into `dest[r][c]`.
fn matrix_outputs<R: AsRef<[Id]>>(rows: &[R], dest: &str) -> Vec<(Id, Dest)> {
    let mut outs = vec![];
    for (r, row) in rows.iter().enumerate() {
        for (c, &e) in row.as_ref().iter().enumerate() {
            outs.push((e, Dest::Mat(dest.into(), r, c)));
        }
    }
    outs
}

/// The outputs of the fused `evaluate`: `M^b` (upper triangle), `F^b`, `Q^b`, `h`, `J`, `A`.
fn evaluate_outputs(sym: &Symbolic, cons: &ConstraintExprs) -> Vec<(Id, Dest)> {
    let mut outs = mass_outputs(sym, "mass");
    outs.extend(vec_outputs(&sym.f, "f"));
    outs.extend(vec_outputs(&sym.q, "qf"));
    outs.extend(vec_outputs(&cons.h, "h"));
    outs.extend(matrix_outputs(&cons.j, "j"));
    outs.extend(vec_outputs(&cons.a, "a"));
    outs
}

/// The outputs of one point's kinematics into `{prefix}p`, `{prefix}j`, `{prefix}a`.
fn point_outputs(pt: &PointExprs, prefix: &str) -> Vec<(Id, Dest)> {
    let mut outs = vec_outputs(&pt.p, &format!("{prefix}p"));
    outs.extend(matrix_outputs(&pt.j, &format!("{prefix}j")));
    outs.extend(vec_outputs(&pt.a, &format!("{prefix}a")));
    outs
}

/// `a - b` field by field: the operations of `a` not in the hoisted part `b`.
fn minus(a: OpCount, b: OpCount) -> OpCount {
    OpCount {
        adds: a.adds.saturating_sub(b.adds),
        muls: a.muls.saturating_sub(b.muls),
        divs: a.divs.saturating_sub(b.divs),
        funcs: a.funcs.saturating_sub(b.funcs),
        negs: a.negs.saturating_sub(b.negs),
    }
}

/// Operations per call of `roots` when the `hoisted` nodes are read from the cache: all the
/// operations of `roots` minus those of the hoisted subexpressions (which only
/// parameter-only nodes feed, so no operation is in both parts).
pub(super) fn per_call_count(dag: &Dag, roots: &[Id], hoisted: &[Id]) -> OpCount {
    let all = dag.op_count(roots);
    if hoisted.is_empty() {
        return all;
    }
    minus(all, dag.op_count(hoisted))
}

/// `name[i][j] = name[j][i];` for the lower triangle (the mass matrix is symmetric).
fn mirror(n: usize, name: &str) -> String {
    let mut mirror = String::new();
    let pad = " ".repeat(super::statements::BODY_INDENT);
    for i in 0..n {
        for j in 0..i {
            let _ = writeln!(mirror, "{pad}{name}[{i}][{j}] = {name}[{j}][{i}];");
        }
    }
    mirror
}

impl<'a> Methods<'a> {
    /// Records the operation count of `outs` under `name`, emits their statements and
    /// returns the marker statement standing for them (nothing for an empty body) and the
    /// inputs they read.
    fn body(&mut self, name: &str, outs: &[(Id, Dest)]) -> (TokenStream, BTreeSet<&'static str>) {
        self.body_with(self.em, name, outs, String::new())
    }

    /// [`Methods::body`] with another statement emitter.
    ///
    /// The statements themselves are written later, all bodies at once
    /// ([`write_bodies`]); the skeleton only needs the marker and the inputs.
    fn body_with(
        &mut self,
        em: FnEmitter<'a>,
        name: &str,
        outs: &[(Id, Dest)],
        tail: String,
    ) -> (TokenStream, BTreeSet<&'static str>) {
        let roots: Vec<Id> = outs.iter().map(|o| o.0).collect();
        let order = em.reachable(&roots);
        let hoisted = em.hoisted_in(&order);
        self.stats
            .push((name.to_string(), per_call_count(em.dag, &roots, &hoisted)));
        let inputs = em.inputs(&order);
        if outs.is_empty() && tail.is_empty() {
            return (TokenStream::new(), inputs);
        }
        let k = Literal::usize_unsuffixed(self.jobs.len());
        self.jobs.push(Job {
            em,
            outs: outs.to_vec(),
            order,
            tail,
        });
        (quote! { __mbs_body!(#k); }, inputs)
    }

    fn nl(&self) -> Literal {
        Literal::usize_unsuffixed(self.n)
    }

    fn ncl(&self) -> Literal {
        Literal::usize_unsuffixed(self.nc)
    }

    /// `mass_matrix`: `M^b(q)` (eq. 11), the lower triangle copied from the upper one.
    pub fn mass_matrix(&mut self, sym: &Symbolic) -> TokenStream {
        let tail = mirror(self.n, "m");
        let (body, inputs) = self.body_with(self.em, "mass_matrix", &mass_outputs(sym, "m"), tail);
        let (q, nl) = (arg(&inputs, "q"), self.nl());
        quote! {
            /// Mass matrix `M^b(q)` (eq. 11).
            pub fn mass_matrix(&self, #q: &[f64; #nl], m: &mut [[f64; #nl]; #nl]) { #body }
        }
    }

    /// `f_vector`: `F^b(q, q')` (eq. 12).
    pub fn f_vector(&mut self, sym: &Symbolic) -> TokenStream {
        let (body, inputs) = self.body("f_vector", &vec_outputs(&sym.f, "f"));
        let (q, qd, nl) = (arg(&inputs, "q"), arg(&inputs, "qd"), self.nl());
        quote! {
            /// Velocity and gravity terms `F^b(q, q')` (eq. 12).
            pub fn f_vector(&self, #q: &[f64; #nl], #qd: &[f64; #nl], f: &mut [f64; #nl]) { #body }
        }
    }

    /// `q_vector`: `Q^b(q, q', t)` (eq. 13).
    pub fn q_vector(&mut self, sym: &Symbolic) -> TokenStream {
        let (body, inputs) = self.body("q_vector", &vec_outputs(&sym.q, "out"));
        let (q, qd, t) = (arg(&inputs, "q"), arg(&inputs, "qd"), arg(&inputs, "t"));
        let nl = self.nl();
        quote! {
            /// Force-element terms `Q^b(q, q', t)`, paper sign (eq. 13).
            pub fn q_vector(&self, #q: &[f64; #nl], #qd: &[f64; #nl], #t: f64, out: &mut [f64; #nl]) { #body }
        }
    }

    /// `constraints`: `h(q)` (eq. 14).
    pub fn constraints(&mut self, cons: &ConstraintExprs) -> TokenStream {
        let (body, inputs) = self.body("constraints", &vec_outputs(&cons.h, "h"));
        let (q, h) = (arg(&inputs, "q"), constraint_out(self.nc, "h"));
        let (nl, ncl) = (self.nl(), self.ncl());
        quote! {
            /// Constraints `h(q)` (eq. 14).
            pub fn constraints(&self, #q: &[f64; #nl], #h: &mut [f64; #ncl]) { #body }
        }
    }

    /// `constraint_jacobian`: `J(q)` (eq. 15).
    pub fn constraint_jacobian(&mut self, cons: &ConstraintExprs) -> TokenStream {
        let outs = matrix_outputs(&cons.j, "j");
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
        let outs = vec_outputs(&cons.a, "a");
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
        let outs = [(sym.potential, Dest::Scalar("v".into()))];
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

    /// `element_power`: `[D, P]`, the force elements' dissipation and input power.
    pub fn element_power(&mut self, sym: &Symbolic) -> TokenStream {
        let outs = [
            (sym.dissipation, Dest::Scalar("d".into())),
            (sym.input_power, Dest::Scalar("p".into())),
        ];
        let (body, inputs) = self.body("element_power", &outs);
        let (q, qd, nl) = (arg(&inputs, "q"), arg(&inputs, "qd"), self.nl());
        quote! {
            /// `[D, P]`: the dissipation power of the force elements (`c q'^2` of the joint
            /// dampers, `c l'^2` of the point spring-dampers) and the power of the loads without
            /// potential (constant joint forces, external forces and torques); along any motion
            /// `d(T + V)/dt = P - D`.
            pub fn element_power(&self, #q: &[f64; #nl], #qd: &[f64; #nl]) -> [f64; 2] {
                let d: f64;
                let p: f64;
                #body
                [d, p]
            }
        }
    }

    /// `gravity_load_jacobian`: `G(q) = dF^b/dg`, `n x 3`.
    pub fn gravity_load_jacobian(&mut self, sym: &Symbolic) -> TokenStream {
        let outs: Vec<(Id, Dest)> = sym
            .gravity_jacobian
            .iter()
            .enumerate()
            .map(|(k, &id)| (id, Dest::Mat("g".into(), k / 3, k % 3)))
            .collect();
        let (body, inputs) = self.body("gravity_load_jacobian", &outs);
        let (q, nl) = (arg(&inputs, "q"), self.nl());
        quote! {
            /// `G(q) = dF^b/dg = -sum_i m_i J_Ci^T` (`g[j][k] = dF^b_j/dg_k`): a ground frame
            /// accelerating by `a` adds the inertial load `-G(q) a` to `F^b`.
            pub fn gravity_load_jacobian(&self, #q: &[f64; #nl], g: &mut [[f64; 3]; #nl]) { #body }
        }
    }

    /// `evaluate`: everything of eqs. 11–16 in one body, every intermediate computed once.
    pub fn evaluate(&mut self, sym: &Symbolic, cons: &ConstraintExprs) -> TokenStream {
        let tail = mirror(self.n, "mass");
        let (body, inputs) =
            self.body_with(self.em, "evaluate", &evaluate_outputs(sym, cons), tail);
        let (q, qd, t) = (arg(&inputs, "q"), arg(&inputs, "qd"), arg(&inputs, "t"));
        let (nl, ncl, rt) = (self.nl(), self.ncl(), self.rt);
        quote! {
            /// `M^b`, `F^b`, `Q^b`, `h`, `J` and `A` at once (eqs. 11–16): one body in which every
            /// intermediate is computed once; bit-identical to the separate methods.
            #[allow(unused_variables)]
            pub fn evaluate(&self, #q: &[f64; #nl], #qd: &[f64; #nl], #t: f64, out: &mut #rt::Evaluation<#nl, #ncl>) {
                let #rt::Evaluation { mass, f, q: qf, h, j, a } = out;
                #body
            }
        }
    }

    /// `point_<name>`: position, Jacobian and bias of one named point (eqs. 49–50).
    pub fn point(&mut self, pt: &PointExprs, fname: &Ident) -> TokenStream {
        let outs = point_outputs(pt, "");
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

    /// `position_<name>`: position and Jacobian of one named point (eq. 49), without the
    /// bias: the same nodes as in `point_<name>`, so bit-identical to its `p` and `j`.
    pub fn position(&mut self, pt: &PointExprs, fname: &Ident) -> TokenStream {
        let mut outs = vec_outputs(&pt.p, "p");
        outs.extend(matrix_outputs(&pt.j, "j"));
        let (body, inputs) = self.body(&format!("position_{}", pt.name), &outs);
        let q = arg(&inputs, "q");
        let doc = format!(
            " Position and Jacobian of point `{}` (eq. 49), without the bias:",
            pt.name
        );
        let nl = self.nl();
        quote! {
            #[doc = #doc]
            #[doc = " bit-identical to the `p` and `j` of its `point_*` method."]
            pub fn #fname(&self, #q: &[f64; #nl], p: &mut [f64; 3], j: &mut [[f64; #nl]; 3]) {
                #body
            }
        }
    }

    /// `evaluate_with_points`: `M^b`, `F^b`, `Q^b`, `h`, `J`, `A` (eqs. 11–16) and the
    /// kinematics of every named point (eqs. 49–50) in one body, so that the trigonometric
    /// leaves and rotation products are computed once for all of them.
    pub fn evaluate_with_points(
        &mut self,
        sym: &Symbolic,
        cons: &ConstraintExprs,
        pts: &[PointExprs],
    ) -> TokenStream {
        let mut outs = evaluate_outputs(sym, cons);
        for (k, pt) in pts.iter().enumerate() {
            outs.extend(point_outputs(pt, &format!("pt{k}_")));
        }
        let tail = mirror(self.n, "mass");
        let (body, inputs) = self.body_with(self.em, "evaluate_with_points", &outs, tail);
        let (q, qd, t) = (arg(&inputs, "q"), arg(&inputs, "qd"), arg(&inputs, "t"));
        let (nl, ncl, rt) = (self.nl(), self.ncl(), self.rt);
        let npts = Literal::usize_unsuffixed(pts.len());
        let pt = |k: usize, what: &str| format_ident!("pt{k}_{what}");
        let whole: Vec<Ident> = (0..pts.len()).map(|k| format_ident!("pt{k}")).collect();
        let (pp, pj, pa): (Vec<Ident>, Vec<Ident>, Vec<Ident>) = (
            (0..pts.len()).map(|k| pt(k, "p")).collect(),
            (0..pts.len()).map(|k| pt(k, "j")).collect(),
            (0..pts.len()).map(|k| pt(k, "a")).collect(),
        );
        quote! {
            /// `M^b`, `F^b`, `Q^b`, `h`, `J`, `A` (eqs. 11–16) and the position, Jacobian and
            /// bias of every named point (eqs. 49–50, `points[k]` for `POINT_NAMES[k]`) in one
            /// body: every intermediate, the sines and cosines first, is computed once;
            /// bit-identical to `evaluate` and the `point_*` methods.
            #[allow(unused_variables)]
            pub fn evaluate_with_points(
                &self,
                #q: &[f64; #nl],
                #qd: &[f64; #nl],
                #t: f64,
                out: &mut #rt::Evaluation<#nl, #ncl>,
                points: &mut [#rt::PointKinematics<#nl>; #npts],
            ) {
                let #rt::Evaluation { mass, f, q: qf, h, j, a } = out;
                let [#(#whole),*] = points;
                #( let #rt::PointKinematics { p: #pp, j: #pj, a: #pa } = #whole; )*
                #body
            }
        }
    }

    /// `hoisted_values`: the parameter-only subexpressions `frontier` (every function reads
    /// them from the cache field), computed from the parameters alone.
    pub fn hoisted_values(&mut self, frontier: &[Id]) -> TokenStream {
        let em = FnEmitter {
            hoisted: &[],
            ..self.em
        };
        let outs: Vec<(Id, Dest)> = frontier
            .iter()
            .enumerate()
            .map(|(k, &id)| (id, Dest::Vec("v".into(), k)))
            .collect();
        let (body, _) = self.body_with(em, "hoisted_values", &outs, String::new());
        let len = Literal::usize_unsuffixed(frontier.len());
        quote! {
            /// The parameter-only subexpressions of the equations, computed from the run-time
            /// parameters alone: cached by `with_params` and `set_param`, read by every
            /// evaluation method (never recomputed per call).
            fn hoisted_values(&self) -> [f64; #len] {
                let mut v = [0.0; #len];
                #body
                v
            }
        }
    }
}
