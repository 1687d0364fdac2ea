//! One mechanism following its attached beam points and its own free coordinates: the
//! dependent coordinates by Newton on `h = 0`, velocities and accelerations by eqs. (18)–(19)
//! and the projection `phi = R^T (M q'' + F + Q)` of its equations on the tangent space of
//! its constraints (eqs. 51–58 for any partition; see the module documentation of
//! [`crate::hybrid`]).
//!
//! The constraint rows of a mechanism are its own loop rows (eq. 14), then per attachment a
//! transverse row `P_y - y_b - w(x_b)` and, for a pin, an axial row `P_x - x_b - u(x_b)`
//! (eqs. 45–46), with `P = origin + R(angle) p(q)` the point in the structure's frame. On the
//! beam only the transverse rows depend on the structure, through `w = n^T q^c` (eq. 35), so
//! `J^c` has one row `-n^T` per attachment (eq. 54); a node of an imported model also moves
//! along `x` (`u`), and a pin there couples through both rows. The structure sees the
//! mechanism through one scalar per coupled row ([`super::model::Coupling`]).

use mbs_symbolic::runtime::Workspace;
use nalgebra::{DMatrix, DVector};

use super::model::{AttachmentKind, HybridModel};
use crate::partition::dense::{
    copy_short, lu_in_place, lu_small, lu_solve, lu_solve_small, lu_solve_transpose,
    lu_solve_transpose_small, singular_range, singular_range_2, solve_2x2, solve_transpose_2x2,
    zero_short,
};

/// One attachment as seen by its mechanism.
#[derive(Clone, Debug)]
pub(crate) struct AttachRow {
    /// Index into the model's attachments.
    pub attachment: usize,
    /// Mechanism point index.
    pub point: usize,
    /// Row of the transverse constraint (along the beam point's direction) in this
    /// mechanism's rows.
    pub row: usize,
    /// That row's direction `d` in the mechanism's ground frame, `R(angle)^T d` (`(sin,
    /// cos)` of the mounting angle for `d = y`): the row is `d . p(q) - offset - w`.
    pub along: [f64; 2],
    /// `d` itself (structure frame).
    pub direction: [f64; 2],
    /// `d . P_0`: the row's value at the undeformed point (`y` for `d = y`).
    pub offset: f64,
    /// Row of the axial constraint (pins only).
    pub axial_row: Option<usize>,
    /// Abscissa of the beam point (the axial target).
    pub x: f64,
    /// The point's undeformed `y` (the transverse target; 0 on the beam).
    pub y: f64,
    /// Index of the transverse row's coupling unknown `w` ([`HybridModel::couplings`]).
    pub coupling: usize,
    /// Index of the axial row's coupling unknown, for a pin on a point that moves along `x`.
    pub axial_coupling: Option<usize>,
}

/// Why a mechanism could not follow.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum FollowError {
    /// `J_d` singular or beyond the mechanism's `max_condition`.
    Singular {
        /// 2-norm condition number of `J_d`.
        condition: f64,
        /// Smallest singular value of `J_d`.
        sigma_min: f64,
    },
    /// Newton on `h = 0` did not converge.
    NoAssembly {
        /// Residual norm at the last iterate.
        residual: f64,
        /// Iterations made.
        iterations: usize,
    },
}

/// How the currents of inductive generators advance over the step (trapezoidal rule, the
/// electrical counterpart of the average-acceleration rule): `L i' + R i = k_e n q'`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CurrentRule<'a> {
    /// Step size (0: the current stays at its old value).
    pub h: f64,
    /// Currents at the start of the step, per force element.
    pub old: &'a [f64],
    /// Their rates at the start of the step.
    pub rate: &'a [f64],
}

/// Buffers and partition of one mechanism.
#[derive(Clone, Debug)]
pub(crate) struct Follower {
    /// Index into the model's mechanisms.
    pub mech: usize,
    n: usize,
    nb: usize,
    loops: usize,
    rows: usize,
    /// Its attachments.
    pub atts: Vec<AttachRow>,
    /// Dependent coordinates (one per row).
    pub dep: Vec<usize>,
    /// Whether `dep` is `0..rows`: `J_d` is then the leading `rows x rows` block of the
    /// column-major `jfull`, copied as one slice.
    dep_leading: bool,
    /// Per coupled row, `(row, coupling)`: the transverse row of each attachment with its
    /// coupling unknown, then its axial row for a pin on a point that moves along `x`
    /// (attachment order). The rows that `E` of eq. (18) selects.
    coupled: Vec<(usize, usize)>,
    /// Independent (free) coordinates.
    pub free: Vec<usize>,
    /// Offset of its free coordinates in the global free-coordinate list.
    pub free_offset: usize,
    /// Its force elements (indices into the model's forces).
    forces: Vec<usize>,
    /// Which excitations of the model act on it ([`Excited`]).
    excited: Excited,
    /// The constants of [`Follower::follow_pin2`] when this is a two-coordinate
    /// mechanism without loops pinned to one structure point (the double bar), `None`
    /// otherwise ([`Pin2::of`]).
    pin2: Option<Pin2>,
    /// `|origin_x| + |origin_y|` of its mount, summed as the position solve's `scale` sums
    /// it.
    origin_abs: f64,
    /// `(cos, sin)` of its mount's angle ([`super::model::Mount::rotation`]), evaluated once.
    rot: (f64, f64),
    ws: Workspace,
    jfull: DMatrix<f64>,
    h: DVector<f64>,
    bias: DVector<f64>,
    lu: DMatrix<f64>,
    piv: Vec<usize>,
    rhs: DVector<f64>,
    svd: DMatrix<f64>,
    jd: DMatrix<f64>,
    /// Coordinates (last evaluation); read with [`Follower::q`], set with
    /// [`Follower::set_q`] (which forgets the position solve's record, [`Follower::drift`]).
    q: DVector<f64>,
    /// Velocities.
    pub qd: DVector<f64>,
    /// Accelerations.
    pub qdd: DVector<f64>,
    g: DVector<f64>,
    /// 2-norm condition number of `J_d` at the last evaluation.
    pub condition: f64,
    /// Smallest singular value of `J_d`.
    pub sigma_min: f64,
    /// Constraint residual norm after the position solve.
    pub residual: f64,
    /// Whether `lu` and `jfull` hold the last converged position solve, made at the
    /// attachment displacements `w_last` and free coordinates `u_last`.
    solved: bool,
    w_last: Vec<f64>,
    u_last: Vec<f64>,
    /// How far (2-norm, summed over the predictions taken as solutions since) `q` lies from
    /// the point at which `jfull` and the LU were evaluated, while `q` holds the last
    /// position solve's result; infinite when unknown or when anything else has moved `q`
    /// (a secant move, [`Follower::set_q`]).
    drift: f64,
}

impl Follower {
    /// Buffers for mechanism `mech` of `model` with partition `free` (the rest dependent).
    pub fn new(model: &HybridModel, mech: usize, free: Vec<usize>, free_offset: usize) -> Self {
        let sys = &model.mechanisms[mech].system;
        let (n, loops) = (sys.dof(), sys.rows());
        let couplings = model.couplings();
        let mut atts = Vec::new();
        let mut row = loops;
        for (i, a) in model.attachments.iter().enumerate() {
            if a.mechanism != mech {
                continue;
            }
            let axial_row = (a.kind == AttachmentKind::Pin).then_some(row + 1);
            let find = |axial: bool| {
                couplings
                    .iter()
                    .position(|c| c.attachment == i && c.axial == axial)
            };
            let d = a.beam.direction;
            let mount = &model.mechanisms[mech].mount;
            atts.push(AttachRow {
                attachment: i,
                point: a.point,
                row,
                along: mount.to_ground(d),
                direction: d,
                offset: d[0] * a.beam.x + d[1] * a.beam.y,
                axial_row,
                x: a.beam.x,
                y: a.beam.y,
                coupling: find(false).expect("every attachment couples along y"),
                axial_coupling: find(true),
            });
            row += a.kind.rows();
        }
        let rows = row;
        let dep: Vec<usize> = (0..n).filter(|c| !free.contains(c)).collect();
        let coupled = coupled_rows(&atts);
        let forces = (0..model.forces.len())
            .filter(|&f| model.forces[f].mechanism == mech)
            .collect();
        let q = DVector::from_column_slice(&model.mechanisms[mech].initial_q);
        let origin_abs = origin_abs(&model.mechanisms[mech].mount.origin);
        let pin2 = Pin2::of(n, loops, &atts, &free, origin_abs);
        Follower {
            mech,
            n,
            nb: couplings.len(),
            loops,
            rows,
            atts,
            dep_leading: leading(&dep, rows),
            coupled,
            dep,
            free,
            free_offset,
            forces,
            excited: Excited {
                joint: model.has_joint_excitation(mech),
                base: model.has_base_excitation(),
            },
            pin2,
            origin_abs,
            rot: model.mechanisms[mech].mount.rotation(),
            ws: sys.workspace(),
            jfull: DMatrix::zeros(rows, n),
            h: DVector::zeros(rows),
            bias: DVector::zeros(rows),
            lu: DMatrix::zeros(rows, rows),
            piv: Vec::with_capacity(rows),
            rhs: DVector::zeros(rows),
            svd: DMatrix::zeros(rows, rows),
            jd: DMatrix::zeros(rows, rows),
            q,
            qd: DVector::zeros(n),
            qdd: DVector::zeros(n),
            g: DVector::zeros(n),
            condition: 1.0,
            sigma_min: 1.0,
            residual: 0.0,
            solved: false,
            w_last: vec![0.0; couplings.len()],
            u_last: vec![0.0; n],
            drift: f64::INFINITY,
        }
    }

    /// The coordinates of the last evaluation.
    pub fn q(&self) -> &DVector<f64> {
        &self.q
    }

    /// Sets the coordinates (the start of the next position solve); the next evaluation
    /// iterates from them.
    pub fn set_q(&mut self, q: &[f64]) {
        self.q.as_mut_slice().copy_from_slice(q);
        self.drift = f64::INFINITY;
    }

    /// Constraint rows (loops + attachments).
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// The full constraint Jacobian `dh/dq` of the last position evaluation.
    pub fn jacobian(&self) -> &DMatrix<f64> {
        &self.jfull
    }

    /// Changes the partition (free coordinates; the rest dependent).
    pub fn set_free(&mut self, free: &[usize]) {
        self.free.clear();
        self.free.extend_from_slice(free);
        self.dep.clear();
        let f = &self.free;
        self.dep.extend((0..self.n).filter(|c| !f.contains(c)));
        self.dep_leading = leading(&self.dep, self.rows);
        self.pin2 = Pin2::of(self.n, self.loops, &self.atts, &self.free, self.origin_abs);
        self.solved = false;
    }

    /// First-order prediction of the dependent coordinates for new attachment
    /// displacements `w` and free coordinates (already in `q`) from the last converged solve:
    /// `q_d += J_d^-1 (E dw - J_f du)` with the factors kept from that solve (one Newton step
    /// without an evaluation; the Newton iteration then starts at a residual of second order
    /// in the change).
    ///
    /// Returns the prediction's distance from the point where the factors were evaluated
    /// ([`Follower::drift`] plus the move) when the prediction may be taken as the solution
    /// without an evaluation, else `None`: when that distance is within a settled Newton
    /// step ([`settled`]). The solve accepts an iterate whose correction is that small; the
    /// prediction is exact to first order in the move (`J_d^-1` of the change of the rows'
    /// right-hand side) with factors from within the same distance, so its residual differs
    /// from the accepted solution's by terms of second order in a step of 1e-13 of the
    /// coordinates' scale, far below rounding, and the factors are as close to it as the
    /// accepted solution's own (evaluated before its last step). It is what the
    /// evaluation's first Newton iteration would find settled, less the rows, `J`, its
    /// factorisation and a correction of rounding size. The iterations within one time step
    /// move the attachment by `beta h^2` times the change of the unknown acceleration, some
    /// 1e-16 of the coordinates, and qualify when the first correction is small (the
    /// paper's damper at 20 elements); the move between time steps, `h w'`, does not.
    #[inline(always)]
    fn predict<R: Dim>(&mut self, r: R, w: &[f64]) -> Option<f64> {
        if !self.solved {
            return None;
        }
        let rows = r.get();
        let rhs = &mut self.rhs.as_mut_slice()[..rows];
        zero_short(rhs);
        for &(r, c) in &self.coupled {
            rhs[r] = w[c] - self.w_last[c];
        }
        let q = self.q.as_mut_slice();
        let jfull = self.jfull.as_slice();
        let mut free_move = 0.0;
        for &c in &self.free {
            let du = q[c] - self.u_last[c];
            free_move += du.abs();
            for (r, j) in rhs.iter_mut().zip(&jfull[c * rows..(c + 1) * rows]) {
                *r -= j * du;
            }
        }
        self.solve_lu(r);
        let rhs = &self.rhs.as_slice()[..rows];
        let q = self.q.as_mut_slice();
        if self.dep_leading {
            for (qc, d) in q[..rows].iter_mut().zip(rhs) {
                *qc += d;
            }
        } else {
            for (&c, d) in self.dep.iter().zip(rhs) {
                q[c] += d;
            }
        }
        let moved = self.drift + (free_move + norm(rhs));
        settled(moved, q).then_some(moved)
    }

    /// `rhs = J_d^-1 rhs` with the factors in `lu`, `piv` (`rows` rows).
    #[inline(always)]
    fn solve_lu<R: Dim>(&mut self, r: R) {
        let rows = r.get();
        let (lu, b) = (self.lu.as_slice(), self.rhs.as_mut_slice());
        if rows > 2 || !lu_solve_small(&lu[..rows * rows], &self.piv, &mut b[..rows]) {
            lu_solve(&self.lu, &self.piv, &mut self.rhs);
        }
    }

    /// Kinematic influence `dq_joint / dw_k` of attachment `attachment`'s displacement on
    /// coordinate `joint` at the configuration `q` (attachment displacements `w`), free
    /// coordinates held: the column of `R` for `w_k` (eq. 18), the velocity amplification of
    /// the mechanism. `None` when the attachment is not this mechanism's or `J_d` is
    /// singular. Re-evaluates the constraint Jacobian at `q` (the position solve's factors
    /// are then those of `q`).
    pub fn influence(
        &mut self,
        model: &HybridModel,
        q: &[f64],
        w: &[f64],
        attachment: usize,
        joint: usize,
    ) -> Option<f64> {
        let row = self.atts.iter().find(|a| a.attachment == attachment)?.row;
        if self.free.contains(&joint) {
            return Some(0.0);
        }
        self.q.as_mut_slice().copy_from_slice(q);
        self.eval_rows(model, w);
        if !self.factor_dependent() {
            self.solved = false;
            return None;
        }
        self.mark_solved(w);
        self.rhs.fill(0.0);
        self.rhs[row] = 1.0;
        lu_solve(&self.lu, &self.piv, &mut self.rhs);
        let k = self.dep.iter().position(|&c| c == joint)?;
        Some(self.rhs[k])
    }

    /// Records a converged solve (for [`Follower::predict`]).
    #[inline(always)]
    fn mark_solved(&mut self, w: &[f64]) {
        self.solved = true;
        self.drift = f64::INFINITY;
        for &(_, c) in &self.coupled {
            self.w_last[c] = w[c];
        }
        let q = self.q.as_slice();
        for &c in &self.free {
            self.u_last[c] = q[c];
        }
    }

    /// `h` and `J` at `self.q` for beam-point displacements `w` (global attachment order).
    pub fn eval_rows(&mut self, model: &HybridModel, w: &[f64]) {
        self.eval_rows_sized(Dyn(self.rows), Dyn(self.n), model, w);
    }

    /// [`Follower::eval_rows`] for `r` rows and `n` coordinates ([`Dim`]).
    #[inline(always)]
    fn eval_rows_sized<R: Dim, N: Dim>(&mut self, r: R, n: N, model: &HybridModel, w: &[f64]) {
        let m = &model.mechanisms[self.mech];
        let rows = r.get();
        let h = &mut self.h.as_mut_slice()[..rows];
        let jfull = &mut self.jfull.as_mut_slice()[..rows * n.get()];
        if self.loops > 0 {
            m.system.evaluate_positions(self.q.as_slice(), &mut self.ws);
            // The loop rows are the first `loops` of every column (column-major).
            let loops = self.loops;
            copy_short(&mut h[..loops], &self.ws.h.as_slice()[..loops]);
            for (dst, src) in jfull
                .chunks_exact_mut(rows)
                .zip(self.ws.j.as_slice().chunks_exact(loops))
            {
                copy_short(&mut dst[..loops], src);
            }
        }
        let (cs, sn) = self.rot;
        for a in &self.atts {
            // Position and Jacobian only (no bias: eval_rows needs none).
            m.system
                .point_position(a.point, self.q.as_slice(), &mut self.ws);
            let p = m
                .mount
                .to_beam_with(self.rot, [self.ws.point_p[0], self.ws.point_p[1]]);
            // Exactly `p_y - y - w` and `sin jx + cos jy` for the direction `y`.
            let (d, e) = (a.direction, a.along);
            h[a.row] = (d[0] * p[0] + d[1] * p[1]) - a.offset - w[a.coupling];
            // Column-major: `J[:, c]` is `jfull[c*rows ..]`, the point's `point_j[3c ..]`.
            let pj = self.ws.point_j.as_slice().chunks_exact(3);
            for (col, pj) in jfull.chunks_exact_mut(rows).zip(pj) {
                let (jx, jy) = (pj[0], pj[1]);
                col[a.row] = e[0] * jx + e[1] * jy;
                if let Some(r) = a.axial_row {
                    col[r] = cs * jx - sn * jy;
                }
            }
            if let Some(r) = a.axial_row {
                h[r] = p[0] - a.x - a.axial_coupling.map_or(0.0, |c| w[c]);
            }
        }
    }

    /// Copies `J_d = J[:, dep]` into the LU buffer and factorises it.
    fn factor_dependent(&mut self) -> bool {
        self.factor_sized(Dyn(self.rows))
    }

    /// [`Follower::factor_dependent`] for `r` rows ([`Dim`]): [`lu_small`] on the buffer
    /// cut to `rows x rows` for up to two rows (what [`lu_in_place`] does for them).
    #[inline(always)]
    fn factor_sized<R: Dim>(&mut self, r: R) -> bool {
        let rows = r.get();
        dependent_columns(
            self.jfull.as_slice(),
            rows,
            &self.dep,
            self.dep_leading,
            self.lu.as_mut_slice(),
        );
        if rows <= 2 {
            self.piv.clear();
            return lu_small(&mut self.lu.as_mut_slice()[..rows * rows], &mut self.piv);
        }
        lu_in_place(&mut self.lu, &mut self.piv)
    }

    /// 2-norm condition of `J_d` (from the current `jfull`) into `condition`, `sigma_min`.
    pub fn refresh_condition(&mut self) {
        self.measure_condition();
    }

    /// The power of the mechanism model's own force elements at `(q, q')`: their dissipation
    /// `D` (model dampers) and input power `P` (constant joint forces, external loads), see
    /// [`mbs_symbolic::runtime::System::element_power`]. Allocation-free.
    pub fn element_power(
        &mut self,
        model: &HybridModel,
        q: &[f64],
        qd: &[f64],
    ) -> mbs_symbolic::runtime::ElementPower {
        model.mechanisms[self.mech]
            .system
            .element_power(q, qd, &mut self.ws)
    }

    /// [`Follower::element_power`] at the follower's own `(q, q')` (the last solve).
    pub fn current_element_power(
        &mut self,
        model: &HybridModel,
    ) -> mbs_symbolic::runtime::ElementPower {
        model.mechanisms[self.mech].system.element_power(
            self.q.as_slice(),
            self.qd.as_slice(),
            &mut self.ws,
        )
    }

    /// The power of the supports' inertial loads on this mechanism per unit support
    /// acceleration at `(q, q')` ([`HybridModel::base_power_mechanism`]).
    pub fn base_power(&mut self, model: &HybridModel, q: &[f64], qd: &[f64]) -> f64 {
        model.base_power_mechanism(self.mech, q, qd, &mut self.ws)
    }

    /// [`Follower::base_power`] at the follower's own `(q, q')` (the last solve).
    pub fn current_base_power(&mut self, model: &HybridModel) -> f64 {
        model.base_power_mechanism(
            self.mech,
            self.q.as_slice(),
            self.qd.as_slice(),
            &mut self.ws,
        )
    }

    /// Kinetic energy `q'^T M q' / 2` (rotors included) and potential energy (gravity and
    /// model springs) at `(q, q')`.
    pub fn energies(
        &mut self,
        model: &HybridModel,
        t: f64,
        q: &[f64],
        qd: &[f64],
        currents: &[f64],
    ) -> (f64, f64) {
        let sys = &model.mechanisms[self.mech].system;
        sys.evaluate(q, qd, t, &mut self.ws);
        model.add_joint_forces(
            self.mech,
            t,
            q,
            qd,
            currents,
            &mut self.ws.m,
            &mut self.ws.q,
        );
        let mut ke = 0.0;
        for i in 0..self.n {
            for j in 0..self.n {
                ke += qd[i] * self.ws.m[(i, j)] * qd[j];
            }
        }
        (0.5 * ke, sys.potential_energy(q, &mut self.ws))
    }

    #[inline(always)]
    fn measure_condition(&mut self) {
        // A 2 x 2 `J_d` (the double bar) read from `J` directly, without the copy into `jd`.
        if let (2, &[d0, d1]) = (self.rows, self.dep.as_slice()) {
            let j = self.jfull.as_slice();
            let (lo, hi) = singular_range_2([j[2 * d0], j[2 * d0 + 1], j[2 * d1], j[2 * d1 + 1]]);
            self.sigma_min = lo;
            self.condition = if lo > 0.0 { hi / lo } else { f64::INFINITY };
            return;
        }
        dependent_columns(
            self.jfull.as_slice(),
            self.rows,
            &self.dep,
            self.dep_leading,
            self.jd.as_mut_slice(),
        );
        let (lo, hi) = singular_range(&self.jd, &mut self.svd);
        self.sigma_min = lo;
        self.condition = if lo > 0.0 { hi / lo } else { f64::INFINITY };
    }

    /// Solves `h(q) = 0` for the dependent coordinates with the free ones at their values in
    /// `self.q`, from the dependent values in `self.q` (the guess selects the assembly
    /// branch). Step length limited to [`POSITION_STEP_LIMIT`]. On success `jfull` and the LU of `J_d` hold the
    /// solution's values (to the last, below-tolerance Newton step). For `r` rows and `n`
    /// coordinates ([`Dim`]).
    #[inline(always)]
    fn solve_positions<R: Dim, N: Dim>(
        &mut self,
        r: R,
        n: N,
        model: &HybridModel,
        w: &[f64],
    ) -> Result<(), FollowError> {
        let rows = r.get();
        if rows == 0 {
            self.residual = 0.0;
            self.condition = 1.0;
            self.sigma_min = 1.0;
            return Ok(());
        }
        let scale = 1.0
            + self
                .atts
                .iter()
                .map(|a| {
                    a.x.abs()
                        + w[a.coupling].abs()
                        + a.axial_coupling.map_or(0.0, |c| a.y.abs() + w[c].abs())
                })
                .sum::<f64>()
            + self.origin_abs;
        if let Some(moved) = self.predict(r, w) {
            self.mark_solved(w);
            self.drift = moved;
            return Ok(());
        }
        self.solved = false;
        let mut last = f64::INFINITY;
        for it in 0..POSITION_ITERATIONS {
            self.eval_rows_sized(r, n, model, w);
            let rn = norm(&self.h.as_slice()[..rows]);
            if !rn.is_finite() {
                return Err(FollowError::NoAssembly {
                    residual: rn,
                    iterations: it,
                });
            }
            last = rn;
            let jmax = amax(&self.jfull.as_slice()[..rows * n.get()]);
            if !self.factor_sized(r)
                || (self.lu.as_slice()[..rows * rows].iter().step_by(rows + 1))
                    .any(|d| d.abs() <= POSITION_PIVOT_TOL * jmax.max(1e-300))
            {
                self.measure_condition();
                return Err(FollowError::Singular {
                    condition: f64::INFINITY,
                    sigma_min: self.sigma_min,
                });
            }
            copy_short(
                &mut self.rhs.as_mut_slice()[..rows],
                &self.h.as_slice()[..rows],
            );
            self.solve_lu(r);
            let rhs = &self.rhs.as_slice()[..rows];
            let (step, len) = limited_step(norm(rhs));
            let q = &mut self.q.as_mut_slice()[..n.get()];
            if self.dep_leading {
                for (qc, d) in q[..rows].iter_mut().zip(rhs) {
                    *qc -= step * d;
                }
            } else {
                for (&c, d) in self.dep.iter().zip(rhs) {
                    q[c] -= step * d;
                }
            }
            if settled(len, q) {
                if rn <= POSITION_RESIDUAL_TOL * scale {
                    self.residual = rn;
                    self.mark_solved(w);
                    self.drift = len;
                    return Ok(());
                }
                return Err(FollowError::NoAssembly {
                    residual: rn,
                    iterations: it + 1,
                });
            }
        }
        if last <= POSITION_RESIDUAL_TOL * scale {
            // Reached to rounding, but the Newton steps do not settle: J_d is too
            // ill-conditioned to pin the coordinates down — the toggle, not the reach.
            self.measure_condition();
            return Err(FollowError::Singular {
                condition: self.condition,
                sigma_min: self.sigma_min,
            });
        }
        Err(FollowError::NoAssembly {
            residual: last,
            iterations: POSITION_ITERATIONS,
        })
    }

    /// Follows: `pos`, `vel`, `acc` hold the coupling displacements `w` (first the
    /// model's couplings, [`HybridModel::couplings`]) then the free coordinates of every mechanism (global
    /// order); writes this mechanism's projected equations `phi` into the same layout, and
    /// the currents of its force elements into `currents`. Fails when `J_d` is beyond the
    /// mechanism's `max_condition` ([`Follower::check_condition`]).
    #[allow(clippy::too_many_arguments)]
    pub fn follow(
        &mut self,
        model: &HybridModel,
        t: f64,
        pos: &[f64],
        vel: &[f64],
        acc: &[f64],
        rule: CurrentRule<'_>,
        currents: &mut [f64],
        phi: &mut [f64],
    ) -> Result<(), FollowError> {
        self.follow_trial(model, t, pos, vel, acc, rule, currents, phi)?;
        self.check_condition(model)
    }

    /// Measures the 2-norm condition of `J_d` at the last position solve into
    /// [`Follower::condition`] and [`Follower::sigma_min`]; an error beyond the mechanism's
    /// `max_condition`.
    pub fn check_condition(&mut self, model: &HybridModel) -> Result<(), FollowError> {
        self.measure_condition();
        if self.condition > model.mechanisms[self.mech].max_condition {
            return Err(FollowError::Singular {
                condition: self.condition,
                sigma_min: self.sigma_min,
            });
        }
        Ok(())
    }

    /// [`Follower::follow`] without the condition measurement: the trial evaluations of the
    /// integrator's iteration, which measures the condition once, at the accepted one
    /// ([`Follower::check_condition`]). [`Follower::condition`] keeps its last measured value.
    #[allow(clippy::too_many_arguments)]
    pub fn follow_trial(
        &mut self,
        model: &HybridModel,
        t: f64,
        pos: &[f64],
        vel: &[f64],
        acc: &[f64],
        rule: CurrentRule<'_>,
        currents: &mut [f64],
        phi: &mut [f64],
    ) -> Result<(), FollowError> {
        // The double bar pinned to the beam: straight-line code on its fixed sizes.
        if let Some(p) = self.pin2 {
            return self.follow_pin2(p, model, t, pos, vel, acc, rule, currents, phi);
        }
        // Any other two rows and two coordinates with the sizes known at compile time; the
        // same code for any other size.
        if (self.rows, self.n) == (2, 2) {
            let (r, n) = (Fixed::<2>, Fixed::<2>);
            return self.follow_sized(r, n, model, t, pos, vel, acc, rule, currents, phi);
        }
        let (r, n) = (Dyn(self.rows), Dyn(self.n));
        self.follow_sized(r, n, model, t, pos, vel, acc, rule, currents, phi)
    }

    /// [`Follower::follow_sized`] for the double bar pinned to one structure point
    /// ([`Pin2`]): the same operations in the same order, so the same results and the same
    /// buffer contents bit for bit (tested against it), written out on the two rows and
    /// two coordinates: no loops over the attachment, coupled-row and free-coordinate
    /// lists, no scatter of the solves, the buffers cut to fixed-size arrays once per call.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn follow_pin2(
        &mut self,
        p: Pin2,
        model: &HybridModel,
        t: f64,
        pos: &[f64],
        vel: &[f64],
        acc: &[f64],
        rule: CurrentRule<'_>,
        currents: &mut [f64],
        phi: &mut [f64],
    ) -> Result<(), FollowError> {
        let (c, ca) = (p.coupling, p.axial_coupling);
        let w = pos[c];
        // The axial row's coupling value (`None` for a point that does not move along `x`).
        let wa = ca.map(|k| pos[k]);
        let m = &model.mechanisms[self.mech];
        let (cs, sn) = self.rot;
        let q = fixed2(&mut self.q);
        let qd = fixed2(&mut self.qd);
        let qdd = fixed2(&mut self.qdd);
        let h = fixed2(&mut self.h);
        let rhs = fixed2(&mut self.rhs);
        let jfull = fixed4(self.jfull.as_mut_slice());
        let lu = fixed4(self.lu.as_mut_slice());
        // Position solve (solve_positions): the scale of its residual test, the prediction
        // from the last solve, Newton on `h = 0`.
        let scale = (1.0 + ((p.x.abs() + w.abs()) + wa.map_or(0.0, |v| p.y.abs() + v.abs())))
            + p.origin_abs;
        let mut converged = false;
        // The pivot row of the factors' first column (`piv = [p0, 1]` after a solve).
        let mut p0 = self.piv.first().copied().unwrap_or(0);
        if self.solved {
            let dwa = ca.map_or(0.0, |k| pos[k] - self.w_last[k]);
            *rhs = [w - self.w_last[c], dwa];
            solve_2x2(lu, p0, rhs);
            q[0] += rhs[0];
            q[1] += rhs[1];
            let moved = self.drift + (0.0 + norm(&rhs[..]));
            if settled(moved, &q[..]) {
                // mark_solved, then the prediction's distance.
                record_pin(&mut self.w_last, c, ca, pos);
                self.drift = moved;
                converged = true;
            }
        }
        let mut last = f64::INFINITY;
        let iterations = if converged {
            0
        } else {
            self.solved = false;
            POSITION_ITERATIONS
        };
        for it in 0..iterations {
            // h and J (eval_rows): the point's position and Jacobian.
            m.system.point_position(p.point, &q[..], &mut self.ws);
            let pp = m
                .mount
                .to_beam_with(self.rot, [self.ws.point_p[0], self.ws.point_p[1]]);
            let (d, e) = (p.direction, p.along);
            h[0] = (d[0] * pp[0] + d[1] * pp[1]) - p.offset - w;
            let pj = &self.ws.point_j.as_slice()[..6];
            for (col, pj) in jfull.chunks_exact_mut(2).zip(pj.chunks_exact(3)) {
                let (jx, jy) = (pj[0], pj[1]);
                col[0] = e[0] * jx + e[1] * jy;
                col[1] = cs * jx - sn * jy;
            }
            h[1] = pp[0] - p.x - wa.map_or(0.0, |v| v);
            let rn = norm(&h[..]);
            if !rn.is_finite() {
                return Err(FollowError::NoAssembly {
                    residual: rn,
                    iterations: it,
                });
            }
            last = rn;
            let jmax = amax(&jfull[..]);
            *lu = *jfull;
            self.piv.clear();
            if !lu_small(&mut lu[..], &mut self.piv)
                || [lu[0], lu[3]]
                    .iter()
                    .any(|d| d.abs() <= POSITION_PIVOT_TOL * jmax.max(1e-300))
            {
                self.measure_condition();
                return Err(FollowError::Singular {
                    condition: f64::INFINITY,
                    sigma_min: self.sigma_min,
                });
            }
            p0 = self.piv[0];
            *rhs = *h;
            solve_2x2(lu, p0, rhs);
            let (step, len) = limited_step(norm(&rhs[..]));
            q[0] -= step * rhs[0];
            q[1] -= step * rhs[1];
            if settled(len, &q[..]) {
                if rn <= POSITION_RESIDUAL_TOL * scale {
                    self.residual = rn;
                    // mark_solved, then the last step's length.
                    self.solved = true;
                    record_pin(&mut self.w_last, c, ca, pos);
                    self.drift = len;
                    converged = true;
                    break;
                }
                return Err(FollowError::NoAssembly {
                    residual: rn,
                    iterations: it + 1,
                });
            }
        }
        if !converged {
            if last <= POSITION_RESIDUAL_TOL * scale {
                // As in solve_positions: reached to rounding, the steps do not settle.
                self.measure_condition();
                return Err(FollowError::Singular {
                    condition: self.condition,
                    sigma_min: self.sigma_min,
                });
            }
            return Err(FollowError::NoAssembly {
                residual: last,
                iterations: POSITION_ITERATIONS,
            });
        }
        // Velocities (18): J_d qd = E w'.
        *rhs = [vel[c], ca.map_or(0.0, |k| vel[k])];
        solve_2x2(lu, p0, rhs);
        *qd = *rhs;
        // Dynamics and the constraint bias A = J' q' (16), (50).
        m.system
            .evaluate_with_point(p.point, &q[..], &qd[..], t, &mut self.ws);
        let (ax, ay) = (self.ws.point_a[0], self.ws.point_a[1]);
        let bias = fixed2(&mut self.bias);
        *bias = [p.along[0] * ax + p.along[1] * ay, cs * ax - sn * ay];
        add_loads(
            model,
            self.mech,
            &self.forces,
            self.excited,
            (t, &q[..], &qd[..]),
            rule,
            currents,
            &mut self.ws,
        );
        // Accelerations (19): J_d qdd = E w'' - A.
        *rhs = [acc[c] - bias[0], ca.map_or(0.0, |k| acc[k]) - bias[1]];
        solve_2x2(lu, p0, rhs);
        *qdd = *rhs;
        // g = M q'' + F + Q (the sums of follow_sized); mu = J_d^-T g, phi_w = E^T mu.
        let g = fixed2(&mut self.g);
        let (mm, f, qv) = (
            &self.ws.m.as_slice()[..4],
            &self.ws.f.as_slice()[..2],
            &self.ws.q.as_slice()[..2],
        );
        for i in 0..2 {
            g[i] = (mm[i] * qdd[0] + mm[2 + i] * qdd[1] + f[i]) + qv[i];
        }
        *rhs = *g;
        solve_transpose_2x2(lu, p0, rhs);
        phi[c] = rhs[0];
        if let Some(k) = ca {
            phi[k] = rhs[1];
        }
        Ok(())
    }

    /// [`Follower::follow_trial`] for `r` rows and `n` coordinates ([`Dim`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn follow_sized<R: Dim, N: Dim>(
        &mut self,
        r: R,
        n: N,
        model: &HybridModel,
        t: f64,
        pos: &[f64],
        vel: &[f64],
        acc: &[f64],
        rule: CurrentRule<'_>,
        currents: &mut [f64],
        phi: &mut [f64],
    ) -> Result<(), FollowError> {
        let (rows, nq) = (r.get(), n.get());
        let off = self.nb + self.free_offset;
        let q = &mut self.q.as_mut_slice()[..nq];
        for (&c, x) in self.free.iter().zip(&pos[off..]) {
            q[c] = *x;
        }
        self.solve_positions(r, n, model, pos)?;
        // Velocities (18): J_d qd_d = E w' - J_f u'.
        let qd = &mut self.qd.as_mut_slice()[..nq];
        for (&c, x) in self.free.iter().zip(&vel[off..]) {
            qd[c] = *x;
        }
        self.constraint_rhs(r, vel);
        self.solve_lu(r);
        scatter(
            &self.dep,
            self.dep_leading,
            &self.rhs.as_slice()[..rows],
            &mut self.qd.as_mut_slice()[..nq],
        );
        // Dynamics and the constraint bias A = J' q' (16), (50).
        let m = &model.mechanisms[self.mech];
        let (cs, sn) = self.rot;
        let bias = &mut self.bias.as_mut_slice()[..rows];
        zero_short(bias);
        let (q, qd) = (&self.q.as_slice()[..nq], &self.qd.as_slice()[..nq]);
        for (i, a) in self.atts.iter().enumerate() {
            if i == 0 {
                // M, F, Q, A and the first point from one (generated: fused) call.
                m.system
                    .evaluate_with_point(a.point, q, qd, t, &mut self.ws);
            } else {
                m.system.point_kinematics(a.point, q, qd, &mut self.ws);
            }
            let (ax, ay) = (self.ws.point_a[0], self.ws.point_a[1]);
            bias[a.row] = a.along[0] * ax + a.along[1] * ay;
            if let Some(r) = a.axial_row {
                bias[r] = cs * ax - sn * ay;
            }
        }
        if self.atts.is_empty() {
            m.system.evaluate(q, qd, t, &mut self.ws);
        }
        copy_short(&mut bias[..self.loops], &self.ws.a.as_slice()[..self.loops]);
        add_loads(
            model,
            self.mech,
            &self.forces,
            self.excited,
            (t, q, qd),
            rule,
            currents,
            &mut self.ws,
        );
        // Accelerations (19): J_d qdd_d = E w'' - J_f u'' - A.
        let qdd = &mut self.qdd.as_mut_slice()[..nq];
        for (&c, x) in self.free.iter().zip(&acc[off..]) {
            qdd[c] = *x;
        }
        self.constraint_rhs(r, acc);
        let rhs = &mut self.rhs.as_mut_slice()[..rows];
        for (r, b) in rhs.iter_mut().zip(&self.bias.as_slice()[..rows]) {
            *r -= b;
        }
        self.solve_lu(r);
        scatter(
            &self.dep,
            self.dep_leading,
            &self.rhs.as_slice()[..rows],
            &mut self.qdd.as_mut_slice()[..nq],
        );
        let qdd = &self.qdd.as_slice()[..nq];
        // g = M q'' + F + Q; phi = R^T g with R = [J_d^-1 E, e_f - J_d^-1 J_f]:
        // mu = J_d^-T g_d, phi_w = E^T mu, phi_u = g_f - J_f^T mu.
        // `M q''` column by column, as nalgebra's `gemv` sums it (the same results bit for
        // bit), then `+ F`, `+ Q`.
        let g = &mut self.g.as_mut_slice()[..nq];
        let (mm, f, qv) = (
            &self.ws.m.as_slice()[..nq * nq],
            &self.ws.f.as_slice()[..nq],
            &self.ws.q.as_slice()[..nq],
        );
        for (i, ((gi, fi), qi)) in g.iter_mut().zip(f).zip(qv).enumerate() {
            let mut s = mm[i] * qdd[0];
            for (col, x) in mm.chunks_exact(nq).zip(qdd).skip(1) {
                s += col[i] * x;
            }
            *gi = (s + fi) + qi;
        }
        let rhs = &mut self.rhs.as_mut_slice()[..rows];
        if self.dep_leading {
            copy_short(rhs, &g[..rows]);
        } else {
            for (&c, r) in self.dep.iter().zip(rhs.iter_mut()) {
                *r = g[c];
            }
        }
        let (lu, b) = (self.lu.as_slice(), self.rhs.as_mut_slice());
        if rows > 2 || !lu_solve_transpose_small(&lu[..rows * rows], &self.piv, &mut b[..rows]) {
            lu_solve_transpose(&self.lu, &self.piv, &mut self.rhs);
        }
        let mu = &self.rhs.as_slice()[..rows];
        for &(r, c) in &self.coupled {
            phi[c] = mu[r];
        }
        let jfull = self.jfull.as_slice();
        for (&c, p) in self.free.iter().zip(&mut phi[off..]) {
            let mut s = g[c];
            for (j, m) in jfull[c * rows..(c + 1) * rows].iter().zip(mu) {
                s -= j * m;
            }
            *p = s;
        }
        Ok(())
    }

    /// The multipliers `lambda = -J_d^-T g_d` of this mechanism's rows (loops, then per
    /// attachment the transverse and axial rows) after [`Follower::follow`]: with them
    /// `g + J^T lambda` vanishes on the dependent coordinates (eq. 17).
    pub fn multipliers(&self) -> impl ExactSizeIterator<Item = f64> + '_ {
        self.rhs.iter().map(|m| -m)
    }

    /// `R = dq/ds` of this mechanism at the last position solve, in the global layout `s`
    /// of [`Follower::follow`] (attachment displacements, then every free coordinate):
    /// the columns of eq. (18), `q_d' = J_d^-1 (E w' - J_f u')`, `q_f' = u'`. `r` is
    /// `dof x s.len()`; columns of other mechanisms' entries stay zero.
    pub fn basis_into(&mut self, r: &mut DMatrix<f64>) {
        r.fill(0.0);
        let off = self.nb + self.free_offset;
        for a in &self.atts {
            let axial = a.axial_row.zip(a.axial_coupling);
            for (row, col) in std::iter::once((a.row, a.coupling)).chain(axial) {
                self.rhs.fill(0.0);
                self.rhs[row] = 1.0;
                lu_solve(&self.lu, &self.piv, &mut self.rhs);
                for (k, &c) in self.dep.iter().enumerate() {
                    r[(c, col)] = self.rhs[k];
                }
            }
        }
        for (j, &f) in self.free.iter().enumerate() {
            for row in 0..self.rows {
                self.rhs[row] = -self.jfull[(row, f)];
            }
            lu_solve(&self.lu, &self.piv, &mut self.rhs);
            for (k, &c) in self.dep.iter().enumerate() {
                r[(c, off + j)] = self.rhs[k];
            }
            r[(f, off + j)] = 1.0;
        }
    }

    /// `rhs = E x_w - J_f x_u` for a position-level vector `x` in the global layout (`r`
    /// rows, [`Dim`]).
    #[inline(always)]
    fn constraint_rhs<R: Dim>(&mut self, r: R, x: &[f64]) {
        let rows = r.get();
        let rhs = &mut self.rhs.as_mut_slice()[..rows];
        zero_short(rhs);
        for &(r, c) in &self.coupled {
            rhs[r] = x[c];
        }
        let off = self.nb + self.free_offset;
        let jfull = self.jfull.as_slice();
        for (&c, u) in self.free.iter().zip(&x[off..]) {
            for (r, j) in rhs.iter_mut().zip(&jfull[c * rows..(c + 1) * rows]) {
                *r -= j * u;
            }
        }
    }

    /// The length of the record [`Follower::save_trial`] writes: `q`, `q'`, `q''`.
    pub fn trial_len(&self) -> usize {
        3 * self.n
    }

    /// Copies the trial state `q`, `q'`, `q''` of the last evaluation into `out`
    /// ([`Follower::trial_len`] long), for [`Follower::extrapolate_trial`].
    pub fn save_trial(&self, out: &mut [f64]) {
        let n = self.n;
        let (q, rest) = out.split_at_mut(n);
        let (qd, qdd) = rest.split_at_mut(n);
        copy_short(q, self.q.as_slice());
        copy_short(qd, self.qd.as_slice());
        copy_short(qdd, self.qdd.as_slice());
    }

    /// Moves the trial state along the secant through the saved one `prev` (the evaluation
    /// at `z_p`, [`Follower::save_trial`]) and the last evaluation (at `z`) to
    /// `z + ratio (z - z_p)`: `x += ratio (x - x_p)` for `q`, `q'`, `q''` of the dependent
    /// coordinates, whose error is of second order in the move; the free coordinates are set
    /// from `pos`, `vel`, `acc` (the layout of [`Follower::follow`]) exactly as an
    /// evaluation there sets them. The position solve's factors (for the next step's
    /// prediction) stay those of the last evaluation, consistent with its record.
    pub fn extrapolate_trial(
        &mut self,
        prev: &[f64],
        ratio: f64,
        pos: &[f64],
        vel: &[f64],
        acc: &[f64],
    ) {
        let n = self.n;
        // The coordinates leave the position solve's result.
        self.drift = f64::INFINITY;
        let (pq, rest) = prev.split_at(n);
        let (pqd, pqdd) = rest.split_at(n);
        // Every coordinate in one indexless pass: the dependent ones are the secant move,
        // the free ones (the complement) are overwritten below, so the numbers are those
        // of the move over `dep` alone.
        for (x, p) in [
            (self.q.as_mut_slice(), pq),
            (self.qd.as_mut_slice(), pqd),
            (self.qdd.as_mut_slice(), pqdd),
        ] {
            for (x, p) in x.iter_mut().zip(p) {
                *x += ratio * (*x - p);
            }
        }
        let off = self.nb + self.free_offset;
        let m = self.free.len();
        let (pos, vel, acc) = (&pos[off..off + m], &vel[off..off + m], &acc[off..off + m]);
        for (((&c, &p), &v), &a) in self.free.iter().zip(pos).zip(vel).zip(acc) {
            self.q[c] = p;
            self.qd[c] = v;
            self.qdd[c] = a;
        }
    }
}

/// The position solve's Newton iteration ([`Follower::solve_positions`] and its copy for
/// the pinned double bar, [`Follower::follow_pin2`]): at most this many iterations.
const POSITION_ITERATIONS: usize = 60;
/// The longest Newton step of the position solve (radians or lengths, as the coordinates).
const POSITION_STEP_LIMIT: f64 = 0.3;
/// A Newton step below this times `1 + sum |q|` has settled the coordinates.
const POSITION_STEP_TOL: f64 = 1e-13;
/// A settled solve assembles when `|h|` is below this times the positions' scale.
const POSITION_RESIDUAL_TOL: f64 = 1e-12;
/// A pivot of `J_d` below this times its largest entry is singular.
const POSITION_PIVOT_TOL: f64 = 1e-14;

/// The Newton step factor and length for a correction of length `len`: the step limited
/// to [`POSITION_STEP_LIMIT`].
#[inline(always)]
fn limited_step(len: f64) -> (f64, f64) {
    if len > POSITION_STEP_LIMIT {
        (POSITION_STEP_LIMIT / len, POSITION_STEP_LIMIT)
    } else {
        (1.0, len)
    }
}

/// The pinned double bar's part of [`Follower::mark_solved`]: the pin's displacements
/// `pos[c]` (and `pos[ca]` along the beam's axis, when it couples) as the last solve's.
#[inline(always)]
fn record_pin(w_last: &mut [f64], c: usize, ca: Option<usize>, pos: &[f64]) {
    w_last[c] = pos[c];
    if let Some(k) = ca {
        w_last[k] = pos[k];
    }
}

/// Whether a Newton step of length `len` from the coordinates `q` has settled them.
#[inline(always)]
fn settled(len: f64, q: &[f64]) -> bool {
    len <= POSITION_STEP_TOL * (1.0 + q.iter().map(|x| x.abs()).sum::<f64>())
}

/// The 2-norm of `x`, summed in order as nalgebra's `norm` sums a short vector (the same
/// value bit for bit).
fn norm(x: &[f64]) -> f64 {
    let mut s = 0.0;
    for v in x {
        s += v * v;
    }
    s.sqrt()
}

/// The largest `|x_i|` (0 for an empty slice).
fn amax(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m: f64, v| m.max(v.abs()))
}

/// `J_d = J[:, dep]` into `jd` (`rows x dep.len()`, column-major like the `rows`-row
/// `j`): whole columns copied as slices; one slice, the leading block, when `leading`
/// (`dep` is `0..rows`, [`leading`]).
#[inline(always)]
fn dependent_columns(j: &[f64], rows: usize, dep: &[usize], leading: bool, jd: &mut [f64]) {
    if rows == 0 {
        return;
    }
    if leading {
        copy_short(&mut jd[..rows * rows], &j[..rows * rows]);
        return;
    }
    for (dst, &c) in jd.chunks_exact_mut(rows).zip(dep) {
        copy_short(dst, &j[c * rows..(c + 1) * rows]);
    }
}

/// `|o_x| + |o_y|` summed in order as an iterator's `sum` sums it (the same value bit
/// for bit as the position solve's former in-place sum).
fn origin_abs(origin: &[f64; 2]) -> f64 {
    origin.iter().map(|x| x.abs()).sum::<f64>()
}

/// The constants of [`Follower::follow_pin2`]: a mechanism of two coordinates without
/// loop rows pinned to one structure point (the double bar on the beam), whose two rows
/// are the pin's transverse row 0 and axial row 1, both coordinates dependent (`dep` is
/// `0..2`, no free coordinate).
#[derive(Clone, Copy, Debug)]
struct Pin2 {
    /// Mechanism point index.
    point: usize,
    /// Coupling unknown of the transverse row.
    coupling: usize,
    /// Coupling unknown of the axial row, for a point that moves along `x`.
    axial_coupling: Option<usize>,
    /// [`AttachRow::direction`].
    direction: [f64; 2],
    /// [`AttachRow::along`].
    along: [f64; 2],
    /// [`AttachRow::offset`].
    offset: f64,
    /// [`AttachRow::x`].
    x: f64,
    /// [`AttachRow::y`].
    y: f64,
    /// [`Follower::origin_abs`].
    origin_abs: f64,
}

impl Pin2 {
    /// The constants when the follower (`n` coordinates, `loops` loop rows, attachments
    /// `atts`, free coordinates `free`) is of that kind.
    fn of(
        n: usize,
        loops: usize,
        atts: &[AttachRow],
        free: &[usize],
        origin_abs: f64,
    ) -> Option<Pin2> {
        match atts {
            [a] if n == 2
                && loops == 0
                && free.is_empty()
                && a.row == 0
                && a.axial_row == Some(1) =>
            {
                Some(Pin2 {
                    point: a.point,
                    coupling: a.coupling,
                    axial_coupling: a.axial_coupling,
                    direction: a.direction,
                    along: a.along,
                    offset: a.offset,
                    x: a.x,
                    y: a.y,
                    origin_abs,
                })
            }
            _ => None,
        }
    }
}

/// Which excitations of the model act on a follower's mechanism: whether
/// [`HybridModel::add_joint_excitations`] and [`HybridModel::add_base_load`] can change
/// its equations (both add nothing without such excitations).
#[derive(Clone, Copy, Debug)]
struct Excited {
    /// An excitation on one of its joints.
    joint: bool,
    /// A base excitation (the supports' motion).
    base: bool,
}

/// The currents of mechanism `mech`'s force elements `forces` (all of its, ascending) at
/// `(t, q, q')` into `currents`, their terms and the excitations' added to `M^b`, `Q^b`
/// in `ws`: [`HybridModel::add_joint_forces`] and [`HybridModel::add_base_load`], the
/// same terms in the same order, over the mechanism's own force elements (not a filter
/// over the model's), each with the current just computed (the quasi-static one is the
/// value `add_joint_forces` recomputes), and the excitation passes skipped when the model
/// has none of their kind ([`Excited`]).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn add_loads(
    model: &HybridModel,
    mech: usize,
    forces: &[usize],
    excited: Excited,
    (t, q, qd): (f64, &[f64], &[f64]),
    rule: CurrentRule<'_>,
    currents: &mut [f64],
    ws: &mut Workspace,
) {
    for &f in forces {
        let force = &model.forces[f];
        let j = force.joint;
        let w = qd[j];
        let current = if force.has_current_state() {
            let g = force.generator().expect("a current state is a generator's");
            let (l, r) = (g.inductance, g.resistance());
            let h = rule.h;
            (rule.old[f] + 0.5 * h * rule.rate[f] + 0.5 * h * g.ke * g.gear_ratio * w / l)
                / (1.0 + 0.5 * h * r / l)
        } else {
            force.quasi_static_current(w)
        };
        currents[f] = current;
        force.add_to_equations(q[j], w, current, &mut ws.m, &mut ws.q);
    }
    if excited.joint {
        model.add_joint_excitations(mech, t, &mut ws.q);
    }
    if excited.base {
        model.add_base_load(mech, t, q, ws);
    }
}

/// The first two entries of `v` as an array (the pinned double bar's rows, coordinates).
#[inline(always)]
fn fixed2(v: &mut DVector<f64>) -> &mut [f64; 2] {
    (&mut v.as_mut_slice()[..2])
        .try_into()
        .expect("a slice of two")
}

/// The first four entries of `v` as an array (a 2 x 2 matrix, column-major).
#[inline(always)]
fn fixed4(v: &mut [f64]) -> &mut [f64; 4] {
    (&mut v[..4]).try_into().expect("a slice of four")
}

/// Whether the dependent coordinates `dep` are `0..rows` (in order).
fn leading(dep: &[usize], rows: usize) -> bool {
    dep.len() == rows && dep.iter().enumerate().all(|(i, &c)| c == i)
}

/// The `(row, coupling)` pairs of [`Follower`]'s coupled rows, in attachment order: the
/// transverse row, then the axial row when it has a coupling unknown.
fn coupled_rows(atts: &[AttachRow]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for a in atts {
        out.push((a.row, a.coupling));
        if let (Some(r), Some(c)) = (a.axial_row, a.axial_coupling) {
            out.push((r, c));
        }
    }
    out
}

/// `dst[dep[k]] = src[k]`: a solve's dependent values into a coordinate vector (one copy
/// of the leading entries when `leading`, [`leading`]).
#[inline(always)]
fn scatter(dep: &[usize], leading: bool, src: &[f64], dst: &mut [f64]) {
    if leading {
        copy_short(&mut dst[..src.len()], src);
    } else {
        for (&c, x) in dep.iter().zip(src) {
            dst[c] = *x;
        }
    }
}

/// A size of the follower's buffers (constraint rows, coordinates): known at compile time
/// ([`Fixed`]) for the sizes of the step's hot path, so that the slices cut to it need no
/// length checks and the loops over it unroll, or at run time ([`Dyn`]). The code using it
/// is the same either way: so are its operations and results.
trait Dim: Copy {
    /// The size.
    fn get(self) -> usize;
}

/// A size known at compile time.
#[derive(Clone, Copy)]
struct Fixed<const N: usize>;

impl<const N: usize> Dim for Fixed<N> {
    #[inline(always)]
    fn get(self) -> usize {
        N
    }
}

/// A size known at run time.
#[derive(Clone, Copy)]
struct Dyn(usize);

impl Dim for Dyn {
    #[inline(always)]
    fn get(self) -> usize {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generator::GeneratorSpec;
    use crate::hybrid::{
        Attachment, BeamPoint, Excitation, ExcitationTarget, ForceKind, JointForce, Mount,
        MountedMechanism, Placement, place_two_bar,
    };
    use fem_beam::{Beam, BeamModel, TimeFunction};
    use mbs_symbolic::samples::SplitMix64;

    /// The paper's damper (`scenarios/damper.toml`, 8 elements): the generated double bar
    /// at 10 degrees pinned to the tip of the cantilever, the generator on its first joint
    /// (with an inductance: the current's trapezoidal rule runs too).
    fn damper() -> HybridModel {
        let text = "[[segment]]\nlength = 1.0\nyoungs_modulus = 210e9\ndensity = 7850.0\n\
                    width = 0.040\nheight = 0.008\nelements = 8\n[[support]]\nx = 0.0\n\
                    kind = \"clamped\"\n";
        let beam = BeamModel::new(&Beam::from_toml_str(text, "b.toml").unwrap()).unwrap();
        let system = model_registry::find_by_name("double_bar").unwrap().system();
        let tip = system.point_index("tip").unwrap();
        let placed = place_two_bar(system.as_ref(), tip, Placement::HalfAngle(10.0)).unwrap();
        let point = BeamPoint::on(&beam, 1.0).unwrap();
        let mechanism = MountedMechanism {
            name: "damper".into(),
            system,
            mount: Mount {
                origin: [1.0 - placed.target[0], -placed.target[1]],
                angle: 0.0,
            },
            max_condition: 1e4,
            reach: Some(placed.reach),
            initial_q: placed.guess.to_vec(),
        };
        let generator = GeneratorSpec {
            kt: 0.0235,
            ke: 0.0235,
            armature_resistance: 1.5,
            load_resistance: 3.5,
            inductance: 1e-3,
            gear_ratio: 5.0,
            rotor_inertia: 1e-6,
            connected: true,
            gear_efficiency: 1.0,
            gear_friction: Default::default(),
        };
        HybridModel::new(
            Some(beam.into()),
            vec![mechanism],
            vec![Attachment {
                name: "tip".into(),
                mechanism: 0,
                point: tip,
                kind: AttachmentKind::Pin,
                beam: point,
            }],
            vec![JointForce {
                name: "generator".into(),
                mechanism: 0,
                joint: 0,
                kind: ForceKind::Generator(generator),
            }],
            vec![],
        )
        .unwrap()
    }

    /// The follow on sizes known at compile time and the straight-line follow of the
    /// pinned double bar (what `follow_trial` runs for it, [`Follower::follow_pin2`])
    /// against the same code on run-time sizes: the same outputs and buffers bit for bit,
    /// along a sequence of trial states (the prediction from the last solve included) and
    /// at a beam displacement beyond the mechanism's reach (the same error).
    #[test]
    fn the_fixed_size_follow_equals_the_run_time_sized_one_bit_for_bit() {
        let model = damper();
        let mut fixed = Follower::new(&model, 0, vec![], 0);
        assert_eq!((fixed.rows(), fixed.n, fixed.nb), (2, 2, 1));
        let mut dynamic = fixed.clone();
        // The straight-line path for the pinned double bar (what follow_trial runs).
        let mut pinned = fixed.clone();
        assert!(pinned.pin2.is_some());
        let mut rng = SplitMix64::new(5);
        let mut errors = 0;
        let mut w_prev = 0.0;
        let mut skipped = 0;
        for k in 0..200 {
            // Mostly small displacements; every 50th far beyond the reach; every third a move
            // of rounding size from the last (an iteration within a time step: the position
            // solve's prediction is taken without an evaluation).
            let w = if k % 50 == 49 {
                0.5
            } else if k % 3 == 2 {
                w_prev + 1e-17 * rng.symmetric(1.0)
            } else {
                2e-3 * rng.symmetric(1.0)
            };
            w_prev = w;
            let jfull = fixed.jfull.clone();
            let (pos, vel, acc) = ([w], [rng.symmetric(0.3)], [rng.symmetric(30.0)]);
            let (old, rate) = ([rng.symmetric(0.1)], [rng.symmetric(10.0)]);
            let rule = CurrentRule {
                h: 1e-4,
                old: &old,
                rate: &rate,
            };
            let t = 1e-4 * k as f64;
            let (mut c1, mut c2, mut c3) = ([f64::NAN], [f64::NAN], [f64::NAN]);
            let (mut p1, mut p2, mut p3) = ([f64::NAN], [f64::NAN], [f64::NAN]);
            let (r, n) = (Fixed::<2>, Fixed::<2>);
            let a = fixed.follow_sized(r, n, &model, t, &pos, &vel, &acc, rule, &mut c1, &mut p1);
            let (r, n) = (Dyn(2), Dyn(2));
            let b = dynamic.follow_sized(r, n, &model, t, &pos, &vel, &acc, rule, &mut c2, &mut p2);
            let c = pinned.follow_trial(&model, t, &pos, &vel, &acc, rule, &mut c3, &mut p3);
            assert_eq!(a, b, "step {k}");
            assert_eq!(a, c, "step {k}");
            errors += usize::from(a.is_err());
            // A prediction taken keeps the factors; a Newton solve evaluates them anew (at
            // another point: other bits).
            skipped += usize::from(a.is_ok() && fixed.jfull == jfull);
            let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            for other in [&dynamic, &pinned] {
                for (x, y) in [
                    (&fixed.q, &other.q),
                    (&fixed.qd, &other.qd),
                    (&fixed.qdd, &other.qdd),
                    (&fixed.rhs, &other.rhs),
                    (&fixed.h, &other.h),
                    (&fixed.bias, &other.bias),
                    (&fixed.g, &other.g),
                ] {
                    assert_eq!(bits(x.as_slice()), bits(y.as_slice()), "step {k}");
                }
                assert_eq!(bits(fixed.lu.as_slice()), bits(other.lu.as_slice()));
                assert_eq!(bits(fixed.jfull.as_slice()), bits(other.jfull.as_slice()));
                assert_eq!(bits(&fixed.w_last), bits(&other.w_last));
                assert_eq!(fixed.drift.to_bits(), other.drift.to_bits());
                assert_eq!(
                    (fixed.piv.clone(), fixed.solved, fixed.residual.to_bits()),
                    (other.piv.clone(), other.solved, other.residual.to_bits())
                );
                assert_eq!(
                    (fixed.condition.to_bits(), fixed.sigma_min.to_bits()),
                    (other.condition.to_bits(), other.sigma_min.to_bits())
                );
            }
            for (x, y) in [(&c1, &c2), (&c1, &c3), (&p1, &p2), (&p1, &p3)] {
                assert_eq!(bits(x), bits(y), "step {k}");
            }
            if a.is_err() {
                // Back to a configuration all three can follow from.
                let q0 = model.mechanisms[0].initial_q.clone();
                for f in [&mut fixed, &mut dynamic, &mut pinned] {
                    f.set_q(&q0);
                }
            }
        }
        assert!((1..20).contains(&errors), "{errors} failed follows");
        assert!((40..=66).contains(&skipped), "{skipped} predictions taken");
    }

    /// The position solve's prediction taken without an evaluation ([`Follower::predict`])
    /// against the full Newton solve from the same start, after a move of rounding size
    /// (what an iteration within a time step makes): the same coordinates to 1e-15, and
    /// velocities, accelerations and the projected equations to 1e-12 of their size (the
    /// factors of `J_d` evaluated 1e-13 away); a larger move is solved by Newton.
    #[test]
    fn a_settled_prediction_equals_the_newton_solve() {
        let model = damper();
        let mut f = Follower::new(&model, 0, vec![], 0);
        let rule = CurrentRule {
            h: 1e-4,
            old: &[0.05],
            rate: &[3.0],
        };
        let (vel, acc) = ([0.2], [-20.0]);
        let (mut cur, mut phi) = ([0.0], [0.0]);
        for w in [1.2e-3, 1.3e-3] {
            f.follow_trial(&model, 0.0, &[w], &vel, &acc, rule, &mut cur, &mut phi)
                .unwrap();
        }
        let settled_len = f.drift;
        assert!(settled_len <= 1e-12, "{settled_len}");
        for (dw, taken) in [(3e-17, true), (-5e-17, true), (1e-9, false)] {
            let w = [1.3e-3 + dw];
            let mut newton = f.clone();
            let q = newton.q.as_slice().to_vec();
            newton.set_q(&q);
            let (mut c2, mut p2) = ([0.0], [0.0]);
            newton
                .follow_trial(&model, 0.0, &w, &vel, &acc, rule, &mut c2, &mut p2)
                .unwrap();
            let jfull = f.jfull.clone();
            f.follow_trial(&model, 0.0, &w, &vel, &acc, rule, &mut cur, &mut phi)
                .unwrap();
            assert_eq!(f.jfull == jfull, taken, "move {dw}");
            let close = |a: &[f64], b: &[f64], tol: f64| {
                a.iter()
                    .zip(b)
                    .all(|(x, y)| (x - y).abs() <= tol * x.abs().max(y.abs()))
            };
            // The coordinates to 1e-15 of the position solve's scale (its settle test's
            // 1e-13 x (1 + sum |q|)).
            let q_scale = 1.0 + f.q.iter().map(|x| x.abs()).sum::<f64>();
            assert!(
                f.q.iter()
                    .zip(newton.q.iter())
                    .all(|(x, y)| (x - y).abs() <= 1e-15 * q_scale),
                "move {dw}: {:?} vs {:?}",
                f.q,
                newton.q
            );
            for (a, b, tol) in [
                (f.qd.as_slice(), newton.qd.as_slice(), 1e-12),
                (f.qdd.as_slice(), newton.qdd.as_slice(), 1e-12),
                (&phi[..], &p2[..], 1e-12),
                (&cur[..], &c2[..], 1e-12),
            ] {
                assert!(close(a, b, tol), "move {dw}: {a:?} vs {b:?}");
            }
        }
    }

    /// [`add_loads`] against what it replaces in the follow (the currents computed per force
    /// element, then [`HybridModel::add_joint_forces`] and [`HybridModel::add_base_load`]):
    /// the same currents, `M^b`, `Q^b` and `G` bit for bit, with a generator with and
    /// without a current state, without excitations and with a joint and a base one.
    #[test]
    fn the_follower_loads_equal_add_joint_forces_and_add_base_load_bit_for_bit() {
        let mut rng = SplitMix64::new(9);
        for (inductance, excited) in [(1e-3, false), (0.0, false), (1e-3, true), (0.0, true)] {
            let mut model = damper();
            if let ForceKind::Generator(g) = &mut model.forces[0].kind {
                g.inductance = inductance;
            }
            if excited {
                let time = TimeFunction::Table {
                    points: vec![[0.0, 0.3], [1.0, -2.0]],
                };
                for (name, target) in [
                    (
                        "drive",
                        ExcitationTarget::Joint {
                            mechanism: 0,
                            joint: 1,
                        },
                    ),
                    ("shaker", ExcitationTarget::BASE_Y),
                ] {
                    model.excitations.push(Excitation {
                        name: name.into(),
                        target,
                        amplitude: 1.7,
                        time: time.clone(),
                    });
                }
            }
            let follower = Follower::new(&model, 0, vec![], 0);
            assert_eq!(
                (follower.excited.joint, follower.excited.base),
                (excited, excited)
            );
            let sys = &model.mechanisms[0].system;
            for _ in 0..20 {
                let q = [rng.symmetric(3.0), rng.symmetric(3.0)];
                let qd = [rng.symmetric(20.0), rng.symmetric(20.0)];
                let t = rng.symmetric(1.0).abs();
                let (old, rate) = ([rng.symmetric(0.1)], [rng.symmetric(10.0)]);
                let rule = CurrentRule {
                    h: 1e-4,
                    old: &old,
                    rate: &rate,
                };
                let mut ws = sys.workspace();
                sys.evaluate(&q, &qd, t, &mut ws);
                let mut reference = ws.clone();
                let (mut c1, mut c2) = ([f64::NAN], [f64::NAN]);
                // The replaced code.
                for &f in &follower.forces {
                    let force = &model.forces[f];
                    let w = qd[force.joint];
                    c1[f] = if force.has_current_state() {
                        let g = force.generator().unwrap();
                        let (l, r) = (g.inductance, g.resistance());
                        let h = rule.h;
                        (rule.old[f]
                            + 0.5 * h * rule.rate[f]
                            + 0.5 * h * g.ke * g.gear_ratio * w / l)
                            / (1.0 + 0.5 * h * r / l)
                    } else {
                        force.quasi_static_current(w)
                    };
                }
                model.add_joint_forces(0, t, &q, &qd, &c1, &mut reference.m, &mut reference.q);
                model.add_base_load(0, t, &q, &mut reference);
                add_loads(
                    &model,
                    0,
                    &follower.forces,
                    follower.excited,
                    (t, &q, &qd),
                    rule,
                    &mut c2,
                    &mut ws,
                );
                let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&c1), bits(&c2));
                assert_eq!(bits(reference.m.as_slice()), bits(ws.m.as_slice()));
                assert_eq!(bits(reference.q.as_slice()), bits(ws.q.as_slice()));
                assert_eq!(
                    bits(reference.gravity_jacobian.as_slice()),
                    bits(ws.gravity_jacobian.as_slice())
                );
                if excited {
                    assert_ne!(bits(reference.q.as_slice()), {
                        let mut bare = sys.workspace();
                        sys.evaluate(&q, &qd, t, &mut bare);
                        model.add_joint_forces(0, t, &q, &qd, &c1, &mut bare.m, &mut bare.q);
                        bits(bare.q.as_slice())
                    });
                }
            }
        }
    }
}
