//! Position projection: the dependent coordinates `v` from `h(u, v) = 0` for given
//! independent coordinates `u`, by Newton iterations with `J_v` (docs/theory.md §3), warm-started
//! from a nearby consistent configuration; then the dependent velocities from eq. (18).

use nalgebra::{DMatrix, DVector};

use crate::partition::{self, Partition, PartitionError, ReduceWorkspace};

use mbs_symbolic::runtime::{System, Workspace};

/// Why a projection failed.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ProjectionError {
    /// `J_v` became singular during the iteration.
    #[error("J_v singular during the position projection: {0}")]
    Partition(#[from] PartitionError),
    /// No convergence within the iteration limit.
    #[error(
        "Newton projection did not converge in {iterations} iterations (max |h| = {residual:.3e})"
    )]
    NoConvergence {
        /// Iterations done.
        iterations: usize,
        /// `max |h_i|` at the last iterate.
        residual: f64,
    },
    /// A non-finite value appeared.
    #[error("Newton projection produced a non-finite value")]
    NonFinite,
}

/// Scratch of the projection, reused across calls.
#[derive(Clone, Debug)]
pub(crate) struct Projector {
    /// Active (non-redundant) constraint rows.
    pub rows: Vec<usize>,
    /// `J` restricted to the active rows.
    pub j: DMatrix<f64>,
    /// Right-hand side / step.
    pub dv: DVector<f64>,
    pub rws: ReduceWorkspace,
    /// Tolerance on `max |h_i|` after convergence (all rows).
    pub tol: f64,
    /// Iteration limit.
    pub max_iterations: usize,
}

/// Outcome of a successful projection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Projected {
    /// Newton iterations.
    pub iterations: usize,
    /// `max |h_i|` over all rows at the result.
    pub residual: f64,
}

impl Projector {
    pub fn new(n: usize, rows: Vec<usize>, tol: f64) -> Projector {
        let r = rows.len();
        Projector {
            rows,
            j: DMatrix::zeros(r, n),
            dv: DVector::zeros(r),
            rws: ReduceWorkspace::new(),
            tol,
            max_iterations: 25,
        }
    }

    /// Copies the active rows of `ws.j` into `self.j`.
    pub fn load_active_jacobian(&mut self, ws: &Workspace) {
        for (k, &r) in self.rows.iter().enumerate() {
            for c in 0..ws.j.ncols() {
                self.j[(k, c)] = ws.j[(r, c)];
            }
        }
    }

    /// Newton on `h(u, v) = 0` for the dependent entries of `q` (the independent ones are
    /// held; the dependent ones are the starting guess). On success `ws.h` and `ws.j` hold
    /// the values at the returned `q`, and `self.j` the active rows of `J`.
    pub fn project<S: System + ?Sized>(
        &mut self,
        sys: &S,
        ws: &mut Workspace,
        p: &Partition,
        q: &mut [f64],
    ) -> Result<Projected, ProjectionError> {
        let nv = p.dependent.len();
        let mut converged = false;
        let mut last_step = f64::INFINITY;
        for it in 0..=self.max_iterations {
            sys.evaluate_positions(q, ws);
            self.load_active_jacobian(ws);
            let residual = ws.h.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            if !residual.is_finite() {
                return Err(ProjectionError::NonFinite);
            }
            if converged || (nv == 0 && residual <= self.tol) {
                if residual <= self.tol {
                    return Ok(Projected {
                        iterations: it,
                        residual,
                    });
                }
                // The step was at rounding level but h is not small: the rows cannot be
                // satisfied with this u (outside the workspace of the partition).
                return Err(ProjectionError::NoConvergence {
                    iterations: it,
                    residual,
                });
            }
            if it == self.max_iterations || nv == 0 {
                return Err(ProjectionError::NoConvergence {
                    iterations: it,
                    residual,
                });
            }
            for (k, &r) in self.rows.iter().enumerate() {
                self.dv[k] = -ws.h[r];
            }
            partition::solve_dependent_into(&self.j, p, &mut self.rws, &mut self.dv)?;
            let mut step = 0.0f64;
            let mut size = 0.0f64;
            for (k, &i) in p.dependent.iter().enumerate() {
                q[i] += self.dv[k];
                step = step.max(self.dv[k].abs());
                size = size.max(q[i].abs());
            }
            if !step.is_finite() {
                return Err(ProjectionError::NonFinite);
            }
            // Quadratic convergence: after a step this small the remaining error is of the
            // order of its square, far below rounding.
            if step <= 1e-10 * (1.0 + size) {
                converged = true;
            }
            if it >= 4 && step > 2.0 * last_step {
                return Err(ProjectionError::NoConvergence {
                    iterations: it + 1,
                    residual,
                });
            }
            last_step = step;
        }
        Err(ProjectionError::NoConvergence {
            iterations: self.max_iterations,
            residual: f64::INFINITY,
        })
    }

    /// Dependent velocities from eq. (18) with `self.j` (the active rows at the current
    /// `q`): writes `q'[dependent]` from `q'[independent]`. Returns `cond(J_v)`.
    pub fn velocities(&mut self, p: &Partition, qd: &mut [f64]) -> Result<f64, PartitionError> {
        for k in 0..self.rows.len() {
            let mut s = 0.0;
            for &i in &p.independent {
                s += self.j[(k, i)] * qd[i];
            }
            self.dv[k] = -s;
        }
        let cond = partition::solve_dependent_into(&self.j, p, &mut self.rws, &mut self.dv)?;
        for (k, &i) in p.dependent.iter().enumerate() {
            qd[i] = self.dv[k];
        }
        Ok(cond)
    }
}
