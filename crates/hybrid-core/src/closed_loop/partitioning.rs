//! Choosing and monitoring the independent coordinates of a run (eq. 18; docs/theory.md §3).
//!
//! At the start, the rank of `J` is examined ([`examine_rank`]): redundant constraint rows
//! are diagnosed by name with the combination of kept rows they equal (or dropped when the
//! settings allow it), and a rank drop that disappears at a nearby configuration is a
//! singular configuration. The automatic partition is the one of LU with full pivoting
//! ([`crate::partition::choose_partition`]); a user's choice replaces it unless it makes
//! `J_v` singular.
//!
//! After every accepted step the partition is checked: `cond(J_v)` of the current choice
//! (1-norm) is compared with the best choice; when it exceeds
//! [`PartitionSettings::switch_ratio`] times the best, or
//! [`PartitionSettings::max_condition`], the independent coordinates change (logged as a
//! [`PartitionChange`]). A stage whose projection or reduction fails triggers the same
//! check before the step is shrunk. When `J` itself loses rank (or the best `J_v` is worse
//! than [`PartitionSettings::singular_condition`]) no partition can help: the run stops
//! with [`SimError::Singular`], naming time, coordinates and the smallest singular value.
//!
//! [`PartitionSettings::switch_ratio`]: super::PartitionSettings::switch_ratio
//! [`PartitionSettings::max_condition`]: super::PartitionSettings::max_condition
//! [`PartitionSettings::singular_condition`]: super::PartitionSettings::singular_condition

use nalgebra::{DMatrix, DVector};

use crate::partition::{self, Partition, PartitionChoice, choose_partition};

use super::error::{
    PartitionChoiceError, RedundancyReport, RedundantRow, SimError, SingularReport,
};
use super::settings::Settings;
use super::simulator::Simulator;
use super::trajectory::{Event, PartitionChange};
use mbs_symbolic::runtime::{System, Workspace};

/// The SVD of `m` with an iteration cap, `None` for a non-finite matrix or when the cap is
/// reached: nalgebra's `svd` iterates without a cap (and never converges on a NaN). At most
/// `30 max(10, min(r, c))` implicit QR sweeps (LAPACK's per-value budget); the sweeps and
/// their deflation test (`5 eps`) are those of `svd`, so a converging matrix gives the same
/// decomposition.
pub(super) fn capped_svd(
    m: DMatrix<f64>,
    u: bool,
    v: bool,
) -> Option<nalgebra::SVD<f64, nalgebra::Dyn, nalgebra::Dyn>> {
    if m.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let cap = 30 * m.nrows().min(m.ncols()).max(10);
    nalgebra::SVD::try_new(m, u, v, 5.0 * f64::EPSILON, cap)
}

/// Smallest and largest singular values of `j` (0, 0 for an empty or non-finite matrix, or
/// one whose SVD does not converge within its cap).
pub(super) fn singular_range(j: &DMatrix<f64>) -> (f64, f64) {
    if j.nrows() == 0 || j.ncols() == 0 {
        return (0.0, 0.0);
    }
    let Some(svd) = capped_svd(j.clone(), false, false) else {
        return (0.0, 0.0);
    };
    let s = svd.singular_values;
    let lo = s.iter().fold(f64::INFINITY, |m, x| m.min(*x));
    let hi = s.iter().fold(0.0f64, |m, x| m.max(*x));
    (lo, hi)
}

/// The name of constraint row `r` (a placeholder if the system names fewer rows).
fn row_name(names: &[String], r: usize) -> String {
    names.get(r).cloned().unwrap_or_else(|| format!("row {r}"))
}

/// Names the redundant rows of `j` and the combinations of kept rows they equal.
fn redundancy_report(
    j: &DMatrix<f64>,
    choice: &PartitionChoice,
    names: &[String],
) -> RedundancyReport {
    let kept = choice.independent_rows(j.nrows());
    let jk = DMatrix::from_fn(kept.len(), j.ncols(), |r, c| j[(kept[r], c)]);
    let redundant = choice
        .redundant_rows
        .iter()
        .map(|&r| {
            // J_r^T = Jk^T c in the least-squares sense.
            let target = DVector::from_fn(j.ncols(), |c, _| j[(r, c)]);
            let scale = target.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let combination = if kept.is_empty() || scale == 0.0 {
                vec![]
            } else {
                match capped_svd(jk.transpose(), true, true)
                    .ok_or("no SVD")
                    .and_then(|svd| svd.solve(&target, 1e-12))
                {
                    Ok(c) => kept
                        .iter()
                        .zip(c.iter())
                        .filter(|(_, c)| c.abs() > 1e-8)
                        .map(|(&k, &c)| (row_name(names, k), c))
                        .collect(),
                    Err(_) => vec![],
                }
            };
            RedundantRow {
                name: row_name(names, r),
                combination,
            }
        })
        .collect();
    RedundancyReport {
        rank: choice.rank,
        rows: j.nrows(),
        redundant,
    }
}

/// The rank examination of `J` at the initial configuration.
pub(super) struct InitialRank {
    /// The system's workspace, with `h` and `J` evaluated at the initial configuration.
    pub ws: Workspace,
    /// The automatic partition (LU with full pivoting of `J`).
    pub choice: PartitionChoice,
    /// The constraint rows kept (all of them unless redundant rows were dropped).
    pub active: Vec<usize>,
    /// The names of the dropped redundant rows.
    pub dropped: Vec<String>,
}

/// Examines the rank of `J` at `q0`: a rank drop that disappears at a nearby configuration
/// is a singular configuration ([`SimError::Singular`]); one that persists is structural
/// redundancy, diagnosed by name ([`SimError::Redundant`]) or dropped when
/// `allow_redundant` is set.
pub(super) fn examine_rank<S: System + ?Sized>(
    sys: &S,
    settings: &Settings,
    q0: &[f64],
) -> Result<InitialRank, SimError> {
    let rows = sys.rows();
    let ps = &settings.partition;
    let mut ws = sys.workspace();
    sys.evaluate_positions(q0, &mut ws);
    let choice = choose_partition(&ws.j, ps.rank_tol);
    let mut active: Vec<usize> = (0..rows).collect();
    let mut dropped = vec![];
    if choice.rank < rows {
        // Structural redundancy persists at a nearby (not assembled) configuration; a
        // rank drop that disappears there is a singular configuration.
        let qp: Vec<f64> = q0
            .iter()
            .enumerate()
            .map(|(i, x)| x + 1e-3 * (1.0 + 0.37 * i as f64) * if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let mut wp = sys.workspace();
        sys.evaluate_positions(&qp, &mut wp);
        let near = choose_partition(&wp.j, ps.rank_tol);
        if near.rank > choice.rank {
            let (lo, hi) = singular_range(&ws.j);
            return Err(SimError::Singular(SingularReport {
                t: settings.t_start,
                coordinates: sys
                    .coordinate_names()
                    .iter()
                    .cloned()
                    .zip(q0.iter().copied())
                    .collect(),
                sigma_min: lo,
                sigma_max: hi,
                rank: choice.rank,
                expected_rank: near.rank,
                best_condition: f64::INFINITY,
            }));
        }
        if !ps.allow_redundant {
            let report = redundancy_report(&ws.j, &choice, sys.constraint_names());
            return Err(SimError::Redundant(report));
        }
        // Not printed (a library prints nothing): the caller reads the dropped rows from
        // `Simulator::dropped_rows`.
        active = choice.independent_rows(rows);
        dropped = choice
            .redundant_rows
            .iter()
            .map(|&r| row_name(sys.constraint_names(), r))
            .collect();
    }
    Ok(InitialRank {
        ws,
        choice,
        active,
        dropped,
    })
}

impl<S: System + ?Sized> Simulator<'_, S> {
    /// Replaces the automatic partition `auto` by the user's independent coordinates, when
    /// given: their number must be the number of degrees of freedom, and a choice that
    /// makes `J_v` singular at the start falls back to `auto` (or is an error when
    /// repartitioning is off).
    pub(super) fn apply_user_partition(&mut self, auto: Partition) -> Result<(), SimError> {
        let Some(ind) = self.settings.partition.independent.clone() else {
            return Ok(());
        };
        let n = self.sys.dof();
        let rank = self.expected_rank;
        let user =
            Partition::from_independent(n, &ind).map_err(|e| SimError::Partition(e.into()))?;
        if user.independent.len() != n - rank {
            return Err(SimError::Partition(PartitionChoiceError::Count {
                chosen: user.independent.len(),
                names: self.names_of(&user.independent).join(", "),
                dof: n - rank,
                n,
                rank,
            }));
        }
        self.partition = user;
        self.proj.load_active_jacobian(&self.ws);
        let cond = self.jv_condition(&self.partition.clone());
        self.cond = cond;
        if cond > self.settings.partition.singular_condition {
            if !self.settings.partition.repartition {
                return Err(SimError::Partition(PartitionChoiceError::Singular {
                    names: self.independent_names().join(", "),
                    cond,
                }));
            }
            self.switch_to(auto, &mut |_| {});
        }
        Ok(())
    }

    /// `cond(J_v)` of partition `p` from the active rows in `self.proj.j`.
    fn jv_condition(&self, p: &Partition) -> f64 {
        let r = self.proj.rows.len();
        let jv = DMatrix::from_fn(r, p.dependent.len(), |i, k| {
            self.proj.j[(i, p.dependent[k])]
        });
        if jv.nrows() != jv.ncols() {
            return f64::INFINITY;
        }
        partition::condition_number(&jv)
    }

    /// Changes to partition `p` at the accepted state and logs it.
    fn switch_to(&mut self, p: Partition, observer: &mut dyn FnMut(Event<'_>)) {
        let cond_after = self.jv_condition(&p);
        let change = PartitionChange {
            t: self.t,
            from: self.independent_names(),
            to: self.names_of(&p.independent),
            cond_before: self.cond,
            cond_after,
        };
        // The caller's observer is the log (the `damper` binary prints it on stderr).
        observer(Event::PartitionChanged(&change));
        self.changes.push(change);
        self.partition = p;
        self.cond = cond_after;
        self.b_acc = DMatrix::zeros(0, 0);
    }

    /// Examines the partition at the accepted state: stops on a rank drop, switches when
    /// the current `J_v` is much worse than the best. Returns whether it switched.
    pub(super) fn monitor(
        &mut self,
        observer: &mut dyn FnMut(Event<'_>),
    ) -> Result<bool, SimError> {
        self.sys.evaluate_positions(&self.q, &mut self.ws);
        self.proj.load_active_jacobian(&self.ws);
        let choice = choose_partition(&self.proj.j, self.settings.partition.rank_tol);
        let ps = &self.settings.partition;
        if choice.rank < self.expected_rank || choice.condition > ps.singular_condition {
            let (lo, hi) = singular_range(&self.proj.j);
            return Err(SimError::Singular(SingularReport {
                t: self.t,
                coordinates: self
                    .sys
                    .coordinate_names()
                    .iter()
                    .cloned()
                    .zip(self.q.iter().copied())
                    .collect(),
                sigma_min: lo,
                sigma_max: hi,
                rank: choice.rank,
                expected_rank: self.expected_rank,
                best_condition: if choice.rank < self.expected_rank {
                    f64::INFINITY
                } else {
                    choice.condition
                },
            }));
        }
        if !ps.repartition || choice.partition == self.partition {
            return Ok(false);
        }
        let degraded =
            self.cond > ps.switch_ratio * choice.condition || self.cond > ps.max_condition;
        if degraded {
            self.switch_to(choice.partition, observer);
            return Ok(true);
        }
        Ok(false)
    }
}
