//! An independent reference for hybrid systems: the joined equations (51)–(54) with every
//! coordinate and every multiplier solved together in one dense system, and a trajectory
//! integrator on it (classical RK4 with projection onto the constraints).
//!
//! Written apart from the partitioned engine ([`super::Integrator`]): nothing here
//! partitions, follows or reduces; it shares with the engine only the model description and
//! the one place joint forces enter the equations ([`HybridModel::add_joint_forces`]). It is
//! slow (dense `O(N^3)` per evaluation, `N` all coordinates) and meant for tests.
//!
//! # The system
//!
//! All coordinates `x = [q^c (the host structure: the beam or an imported or reduced model,
//! n); q^1; q^2; ...]` (every mechanism's tree coordinates) and all multipliers `lambda` (per
//! mechanism: its loop rows, then per attachment of that mechanism, in the model's order, the
//! row along the point's direction and for a pin the `x` row):
//!
//! ```text
//! [ M_full  J^T ] [ x''    ]   [ rhs ]        M_full = blockdiag(A, M^1, M^2, ...)
//! [ J       0   ] [ lambda ] = [ -a  ]        rhs = [P(t) - B q^c' - C q^c; -(F^b + Q^b) ...]
//! ```
//!
//! with `M^b`, `F^b`, `Q^b` of each mechanism including its force elements and joint
//! excitations (eqs. 11–13), `P` the beam's loads plus its excitations, and the rows
//!
//! ```text
//! loop rows        h = h^b(q^b)                       J = [0 .. J^b ..]       a = A^b   (14)–(16)
//! direction row    h = d.(P(q^b) - P_0) - n^T q^c     J = [-n^T .. d.dP/dq^b ..]       (45), (54)
//! x row (pin)      h = P_x(q^b) - x_0 - m^T q^c       J = [-m^T .. dP_x/dq^b ..]       (46)
//! ```
//!
//! `P = origin + R(angle) p(q^b)` the mechanism point in the structure's frame, `P_0 = (x_0,
//! y_0)` the attachment's undeformed position, `d` its direction (`y` on the beam and for a
//! pin; a roller at a node follows its own), `n` the weights of its displacement along `d`,
//! `m` those along `x` (none on the beam, whose points do not move axially: eq. 46 as
//! written), `a` the bias `J' x'` (the point bias `point_a` rotated by the mount; `n`, `m`
//! are constant so the structure adds no bias). The structure's dense `M`, `B`, `K` are its
//! products with the unit vectors. The first block row is the beam (44) with `-J^c^T lambda` moved to the left, the
//! next ones are each mechanism's `M q'' + F + Q + J^T lambda = 0` (17).
//!
//! # Trajectories
//!
//! The index-1 form above gives `x''` for any `(x, x')`; [`Reference::step`] advances
//! `(x, x', i)` (`i` the currents of inductive generators, `L i' = k_e n q_j' - R i`) by one
//! classical Runge–Kutta step and then projects `x` onto `h(x) = 0` by Gauss–Newton with the
//! full Jacobian (minimum-norm corrections `-J^T (J J^T)^-1 h`) and `x'` onto `J x' = 0`.

use mbs_symbolic::samples::SplitMix64;
use nalgebra::{DMatrix, DVector};

use super::linear::{Linearization, Matrix};

use super::integrator::HybridState;
use super::model::{AttachmentKind, HybridModel};
use super::structure::LinearStructure;

/// Index bookkeeping of the full coordinate and multiplier vectors.
#[derive(Clone, Debug)]
struct Layout {
    /// Beam DOFs.
    n: usize,
    /// Offset of each mechanism's coordinates in `x`.
    coord: Vec<usize>,
    /// Offset of each mechanism's rows in `lambda`.
    row: Vec<usize>,
    /// All coordinates.
    total: usize,
    /// All rows.
    rows: usize,
    /// The structure's mass, damping and stiffness matrices, dense.
    dense: Option<[DMatrix<f64>; 3]>,
}

impl Layout {
    fn of(model: &HybridModel) -> Layout {
        let n = model.structure_dofs();
        let (mut coord, mut row) = (Vec::new(), Vec::new());
        let (mut c, mut r) = (n, 0);
        for (i, m) in model.mechanisms.iter().enumerate() {
            coord.push(c);
            row.push(r);
            c += m.system.dof();
            r += m.system.rows()
                + model
                    .attachments
                    .iter()
                    .filter(|a| a.mechanism == i)
                    .map(|a| a.kind.rows())
                    .sum::<usize>();
        }
        Layout {
            n,
            coord,
            row,
            total: c,
            rows: r,
            dense: structure_matrices(model),
        }
    }
}

/// The host structure's mass, damping and stiffness matrices, dense (`None` without a
/// structure): its products with the unit vectors.
pub fn structure_matrices(model: &HybridModel) -> Option<[DMatrix<f64>; 3]> {
    let n = model.structure_dofs();
    model.structure.as_ref().map(|s| {
        [
            dense(n, |x, y| s.mass_mul_add(1.0, x, y)),
            dense(n, |x, y| s.damping_mul_add(1.0, x, y)),
            dense(n, |x, y| s.stiffness_mul_add(1.0, x, y)),
        ]
    })
}

/// The `n x n` matrix of the product `y += A x`, column by column (`A e_j`).
fn dense(n: usize, mul_add: impl Fn(&[f64], &mut [f64])) -> DMatrix<f64> {
    let mut a = DMatrix::zeros(n, n);
    let mut e = vec![0.0; n];
    let mut col = vec![0.0; n];
    for j in 0..n {
        e[j] = 1.0;
        col.fill(0.0);
        mul_add(&e, &mut col);
        a.column_mut(j).copy_from_slice(&col);
        e[j] = 0.0;
    }
    a
}

/// Constraint values `h`, Jacobian `J = dh/dx` and (with velocities) the bias `a = J' x'`
/// of the joined system at `x` (full layout: beam, then every mechanism).
fn constraint_terms(
    model: &HybridModel,
    lay: &Layout,
    x: &[f64],
    xd: Option<&[f64]>,
) -> (DVector<f64>, DMatrix<f64>, DVector<f64>) {
    let mut h = DVector::zeros(lay.rows);
    let mut jac = DMatrix::zeros(lay.rows, lay.total);
    let mut bias = DVector::zeros(lay.rows);
    for (i, m) in model.mechanisms.iter().enumerate() {
        let sys = &m.system;
        let (c0, r0, dof) = (lay.coord[i], lay.row[i], sys.dof());
        let q = &x[c0..c0 + dof];
        let zero = vec![0.0; dof];
        let qd = xd.map_or(&zero[..], |v| &v[c0..c0 + dof]);
        let mut ws = sys.workspace();
        let loops = sys.rows();
        if loops > 0 {
            sys.evaluate(q, qd, 0.0, &mut ws);
            for r in 0..loops {
                h[r0 + r] = ws.h[r];
                bias[r0 + r] = ws.a[r];
                for c in 0..dof {
                    jac[(r0 + r, c0 + c)] = ws.j[(r, c)];
                }
            }
        }
        let (cs, sn) = (m.mount.angle.cos(), m.mount.angle.sin());
        let mut r = r0 + loops;
        for a in model.attachments.iter().filter(|a| a.mechanism == i) {
            assert!(
                sys.point_kinematics(a.point, q, qd, &mut ws),
                "attachment point exists (checked by HybridModel::new)"
            );
            let (px, py) = (ws.point_p[0], ws.point_p[1]);
            let (bx, by) = (
                m.mount.origin[0] + cs * px - sn * py,
                m.mount.origin[1] + sn * px + cs * py,
            );
            // The row along the point's direction d (y on the beam and for a pin):
            // d . (P - P_0) - n^T q^c.
            let d = a.beam.direction;
            h[r] = d[0] * (bx - a.beam.x) + d[1] * (by - a.beam.y) - a.beam.value(&x[..lay.n]);
            for &(k, w) in &a.beam.weights {
                jac[(r, k)] -= w;
            }
            let (dx, dy) = (d[0] * cs + d[1] * sn, d[1] * cs - d[0] * sn);
            for c in 0..dof {
                jac[(r, c0 + c)] = dx * ws.point_j[(0, c)] + dy * ws.point_j[(1, c)];
            }
            bias[r] = dx * ws.point_a[0] + dy * ws.point_a[1];
            r += 1;
            if a.kind == AttachmentKind::Pin {
                // The x row: P_x - x_0 - (the node's u_x; nothing on the beam).
                h[r] = bx - a.beam.x - a.beam.axial.iter().map(|&(k, w)| w * x[k]).sum::<f64>();
                for &(k, w) in &a.beam.axial {
                    jac[(r, k)] -= w;
                }
                for c in 0..dof {
                    jac[(r, c0 + c)] = cs * ws.point_j[(0, c)] - sn * ws.point_j[(1, c)];
                }
                bias[r] = cs * ws.point_a[0] - sn * ws.point_a[1];
                r += 1;
            }
        }
    }
    (h, jac, bias)
}

fn flatten(beam: &[f64], mech: &[Vec<f64>]) -> Vec<f64> {
    let mut x = beam.to_vec();
    for m in mech {
        x.extend_from_slice(m);
    }
    x
}

fn split(lay: &Layout, model: &HybridModel, x: &[f64]) -> (Vec<f64>, Vec<Vec<f64>>) {
    let mech = model
        .mechanisms
        .iter()
        .zip(&lay.coord)
        .map(|(m, &c)| x[c..c + m.system.dof()].to_vec())
        .collect();
    (x[..lay.n].to_vec(), mech)
}

/// Constraint values `h` of the joined system (per mechanism: loop rows, then per attachment
/// the transverse and, for a pin, the axial row) at beam DOFs `beam_q` and mechanism
/// coordinates `mech_q` — an independent check of a state's consistency.
pub fn constraints(model: &HybridModel, beam_q: &[f64], mech_q: &[Vec<f64>]) -> Vec<f64> {
    let lay = Layout::of(model);
    let x = flatten(beam_q, mech_q);
    constraint_terms(model, &lay, &x, None)
        .0
        .as_slice()
        .to_vec()
}

/// Velocity constraint values `J x'` of the joined system (same row order as
/// [`constraints`]).
pub fn velocity_constraints(
    model: &HybridModel,
    beam_q: &[f64],
    mech_q: &[Vec<f64>],
    beam_v: &[f64],
    mech_qd: &[Vec<f64>],
) -> Vec<f64> {
    let lay = Layout::of(model);
    let x = flatten(beam_q, mech_q);
    let xd = DVector::from_vec(flatten(beam_v, mech_qd));
    let jac = constraint_terms(model, &lay, &x, None).1;
    (jac * xd).as_slice().to_vec()
}

/// `x''` and `lambda` from the dense KKT system at `(x, x')` (full layout), with currents
/// `currents` for the inductive generators.
fn solve_kkt(
    model: &HybridModel,
    lay: &Layout,
    t: f64,
    x: &[f64],
    xd: &[f64],
    currents: &[f64],
) -> (DVector<f64>, DVector<f64>) {
    let (nt, nr) = (lay.total, lay.rows);
    let mut kkt = DMatrix::zeros(nt + nr, nt + nr);
    let mut rhs = DVector::zeros(nt + nr);
    let n = lay.n;
    if let (Some(structure), Some([mass, damp, stiff])) = (&model.structure, &lay.dense) {
        kkt.view_mut((0, 0), (n, n)).copy_from(mass);
        let mut p = vec![0.0; n];
        structure.load_into(t, &mut p);
        model.add_beam_excitations(t, &mut p);
        let a = model.base_acceleration(t);
        if a != 0.0 {
            for (pi, b) in p.iter_mut().zip(model.base_beam_load()) {
                *pi += a * b;
            }
        }
        let q = DVector::from_column_slice(&x[..n]);
        let v = DVector::from_column_slice(&xd[..n]);
        let r = DVector::from_vec(p) - damp * v - stiff * q;
        rhs.rows_mut(0, n).copy_from(&r);
    }
    for (i, m) in model.mechanisms.iter().enumerate() {
        let sys = &m.system;
        let (c0, dof) = (lay.coord[i], sys.dof());
        let (q, qd) = (&x[c0..c0 + dof], &xd[c0..c0 + dof]);
        let mut ws = sys.workspace();
        sys.evaluate(q, qd, t, &mut ws);
        model.add_joint_forces(i, t, q, qd, currents, &mut ws.m, &mut ws.q);
        model.add_base_load(i, t, q, &mut ws);
        kkt.view_mut((c0, c0), (dof, dof)).copy_from(&ws.m);
        for c in 0..dof {
            rhs[c0 + c] = -(ws.f[c] + ws.q[c]);
        }
    }
    let (_, jac, bias) = constraint_terms(model, lay, x, Some(xd));
    kkt.view_mut((nt, 0), (nr, nt)).copy_from(&jac);
    kkt.view_mut((0, nt), (nt, nr)).copy_from(&jac.transpose());
    rhs.rows_mut(nt, nr).copy_from(&(-bias));
    let sol = kkt
        .lu()
        .solve(&rhs)
        .expect("the KKT matrix is regular (positive definite mass, full-rank constraints)");
    (sol.rows(0, nt).into_owned(), sol.rows(nt, nr).into_owned())
}

/// Accelerations and multipliers of the joined system (eqs. 51–54) at time `t`, beam DOFs
/// `beam_q`, `beam_v`, mechanism coordinates `mech_q` and velocities `mech_qd`, currents
/// `currents` (one per force element; used for inductive generators, the others take their
/// quasi-static current): `(beam accelerations, each mechanism's q'', lambda)`, every
/// coordinate and multiplier solved together from the dense KKT system (see the module
/// documentation for the row order of `lambda`).
pub fn accelerations(
    model: &HybridModel,
    t: f64,
    beam_q: &[f64],
    beam_v: &[f64],
    mech_q: &[Vec<f64>],
    mech_qd: &[Vec<f64>],
    currents: &[f64],
) -> (Vec<f64>, Vec<Vec<f64>>, Vec<f64>) {
    let lay = Layout::of(model);
    let x = flatten(beam_q, mech_q);
    let xd = flatten(beam_v, mech_qd);
    let (xdd, lambda) = solve_kkt(model, &lay, t, &x, &xd, currents);
    let (a, qdd) = split(&lay, model, xdd.as_slice());
    (a, qdd, lambda.as_slice().to_vec())
}

/// A trajectory of the joined system: RK4 on the KKT system with projection onto the
/// constraints after each step (see the module documentation).
#[derive(Clone, Debug)]
pub struct Reference {
    lay: Layout,
    /// Time (s).
    pub t: f64,
    /// All coordinates (beam DOFs, then each mechanism's).
    x: Vec<f64>,
    /// Their velocities.
    xd: Vec<f64>,
    /// Current of each force element (the state of inductive generators; the quasi-static
    /// current of the others, refreshed after each step).
    currents: Vec<f64>,
    /// Largest position and velocity constraint residual norms after a projection so far.
    pub worst_residual: (f64, f64),
}

impl Reference {
    /// Starts at `state` (positions, velocities, currents and time of a consistent engine
    /// state; its accelerations are not used).
    pub fn from_state(model: &HybridModel, state: &HybridState) -> Reference {
        let lay = Layout::of(model);
        let mq: Vec<Vec<f64>> = state.mechanisms.iter().map(|m| m.q.clone()).collect();
        let mqd: Vec<Vec<f64>> = state.mechanisms.iter().map(|m| m.qd.clone()).collect();
        Reference {
            x: flatten(&state.q, &mq),
            xd: flatten(&state.v, &mqd),
            lay,
            t: state.t,
            currents: state.currents.clone(),
            worst_residual: (0.0, 0.0),
        }
    }

    /// Beam DOFs.
    pub fn beam_q(&self) -> &[f64] {
        &self.x[..self.lay.n]
    }

    /// Beam velocities.
    pub fn beam_v(&self) -> &[f64] {
        &self.xd[..self.lay.n]
    }

    /// Coordinates of mechanism `i`.
    pub fn mech_q(&self, model: &HybridModel, i: usize) -> &[f64] {
        let c = self.lay.coord[i];
        &self.x[c..c + model.mechanisms[i].system.dof()]
    }

    /// Velocities of mechanism `i`.
    pub fn mech_qd(&self, model: &HybridModel, i: usize) -> &[f64] {
        let c = self.lay.coord[i];
        &self.xd[c..c + model.mechanisms[i].system.dof()]
    }

    /// Current of each force element.
    pub fn currents(&self) -> &[f64] {
        &self.currents
    }

    /// `(x', x'', i')` at `(t, x, x', i)`.
    fn derivative(
        &self,
        model: &HybridModel,
        t: f64,
        x: &[f64],
        xd: &[f64],
        cur: &[f64],
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let (xdd, _) = solve_kkt(model, &self.lay, t, x, xd, cur);
        let di = model
            .forces
            .iter()
            .zip(cur)
            .map(|(f, &i)| match f.generator() {
                Some(g) if f.has_current_state() => {
                    let qd = xd[self.lay.coord[f.mechanism] + f.joint];
                    (g.ke * g.gear_ratio * qd - g.resistance() * i) / g.inductance
                }
                _ => 0.0,
            })
            .collect();
        (xd.to_vec(), xdd.as_slice().to_vec(), di)
    }

    /// One classical RK4 step of size `h`, then the projection onto `h(x) = 0` and
    /// `J x' = 0`.
    pub fn step(&mut self, model: &HybridModel, h: f64) {
        let t = self.t;
        let shift = |base: &[f64], d: &[f64], s: f64| -> Vec<f64> {
            base.iter().zip(d).map(|(b, d)| b + s * d).collect()
        };
        let k1 = self.derivative(model, t, &self.x, &self.xd, &self.currents);
        let (x2, v2, c2) = (
            shift(&self.x, &k1.0, 0.5 * h),
            shift(&self.xd, &k1.1, 0.5 * h),
            shift(&self.currents, &k1.2, 0.5 * h),
        );
        let k2 = self.derivative(model, t + 0.5 * h, &x2, &v2, &c2);
        let (x3, v3, c3) = (
            shift(&self.x, &k2.0, 0.5 * h),
            shift(&self.xd, &k2.1, 0.5 * h),
            shift(&self.currents, &k2.2, 0.5 * h),
        );
        let k3 = self.derivative(model, t + 0.5 * h, &x3, &v3, &c3);
        let (x4, v4, c4) = (
            shift(&self.x, &k3.0, h),
            shift(&self.xd, &k3.1, h),
            shift(&self.currents, &k3.2, h),
        );
        let k4 = self.derivative(model, t + h, &x4, &v4, &c4);
        let combine = |y: &mut [f64], a: &[f64], b: &[f64], c: &[f64], d: &[f64]| {
            for i in 0..y.len() {
                y[i] += h / 6.0 * (a[i] + 2.0 * b[i] + 2.0 * c[i] + d[i]);
            }
        };
        combine(&mut self.x, &k1.0, &k2.0, &k3.0, &k4.0);
        combine(&mut self.xd, &k1.1, &k2.1, &k3.1, &k4.1);
        combine(&mut self.currents, &k1.2, &k2.2, &k3.2, &k4.2);
        self.t = t + h;
        self.project(model);
        for (k, f) in model.forces.iter().enumerate() {
            if !f.has_current_state() {
                let qd = self.xd[self.lay.coord[f.mechanism] + f.joint];
                self.currents[k] = f.quasi_static_current(qd);
            }
        }
    }

    /// Gauss–Newton on `h(x) = 0` with minimum-norm corrections, then `x'` projected onto
    /// the null space of `J`.
    fn project(&mut self, model: &HybridModel) {
        if self.lay.rows == 0 {
            return;
        }
        let scale = 1.0 + self.x.iter().map(|v| v.abs()).fold(0.0, f64::max);
        let mut jac = DMatrix::zeros(0, 0);
        let mut res = f64::INFINITY;
        for it in 0..=20 {
            let (h, j, _) = constraint_terms(model, &self.lay, &self.x, None);
            res = h.norm();
            jac = j;
            if res <= 1e-15 * scale || it == 20 {
                break;
            }
            let jjt = &jac * jac.transpose();
            let mu = jjt
                .full_piv_lu()
                .solve(&h)
                .expect("the constraint Jacobian has full row rank");
            let dx = jac.transpose() * mu;
            for (x, d) in self.x.iter_mut().zip(dx.iter()) {
                *x -= d;
            }
        }
        let xd = DVector::from_column_slice(&self.xd);
        let jv = &jac * &xd;
        let jjt = &jac * jac.transpose();
        let mu = jjt
            .full_piv_lu()
            .solve(&jv)
            .expect("the constraint Jacobian has full row rank");
        let dv = jac.transpose() * mu;
        for (v, d) in self.xd.iter_mut().zip(dv.iter()) {
            *v -= d;
        }
        let vres = (&jac * DVector::from_column_slice(&self.xd)).norm();
        self.worst_residual.0 = self.worst_residual.0.max(res);
        self.worst_residual.1 = self.worst_residual.1.max(vres);
    }
}

// ---------------------------------------------------------------------------------------
// The linearisation against central differences of the KKT accelerations
// ---------------------------------------------------------------------------------------

/// The rows `T dz` of a reduced direction in the full coordinates: the beam part, and
/// every mechanism's `R_i P dz`.
fn full_direction(lin: &Linearization, dz: &[f64]) -> (Vec<f64>, Vec<Vec<f64>>) {
    (
        dz[..lin.structure_dofs()].to_vec(),
        lin.mechanism_motion(dz),
    )
}

fn axpy(x: &[f64], a: f64, y: &[f64]) -> Vec<f64> {
    x.iter().zip(y).map(|(x, y)| x + a * y).collect()
}

/// The dense KKT accelerations (beam, then every mechanism's, flattened) at positions
/// `x0 + e dx`, velocities `e dv` (both in full coordinates) and currents `e di`.
#[allow(clippy::too_many_arguments)]
fn kkt(
    model: &HybridModel,
    beam_q: &[f64],
    mech_q: &[Vec<f64>],
    e: f64,
    dx: &(Vec<f64>, Vec<Vec<f64>>),
    dv: &(Vec<f64>, Vec<Vec<f64>>),
    di: &[f64],
) -> Vec<f64> {
    let bq = axpy(beam_q, e, &dx.0);
    let mq: Vec<Vec<f64>> = mech_q
        .iter()
        .zip(&dx.1)
        .map(|(q, d)| axpy(q, e, d))
        .collect();
    let bv: Vec<f64> = dv.0.iter().map(|v| e * v).collect();
    let mv: Vec<Vec<f64>> =
        dv.1.iter()
            .map(|d| d.iter().map(|v| e * v).collect())
            .collect();
    let cur: Vec<f64> = di.iter().map(|v| e * v).collect();
    let (a, qdd, _) = accelerations(model, 0.0, &bq, &bv, &mq, &mv, &cur);
    let mut out = a;
    for q in qdd {
        out.extend(q);
    }
    out
}

/// Largest relative difference between `-T M_R^-1 f` (the linearised accelerations for a
/// generalised force `f` in `z`) and the central difference of the KKT accelerations.
fn compare(lin: &Linearization, f: &DVector<f64>, fd: &[f64]) -> f64 {
    let m = lin.dense(Matrix::Mass);
    let y = m.lu().solve(&(-f)).unwrap();
    let (b, mech) = full_direction(lin, y.as_slice());
    let mut pred = b;
    for q in mech {
        pred.extend(q);
    }
    let scale = pred.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    pred.iter()
        .zip(fd)
        .fold(0.0f64, |m, (p, d)| m.max((p - d).abs()))
        / scale
}

/// The worst relative error of a linearisation's tangents: checks `K_R`, `C_R` (and `M_R`
/// through them) and the current coupling of a linearised
/// model against central differences of the independent dense KKT accelerations
/// ([`accelerations`]) along two random consistent directions `T dz` (seeded), and the
/// current coupling of every inductive generator. Returns the worst relative difference.
///
/// At the equilibrium the KKT accelerations vanish; along `x0 + e T dz` (rest) they are
/// `-T M_R^-1 K_R dz e + O(e^2)` (the derivative of `M x'' + F + Q + J^T lambda = 0`,
/// `J x'' = -a` at `x'' = 0`, `lambda = lambda0` is the linearised system with the
/// curvature `G(lambda0)`), at velocities `e T dz` they are `-T M_R^-1 C_R dz e + O(e^2)`,
/// and with currents `e` they are `-T M_R^-1 P^T b e`. Central differences cancel the
/// `O(e^2)` terms; `e` is chosen so the `O(e^2)` remainder and the KKT solve's rounding
/// (relative 1e-13 of the elastic forces, divided by `e`) both stay near 1e-9.
pub fn tangent_error(model: &HybridModel, lin: &Linearization, seed: u64) -> f64 {
    let mut rng = SplitMix64::new(seed);
    let rng = &mut rng;
    let model = super::linear::static_model(model);
    let eq = &lin.equilibrium;
    let d = lin.dim();
    let n = lin.structure_dofs();
    let mut worst = 0.0f64;
    let zero_dir = (
        vec![0.0; n],
        eq.mech_q.iter().map(|q| vec![0.0; q.len()]).collect(),
    );
    let nf = model.forces.len();
    for _ in 0..2 {
        // A random direction: beam DOFs of the static deflection's size, free coordinates
        // of order 0.1 rad.
        let beam_size = 1e-3;
        let dz: Vec<f64> = (0..d)
            .map(|i| {
                if i < n {
                    beam_size * rng.uniform(-1.0, 1.0)
                } else {
                    0.1 * rng.uniform(-1.0, 1.0)
                }
            })
            .collect();
        let dir = full_direction(lin, &dz);
        let e = 1e-4;
        let zero_i = vec![0.0; nf];
        // Stiffness.
        let p = kkt(&model, &eq.beam_q, &eq.mech_q, e, &dir, &zero_dir, &zero_i);
        let m = kkt(&model, &eq.beam_q, &eq.mech_q, -e, &dir, &zero_dir, &zero_i);
        let fd: Vec<f64> = p.iter().zip(&m).map(|(a, b)| (a - b) / (2.0 * e)).collect();
        let k = lin.dense(Matrix::Stiffness) * DVector::from_column_slice(&dz);
        worst = worst.max(compare(lin, &k, &fd));
        // Damping (velocity terms quadratic in e cancel).
        let ev = 1e-3;
        let p = kkt(&model, &eq.beam_q, &eq.mech_q, ev, &zero_dir, &dir, &zero_i);
        let m = kkt(
            &model, &eq.beam_q, &eq.mech_q, -ev, &zero_dir, &dir, &zero_i,
        );
        let fd: Vec<f64> = p
            .iter()
            .zip(&m)
            .map(|(a, b)| (a - b) / (2.0 * ev))
            .collect();
        let c = lin.dense(Matrix::Damping) * DVector::from_column_slice(&dz);
        if c.amax() > 0.0 {
            worst = worst.max(compare(lin, &c, &fd));
        }
    }
    // Currents of inductive generators.
    for el in &lin.electrical {
        let mut di = vec![0.0; nf];
        di[el.force] = 1.0;
        let p = kkt(
            &model, &eq.beam_q, &eq.mech_q, 1.0, &zero_dir, &zero_dir, &di,
        );
        let m = kkt(
            &model, &eq.beam_q, &eq.mech_q, -1.0, &zero_dir, &zero_dir, &di,
        );
        let fd: Vec<f64> = p.iter().zip(&m).map(|(a, b)| (a - b) / 2.0).collect();
        let mut f = vec![0.0; d];
        lin.add_from_small(el.torque.as_slice(), &mut f);
        worst = worst.max(compare(lin, &DVector::from_vec(f), &fd));
    }
    worst
}
