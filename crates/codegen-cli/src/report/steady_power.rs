//! The mean powers of a forced run's periodic steady state, read online from the output
//! rows (issue #20, item 3): what a harvester delivers once the start-up transient has
//! gone, separately from the whole-run energy account (whose mean includes the transient).
//!
//! # Method
//!
//! The run's excitations are all harmonic with commensurate frequencies (each an integer
//! multiple of the lowest, `f_min`), so the forced state repeats with the period
//! `T = 1 / f_min`. The energy account's integrals `E_q(t)` (each generator's dissipation,
//! each excitation's work, the structure's dissipation) are read at the output rows; at
//! every period boundary `t_k = k T` they are interpolated linearly between the two rows
//! around it (the integrals are smooth: with `r` rows per period the relative error of a
//! period's energy is at most `(pi / r)^2 / 4`, below `1e-4` at the 100 rows per period
//! the tracker asks for, see [`MIN_ROWS_PER_PERIOD`]). The mean power of period `k` is
//! `P_q,k = (E_q(t_{k+1}) - E_q(t_k)) / T`.
//!
//! **Settled periods**: period `k` agrees with period `k - 1` when every quantity changed
//! by at most `tol` times the largest of them, `|P_q,k - P_q,k-1| <= tol max_q |P_q,k|`
//! (`tol` = [`TOLERANCE`]). The reported means are those of the trailing run of periods
//! that agree with their predecessors (the settled periods, at least
//! [`MIN_SETTLED_PERIODS`]); a run that ends before that reports its last whole period with
//! `settled = false`. A settled state stores nothing over a period, so the excitations'
//! mean input equals the structure's and the elements' mean dissipation (reported side by
//! side). Memory is constant: only the running sums of the trailing settled periods are
//! kept.

use fem_beam::TimeFunction;
use hybrid_core::hybrid::{HybridModel, HybridState};
use serde::Serialize;

/// Relative change per period below which a period counts as settled.
pub const TOLERANCE: f64 = 1e-3;
/// Trailing settled periods needed to report `settled = true`.
pub const MIN_SETTLED_PERIODS: usize = 3;
/// Output rows per period below which the interpolation of the energy integrals is not
/// trusted and no steady power is read.
pub const MIN_ROWS_PER_PERIOD: f64 = 100.0;

/// The period of a model's forcing: `1 / f_min` when every time-dependent excitation is
/// harmonic and every frequency is an integer multiple of the lowest (within `1e-9`),
/// `None` otherwise (no excitation that varies, a step, a table, incommensurate
/// frequencies).
pub fn forcing_period(model: &HybridModel) -> Option<f64> {
    let mut freqs = vec![];
    for e in &model.excitations {
        match e.time {
            TimeFunction::Constant => {}
            TimeFunction::Harmonic { frequency_hz, .. } if frequency_hz > 0.0 => {
                freqs.push(frequency_hz)
            }
            _ => return None,
        }
    }
    let f_min = freqs.iter().copied().reduce(f64::min)?;
    freqs
        .iter()
        .all(|f| {
            let ratio = f / f_min;
            (ratio - ratio.round()).abs() <= 1e-9 * ratio
        })
        .then_some(1.0 / f_min)
}

/// The steady-state mean powers in the summary.
#[derive(Clone, Debug, Serialize)]
pub struct SteadyPower {
    /// The forcing period `T` (s).
    pub period_s: f64,
    /// Whole periods run.
    pub periods: usize,
    /// Whether the last [`MIN_SETTLED_PERIODS`] or more periods agreed to `tolerance`.
    pub settled: bool,
    /// The trailing periods that agree with their predecessors (the means are over them;
    /// over the last period when the run did not settle).
    pub settled_periods: usize,
    /// Start of the averaging window (s).
    pub from_t: f64,
    /// Relative change per period of a settled period.
    pub tolerance: f64,
    /// Per generator: mean power dissipated in its circuit and in its load (W).
    pub generators: Vec<SteadyGeneratorPower>,
    /// Mean input power of each excitation (W), by name.
    pub excitations: Vec<(String, f64)>,
    /// Mean power dissipated by the structure's damping (W).
    pub structure: f64,
    /// Mean power dissipated by every force element (generators with their gears and
    /// conversion losses, dampers) (W).
    pub elements: f64,
}

/// One generator's steady-state mean powers.
#[derive(Clone, Debug, Serialize)]
pub struct SteadyGeneratorPower {
    /// The force element.
    pub name: String,
    /// Mean power dissipated in its circuit, `(R_a + R_L) i^2` (W).
    pub mean_power_dissipated: f64,
    /// Mean power lost in its gear (W).
    pub mean_power_gearbox: f64,
    /// Mean power into its load, `R_L i^2` (W).
    pub mean_power_load: f64,
}

/// The online reader of [`SteadyPower`] (see the module documentation).
pub struct SteadyPowerTracker {
    period: f64,
    /// Whether a row has been read.
    started: bool,
    /// Time and energy integrals of the last row.
    last_t: f64,
    last: Vec<f64>,
    /// The integrals of the row being read.
    now: Vec<f64>,
    /// The integrals at the last period boundary, once one has been passed.
    at_boundary: Option<Vec<f64>>,
    /// Index of the next period boundary `k T`.
    next: usize,
    /// The mean powers of the last whole period.
    previous: Vec<f64>,
    /// Sums of the mean powers over the trailing agreeing periods, and their number.
    sums: Vec<f64>,
    run: usize,
    periods: usize,
}

/// The quantities tracked, in order: each force element's dissipation, of it each
/// generator's gear loss, each generator's conversion loss (unequal constants), each
/// excitation's work, the structure's dissipation.
fn read(state: &HybridState, out: &mut Vec<f64>) {
    out.clear();
    out.extend_from_slice(&state.account.dissipated);
    out.extend_from_slice(&state.account.gearbox_loss);
    out.extend_from_slice(&state.account.conversion);
    out.extend_from_slice(&state.account.excitation_work);
    out.push(state.account.dissipated_structure);
}

impl SteadyPowerTracker {
    /// A tracker for `model` run from `t0` with rows every `row_dt` seconds, when its
    /// forcing is periodic ([`forcing_period`]) and the rows resolve the period.
    pub fn new(model: &HybridModel, t0: f64, row_dt: f64) -> Option<Self> {
        let period = forcing_period(model)?;
        if !(row_dt > 0.0 && period / row_dt >= MIN_ROWS_PER_PERIOD) {
            return None;
        }
        let n = 3 * model.forces.len() + model.excitations.len() + 1;
        Some(SteadyPowerTracker {
            period,
            started: false,
            last_t: t0,
            last: Vec::with_capacity(n),
            now: Vec::with_capacity(n),
            at_boundary: None,
            // The first boundary at or after the start.
            next: (t0 / period).ceil().max(0.0) as usize,
            previous: vec![],
            sums: vec![0.0; n],
            run: 0,
            periods: 0,
        })
    }

    /// Takes one output row.
    pub fn push(&mut self, state: &HybridState) {
        read(state, &mut self.now);
        let t = state.t;
        if !self.started {
            self.started = true;
            let tb = self.next as f64 * self.period;
            if (t - tb).abs() <= 1e-12 * t.abs().max(1.0) {
                // A row on the first boundary (the usual start at t = 0).
                self.at_boundary = Some(self.now.clone());
                self.next += 1;
            }
        } else {
            // Every boundary between the last row and this one: at most one, the rows being
            // closer than a period (MIN_ROWS_PER_PERIOD).
            while self.next as f64 * self.period <= t {
                let tb = self.next as f64 * self.period;
                let s = if t > self.last_t {
                    ((tb - self.last_t) / (t - self.last_t)).clamp(0.0, 1.0)
                } else {
                    1.0
                };
                let e: Vec<f64> = self
                    .last
                    .iter()
                    .zip(&self.now)
                    .map(|(a, b)| a + s * (b - a))
                    .collect();
                if let Some(before) = &self.at_boundary {
                    let p = e
                        .iter()
                        .zip(before)
                        .map(|(a, b)| (a - b) / self.period)
                        .collect();
                    self.period_done(p);
                }
                self.at_boundary = Some(e);
                self.next += 1;
            }
        }
        std::mem::swap(&mut self.last, &mut self.now);
        self.last_t = t;
    }

    /// One whole period's mean powers.
    fn period_done(&mut self, p: Vec<f64>) {
        self.periods += 1;
        let scale = p.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let agrees = !self.previous.is_empty()
            && p.iter()
                .zip(&self.previous)
                .all(|(a, b)| (a - b).abs() <= TOLERANCE * scale);
        if agrees {
            self.sums.iter_mut().zip(&p).for_each(|(s, v)| *s += v);
            self.run += 1;
        } else {
            self.sums.clone_from(&p);
            self.run = 1;
        }
        self.previous = p;
    }

    /// The report, `None` before the first whole period.
    pub fn finish(&self, model: &HybridModel) -> Option<SteadyPower> {
        if self.periods == 0 {
            return None;
        }
        let settled = self.run > MIN_SETTLED_PERIODS;
        // Over the trailing agreeing periods when settled (the first of the run is the one
        // the others agreed with, so it belongs to the steady state too), else the last.
        let (means, count): (Vec<f64>, usize) = if settled {
            (
                self.sums.iter().map(|s| s / self.run as f64).collect(),
                self.run,
            )
        } else {
            (self.previous.clone(), 1)
        };
        let nf = model.forces.len();
        let ne = model.excitations.len();
        let generators = model
            .forces
            .iter()
            .enumerate()
            .filter_map(|(k, f)| {
                let g = f.generator()?;
                let (d, gear) = (means[k] - means[nf + k], means[nf + k]);
                Some(SteadyGeneratorPower {
                    name: f.name.clone(),
                    mean_power_dissipated: d,
                    mean_power_gearbox: gear,
                    mean_power_load: g.load_part(d),
                })
            })
            .collect();
        let end = self.next.saturating_sub(1) as f64 * self.period;
        Some(SteadyPower {
            period_s: self.period,
            periods: self.periods,
            settled,
            settled_periods: if settled { count } else { 0 },
            from_t: end - count as f64 * self.period,
            tolerance: TOLERANCE,
            generators,
            excitations: model
                .excitations
                .iter()
                .zip(&means[3 * nf..3 * nf + ne])
                .map(|(e, p)| (e.name.clone(), *p))
                .collect(),
            structure: means[3 * nf + ne],
            // Every element's dissipation (gear losses included) and the conversion losses.
            elements: means[..nf].iter().sum::<f64>() + means[2 * nf..3 * nf].iter().sum::<f64>(),
        })
    }
}
