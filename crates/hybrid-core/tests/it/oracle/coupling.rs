//! The oracle's joint between the beam and the mechanism (paper section 4, docs/theory.md
//! sections 5–6): a copy of the former `hybrid_core::coupling`, on hybrid-core's public API.
//!
//! A point `p(q^b)` of a planar two-coordinate mechanism (the double bar's `tip`) is pinned
//! to a point of the beam whose transverse displacement is `y = n . q^c` — a single DOF
//! (`n = e_j`, pinning at node `j`) or, inside an element, the shape-function row of eq. (35).
//! With the mechanism's ground frame aligned with the beam's axes:
//!
//! ```text
//! h1 = p_y(q^b) - (y0 + n . q^c)        (45)     h2 = p_x(q^b) - x0        (46)
//! J^b = [dp_y/dq^b ; dp_x/dq^b]          J^c = [-n^T ; 0]                   (49), (53)–(54)
//! A^b = [J'_y q^b' ; J'_x q^b']          (50; rows in the order of J^b)
//! ```
//!
//! With all mechanism coordinates dependent (docs/theory.md section 6), the mechanism follows the
//! beam: `q^b` from `h = 0` (Newton with `J^b`), `q^b' = g y'` with `g = J^b^-1 e_1`, and the
//! reduction (56)–(58) collapses to a rank-one term on the beam:
//!
//! ```text
//! A^cR = A^c + m_eff n n^T,          m_eff = g^T M^b g                              (56)
//! P^cR = P^c + n f,                  f = g^T (M^b s - F^b - Q^b),  s = J^b^-1 A^b     (58)
//! ```
//!
//! `m_eff` is the mechanism's (and the rotor's) reflected mass at the beam point and `f` the
//! force the mechanism applies to the beam; `g_1` is the velocity amplification
//! `q1'/y'`, and the generator's `Q_1 = c_g q1'` reflects as the damping `c_g g_1^2`.

use std::cell::RefCell;

use hybrid_core::generator::GeneratorSpec;
use mbs_symbolic::runtime::{System, Workspace};

/// Where the mechanism point is pinned: its target in the mechanism's ground frame when the
/// beam is undeformed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Attachment {
    /// Index of the mechanism point (e.g. `tip`).
    pub point: usize,
    /// `x0` of eq. (46).
    pub x0: f64,
    /// `y0` of eq. (45): the point's `y` when the beam is undeformed.
    pub y0: f64,
}

/// Why the mechanism could not follow the beam.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum KinematicError {
    /// `J^b` is (nearly) singular: the mechanism is at or near its singular (toggle)
    /// position.
    #[error(
        "mechanism at its singular position: cond(J^b) = {condition:.3e} (smallest singular value {sigma_min:.3e} m) at q^b = [{:.6}, {:.6}] rad",
        q[0],
        q[1]
    )]
    Singular {
        /// Condition number of `J^b`.
        condition: f64,
        /// Smallest singular value of `J^b` (m/rad): the distance to the singular position.
        sigma_min: f64,
        /// Mechanism coordinates.
        q: [f64; 2],
    },
    /// Newton on `h = 0` did not converge: the beam point is out of the mechanism's reach
    /// (e.g. pushed through the toggle position).
    #[error("{}", no_assembly_message(*residual, *iterations, q, *reach))]
    NoAssembly {
        /// How far the beam point can move from its undeformed position in the direction
        /// that stretches the mechanism (m), when the geometry gives it: `2 L (1 - cos a0)`
        /// for a double bar of equal bars at half-angle `a0`.
        reach: Option<f64>,
        /// Constraint residual norm at the last iterate.
        residual: f64,
        /// Iterations made.
        iterations: usize,
        /// Last iterate.
        q: [f64; 2],
    },
}

fn no_assembly_message(
    residual: f64,
    iterations: usize,
    q: &[f64; 2],
    reach: Option<f64>,
) -> String {
    let reach = match reach {
        Some(r) => format!(
            "it reaches at most {r:.6e} m from the undeformed position (2 L (1 - cos a0) for a double bar of equal bars L at half-angle a0); "
        ),
        None => String::new(),
    };
    format!(
        "the mechanism cannot reach the beam point: {reach}|h| = {residual:.3e} m after {iterations} Newton iterations (q^b = [{:.6}, {:.6}] rad)",
        q[0], q[1]
    )
}

/// 2x2 helpers.
fn det2(j: &[[f64; 2]; 2]) -> f64 {
    j[0][0] * j[1][1] - j[0][1] * j[1][0]
}

/// `J^-1 b` for a 2x2 system (Cramer's rule; the caller checks the conditioning first).
fn solve2(j: &[[f64; 2]; 2], b: [f64; 2]) -> [f64; 2] {
    let d = det2(j);
    [
        (b[0] * j[1][1] - b[1] * j[0][1]) / d,
        (j[0][0] * b[1] - j[1][0] * b[0]) / d,
    ]
}

/// Singular values (largest, smallest) of a 2x2 matrix.
fn singular_values2(j: &[[f64; 2]; 2]) -> (f64, f64) {
    let fro2 = j[0][0].powi(2) + j[0][1].powi(2) + j[1][0].powi(2) + j[1][1].powi(2);
    let d = det2(j).abs();
    // sigma_max^2 + sigma_min^2 = |J|_F^2, sigma_max sigma_min = |det J|.
    let disc = (fro2 * fro2 - 4.0 * d * d).max(0.0).sqrt();
    let smax = ((fro2 + disc) / 2.0).sqrt();
    let smin = if smax > 0.0 { d / smax } else { 0.0 };
    (smax, smin)
}

/// The mechanism's configuration following a beam point, and the reduced terms it feeds
/// back (see the module documentation). Filled by [`MechanismLink::follow`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LinkState {
    /// Mechanism coordinates `q^b`.
    pub q: [f64; 2],
    /// Mechanism velocities `q^b' = g y'` (eq. 18).
    pub qd: [f64; 2],
    /// `J^b` (rows: y, x).
    pub jb: [[f64; 2]; 2],
    /// `g = J^b^-1 e_1 = dq^b/dy`: the kinematic influence of the beam point's motion.
    pub g: [f64; 2],
    /// Reflected mass `m_eff = g^T M^b g` (kg).
    pub m_eff: f64,
    /// Force of the mechanism on the beam point, `f` of eq. (58) (N).
    pub force: f64,
    /// Generator current (A).
    pub current: f64,
    /// Condition number of `J^b`.
    pub condition: f64,
    /// Smallest singular value of `J^b` (m/rad).
    pub sigma_min: f64,
    /// Kinetic energy of the mechanism and rotor, `q^b'^T M^b q^b' / 2` (J).
    pub kinetic_energy: f64,
    /// Potential energy of the mechanism (gravity, springs), `V(q^b)` (J).
    pub potential_energy: f64,
    /// Norm of the position constraint residual `h` after the Newton solve (m).
    pub residual: f64,
}

/// A two-coordinate mechanism pinned to a beam point, with the generator on one joint.
///
/// The mechanism is any [`System`] (generated code, the interpreter or the numeric
/// reference, usually a `Box<dyn System>` from the model registry) of two coordinates and no
/// constraint rows; its evaluations go into a workspace allocated once, here.
#[derive(Clone, Debug)]
pub struct MechanismLink<M> {
    /// The mechanism equations.
    pub mechanism: M,
    /// Where its point is pinned.
    pub attachment: Attachment,
    /// Joint index carrying the generator.
    pub generator_joint: usize,
    /// Condition number of `J^b` beyond which the run stops (approach of the singular
    /// position).
    pub max_condition: f64,
    /// How far the beam point can move from its undeformed position in the direction that
    /// stretches the mechanism (m), when the geometry gives it (reported when the
    /// mechanism cannot follow).
    pub reach: Option<f64>,
    ws: RefCell<Workspace>,
}

/// A mechanism that cannot be the damper's: the damper needs a two-coordinate mechanism
/// without constraint rows, whose point and generator joint exist.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LinkShapeError {
    /// Wrong number of coordinates or constraint rows.
    #[error(
        "the damper needs a planar mechanism of 2 coordinates without constraints; this model has {dof} coordinate(s) and {rows} constraint row(s)"
    )]
    Shape {
        /// Coordinates of the model.
        dof: usize,
        /// Constraint rows of the model.
        rows: usize,
    },
    /// The point index is out of range.
    #[error("the model has no point number {0}")]
    Point(usize),
    /// The generator joint index is out of range.
    #[error("the model has no joint number {0}")]
    Joint(usize),
}

impl<M: System> MechanismLink<M> {
    /// Links `mechanism` (checked to have 2 coordinates, no constraint rows, the point and
    /// the joint) to the beam point.
    pub fn new(
        mechanism: M,
        attachment: Attachment,
        generator_joint: usize,
        max_condition: f64,
    ) -> Result<Self, LinkShapeError> {
        let (dof, rows) = (mechanism.dof(), mechanism.rows());
        if dof != 2 || rows != 0 {
            return Err(LinkShapeError::Shape { dof, rows });
        }
        if attachment.point >= mechanism.point_names().len() {
            return Err(LinkShapeError::Point(attachment.point));
        }
        if generator_joint >= dof {
            return Err(LinkShapeError::Joint(generator_joint));
        }
        let ws = RefCell::new(mechanism.workspace());
        Ok(MechanismLink {
            mechanism,
            attachment,
            generator_joint,
            max_condition,
            reach: None,
            ws,
        })
    }

    /// Point kinematics of the attachment point at `(q, q')`: `(p, J rows, A)` in the
    /// ground frame (eqs. 49–50).
    pub fn point(&self, q: &[f64; 2], qd: &[f64; 2]) -> ([f64; 3], [[f64; 2]; 3], [f64; 3]) {
        let ws = &mut *self.ws.borrow_mut();
        self.mechanism
            .point_kinematics(self.attachment.point, q, qd, ws);
        // Column-major 3 x 2.
        let pj = &ws.point_j.as_slice()[..6];
        let (p, a) = (ws.point_p, ws.point_a);
        (
            [p[0], p[1], p[2]],
            [[pj[0], pj[3]], [pj[1], pj[4]], [pj[2], pj[5]]],
            [a[0], a[1], a[2]],
        )
    }

    /// `M^b`, `F^b`, `Q^b` at `(q, q', t)` with the generator's contribution (rotor inertia,
    /// torque for `current`) added — from one evaluation of the mechanism.
    pub fn equations(
        &self,
        q: &[f64; 2],
        qd: &[f64; 2],
        t: f64,
        generator: &GeneratorSpec,
        current: f64,
    ) -> ([[f64; 2]; 2], [f64; 2], [f64; 2]) {
        let ws = &mut *self.ws.borrow_mut();
        self.mechanism.evaluate(q, qd, t, ws);
        generator.add_to_equations(
            self.generator_joint,
            qd[self.generator_joint],
            current,
            &mut ws.m,
            &mut ws.q,
        );
        // Column-major 2 x 2.
        let m = &ws.m.as_slice()[..4];
        let (f, qv) = (&ws.f.as_slice()[..2], &ws.q.as_slice()[..2]);
        ([[m[0], m[2]], [m[1], m[3]]], [f[0], f[1]], [qv[0], qv[1]])
    }

    /// Potential energy `V(q^b)` of the mechanism (gravity, springs).
    pub fn potential_energy(&self, q: &[f64; 2]) -> f64 {
        self.mechanism
            .potential_energy(q, &mut self.ws.borrow_mut())
    }

    /// Constraint residual `h = [p_y - (y0 + y), p_x - x0]` and `J^b` at `q`.
    fn residual(&self, q: &[f64; 2], y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
        let (p, j, _) = self.point(q, &[0.0; 2]);
        let h = [p[1] - (self.attachment.y0 + y), p[0] - self.attachment.x0];
        (h, [j[1], j[0]])
    }

    /// Solves `h(q^b) = 0` for the beam point at `y` by Newton's method from `guess`
    /// (the guess selects the assembly branch). Step length limited to 0.3 rad.
    pub fn solve_positions(&self, y: f64, guess: [f64; 2]) -> Result<[f64; 2], KinematicError> {
        let mut q = guess;
        let scale = 1.0 + self.attachment.y0.abs() + self.attachment.x0.abs();
        for it in 0..60 {
            let (h, jb) = self.residual(&q, y);
            let rn = h[0].hypot(h[1]);
            if !rn.is_finite() {
                return Err(KinematicError::NoAssembly {
                    reach: self.reach,
                    residual: rn,
                    iterations: it,
                    q,
                });
            }
            let (smax, smin) = singular_values2(&jb);
            if smin <= 1e-14 * smax.max(1e-300) {
                return Err(KinematicError::Singular {
                    condition: f64::INFINITY,
                    sigma_min: smin,
                    q,
                });
            }
            let mut dq = solve2(&jb, h);
            let len = dq[0].hypot(dq[1]);
            if len > 0.3 {
                dq = [dq[0] * 0.3 / len, dq[1] * 0.3 / len];
            }
            q = [q[0] - dq[0], q[1] - dq[1]];
            if len <= 1e-13 * (1.0 + q[0].abs() + q[1].abs()) {
                let (h, _) = self.residual(&q, y);
                let r = h[0].hypot(h[1]);
                if r <= 1e-12 * scale {
                    return Ok(q);
                }
                return Err(KinematicError::NoAssembly {
                    reach: self.reach,
                    residual: r,
                    iterations: it + 1,
                    q,
                });
            }
        }
        let (h, jb) = self.residual(&q, y);
        let residual = h[0].hypot(h[1]);
        if residual <= 1e-12 * scale {
            // The point is reached (h = 0 to rounding) but the Newton steps do not settle:
            // J^b is too ill-conditioned to pin q^b down — the toggle, not the reach.
            let (smax, smin) = singular_values2(&jb);
            return Err(KinematicError::Singular {
                condition: if smin > 0.0 {
                    smax / smin
                } else {
                    f64::INFINITY
                },
                sigma_min: smin,
                q,
            });
        }
        Err(KinematicError::NoAssembly {
            reach: self.reach,
            residual,
            iterations: 60,
            q,
        })
    }

    /// Follows the beam point at displacement `y`, velocity `yd`: positions by Newton
    /// (warm-started from `warm`), velocities by eq. (18), and the reduced terms `m_eff`, `f`
    /// of eqs. (56), (58), with the generator torque from `current`. Allocates nothing.
    pub fn follow(
        &self,
        y: f64,
        yd: f64,
        t: f64,
        warm: [f64; 2],
        current: Current<'_>,
    ) -> Result<LinkState, KinematicError> {
        let q = self.solve_positions(y, warm)?;
        let (h, jb) = self.residual(&q, y);
        let (smax, smin) = singular_values2(&jb);
        let condition = if smin > 0.0 {
            smax / smin
        } else {
            f64::INFINITY
        };
        if condition > self.max_condition {
            return Err(KinematicError::Singular {
                condition,
                sigma_min: smin,
                q,
            });
        }
        let g = solve2(&jb, [1.0, 0.0]);
        let qd = [g[0] * yd, g[1] * yd];
        let (_, _, pa) = self.point(&q, &qd);
        let ab = [pa[1], pa[0]];
        let s = solve2(&jb, ab);
        let (spec, i) = match current {
            Current::QuasiStatic(spec) => {
                (spec, spec.quasi_static_current(qd[self.generator_joint]))
            }
            Current::State(spec, i) => (spec, i),
        };
        // M, F, Q from one fused evaluation (shared trigonometric leaves), generator added.
        let (m, f, qv) = self.equations(&q, &qd, t, spec, i);
        let mg = [
            m[0][0] * g[0] + m[0][1] * g[1],
            m[1][0] * g[0] + m[1][1] * g[1],
        ];
        let ms = [
            m[0][0] * s[0] + m[0][1] * s[1],
            m[1][0] * s[0] + m[1][1] * s[1],
        ];
        let m_eff = g[0] * mg[0] + g[1] * mg[1];
        let force = g[0] * (ms[0] - f[0] - qv[0]) + g[1] * (ms[1] - f[1] - qv[1]);
        let kinetic_energy = 0.5 * yd * yd * m_eff;
        let potential_energy = self.potential_energy(&q);
        Ok(LinkState {
            q,
            qd,
            jb,
            g,
            m_eff,
            force,
            current: i,
            condition,
            sigma_min: smin,
            kinetic_energy,
            potential_energy,
            residual: h[0].hypot(h[1]),
        })
    }
}

/// How the generator current is known when following the beam.
#[derive(Clone, Copy, Debug)]
pub enum Current<'a> {
    /// Zero inductance: `i = k_e n q' / R` (0 when disconnected), and its torque is applied.
    QuasiStatic(&'a GeneratorSpec),
    /// A current state `i` (inductance > 0), whose torque is applied.
    State(&'a GeneratorSpec, f64),
}
