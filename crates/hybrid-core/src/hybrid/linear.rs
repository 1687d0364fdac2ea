//! The linearised hybrid system: its static equilibrium and the exact tangent matrices of
//! the reduced equations about it (issue #11).
//!
//! # Equilibrium
//!
//! At rest (`q' = q'' = 0`, currents zero) the reduced equations of [`crate::hybrid`] are
//!
//! ```text
//! r_x = C q^c - P_0 + N phi_w(w, u) = 0,      r_u = phi_u(w, u) = 0,     w = N^T q^c
//! ```
//!
//! with `P_0` the time-independent loads (the beam's loads and the excitations whose time
//! function is `Constant`; harmonic, step and table loads are the dynamic input), `phi` the
//! projected mechanism equations (gravity, springs, preloads) of [`super::follow`]. Newton's
//! method on `z = (q^c, u)` with the exact Jacobian `K_R` below (it is the reduced
//! stiffness: `d phi / ds = R^T (K + G(lambda)) R` up to a term proportional to the residual,
//! so the convergence is quadratic) from the undeformed beam and the mechanisms'
//! [`super::MountedMechanism::initial_q`].
//!
//! # Reduced tangent
//!
//! Per mechanism, about `(q0, lambda0)` (see [`mbs_symbolic::runtime::TangentSystem`]):
//!
//! ```text
//! M_i = M(q0) + rotor inertias              (eq. 11)
//! C_i = d(F + Q)/dq'  + force elements       (dampers, quasi-static generators)
//! K_i = d(M q'' + F + Q)/dq + springs + G(lambda_loops) + sum_k G_k(f_k)
//! f_k = (sin a lambda_t + cos a lambda_a, cos a lambda_t - sin a lambda_a)
//! ```
//!
//! `G` the loop curvature `d(J^T lambda)/dq`, `G_k` the curvature of attachment `k`'s point
//! rows (45)–(46) (`P = origin + R(a) p(q)`, so the rows' multipliers act on `p` through the
//! rotated force `f_k`). With `R_i = dq_i/ds` the basis of eq. (18) in the global layout
//! `s = (w, u)` (attachment displacements, then every free coordinate), the small blocks are
//!
//! ```text
//! M_s = sum_i R_i^T M_i R_i,    C_s = sum_i R_i^T C_i R_i,    K_s = sum_i R_i^T K_i R_i
//! ```
//!
//! and the reduced matrices in `z = (q^c, u)`, `s = P z` (`w = N^T q^c`):
//!
//! ```text
//! M_R = blockdiag(A, 0) + P^T M_s P,   C_R = blockdiag(B, 0) + P^T C_s P,
//! K_R = blockdiag(C, 0) + P^T K_s P                                     (eqs. 55-58, linear)
//! ```
//!
//! the banded beam plus a term of rank `nb + nf`. An inductive generator (`L > 0`) on joint
//! `j` of mechanism `i` adds its current `i_e` as a state:
//!
//! ```text
//! M_R z'' + C_R z' + K_R z + P^T b_e i_e = 0,   L i_e' = g_e^T P z' - R i_e,
//! b_e = n k_t R_i^T e_j,   g_e = k_e n R_i^T e_j
//! ```
//!
//! (docs/theory.md section 7: `Q_j += n k_t i`, `L i' + R i = k_e n q_j'`). A generator without
//! inductance is the damper `n^2 k_t k_e / R` on its joint, inside `C_i`. A generator's
//! gear loss is the damper `n^2 (tau_c / w_s + b + b_eta)` on its joint (the smooth Coulomb
//! friction by its slope at rest; [`crate::generator`]).
//!
//! The mechanism models' own force elements are inside `K_i`, `C_i`, exactly (symbolic
//! derivatives, see [`mbs_symbolic::runtime::TangentSystem`]); one without a tangent at the
//! equilibrium (a point spring-damper whose points coincide) is refused with
//! [`LinearError::ForceElement`]. The scenario's force elements' contributions are linear in
//! `(q, q', i)` (but for the gears' Coulomb friction, taken by its slope at rest), so they
//! are taken exactly
//! as differences of [`HybridModel::add_joint_forces`] at unit changes (no truncation: the
//! difference of an affine function is its slope, up to one rounding).

use mbs_symbolic::runtime::{TangentSystem, TangentWorkspace};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::follow::{CurrentRule, Follower};
use super::integrator::map_follow;
use super::model::{Coupling, ExcitationTarget, HybridModel};
use super::pencil::Pencil;
use super::structure::{LinearStructure, Structure};
use super::{HybridError, initial_state};

/// Newton settings of the equilibrium search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EquilibriumOptions {
    /// Converged when the residual norm is below `tolerance` times the size of the terms it
    /// sums (`|K_R| |z| + |P_0| + |phi|`, its rounding floor being about 1e-16 of that), or
    /// the largest Newton step entry is below `tolerance` times the largest entry of `z`.
    pub tolerance: f64,
    /// Newton iterations before giving up.
    pub max_iterations: usize,
}

impl Default for EquilibriumOptions {
    fn default() -> Self {
        EquilibriumOptions {
            tolerance: 1e-12,
            max_iterations: 50,
        }
    }
}

/// Why a hybrid system could not be linearised.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LinearError {
    /// A mechanism cannot be assembled or is singular on the way to the equilibrium.
    #[error("static equilibrium: {0}")]
    Hybrid(#[from] HybridError),
    /// Newton's method did not converge.
    #[error(
        "no static equilibrium found: residual {residual:.3e} after {iterations} Newton iterations (is the system stable under its static loads?)"
    )]
    NoEquilibrium {
        /// Residual norm at the last iterate.
        residual: f64,
        /// Iterations made.
        iterations: usize,
    },
    /// The tangent model is not of the mechanism's size (a different model).
    #[error(
        "mechanism \"{mechanism}\": the tangent model has {tangent_dof} coordinates and {tangent_rows} loop rows, the mechanism {dof} and {rows}"
    )]
    TangentSize {
        /// The mechanism.
        mechanism: String,
        /// Coordinates of the tangent model.
        tangent_dof: usize,
        /// Loop rows of the tangent model.
        tangent_rows: usize,
        /// Coordinates of the mechanism.
        dof: usize,
        /// Loop rows of the mechanism.
        rows: usize,
    },
    /// The tangent model's mass matrix differs from the mechanism's (a different model file
    /// or run-time parameters).
    #[error(
        "mechanism \"{mechanism}\": its tangent model's mass matrix differs from the mechanism's by {difference:.3e} (relative; different model file or run-time parameters)"
    )]
    TangentMass {
        /// The mechanism.
        mechanism: String,
        /// Largest entry of the difference over the largest entry of the mass matrix.
        difference: f64,
    },
    /// A force element of a mechanism model has no tangent at the equilibrium (e.g. a point
    /// spring-damper whose points coincide): refused rather than linearised inexactly.
    #[error("mechanism \"{mechanism}\": {source}")]
    ForceElement {
        /// The mechanism.
        mechanism: String,
        /// The element and why (boxed: the error stays small).
        source: Box<mbs_symbolic::runtime::TangentError>,
    },
    /// The structure's part `C + s B + s^2 A` of the shifted pencil is singular.
    #[error(
        "the {kind}'s dynamic stiffness C + s B + s^2 A at s = {}{:+}i is singular{}: a structure without supports (rigid-body motion) or a shift on an eigenvalue",
        shift[0],
        shift[1],
        pivot.map_or_else(String::new, |p| format!(" (pivot {p})"))
    )]
    SingularStructure {
        /// What the structure is ([`super::Structure::kind`]).
        kind: &'static str,
        /// The shift `s` (real and imaginary parts, 1/s).
        shift: [f64; 2],
        /// The elimination index of the zero pivot, where the factorisation tells it.
        pivot: Option<usize>,
    },
    /// The reduced dynamic stiffness (the Woodbury border of the mechanisms) at the shift
    /// has a zero pivot.
    #[error(
        "the reduced dynamic stiffness at s = {}{:+}i is singular (pivot {pivot}): a mechanism coordinate without stiffness (a free crank, a mechanism at its singular position) or a shift on an eigenvalue",
        shift[0],
        shift[1]
    )]
    SingularReduced {
        /// The shift `s` (real and imaginary parts, 1/s).
        shift: [f64; 2],
        /// The index of the zero pivot in the small bordered system.
        pivot: usize,
    },
    /// A matrix handed to an eigenvalue decomposition has a non-finite entry (refused before
    /// the decomposition, whose iteration would not converge on it).
    #[error(
        "the {matrix} has a non-finite entry {value} at ({row}, {column}): the linearised system is out of floating-point range (check the parameters' magnitudes)"
    )]
    NonFinite {
        /// Which matrix.
        matrix: &'static str,
        /// Row of the first non-finite entry.
        row: usize,
        /// Column of the first non-finite entry.
        column: usize,
        /// The entry.
        value: f64,
    },
    /// The (projected) mass matrix of a first-order form is singular.
    #[error(
        "the mass matrix of the first-order form (size {size}) is singular: a coordinate without mass (give the mechanism's bodies mass or inertia)"
    )]
    SingularMass {
        /// Its size.
        size: usize,
    },
    /// A stationary random response asked of a system that is not asymptotically stable.
    #[error(
        "the linearised system has the eigenvalue {}{:+}i, not in the open left half-plane: no stationary random response (a rigid or undamped motion, or an unstable equilibrium)",
        eigenvalue[0],
        eigenvalue[1]
    )]
    NotStable {
        /// The eigenvalue (1/s): real and imaginary parts.
        eigenvalue: [f64; 2],
    },
    /// An eigenvalue whose derivative was asked is not simple (its left and right vectors
    /// are orthogonal through the pencil's derivative): it has no derivative.
    #[error(
        "the eigenvalue {}{:+}i is not simple (a multiple or defective eigenvalue): it has no derivative with respect to a parameter",
        eigenvalue[0],
        eigenvalue[1]
    )]
    NotSimple {
        /// The eigenvalue (1/s): real and imaginary parts.
        eigenvalue: [f64; 2],
    },
    /// Two linearisations of a pencil derivative differ in their layout (beam DOFs,
    /// attachments or the mechanisms' free coordinates): the parameter changes the
    /// coordinates themselves, so their matrices cannot be differenced.
    #[error(
        "the linearisations at p - h and p + h have different coordinates ({what}): the parameter changes the model's layout"
    )]
    LayoutChanged {
        /// What differs.
        what: &'static str,
    },
    /// An iterative eigenvalue computation reached its iteration cap.
    #[error(
        "the {what} did not converge within {iterations} iterations (size {size}): the linearised system is too ill-scaled for its eigenvalues to be computed"
    )]
    NoEigenConvergence {
        /// Which computation.
        what: &'static str,
        /// The cap reached.
        iterations: usize,
        /// Size of the matrix.
        size: usize,
    },
}

/// The static equilibrium of a hybrid system.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Equilibrium {
    /// The structure's coordinates (m, rad; a reduced structure's interface displacements
    /// and modal amplitudes).
    pub beam_q: Vec<f64>,
    /// Every mechanism's coordinates.
    pub mech_q: Vec<Vec<f64>>,
    /// Every mechanism's free (independent) coordinates.
    pub free: Vec<Vec<usize>>,
    /// Every mechanism's multipliers (loop rows, then per attachment the transverse and,
    /// for a pin, the axial row; eq. 17 sign: `M q'' + F + Q + J^T lambda = 0`).
    pub multipliers: Vec<Vec<f64>>,
    /// 2-norm condition number of every mechanism's `J_d` (1 without rows).
    pub conditions: Vec<f64>,
    /// Newton iterations made.
    pub iterations: usize,
    /// Final residual norm (N, N m).
    pub residual: f64,
}

/// The state of an inductive generator in the linearised equations (see the module
/// documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct ElectricalState {
    /// Index into the model's forces.
    pub force: usize,
    /// Inductance `L` (H).
    pub inductance: f64,
    /// Circuit resistance `R = R_a + R_L` (ohm).
    pub resistance: f64,
    /// `b_e = n k_t R_i^T e_j` in the layout `s` (torque per ampere, projected).
    pub torque: DVector<f64>,
    /// `g_e = k_e n R_i^T e_j` in the layout `s` (EMF per unit velocity).
    pub emf: DVector<f64>,
}

/// A hybrid system linearised about its static equilibrium (see the module documentation):
/// the structure (any [`Structure`]), the small blocks `M_s`, `C_s`, `K_s` in `s = (w, u)` and the
/// electrical states, with products and dense assembly of the reduced matrices.
#[derive(Clone, Debug)]
pub struct Linearization {
    n: usize,
    nb: usize,
    nf: usize,
    /// The equilibrium.
    pub equilibrium: Equilibrium,
    /// The structure: its mass `A`, damping `B` and stiffness `C` (eq. 44).
    structure: Option<Structure>,
    /// Upper bounds of the infinity norms of `[A, B, C]` ([`Structure::norm_bounds`]).
    structure_norms: [f64; 3],
    /// The structure's displacement coordinates ([`Structure::translation_dofs`]).
    translations: Vec<usize>,
    /// Per beam node: its abscissa and its transverse DOF (`None` where a support locks it).
    nodes: Vec<(f64, Option<usize>)>,
    /// The coupling components ([`HybridModel::couplings`]): the entries of `w`.
    couplings: Vec<Coupling>,
    /// The columns of `N`: per coupling, the weights of its component of the attachment's
    /// point ([`super::BeamPoint::component`]).
    columns: Vec<Vec<(usize, f64)>>,
    /// `R_i = dq_i/ds` per mechanism (`dof_i x (nb + nf)`).
    pub basis: Vec<DMatrix<f64>>,
    /// `M_s`.
    pub ms: DMatrix<f64>,
    /// `C_s`.
    pub cs: DMatrix<f64>,
    /// `K_s`.
    pub ks: DMatrix<f64>,
    /// Inductive generators.
    pub electrical: Vec<ElectricalState>,
    /// The mechanisms' generalised load in `s` per unit support acceleration along the
    /// structure's `x` and `y`, `sum_i R_i^T G_i(q0) M_i^T e` ([`ExcitationTarget::Base`];
    /// `M_i` the mount's rotation, `e` the axis): a direction `d` loads `d_x [0] + d_y [1]`.
    base_small: [DVector<f64>; 2],
}

/// Which reduced matrix a product is with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Matrix {
    /// `M_R`.
    Mass,
    /// `C_R`.
    Damping,
    /// `K_R`.
    Stiffness,
}

/// The time-independent loads on the beam: its constant loads and the constant beam
/// excitations.
fn static_beam_load(model: &HybridModel) -> Vec<f64> {
    let mut p = vec![0.0; model.structure_dofs()];
    if let Some(b) = model.beam() {
        b.constant_load_into(&mut p);
    }
    for e in &model.excitations {
        if let ExcitationTarget::Beam(bp) = &e.target
            && e.time == fem_beam::TimeFunction::Constant
        {
            bp.add_force(e.amplitude, &mut p);
        }
    }
    p
}

/// The model with only its time-independent excitations (the joint forces of the
/// equilibrium come from [`HybridModel::add_joint_forces`] at `t = 0`). The supports'
/// accelerations are inputs of the linear model whatever their time function (a constant
/// one's static effect is the linear response at zero frequency to
/// [`Linearization::force_vector`]`(Base)`), so they are left out of the equilibrium.
pub(crate) fn static_model(model: &HybridModel) -> HybridModel {
    let mut m = model.clone();
    m.excitations
        .retain(|e| e.time == fem_beam::TimeFunction::Constant && !e.target.is_base());
    m
}

struct Mechanics {
    followers: Vec<Follower>,
    tangents_ws: Vec<TangentWorkspace>,
    nb: usize,
    nf: usize,
    zero: Vec<f64>,
    currents: Vec<f64>,
    phi: Vec<f64>,
}

impl Mechanics {
    fn ns(&self) -> usize {
        self.nb + self.nf
    }

    /// Positions and projected static equations `phi` at `s` (into `self.phi`).
    fn follow(&mut self, model: &HybridModel, s: &[f64]) -> Result<(), HybridError> {
        let rule = CurrentRule {
            h: 0.0,
            old: &self.zero[..model.forces.len()],
            rate: &self.zero[..model.forces.len()],
        };
        self.phi.fill(0.0);
        for f in &mut self.followers {
            f.follow(
                model,
                0.0,
                s,
                &self.zero,
                &self.zero,
                rule,
                &mut self.currents,
                &mut self.phi,
            )
            .map_err(|e| map_follow(model, s, f.mech, 0.0, e))?;
        }
        Ok(())
    }
}

impl Linearization {
    /// Finds the static equilibrium of `model` and linearises it. `tangents` holds one
    /// [`TangentSystem`] per mechanism, built from the same model file with the same
    /// run-time parameters (checked: its mass matrix must equal the mechanism's).
    pub fn new(
        model: &HybridModel,
        tangents: &[&TangentSystem],
        options: EquilibriumOptions,
    ) -> Result<Linearization, LinearError> {
        assert_eq!(
            tangents.len(),
            model.mechanisms.len(),
            "one tangent system per mechanism"
        );
        for (m, t) in model.mechanisms.iter().zip(tangents) {
            if t.dof() != m.system.dof() || t.rows() != m.system.rows() {
                return Err(LinearError::TangentSize {
                    mechanism: m.name.clone(),
                    tangent_dof: t.dof(),
                    tangent_rows: t.rows(),
                    dof: m.system.dof(),
                    rows: m.system.rows(),
                });
            }
        }
        // A force element without a tangent at the start (where the consistent
        // accelerations of `initial_state` would already be non-finite) is refused by name;
        // the Newton iterates are checked in `assemble`.
        for (m, t) in model.mechanisms.iter().zip(tangents) {
            t.check_elements(&m.initial_q, &mut t.workspace())
                .map_err(|source| LinearError::ForceElement {
                    mechanism: m.name.clone(),
                    source: Box::new(source),
                })?;
        }
        let model = static_model(model);
        let model = &model;
        let n = model.structure_dofs();
        let nb = model.couplings().len();
        let start = initial_state(model, vec![0.0; n], vec![0.0; n])?;
        let mut followers = Vec::new();
        let mut nf = 0;
        for (i, ms) in start.mechanisms.iter().enumerate() {
            let mut f = Follower::new(model, i, ms.free.clone(), nf);
            f.set_q(&ms.q);
            nf += ms.free.len();
            followers.push(f);
        }
        let ns = nb + nf;
        let mut mech = Mechanics {
            followers,
            tangents_ws: tangents.iter().map(|t| t.workspace()).collect(),
            nb,
            nf,
            zero: vec![0.0; ns.max(model.forces.len())],
            currents: vec![0.0; model.forces.len()],
            phi: vec![0.0; ns],
        };
        let p0 = static_beam_load(model);
        let mut z = vec![0.0; n + nf];
        for f in &mech.followers {
            for (k, &c) in f.free.iter().enumerate() {
                z[n + f.free_offset + k] = f.q()[c];
            }
        }
        let mut s = vec![0.0; ns];
        let mut r = vec![0.0; n + nf];
        let mut last = f64::INFINITY;
        for it in 0..=options.max_iterations {
            to_s(model, n, &z, &mut s);
            mech.follow(model, &s)?;
            let lin = Self::assemble(model, tangents, &mut mech)?;
            // Residual r = [C x - P0 + N phi_w; phi_u].
            r.fill(0.0);
            if let Some(st) = &lin.structure {
                st.stiffness_mul_add(1.0, &z[..n], &mut r[..n]);
            }
            for i in 0..n {
                r[i] -= p0[i];
            }
            for (k, c) in model.couplings().iter().enumerate() {
                model.attachments[c.attachment].beam.add_force_along(
                    c.axial,
                    mech.phi[k],
                    &mut r[..n],
                );
            }
            r[n..].copy_from_slice(&mech.phi[nb..]);
            let rn = r.iter().map(|x| x * x).sum::<f64>().sqrt();
            last = rn;
            if !rn.is_finite() {
                break;
            }
            // The residual's rounding floor: the size of the terms it is the sum of.
            let amax = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let terms = lin.norm_bound(Matrix::Stiffness) * amax(&z) + amax(&p0) + amax(&mech.phi);
            let pencil = Pencil::new(&lin, nalgebra::Complex::new(0.0, 0.0))?;
            let mut dz: Vec<nalgebra::Complex<f64>> =
                r.iter().map(|&x| nalgebra::Complex::new(-x, 0.0)).collect();
            pencil.solve_in_place(&mut dz);
            let step = dz.iter().fold(0.0f64, |m, x| m.max(x.re.abs()));
            if rn <= options.tolerance * terms || step <= options.tolerance * amax(&z) {
                let mut lin = lin;
                lin.equilibrium.beam_q = z[..n].to_vec();
                lin.equilibrium.iterations = it;
                lin.equilibrium.residual = rn;
                return Ok(lin);
            }
            let size = 1.0 + z.iter().map(|x| x.abs()).sum::<f64>();
            let step = dz.iter().map(|x| x.re * x.re).sum::<f64>().sqrt();
            // Limit the step to keep the mechanisms on their assembly branch.
            let damp = if step > 0.1 * size {
                0.1 * size / step
            } else {
                1.0
            };
            for (zi, d) in z.iter_mut().zip(&dz) {
                *zi += damp * d.re;
            }
        }
        Err(LinearError::NoEquilibrium {
            residual: last,
            iterations: options.max_iterations,
        })
    }

    /// The reduced blocks at the followers' current (followed) configuration.
    fn assemble(
        model: &HybridModel,
        tangents: &[&TangentSystem],
        mech: &mut Mechanics,
    ) -> Result<Linearization, LinearError> {
        let (nb, nf) = (mech.nb, mech.nf);
        let ns = mech.ns();
        let mut ms = DMatrix::zeros(ns, ns);
        let mut cs = DMatrix::zeros(ns, ns);
        let mut ks = DMatrix::zeros(ns, ns);
        let mut basis = Vec::new();
        let mut equilibrium = Equilibrium {
            beam_q: vec![],
            mech_q: vec![],
            free: vec![],
            multipliers: vec![],
            conditions: vec![],
            iterations: 0,
            residual: 0.0,
        };
        let mut electrical = Vec::new();
        let mut base_small = [DVector::zeros(ns), DVector::zeros(ns)];
        for (i, f) in mech.followers.iter_mut().enumerate() {
            let m = &model.mechanisms[i];
            let t = tangents[i];
            let ws = &mut mech.tangents_ws[i];
            let dof = m.system.dof();
            let q: Vec<f64> = f.q().iter().copied().collect();
            let zero = vec![0.0; dof];
            let lambda: Vec<f64> = f.multipliers().collect();
            f.refresh_condition();
            // Tree: M, K, C (eqs. 11-13 differentiated), exact for every force element that
            // has a tangent here (the others are refused).
            t.check_elements(&q, ws)
                .map_err(|source| LinearError::ForceElement {
                    mechanism: m.name.clone(),
                    source: Box::new(source),
                })?;
            t.evaluate_dynamics(&q, &zero, &zero, 0.0, ws);
            let mut sws = m.system.workspace();
            m.system.evaluate(&q, &zero, 0.0, &mut sws);
            let mscale = sws.m.amax().max(1e-300);
            let difference = (&sws.m - &ws.m).amax() / mscale;
            if difference > 1e-9 {
                return Err(LinearError::TangentMass {
                    mechanism: m.name.clone(),
                    difference,
                });
            }
            let (mut mi, mut ki, mut ci) = (ws.m.clone(), ws.k.clone(), ws.c.clone());
            // Force elements, exactly (affine in q, q', i).
            let currents = vec![0.0; model.forces.len()];
            let base = joint_terms(model, i, &q, &zero, &currents);
            mi += &base.0;
            for c in 0..dof {
                let mut qc = q.clone();
                qc[c] += 1.0;
                let (_, qv) = joint_terms(model, i, &qc, &zero, &currents);
                let mut e = zero.clone();
                e[c] = 1.0;
                let (_, qd) = joint_terms(model, i, &q, &e, &currents);
                for r in 0..dof {
                    ki[(r, c)] += qv[r] - base.1[r];
                    ci[(r, c)] += qd[r] - base.1[r];
                }
            }
            // The gears' smooth Coulomb friction is the one term that is not affine: its
            // difference at a unit speed, n tau_c tanh(n / w_s), is replaced by its slope at
            // rest, n^2 tau_c / w_s (crate::generator).
            for force in model.forces.iter().filter(|f| f.mechanism == i) {
                if let Some(g) = force.generator()
                    && g.gear_friction.coulomb != 0.0
                {
                    let (n, fr) = (g.gear_ratio, &g.gear_friction);
                    let j = force.joint;
                    ci[(j, j)] += n * n * fr.coulomb / fr.smoothing_speed
                        - n * fr.coulomb * (n / fr.smoothing_speed).tanh();
                }
            }
            // Constraint curvature: loops, then the attachment points.
            let loops = m.system.rows();
            if loops > 0 {
                t.evaluate_constraints(&q, &lambda[..loops], ws);
                ki += &ws.constraint_curvature;
            }
            let (cs_, sn) = m.mount.rotation();
            let mut row = loops;
            for a in model.attachments.iter().filter(|a| a.mechanism == i) {
                let lt = lambda[row];
                let la = if a.kind == super::AttachmentKind::Pin {
                    lambda[row + 1]
                } else {
                    0.0
                };
                row += a.kind.rows();
                // The first row's multiplier acts along the point's direction `d` (`y` on the
                // beam, a roller's direction at a node), the pin's second along `x`; the
                // force in the mechanism's frame is `R^T (la e_x + lt d)`.
                let d = a.beam.direction;
                let v = [lt * d[0] + la, lt * d[1]];
                let force = [cs_ * v[0] + sn * v[1], cs_ * v[1] - sn * v[0], 0.0];
                t.evaluate_point(a.point, &q, force, ws);
                ki += &ws.point_curvature;
            }
            // Basis R_i and the small blocks.
            let mut ri = DMatrix::zeros(dof, ns);
            f.basis_into(&mut ri);
            // The supports' inertial load per unit acceleration along x and y, G(q0) R^T e.
            m.system.gravity_load_jacobian(&q, &mut sws);
            for (small, e) in base_small.iter_mut().zip([[1.0, 0.0], [0.0, 1.0]]) {
                let [gx, gy] = m.mount.to_ground(e);
                let e = nalgebra::Vector3::new(gx, gy, 0.0);
                *small += ri.transpose() * (&sws.gravity_jacobian * e);
            }
            ms += ri.transpose() * &mi * &ri;
            cs += ri.transpose() * &ci * &ri;
            ks += ri.transpose() * &ki * &ri;
            for (k, force) in model.forces.iter().enumerate() {
                if force.mechanism != i || !force.has_current_state() {
                    continue;
                }
                let g = force.generator().expect("a current state is a generator's");
                let row_j = ri.row(force.joint).transpose();
                electrical.push(ElectricalState {
                    force: k,
                    inductance: g.inductance,
                    resistance: g.resistance(),
                    torque: &row_j * (g.gear_ratio * g.kt),
                    emf: &row_j * (g.gear_ratio * g.ke),
                });
            }
            basis.push(ri);
            equilibrium.mech_q.push(q);
            equilibrium.free.push(f.free.clone());
            equilibrium.multipliers.push(lambda);
            equilibrium.conditions.push(f.condition);
        }
        let structure = model.structure.clone();
        Ok(Linearization {
            n: model.structure_dofs(),
            nb,
            nf,
            equilibrium,
            structure_norms: structure.as_ref().map_or([0.0; 3], Structure::norm_bounds),
            translations: structure
                .as_ref()
                .map_or_else(Vec::new, Structure::translation_dofs),
            structure,
            nodes: model.beam().map_or_else(Vec::new, |b| {
                b.beam()
                    .node_positions()
                    .iter()
                    .enumerate()
                    .map(|(i, &x)| (x, b.dof_index(i, fem_beam::Dof::Transverse)))
                    .collect()
            }),
            columns: model
                .couplings()
                .iter()
                .map(|c| {
                    model.attachments[c.attachment]
                        .beam
                        .component(c.axial)
                        .to_vec()
                })
                .collect(),
            couplings: model.couplings(),
            basis,
            ms,
            cs,
            ks,
            electrical,
            base_small,
        })
    }

    /// Beam DOFs.
    pub fn structure_dofs(&self) -> usize {
        self.n
    }

    /// Size of `z = (q^c, u)`: beam DOFs plus free mechanism coordinates.
    pub fn dim(&self) -> usize {
        self.n + self.nf
    }

    /// Size of `s = (w, u)`: coupling components plus free coordinates.
    pub fn small_dim(&self) -> usize {
        self.nb + self.nf
    }

    /// The coupling components ([`HybridModel::couplings`]): the entries of `w`, one
    /// column of `N` each.
    pub fn couplings(&self) -> &[Coupling] {
        &self.couplings
    }

    /// The columns of `N`: per coupling, `(coordinate, weight)` of its displacement
    /// component.
    pub fn columns(&self) -> &[Vec<(usize, f64)>] {
        &self.columns
    }

    /// The host structure, if there is one.
    pub fn structure(&self) -> Option<&Structure> {
        self.structure.as_ref()
    }

    /// The structure's displacement coordinates ([`Structure::translation_dofs`]).
    pub fn translation_dofs(&self) -> &[usize] {
        &self.translations
    }

    /// Per beam node: its abscissa (m) and its transverse DOF (`None` where a support locks
    /// it).
    pub fn nodes(&self) -> &[(f64, Option<usize>)] {
        &self.nodes
    }

    /// The beam's transverse deflection `(x, w)` at every node for a state `z` (zero at
    /// locked nodes).
    pub fn beam_deflection<T: Copy + Default>(&self, z: &[T]) -> Vec<(f64, T)> {
        self.nodes
            .iter()
            .map(|&(x, dof)| (x, dof.map_or_else(T::default, |i| z[i])))
            .collect()
    }

    /// The small block of `which` (`M_s`, `C_s` or `K_s`).
    pub fn small(&self, which: Matrix) -> &DMatrix<f64> {
        match which {
            Matrix::Mass => &self.ms,
            Matrix::Damping => &self.cs,
            Matrix::Stiffness => &self.ks,
        }
    }

    /// `s = P z`: attachment displacements `w = N^T q^c`, then the free coordinates.
    pub fn to_small<T>(&self, z: &[T], s: &mut [T])
    where
        T: Copy + std::ops::Mul<f64, Output = T> + std::ops::Add<Output = T> + Default,
    {
        for (k, col) in self.columns.iter().enumerate() {
            s[k] = col.iter().fold(T::default(), |acc, &(i, w)| acc + z[i] * w);
        }
        s[self.nb..].copy_from_slice(&z[self.n..]);
    }

    /// `z += P^T s`.
    pub fn add_from_small<T>(&self, s: &[T], z: &mut [T])
    where
        T: Copy + std::ops::Mul<f64, Output = T> + std::ops::AddAssign,
    {
        for (k, col) in self.columns.iter().enumerate() {
            for &(i, w) in col {
                z[i] += s[k] * w;
            }
        }
        for (zi, &si) in z[self.n..].iter_mut().zip(&s[self.nb..]) {
            *zi += si;
        }
    }

    /// `y = X z` for `X` = `M_R`, `C_R` or `K_R` (structured: banded beam + `P^T X_s P`).
    pub fn mul(&self, which: Matrix, z: &[f64], y: &mut [f64]) {
        y.fill(0.0);
        if let Some(st) = &self.structure {
            let (x, out) = (&z[..self.n], &mut y[..self.n]);
            match which {
                Matrix::Mass => st.mass_mul_add(1.0, x, out),
                Matrix::Damping => st.damping_mul_add(1.0, x, out),
                Matrix::Stiffness => st.stiffness_mul_add(1.0, x, out),
            }
        }
        let ns = self.small_dim();
        let mut s = vec![0.0; ns];
        self.to_small(z, &mut s);
        let xs = self.small(which) * DVector::from_vec(s);
        self.add_from_small(xs.as_slice(), y);
    }

    /// An upper bound of the infinity norm of the reduced matrix `which`:
    /// `|X_b|_inf + |P^T|_inf |X_s|_inf |P|_inf`.
    pub fn norm_bound(&self, which: Matrix) -> f64 {
        let k = match which {
            Matrix::Mass => 0,
            Matrix::Damping => 1,
            Matrix::Stiffness => 2,
        };
        let beam = self.structure_norms[k];
        let xs = self.small(which);
        let small = (0..xs.nrows())
            .map(|r| xs.row(r).iter().map(|v| v.abs()).sum::<f64>())
            .fold(0.0, f64::max);
        let p = self
            .columns
            .iter()
            .map(|c| c.iter().map(|w| w.1.abs()).sum::<f64>())
            .fold(1.0, f64::max);
        beam + p * small * p
    }

    /// The reduced matrix `which` as a dense `dim x dim` matrix (for small systems and
    /// tests).
    pub fn dense(&self, which: Matrix) -> DMatrix<f64> {
        let d = self.dim();
        let mut out = DMatrix::zeros(d, d);
        let mut e = vec![0.0; d];
        let mut y = vec![0.0; d];
        for c in 0..d {
            e[c] = 1.0;
            self.mul(which, &e, &mut y);
            e[c] = 0.0;
            out.column_mut(c).copy_from_slice(&y);
        }
        out
    }

    /// Mechanism coordinates' perturbation `dq_i = R_i s` of a state `z` (complex or real).
    pub fn mechanism_motion<T>(&self, z: &[T]) -> Vec<Vec<T>>
    where
        T: Copy
            + std::ops::Mul<f64, Output = T>
            + std::ops::Add<Output = T>
            + std::ops::AddAssign
            + Default,
    {
        let mut s = vec![T::default(); self.small_dim()];
        self.to_small(z, &mut s);
        self.basis
            .iter()
            .map(|r| {
                (0..r.nrows())
                    .map(|row| (0..r.ncols()).fold(T::default(), |acc, c| acc + s[c] * r[(row, c)]))
                    .collect()
            })
            .collect()
    }

    /// The velocity amplification `dq_joint / dw_k` of mechanism `mech` at the equilibrium
    /// for coupling component `coupling` ([`Linearization::couplings`]; free coordinates and
    /// the other components held): the entry of `R_i` (eq. 18).
    pub fn amplification(&self, mech: usize, joint: usize, coupling: usize) -> f64 {
        self.basis[mech][(joint, coupling)]
    }
}

/// `s = P z` for the model's couplings (before a [`Linearization`] exists).
fn to_s(model: &HybridModel, n: usize, z: &[f64], s: &mut [f64]) {
    let w = model.coupling_values(&z[..n]);
    s[..w.len()].copy_from_slice(&w);
    s[w.len()..].copy_from_slice(&z[n..]);
}

/// `(M^b, Q^b)` contributions of mechanism `mech`'s force elements and constant joint
/// excitations at `(q, q')` with currents `currents`, zero tree terms.
fn joint_terms(
    model: &HybridModel,
    mech: usize,
    q: &[f64],
    qd: &[f64],
    currents: &[f64],
) -> (DMatrix<f64>, DVector<f64>) {
    let n = q.len();
    let mut m = DMatrix::zeros(n, n);
    let mut v = DVector::zeros(n);
    model.add_joint_forces(mech, 0.0, q, qd, currents, &mut m, &mut v);
    (m, v)
}

impl Linearization {
    /// The generalised force in `z` of a unit excitation at `target`: a unit transverse force
    /// at a beam point (`n`), a unit torque/force driving a mechanism joint (`Q_j -= f`,
    /// so `+P^T R_i^T e_j`), or a unit support acceleration (1 m/s^2) along its direction
    /// `d`: the inertial loads `-(A r)` on the structure (`r` the rigid translation along
    /// `d`, see [`ExcitationTarget::Base`]) and `P^T sum_i R_i^T G_i(q0) M_i^T d` from the
    /// mechanisms (`M_i` the mount's rotation), which equals `-(M_R r_z)` for the rigid
    /// translation `r_z` of the whole system in `z` (structure `r`, the free coordinates as
    /// the mechanisms move with their grounds).
    pub fn force_vector(&self, target: &ExcitationTarget) -> Vec<f64> {
        let mut f = vec![0.0; self.dim()];
        match target {
            ExcitationTarget::Beam(p) => p.add_force(1.0, &mut f[..self.n]),
            ExcitationTarget::Joint { mechanism, joint } => {
                let r = &self.basis[*mechanism];
                let s: Vec<f64> = (0..r.ncols()).map(|c| r[(*joint, c)]).collect();
                self.add_from_small(&s, &mut f);
            }
            ExcitationTarget::Base { direction: d } => {
                if let Some(st) = &self.structure {
                    f[..self.n].copy_from_slice(&st.base_load(*d));
                }
                let [bx, by] = &self.base_small;
                let small: Vec<f64> = bx
                    .iter()
                    .zip(by)
                    .map(|(x, y)| d[0] * x + d[1] * y)
                    .collect();
                self.add_from_small(&small, &mut f);
            }
        }
        f
    }

    /// The response `z(omega)` to the harmonic generalised force `f e^{i omega t}`:
    /// `(K_R + i omega C_R - omega^2 M_R + electrical) z = f` (the pencil at
    /// `sigma = i omega`, eliminating the currents). The receptance at a beam point `p` is
    /// `p.value(z)` (m/N).
    pub fn harmonic_response(
        &self,
        f: &[f64],
        omega: f64,
    ) -> Result<Vec<nalgebra::Complex<f64>>, LinearError> {
        let p = Pencil::new(self, nalgebra::Complex::new(0.0, omega))?;
        let mut z: Vec<nalgebra::Complex<f64>> =
            f.iter().map(|&v| nalgebra::Complex::new(v, 0.0)).collect();
        p.solve_in_place(&mut z);
        Ok(z)
    }
}
