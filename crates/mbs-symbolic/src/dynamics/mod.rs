//! The symbolic recursive Newton–Euler formulation for tree mechanisms (paper section 2.1,
//! eqs. 1–13), in the Fisette–Samin / ROBOTRAN style: every kinematic and dynamic quantity is
//! a node of one expression DAG, expressed in body-fixed frames, with intermediate variables
//! shared rather than expanded.
//!
//! # Forward recursion (eqs. 1–3)
//!
//! For body `i` with parent `p`, relative rotation `R_i` and joint offset `d_i` (in `F_p`):
//!
//! ```text
//! T^i  = T^p R_i                      x_Oi = x_Op + T^p d_i                     (1)
//! w_i  = R_i^T w_p + e_i q'_i                         (revolute; w_i = R_i^T w_p if prismatic)
//! a_i  = R_i^T (a_p + al_p x d_i + w_p x (w_p x d_i) + 2 w_p x u_i q'_i)         remainders of (3)
//! al_i = R_i^T al_p + (R_i^T w_p) x e_i q'_i
//! ```
//!
//! with `a_0 = -g` (gravity as a base acceleration, so gravity lands in `F`), `u_i` the
//! prismatic axis in `F_p`, and all quantities in the body's own frame. `T^i` uses the sine
//! and cosine of the *sum* of the angles of consecutive revolute joints about the same axis
//! (ROBOTRAN's angle grouping) instead of products of rotations.
//!
//! The formulas of each joint type are in `joint.rs`, in one place.
//!
//! # Backward recursion (eqs. 4–9) and projection (eqs. 10–13)
//!
//! * `F^b` (12): the `D` terms — the inertial wrench of each body with `q'' = 0`,
//!   `f_i = m_i a_Ci`, `n_i = I_i al_i + w_i x (I_i w_i) + c_i x f_i` about `O_i`, summed from
//!   the leaves to the root (`W_p += (R_i f, R_i n + d_i x R_i f)`) and projected on the joint
//!   axis (`e . n` for a revolute, `a . f` for a prismatic joint). Two exact variants are
//!   derived and the cheaper kept: gravity as the base acceleration or as body forces
//!   `m T^i^T g`, and the wrench carried plain or in composite form `F_i = M_i a_i + G_i`,
//!   `N_i = S_i x a_i + H_i` (subtree mass `M_i`, first moment `S_i`), in which a child's
//!   force reaches its parent as `M_k (a_p + rel_k) + R_k G_k` and the acceleration is not
//!   rotated back to the frame it came from (`forces.rs`).
//! * `M^b` (11): the `C` terms — the response of the subtree of body `j` to a unit `q''_j`
//!   is the composite rigid body of that subtree (mass, first moment, inertia about `O_j`,
//!   accumulated from the leaves) times the joint's motion; projecting it on the axes of `j`
//!   and of its ancestors gives column `j` of `M^b` on and above the diagonal
//!   (the "sum over `l : i <= l`" of eq. 9 done once per subtree).
//! * `Q^b` (13): the `E` terms — applied forces and torques of the force elements,
//!   expressed in body frames, summed from the leaves and projected, with the paper's sign
//!   `Q = -(generalised applied force)`; joint force elements add directly to their row.

//!
//! # Layout
//!
//! * `joint.rs`: every joint type's formulas (eqs. 1–3, 11) — a new joint type is added here.
//! * `kinematics.rs`: the forward recursion (eqs. 1–3).
//! * `mass.rs`: `M^b` (eq. 11) by composite bodies.
//! * `forces.rs`: `F^b` (eq. 12) and the backward recursion it shares with `Q^b`.
//! * `elements.rs`: the force elements, one function each stating its `Q^b` terms (eq. 13),
//!   its potential `V_e`, its dissipation power `D_e` and its input power `P_e` — a new force
//!   element is added here.
//! * `energy.rs`: the potential energy `V(q)` (gravity and the elements' `V_e`).
mod elements;
mod energy;
mod forces;
mod joint;
mod kinematics;
mod mass;
pub mod vec3;

pub(crate) use joint::is_rotation;
pub use kinematics::BodyKinematics;

use crate::expr::{Dag, Id, OpCount};
use crate::model::{Model, Scalar};
use forces::{Gravity, Recursion};
use vec3::{M3, V3};

/// The symbolic equations of motion `M q'' + F + Q = 0` of a tree (eq. 10) and the
/// body kinematics they were derived from, all in one DAG.
#[derive(Clone, Debug)]
pub struct Symbolic {
    /// The expression arena.
    pub dag: Dag,
    /// Number of joint coordinates.
    pub n: usize,
    /// Per-body kinematics.
    pub bodies: Vec<BodyKinematics>,
    /// `M^b`, row-major `n x n`; `mass[i*n+j]` and `mass[j*n+i]` are the same node.
    pub mass: Vec<Id>,
    /// `F^b`: velocity terms and gravity.
    pub f: Vec<Id>,
    /// `Q^b`: force elements, paper sign.
    pub q: Vec<Id>,
    /// `G(q) = dF^b/dg = -sum_i m_i J_Ci^T`, row-major `n x 3` (`gravity_jacobian[3 j + k]`
    /// = `dF^b_j/dg_k`): the generalised load of a frame acceleration `a` is `-G a` (see
    /// `forces::gravity_jacobian`).
    pub gravity_jacobian: Vec<Id>,
    /// Potential energy `V(q)`: gravity `-sum m_i g . x_Ci` plus the springs of the force
    /// elements, `k (q - rest)^2 / 2` and `k (l - l0)^2 / 2`. The gravity part of `F^b` and the
    /// spring part of `Q^b` are its gradient.
    pub potential: Id,
    /// Dissipation power of the force elements `D(q, q') = sum_e D_e`: `c q'^2` of the
    /// joint dampers, `c l'^2` of the point spring-dampers (see `elements.rs`).
    pub dissipation: Id,
    /// Power put in by the force elements that have neither potential nor dissipation,
    /// `P(q, q') = sum_e P_e`: `f0 q'` of the constant joint forces, `f . x' + t . w` of the
    /// external loads. Along any motion `d(T + V)/dt = P - D` (docs/theory.md section 8).
    pub input_power: Id,
}

/// The model being derived and the DAG its expressions go into.
struct Builder<'m> {
    model: &'m Model,
    dag: Dag,
}

impl Builder<'_> {
    fn s(&mut self, x: &Scalar) -> Id {
        self.dag.scalar(x, &self.model.parameters)
    }

    fn v(&mut self, x: &[Scalar; 3]) -> V3 {
        [self.s(&x[0]), self.s(&x[1]), self.s(&x[2])]
    }

    fn inertia(&mut self, i: &[[Scalar; 3]; 3]) -> M3 {
        let mut m = [[self.dag.zero(); 3]; 3];
        for r in 0..3 {
            for c in 0..3 {
                // Symmetric by validation; use the upper triangle for both halves so the
                // two halves are the same node.
                let (a, b) = if r <= c { (r, c) } else { (c, r) };
                m[r][c] = self.s(&i[a][b]);
            }
        }
        m
    }
}

impl Symbolic {
    /// Derives the symbolic equations of motion of the model's tree.
    pub fn derive(model: &Model) -> Symbolic {
        let mut b = Builder {
            model,
            dag: Dag::new(),
        };
        let bodies = kinematics::forward_kinematics(&mut b);
        let n = model.dof();
        let mass = mass::mass_matrix(&mut b, &bodies);
        // Every way of bringing in gravity and of carrying the wrenches is exact; keep the
        // one that needs the fewest operations together with M (the others' nodes are never
        // emitted). Ties keep the earlier variant, so the choice is deterministic.
        let mut best: Option<(usize, Vec<Id>)> = None;
        for recursion in [Recursion::Plain, Recursion::Composite] {
            for gravity in [Gravity::BaseAcceleration, Gravity::BodyForces] {
                let f = forces::velocity_and_gravity_terms(&mut b, &bodies, gravity, recursion);
                let roots: Vec<Id> = mass.iter().chain(&f).copied().collect();
                let cost = b.dag.op_count(&roots).total();
                if best.as_ref().is_none_or(|(c, _)| cost < *c) {
                    best = Some((cost, f));
                }
            }
        }
        let f = best.map(|(_, f)| f).unwrap_or_default();
        let gravity_jacobian = forces::gravity_jacobian(&mut b, &bodies);
        let elements = elements::force_elements(&mut b, &bodies);
        let potential = energy::potential_energy(&mut b, &bodies, &elements.potentials);
        Symbolic {
            dag: b.dag,
            n,
            bodies,
            mass,
            f,
            q: elements.q,
            gravity_jacobian,
            potential,
            dissipation: elements.dissipation,
            input_power: elements.input,
        }
    }

    /// The distinct nodes of `M^b` (upper triangle, row by row) followed by `F^b`.
    pub fn mf_roots(&self) -> Vec<Id> {
        let mut roots = Vec::with_capacity(self.n * (self.n + 1) / 2 + self.n);
        for i in 0..self.n {
            for j in i..self.n {
                roots.push(self.mass[i * self.n + j]);
            }
        }
        roots.extend(&self.f);
        roots
    }

    /// Operations to evaluate `M^b` and `F^b` once (shared intermediates counted once).
    pub fn op_count_mf(&self) -> OpCount {
        self.dag.op_count(&self.mf_roots())
    }

    /// Operations to evaluate `M^b` once.
    pub fn op_count_m(&self) -> OpCount {
        let roots = self.mf_roots();
        self.dag.op_count(&roots[..roots.len() - self.n])
    }

    /// Operations to evaluate `F^b` once.
    pub fn op_count_f(&self) -> OpCount {
        self.dag.op_count(&self.f)
    }

    /// Operations to evaluate `Q^b` once.
    pub fn op_count_q(&self) -> OpCount {
        self.dag.op_count(&self.q)
    }

    /// Ground-frame position of a point fixed on `body` (`None` = ground) at body-frame
    /// coordinates `r` (eq. 1: `x = x_Oi + T^i r`).
    pub fn point_position(&mut self, body: Option<usize>, r: V3) -> V3 {
        kinematics::ground_point(&mut self.dag, &self.bodies, body, r)
    }

    /// Jacobian `dp/dq` (eq. 49) of that point, 3 rows of `n`, in O(N) operations (lever
    /// arms shared from the body towards the root; see `kinematics::point_jacobian`).
    pub fn point_jacobian(&mut self, body: Option<usize>, r: V3) -> [Vec<Id>; 3] {
        kinematics::point_jacobian(&mut self.dag, &self.bodies, body, r)
    }

    /// Bias `A = J' q'` (eq. 50) of that point from the forward recursion's acceleration
    /// remainders without the base acceleration: every term is a product with a joint rate,
    /// so the bias is exactly zero at `q' = 0`.
    pub fn point_bias(&mut self, body: Option<usize>, r: V3) -> V3 {
        kinematics::point_bias(&mut self.dag, &self.bodies, body, r)
    }
}

#[cfg(test)]
mod tests;
