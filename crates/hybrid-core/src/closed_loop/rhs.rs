//! The reduced right-hand side `y' = (u', u'')` of a closed-loop mechanism in independent
//! coordinates: `M^R u'' + F^R + Q^R = 0` (eqs. 22–25; docs/theory.md §3).
//!
//! The state is `y = (u, u')`. One evaluation:
//!
//! 1. dependent coordinates `v` from `h(u, v) = 0` by Newton iterations with `J_v`
//!    ([`super::projection`]), warm-started from the last accepted configuration plus the
//!    first-order prediction `B (u - u_accepted)`;
//! 2. dependent velocities from eq. (18), `J_v v' = -J_u u'`;
//! 3. `M`, `F`, `Q`, `J`, `A` at `(q, q', t)` from the [`System`];
//! 4. `M^R`, `F^R`, `Q^R` from eqs. (23)–(25) ([`crate::partition::reduce_into`]) and
//!    `u''` from eq. (22) by Cholesky.
//!
//! So `v(u)` is solved to rounding level at every stage and every accepted step: the
//! constraint residual never drifts, and the integrated ODE is smooth in `u`, which keeps
//! the error estimates and the order of the method intact.

use std::fmt;

use nalgebra::DVector;

use crate::partition::{self, PartitionError};

use super::error::SimError;
use super::projection::ProjectionError;
use super::simulator::Simulator;
use mbs_symbolic::runtime::System;

/// Why one evaluation of the reduced equations failed (the step is retried smaller).
#[derive(Clone, Debug)]
pub(super) enum StageError {
    Projection(ProjectionError),
    Reduction(PartitionError),
    NonFinite,
}

impl fmt::Display for StageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StageError::Projection(e) => write!(f, "{e}"),
            StageError::Reduction(e) => write!(f, "{e}"),
            StageError::NonFinite => f.write_str("non-finite state or derivative"),
        }
    }
}

impl<S: System + ?Sized> Simulator<'_, S> {
    /// `y = (u, u')` of the accepted state.
    fn y_of_state(&self) -> DVector<f64> {
        let nu = self.partition.independent.len();
        DVector::from_fn(2 * nu, |i, _| {
            if i < nu {
                self.q[self.partition.independent[i]]
            } else {
                self.qd[self.partition.independent[i - nu]]
            }
        })
    }

    /// One evaluation of the reduced equations at `(t, y)`; leaves the full state in
    /// `qt`, `qdt` and the evaluation in `ws`, `red`.
    pub(super) fn rhs(
        &mut self,
        t: f64,
        y: &DVector<f64>,
        dy: &mut DVector<f64>,
    ) -> Result<(), StageError> {
        self.stats.rhs_evaluations += 1;
        let nu = self.partition.independent.len();
        if y.iter().any(|x| !x.is_finite()) {
            return Err(StageError::NonFinite);
        }
        // Warm start: accepted configuration + B (u - u_accepted).
        self.qt.copy_from_slice(&self.q);
        for (l, &i) in self.partition.independent.iter().enumerate() {
            self.qt[i] = y[l];
        }
        if self.b_acc.shape() == (self.partition.dependent.len(), nu) {
            for (k, &d) in self.partition.dependent.iter().enumerate() {
                let mut s = 0.0;
                for (l, &i) in self.partition.independent.iter().enumerate() {
                    s += self.b_acc[(k, l)] * (y[l] - self.q[i]);
                }
                self.qt[d] += s;
            }
        }
        let mut qt = std::mem::take(&mut self.qt);
        let res = self
            .proj
            .project(self.sys, &mut self.ws, &self.partition, &mut qt);
        self.qt = qt;
        let p = res.map_err(StageError::Projection)?;
        self.stats.newton_iterations += p.iterations;
        for (l, &i) in self.partition.independent.iter().enumerate() {
            self.qdt[i] = y[nu + l];
        }
        let mut qdt = std::mem::take(&mut self.qdt);
        let vres = self.proj.velocities(&self.partition, &mut qdt);
        self.qdt = qdt;
        vres.map_err(StageError::Reduction)?;
        self.sys.evaluate(&self.qt, &self.qdt, t, &mut self.ws);
        for (k, &r) in self.proj.rows.iter().enumerate() {
            for c in 0..self.ws.j.ncols() {
                self.jr[(k, c)] = self.ws.j[(r, c)];
            }
            self.ar[k] = self.ws.a[r];
        }
        partition::reduce_into(
            &self.ws.m,
            &self.ws.f,
            &self.ws.q,
            &self.jr,
            &self.ar,
            &self.partition,
            &mut self.rws,
            &mut self.red,
        )
        .map_err(StageError::Reduction)?;
        self.red
            .accelerations_into(&mut self.rws, &mut self.udd)
            .map_err(StageError::Reduction)?;
        for l in 0..nu {
            dy[l] = y[nu + l];
            dy[nu + l] = self.udd[l];
        }
        self.last_cond = self.red.jv_condition;
        if dy.iter().any(|x| !x.is_finite()) {
            return Err(StageError::NonFinite);
        }
        Ok(())
    }

    /// Evaluates `y'` at the accepted state (the first stage, also after a change of
    /// partition) and refreshes `B` for the warm start. Returns `y` of the accepted state.
    pub(super) fn restart(&mut self, k1: &mut DVector<f64>) -> Result<DVector<f64>, SimError> {
        let y = self.y_of_state();
        if k1.len() != y.len() {
            *k1 = DVector::zeros(y.len());
        }
        let t = self.t;
        self.rhs(t, &y, k1)
            .map_err(|e| self.diverged(format!("evaluation at the accepted state failed: {e}")))?;
        self.b_acc.clone_from(&self.red.b);
        self.cond = self.last_cond;
        Ok(y)
    }
}
