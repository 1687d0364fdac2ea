//! Hybrid systems of any shape: an optional beam, any number of mechanisms (any model:
//! trees with loop constraints, revolute and prismatic joints), attachments between
//! mechanism points and beam points, force elements on joints and excitations — reduced by
//! coordinate partitioning of the joined system and integrated in `O(n)` per step.
//!
//! # Equations
//!
//! The joined system (eqs. 51–54): beam `A q^c'' + B q^c' + C q^c = P(t) - J^c^T lambda`
//! (44), each mechanism `M q'' + F + Q + J^T lambda = 0` (17), and the constraint rows of
//! each mechanism: its loop rows (14) and, per attachment, the transverse row
//! `P_y(q) - n^T q^c` and for a pin the axial row `P_x(q) - x_b` (45)–(46), `P` the point in
//! the beam frame (mounting position and angle), `n` the shape-function weights of the beam
//! point (35). `J^c` is one row `-n_k^T` per attachment (54).
//!
//! **Partitioning** (eqs. 18–25 applied to the joined system). Per mechanism the dependent
//! coordinates `q_d` are the pivot columns of LU with full pivoting of its `J` (one per row),
//! the rest `u` are free. With `w` the attachment displacements,
//!
//! ```text
//! J_d q_d' = E w' - J_f u'                      q_d'' = J_d^-1 (E w'' - J_f u'' - A)   (18), (19)
//! phi = R^T (M q'' + F + Q),   R = dq/d(w, u)   (the projection that removes lambda)
//! mu = J_d^-T g_d,  phi_w = E^T mu,  phi_u = g_f - J_f^T mu,  g = M q'' + F + Q
//! ```
//!
//! and the multipliers of the transverse rows are `lambda_w = -phi_w`. The independent
//! coordinates of the whole system are all beam coordinates and every free `u`; the reduced
//! equations are
//!
//! ```text
//! A q^c'' + B q^c' + C q^c = P - N phi_w(w, u)                     (55)–(58), any shape
//! phi_u(w, u) = 0,          w = N^T q^c
//! ```
//!
//! with `N = [n_1 .. n_nb]`: the banded beam plus a term of rank `nb` (one per attachment),
//! bordered by the free mechanism coordinates. For the paper's double bar (`nb = 1`, no free
//! coordinate) `phi_w = m_eff w'' - f` and this is the rank-one update of eqs. (55)–(58).
//!
//! # Time integration
//!
//! Newmark / HHT-alpha ([`Method`]) on `(q^c, u)` with the mechanism terms at `t_{n+1}`
//! (not alpha-weighted: the mechanism's whole reaction on the beam is inertial apart from
//! its force elements, and weighting only part of it would split its inertia between two
//! instants and pump energy into the system). With the predictors `^` and
//! `K = A + (1+alpha)(gamma h B + beta h^2 C)` factorised once,
//!
//! ```text
//! q^c'' = a0 - Z phi_w,     a0 = K^-1 r0,   Z = K^-1 N  (computed once)
//! r_w = w'' - N^T a0 + S phi_w(z) = 0,      S = N^T Z   (nb x nb)
//! r_u = phi_u(z) = 0,                       z = (w'', u'')
//! ```
//!
//! a small nonlinear system in `z` (size `nb + nf`) solved by Broyden's quasi-Newton method
//! (the secant method for the double bar) from the previous step's accelerations and
//! Jacobian; the Jacobian is refreshed by finite differences at the start, after a
//! re-partition, or when the iteration is slow. With one unknown the iteration starts from
//! the unknown extrapolated from the last steps' values (the polynomial, up to the fourth
//! order, or the alternation-following prediction that erred least on the last step), the
//! Jacobian is extrapolated from the last two steps' and the third iterate is accepted from
//! the secant, without evaluating it, when the correction it leaves is bounded below
//! round-off (two evaluations per step on nearly every step). Each residual evaluates every mechanism once
//! (positions by Newton on `h = 0`, then M, F, Q, A): a step is one banded solve plus
//! `O(n)` vector work, whatever the number of mechanisms, and allocates nothing. Inductive
//! generator currents advance with the trapezoidal rule inside the residual.
//!
//! # Singular positions
//!
//! Every mechanism's `cond_2(J_d)` is measured at every evaluation; above its
//! `max_condition` the run stops with the time, the mechanism, the beam point displacement,
//! the condition, the smallest singular value and the remaining reach where known. A
//! mechanism with free coordinates is re-partitioned (logged) when its `J_d` degrades and a
//! better block exists.
//!
//! # Linearisation, modes, responses and sensitivities
//!
//! About the static equilibrium the reduced equations have exact tangents `M_R`, `C_R`, `K_R`
//! and the inductive generators' currents ([`Linearization`]); their pencil
//! `S(sigma) = K_R + sigma C_R + sigma^2 M_R + electrical` is solved in `O(n)` ([`Pencil`]) for
//! the modes ([`modes`]), the harmonic responses and the first-order form of the random
//! response ([`StateSpace`], [`lyapunov`]). The derivatives of an eigenvalue
//! (`d lambda = -psi^T dS phi / psi^T S' phi`) and of a harmonic response
//! (`dz = S^-1 (df - dS z)`) with respect to a parameter, given the pencil's derivative, are
//! [`EigenSensitivity`] and [`response_derivative`].

mod dense;
mod eigen;
mod error;
mod follow;
mod integrator;
mod linear;
mod method;
mod model;
mod pencil;
mod placement;
pub mod reference;
mod run;
mod sensitivity;
mod shifted;
mod steady;
mod stochastic;
mod structure;
mod variants;

pub use dense::DenseCholesky;
pub use eigen::{DENSE_STATES, EigenMethod, Mode, ModeKind, first_mode, modes};
pub use error::HybridError;
pub use integrator::{Account, HybridState, Integrator, MechanismState, Repartition, Stored};
pub use linear::{
    ElectricalState, Equilibrium, EquilibriumOptions, LinearError, Linearization, Matrix,
};
pub use method::Method;
pub use model::{
    Attachment, AttachmentKind, BeamPoint, Coupling, Excitation, ExcitationTarget, ForceKind,
    HybridModel, JointForce, ModelError, Mount, MountedMechanism,
};
pub use pencil::Pencil;
pub use placement::{Knee, Placement, PlacementError, TwoBar, initial_deflection, place_two_bar};
pub use run::{
    RunError, RunFigures, RunOptions, RunOutcome, balance_error, dissipated, input_work, run,
    run_observed,
};
pub use sensitivity::{EigenSensitivity, pencil_derivative, response_derivative, same_layout};
pub use steady::{
    SteadyError, SteadyOptions, SteadyState, output_value, rest_state, steady_state, steady_states,
    warped_frequency,
};
pub use stochastic::{
    PsdInput, Quadrature, StateOutput, StateSpace, lyapunov, psd_at, psd_variances,
};
pub use structure::{
    LinearStructure, Structure, StructureError, StructureFactor, StructureModes, reduced_base_load,
};

use crate::partition::choose_partition;
use follow::Follower;

/// The initial state: the beam at `(q, v)`, every mechanism assembled from its
/// [`MountedMechanism::initial_q`] (free coordinates exact, dependent ones a guess), free
/// velocities zero, currents zero, and consistent accelerations.
pub fn initial_state(
    model: &HybridModel,
    q: Vec<f64>,
    v: Vec<f64>,
) -> Result<HybridState, HybridError> {
    let n = model.structure_dofs();
    assert_eq!(q.len(), n, "beam DOF vector length");
    assert_eq!(v.len(), n, "beam velocity vector length");
    let w = model.coupling_values(&q);
    let mut mechanisms = Vec::with_capacity(model.mechanisms.len());
    for (i, m) in model.mechanisms.iter().enumerate() {
        let mut f = Follower::new(model, i, vec![], 0);
        let free = if f.rows() == 0 {
            (0..m.system.dof()).collect()
        } else {
            f.eval_rows(model, &w);
            let choice = choose_partition(f.jacobian(), 1e-9);
            if choice.rank < f.rows() {
                return Err(HybridError::Partition {
                    mechanism: m.name.clone(),
                    rows: f.rows(),
                    rank: choice.rank,
                });
            }
            choice.partition.independent
        };
        let dof = m.system.dof();
        mechanisms.push(MechanismState {
            q: m.initial_q.clone(),
            qd: vec![0.0; dof],
            qdd: vec![0.0; dof],
            free,
            condition: 1.0,
            sigma_min: 1.0,
            residual: 0.0,
        });
    }
    let nf = model.forces.len();
    let mut state = HybridState {
        t: 0.0,
        a: vec![0.0; n],
        q,
        v,
        mechanisms,
        currents: vec![0.0; nf],
        current_rates: vec![0.0; nf],
        account: Account {
            dissipated: vec![0.0; nf],
            gearbox_loss: vec![0.0; nf],
            mechanical_input: vec![0.0; nf],
            conversion: vec![0.0; nf],
            excitation_work: vec![0.0; model.excitations.len()],
            dissipated_model: vec![0.0; model.mechanisms.len()],
            model_input_work: vec![0.0; model.mechanisms.len()],
            ..Account::default()
        },
        steps: 0,
    };
    let mut start = Integrator::new(model, Method::Newmark, 0.0, &state)?;
    start.initial_accelerations(model, &mut state)?;
    Ok(state)
}
