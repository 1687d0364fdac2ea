//! The dynamic-size view of a closed-loop mechanism that the assembly, the partitioning and
//! the integrator work on: `M`, `F`, `Q` (eqs. 11–13) and `h`, `J`, `A` (eqs. 14–16) written
//! into a preallocated [`Workspace`].
//!
//! Three adapters implement [`System`] (see [`super::adapters`]): compiled-in generated
//! code (any [`mbs_symbolic::runtime::Mechanism`]), the DAG interpreter for a model read at
//! run time, and the numeric recursive reference.

use nalgebra::{DMatrix, DVector};

/// Preallocated buffers for one evaluation of a [`System`].
///
/// Created by [`System::workspace`] with the system's sizes; the evaluation methods
/// overwrite the buffers they document and leave the others untouched.
#[derive(Clone, Debug)]
pub struct Workspace {
    /// `M^b(q)` (eq. 11), `n x n`.
    pub m: DMatrix<f64>,
    /// `F^b(q, q')`: velocity terms and gravity (eq. 12).
    pub f: DVector<f64>,
    /// `Q^b(q, q', t)`: force elements, paper sign (eq. 13).
    pub q: DVector<f64>,
    /// `h(q)` (eq. 14), one entry per constraint row.
    pub h: DVector<f64>,
    /// `J(q) = dh/dq` (eq. 15), `rows x n`.
    pub j: DMatrix<f64>,
    /// `A(q, q') = J' q'` (eq. 16).
    pub a: DVector<f64>,
    /// Backend scratch space (the interpreter's tape slots); length
    /// [`System::scratch_len`].
    pub scratch: Vec<f64>,
}

impl Workspace {
    /// Zeroed buffers for `n` coordinates, `rows` constraint rows and `scratch` backend slots.
    pub fn new(n: usize, rows: usize, scratch: usize) -> Workspace {
        Workspace {
            m: DMatrix::zeros(n, n),
            f: DVector::zeros(n),
            q: DVector::zeros(n),
            h: DVector::zeros(rows),
            j: DMatrix::zeros(rows, n),
            a: DVector::zeros(rows),
            scratch: vec![0.0; scratch],
        }
    }
}

/// A mechanism with `dof()` tree coordinates and `rows()` constraint rows, evaluated into
/// caller-owned buffers (paper convention `M q'' + F + Q + J^T lambda = 0`, eq. 17).
///
/// Callers pass slices of length [`System::dof`] and a workspace made by
/// [`System::workspace`]; implementations may panic otherwise (a programming error, not
/// bad input).
pub trait System {
    /// Number of tree coordinates `n`.
    fn dof(&self) -> usize;

    /// Number of constraint rows (the length of `h`).
    fn rows(&self) -> usize;

    /// Names of the coordinates, in the model's order.
    fn coordinate_names(&self) -> &[String];

    /// Names of the constraint rows (`"<constraint>.<component>"`), in the model's order.
    fn constraint_names(&self) -> &[String];

    /// A short name of the implementation (`"generated"`, `"interpreter"`, `"numeric"`).
    fn backend(&self) -> &'static str;

    /// Length of [`Workspace::scratch`] the backend needs.
    fn scratch_len(&self) -> usize {
        0
    }

    /// A workspace with this system's sizes.
    fn workspace(&self) -> Workspace {
        Workspace::new(self.dof(), self.rows(), self.scratch_len())
    }

    /// Fills `M`, `F`, `Q`, `h`, `J` and `A` at `(q, q', t)`.
    fn evaluate(&self, q: &[f64], qd: &[f64], t: f64, ws: &mut Workspace);

    /// Fills `h` and `J` at `q` only (position-level work: assembly, projection).
    fn evaluate_positions(&self, q: &[f64], ws: &mut Workspace);

    /// Potential energy `V(q)` (gravity and springs) when the backend knows it; used for
    /// energy bookkeeping only.
    fn potential_energy(&self, q: &[f64]) -> Option<f64> {
        let _ = q;
        None
    }
}

/// `System` for references and boxes: every method forwards to the pointee.
macro_rules! forward_system {
    ($($ty:ty),*) => {$(
        impl<S: System + ?Sized> System for $ty {
            fn dof(&self) -> usize {
                (**self).dof()
            }
            fn rows(&self) -> usize {
                (**self).rows()
            }
            fn coordinate_names(&self) -> &[String] {
                (**self).coordinate_names()
            }
            fn constraint_names(&self) -> &[String] {
                (**self).constraint_names()
            }
            fn backend(&self) -> &'static str {
                (**self).backend()
            }
            fn scratch_len(&self) -> usize {
                (**self).scratch_len()
            }
            fn evaluate(&self, q: &[f64], qd: &[f64], t: f64, ws: &mut Workspace) {
                (**self).evaluate(q, qd, t, ws)
            }
            fn evaluate_positions(&self, q: &[f64], ws: &mut Workspace) {
                (**self).evaluate_positions(q, ws)
            }
            fn potential_energy(&self, q: &[f64]) -> Option<f64> {
                (**self).potential_energy(q)
            }
        }
    )*};
}

forward_system!(&S, Box<S>);
