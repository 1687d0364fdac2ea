//! The DAG interpreter backend: evaluates the symbolic equations without generating code.
//!
//! It is the second of the three formulations every test compares (generated code, numeric
//! recursive reference, interpreter): the same expressions the generator emits, evaluated by
//! [`crate::expr::Tape`].

use crate::dynamics::Symbolic;
use crate::expr::{EvalInput, Tape};
use crate::model::Model;

/// Interpreted `M^b`, `F^b`, `Q^b` of a model.
#[derive(Clone, Debug)]
pub struct Interpreter {
    n: usize,
    mass: Tape,
    f: Tape,
    q: Tape,
    params: Vec<f64>,
}

impl Interpreter {
    /// Derives the model symbolically and compiles evaluation tapes. Folded parameters take
    /// their values from `model`; run-time parameters start at their defaults.
    pub fn new(model: &Model) -> Interpreter {
        Interpreter::from_symbolic(&Symbolic::derive(model), model.default_params())
    }

    /// Compiles evaluation tapes for an existing derivation; `params` holds the values of all
    /// model parameters (only the run-time ones are read).
    pub fn from_symbolic(sym: &Symbolic, params: Vec<f64>) -> Interpreter {
        Interpreter {
            n: sym.n,
            mass: Tape::new(&sym.dag, &sym.mass),
            f: Tape::new(&sym.dag, &sym.f),
            q: Tape::new(&sym.dag, &sym.q),
            params,
        }
    }

    /// Number of joint coordinates.
    pub fn dof(&self) -> usize {
        self.n
    }

    /// Sets the value of run-time parameter `k` (index into the model's parameter list).
    pub fn set_param(&mut self, k: usize, value: f64) {
        self.params[k] = value;
    }

    fn input<'a>(&'a self, q: &'a [f64], qd: &'a [f64], t: f64) -> EvalInput<'a> {
        EvalInput {
            q,
            qd,
            qdd: &[],
            t,
            params: &self.params,
        }
    }

    /// `M^b(q)`, row-major `n x n` (eq. 11).
    pub fn mass_matrix(&self, q: &[f64]) -> Vec<f64> {
        self.mass.eval_vec(&self.input(q, &[], 0.0))
    }

    /// `F^b(q, q')` (eq. 12).
    pub fn f_vector(&self, q: &[f64], qd: &[f64]) -> Vec<f64> {
        self.f.eval_vec(&self.input(q, qd, 0.0))
    }

    /// `Q^b(q, q', t)` (eq. 13).
    pub fn q_vector(&self, q: &[f64], qd: &[f64], t: f64) -> Vec<f64> {
        self.q.eval_vec(&self.input(q, qd, t))
    }
}
