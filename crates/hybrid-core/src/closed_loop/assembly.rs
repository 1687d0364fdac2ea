//! Assembly: consistent initial positions `h(q) = 0` (eq. 14) and velocities `J q' = 0`
//! (eq. 15) from a partial specification.
//!
//! Positions: the user fixes some coordinates (the driver joints, or any others) and guesses
//! the rest; the free coordinates `z` are found by a damped Newton (Levenberg–Marquardt)
//! iteration on `h(q) = 0`,
//!
//! ```text
//! (J_z^T J_z + mu I) dz = -J_z^T h        or, when J_z has more columns than rows,
//! dz = -J_z^T (J_z J_z^T + mu I)^-1 h      (the same step, minimum norm)
//! ```
//!
//! with `mu` shrunk after every successful step (pure Gauss–Newton near the solution:
//! quadratic convergence) and grown after a failed one, and every step limited to
//! [`AssemblyOptions::max_step`] in each coordinate. The guess selects the assembly branch:
//! the iteration stays in the basin of the nearest solution. When the loop cannot close,
//! the iteration settles on the least-squares configuration with `h != 0`: that is
//! reported as [`AssemblyError::Infeasible`] with the residual of every constraint row.
//!
//! Velocities: the given velocities are held and the others solved from `J q' = 0` in the
//! least-squares, minimum-norm sense (SVD); given velocities that violate the constraints
//! are reported.

use nalgebra::{DMatrix, DVector};

use mbs_symbolic::runtime::{System, Workspace};

/// Tuning of the position assembly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AssemblyOptions {
    /// Converged when `max |h_i| <= tol` (model length units; default 1e-12).
    pub tol: f64,
    /// Maximum number of iterations (default 200).
    pub max_iterations: usize,
    /// Largest change of any coordinate in one step (default 0.5: radians or metres).
    pub max_step: f64,
}

impl Default for AssemblyOptions {
    fn default() -> Self {
        AssemblyOptions {
            tol: 1e-12,
            max_iterations: 200,
            max_step: 0.5,
        }
    }
}

/// A constraint row with its residual.
#[derive(Clone, Debug, PartialEq)]
pub struct RowResidual {
    /// Row name (`"pin.x"`).
    pub name: String,
    /// `h_i` at the final iterate.
    pub value: f64,
}

/// Result of [`assemble_positions`].
#[derive(Clone, Debug, PartialEq)]
pub struct Assembly {
    /// All coordinates, `h(q) = 0` to the tolerance.
    pub q: Vec<f64>,
    /// `max |h_i|` at `q`.
    pub residual: f64,
    /// Iterations used.
    pub iterations: usize,
}

/// Errors of the assembly.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum AssemblyError {
    /// The constraints cannot be satisfied with the given coordinates (a loop that cannot
    /// close): the closest configuration found leaves these residuals.
    #[error(
        "assembly failed: the constraints cannot be satisfied (max |h| = {residual:.3e} after {iterations} iterations; {})",
        format_rows(rows)
    )]
    Infeasible {
        /// `max |h_i|` at the closest configuration found.
        residual: f64,
        /// The rows left violated (`|h_i| > tol`), in row order.
        rows: Vec<RowResidual>,
        /// The closest configuration found.
        q: Vec<f64>,
        /// Iterations used.
        iterations: usize,
    },
    /// An evaluation produced NaN or an infinity.
    #[error("assembly failed: the constraints evaluate to a non-finite value at q = {q:?}")]
    NonFinite {
        /// The coordinates.
        q: Vec<f64>,
    },
    /// The given velocities violate `J q' = 0` whatever the others are.
    #[error(
        "the given velocities violate the velocity constraints J q' = 0 (max |J q'| = {residual:.3e}; {})",
        format_rows(rows)
    )]
    InconsistentVelocities {
        /// `max |(J q')_i|`.
        residual: f64,
        /// The violated rows.
        rows: Vec<RowResidual>,
    },
    /// An index or a slice length does not match the system.
    #[error("assembly input: {0}")]
    Input(String),
}

fn format_rows(rows: &[RowResidual]) -> String {
    if rows.is_empty() {
        return "no single row above tolerance".into();
    }
    let parts: Vec<String> = rows
        .iter()
        .map(|r| format!("{} = {:.3e}", r.name, r.value))
        .collect();
    format!("violated: {}", parts.join(", "))
}

fn max_abs(v: &DVector<f64>) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn violated(names: &[String], values: &DVector<f64>, tol: f64) -> Vec<RowResidual> {
    values
        .iter()
        .enumerate()
        .filter(|(_, v)| v.abs() > tol)
        .map(|(i, v)| RowResidual {
            name: names.get(i).cloned().unwrap_or_else(|| format!("row {i}")),
            value: *v,
        })
        .collect()
}

fn check_indices(n: usize, idx: &[usize], what: &str) -> Result<Vec<bool>, AssemblyError> {
    let mut mask = vec![false; n];
    for &i in idx {
        if i >= n {
            return Err(AssemblyError::Input(format!(
                "{what}: coordinate index {i} out of range (n = {n})"
            )));
        }
        mask[i] = true;
    }
    Ok(mask)
}

/// Solves `h(q) = 0` for the coordinates not in `fixed`, starting from `q0` (the values of
/// the fixed coordinates and the guess for the others). See the module documentation.
pub fn assemble_positions<S: System + ?Sized>(
    sys: &S,
    ws: &mut Workspace,
    q0: &[f64],
    fixed: &[usize],
    opts: &AssemblyOptions,
) -> Result<Assembly, AssemblyError> {
    let n = sys.dof();
    if q0.len() != n {
        return Err(AssemblyError::Input(format!(
            "{} initial coordinates given, the mechanism has {n}",
            q0.len()
        )));
    }
    if q0.iter().any(|x| !x.is_finite()) {
        return Err(AssemblyError::NonFinite { q: q0.to_vec() });
    }
    let is_fixed = check_indices(n, fixed, "fixed coordinates")?;
    let free: Vec<usize> = (0..n).filter(|&i| !is_fixed[i]).collect();
    let mut q = q0.to_vec();
    let rows = sys.rows();
    if rows == 0 {
        return Ok(Assembly {
            q,
            residual: 0.0,
            iterations: 0,
        });
    }
    sys.evaluate_positions(&q, ws);
    let mut h = ws.h.clone();
    let mut jz = DMatrix::from_fn(rows, free.len(), |r, c| ws.j[(r, free[c])]);
    if h.iter().chain(jz.iter()).any(|x| !x.is_finite()) {
        return Err(AssemblyError::NonFinite { q });
    }
    let mut cost = h.norm_squared();
    let mut mu_rel = 1e-6;
    let mut iterations = 0;
    let mut stalled = 0;
    while max_abs(&h) > opts.tol {
        if iterations >= opts.max_iterations || free.is_empty() || stalled >= 5 {
            return Err(AssemblyError::Infeasible {
                residual: max_abs(&h),
                rows: violated(sys.constraint_names(), &h, opts.tol),
                q,
                iterations,
            });
        }
        iterations += 1;
        let scale = jz
            .iter()
            .fold(0.0f64, |m, x| m.max(x * x))
            .max(f64::MIN_POSITIVE);
        // Try steps with growing damping until the residual decreases.
        let mut accepted = false;
        for _ in 0..40 {
            let mu = mu_rel * scale;
            let Some(mut dz) = lm_step(&jz, &h, mu) else {
                mu_rel *= 10.0;
                continue;
            };
            let big = dz.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            if big > opts.max_step {
                dz *= opts.max_step / big;
            }
            let mut trial = q.clone();
            for (k, &i) in free.iter().enumerate() {
                trial[i] += dz[k];
            }
            sys.evaluate_positions(&trial, ws);
            let trial_cost = ws.h.norm_squared();
            if trial_cost.is_finite() && trial_cost < cost {
                let tiny = big <= 1e-15 * (1.0 + q.iter().fold(0.0f64, |m, x| m.max(x.abs())));
                q = trial;
                h.copy_from(&ws.h);
                for r in 0..rows {
                    for (c, &i) in free.iter().enumerate() {
                        jz[(r, c)] = ws.j[(r, i)];
                    }
                }
                // Little relative progress with a finite residual: a least-squares minimum.
                stalled = if trial_cost > (1.0 - 1e-6) * cost || tiny {
                    stalled + 1
                } else {
                    0
                };
                cost = trial_cost;
                mu_rel = (mu_rel / 10.0).max(1e-16);
                accepted = true;
                break;
            }
            mu_rel *= 8.0;
            if mu_rel > 1e16 {
                break;
            }
        }
        if !accepted {
            stalled = usize::MAX;
        }
        if jz.iter().any(|x| !x.is_finite()) {
            return Err(AssemblyError::NonFinite { q });
        }
    }
    // Polish: a few undamped Gauss–Newton steps while they still pay off (quadratic
    // convergence takes a residual just below `tol` to rounding level).
    for _ in 0..3 {
        if cost == 0.0 || free.is_empty() {
            break;
        }
        let scale = jz
            .iter()
            .fold(0.0f64, |m, x| m.max(x * x))
            .max(f64::MIN_POSITIVE);
        let Some(dz) = lm_step(&jz, &h, 1e-14 * scale) else {
            break;
        };
        let mut trial = q.clone();
        for (k, &i) in free.iter().enumerate() {
            trial[i] += dz[k];
        }
        sys.evaluate_positions(&trial, ws);
        let trial_cost = ws.h.norm_squared();
        if trial_cost.is_nan() || trial_cost >= 0.25 * cost {
            break;
        }
        q = trial;
        h.copy_from(&ws.h);
        for r in 0..rows {
            for (c, &i) in free.iter().enumerate() {
                jz[(r, c)] = ws.j[(r, i)];
            }
        }
        cost = trial_cost;
    }
    Ok(Assembly {
        residual: max_abs(&h),
        q,
        iterations,
    })
}

/// One Levenberg–Marquardt step `dz` for `J dz ~ -h` with damping `mu`, through the smaller
/// of the two normal-equation forms. `None` when the system cannot be factored.
fn lm_step(j: &DMatrix<f64>, h: &DVector<f64>, mu: f64) -> Option<DVector<f64>> {
    let (m, nz) = j.shape();
    if nz == 0 {
        return None;
    }
    if nz <= m {
        let mut a = j.transpose() * j;
        for i in 0..nz {
            a[(i, i)] += mu;
        }
        let rhs = -(j.transpose() * h);
        a.cholesky().map(|c| c.solve(&rhs))
    } else {
        let mut a = j * j.transpose();
        for i in 0..m {
            a[(i, i)] += mu;
        }
        let y = a.cholesky()?.solve(&(-h));
        Some(j.transpose() * y)
    }
}

/// Velocities consistent with `J(q) q' = 0` (eq. 15): the entries of `qd0` at the indices
/// in `given` are held, the others solved in the least-squares, minimum-norm sense.
///
/// When fewer velocities are given than the mechanism has degrees of freedom, the remaining
/// freedom takes its minimum-norm value (zero when nothing is given). Given velocities that
/// violate the constraints (relative residual above `1e-9`) are an error naming the rows.
pub fn assemble_velocities<S: System + ?Sized>(
    sys: &S,
    ws: &mut Workspace,
    q: &[f64],
    qd0: &[f64],
    given: &[usize],
) -> Result<Vec<f64>, AssemblyError> {
    let n = sys.dof();
    if q.len() != n || qd0.len() != n {
        return Err(AssemblyError::Input(format!(
            "{} coordinates and {} velocities given, the mechanism has {n}",
            q.len(),
            qd0.len()
        )));
    }
    let is_given = check_indices(n, given, "given velocities")?;
    let mut qd = qd0.to_vec();
    let rows = sys.rows();
    if rows == 0 {
        return Ok(qd);
    }
    sys.evaluate_positions(q, ws);
    let free: Vec<usize> = (0..n).filter(|&i| !is_given[i]).collect();
    let mut rhs = DVector::zeros(rows);
    for r in 0..rows {
        let mut s = 0.0;
        for i in (0..n).filter(|&i| is_given[i]) {
            s += ws.j[(r, i)] * qd[i];
        }
        rhs[r] = -s;
    }
    if !free.is_empty() {
        let jf = DMatrix::from_fn(rows, free.len(), |r, c| ws.j[(r, free[c])]);
        let svd = super::partitioning::capped_svd(jf, true, true).ok_or_else(|| {
            AssemblyError::Input(
                "velocity solve: the constraint Jacobian is not finite or its SVD did not converge"
                    .to_string(),
            )
        })?;
        let smax = svd.singular_values.iter().fold(0.0f64, |m, s| m.max(*s));
        let x = svd
            .solve(&rhs, 1e-10 * smax.max(f64::MIN_POSITIVE))
            .map_err(|e| AssemblyError::Input(format!("velocity solve: {e}")))?;
        for (k, &i) in free.iter().enumerate() {
            qd[i] = x[k];
        }
    }
    let qdv = DVector::from_column_slice(&qd);
    let res = &ws.j * &qdv;
    let scale = ws.j.iter().fold(0.0f64, |m, x| m.max(x.abs())) * max_abs(&qdv);
    let tol = 1e-9 * scale.max(f64::MIN_POSITIVE);
    if !res.iter().all(|x| x.is_finite()) || max_abs(&res) > tol {
        return Err(AssemblyError::InconsistentVelocities {
            residual: max_abs(&res),
            rows: violated(sys.constraint_names(), &res, tol),
        });
    }
    Ok(qd)
}
