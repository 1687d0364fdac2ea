//! The stationary figures of a run under random excitation (issue #20): the seed of every
//! realisation, and over the stationary part of the run the RMS of the outputs `damper
//! random` reports (every attachment's beam displacement and velocity, every mechanism
//! coordinate and rate, every generator's current and rotor speed) and each generator's mean
//! dissipated and load power, each with its standard error.
//!
//! **Stationary part**: the run from [`stationary_start`] on: after [`TRANSIENT_FRACTION`] of
//! `t_end` and after [`DECAY_TIMES`] time constants `1 / sigma` of the slowest-decaying mode
//! of the linearised system (`sigma` its decay rate `-Re lambda`; the start's transient has
//! decayed to `e^-5` = 0.7 % of its amplitude there), but at most half the run: where the
//! transient needs more, the report carries a warning naming the `t_end` that would do
//! (`random_damper.toml` skips 6.5 s, 10 time constants of its first mode).
//!
//! **Standard error by batch means**: the stationary part is cut into [`BATCHES`] batches of
//! equal duration; per batch the variance of each output about the batch's own mean (the
//! coordinates' equilibrium is not zero) and the mean square of each current; the figure is
//! the mean over the batches and its standard error is the batches' standard deviation over
//! `sqrt(BATCHES)` (batches much longer than the correlation time are nearly independent).
//! The RMS's error is the variance's over `2 RMS`. Memory is flat: sums per batch and output.

use serde::Serialize;

/// Share of the run skipped as the transient, at least.
pub const TRANSIENT_FRACTION: f64 = 0.1;
/// Time constants of the slowest mode skipped as the transient.
pub const DECAY_TIMES: f64 = 5.0;
/// Largest share of the run skipped as the transient.
pub const MAX_TRANSIENT_FRACTION: f64 = 0.5;

/// Start of the stationary part of a run to `t_end` (module documentation) for the slowest
/// decay rate `slowest` (1/s) of the linearised modes (`None`: unknown, the fixed share), and
/// a warning where the transient needs more than half the run.
pub fn stationary_start(t_end: f64, slowest: Option<f64>) -> (f64, Option<String>) {
    let fixed = TRANSIENT_FRACTION * t_end;
    let Some(rate) = slowest.filter(|r| *r > 0.0 && r.is_finite()) else {
        return (fixed, None);
    };
    let settle = DECAY_TIMES / rate;
    let cap = MAX_TRANSIENT_FRACTION * t_end;
    if settle <= cap {
        return (fixed.max(settle), None);
    }
    let warning = format!(
        "the slowest mode decays at {rate:.4} 1/s: its transient needs {settle:.3} s ({DECAY_TIMES} time constants), more than half the run; the statistics from {cap:.3} s on include part of it (t_end = {:.3} s or more would leave half the run stationary)",
        settle / MAX_TRANSIENT_FRACTION
    );
    (cap, Some(warning))
}
/// Batches of the batch-means standard error.
pub const BATCHES: usize = 20;

/// A realisation's seed and level.
#[derive(Clone, Debug, Serialize)]
pub struct RealisationReport {
    /// The excitation.
    pub excitation: String,
    /// The seed drawn from.
    pub seed: u64,
    /// Period of the realisation (s), at least the run.
    pub period: f64,
    /// Mean square of the realisation over its period.
    pub mean_square: f64,
    /// `∫ G df` of the written PSD.
    pub psd_mean_square: f64,
}

/// A statistic of the stationary part and its standard error: the one JSON shape
/// `{value, standard_error}` of every output's RMS and every generator's figure.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Estimate {
    /// The statistic.
    pub value: f64,
    /// Its standard error (batch means).
    pub standard_error: f64,
}

impl From<[f64; 2]> for Estimate {
    fn from([value, standard_error]: [f64; 2]) -> Estimate {
        Estimate {
            value,
            standard_error,
        }
    }
}

impl std::fmt::Display for Estimate {
    /// `value ± standard_error` (4 significant digits).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:.4e} ± {:.1e}", self.value, self.standard_error)
    }
}

/// One output's RMS with its standard error.
#[derive(Clone, Debug, Serialize)]
pub struct RmsEstimate {
    /// As `damper random` names it.
    pub name: String,
    /// SI unit.
    pub unit: String,
    /// RMS about its mean over the stationary part, and its standard error.
    pub rms: Estimate,
}

/// One generator's figures over the stationary part.
#[derive(Clone, Debug, Serialize)]
pub struct GeneratorEstimate {
    /// The force element.
    pub name: String,
    /// RMS current (A) and its standard error.
    pub rms_current: Estimate,
    /// Mean power dissipated in `R_a + R_L` (W) and its standard error.
    pub mean_power_dissipated: Estimate,
    /// Mean power in the load (W) and its standard error.
    pub mean_power_load: Estimate,
}

impl RandomRunReport {
    /// The lines `simulate` prints: every output's RMS and every generator's RMS current and
    /// mean powers, each with its standard error.
    pub fn lines(&self) -> String {
        let mut out = format!(
            "  random response over [{:.3} s, end] ({} samples, {} batches):\n",
            self.from, self.samples, self.batches
        );
        for o in &self.outputs {
            out.push_str(&format!("    RMS {} = {} {}\n", o.name, o.rms, o.unit));
        }
        for g in &self.generators {
            out.push_str(&format!(
                "    {}: RMS current {} A, mean power dissipated {} W, in the load {} W\n",
                g.name, g.rms_current, g.mean_power_dissipated, g.mean_power_load
            ));
        }
        out
    }
}

/// The `random` block of a run's summary.
#[derive(Clone, Debug, Serialize)]
pub struct RandomRunReport {
    /// Every random excitation's realisation.
    pub realisations: Vec<RealisationReport>,
    /// Start of the stationary part (s), [`stationary_start`].
    pub from: f64,
    /// The slowest decay rate of the linearised modes (1/s), where the linearisation gives it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slowest_decay_rate: Option<f64>,
    /// Why the statistics may include part of the transient.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
    /// Batches of the standard errors.
    pub batches: usize,
    /// Samples (output rows) in the stationary part.
    pub samples: u64,
    /// How the response spectra of `random_psd.csv` were estimated (every step of the
    /// stationary part; absent when it is too short for 16 averages).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub psd: Option<super::random_psd::PsdReport>,
    /// The outputs.
    pub outputs: Vec<RmsEstimate>,
    /// The generators (and their rotor speeds among the outputs).
    pub generators: Vec<GeneratorEstimate>,
    /// Every output's RMS against time over the whole run (for `random_rms.svg`; not in the
    /// summary).
    #[serde(skip)]
    pub history: Vec<RmsHistory>,
}

/// Windows of the whole run over which the RMS against time is drawn
/// (`random_rms.svg`): each 1/100 of the run.
pub const HISTORY_WINDOWS: usize = 100;

/// Streaming sums per batch of `n` signals, and per window of the whole run (transient
/// included) for the RMS against time.
#[derive(Clone, Debug)]
pub struct BatchStats {
    from: f64,
    width: f64,
    /// Per batch: count, then per signal (sum, sum of squares).
    count: Vec<u64>,
    sums: Vec<Vec<[f64; 2]>>,
    /// Width of a history window (s).
    window: f64,
    /// Per history window: count, then per signal (sum, sum of squares).
    window_count: Vec<u64>,
    window_sums: Vec<Vec<[f64; 2]>>,
}

/// An output's RMS against time: over each window of the run, its RMS (about the window's
/// mean where the output's statistic is centred), at the window's middle.
#[derive(Clone, Debug)]
pub struct RmsHistory {
    /// The output, as `damper random` names it.
    pub name: String,
    /// SI unit.
    pub unit: String,
    /// `(t, RMS)` per window with samples.
    pub points: Vec<(f64, f64)>,
}

impl BatchStats {
    /// Sums of `n` signals over `[from, t_end]` (and over the windows of `[0, t_end]`).
    pub fn new(n: usize, from: f64, t_end: f64) -> Self {
        BatchStats {
            from,
            width: (t_end - from) / BATCHES as f64,
            count: vec![0; BATCHES],
            sums: vec![vec![[0.0; 2]; n]; BATCHES],
            window: t_end / HISTORY_WINDOWS as f64,
            window_count: vec![0; HISTORY_WINDOWS],
            window_sums: vec![vec![[0.0; 2]; n]; HISTORY_WINDOWS],
        }
    }

    /// Signal `k`'s RMS (about each window's mean when `centred`) per window of the run:
    /// `(middle of the window, RMS)`, windows without samples left out.
    pub fn history(&self, k: usize, centred: bool) -> Vec<(f64, f64)> {
        self.window_count
            .iter()
            .zip(&self.window_sums)
            .enumerate()
            .filter(|(_, (c, _))| **c > 0)
            .map(|(w, (&c, s))| {
                let (m, ms) = (s[k][0] / c as f64, s[k][1] / c as f64);
                let second = if centred { (ms - m * m).max(0.0) } else { ms };
                ((w as f64 + 0.5) * self.window, second.sqrt())
            })
            .collect()
    }

    /// Start of the stationary part.
    pub fn from(&self) -> f64 {
        self.from
    }

    /// Adds the sample `x` (one value per signal) at `t` (ignored in the transient).
    pub fn push(&mut self, t: f64, x: impl Iterator<Item = f64>) {
        let window = (self.window > 0.0 && t >= 0.0)
            .then(|| ((t / self.window) as usize).min(HISTORY_WINDOWS - 1));
        let batch = (t >= self.from && self.width > 0.0)
            .then(|| (((t - self.from) / self.width) as usize).min(BATCHES - 1));
        if let Some(w) = window {
            self.window_count[w] += 1;
        }
        if let Some(b) = batch {
            self.count[b] += 1;
        }
        for (k, v) in x.enumerate() {
            if let Some(w) = window {
                let s = &mut self.window_sums[w][k];
                s[0] += v;
                s[1] += v * v;
            }
            if let Some(b) = batch {
                let s = &mut self.sums[b][k];
                s[0] += v;
                s[1] += v * v;
            }
        }
    }

    /// Samples in the stationary part.
    pub fn samples(&self) -> u64 {
        self.count.iter().sum()
    }

    /// Signal `k`'s variance about the batch means (`centred`) or mean square, and its
    /// standard error (module documentation); `[0, 0]` without samples.
    pub fn second_moment(&self, k: usize, centred: bool) -> [f64; 2] {
        let per: Vec<f64> = self
            .count
            .iter()
            .zip(&self.sums)
            .filter(|(c, _)| **c > 0)
            .map(|(&c, s)| {
                let (m, ms) = (s[k][0] / c as f64, s[k][1] / c as f64);
                if centred { (ms - m * m).max(0.0) } else { ms }
            })
            .collect();
        let nb = per.len() as f64;
        if nb == 0.0 {
            return [0.0, 0.0];
        }
        let mean = per.iter().sum::<f64>() / nb;
        let var = if nb > 1.0 {
            per.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (nb - 1.0)
        } else {
            0.0
        };
        [mean, (var / nb).sqrt()]
    }

    /// Signal `k`'s RMS (centred or not) and its standard error.
    pub fn rms(&self, k: usize, centred: bool) -> [f64; 2] {
        let [v, se] = self.second_moment(k, centred);
        let r = v.sqrt();
        [r, if r > 0.0 { se / (2.0 * r) } else { 0.0 }]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batch_means_of_a_known_signal() {
        // x = 3 + 2 sin(2 pi 50 t) sampled finely: centred RMS sqrt(2), mean square 9 + 2.
        let mut s = BatchStats::new(1, 10.0, 100.0);
        let dt = 1e-3;
        for i in 0..=100_000 {
            let t = i as f64 * dt;
            s.push(
                t,
                [3.0 + 2.0 * (2.0 * std::f64::consts::PI * 50.0 * t).sin()].into_iter(),
            );
        }
        assert_eq!(s.samples(), 90_001);
        // The RMS against time: every window of the run (transient included) holds 50
        // periods of the sine: its centred RMS sqrt(2), its mean square's root sqrt(11).
        let h = s.history(0, true);
        assert_eq!(h.len(), HISTORY_WINDOWS);
        assert!((h[0].0 - 0.5).abs() < 1e-12 && (h[99].0 - 99.5).abs() < 1e-12);
        assert!(
            h.iter().all(|(_, r)| (r - 2f64.sqrt()).abs() < 1e-3),
            "{h:?}"
        );
        let raw = s.history(0, false);
        assert!(raw.iter().all(|(_, r)| (r - 11f64.sqrt()).abs() < 1e-3));
        // Each batch holds 225 periods and one sample more (its start): the moments are
        // exact to about 1 / 4500 of the sine's swing per batch.
        let [r, se] = s.rms(0, true);
        assert!((r - 2f64.sqrt()).abs() < 2e-5, "{r}");
        assert!(se < 2e-5, "{se}");
        let [ms, _] = s.second_moment(0, false);
        assert!((ms - 11.0).abs() < 2e-4, "{ms}");
    }
}
