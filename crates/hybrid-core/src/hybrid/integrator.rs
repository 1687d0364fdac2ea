//! Newmark / HHT-alpha time integration of a [`HybridModel`] with a quasi-Newton iteration
//! on the small vector of reduced unknowns (see the module documentation of
//! [`crate::hybrid`]). A step costs one banded solve, `O(n)` vector work and a few
//! mechanism evaluations, and allocates nothing.

use fem_beam::NewmarkPredictor;
use nalgebra::{DMatrix, DVector};

use super::error::HybridError;
use super::follow::{CurrentRule, FollowError, Follower};
use super::method::Method;
use super::model::{Coupling, ExcitationTarget, HybridModel};
use super::structure::{LinearStructure, Structure, StructureFactor};
use crate::partition::choose_partition;
use crate::partition::dense::{copy_short, lu_in_place, lu_solve};

/// The state of one mechanism.
#[derive(Clone, Debug, PartialEq)]
pub struct MechanismState {
    /// Coordinates.
    pub q: Vec<f64>,
    /// Velocities.
    pub qd: Vec<f64>,
    /// Accelerations.
    pub qdd: Vec<f64>,
    /// Independent (free) coordinates of the current partition, sorted.
    pub free: Vec<usize>,
    /// 2-norm condition number of the dependent Jacobian `J_d`.
    pub condition: f64,
    /// Smallest singular value of `J_d`.
    pub sigma_min: f64,
    /// Constraint residual norm after the position solve.
    pub residual: f64,
}

/// Integrals of the energy account since `t = 0` (J).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Account {
    /// Dissipated by the beam's Rayleigh damping, `integral v^T B v dt`.
    pub dissipated_structure: f64,
    /// Work of the beam's own loads (fem-beam loads), `integral P^T v dt`.
    pub beam_load_work: f64,
    /// Dissipated by each force element (generator: `(R_a + R_L) i^2` and its gear's loss;
    /// damper: `c q'^2`).
    pub dissipated: Vec<f64>,
    /// Of [`Account::dissipated`], lost in each generator's gear (0 for other elements),
    /// `integral tau_g w dt` ([`crate::generator`]).
    pub gearbox_loss: Vec<f64>,
    /// Work each generator takes from its joint (0 for other elements), `integral (n k_t i +
    /// n tau_g) q' dt`: its mechanical input.
    pub mechanical_input: Vec<f64>,
    /// Work each generator's unequal constants lose (created where negative),
    /// `integral (k_t - k_e) n i q' dt`: the torque takes `k_t i w` from the joint, the EMF
    /// gives the circuit `k_e i w`. Zero for the ideal machine (`k_t = k_e` in SI) and for
    /// other elements; a dissipation of the energy account.
    pub conversion: Vec<f64>,
    /// Work done by each excitation.
    pub excitation_work: Vec<f64>,
    /// Dissipated by each mechanism model's own force elements (its dampers: `c q'^2`,
    /// `c l'^2`), `integral D dt` with `D` of
    /// [`mbs_symbolic::runtime::System::element_power`], one entry per mechanism.
    pub dissipated_model: Vec<f64>,
    /// Work put in by each mechanism model's force elements without potential (constant
    /// joint forces, external forces and torques), `integral P dt`, one entry per mechanism.
    pub model_input_work: Vec<f64>,
}

impl Account {
    /// Of force element `k`'s dissipation, the part in its circuit (a generator's
    /// `(R_a + R_L) i^2` integrated, without its gear's loss; all of it for other elements).
    pub fn circuit_dissipated(&self, k: usize) -> f64 {
        self.dissipated[k] - self.gearbox_loss[k]
    }
}

/// The state of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct HybridState {
    /// Time (s).
    pub t: f64,
    /// Beam DOFs.
    pub q: Vec<f64>,
    /// Beam velocities.
    pub v: Vec<f64>,
    /// Beam accelerations.
    pub a: Vec<f64>,
    /// Mechanisms.
    pub mechanisms: Vec<MechanismState>,
    /// Current through each force element (A; 0 for non-generators).
    pub currents: Vec<f64>,
    /// Its rate `di/dt` (A/s; inductive generators).
    pub current_rates: Vec<f64>,
    /// Energy integrals.
    pub account: Account,
    /// Steps taken.
    pub steps: u64,
}

/// Stored energies at one state (J).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stored {
    /// `v^T A v / 2`.
    pub beam_kinetic: f64,
    /// `q^T C q / 2`.
    pub beam_potential: f64,
    /// Kinetic energy of each mechanism with its rotors, `q'^T M q' / 2`.
    pub mechanism_kinetic: Vec<f64>,
    /// Potential energy of each mechanism: gravity and model springs `V(q)` plus the
    /// scenario's springs.
    pub mechanism_potential: Vec<f64>,
    /// Magnetic energy `L i^2 / 2` of the generators.
    pub magnetic: f64,
}

impl Stored {
    /// Total stored energy.
    pub fn total(&self) -> f64 {
        self.beam_kinetic
            + self.beam_potential
            + self.mechanism_kinetic.iter().sum::<f64>()
            + self.mechanism_potential.iter().sum::<f64>()
            + self.magnetic
    }
}

/// A change of independent coordinates during a run.
#[derive(Clone, Debug, PartialEq)]
pub struct Repartition {
    /// Time (s).
    pub t: f64,
    /// Mechanism index.
    pub mechanism: usize,
    /// Free coordinates before.
    pub from: Vec<usize>,
    /// Free coordinates after.
    pub to: Vec<usize>,
    /// cond(J_d) before and after.
    pub condition: (f64, f64),
}

/// A time integrator bound to a model: the factorised iteration matrix, `K^-1 N` and
/// work buffers.
#[derive(Clone, Debug)]
pub struct Integrator {
    h: f64,
    alpha: f64,
    beta: f64,
    gamma: f64,
    /// The factorised Newmark matrix of the structure ([`LinearStructure::factorize_newmark`]).
    factor: Option<StructureFactor>,
    /// Rayleigh damping folded into the factorised matrix (average acceleration, `alpha = 0`,
    /// `B = a A + b C`): `(mu, kappa)` of `K^-1 (P - B v^ - C q^) = K^-1 (P - C (q^ + mu v^))
    /// - kappa v^` (docs/theory.md section 13.5); `None`: the products with `B` and `C`.
    fold: Option<(f64, f64)>,
    /// `q^ + mu v^` of the folded step.
    q_mix: Vec<f64>,
    nb: usize,
    nz: usize,
    /// The coupling unknowns `w` ([`HybridModel::couplings`]).
    couplings: Vec<Coupling>,
    /// `K^-1 n_k` for each coupling, column-major `n x nb`.
    zcols: Vec<f64>,
    /// `S = N^T K^-1 N`.
    s: DMatrix<f64>,
    followers: Vec<Follower>,
    q_hat: Vec<f64>,
    v_hat: Vec<f64>,
    r0: Vec<f64>,
    /// The folded step's `kappa` not yet taken from `r0`: the beam accelerations without
    /// the mechanisms are `r0 - kappa v^`, formed where `r0` is read
    /// ([`Integrator::prepare`], [`Integrator::accept`]) instead of in a pass of their own
    /// (docs/theory.md section 13.5); `None`: `r0` is complete.
    r0_kappa: Option<f64>,
    /// The beam load `P` at the step's end (at `p_new_t` after a step).
    p_new: Vec<f64>,
    /// The time at which `p_new` holds `P` (`None` before the first evaluation): the next
    /// step starts there and takes it as its `P_n` instead of evaluating the loads again.
    p_new_t: Option<f64>,
    /// The beam load at the step's start.
    p_old: Vec<f64>,
    v_mid: Vec<f64>,
    pos_hat: Vec<f64>,
    vel_hat: Vec<f64>,
    pos: Vec<f64>,
    vel: Vec<f64>,
    z: Vec<f64>,
    z_new: Vec<f64>,
    phi: Vec<f64>,
    res: Vec<f64>,
    res_new: Vec<f64>,
    a0w: Vec<f64>,
    scale: Vec<f64>,
    /// Largest |z_i| accepted so far: the typical size of each unknown, so that the
    /// convergence test stays relative when an acceleration passes through zero.
    zmax: Vec<f64>,
    dz: DVector<f64>,
    jdz: Vec<f64>,
    jac: DMatrix<f64>,
    jac_lu: DMatrix<f64>,
    jac_piv: Vec<usize>,
    jac_valid: bool,
    /// One unknown (`nz = 1`): the Jacobian at the end of the step before, for the
    /// extrapolation of the next step's Jacobian ([`Integrator::extrapolate_jacobian`]);
    /// `None` when there is no such history (a finite-difference refresh since).
    jac_prev: Option<f64>,
    /// One unknown: the followers' trial states ([`Follower::save_trial`]), `phi` and the
    /// currents at the first iterate of a step, for the secant step that accepts the third
    /// iterate without evaluating it ([`Integrator::accept_secant`]).
    trial_prev: Vec<f64>,
    phi_prev: Vec<f64>,
    currents_prev: Vec<f64>,
    /// Whether [`Integrator::accept_secant`] may accept an iterate without evaluating it
    /// ([`Integrator::set_secant_acceptance`]).
    secant_acceptance: bool,
    /// One unknown: its values in the states of the last steps, the latest first
    /// (`z_hist_len` of them), from which [`Integrator::extrapolate_start`] extrapolates the
    /// warm start; the state's time of the latest and the number of re-partitions then
    /// (the history stays only while the steps follow each other and the unknown is the
    /// same).
    z_hist: [f64; START_POINTS],
    z_hist_len: usize,
    z_hist_t: Option<(f64, usize)>,
    /// One unknown: the next step's value predicted from the history
    /// ([`Integrator::extrapolate_start`]; each from the number of values in `START_NEEDS`).
    z_pred: [f64; START_NEEDS.len()],
    /// One unknown: the state's own value, the warm start of the step when the
    /// extrapolated one replaced it (the iteration starts again from it when an evaluation
    /// at the extrapolated one fails).
    z_start: Option<f64>,
    /// Whether [`Integrator::extrapolate_start`] extrapolates the warm start
    /// ([`Integrator::set_extrapolated_start`]).
    extrapolated_start: bool,
    /// One unknown: whether the last step's iteration measured the Jacobian, a secant
    /// update from a step above 1e-9 of the unknown's scale (its slope then precise enough
    /// for the next step's extrapolation, [`Integrator::extrapolate_jacobian`]).
    jac_measured: bool,
    /// Residual evaluations so far ([`Integrator::evaluations`]).
    evaluations: u64,
    currents: Vec<f64>,
    /// The beam load per unit support acceleration, `-(A r)` (empty without a base
    /// excitation or a beam; [`HybridModel::base_beam_load`]).
    base_load: Vec<f64>,
    /// Whether the model has a base excitation.
    base: bool,
    /// Whether any mechanism model has force elements of its own
    /// ([`Integrator::account_model_elements`]; without, their account stays zero).
    model_elements: bool,
    /// Whether the beam load `P(t)` can be non-zero (the structure's own loads, beam
    /// excitations, a base excitation's inertial load); without, `p_old` and `p_new` stay
    /// zero and are not evaluated.
    loaded: bool,
    checked_condition: Vec<f64>,
    /// Changes of independent coordinates so far.
    pub repartitions: Vec<Repartition>,
}

pub(super) fn map_follow(
    model: &HybridModel,
    state_w: &[f64],
    mech: usize,
    t: f64,
    e: FollowError,
) -> HybridError {
    let m = &model.mechanisms[mech];
    let displacement = model
        .attachments
        .iter()
        .position(|a| a.mechanism == mech)
        .map_or(0.0, |k| state_w[model.coupling_of(k)]);
    match e {
        FollowError::Singular {
            condition,
            sigma_min,
        } => HybridError::Singular {
            t,
            mechanism: m.name.clone(),
            displacement,
            condition,
            sigma_min,
            reach: m.reach.map(|r| r - displacement),
        },
        FollowError::NoAssembly {
            residual,
            iterations,
        } => HybridError::NoAssembly {
            t,
            mechanism: m.name.clone(),
            displacement,
            residual,
            iterations,
            reach: m.reach,
        },
    }
}

impl Integrator {
    /// Prepares the scheme with time step `h` (`h = 0`: the integrator of the initial
    /// accelerations): factorises `K = A + (1+alpha)(gamma h B + beta h^2 C)`, computes
    /// `K^-1 N` and the first partition of every mechanism at `state`.
    pub fn new(
        model: &HybridModel,
        method: Method,
        h: f64,
        state: &HybridState,
    ) -> Result<Integrator, HybridError> {
        let (alpha, beta, gamma) = method.coefficients();
        let n = model.structure_dofs();
        let couplings = model.couplings();
        let nb = couplings.len();
        let factor = match &model.structure {
            Some(structure) => Some(
                structure
                    .factorize_newmark((1.0 + alpha) * gamma * h, (1.0 + alpha) * beta * h * h)
                    .map_err(HybridError::Factorization)?,
            ),
            None => None,
        };
        // K = A + gh B + bh2 C = (1 + gh a) A + (gh b + bh2) C when B = a A + b C, so
        // a A = (a / c1) (K - c2 C).
        let fold = match (&model.structure, &factor) {
            (Some(structure), Some(_)) if alpha == 0.0 && h > 0.0 => {
                structure.rayleigh().map(|(a, b)| {
                    let (c1, c2) = (1.0 + gamma * h * a, gamma * h * b + beta * h * h);
                    (b - a * c2 / c1, a / c1)
                })
            }
            _ => None,
        };
        let mut zcols = vec![0.0; n * nb];
        let mut s = DMatrix::zeros(nb, nb);
        if let Some(f) = &factor {
            for (k, c) in couplings.iter().enumerate() {
                let col = &mut zcols[k * n..(k + 1) * n];
                model.attachments[c.attachment]
                    .beam
                    .add_force_along(c.axial, 1.0, col);
                Structure::solve_in_place(f, col);
            }
            for (i, c) in couplings.iter().enumerate() {
                let p = &model.attachments[c.attachment].beam;
                for k in 0..nb {
                    s[(i, k)] = p.value_along(c.axial, &zcols[k * n..(k + 1) * n]);
                }
            }
        }
        let mut followers = Vec::with_capacity(model.mechanisms.len());
        let mut offset = 0;
        for (i, ms) in state.mechanisms.iter().enumerate() {
            let mut f = Follower::new(model, i, ms.free.clone(), offset);
            f.set_q(&ms.q);
            f.qd.copy_from_slice(&ms.qd);
            f.qdd.copy_from_slice(&ms.qdd);
            offset += ms.free.len();
            followers.push(f);
        }
        let nz = nb + offset;
        let nf = model.forces.len();
        let trial_len = if nz == 1 {
            followers.iter().map(|f| f.trial_len()).sum()
        } else {
            0
        };
        let base_load = if model.has_base_excitation() {
            model.base_beam_load()
        } else {
            Vec::new()
        };
        let loaded = model.structure.as_ref().is_some_and(|s| s.has_loads())
            || model
                .excitations
                .iter()
                .any(|e| matches!(e.target, ExcitationTarget::Beam(_)))
            || !base_load.is_empty();
        Ok(Integrator {
            h,
            alpha,
            beta,
            gamma,
            factor,
            fold,
            q_mix: if fold.is_some() {
                vec![0.0; n]
            } else {
                Vec::new()
            },
            nb,
            nz,
            couplings,
            zcols,
            s,
            followers,
            q_hat: vec![0.0; n],
            v_hat: vec![0.0; n],
            r0: vec![0.0; n],
            r0_kappa: None,
            p_new: vec![0.0; n],
            p_new_t: None,
            p_old: vec![0.0; n],
            v_mid: vec![0.0; n],
            pos_hat: vec![0.0; nz],
            vel_hat: vec![0.0; nz],
            pos: vec![0.0; nz],
            vel: vec![0.0; nz],
            z: vec![0.0; nz],
            z_new: vec![0.0; nz],
            phi: vec![0.0; nz],
            res: vec![0.0; nz],
            res_new: vec![0.0; nz],
            a0w: vec![0.0; nb],
            scale: vec![0.0; nz],
            zmax: vec![0.0; nz],
            dz: DVector::zeros(nz),
            jdz: vec![0.0; nz],
            jac: DMatrix::zeros(nz, nz),
            jac_lu: DMatrix::zeros(nz, nz),
            jac_piv: Vec::with_capacity(nz),
            jac_valid: false,
            jac_prev: None,
            trial_prev: vec![0.0; trial_len],
            phi_prev: vec![0.0; if nz == 1 { nz } else { 0 }],
            currents_prev: vec![0.0; if nz == 1 { nf } else { 0 }],
            secant_acceptance: true,
            z_hist: [0.0; START_POINTS],
            z_hist_len: 0,
            z_hist_t: None,
            z_pred: [0.0; START_NEEDS.len()],
            z_start: None,
            extrapolated_start: true,
            jac_measured: false,
            evaluations: 0,
            currents: vec![0.0; nf],
            base: model.has_base_excitation(),
            model_elements: model
                .mechanisms
                .iter()
                .any(|m| m.system.has_force_elements()),
            base_load,
            loaded,
            checked_condition: state.mechanisms.iter().map(|m| m.condition).collect(),
            repartitions: Vec::new(),
        })
    }

    /// The time step.
    pub fn step_size(&self) -> f64 {
        self.h
    }

    /// Evaluations of the reduced residual so far (each one follow of every mechanism; the
    /// finite-difference Jacobians' included): the iteration's cost.
    pub fn evaluations(&self) -> u64 {
        self.evaluations
    }

    /// Allows (the default) or forbids accepting the third iterate of a step with one
    /// unknown from the secant without evaluating it (see the module documentation); forbidden,
    /// every accepted iterate is one evaluated, for checks against that.
    pub fn set_secant_acceptance(&mut self, on: bool) {
        self.secant_acceptance = on;
    }

    /// Allows (the default) or forbids starting the iteration of a step with one unknown
    /// from its value extrapolated from the last steps' (of six predictions through up to
    /// five of them, the one that erred least on the last step; see the module
    /// documentation) instead of the last state's value; either way the iteration runs to
    /// the same convergence test. Forbidden, the iteration is the one before the
    /// extrapolated start, bit for bit.
    pub fn set_extrapolated_start(&mut self, on: bool) {
        self.extrapolated_start = on;
    }

    /// The beam load `P(t)`: the beam's own loads plus the beam excitations plus the
    /// supports' inertial load `base_load a_b(t)`.
    fn load_into(model: &HybridModel, base_load: &[f64], t: f64, out: &mut [f64]) {
        if let Some(beam) = &model.structure {
            LinearStructure::load_into(beam, t, out);
        }
        model.add_beam_excitations(t, out);
        if !base_load.is_empty() {
            let a = model.base_acceleration(t);
            for (o, b) in out.iter_mut().zip(base_load) {
                *o += a * b;
            }
        }
    }

    /// Evaluates the reduced residual at `z` (into `res`); the followers hold the trial
    /// state. `rule` advances inductive currents. Inlined into the iteration: a call's
    /// prologue, epilogue and argument moves cost about 25 instructions an evaluation.
    #[inline(always)]
    fn residual(
        &mut self,
        model: &HybridModel,
        t: f64,
        z_is_new: bool,
        state: &HybridState,
    ) -> Result<(), HybridError> {
        if self.nz == 1 {
            self.residual_sized::<1>(model, t, z_is_new, state)
        } else {
            self.residual_sized::<0>(model, t, z_is_new, state)
        }
    }

    /// [`Integrator::residual`] with the vectors cut to `NZ` entries when `NZ > 0` (a
    /// size known at compile time, as in [`Integrator::iterate_sized`]), else to `self.nz`.
    /// The same operations either way.
    #[inline(always)]
    fn residual_sized<const NZ: usize>(
        &mut self,
        model: &HybridModel,
        t: f64,
        z_is_new: bool,
        state: &HybridState,
    ) -> Result<(), HybridError> {
        let nz = if NZ > 0 { NZ } else { self.nz };
        self.evaluations += 1;
        let (bh2, gh) = (self.beta * self.h * self.h, self.gamma * self.h);
        let z = if z_is_new { &self.z_new } else { &self.z };
        for (((p, v), (ph, vh)), zi) in self.pos[..nz]
            .iter_mut()
            .zip(&mut self.vel[..nz])
            .zip(self.pos_hat[..nz].iter().zip(&self.vel_hat[..nz]))
            .zip(&z[..nz])
        {
            *p = ph + bh2 * zi;
            *v = vh + gh * zi;
        }
        let rule = CurrentRule {
            h: self.h,
            old: &state.currents,
            rate: &state.current_rates,
        };
        for f in self.followers.iter_mut() {
            let mech = f.mech;
            f.follow_trial(
                model,
                t,
                &self.pos,
                &self.vel,
                z,
                rule,
                &mut self.currents,
                &mut self.phi,
            )
            .map_err(|e| map_follow(model, &self.pos, mech, t, e))?;
        }
        let res = if z_is_new {
            &mut self.res_new
        } else {
            &mut self.res
        };
        // r_w = z_w - a0_w + S phi_w (S column-major), r_u = phi_u.
        let nb = self.nb;
        let s = self.s.as_slice();
        let (res, z, phi) = (&mut res[..nz], &z[..nz], &self.phi[..nz]);
        for (i, ((r, zi), a)) in res.iter_mut().zip(z).zip(&self.a0w).enumerate() {
            let mut x = zi - a;
            for (k, p) in phi[..nb].iter().enumerate() {
                x += s[k * nb + i] * p;
            }
            *r = x;
        }
        for (r, p) in res[nb..].iter_mut().zip(&phi[nb..]) {
            *r = *p;
        }
        Ok(())
    }

    /// Finite-difference Jacobian of the residual at `z` (with `res` its residual).
    fn fd_jacobian(
        &mut self,
        model: &HybridModel,
        t: f64,
        state: &HybridState,
    ) -> Result<(), HybridError> {
        self.jac_prev = None;
        for j in 0..self.nz {
            self.z_new.copy_from_slice(&self.z);
            // At least 1e-7 (m/s^2 or rad/s^2): a free coordinate starting at rest has
            // z = 0 and scale 1e-9, whose step would be lost in the residual's rounding.
            let d = 1e-7 * self.scale[j].max(1.0);
            self.z_new[j] += d;
            self.residual(model, t, true, state)?;
            let nz = self.nz;
            let col = &mut self.jac.as_mut_slice()[j * nz..(j + 1) * nz];
            for (c, (rn, r)) in col.iter_mut().zip(self.res_new.iter().zip(&self.res)) {
                *c = (rn - r) / d;
            }
        }
        self.factor_jacobian();
        Ok(())
    }

    /// Factorises `jac` into `jac_lu` / `jac_piv`, setting `jac_valid`. Inlined for the
    /// one-unknown case, a copy and a test where a call cost 40 instructions.
    #[inline(always)]
    fn factor_jacobian(&mut self) {
        // One unknown, once factorised before (`jac_piv` is `[0]`): [`lu_in_place`]'s 1 x 1
        // case (the pivot is the entry, valid when non-zero and finite) without clearing
        // and refilling the pivots.
        if let ([lu], &[j], [0]) = (
            self.jac_lu.as_mut_slice(),
            self.jac.as_slice(),
            self.jac_piv.as_slice(),
        ) {
            *lu = j;
            self.jac_valid = j.abs() != 0.0 && j.abs().is_finite();
            return;
        }
        self.factor_jacobian_general();
    }

    /// [`Integrator::factor_jacobian`] for any size (and the first 1 x 1 factorisation).
    #[inline(never)]
    fn factor_jacobian_general(&mut self) {
        copy_short(self.jac_lu.as_mut_slice(), self.jac.as_slice());
        self.jac_valid = lu_in_place(&mut self.jac_lu, &mut self.jac_piv);
    }

    /// The error of a non-converged iteration, naming the worst-conditioned mechanism.
    fn no_convergence(&mut self, model: &HybridModel, t: f64, iterations: usize) -> HybridError {
        // The trial evaluations do not measure the condition: measure it at the last one.
        for f in self.followers.iter_mut() {
            f.refresh_condition();
        }
        let worst = self
            .followers
            .iter()
            .max_by(|a, b| a.condition.total_cmp(&b.condition));
        let (mechanism, condition, sigma_min, displacement) = match worst {
            Some(f) => {
                let w = model
                    .attachments
                    .iter()
                    .position(|a| a.mechanism == f.mech)
                    .map_or(0.0, |k| self.pos[model.coupling_of(k)]);
                (
                    model.mechanisms[f.mech].name.clone(),
                    f.condition,
                    f.sigma_min,
                    w,
                )
            }
            None => (String::new(), 0.0, 0.0, 0.0),
        };
        HybridError::NoConvergence {
            t,
            residual: norm(&self.res),
            iterations,
            mechanism,
            displacement,
            condition,
            sigma_min,
        }
    }

    /// Solves the reduced equations at `t` for `z` (starting from `self.z`), leaving the
    /// accepted trial in the followers, `phi` and `currents`; then measures the condition of
    /// every mechanism's `J_d` there, an error beyond its `max_condition` (measured once
    /// per step, not at every trial evaluation).
    fn solve(
        &mut self,
        model: &HybridModel,
        t: f64,
        state: &HybridState,
    ) -> Result<(), HybridError> {
        self.iterate(model, t, state)?;
        for f in self.followers.iter_mut() {
            let mech = f.mech;
            f.check_condition(model)
                .map_err(|e| map_follow(model, &self.pos, mech, t, e))?;
        }
        Ok(())
    }

    /// The quasi-Newton iteration of [`Integrator::solve`] (trial evaluations without the
    /// condition check).
    ///
    /// With one unknown (`nz = 1`: the secant method) the step starts from the Jacobian
    /// extrapolated from the last two steps' ([`Integrator::extrapolate_jacobian`]), and
    /// after the first secant update the next iterate may be accepted without being
    /// evaluated ([`Integrator::accept_secant`]).
    fn iterate(
        &mut self,
        model: &HybridModel,
        t: f64,
        state: &HybridState,
    ) -> Result<(), HybridError> {
        match self.nz {
            0 => {
                // Beam alone (or mechanisms without free coordinates and attachments).
                self.residual(model, t, false, state)?;
                Ok(())
            }
            1 => self.iterate_sized::<1>(model, t, state),
            _ => self.iterate_sized::<0>(model, t, state),
        }
    }

    /// [`Integrator::iterate`] for `nz > 0` unknowns, `NZ` of them when `NZ > 0` (known at
    /// compile time: the vectors' loops of one unknown, the paper's damper, then compile to
    /// scalar operations), else `self.nz`. The same operations either way.
    #[inline(always)]
    fn iterate_sized<const NZ: usize>(
        &mut self,
        model: &HybridModel,
        t: f64,
        state: &HybridState,
    ) -> Result<(), HybridError> {
        let nz = if NZ > 0 { NZ } else { self.nz };
        let secant = nz == 1;
        if secant {
            self.extrapolate_jacobian();
            self.jac_measured = false;
        }
        if let Err(e) = self.residual(model, t, false, state) {
            // An extrapolated warm start that leaves the mechanism's reach: start again
            // from the state's own value.
            match self.z_start.take() {
                Some(z) if NZ == 1 => {
                    self.z[0] = z;
                    self.residual(model, t, false, state)?;
                }
                _ => return Err(e),
            }
        }
        if self.res[..nz].iter().all(|r| *r == 0.0) {
            return Ok(());
        }
        let mut refreshed = false;
        // The Jacobian is a finite-difference one, not yet updated by Broyden.
        let mut fresh = false;
        let mut iterations = 0;
        // Whether the followers hold the evaluation at `z` (finite differences move them).
        let mut at_z = true;
        // One unknown, after the step's first secant update: the relative change it made to
        // the Jacobian and the iterate the secant started from (whose trial is recorded).
        let mut secant_step: Option<(f64, f64)> = None;
        loop {
            if !self.jac_valid {
                self.fd_jacobian(model, t, state)?;
                refreshed = true;
                at_z = false;
                fresh = true;
                if !self.jac_valid {
                    return Err(self.no_convergence(model, t, iterations));
                }
            }
            iterations += 1;
            for (d, r) in self.dz.as_mut_slice()[..nz].iter_mut().zip(&self.res[..nz]) {
                *d = -r;
            }
            if NZ == 1 {
                // [`lu_solve`]'s 1 x 1 case: `x = b / u`.
                self.dz.as_mut_slice()[0] /= self.jac_lu.as_slice()[0];
            } else {
                lu_solve(&self.jac_lu, &self.jac_piv, &mut self.dz);
            }
            // Converged when the next quasi-Newton correction is below round-off level:
            // `z` is then the solution to that accuracy and the followers already hold it.
            if below_round_off(&self.dz.as_slice()[..nz], &self.scale[..nz], &self.z[..nz]) {
                if !at_z {
                    self.residual(model, t, false, state)?;
                }
                return Ok(());
            }
            if let Some((change, z_prev)) = secant_step.take() {
                if at_z && !refreshed && self.accept_secant(change, z_prev) {
                    return Ok(());
                }
            }
            // One unknown, the first step from a carried Jacobian: record the trial at `z`
            // for [`Integrator::accept_secant`].
            let record = secant && iterations == 1 && at_z && !refreshed;
            if record {
                self.record_trial();
            }
            for ((zn, z), d) in self.z_new[..nz]
                .iter_mut()
                .zip(&self.z[..nz])
                .zip(&self.dz.as_slice()[..nz])
            {
                *zn = z + d;
            }
            if let Err(e) = self.residual(model, t, true, state) {
                // A quasi-Newton step from a stale Jacobian may leave the mechanisms'
                // reach: retry once from the last good iterate with a fresh one.
                if refreshed {
                    return Err(e);
                }
                self.residual(model, t, false, state)?;
                self.jac_valid = false;
                at_z = true;
                continue;
            }
            at_z = true;
            // A Newton step from a fresh finite-difference Jacobian that no longer lowers
            // the residual, while small, has reached the residual's round-off floor (the
            // residual is nearly linear in z): converged, even when a free coordinate's
            // acceleration is near zero and the relative step test cannot be met.
            let dz = &self.dz.as_slice()[..nz];
            let (scale, z_new) = (&self.scale[..nz], &self.z_new[..nz]);
            let stalled = fresh
                && norm(&self.res_new[..nz]) >= norm(&self.res[..nz])
                && dz
                    .iter()
                    .zip(scale.iter().zip(z_new))
                    .all(|(d, (s, z))| d.abs() <= 1e-6 * s.max(1.0).max(z.abs()));
            let converged = below_round_off(dz, scale, z_new)
                || self.res_new[..nz].iter().all(|r| *r == 0.0)
                || stalled;
            // Broyden's update J += ((dr - J dz) dz^T) / (dz^T dz) (the secant method in
            // one dimension); not from the last, converged step, whose residual change is
            // round-off, nor (one unknown) from a step within 1e3 of the round-off level,
            // whose residual change is mostly rounding: a secant from it could be wrong in
            // the third digit, and the next step's extrapolated Jacobian with it.
            let dd: f64 = dz.iter().map(|x| x * x).sum();
            let tiny = secant
                && dz
                    .iter()
                    .zip(scale.iter().zip(z_new))
                    .all(|(d, (s, z))| d.abs() <= 1e-10 * s.max(z.abs()));
            if dd > 0.0 && !converged && !tiny {
                // `jac` column-major: J_ij at `j nz + i`.
                let jac = &mut self.jac.as_mut_slice()[..nz * nz];
                for (i, (jdz, (rn, r))) in self.jdz[..nz]
                    .iter_mut()
                    .zip(self.res_new[..nz].iter().zip(&self.res[..nz]))
                    .enumerate()
                {
                    let mut jd = 0.0;
                    for (j, d) in dz.iter().enumerate() {
                        jd += jac[j * nz + i] * d;
                    }
                    *jdz = (rn - r - jd) / dd;
                }
                for (col, d) in jac.chunks_exact_mut(nz).zip(dz) {
                    for (c, jdz) in col.iter_mut().zip(&self.jdz[..nz]) {
                        *c += jdz * d;
                    }
                }
                if record {
                    // The secant is meaningful only from a step well above the residual's
                    // rounding (`tiny` above), here 1e-9 of the unknown's scale.
                    let (z0, z1) = (self.z[0], self.z_new[0]);
                    if (z1 - z0).abs() > 1e-9 * self.scale[0].max(z1.abs()) {
                        let change = (self.jdz[0] * dz[0]).abs() / jac[0].abs();
                        secant_step = Some((change, z0));
                        self.jac_measured = true;
                    }
                }
                self.factor_jacobian();
                fresh = false;
            }
            // The new iterate and its residual become the current ones (`z_new` and
            // `res_new` are written in full before they are read again).
            std::mem::swap(&mut self.z, &mut self.z_new);
            std::mem::swap(&mut self.res, &mut self.res_new);
            if converged {
                return Ok(());
            }
            if iterations % 12 == 0 {
                self.jac_valid = false;
            }
            if iterations >= 40 {
                return Err(self.no_convergence(model, t, iterations));
            }
        }
    }

    /// One unknown: extrapolates the Jacobian carried from the last step linearly from the
    /// last two steps' (`J + (J - J_prev)`; the Jacobian follows the slowly changing
    /// mechanism, and the extrapolated one is typically 1e-7 of it off where the carried
    /// one is 1e-4), unless that changes it by more than 10 % or leaves it singular; records
    /// the carried one as the next step's `J_prev`. Without a valid Jacobian (a
    /// finite-difference refresh follows) the history is dropped.
    fn extrapolate_jacobian(&mut self) {
        if !self.jac_valid {
            self.jac_prev = None;
            return;
        }
        let j1 = self.jac[(0, 0)];
        if let Some(j0) = self.jac_prev {
            let jp = j1 + (j1 - j0);
            if (jp - j1).abs() <= 0.1 * j1.abs() {
                self.jac[(0, 0)] = jp;
                self.factor_jacobian();
                if !self.jac_valid {
                    self.jac[(0, 0)] = j1;
                    self.factor_jacobian();
                }
            }
        }
        self.jac_prev = Some(j1);
    }

    /// Records the followers' trial states, `phi` and the currents of the evaluation at `z`
    /// (one unknown), the first point of [`Integrator::accept_secant`]'s secant.
    fn record_trial(&mut self) {
        let mut rest = self.trial_prev.as_mut_slice();
        for f in &self.followers {
            let (out, tail) = rest.split_at_mut(f.trial_len());
            f.save_trial(out);
            rest = tail;
        }
        copy_short(&mut self.phi_prev, &self.phi);
        copy_short(&mut self.currents_prev, &self.currents);
    }

    /// One unknown, after the secant update from the recorded iterate `z_prev` to `z`
    /// changed the Jacobian by the relative amount `change`, with `dz` the secant step from
    /// `z`: accepts `z + dz` without evaluating it when the correction an evaluation there
    /// would give is below round-off level.
    ///
    /// That correction is `-(J_t - J) dz / J` with `J_t` the residual's slope between `z`
    /// and `z + dz` and `J` the secant's: the residual at `z + dz` is `r + J_t dz` with
    /// `r + J dz = 0`. The secant's error `|J_t - J| / |J|` comes from the residual's
    /// curvature over `z_prev .. z + dz`, a small part of the change of the Jacobian over a
    /// time step that `change` measures (the carried Jacobian's error: the extrapolation's
    /// of the slowly changing mechanism), and is bounded by `change` with a factor
    /// 10 to spare: the test is `10 change |dz|` below round-off ([`below_round_off`]),
    /// the same bound that accepts an evaluated iterate.
    ///
    /// The followers' states, `phi` and the currents, then move along the secant through
    /// the recorded evaluation at `z_prev` and the last one at `z` to `z + dz`
    /// ([`Follower::extrapolate_trial`]): exact for the parts linear in `z`, and for the rest
    /// off by the curvature over `dz_1 dz`, of the order of the residual's error there.
    fn accept_secant(&mut self, change: f64, z_prev: f64) -> bool {
        let (z1, dz) = (self.z[0], self.dz[0]);
        let z2 = z1 + dz;
        // Written so that a NaN bound declines.
        let within = 10.0 * change * dz.abs() <= 1e-13 * self.scale[0].max(z2.abs());
        if !self.secant_acceptance || !within {
            return false;
        }
        let ratio = dz / (z1 - z_prev);
        let (bh2, gh) = (self.beta * self.h * self.h, self.gamma * self.h);
        self.z[0] = z2;
        self.pos[0] = self.pos_hat[0] + bh2 * z2;
        self.vel[0] = self.vel_hat[0] + gh * z2;
        let mut prev = self.trial_prev.as_slice();
        for f in self.followers.iter_mut() {
            let (p, tail) = prev.split_at(f.trial_len());
            f.extrapolate_trial(p, ratio, &self.pos, &self.vel, &self.z);
            prev = tail;
        }
        for (x, p) in self
            .phi
            .iter_mut()
            .zip(&self.phi_prev)
            .chain(self.currents.iter_mut().zip(&self.currents_prev))
        {
            *x += ratio * (*x - p);
        }
        // After the swap `res_new` holds the residual at `z_prev`.
        self.res[0] += ratio * (self.res[0] - self.res_new[0]);
        true
    }

    /// Sets the per-unknown scales (after [`Integrator::predict_mechanisms`], which sets
    /// the predictor of the attachment accelerations they take).
    #[inline(always)]
    fn prepare(&mut self) {
        for (i, (s, (z, m))) in self
            .scale
            .iter_mut()
            .zip(self.z.iter().zip(&self.zmax))
            .enumerate()
        {
            let base = self.a0w.get(i).map_or(0.0, |a| a.abs());
            *s = 1e-9 + z.abs() + base + 1e-2 * m;
        }
    }

    /// Loads the predictors of the attachments and the free coordinates, the attachments'
    /// accelerations predicted from `r0` (`a0w`, the value along the attachment of `r0` or,
    /// for a folded step, of `r0 - kappa v^`; 0 without a beam) and the warm start `z`
    /// from `state` (one unknown: extrapolated from the last steps,
    /// [`Integrator::extrapolate_start`]).
    #[inline(always)]
    fn predict_mechanisms(&mut self, model: &HybridModel, state: &HybridState) {
        let (h, beta, gamma) = (self.h, self.beta, self.gamma);
        let n = self.r0.len();
        for (k, c) in self.couplings.iter().enumerate() {
            let p = &model.attachments[c.attachment].beam;
            let weights = p.component(c.axial);
            let (pos, vel, acc, a0) = match self.r0_kappa {
                // The four sums in one pass over the weights.
                Some(kappa) if n > 0 => values_along_folded(
                    weights,
                    [&self.q_hat, &self.v_hat, &state.a, &self.r0],
                    kappa,
                ),
                // Not folded (here with a beam), or no beam.
                _ => {
                    let (pos, vel, acc) = values_along(weights, &self.q_hat, &self.v_hat, &state.a);
                    let a0 = if n > 0 {
                        p.value_along(c.axial, &self.r0)
                    } else {
                        0.0
                    };
                    (pos, vel, acc, a0)
                }
            };
            self.pos_hat[k] = pos;
            self.vel_hat[k] = vel;
            self.z[k] = acc;
            self.a0w[k] = a0;
        }
        let mut i = self.nb;
        for (f, ms) in self.followers.iter().zip(&state.mechanisms) {
            for &c in &f.free {
                self.pos_hat[i] = ms.q[c] + h * ms.qd[c] + h * h * (0.5 - beta) * ms.qdd[c];
                self.vel_hat[i] = ms.qd[c] + h * (1.0 - gamma) * ms.qdd[c];
                self.z[i] = ms.qdd[c];
                i += 1;
            }
        }
        if self.nz == 1 {
            self.extrapolate_start(state.t);
        }
    }

    /// One unknown: records the state's value `z` (the last step's accepted acceleration,
    /// at `t`) in the history and starts the iteration from the value at `t + h` of the
    /// polynomial through the last `k + 1` values (equally spaced by the step, `k <= 4`)
    /// or of a quadratic plus an alternation growing linearly through the last five, the
    /// one chosen by the last step: whose prediction of `z` erred least, yet not below
    /// 1e-8 of the unknown's scale (order 0, the state's own value, when none).
    ///
    /// `z` sampled `h` apart is smooth when the motion is slow against the step (the
    /// order-`k` error about `(omega h)^(k+1)` of the amplitude; measured on damper.toml
    /// between 0.5 and 1.0 s, relative to the scale: median 3e-3 for the state's value,
    /// 2e-8 for the fourth order) but not when the beam's high modes (average acceleration:
    /// undamped, near the step's Nyquist frequency at 200 elements) carry it, where every
    /// order doubles the error (3e-2 for the state's value) and the prediction that follows
    /// the alternation does best (2e-5): the last step's errors choose. The floor keeps
    /// the first correction large enough for the secant through it to measure the
    /// Jacobian's slope (below 1e-8 of the scale the residual's rounding, some 1e-13 of it,
    /// spoils the slope, and the Jacobian extrapolated from it,
    /// [`Integrator::extrapolate_jacobian`]); a step that did not measure it
    /// (`jac_measured`) is followed by one from the state's value, whose first correction,
    /// about `omega h` of the scale, does. The iteration's convergence test is the same
    /// whatever the start.
    ///
    /// The history restarts when the steps do not follow each other (the state's time is
    /// not the last one's plus `h`), after a re-partition (a free coordinate's unknown may
    /// be another coordinate's) and in the integrator of the initial accelerations (`h = 0`).
    fn extrapolate_start(&mut self, t: f64) {
        let z = self.z[0];
        self.z_start = None;
        let key = self.repartitions.len();
        let follows = matches!(self.z_hist_t, Some((tp, k)) if tp + self.h == t && k == key);
        if !follows || self.h == 0.0 || !self.extrapolated_start {
            self.z_hist_len = 0;
        }
        let order = start_choice(&self.z_pred, self.z_hist_len, z, 1e-8 * self.scale[0]);
        self.z_hist.copy_within(..START_POINTS - 1, 1);
        self.z_hist[0] = z;
        self.z_hist_len = (self.z_hist_len + 1).min(START_POINTS);
        self.z_hist_t = Some((t, key));
        self.z_pred = start_predictions(&self.z_hist);
        if order > 0 && self.jac_measured {
            self.z[0] = self.z_pred[order];
            self.z_start = Some(z);
        }
    }

    /// Consistent initial accelerations of `state` (beam and mechanisms) and currents: the
    /// reduced equations solved at fixed positions and velocities (an integrator built with
    /// `h = 0`).
    pub fn initial_accelerations(
        &mut self,
        model: &HybridModel,
        state: &mut HybridState,
    ) -> Result<(), HybridError> {
        self.q_hat.copy_from_slice(&state.q);
        self.v_hat.copy_from_slice(&state.v);
        self.r0_kappa = None;
        if let Some(beam) = &model.structure {
            Self::load_into(model, &self.base_load, state.t, &mut self.p_new);
            self.p_new_t = Some(state.t);
            self.r0.copy_from_slice(&self.p_new);
            beam.damping_mul_add(-1.0, &state.v, &mut self.r0);
            beam.stiffness_mul_add(-1.0, &state.q, &mut self.r0);
            if let Some(f) = &self.factor {
                Structure::solve_in_place(f, &mut self.r0);
            }
        }
        self.predict_mechanisms(model, state);
        self.prepare();
        self.solve(model, state.t, state)?;
        self.accept(model, state);
        Ok(())
    }

    /// Whether [`Integrator::integrate_beam`] forms the beam accelerations itself, in its
    /// pass (a folded step with one coupling column, the paper's damper): `a = (r0 - kappa
    /// v^) - z phi_w`, the operations of [`Integrator::accept`]'s pass.
    fn fused_accelerations(&self, n: usize) -> bool {
        n > 0 && self.nb == 1 && self.r0_kappa.is_some()
    }

    /// Writes the accepted solution into `state` (beam accelerations from
    /// `a = a0 - K^-1 N phi_w`, `a0 = r0 - kappa v^` for a folded step, unless
    /// [`Integrator::integrate_beam`] forms them ([`Integrator::fused_accelerations`]);
    /// mechanisms from the followers); the beam's positions and velocities are
    /// [`Integrator::integrate_beam`]'s.
    #[inline(always)]
    fn accept(&mut self, model: &HybridModel, state: &mut HybridState) {
        let n = state.q.len();
        if !self.fused_accelerations(n) {
            self.accept_beam(state);
        }
        for (m, z) in self.zmax.iter_mut().zip(&self.z) {
            *m = m.max(z.abs());
        }
        for (f, ms) in self.followers.iter().zip(state.mechanisms.iter_mut()) {
            copy_short(&mut ms.q, f.q().as_slice());
            copy_short(&mut ms.qd, f.qd.as_slice());
            copy_short(&mut ms.qdd, f.qdd.as_slice());
            ms.condition = f.condition;
            ms.sigma_min = f.sigma_min;
            ms.residual = f.residual;
        }
        for (k, f) in model.forces.iter().enumerate() {
            let i = self.currents[k];
            state.currents[k] = i;
            state.current_rates[k] = match f.generator() {
                Some(g) if f.has_current_state() => {
                    let w = state.mechanisms[f.mechanism].qd[f.joint];
                    (g.ke * g.gear_ratio * w - g.resistance() * i) / g.inductance
                }
                _ => 0.0,
            };
        }
    }

    /// The beam accelerations `a = a0 - K^-1 N phi_w` (`a0 = r0 - kappa v^` for a folded
    /// step) into `state.a`, in a pass of their own.
    fn accept_beam(&self, state: &mut HybridState) {
        let n = state.q.len();
        // `a0` and the first column in the same pass as the copy of `r0` (the same
        // operations as the passes one after the other).
        let mut cols = self.zcols.chunks_exact(n.max(1)).zip(&self.phi);
        let a0 = state.a.iter_mut().zip(&self.r0);
        match (cols.next(), self.r0_kappa) {
            (Some((col, phi)), None) if n > 0 => {
                for ((a, r), z) in a0.zip(col) {
                    *a = r - z * phi;
                }
            }
            (Some((col, phi)), Some(kappa)) if n > 0 => {
                for (((a, r), z), vh) in a0.zip(col).zip(&self.v_hat) {
                    *a = (r - kappa * vh) - z * phi;
                }
            }
            (_, Some(kappa)) => {
                for ((a, r), vh) in a0.zip(&self.v_hat) {
                    *a = r - kappa * vh;
                }
            }
            (_, None) => state.a.copy_from_slice(&self.r0),
        }
        for (col, phi) in cols {
            for (a, z) in state.a.iter_mut().zip(col) {
                *a -= z * phi;
            }
        }
    }

    /// The beam's Newmark update from the accepted accelerations, `q = q^ + beta h^2 a`,
    /// `v = v^ + gamma h a`, in one pass with what the energy account needs of it: the
    /// midpoint velocity `v_mid = (v_n + v_{n+1}) / 2` (into `v_mid`) and the power of the
    /// beam loads `sum (P_n + P_{n+1}) / 2 v_mid` (returned with whether the new positions
    /// and velocities are finite). With [`Integrator::fused_accelerations`] the same pass
    /// forms the accelerations first, `a = (r0 - kappa v^) - z phi_w` into `state.a` (the
    /// operations of [`Integrator::accept_beam`]: the same numbers).
    fn integrate_beam(
        &mut self,
        model: &HybridModel,
        state: &mut HybridState,
    ) -> (Option<bool>, f64) {
        let n = state.q.len();
        if self.fused_accelerations(n) {
            match self.integrate_beam_fused(model, state) {
                Some(result) => return result,
                None => self.accept_beam(state),
            }
        }
        let (cq, cv) = (self.beta * self.h * self.h, self.gamma * self.h);
        let loads = self
            .loaded
            .then_some((self.p_old.as_slice(), self.p_new.as_slice()));
        let (finite, work) = newmark_update(
            [cq, cv],
            &mut state.q,
            &mut state.v,
            &mut self.v_mid,
            &self.q_hat,
            &self.v_hat,
            &state.a,
            loads,
        );
        (Some(finite), work)
    }

    /// [`Integrator::integrate_beam`] with the accelerations of a folded step with one
    /// coupling column formed in its pass; `None` (nothing written) without that column.
    ///
    /// The finiteness of the new `q` and `v` is left to the step's dissipation form
    /// (`None`) for the beam when `beta h^2 <= gamma h`: every row's term of the beam's
    /// banded form `v_mid^T B v_mid` is `x_i (B_ii x_i + 2 sum_j B_ij x_j)`, infinite or NaN
    /// when `x_i` is, and a sum holding an infinite or NaN term never returns to a finite
    /// value; `v_mid = (v_old + v) / 2` with `v_old` finite is finite exactly when `v` is;
    /// and a finite `v = v^ + gamma h a` has a finite `a`, whose `q = q^ + beta h^2 a` is
    /// then finite (`beta h^2 a` no larger than `gamma h a`) short of a sum of magnitudes
    /// near `f64::MAX`. Otherwise each entry is tested in the pass.
    fn integrate_beam_fused(
        &mut self,
        model: &HybridModel,
        state: &mut HybridState,
    ) -> Option<(Option<bool>, f64)> {
        let n = state.q.len();
        let (cq, cv) = (self.beta * self.h * self.h, self.gamma * self.h);
        let (Some(kappa), Some(&phi), Some(col)) =
            (self.r0_kappa, self.phi.first(), self.zcols.get(..n))
        else {
            return None;
        };
        let loads = self
            .loaded
            .then_some((self.p_old.as_slice(), self.p_new.as_slice()));
        let by_form = cq <= cv && matches!(model.structure, Some(Structure::Beam(_)));
        let c = [cq, cv, kappa, phi];
        let (q, v, a, m) = (&mut state.q, &mut state.v, &mut state.a, &mut self.v_mid);
        let (r, qh, vh) = (&self.r0, &self.q_hat, &self.v_hat);
        Some(if by_form {
            let (_, work) = newmark_fused::<false>(c, q, v, a, m, r, col, qh, vh, loads);
            (None, work)
        } else {
            let (finite, work) = newmark_fused::<true>(c, q, v, a, m, r, col, qh, vh, loads);
            (Some(finite), work)
        })
    }

    /// The mechanism models' own force elements in the energy account (docs/theory.md section 8:
    /// d(T + V)/dt of a tree is P - D), by the trapezoidal rule between `state` (the old
    /// step) and the followers' solution. Kept out of [`Integrator::step`]'s body (not
    /// inlined): inlined, it changed how the step's vector loops were compiled and cost 4 %
    /// of the step of the paper's damper, whose model has no force elements.
    #[inline(never)]
    fn account_model_elements(
        followers: &mut [Follower],
        model: &HybridModel,
        state: &mut HybridState,
        h: f64,
    ) {
        let acc = &mut state.account;
        acc.dissipated_model.resize(followers.len(), 0.0);
        acc.model_input_work.resize(followers.len(), 0.0);
        for (i, f) in followers.iter_mut().enumerate() {
            // Without force elements D = P = 0 at every state.
            if !model.mechanisms[i].system.has_force_elements() {
                continue;
            }
            let ms = &state.mechanisms[i];
            let old = f.element_power(model, &ms.q, &ms.qd);
            let new = f.current_element_power(model);
            acc.dissipated_model[i] += 0.5 * h * (old.dissipated + new.dissipated);
            acc.model_input_work[i] += 0.5 * h * (old.input + new.input);
        }
    }

    /// The supports' inertial loads on the mechanisms in the energy account: the work of
    /// each base excitation `k`, `integral a_k(t) sum_i q_i'^T G_i(q_i) R_i^T y dt`, by the
    /// trapezoidal rule between `state` (the old step) and the followers' solution. Kept
    /// out of [`Integrator::step`]'s body like [`Integrator::account_model_elements`].
    #[inline(never)]
    fn account_base_mechanisms(
        followers: &mut [Follower],
        model: &HybridModel,
        state: &mut HybridState,
        t_new: f64,
        h: f64,
    ) {
        let (mut old, mut new) = (0.0, 0.0);
        for (i, f) in followers.iter_mut().enumerate() {
            let ms = &state.mechanisms[i];
            old += f.base_power(model, &ms.q, &ms.qd);
            new += f.current_base_power(model);
        }
        for (k, e) in model.excitations.iter().enumerate() {
            if e.target.is_base() {
                state.account.excitation_work[k] +=
                    0.5 * h * (e.value(state.t) * old + e.value(t_new) * new);
            }
        }
    }

    /// Advances `state` by one step. Allocates nothing (unless a mechanism is
    /// re-partitioned, which is logged in [`Integrator::repartitions`]).
    pub fn step(
        &mut self,
        model: &HybridModel,
        state: &mut HybridState,
    ) -> Result<(), HybridError> {
        let (h, alpha, beta, gamma) = (self.h, self.alpha, self.beta, self.gamma);
        let t_new = state.t + h;
        self.r0_kappa = None;
        if let Some((mu, kappa)) = self.fold {
            self.step_folded(model, state, mu, kappa);
        } else if let Some(beam) = &model.structure {
            let (ca, cv) = (h * h * (0.5 - beta), h * (1.0 - gamma));
            for ((qh, vh), ((q, v), a)) in self
                .q_hat
                .iter_mut()
                .zip(&mut self.v_hat)
                .zip(state.q.iter().zip(&state.v).zip(&state.a))
            {
                *qh = q + h * v + ca * a;
                *vh = v + cv * a;
            }
            // r0 = (1+alpha)(P_{n+1} - B v^ - C q^) - alpha (P_n - B v_n - C q_n)
            self.advance_loads(model, state.t, t_new);
            self.r0.copy_from_slice(&self.p_new);
            beam.damping_mul_add(-1.0, &self.v_hat, &mut self.r0);
            beam.stiffness_mul_add(-1.0, &self.q_hat, &mut self.r0);
            if alpha != 0.0 {
                for x in self.r0.iter_mut() {
                    *x *= 1.0 + alpha;
                }
                for (r, p) in self.r0.iter_mut().zip(&self.p_old) {
                    *r -= alpha * p;
                }
                beam.damping_mul_add(alpha, &state.v, &mut self.r0);
                beam.stiffness_mul_add(alpha, &state.q, &mut self.r0);
            }
            if let Some(f) = &self.factor {
                Structure::solve_in_place(f, &mut self.r0);
            }
        }
        self.finish_step(model, state)
    }

    /// The beam loads of a step from `t` to `t_new`: `P_n` into `p_old` (the last step's
    /// `P_{n+1}` when that step ended at `t`: the loads are functions of t alone), `P_{n+1}`
    /// into `p_new`. Without loads both stay zero.
    fn advance_loads(&mut self, model: &HybridModel, t: f64, t_new: f64) {
        if self.loaded {
            if self.p_new_t == Some(t) {
                std::mem::swap(&mut self.p_old, &mut self.p_new);
            } else {
                Self::load_into(model, &self.base_load, t, &mut self.p_old);
            }
            Self::load_into(model, &self.base_load, t_new, &mut self.p_new);
        }
        self.p_new_t = Some(t_new);
    }

    /// The beam's part of a step with the Rayleigh damping folded into the factorised
    /// matrix (docs/theory.md section 13.5): the predictors, `q_mix = q^ + mu v^`, and
    /// `P_{n+1} - C q_mix` in one pass ([`LinearStructure::predict_stiffness_mul_sub`]; the
    /// loads are functions of t alone, advanced first), then
    /// `r0 = K^-1 (P_{n+1} - C q_mix)` — one banded product instead of the two with `B`
    /// and `C` — whose `- kappa v^` is taken where `r0` is read (`r0_kappa`).
    fn step_folded(&mut self, model: &HybridModel, state: &HybridState, mu: f64, kappa: f64) {
        let (h, beta, gamma) = (self.h, self.beta, self.gamma);
        let Some(beam) = &model.structure else {
            return;
        };
        let t_new = state.t + h;
        let predictor = NewmarkPredictor {
            h,
            ca: h * h * (0.5 - beta),
            cv: h * (1.0 - gamma),
            mu,
        };
        self.advance_loads(model, state.t, t_new);
        beam.predict_stiffness_mul_sub(
            &predictor,
            [&state.q, &state.v, &state.a],
            [&mut self.q_hat, &mut self.v_hat, &mut self.q_mix],
            &self.p_new,
            &mut self.r0,
        );
        if let Some(f) = &self.factor {
            Structure::solve_in_place(f, &mut self.r0);
        }
        self.r0_kappa = Some(kappa);
    }

    /// The rest of [`Integrator::step`] once `q^`, `v^`, the loads and `r0` are set: the
    /// mechanisms' iteration, the energy account and the Newmark update.
    fn finish_step(
        &mut self,
        model: &HybridModel,
        state: &mut HybridState,
    ) -> Result<(), HybridError> {
        let h = self.h;
        let t_new = state.t + h;
        self.predict_mechanisms(model, state);
        self.prepare();
        self.solve(model, t_new, state)?;
        // Energy account, part 1 (needs the old state): per force element and excitation,
        // trapezoidal power.
        let acc = &mut state.account;
        let nf = model.forces.len();
        if acc.gearbox_loss.len() != nf
            || acc.mechanical_input.len() != nf
            || acc.conversion.len() != nf
        {
            acc.gearbox_loss.resize(nf, 0.0);
            acc.mechanical_input.resize(nf, 0.0);
            acc.conversion.resize(nf, 0.0);
        }
        for (k, f) in model.forces.iter().enumerate() {
            let (w_old, i_old) = (state.mechanisms[f.mechanism].qd[f.joint], state.currents[k]);
            let (w_new, i_new) = (self.followers[f.mechanism].qd[f.joint], self.currents[k]);
            let Some(g) = f.generator() else {
                let old = f.dissipated_power(w_old, i_old);
                let new = f.dissipated_power(w_new, i_new);
                acc.dissipated[k] += 0.5 * h * (old + new);
                continue;
            };
            // The generator's powers at both ends (`dissipated_power`, `mechanical_power`,
            // `gear_loss_power`: the same numbers, the gear-loss test made once).
            let (loss, [old, new]) = g.step_powers([(w_old, i_old), (w_new, i_new)]);
            acc.dissipated[k] += 0.5 * h * (old.dissipated + new.dissipated);
            acc.mechanical_input[k] += 0.5 * h * (old.mechanical + new.mechanical);
            if g.kt != g.ke {
                let p = |w: f64, i: f64| (g.kt - g.ke) * g.gear_ratio * i * w;
                acc.conversion[k] += 0.5 * h * (p(w_old, i_old) + p(w_new, i_new));
            }
            if loss {
                acc.gearbox_loss[k] += 0.5 * h * (old.gear_loss + new.gear_loss);
            }
        }
        // Without force elements in any model only the account's sizes are set (once).
        let nm = self.followers.len();
        if self.model_elements
            || state.account.dissipated_model.len() != nm
            || state.account.model_input_work.len() != nm
        {
            Self::account_model_elements(&mut self.followers, model, state, h);
        }
        if self.base {
            Self::account_base_mechanisms(&mut self.followers, model, state, t_new, h);
        }
        let acc = &mut state.account;
        for (k, e) in model.excitations.iter().enumerate() {
            if let ExcitationTarget::Joint { mechanism, joint } = e.target {
                let old = e.value(state.t) * state.mechanisms[mechanism].qd[joint];
                let new = e.value(t_new) * self.followers[mechanism].qd[joint];
                acc.excitation_work[k] += 0.5 * h * (old + new);
            }
        }
        self.accept(model, state);
        let (beam_finite, work) = self.integrate_beam(model, state);
        // The Rayleigh dissipation form of the midpoint velocities (energy account, part
        // 2), which also decides the beam's finiteness when the update left it to it.
        let form = model
            .structure
            .as_ref()
            .map_or(0.0, |beam| beam.damping_quadratic_form(&self.v_mid));
        let finite = beam_finite.unwrap_or(form.is_finite())
            && state
                .mechanisms
                .iter()
                .all(|m| m.q.iter().chain(&m.qd).all(|x| x.is_finite()))
            && state.currents.iter().all(|x| x.is_finite());
        if !finite {
            return Err(HybridError::Diverged { t: t_new });
        }
        // Energy account, part 2: midpoint velocity for the Rayleigh dissipation and the
        // beam loads (exact for the linear part under the average-acceleration rule).
        if model.structure.is_some() {
            let acc = &mut state.account;
            acc.dissipated_structure += h * form;
            let mut excited = 0.0;
            let base_v: f64 = self
                .base_load
                .iter()
                .zip(&self.v_mid)
                .map(|(b, v)| b * v)
                .sum();
            for (k, e) in model.excitations.iter().enumerate() {
                let w = match &e.target {
                    ExcitationTarget::Beam(p) => {
                        0.5 * (e.value(state.t) + e.value(t_new)) * p.value(&self.v_mid)
                    }
                    ExcitationTarget::Base { .. } if !self.base_load.is_empty() => {
                        0.5 * (e.value(state.t) + e.value(t_new)) * base_v
                    }
                    _ => continue,
                };
                acc.excitation_work[k] += h * w;
                excited += w;
            }
            acc.beam_load_work += h * (work - excited);
        }
        state.t = t_new;
        state.steps += 1;
        self.check_partitions(state);
        Ok(())
    }

    /// Re-chooses the free coordinates of a mechanism whose `J_d` has degraded (cond grown
    /// by a factor 2 since the last check and above 10) when full pivoting finds a better
    /// block; logs the change.
    fn check_partitions(&mut self, state: &mut HybridState) {
        for (i, f) in self.followers.iter_mut().enumerate() {
            if f.free.is_empty() || f.rows() == 0 {
                continue;
            }
            let c = f.condition;
            if c.is_nan() || c <= 10.0 || c <= 2.0 * self.checked_condition[i] {
                continue;
            }
            self.checked_condition[i] = c;
            let choice = choose_partition(f.jacobian(), 1e-12);
            if choice.partition.independent == f.free || choice.rank < f.rows() {
                continue;
            }
            let from = f.free.clone();
            f.set_free(&choice.partition.independent);
            // Condition of the new block at the same state.
            let old = c;
            f.refresh_condition();
            let new = f.condition;
            if new >= old {
                f.set_free(&from);
                f.refresh_condition();
                continue;
            }
            self.checked_condition[i] = new;
            state.mechanisms[i].free.clone_from(&f.free);
            state.mechanisms[i].condition = new;
            self.repartitions.push(Repartition {
                t: state.t,
                mechanism: i,
                from,
                to: f.free.clone(),
                condition: (old, new),
            });
            self.jac_valid = false;
        }
    }

    /// Velocity amplification `dq_joint / dw` of mechanism `mech`'s coordinate `joint` with
    /// respect to the displacement of attachment `attachment` (free coordinates held), at
    /// `state` (eq. 18); `None` if the attachment is not on that mechanism. For the double
    /// bar with the generator on the crank this is `g_1 = q1'/y'`. Allocation-free.
    pub fn amplification(
        &mut self,
        model: &HybridModel,
        state: &HybridState,
        mech: usize,
        attachment: usize,
        joint: usize,
    ) -> Option<f64> {
        for (k, c) in self.couplings.iter().enumerate() {
            self.pos[k] = model.attachments[c.attachment]
                .beam
                .value_along(c.axial, &state.q);
        }
        let f = self.followers.get_mut(mech)?;
        f.influence(
            model,
            &state.mechanisms[mech].q,
            &self.pos,
            attachment,
            joint,
        )
    }

    /// Stored energies at `state`, into `out` (allocation-free once `out` has the sizes).
    pub fn stored_into(&mut self, model: &HybridModel, state: &HybridState, out: &mut Stored) {
        if let Some(beam) = &model.structure {
            out.beam_kinetic = 0.5 * beam.mass_quadratic_form(&state.v);
            out.beam_potential = 0.5 * beam.stiffness_quadratic_form(&state.q);
        }
        out.mechanism_kinetic.resize(model.mechanisms.len(), 0.0);
        out.mechanism_potential.resize(model.mechanisms.len(), 0.0);
        out.magnetic = 0.0;
        for (i, f) in self.followers.iter_mut().enumerate() {
            let ms = &state.mechanisms[i];
            let (ke, pe) = f.energies(model, state.t, &ms.q, &ms.qd, &state.currents);
            out.mechanism_kinetic[i] = ke;
            out.mechanism_potential[i] = pe;
        }
        for (k, f) in model.forces.iter().enumerate() {
            let q = state.mechanisms[f.mechanism].q[f.joint];
            let e = f.stored_energy(q, state.currents[k]);
            match f.kind {
                super::model::ForceKind::Spring { .. } => out.mechanism_potential[f.mechanism] += e,
                _ => out.magnetic += e,
            }
        }
    }
}

/// The number of last steps' values of the one unknown ([`Integrator::extrapolate_start`]).
const START_POINTS: usize = 5;

/// The number of last steps' values each prediction of [`Integrator::extrapolate_start`]
/// takes.
const START_NEEDS: [usize; 6] = [1, 2, 3, 4, 5, 5];

/// The predictions of the next value of a sequence from its last values `h` (the latest
/// first) of [`Integrator::extrapolate_start`]: the order-`k` extrapolations through `k + 1`
/// values (`k` = 0 to 4; binomial weights, exact when `(E - 1)^(k+1)` annihilates the
/// sequence, `E` the shift), then the one exact for a quadratic plus an alternation
/// growing linearly (`(E - 1)^3 (E + 1)^2`). Each takes the number of values in
/// [`START_NEEDS`].
#[inline(always)]
fn start_predictions(h: &[f64; START_POINTS]) -> [f64; START_NEEDS.len()] {
    let [a, b, c, d, e] = *h;
    [
        a,
        2.0 * a - b,
        3.0 * (a - b) + c,
        4.0 * (a + c) - 6.0 * b - d,
        5.0 * (a - d) + 10.0 * (c - b) + e,
        (a - d) + 2.0 * (b - c) + e,
    ]
}

/// The prediction [`Integrator::extrapolate_start`] takes: of the last step's predictions
/// `pred` (from a history of `len` values: those that take more are void), the one whose
/// error against the value `z` that came was the smallest not below `floor`; 0 (the value
/// itself) when there is none.
#[inline(always)]
fn start_choice(pred: &[f64; START_NEEDS.len()], len: usize, z: f64, floor: f64) -> usize {
    let (mut choice, mut best) = (0, f64::INFINITY);
    for (k, (p, &n)) in pred.iter().zip(&START_NEEDS).enumerate() {
        let e = (p - z).abs();
        if n <= len && e >= floor && e < best {
            (choice, best) = (k, e);
        }
    }
    choice
}

/// Whether every correction `dz_i` is below round-off level of its unknown:
/// `|dz_i| <= 1e-13 max(scale_i, |z_i|)`.
fn below_round_off(dz: &[f64], scale: &[f64], z: &[f64]) -> bool {
    dz.iter()
        .zip(scale.iter().zip(z))
        .all(|(d, (s, z))| d.abs() <= 1e-13 * s.max(z.abs()))
}

/// [`super::model::BeamPoint::value_along`] of the component `weights` for three vectors
/// in one pass over the weights: each sum the same operations in the same order as its own
/// `value_along` (the library's float sum: from `-0.0`, term by term).
#[inline(always)]
fn values_along(weights: &[(usize, f64)], x: &[f64], y: &[f64], z: &[f64]) -> (f64, f64, f64) {
    let (mut sx, mut sy, mut sz) = (-0.0, -0.0, -0.0);
    for &(k, w) in weights {
        sx += w * x[k];
        sy += w * y[k];
        sz += w * z[k];
    }
    (sx, sy, sz)
}

/// [`values_along`] of `x = [q^, v^, a, r0]` for a folded step: the sums along the weights
/// of `q^`, `v^`, `a` and `r0 - kappa v^` (the last `value_along` of `r0 - kappa v^` entry
/// by entry) in one pass, each the same operations in the same order as its own sum.
#[inline(always)]
fn values_along_folded(
    weights: &[(usize, f64)],
    [q, v, a, r]: [&[f64]; 4],
    kappa: f64,
) -> (f64, f64, f64, f64) {
    let (mut sq, mut sv, mut sa, mut sr) = (-0.0, -0.0, -0.0, -0.0);
    for &(k, w) in weights {
        sq += w * q[k];
        sv += w * v[k];
        sa += w * a[k];
        sr += w * (r[k] - kappa * v[k]);
    }
    (sq, sv, sa, sr)
}

fn norm(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// The pass of [`Integrator::integrate_beam_fused`]: per entry `a = (r - kappa v^) - z phi`,
/// `q = q^ + cq a`, `v = v^ + cv a`, `v_mid = (v_old + v) / 2` (`c = [cq, cv, kappa, phi]`),
/// with whether every new `q` and `v` is finite (`TEST`; without, `true`: the caller tests
/// otherwise) and, with `loads = (P_n, P_{n+1})`, the power `sum (P_n + P_{n+1}) / 2 v_mid`.
/// A function of its slices, not inlined: its `&mut`
/// slices are arguments, which the compiler knows to overlap nothing, so the loop is
/// vectorised without the run-time overlap tests of the eight slices that it emitted when
/// the pass was inlined into the step from the integrator's and the state's vectors (about
/// 240 instructions every step, measured with callgrind).
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn newmark_fused<const TEST: bool>(
    [cq, cv, kappa, phi]: [f64; 4],
    q: &mut [f64],
    v: &mut [f64],
    a: &mut [f64],
    v_mid: &mut [f64],
    r0: &[f64],
    col: &[f64],
    q_hat: &[f64],
    v_hat: &[f64],
    loads: Option<(&[f64], &[f64])>,
) -> (bool, f64) {
    let mut bad = 0u64;
    // One entry: a, q, v and v_mid updated, the bits of its finiteness test.
    let update =
        |q: &mut f64, v: &mut f64, a: &mut f64, m: &mut f64, r: f64, z: f64, qh: f64, vh: f64| {
            let acc = (r - kappa * vh) - z * phi;
            *a = acc;
            let (q_new, v_new) = (qh + cq * acc, vh + cv * acc);
            *q = q_new;
            *m = 0.5 * (*v + v_new);
            *v = v_new;
            if TEST { finite_bits(q_new, v_new) } else { 0 }
        };
    let newmark = q
        .iter_mut()
        .zip(v)
        .zip(a.iter_mut().zip(v_mid))
        .zip(r0.iter().zip(col))
        .zip(q_hat.iter().zip(v_hat));
    let Some((p_old, p_new)) = loads else {
        for ((((q, v), (a, m)), (r, z)), (qh, vh)) in newmark {
            bad |= update(q, v, a, m, *r, *z, *qh, *vh);
        }
        return (bad == 0, 0.0);
    };
    let mut work = 0.0;
    for (((((q, v), (a, m)), (r, z)), (qh, vh)), (po, pn)) in newmark.zip(p_old.iter().zip(p_new)) {
        bad |= update(q, v, a, m, *r, *z, *qh, *vh);
        work += 0.5 * (po + pn) * *m;
    }
    (bad == 0, work)
}

/// The pass of [`Integrator::integrate_beam`] from accelerations already formed:
/// `q = q^ + cq a`, `v = v^ + cv a`, `v_mid = (v_old + v) / 2` (`c = [cq, cv]`), with
/// whether every new `q` and `v` is finite and, with `loads = (P_n, P_{n+1})`, the power
/// `sum (P_n + P_{n+1}) / 2 v_mid` (without loads 0: each term would be a signed zero). Not
/// inlined, like [`newmark_fused`] (and for the same reason).
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn newmark_update(
    [cq, cv]: [f64; 2],
    q: &mut [f64],
    v: &mut [f64],
    v_mid: &mut [f64],
    q_hat: &[f64],
    v_hat: &[f64],
    a: &[f64],
    loads: Option<(&[f64], &[f64])>,
) -> (bool, f64) {
    let mut bad = 0u64;
    // One entry: q, v and v_mid updated, the bits of its finiteness test.
    let update = |q: &mut f64, v: &mut f64, qh: f64, vh: f64, a: f64, m: &mut f64| {
        let (q_new, v_new) = (qh + cq * a, vh + cv * a);
        *q = q_new;
        *m = 0.5 * (*v + v_new);
        *v = v_new;
        finite_bits(q_new, v_new)
    };
    let newmark = q
        .iter_mut()
        .zip(v)
        .zip(q_hat.iter().zip(v_hat))
        .zip(a.iter().zip(v_mid));
    let Some((p_old, p_new)) = loads else {
        for (((q, v), (qh, vh)), (a, m)) in newmark {
            bad |= update(q, v, *qh, *vh, *a, m);
        }
        return (bad == 0, 0.0);
    };
    let mut work = 0.0;
    for ((((q, v), (qh, vh)), (a, m)), (po, pn)) in newmark.zip(p_old.iter().zip(p_new)) {
        bad |= update(q, v, *qh, *vh, *a, m);
        work += 0.5 * (po + pn) * *m;
    }
    (bad == 0, work)
}

/// The bits of `(x - x) + (y - y)`: 0 (`+0.0`) when `x` and `y` are finite, a NaN's
/// (never 0) otherwise; their bitwise or over entries is 0 exactly when all are finite.
#[inline(always)]
#[allow(clippy::eq_op)] // `x - x` is the test itself, not a slip
fn finite_bits(x: f64, y: f64) -> u64 {
    ((x - x) + (y - y)).to_bits()
}

#[cfg(test)]
mod tests {
    use super::{finite_bits, start_choice, start_predictions, values_along, values_along_folded};

    #[test]
    fn start_predictions_are_exact_for_their_sequences() {
        // Order k is exact for a polynomial of degree k (small integers: exact arithmetic).
        let poly = |deg: i32, n: i32| -> f64 {
            (0..=deg)
                .map(|p| f64::from((n + 3).pow(p as u32) * (p + 1)))
                .sum()
        };
        for deg in 0..5 {
            let h = [-1, -2, -3, -4, -5].map(|n| poly(deg, n));
            let pred = start_predictions(&h);
            for (k, p) in pred[..5].iter().enumerate() {
                if k >= deg as usize {
                    assert_eq!(*p, poly(deg, 0), "degree {deg}, order {k}");
                } else {
                    assert_ne!(*p, poly(deg, 0), "degree {deg}, order {k}");
                }
            }
        }
        // The last one: a quadratic plus (-1)^n (c0 + c1 n).
        let f = |n: i32| f64::from(3 * n * n - 2 * n + 7 + (1 - 2 * (n & 1)) * (5 + 4 * n));
        let pred = start_predictions(&[-1, -2, -3, -4, -5].map(f));
        assert_eq!(pred[5], f(0));
        assert!(pred[..5].iter().all(|p| *p != f(0)));
    }

    #[test]
    fn start_choice_takes_the_least_error_above_the_floor() {
        let pred = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        // Errors against 3.5: 2.5, 1.5, 0.5, 0.5, 1.5, 2.5: the first least.
        assert_eq!(start_choice(&pred, 5, 3.5, 0.0), 2);
        // Only the predictions the history's length allows.
        assert_eq!(start_choice(&pred, 2, 3.5, 0.0), 1);
        assert_eq!(start_choice(&pred, 4, 6.0, 0.0), 3);
        assert_eq!(start_choice(&pred, 5, 6.0, 0.0), 5);
        // Below the floor: not chosen; none above it: 0.
        assert_eq!(start_choice(&pred, 5, 3.0, 0.6), 1);
        assert_eq!(start_choice(&pred, 5, 3.0, 10.0), 0);
        assert_eq!(start_choice(&pred, 0, 3.0, 0.0), 0);
        // A NaN value chooses nothing.
        assert_eq!(start_choice(&pred, 5, f64::NAN, 0.0), 0);
    }

    #[test]
    fn values_along_equals_three_sums_bit_for_bit() {
        // Signed zeros included: a sum of negative zeros stays -0.0 only from -0.0.
        let x = [0.0, -0.0, 1.5, -2.25e-3, 7.0e8, 0.0];
        let y = [-0.0, 0.0, -0.0, 0.0, -0.0, 0.0];
        let z = [3.0e-12, -1.0, 0.1, 0.2, 0.3, -0.0];
        let cases: [&[(usize, f64)]; 5] = [
            &[],
            &[(1, 0.5)],
            &[(0, -1.0), (1, 2.0)],
            &[(2, 0.37), (3, -1.1), (4, 1e-9), (5, -0.0)],
            &[(5, -2.0), (0, 0.7), (2, 0.1), (4, -0.3), (1, 1.0)],
        ];
        for w in cases {
            let sum = |v: &[f64]| w.iter().map(|&(k, c)| c * v[k]).sum::<f64>();
            let (a, b, c) = values_along(w, &x, &y, &z);
            let got = [a.to_bits(), b.to_bits(), c.to_bits()];
            let want = [sum(&x).to_bits(), sum(&y).to_bits(), sum(&z).to_bits()];
            assert_eq!(got, want, "{w:?}");
            // The folded step's four sums: the three and prepare's former sum of
            // `r0 - kappa v^` (here x, y, z, r0 = y reversed).
            let r: Vec<f64> = y.iter().rev().map(|v| v * 3.0 - 1e-3).collect();
            for kappa in [0.0, -0.0, 0.25, -7.5e3] {
                let (q, v, a, s) = values_along_folded(w, [&x, &y, &z, &r], kappa);
                let folded: f64 = w.iter().map(|&(j, c)| c * (r[j] - kappa * y[j])).sum();
                let got = [q, v, a, s].map(f64::to_bits);
                assert_eq!(got[..3], want, "{w:?}");
                assert_eq!(got[3], folded.to_bits(), "{w:?} {kappa}");
            }
        }
    }

    #[test]
    fn finite_bits_are_zero_exactly_when_both_are_finite() {
        let values = [
            0.0,
            -0.0,
            1.5,
            -3e300,
            f64::MAX,
            f64::MIN_POSITIVE,
            5e-324,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for x in values {
            for y in values {
                let both = x.is_finite() && y.is_finite();
                assert_eq!(finite_bits(x, y) == 0, both, "{x} {y}");
                // An or over entries: 0 exactly when every pair is finite.
                assert_eq!(
                    finite_bits(x, y) | finite_bits(1.0, -2.5) == 0,
                    both,
                    "{x} {y}"
                );
            }
        }
    }
}
