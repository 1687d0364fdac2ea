//! The [`Simulator`]: a closed-loop run in independent coordinates (eqs. 18–25).
//!
//! It holds the accepted state `(t, q, q')`, the partition in use, the scratch of the last
//! evaluation of the reduced equations ([`super::rhs`]) and the counters. Preparing a run
//! ([`Simulator::new`]) checks the settings and the initial state, examines the rank of `J`
//! ([`super::partitioning`]), applies the user's partition if any, and projects the
//! dependent coordinates and velocities to rounding level. [`Simulator::run`] hands the
//! state to the integrator driver ([`super::dopri`] or [`super::rk4`]), which calls back
//! here to accept steps and emit the output samples.

use nalgebra::{DMatrix, DVector};

use crate::partition::{Partition, PartitionChoice, ReduceWorkspace, Reduced};

use super::error::{SettingsError, SimError};
use super::partitioning::{InitialRank, examine_rank, singular_range};
use super::projection::Projector;
use super::settings::{Method, Settings};
use super::trajectory::{Event, OutputRow, PartitionChange, Stats, Trajectory};
use mbs_symbolic::runtime::{System, Workspace};

/// Runs a simulation from a consistent state and collects the output.
///
/// `q0`, `qd0` must satisfy the constraints (use `closed_loop::assembly` first); the dependent
/// coordinates are re-projected to rounding level before the start.
pub fn simulate<S: System + ?Sized>(
    sys: &S,
    settings: Settings,
    q0: &[f64],
    qd0: &[f64],
) -> Result<Trajectory, SimError> {
    let mut sim = Simulator::new(sys, settings, q0, qd0)?;
    let mut rows = Vec::new();
    sim.run(&mut |e| {
        if let Event::Output(r) = e {
            rows.push(r.clone());
        }
    })?;
    Ok(Trajectory {
        rows,
        changes: sim.changes().to_vec(),
        stats: sim.stats().clone(),
        initial_independent: sim.initial_independent().to_vec(),
        final_independent: sim.independent_names(),
        dropped_rows: sim.dropped_rows().to_vec(),
    })
}

/// A closed-loop simulation in progress: the accepted state, the partition and the
/// scratch buffers. [`simulate`] is the one-call form.
pub struct Simulator<'s, S: System + ?Sized> {
    pub(super) sys: &'s S,
    pub(super) settings: Settings,
    pub(super) ws: Workspace,
    pub(super) proj: Projector,
    pub(super) red: Reduced,
    pub(super) rws: ReduceWorkspace,
    /// `J` restricted to the active rows, at the last evaluation.
    pub(super) jr: DMatrix<f64>,
    /// `A` restricted to the active rows, at the last evaluation.
    pub(super) ar: DVector<f64>,
    pub(super) partition: Partition,
    /// Rank of `J` at the start (the number of active constraint rows).
    pub(super) expected_rank: usize,
    pub(super) dropped: Vec<String>,
    pub(super) initial_independent: Vec<String>,
    // Accepted state.
    pub(super) t: f64,
    pub(super) q: Vec<f64>,
    pub(super) qd: Vec<f64>,
    /// `B` at the accepted state, for the warm start of the projection.
    pub(super) b_acc: DMatrix<f64>,
    /// `cond(J_v)` at the accepted state.
    pub(super) cond: f64,
    // Scratch of the last evaluation.
    pub(super) qt: Vec<f64>,
    pub(super) qdt: Vec<f64>,
    pub(super) udd: DVector<f64>,
    pub(super) last_cond: f64,
    pub(super) stats: Stats,
    pub(super) changes: Vec<PartitionChange>,
    pub(super) next_output: usize,
    pub(super) output_count: usize,
    /// Polled before every step: `true` ends the run with [`SimError::Stopped`].
    pub(super) stop: Option<fn() -> bool>,
}

/// `name = value` of every coordinate, for error messages.
pub(super) fn fmt_coords(names: &[String], q: &[f64]) -> String {
    names
        .iter()
        .zip(q)
        .map(|(n, v)| format!("{n} = {v:.9}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Checks the sizes and the finiteness of the initial state.
fn check_initial_state<S: System + ?Sized>(
    sys: &S,
    settings: &Settings,
    q0: &[f64],
    qd0: &[f64],
) -> Result<(), SimError> {
    let n = sys.dof();
    if q0.len() != n || qd0.len() != n {
        return Err(SimError::Settings(SettingsError::StateSize {
            coordinates: q0.len(),
            velocities: qd0.len(),
            dof: n,
        }));
    }
    if q0.iter().chain(qd0).any(|x| !x.is_finite()) {
        return Err(SimError::Diverged {
            t: settings.t_start,
            cause: "non-finite initial state".into(),
            coordinates: fmt_coords(sys.coordinate_names(), q0),
        });
    }
    Ok(())
}

impl<'s, S: System + ?Sized> Simulator<'s, S> {
    /// Prepares a run from a consistent state: checks the settings, examines the rank of
    /// `J` (redundant rows are diagnosed by name, or dropped when allowed; a rank drop
    /// that disappears nearby is a singular configuration), chooses the partition and
    /// projects the dependent coordinates and velocities (eq. 18) to rounding level.
    pub fn new(sys: &'s S, settings: Settings, q0: &[f64], qd0: &[f64]) -> Result<Self, SimError> {
        settings.validate()?;
        check_initial_state(sys, &settings, q0, qd0)?;
        let InitialRank {
            ws,
            choice,
            active,
            dropped,
        } = examine_rank(sys, &settings, q0)?;
        let mut sim =
            Simulator::with_partition(sys, settings, ws, &choice, active, dropped, q0, qd0);
        sim.apply_user_partition(choice.partition)?;
        sim.initial_independent = sim.independent_names();
        let (n, rank) = (sys.dof(), choice.rank);
        // A change to the user's partition cleared `B`; the warm start of the first
        // evaluation uses `B = 0`.
        sim.b_acc = DMatrix::zeros(rank, n - rank);
        sim.project_initial_positions()?;
        sim.project_initial_velocities(q0)?;
        Ok(sim)
    }

    /// The simulator at `(t_start, q0, qd0)` with the automatic partition of `choice` and
    /// buffers of the right shapes; nothing projected yet.
    #[allow(clippy::too_many_arguments)]
    fn with_partition(
        sys: &'s S,
        settings: Settings,
        ws: Workspace,
        choice: &PartitionChoice,
        active: Vec<usize>,
        dropped: Vec<String>,
        q0: &[f64],
        qd0: &[f64],
    ) -> Self {
        let n = sys.dof();
        let rank = choice.rank;
        Simulator {
            sys,
            ws,
            proj: Projector::new(n, active, settings.projection_tol),
            red: Reduced::empty(),
            rws: ReduceWorkspace::new(),
            jr: DMatrix::zeros(rank, n),
            ar: DVector::zeros(rank),
            partition: choice.partition.clone(),
            expected_rank: rank,
            dropped,
            initial_independent: vec![],
            t: settings.t_start,
            q: q0.to_vec(),
            qd: qd0.to_vec(),
            b_acc: DMatrix::zeros(rank, n - rank),
            cond: choice.condition,
            qt: q0.to_vec(),
            qdt: qd0.to_vec(),
            udd: DVector::zeros(n - rank),
            last_cond: choice.condition,
            stats: Stats {
                final_time: settings.t_start,
                min_step: f64::INFINITY,
                ..Stats::default()
            },
            changes: vec![],
            next_output: 0,
            output_count: 0,
            stop: None,
            settings,
        }
    }

    /// Polls `stop` before every step: when it returns `true` the run ends with
    /// [`SimError::Stopped`] (e.g. an interrupt asked by the user).
    pub fn set_stop(&mut self, stop: fn() -> bool) {
        self.stop = Some(stop);
    }

    /// [`SimError::Stopped`] when the stop polled says so.
    pub(super) fn check_stop(&self) -> Result<(), SimError> {
        match self.stop {
            Some(stop) if stop() => Err(SimError::Stopped { t: self.t }),
            _ => Ok(()),
        }
    }

    /// Projects the dependent coordinates of the initial configuration to rounding level
    /// (skipped when the residual is already there, so that the coordinates the user held
    /// keep their exact values).
    fn project_initial_positions(&mut self) -> Result<(), SimError> {
        self.sys.evaluate_positions(&self.q, &mut self.ws);
        self.proj.load_active_jacobian(&self.ws);
        let initial_residual = self.ws.h.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let mut qt = std::mem::take(&mut self.qt);
        qt.copy_from_slice(&self.q);
        let projected = if initial_residual <= 1e-15 {
            Ok(None)
        } else {
            self.proj
                .project(self.sys, &mut self.ws, &self.partition, &mut qt)
                .map(Some)
        };
        self.qt = qt;
        match projected {
            Ok(p) => self.stats.newton_iterations += p.map_or(0, |p| p.iterations),
            Err(e) => {
                return Err(self.diverged(format!(
                    "the initial configuration does not satisfy the constraints ({e}); \
                     assemble it first"
                )));
            }
        }
        self.q.copy_from_slice(&self.qt);
        Ok(())
    }

    /// Checks `J q' = 0` at the projected configuration and makes the dependent
    /// velocities satisfy eq. (18) exactly. `q0` (the configuration given) names the
    /// coordinates in the error.
    fn project_initial_velocities(&mut self, q0: &[f64]) -> Result<(), SimError> {
        let vel_res = {
            let qdv = DVector::from_column_slice(&self.qd);
            let r = &self.proj.j * qdv;
            r.iter().fold(0.0f64, |m, x| m.max(x.abs()))
        };
        let vel_scale = self.proj.j.iter().fold(0.0f64, |m, x| m.max(x.abs()))
            * self.qd.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if vel_res > 1e-6 * vel_scale.max(f64::MIN_POSITIVE) {
            return Err(SimError::Diverged {
                t: self.t,
                cause: format!(
                    "the initial velocities violate J q' = 0 (max |J q'| = {vel_res:.3e}); \
                     assemble them first"
                ),
                coordinates: fmt_coords(self.sys.coordinate_names(), q0),
            });
        }
        let mut qd = std::mem::take(&mut self.qd);
        let part = self.partition.clone();
        let cond = self
            .proj
            .velocities(&part, &mut qd)
            .map_err(|e| SimError::Partition(e.into()))?;
        self.qd = qd;
        self.cond = cond;
        Ok(())
    }

    /// The counters so far (also valid after a failed run).
    pub fn stats(&self) -> &Stats {
        &self.stats
    }

    /// Partition changes so far.
    pub fn changes(&self) -> &[PartitionChange] {
        &self.changes
    }

    /// Constraint rows dropped as redundant.
    pub fn dropped_rows(&self) -> &[String] {
        &self.dropped
    }

    /// The current independent coordinates, by name.
    pub fn independent_names(&self) -> Vec<String> {
        self.names_of(&self.partition.independent)
    }

    /// The independent coordinates at the start, by name.
    pub fn initial_independent(&self) -> &[String] {
        &self.initial_independent
    }

    /// The current partition.
    pub fn partition(&self) -> &Partition {
        &self.partition
    }

    /// Time and state of the last accepted step.
    pub fn state(&self) -> (f64, &[f64], &[f64]) {
        (self.t, &self.q, &self.qd)
    }

    /// The names of coordinates `idx`.
    pub(super) fn names_of(&self, idx: &[usize]) -> Vec<String> {
        let names = self.sys.coordinate_names();
        idx.iter()
            .map(|&i| names.get(i).cloned().unwrap_or_else(|| format!("q[{i}]")))
            .collect()
    }

    /// Runs to `t_end`, reporting outputs, partition changes and progress to `observer`.
    pub fn run(&mut self, observer: &mut dyn FnMut(Event<'_>)) -> Result<(), SimError> {
        let mut k1 = DVector::zeros(0);
        let mut y = self.restart(&mut k1)?;
        if self.next_output == 0 {
            let t0 = self.t;
            self.emit(t0, observer);
            self.next_output = 1;
        }
        self.output_count = self.output_total();
        match self.settings.method {
            Method::Dopri5 { .. } => self.run_dopri(&mut y, &mut k1, observer),
            Method::Rk4 { step } => self.run_rk4(step, &mut y, &mut k1, observer),
        }
    }

    /// Makes the last evaluated state the accepted one, after a step of size `h` to `t`.
    pub(super) fn accept_last(&mut self, t: f64, h: f64) {
        self.t = t;
        self.q.copy_from_slice(&self.qt);
        self.qd.copy_from_slice(&self.qdt);
        self.b_acc.clone_from(&self.red.b);
        self.cond = self.last_cond;
        let res = self.ws.h.norm();
        self.stats.max_residual = self.stats.max_residual.max(res);
        self.stats.final_time = t;
        self.stats.steps_accepted += 1;
        self.stats.min_step = self.stats.min_step.min(h);
        self.stats.max_step = self.stats.max_step.max(h);
    }

    /// Builds the output row of the last evaluated state.
    fn output_row(&mut self, t: f64) -> OutputRow {
        let qd = DVector::from_column_slice(&self.qdt);
        let kinetic_energy = 0.5 * qd.dot(&(&self.ws.m * &qd));
        OutputRow {
            t,
            q: self.qt.clone(),
            qd: self.qdt.clone(),
            kinetic_energy,
            potential_energy: Some(self.sys.potential_energy(&self.qt, &mut self.ws)),
            residual_norm: self.ws.h.norm(),
            cond_jv: self.last_cond,
        }
    }

    fn output_time(&self, k: usize) -> f64 {
        let s = &self.settings;
        (s.t_start + k as f64 * s.output_step).min(s.t_end)
    }

    /// Number of output times: the grid `t_start + k * output_step` up to `t_end`, plus
    /// `t_end` itself when it is not on the grid.
    fn output_total(&self) -> usize {
        let s = &self.settings;
        let span = (s.t_end - s.t_start) / s.output_step;
        let k = (span + 1e-9).floor() as usize;
        if (s.t_start + k as f64 * s.output_step) < s.t_end - 1e-9 * s.output_step {
            k + 2
        } else {
            k + 1
        }
    }

    /// Emits the output row of the last evaluated state at `t` and updates the energy and
    /// residual extremes.
    fn emit(&mut self, t: f64, observer: &mut dyn FnMut(Event<'_>)) {
        let row = self.output_row(t);
        self.stats.max_residual = self.stats.max_residual.max(row.residual_norm);
        self.stats.max_kinetic_energy = self.stats.max_kinetic_energy.max(row.kinetic_energy);
        if let Some(e) = row.total_energy() {
            match self.stats.initial_energy {
                None => {
                    self.stats.initial_energy = Some(e);
                    self.stats.max_energy_error = Some(0.0);
                }
                Some(e0) => {
                    let d = (e - e0).abs();
                    self.stats.max_energy_error =
                        Some(self.stats.max_energy_error.unwrap_or(0.0).max(d));
                }
            }
        }
        observer(Event::Output(&row));
    }

    /// Emits the outputs with times in `(t_old, t_old + h]` using the integrator's dense
    /// output `interp(theta)` for `y`.
    pub(super) fn outputs_in_step(
        &mut self,
        t_old: f64,
        h: f64,
        interp: &dyn Fn(f64, &mut DVector<f64>),
        observer: &mut dyn FnMut(Event<'_>),
    ) -> Result<(), SimError> {
        let t_new = t_old + h;
        let last =
            (t_new - self.settings.t_end).abs() <= 1e-12 * self.settings.t_end.abs().max(1.0);
        let mut yo = DVector::zeros(2 * self.partition.independent.len());
        let mut dy = yo.clone();
        while self.next_output < self.output_count {
            let to = self.output_time(self.next_output);
            let within = to <= t_new + 1e-12 * t_new.abs().max(1.0);
            if !(within || last) {
                break;
            }
            let theta = ((to - t_old) / h).clamp(0.0, 1.0);
            interp(theta, &mut yo);
            if let Err(e) = self.rhs(to, &yo, &mut dy) {
                return Err(self.diverged(format!("evaluation at output time {to} failed: {e}")));
            }
            self.emit(to, observer);
            self.next_output += 1;
        }
        Ok(())
    }

    /// `name = value` of every coordinate of the accepted state.
    fn error_coords(&self) -> String {
        fmt_coords(self.sys.coordinate_names(), &self.q)
    }

    /// [`SimError::Diverged`] at the accepted state.
    pub(super) fn diverged(&self, cause: String) -> SimError {
        SimError::Diverged {
            t: self.t,
            cause,
            coordinates: self.error_coords(),
        }
    }

    /// [`SimError::StepSizeTooSmall`] at the accepted state.
    pub(super) fn step_too_small(&self, h: f64, cause: String) -> SimError {
        let (lo, _) = singular_range(&self.proj.j);
        SimError::StepSizeTooSmall {
            t: self.t,
            h,
            cause,
            cond: self.cond,
            sigma_min: lo,
            coordinates: self.error_coords(),
        }
    }
}
