//! Exact first derivatives of a mechanism's equations (tangent matrices), by symbolic
//! differentiation in the expression DAG ([`crate::expr::diff`]) and evaluation by the
//! interpreter's tapes ([`crate::expr::Tape`]).
//!
//! # The equations
//!
//! The paper's equations of a constrained tree, in the sign convention of
//! `docs/theory.md` (eqs. 10–17):
//!
//! ```text
//! r(q, q', q'', t) = M(q) q'' + F(q, q') + Q(q, q', t)        (eqs. 10–13)
//! r + J(q)^T lambda = 0,   h(q) = 0,   J = dh/dq             (eqs. 14, 15, 17)
//! ```
//!
//! A small perturbation `(dq, dq', dq'', dlambda)` of a motion (or of a static equilibrium)
//! changes the left-hand side by, to first order,
//!
//! ```text
//! d(M q'' + F + Q + J^T lambda)
//!     = M dq'' + C dq' + (K + G(lambda)) dq + J^T dlambda,        d h = J dq,
//! ```
//!
//! with the matrices [`TangentSystem`] evaluates:
//!
//! - `M(q)`, the mass matrix of eq. 11;
//! - `K = d(M q'' + F + Q)/dq` with `q''` held (so it contains `dM/dq . q''`), `n x n`;
//! - `C = d(F + Q)/dq' = d(M q'' + F + Q)/dq'`, `n x n` (gyroscopic/Coriolis and damping);
//! - `G(lambda) = d(J^T lambda)/dq = sum_r lambda_r d²h_r/dq²`, the constraint curvature
//!   (symmetric): the stiffness a preloaded closed loop contributes;
//! - for a named point `k` with position `p_k(q)` and Jacobian `J_k = dp_k/dq` (eq. 49), the
//!   curvature `G_k(f) = d(J_k^T f)/dq = sum_c f_c d²p_kc/dq²` for a ground-frame force `f`
//!   held fixed (symmetric): the stiffness of a force acting through a point Jacobian, such
//!   as an attachment's reaction.
//!
//! The linearisation of issue #11 assembles exactly these. About an equilibrium
//! `(q0, q' = 0, q'' = 0, lambda0)` of the tree with loop multipliers `lambda0` and point
//! forces `f_k0` entering the left-hand side as `+ J_k^T f_k` (a force `f` *applied* at the
//! point enters `Q` as `- J_k^T f`, eq. 13, and so contributes `- G_k(f)`), the linearised
//! equations are
//!
//! ```text
//! M dq'' + C dq' + (K + G(lambda0) + sum_k G_k(f_k0)) dq + J^T dlambda
//!        + sum_k J_k^T df_k = 0,                     J dq = 0,
//! ```
//!
//! reduced to the independent coordinates by the coordinate partitioning of eqs. 18–25. At
//! rest the bias `A = J' q'` (eq. 16) and the velocity terms of `F` are quadratic in `q'`, so
//! they contribute nothing to first order; `C` there is the damping of the force elements.
//!
//! # How
//!
//! Everything is built once, in [`TangentSystem::new`]: the residual `r = M q'' + F + Q` is
//! formed in the DAG with `q''` as its [`Var::Qdd`] leaves, and differentiated with respect to
//! every `q_j` and `q'_j` ([`Dag::diff_many`]: forward mode memoised per node, sharing the
//! original nodes). The multipliers `lambda` and the point force `f` enter the DAG as extra
//! [`Var::Param`] leaves numbered after the model's own parameters (indices `np..`, `np` the
//! length of the model's parameter list): parameters are constants of the differentiation
//! and of the time derivative, which is exactly what `lambda` and `f` are here, and the
//! interpreter reads them from the same slice as the parameters, so neither the DAG nor the
//! interpreter needed a new kind of leaf. The derivative expressions are compiled into tapes
//! (one for the dynamics, one for the constraints, one per named point); evaluation copies
//! the run-time parameter values and the extra inputs into [`TangentWorkspace::inputs`] and
//! runs a tape into [`TangentWorkspace::scratch`]: nothing is allocated once the workspace
//! exists.
//!
//! # Which force elements linearise exactly
//!
//! Every force element's `Q^b` terms are expressions of the DAG (`dynamics/elements.rs`), so
//! `K` and `C` are their exact derivatives at any state, moving or at rest: the joint
//! spring-damper and constant force (affine in `q`, `q'`), the point spring-damper (its
//! damping term `c l' d / l` is differentiated in `q` as well as in `q'`, so a tangent about
//! a moving state keeps `c d(l')/dq`), and the external loads (a body-frame load is a
//! follower force: its stiffness `d(J^T T f)/dq` is exact and in general not symmetric).
//! The one place where an element has no tangent is a point spring-damper whose two points
//! coincide (`l = 0`): its direction `d / l` is undefined there (the numeric reference
//! applies no force, the symbolic expressions are not finite). [`TangentSystem::check_elements`]
//! refuses such a state with [`TangentError::CoincidentSpringPoints`] naming the element,
//! instead of returning a silently wrong or non-finite tangent; the hybrid linearisation
//! calls it at the equilibrium.
//!
//! Cost: forward mode makes one derivative pass per coordinate, so the `K`, `C` tape grows
//! about `n`-fold over the equations' own: measured tape slots 127 against the
//! interpreter's 73 for the double bar (`n = 2`), 25,597 against 2,968 for a 12-body
//! spatial chain.

use nalgebra::{DMatrix, DVector, Vector3};

use crate::constraints;
use crate::expr::{Dag, EvalInput, Id, Tape, Var};
use crate::model::{ForceElement, Model};

use super::system::{Names, ParamError};

/// Why a force element has no tangent at a state (see the module documentation).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TangentError {
    /// A point spring-damper whose two points coincide: its direction, hence its force and
    /// its tangent, is undefined.
    #[error(
        "force element `{element}`: its points `{a}` and `{b}` coincide (length {length:e} m), where the spring-damper's direction and so its linearisation are undefined"
    )]
    CoincidentSpringPoints {
        /// The element's name.
        element: String,
        /// Its first point.
        a: String,
        /// Its second point.
        b: String,
        /// The length `l = |p_b - p_a|` found.
        length: f64,
    },
}

/// A point spring-damper of the model, for [`TangentSystem::check_elements`].
#[derive(Clone, Debug)]
struct SpringCheck {
    element: String,
    a: String,
    b: String,
}

/// Caller-owned buffers for the evaluations of a [`TangentSystem`]; created by
/// [`TangentSystem::workspace`]. Each evaluation method overwrites the buffers it documents
/// and leaves the others untouched.
#[derive(Clone, Debug)]
pub struct TangentWorkspace {
    /// `M(q)` (eq. 11), `n x n`.
    pub m: DMatrix<f64>,
    /// `K = d(M q'' + F + Q)/dq` at fixed `q'`, `q''`, `t`, `n x n`.
    pub k: DMatrix<f64>,
    /// `C = d(F + Q)/dq'` at fixed `q`, `t`, `n x n`.
    pub c: DMatrix<f64>,
    /// `h(q)` (eq. 14).
    pub h: DVector<f64>,
    /// `J = dh/dq` (eq. 15), `rows x n`.
    pub j: DMatrix<f64>,
    /// `G(lambda) = d(J^T lambda)/dq = sum_r lambda_r d²h_r/dq²`, `n x n`.
    pub constraint_curvature: DMatrix<f64>,
    /// Position of the point last evaluated by [`TangentSystem::evaluate_point`].
    pub point_p: Vector3<f64>,
    /// Its Jacobian `J_k = dp/dq` (eq. 49), `3 x n`.
    pub point_j: DMatrix<f64>,
    /// Its curvature `G_k(f) = d(J_k^T f)/dq = sum_c f_c d²p_c/dq²`, `n x n`.
    pub point_curvature: DMatrix<f64>,
    /// Tape slots and outputs.
    pub scratch: Vec<f64>,
    /// The parameter slice the tapes read: the model's parameter values, then `lambda` or
    /// `f`.
    pub inputs: Vec<f64>,
}

/// Exact tangent matrices of a model's equations (see the module documentation): `M`, `K`,
/// `C` of the tree, `h`, `J` and the constraint curvature `d(J^T lambda)/dq`, and per named
/// point `p`, `J_k` and the curvature `d(J_k^T f)/dq`. Run-time parameters are set as in
/// [`super::InterpretedSystem`] ([`TangentSystem::set_param`]).
#[derive(Clone, Debug)]
pub struct TangentSystem {
    n: usize,
    rows: usize,
    /// Length of the model's parameter list (the extra inputs start here).
    np: usize,
    /// Outputs `M` (n²), `K` (n²), `C` (n²), each row-major.
    dynamics: Tape,
    /// Outputs `h` (rows), `J` (rows * n), `G(lambda)` (n²).
    constraints: Tape,
    /// Per point: `p` (3), `J_k` (3n), `G_k(f)` (n²).
    point_tapes: Vec<Tape>,
    /// Outputs `l^2` of each point spring-damper, in [`TangentSystem::springs`] order.
    spring_tape: Tape,
    springs: Vec<SpringCheck>,
    values: Vec<f64>,
    names: Names,
    param_index: Vec<usize>,
}

/// `d e_i / d v_j` for every output `e_i` and leaf `v_j`, row-major (`i` slow).
fn jacobian(dag: &mut Dag, es: &[Id], vars: impl Iterator<Item = Var>) -> Vec<Id> {
    let cols: Vec<Vec<Id>> = vars.map(|v| dag.diff_many(es, v)).collect();
    let mut out = Vec::with_capacity(es.len() * cols.len());
    for i in 0..es.len() {
        out.extend(cols.iter().map(|col| col[i]));
    }
    out
}

/// `sum_r w_r a_r` for weights `w` and rows `a_r` (each of length `n`): the vector
/// `A^T w`.
fn weighted_rows(dag: &mut Dag, w: &[Id], rows: &[&[Id]], n: usize) -> Vec<Id> {
    (0..n)
        .map(|i| {
            let terms: Vec<Id> = w
                .iter()
                .zip(rows)
                .map(|(&wr, row)| dag.mul(wr, row[i]))
                .collect();
            dag.sum(terms)
        })
        .collect()
}

/// The leaves of a position-level evaluation (`q` only).
fn positions(q: &[f64]) -> EvalInput<'_> {
    EvalInput {
        q,
        qd: &[],
        qdd: &[],
        t: 0.0,
        params: &[],
    }
}

fn q_vars(n: usize) -> impl Iterator<Item = Var> {
    (0..n as u32).map(Var::Q)
}

impl TangentSystem {
    /// Derives the model symbolically (Newton–Euler, constraints, points), differentiates
    /// the equations and compiles the tapes. Folded parameters take their values from
    /// `model`; run-time parameters start at their defaults.
    pub fn new(model: &Model) -> TangentSystem {
        let (mut sym, cons, pts) = constraints::derive_all(model);
        let n = sym.n;
        let rows = cons.h.len();
        let np = model.parameters.len();
        let dag = &mut sym.dag;
        let extra = |dag: &mut Dag, k: usize| dag.var(Var::Param((np + k) as u32));

        // r = M q'' + F + Q
        let residual: Vec<Id> = (0..n)
            .map(|i| {
                let mut terms: Vec<Id> = (0..n)
                    .map(|k| {
                        let qdd = dag.qdd(k);
                        dag.mul(sym.mass[i * n + k], qdd)
                    })
                    .collect();
                terms.push(sym.f[i]);
                terms.push(sym.q[i]);
                dag.sum(terms)
            })
            .collect();
        let mut outs: Vec<Id> = sym.mass.clone();
        outs.extend(jacobian(dag, &residual, q_vars(n)));
        outs.extend(jacobian(dag, &residual, (0..n as u32).map(Var::Qd)));
        let dynamics = Tape::new(dag, &outs);

        // G(lambda) = d(J^T lambda)/dq
        let lambda: Vec<Id> = (0..rows).map(|r| extra(dag, r)).collect();
        let jrows: Vec<&[Id]> = cons.j.iter().map(Vec::as_slice).collect();
        let jt_lambda = weighted_rows(dag, &lambda, &jrows, n);
        let mut outs: Vec<Id> = cons.h.clone();
        for row in &cons.j {
            outs.extend(row);
        }
        outs.extend(jacobian(dag, &jt_lambda, q_vars(n)));
        let constraints = Tape::new(dag, &outs);

        // G_k(f) = d(J_k^T f)/dq
        let force: Vec<Id> = (0..3).map(|c| extra(dag, c)).collect();
        let point_tapes = pts
            .iter()
            .map(|pt| {
                let jrows: Vec<&[Id]> = pt.j.iter().map(Vec::as_slice).collect();
                let jt_f = weighted_rows(dag, &force, &jrows, n);
                let mut outs: Vec<Id> = pt.p.to_vec();
                for row in &pt.j {
                    outs.extend(row);
                }
                outs.extend(jacobian(dag, &jt_f, q_vars(n)));
                Tape::new(dag, &outs)
            })
            .collect();

        // l^2 = |p_b - p_a|^2 of every point spring-damper.
        let mut springs = Vec::new();
        let mut lengths = Vec::new();
        for fe in &model.forces {
            if let ForceElement::PointSpring { name, a, b, .. } = fe {
                let (pa, pb) = (pts[*a].p, pts[*b].p);
                let d: Vec<Id> = (0..3).map(|c| dag.sub(pb[c], pa[c])).collect();
                let d2: Vec<Id> = d.iter().map(|&x| dag.mul(x, x)).collect();
                lengths.push(dag.sum(d2));
                springs.push(SpringCheck {
                    element: name.clone(),
                    a: model.points[*a].name.clone(),
                    b: model.points[*b].name.clone(),
                });
            }
        }
        let spring_tape = Tape::new(dag, &lengths);

        let (names, param_index) = Names::of(model);
        TangentSystem {
            n,
            rows,
            np,
            dynamics,
            constraints,
            point_tapes,
            spring_tape,
            springs,
            values: model.default_params(),
            names,
            param_index,
        }
    }

    /// Number of tree coordinates `n`.
    pub fn dof(&self) -> usize {
        self.n
    }

    /// Number of constraint rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// The names of the coordinates, constraint rows, points and run-time parameters.
    pub fn names(&self) -> &Names {
        &self.names
    }

    /// Sets a run-time parameter (the same names and checks as
    /// [`super::System::set_param`]).
    pub fn set_param(&mut self, name: &str, value: f64) -> Result<(), ParamError> {
        let k = self.param_index[self.names.param(name, value)?];
        self.values[k] = value;
        Ok(())
    }

    fn tapes(&self) -> impl Iterator<Item = &Tape> {
        [&self.dynamics, &self.constraints, &self.spring_tape]
            .into_iter()
            .chain(&self.point_tapes)
    }

    /// A workspace with this system's sizes.
    pub fn workspace(&self) -> TangentWorkspace {
        let (n, rows) = (self.n, self.rows);
        let scratch = self
            .tapes()
            .map(|t| t.scratch_len() + t.output_len())
            .max()
            .unwrap_or(0);
        TangentWorkspace {
            m: DMatrix::zeros(n, n),
            k: DMatrix::zeros(n, n),
            c: DMatrix::zeros(n, n),
            h: DVector::zeros(rows),
            j: DMatrix::zeros(rows, n),
            constraint_curvature: DMatrix::zeros(n, n),
            point_p: Vector3::zeros(),
            point_j: DMatrix::zeros(3, n),
            point_curvature: DMatrix::zeros(n, n),
            scratch: vec![0.0; scratch],
            inputs: vec![0.0; self.np + rows.max(3)],
        }
    }

    /// Runs `tape` on the leaves `x` (`q`, `q'`, `q''`, `t`; the parameter slice is
    /// replaced by the parameter values followed by `extra`), then hands the outputs and
    /// the workspace's matrices to `read`.
    fn run(
        &self,
        tape: &Tape,
        x: EvalInput<'_>,
        extra: &[f64],
        ws: &mut TangentWorkspace,
        read: impl FnOnce(&[f64], &mut TangentWorkspace),
    ) {
        assert_eq!(x.q.len(), self.n, "q has the wrong length");
        let need = tape.scratch_len() + tape.output_len();
        if ws.scratch.len() < need {
            // Only a workspace not made by `workspace()` is too short.
            ws.scratch.resize(need, 0.0);
        }
        if ws.inputs.len() < self.np + extra.len() {
            ws.inputs.resize(self.np + extra.len(), 0.0);
        }
        ws.inputs[..self.np].copy_from_slice(&self.values);
        ws.inputs[self.np..self.np + extra.len()].copy_from_slice(extra);
        let mut scratch = std::mem::take(&mut ws.scratch);
        let (slots, rest) = scratch.split_at_mut(tape.scratch_len());
        let out = &mut rest[..tape.output_len()];
        let input = EvalInput {
            params: &ws.inputs,
            ..x
        };
        tape.eval(&input, slots, out);
        read(out, ws);
        ws.scratch = scratch;
    }

    /// Checks that every force element has a tangent at `q` (see the module documentation):
    /// refuses a point spring-damper whose points coincide. Allocation-free.
    pub fn check_elements(&self, q: &[f64], ws: &mut TangentWorkspace) -> Result<(), TangentError> {
        let mut bad = None;
        self.run(&self.spring_tape, positions(q), &[], ws, |out, _| {
            bad = out
                .iter()
                .position(|&l2| !(l2 > 0.0 && l2.is_finite()))
                .map(|k| (k, out[k].max(0.0).sqrt()));
        });
        match bad {
            None => Ok(()),
            Some((k, length)) => {
                let s = &self.springs[k];
                Err(TangentError::CoincidentSpringPoints {
                    element: s.element.clone(),
                    a: s.a.clone(),
                    b: s.b.clone(),
                    length,
                })
            }
        }
    }

    /// Fills [`TangentWorkspace::m`], [`TangentWorkspace::k`] and [`TangentWorkspace::c`] at
    /// `(q, q', q'', t)`.
    pub fn evaluate_dynamics(
        &self,
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        t: f64,
        ws: &mut TangentWorkspace,
    ) {
        assert_eq!(qd.len(), self.n, "q' has the wrong length");
        assert_eq!(qdd.len(), self.n, "q'' has the wrong length");
        let n = self.n;
        let x = EvalInput {
            q,
            qd,
            qdd,
            t,
            params: &[],
        };
        self.run(&self.dynamics, x, &[], ws, |out, ws| {
            for r in 0..n {
                for c in 0..n {
                    ws.m[(r, c)] = out[r * n + c];
                    ws.k[(r, c)] = out[n * n + r * n + c];
                    ws.c[(r, c)] = out[2 * n * n + r * n + c];
                }
            }
        });
    }

    /// Fills [`TangentWorkspace::h`], [`TangentWorkspace::j`] and
    /// [`TangentWorkspace::constraint_curvature`] (`d(J^T lambda)/dq`) at `q` for the
    /// multipliers `lambda` (one per constraint row).
    pub fn evaluate_constraints(&self, q: &[f64], lambda: &[f64], ws: &mut TangentWorkspace) {
        assert_eq!(lambda.len(), self.rows, "lambda has the wrong length");
        let (n, rows) = (self.n, self.rows);
        self.run(&self.constraints, positions(q), lambda, ws, |out, ws| {
            for r in 0..rows {
                ws.h[r] = out[r];
                for c in 0..n {
                    ws.j[(r, c)] = out[rows + r * n + c];
                }
            }
            let g0 = rows * (n + 1);
            for r in 0..n {
                for c in 0..n {
                    ws.constraint_curvature[(r, c)] = out[g0 + r * n + c];
                }
            }
        });
    }

    /// Fills [`TangentWorkspace::point_p`], [`TangentWorkspace::point_j`] and
    /// [`TangentWorkspace::point_curvature`] (`d(J_k^T f)/dq`) of point `k` (index into
    /// [`Names::points`]) at `q` for the ground-frame force `f`; `false` (workspace
    /// unchanged) when there is no such point.
    pub fn evaluate_point(
        &self,
        k: usize,
        q: &[f64],
        f: [f64; 3],
        ws: &mut TangentWorkspace,
    ) -> bool {
        let Some(tape) = self.point_tapes.get(k) else {
            return false;
        };
        let n = self.n;
        self.run(tape, positions(q), &f, ws, |out, ws| {
            for r in 0..3 {
                ws.point_p[r] = out[r];
                for c in 0..n {
                    ws.point_j[(r, c)] = out[3 + r * n + c];
                }
            }
            let g0 = 3 * (n + 1);
            for r in 0..n {
                for c in 0..n {
                    ws.point_curvature[(r, c)] = out[g0 + r * n + c];
                }
            }
        });
        true
    }
}
