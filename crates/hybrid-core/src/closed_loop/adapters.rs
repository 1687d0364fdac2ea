//! [`System`] implementations: generated code, the DAG interpreter and the numeric
//! reference, so that the closed-loop machinery works for any model — compiled in (fast) or
//! read at run time.

use mbs_symbolic::constraints;
use mbs_symbolic::dynamics::Symbolic;
use mbs_symbolic::expr::{EvalInput, Tape};
use mbs_symbolic::model::{Constraint, Model};
use mbs_symbolic::numeric::NumericModel;
use mbs_symbolic::runtime::{Evaluation, Mechanism};

use super::system::{System, Workspace};

/// Errors building an adapter.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum AdapterError {
    /// A list of names has the wrong length.
    #[error("{what}: {found} names given, the mechanism has {expected}")]
    NameCount {
        /// Which names.
        what: &'static str,
        /// The mechanism's count.
        expected: usize,
        /// Names given.
        found: usize,
    },
    /// The parameter vector does not match the model.
    #[error("model {model:?}: {found} parameter values given, the model declares {expected}")]
    ParamCount {
        /// The model.
        model: String,
        /// Declared parameters.
        expected: usize,
        /// Values given.
        found: usize,
    },
}

/// Names of the constraint rows of a model, in row order: `"<name>.<component>"` for loop
/// and fixed-point constraints, the constraint's name for an angle closure (the same names
/// as [`mbs_symbolic::constraints::ConstraintExprs::names`]).
pub fn constraint_row_names(model: &Model) -> Vec<String> {
    let mut out = Vec::with_capacity(model.constraint_rows());
    for c in &model.constraints {
        match c {
            Constraint::Loop {
                name, components, ..
            }
            | Constraint::Fixed {
                name, components, ..
            } => out.extend(components.iter().map(|ax| format!("{name}.{ax}"))),
            Constraint::Angle { name, .. } => out.push(name.clone()),
        }
    }
    out
}

/// Names of the coordinates of a model, in coordinate order.
pub fn coordinate_names(model: &Model) -> Vec<String> {
    model.bodies.iter().map(|b| b.coordinate.clone()).collect()
}

/// Generated code (any [`Mechanism`] with `N` coordinates and `NC` constraint rows) as a
/// [`System`]: the fixed-size outputs are copied into the workspace buffers.
///
/// The potential energy comes from the generated `potential_energy` (gravity, springs).
#[derive(Clone, Debug)]
pub struct GeneratedSystem<T, const N: usize, const NC: usize> {
    mech: T,
    coords: Vec<String>,
    cons: Vec<String>,
}

impl<T: Mechanism<N, NC>, const N: usize, const NC: usize> GeneratedSystem<T, N, NC> {
    /// Wraps `mech`; the names are usually the generated `COORDINATE_NAMES` and
    /// `CONSTRAINT_NAMES` constants.
    pub fn new(
        mech: T,
        coordinate_names: &[&str],
        constraint_names: &[&str],
    ) -> Result<Self, AdapterError> {
        if coordinate_names.len() != N {
            return Err(AdapterError::NameCount {
                what: "coordinate names",
                expected: N,
                found: coordinate_names.len(),
            });
        }
        if constraint_names.len() != NC {
            return Err(AdapterError::NameCount {
                what: "constraint names",
                expected: NC,
                found: constraint_names.len(),
            });
        }
        Ok(GeneratedSystem {
            mech,
            coords: coordinate_names.iter().map(|s| s.to_string()).collect(),
            cons: constraint_names.iter().map(|s| s.to_string()).collect(),
        })
    }

    /// The wrapped mechanism.
    pub fn mechanism(&self) -> &T {
        &self.mech
    }

    /// The wrapped mechanism, mutably (to set run-time parameters).
    pub fn mechanism_mut(&mut self) -> &mut T {
        &mut self.mech
    }
}

fn array<const N: usize>(v: &[f64]) -> [f64; N] {
    let mut a = [0.0; N];
    a.copy_from_slice(v);
    a
}

impl<T: Mechanism<N, NC>, const N: usize, const NC: usize> System for GeneratedSystem<T, N, NC> {
    fn dof(&self) -> usize {
        N
    }
    fn rows(&self) -> usize {
        NC
    }
    fn coordinate_names(&self) -> &[String] {
        &self.coords
    }
    fn constraint_names(&self) -> &[String] {
        &self.cons
    }
    fn backend(&self) -> &'static str {
        "generated"
    }

    fn evaluate(&self, q: &[f64], qd: &[f64], t: f64, ws: &mut Workspace) {
        let (q, qd) = (array::<N>(q), array::<N>(qd));
        // One fused generated body: trigonometric leaves and rotations computed once.
        let mut e = Evaluation::<N, NC>::default();
        self.mech.evaluate(&q, &qd, t, &mut e);
        for r in 0..N {
            for c in 0..N {
                ws.m[(r, c)] = e.mass[r][c];
            }
            ws.f[r] = e.f[r];
            ws.q[r] = e.q[r];
        }
        for r in 0..NC {
            ws.h[r] = e.h[r];
            ws.a[r] = e.a[r];
            for c in 0..N {
                ws.j[(r, c)] = e.j[r][c];
            }
        }
    }

    fn evaluate_positions(&self, q: &[f64], ws: &mut Workspace) {
        let q = array::<N>(q);
        let mut h = [0.0; NC];
        let mut j = [[0.0; N]; NC];
        self.mech.constraints(&q, &mut h);
        self.mech.constraint_jacobian(&q, &mut j);
        for r in 0..NC {
            ws.h[r] = h[r];
            for c in 0..N {
                ws.j[(r, c)] = j[r][c];
            }
        }
    }

    fn potential_energy(&self, q: &[f64]) -> Option<f64> {
        Some(self.mech.potential_energy(&array::<N>(q)))
    }
}

/// The symbolic equations of a model evaluated by the DAG interpreter
/// ([`mbs_symbolic::expr::Tape`]): any model read at run time, no code generation.
///
/// Two tapes are compiled once: one for everything (`M`, `F`, `Q`, `h`, `J`, `A`), one for
/// the position level (`h`, `J`). The potential energy comes from the numeric reference of
/// the same model and parameters.
#[derive(Clone, Debug)]
pub struct InterpretedSystem {
    n: usize,
    rows: usize,
    all: Tape,
    positions: Tape,
    params: Vec<f64>,
    coords: Vec<String>,
    cons: Vec<String>,
    energy: NumericModel,
}

impl InterpretedSystem {
    /// Derives the model symbolically (Newton–Euler and constraints) and compiles the
    /// tapes, with the model's default parameter values.
    pub fn new(model: &Model) -> InterpretedSystem {
        // Default parameters always match the model.
        Self::with_params(model, model.default_params()).unwrap_or_else(|_| unreachable!())
    }

    /// [`InterpretedSystem::new`] with explicit values of all model parameters (indexed
    /// like [`Model::parameters`]).
    pub fn with_params(model: &Model, params: Vec<f64>) -> Result<InterpretedSystem, AdapterError> {
        if params.len() != model.parameters.len() {
            return Err(AdapterError::ParamCount {
                model: model.name.clone(),
                expected: model.parameters.len(),
                found: params.len(),
            });
        }
        let mut sym = Symbolic::derive(model);
        let cons = constraints::constraints(model, &mut sym);
        let n = sym.n;
        let rows = cons.h.len();
        let mut outs = Vec::with_capacity(n * n + 2 * n + rows * (n + 2));
        outs.extend(&sym.mass);
        outs.extend(&sym.f);
        outs.extend(&sym.q);
        let pos_start = outs.len();
        outs.extend(&cons.h);
        for row in &cons.j {
            outs.extend(row);
        }
        let pos_end = outs.len();
        outs.extend(&cons.a);
        let all = Tape::new(&sym.dag, &outs);
        let positions = Tape::new(&sym.dag, &outs[pos_start..pos_end]);
        let energy = NumericModel::new(model, &params);
        Ok(InterpretedSystem {
            n,
            rows,
            all,
            positions,
            params,
            coords: coordinate_names(model),
            cons: cons.names,
            energy,
        })
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

    /// Copies `h` and `J` from tape outputs starting at `base` in the scratch.
    fn copy_positions(&self, out: &[f64], ws: &mut Workspace) {
        let (n, rows) = (self.n, self.rows);
        for r in 0..rows {
            ws.h[r] = out[r];
            for c in 0..n {
                ws.j[(r, c)] = out[rows + r * n + c];
            }
        }
    }
}

impl System for InterpretedSystem {
    fn dof(&self) -> usize {
        self.n
    }
    fn rows(&self) -> usize {
        self.rows
    }
    fn coordinate_names(&self) -> &[String] {
        &self.coords
    }
    fn constraint_names(&self) -> &[String] {
        &self.cons
    }
    fn backend(&self) -> &'static str {
        "interpreter"
    }
    fn scratch_len(&self) -> usize {
        self.all.scratch_len() + self.all.output_len()
    }

    fn evaluate(&self, q: &[f64], qd: &[f64], t: f64, ws: &mut Workspace) {
        let need = self.scratch_len();
        if ws.scratch.len() < need {
            ws.scratch.resize(need, 0.0);
        }
        let mut scratch = std::mem::take(&mut ws.scratch);
        let (slots, out) = scratch.split_at_mut(self.all.scratch_len());
        self.all.eval(&self.input(q, qd, t), slots, out);
        let n = self.n;
        for r in 0..n {
            for c in 0..n {
                ws.m[(r, c)] = out[r * n + c];
            }
            ws.f[r] = out[n * n + r];
            ws.q[r] = out[n * n + n + r];
        }
        let base = n * n + 2 * n;
        self.copy_positions(&out[base..], ws);
        let a0 = base + self.rows * (n + 1);
        for r in 0..self.rows {
            ws.a[r] = out[a0 + r];
        }
        ws.scratch = scratch;
    }

    fn evaluate_positions(&self, q: &[f64], ws: &mut Workspace) {
        let need = self.positions.scratch_len() + self.positions.output_len();
        if ws.scratch.len() < need {
            ws.scratch.resize(need, 0.0);
        }
        let mut scratch = std::mem::take(&mut ws.scratch);
        let (slots, rest) = scratch.split_at_mut(self.positions.scratch_len());
        let out = &mut rest[..self.positions.output_len()];
        self.positions.eval(&self.input(q, &[], 0.0), slots, out);
        self.copy_positions(out, ws);
        ws.scratch = scratch;
    }

    fn potential_energy(&self, q: &[f64]) -> Option<f64> {
        Some(self.energy.potential_energy(q))
    }
}

/// The numeric recursive reference ([`NumericModel`]) as a [`System`]. It allocates its
/// results (a reference, not a hot path).
#[derive(Clone, Debug)]
pub struct NumericSystem {
    model: NumericModel,
    coords: Vec<String>,
    cons: Vec<String>,
}

impl NumericSystem {
    /// The numeric model of `model` with its default parameter values.
    pub fn new(model: &Model) -> NumericSystem {
        NumericSystem {
            model: NumericModel::with_default_params(model),
            coords: coordinate_names(model),
            cons: constraint_row_names(model),
        }
    }

    /// The numeric model of `model` with explicit parameter values.
    pub fn with_params(model: &Model, params: &[f64]) -> Result<NumericSystem, AdapterError> {
        if params.len() != model.parameters.len() {
            return Err(AdapterError::ParamCount {
                model: model.name.clone(),
                expected: model.parameters.len(),
                found: params.len(),
            });
        }
        Ok(NumericSystem {
            model: NumericModel::new(model, params),
            coords: coordinate_names(model),
            cons: constraint_row_names(model),
        })
    }

    /// The wrapped numeric model.
    pub fn model(&self) -> &NumericModel {
        &self.model
    }
}

impl System for NumericSystem {
    fn dof(&self) -> usize {
        self.model.dof()
    }
    fn rows(&self) -> usize {
        self.model.constraint_rows()
    }
    fn coordinate_names(&self) -> &[String] {
        &self.coords
    }
    fn constraint_names(&self) -> &[String] {
        &self.cons
    }
    fn backend(&self) -> &'static str {
        "numeric"
    }

    fn evaluate(&self, q: &[f64], qd: &[f64], t: f64, ws: &mut Workspace) {
        ws.m.copy_from(&self.model.mass_matrix(q));
        ws.f.copy_from(&self.model.f_vector(q, qd));
        ws.q.copy_from(&self.model.q_vector(q, qd, t));
        self.evaluate_positions(q, ws);
        ws.a.copy_from(&self.model.constraint_bias(q, qd));
    }

    fn evaluate_positions(&self, q: &[f64], ws: &mut Workspace) {
        ws.h.copy_from(&self.model.constraints(q));
        ws.j.copy_from(&self.model.constraint_jacobian(q));
    }

    fn potential_energy(&self, q: &[f64]) -> Option<f64> {
        Some(self.model.potential_energy(q))
    }
}
