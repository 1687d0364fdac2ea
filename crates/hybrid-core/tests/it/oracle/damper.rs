//! The coupled beam + double bar + generator in its specialised rank-one form and its time
//! integration — the second, independent formulation the general engine
//! ([`hybrid_core::hybrid`]) is checked against step by step (a copy of the former
//! `hybrid_core::damper`, on hybrid-core's public API).
//!
//! # Equations
//!
//! The beam (eq. 44) with the mechanism reduced onto it (eqs. 55–58, corrected in docs/theory.md
//! section 6; see [`super::coupling`]):
//!
//! ```text
//! (A + m_eff(y) n n^T) q'' + B q' + C q = P(t) + n f(y, y', i)            (55)–(58)
//! y = n . q                                                               (beam point)
//! L i' + (R_a + R_L) i = k_e n_g q1'       (only when the inductance is > 0; docs/theory.md section 7)
//! ```
//!
//! # Time integration: Newmark / HHT-alpha with a rank-one Newton
//!
//! With `q = q^ + beta h^2 a`, `v = v^ + gamma h a` (predictors from step `n`), HHT-alpha
//! (`alpha` in [-1/3, 0]; `alpha = 0` is Newmark's average acceleration, the default) gives
//!
//! ```text
//! (K + m_eff n n^T) a = r0 + n f_{n+1},      K = A + (1+alpha)(gamma h B + beta h^2 C)
//! r0 = (1+alpha)(P_{n+1} - B v^ - C q^) - alpha (P_n - B v_n - C q_n)
//! ```
//!
//! The mechanism's whole reaction on the beam, `m_eff a_y - f`, is inertial (reflected mass
//! and its velocity terms) apart from the generator torque, so, like the beam's inertia, it
//! is taken at `t_{n+1}` and not alpha-weighted: weighting only the `f` part would split the
//! mechanism's inertia between two instants and pump energy into the system.
//!
//! `K` is constant: it is factorised once (banded LDL^T), and `z = K^-1 n` is computed once.
//! Sherman–Morrison then reduces each step to one banded solve `a0 = K^-1 r0` and a scalar
//! equation for the beam point's acceleration `a_y = n . a`:
//!
//! ```text
//! R(a_y) = a_y (1 + m_eff zeta) - a0_y - zeta f(a_y) = 0,   zeta = n . z
//! a = a0 + z (f - m_eff a_y)
//! ```
//!
//! solved by secant iterations (each evaluates the mechanism at the trial `y`, `y'`). A step
//! costs `O(n)` in the number of beam DOFs and allocates nothing.

use fem_beam::{BandedFactor, BandedSym, BeamModel};
use mbs_symbolic::runtime::System;

use hybrid_core::generator::GeneratorSpec;
use hybrid_core::hybrid::Method;

use super::coupling::{Current, KinematicError, LinkState, MechanismLink};

/// Why a run stopped.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SimError {
    /// The mechanism could not follow the beam (singular position or out of reach).
    #[error("t = {t:.6} s, beam point displacement {y:.6e} m: {error}")]
    Kinematics {
        /// Time.
        t: f64,
        /// Displacement of the beam point (m).
        y: f64,
        /// What happened (part of the message, not a separate source, so a chain-printing
        /// reporter says it once).
        error: KinematicError,
    },
    /// The scalar Newton iteration of a step did not converge.
    #[error(
        "t = {t:.6} s, beam point displacement {y:.6e} m: the implicit step did not converge (residual {residual:.3e} after {iterations} iterations){}",
        if *condition > 100.0 {
            format!("; the mechanism is close to its singular position: cond(J^b) = {condition:.3e}, smallest singular value {sigma_min:.3e} m")
        } else {
            format!("; cond(J^b) = {condition:.3e}: reduce the time step")
        }
    )]
    NoConvergence {
        /// Time.
        t: f64,
        /// Displacement of the beam point at the last iterate (m).
        y: f64,
        /// cond(J^b) at the last iterate.
        condition: f64,
        /// Smallest singular value of J^b at the last iterate (m/rad).
        sigma_min: f64,
        /// Last residual.
        residual: f64,
        /// Iterations made.
        iterations: usize,
    },
    /// The state became non-finite.
    #[error("t = {t:.6} s: the solution diverged (non-finite state); reduce the time step")]
    Diverged {
        /// Time.
        t: f64,
    },
    /// A beam matrix could not be factorised.
    #[error("beam matrix factorisation failed: {0}")]
    Factorization(String),
}

/// The coupled model: beam, mechanism link and generator.
#[derive(Clone, Debug)]
pub struct DamperModel<M> {
    /// The beam's reduced matrices (eq. 44).
    pub beam: BeamModel,
    /// The mechanism pinned to the beam point.
    pub link: MechanismLink<M>,
    /// The generator on the mechanism joint `link.generator_joint`.
    pub generator: GeneratorSpec,
    /// The beam point: `y = sum w_k q_k` over `(k, w_k)` (one entry `(j, 1)` at a node, up to
    /// four shape-function weights inside an element, eq. 35).
    pub coupling: Vec<(usize, f64)>,
}

/// Energies and the energy account of a run (J).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energy {
    /// `v^T A v / 2`.
    pub beam_kinetic: f64,
    /// `q^T C q / 2`.
    pub beam_potential: f64,
    /// Mechanism and rotor kinetic energy `q^b'^T M^b q^b' / 2`.
    pub mechanism_kinetic: f64,
    /// Mechanism potential energy `V(q^b)` (gravity, springs).
    pub mechanism_potential: f64,
    /// `L i^2 / 2`.
    pub magnetic: f64,
    /// Dissipated by the beam's Rayleigh damping, `integral v^T B v dt`.
    pub dissipated_structure: f64,
    /// Dissipated in the armature, `integral R_a i^2 dt`.
    pub dissipated_armature: f64,
    /// Dissipated (harvested) in the load, `integral R_L i^2 dt`.
    pub dissipated_load: f64,
    /// Work of the external beam loads, `integral P^T v dt`.
    pub external_work: f64,
}

/// The state of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    /// Time (s).
    pub t: f64,
    /// Beam DOFs.
    pub q: Vec<f64>,
    /// Beam velocities.
    pub v: Vec<f64>,
    /// Beam accelerations.
    pub a: Vec<f64>,
    /// Generator current (A).
    pub current: f64,
    /// The mechanism following the beam.
    pub link: LinkState,
    /// Energy account.
    pub energy: Energy,
    /// Steps taken.
    pub steps: u64,
}

impl<M: System> DamperModel<M> {
    /// `n . x`.
    pub fn point_value(&self, x: &[f64]) -> f64 {
        self.coupling.iter().map(|&(k, w)| w * x[k]).sum()
    }

    fn current_mode(&self, current: f64) -> Current<'_> {
        if self.generator.has_current_state() {
            Current::State(&self.generator, current)
        } else {
            Current::QuasiStatic(&self.generator)
        }
    }

    /// The mechanism following the beam state, as a [`SimError`] at time `t` on failure.
    pub fn follow(
        &self,
        t: f64,
        q: &[f64],
        v: &[f64],
        current: f64,
        warm: [f64; 2],
    ) -> Result<LinkState, SimError> {
        let y = self.point_value(q);
        self.link
            .follow(y, self.point_value(v), t, warm, self.current_mode(current))
            .map_err(|error| SimError::Kinematics { t, y, error })
    }

    /// Accelerations of the reduced model (eqs. 55–58) by the structured path: the rank-one
    /// term through Sherman–Morrison on a factorisation of `A` (`mass_factor`).
    pub fn accelerations(
        &self,
        mass_factor: &BandedFactor,
        t: f64,
        q: &[f64],
        v: &[f64],
        link: &LinkState,
    ) -> Vec<f64> {
        let n = q.len();
        let mut r = vec![0.0; n];
        self.beam.load_into(t, &mut r);
        self.beam.damping().mul_add_into(-1.0, v, &mut r);
        self.beam.stiffness().mul_add_into(-1.0, q, &mut r);
        let mut z = vec![0.0; n];
        for &(k, w) in &self.coupling {
            z[k] = w;
        }
        mass_factor.solve_in_place(&mut r);
        mass_factor.solve_in_place(&mut z);
        let (a0, zeta) = (self.point_value(&r), self.point_value(&z));
        // (A + m n n^T) a = r + n f:  a_y = (a0_y + zeta f) / (1 + m zeta)
        let ay = (a0 + zeta * link.force) / (1.0 + link.m_eff * zeta);
        let c = link.force - link.m_eff * ay;
        r.iter().zip(&z).map(|(ri, zi)| ri + zi * c).collect()
    }

    /// The initial state: the beam deflected in the static shape of a load at the beam point
    /// scaled to the displacement `y0`, at rest, the mechanism assembled from `guess`.
    pub fn initial_state(&self, y0: f64, guess: [f64; 2]) -> Result<State, SimError> {
        let n = self.beam.dof_count();
        let mut p = vec![0.0; n];
        for &(k, w) in &self.coupling {
            p[k] = w;
        }
        let shape = self
            .beam
            .static_deflection(&p)
            .map_err(|e| SimError::Factorization(e.to_string()))?;
        let y1 = self.point_value(&shape);
        let q: Vec<f64> = shape.iter().map(|s| s * y0 / y1).collect();
        let v = vec![0.0; n];
        let current = 0.0;
        let link = self.follow(0.0, &q, &v, current, guess)?;
        let factor = self
            .beam
            .mass()
            .factorize()
            .map_err(|e| SimError::Factorization(e.to_string()))?;
        let a = self.accelerations(&factor, 0.0, &q, &v, &link);
        let mut energy = Energy {
            beam_kinetic: 0.5 * self.beam.mass().quadratic_form(&v),
            beam_potential: 0.5 * self.beam.stiffness().quadratic_form(&q),
            mechanism_kinetic: link.kinetic_energy,
            mechanism_potential: link.potential_energy,
            ..Energy::default()
        };
        energy.magnetic = 0.5 * self.generator.inductance * current * current;
        Ok(State {
            t: 0.0,
            q,
            v,
            a,
            current,
            link,
            energy,
            steps: 0,
        })
    }
}

/// A time integrator bound to a model: the factorised iteration matrix and work buffers.
#[derive(Clone, Debug)]
pub struct Integrator {
    h: f64,
    alpha: f64,
    beta: f64,
    gamma: f64,
    factor: BandedFactor,
    z: Vec<f64>,
    zeta: f64,
    // Work buffers (length = beam DOFs).
    q_hat: Vec<f64>,
    v_hat: Vec<f64>,
    r0: Vec<f64>,
    p_new: Vec<f64>,
    p_old: Vec<f64>,
    v_old: Vec<f64>,
}

impl Integrator {
    /// Prepares the scheme with time step `h`: factorises `K = A + (1+alpha)(gamma h B +
    /// beta h^2 C)` and computes `z = K^-1 n`.
    pub fn new<M: System>(
        model: &DamperModel<M>,
        method: Method,
        h: f64,
    ) -> Result<Integrator, SimError> {
        let (alpha, beta, gamma) = method.coefficients();
        let mut k: BandedSym = model.beam.mass().clone();
        k.scaled_add((1.0 + alpha) * gamma * h, model.beam.damping())
            .map_err(|e| SimError::Factorization(e.to_string()))?;
        k.scaled_add((1.0 + alpha) * beta * h * h, model.beam.stiffness())
            .map_err(|e| SimError::Factorization(e.to_string()))?;
        let factor = model
            .beam
            .factorize(&k)
            .map_err(|e| SimError::Factorization(e.to_string()))?;
        let n = model.beam.dof_count();
        let mut z = vec![0.0; n];
        for &(j, w) in &model.coupling {
            z[j] = w;
        }
        factor.solve_in_place(&mut z);
        let zeta = model.point_value(&z);
        Ok(Integrator {
            h,
            alpha,
            beta,
            gamma,
            factor,
            z,
            zeta,
            q_hat: vec![0.0; n],
            v_hat: vec![0.0; n],
            r0: vec![0.0; n],
            p_new: vec![0.0; n],
            p_old: vec![0.0; n],
            v_old: vec![0.0; n],
        })
    }

    /// Advances `state` by one step. Allocates nothing.
    pub fn step<M: System>(
        &mut self,
        model: &DamperModel<M>,
        state: &mut State,
    ) -> Result<(), SimError> {
        let (h, alpha, beta, gamma) = (self.h, self.alpha, self.beta, self.gamma);
        let t_new = state.t + h;
        let gspec = &model.generator;
        // Predictors.
        for i in 0..state.q.len() {
            self.q_hat[i] = state.q[i] + h * state.v[i] + h * h * (0.5 - beta) * state.a[i];
            self.v_hat[i] = state.v[i] + h * (1.0 - gamma) * state.a[i];
        }
        // r0 = (1+alpha)(P_{n+1} - B v^ - C q^) - alpha (P_n - B v_n - C q_n)
        model.beam.load_into(t_new, &mut self.p_new);
        model.beam.load_into(state.t, &mut self.p_old);
        self.r0.copy_from_slice(&self.p_new);
        model
            .beam
            .damping()
            .mul_add_into(-1.0, &self.v_hat, &mut self.r0);
        model
            .beam
            .stiffness()
            .mul_add_into(-1.0, &self.q_hat, &mut self.r0);
        if alpha != 0.0 {
            for x in self.r0.iter_mut() {
                *x *= 1.0 + alpha;
            }
            for (r, p) in self.r0.iter_mut().zip(&self.p_old) {
                *r -= alpha * p;
            }
            model
                .beam
                .damping()
                .mul_add_into(alpha, &state.v, &mut self.r0);
            model
                .beam
                .stiffness()
                .mul_add_into(alpha, &state.q, &mut self.r0);
        }
        self.factor.solve_in_place(&mut self.r0);
        let a0y = model.point_value(&self.r0);
        let (yh, ydh) = (
            model.point_value(&self.q_hat),
            model.point_value(&self.v_hat),
        );
        let zeta = self.zeta;
        let inductive = gspec.has_current_state();
        // Current update (trapezoidal, consistent with the average-acceleration rule).
        let (i_old, di_old) = if inductive {
            let qd_old = state.link.qd[model.link.generator_joint];
            (
                state.current,
                (gspec.ke * gspec.gear_ratio * qd_old - gspec.resistance() * state.current)
                    / gspec.inductance,
            )
        } else {
            (0.0, 0.0)
        };
        let warm = state.link.q;
        let eval = |ay: f64| -> Result<(f64, LinkState), SimError> {
            let y = yh + beta * h * h * ay;
            let yd = ydh + gamma * h * ay;
            let link = if inductive {
                let l = model
                    .link
                    .follow(y, yd, t_new, warm, Current::State(gspec, 0.0));
                let mut l = l.map_err(|error| SimError::Kinematics { t: t_new, y, error })?;
                let w = l.qd[model.link.generator_joint];
                let i = (i_old
                    + 0.5 * h * di_old
                    + 0.5 * h * gspec.ke * gspec.gear_ratio * w / gspec.inductance)
                    / (1.0 + 0.5 * h * gspec.resistance() / gspec.inductance);
                l.force -= l.g[model.link.generator_joint] * gspec.q_term(i);
                l.current = i;
                l
            } else {
                model
                    .link
                    .follow(y, yd, t_new, warm, Current::QuasiStatic(gspec))
                    .map_err(|error| SimError::Kinematics { t: t_new, y, error })?
            };
            let r = ay * (1.0 + link.m_eff * zeta) - a0y - zeta * link.force;
            Ok((r, link))
        };
        // Secant iterations on R(a_y) = 0 from the previous acceleration.
        let mut x0 = model.point_value(&state.a);
        let (mut r0v, mut best) = eval(x0)?;
        let scale = 1e-9 + x0.abs() + a0y.abs();
        let mut x1 = x0 + 1e-7 * scale;
        let mut iterations = 0;
        let mut converged = r0v == 0.0;
        let mut x_final = x0;
        if !converged {
            let (mut r1v, mut l1) = eval(x1)?;
            while iterations < 40 {
                iterations += 1;
                if r1v == 0.0 {
                    converged = true;
                    x_final = x1;
                    best = l1;
                    break;
                }
                let denom = r1v - r0v;
                if denom == 0.0 || !denom.is_finite() {
                    break;
                }
                let x2 = x1 - r1v * (x1 - x0) / denom;
                let (r2v, l2) = eval(x2)?;
                let dx = (x2 - x1).abs();
                x0 = x1;
                r0v = r1v;
                x1 = x2;
                r1v = r2v;
                l1 = l2;
                if dx <= 1e-14 * scale.max(x2.abs()) {
                    converged = true;
                    x_final = x1;
                    best = l1;
                    break;
                }
            }
            if !converged {
                return Err(SimError::NoConvergence {
                    t: t_new,
                    y: yh + beta * h * h * x1,
                    condition: l1.condition,
                    sigma_min: l1.sigma_min,
                    residual: r1v.abs(),
                    iterations,
                });
            }
        }
        let ay = x_final;
        let c = best.force - best.m_eff * ay;
        // Keep the old velocity for the energy account, then update.
        self.v_old.copy_from_slice(&state.v);
        for i in 0..state.q.len() {
            let a = self.r0[i] + self.z[i] * c;
            state.a[i] = a;
            state.q[i] = self.q_hat[i] + beta * h * h * a;
            state.v[i] = self.v_hat[i] + gamma * h * a;
        }
        let link = best;
        if !state.q.iter().chain(&state.v).all(|x| x.is_finite()) || !link.force.is_finite() {
            return Err(SimError::Diverged { t: t_new });
        }
        // Energy account: midpoint velocity for the Rayleigh dissipation and the load work
        // (exact for the linear part under the average-acceleration rule), trapezoid for the
        // generator's resistive losses.
        let e = &mut state.energy;
        let mut diss = 0.0;
        let mut work = 0.0;
        // v_mid^T B v_mid = (v_o^T B v_o + 2 v_o^T B v_n + v_n^T B v_n) / 4; computed through
        // the quadratic form of the sum, reusing q_hat as scratch.
        for i in 0..state.q.len() {
            self.q_hat[i] = 0.5 * (self.v_old[i] + state.v[i]);
            work += 0.5 * (self.p_old[i] + self.p_new[i]) * self.q_hat[i];
        }
        diss += model.beam.damping().quadratic_form(&self.q_hat);
        e.dissipated_structure += h * diss;
        e.external_work += h * work;
        let (i0, i1) = (state.current, link.current);
        let mean_sq = 0.5 * (i0 * i0 + i1 * i1);
        e.dissipated_armature += h * gspec.armature_resistance * mean_sq;
        e.dissipated_load += h * gspec.load_resistance * mean_sq;
        e.beam_kinetic = 0.5 * model.beam.mass().quadratic_form(&state.v);
        e.beam_potential = 0.5 * model.beam.stiffness().quadratic_form(&state.q);
        e.mechanism_kinetic = link.kinetic_energy;
        e.mechanism_potential = link.potential_energy;
        e.magnetic = 0.5 * gspec.inductance * i1 * i1;
        state.current = i1;
        state.link = link;
        state.t = t_new;
        state.steps += 1;
        Ok(())
    }
}
