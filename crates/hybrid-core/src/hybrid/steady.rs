//! The nonlinear steady state under harmonic excitation, from time-domain runs (issue #11,
//! item 4): the measured counterpart of the linear receptance
//! [`super::Linearization::harmonic_response`].
//!
//! # Method
//!
//! Excitation `k` of the model is `F sin(omega t + phi_e)` (its time function is made
//! [`TimeFunction::Harmonic`] at each frequency asked for, keeping its phase). The engine
//! ([`Integrator`], the model's scheme) runs from a rest state (the static equilibrium:
//! [`rest_state`]) with exactly `N` steps per period `T = 2 pi / omega`. Over each period `k`
//! the output's samples `y_j` at `omega t_j = 2 pi (k + j / N)`, `j = 0 .. N-1`, are fitted by
//! least squares with `a + b cos(omega t) + c sin(omega t)`; the samples being equally spaced
//! over a whole period, the normal equations are diagonal and the fit is the discrete
//! Fourier coefficient (exact for a sinusoid, `N >= 3`):
//!
//! ```text
//! a = (1/N) sum y_j,   b = (2/N) sum y_j cos(2 pi j / N),   c = (2/N) sum y_j sin(2 pi j / N)
//! y - a = A sin(omega t + psi),   A = hypot(b, c),   psi = atan2(b, c)
//! ```
//!
//! **Phase convention**: the response is `A sin(omega t + phi_e + phi)`, so `phi = psi - phi_e`
//! (plus `pi` for a negative amplitude `F`), wrapped to `(-pi, pi]`; for a linear system
//! `A = |H| |F|` and `phi = arg H` with `H` the receptance of
//! [`super::Linearization::harmonic_response`] (response `z e^{i omega t}` to the force
//! `e^{i omega t}`).
//!
//! **Distortion**: the RMS of the fit's residual over the period relative to `A` — zero for a
//! linear system, growing with the harmonics the mechanism's nonlinearity generates.
//!
//! **Settling**: with the phasor `C_k = c + i b` of period `k` (`|C_k| = A_k`,
//! `arg C_k = psi_k`) and its change `d_k = |C_k - C_{k-1}| / |C_k|` (which bounds the
//! relative change of the amplitude and, to first order, the change of the phase in
//! radians), a run has settled after period `k >= min_periods` when
//!
//! ```text
//! d_k <= tol,   D <= tol,   D r / (1 - r) <= tol,
//! D = max_{j in last W} |dC_j| / |C_k|,   r = (D / D_previous W)^(1/W) < 1     (W = 8)
//! ```
//!
//! the last condition being the geometric tail of the decaying transient (what is still to
//! come if it keeps decaying at the observed rate, `r` the decay per period of the envelope
//! of the changes — the envelope, because with several transient components the changes
//! beat): near a lightly damped resonance the
//! per-period change is `2 pi zeta` times the remaining transient, and the change alone
//! would stop far too early. A change below `tol / 1000` settles without the ratio test
//! (the transient has reached the integrator's own precision, where the ratios are noise).
//! A run that does not settle within `max_periods` (or is asked to stop,
//! [`SteadyOptions::stop`]) reports `settled = false` with the last period's values — never
//! a NaN.
//!
//! **Power**: over the last period (the `N` steps ending at its last sample, exactly one
//! period `T`) the energy account's increments divided by `T`: the mean power dissipated in
//! each force element (a generator's `(R_a + R_L) i^2`, its load's share `R_L / (R_a + R_L)`
//! of it) and the mean input power of each excitation. In a settled periodic state the
//! input balances the dissipation (the structure's and the elements'), up to the remaining
//! transient.
//!
//! **Discrete steady state**: the average-acceleration rule (Newmark, `beta = 1/4`,
//! `gamma = 1/2`) is the trapezoidal rule, i.e. the bilinear transform: on a linear system
//! its steady response to a sampled sinusoid of frequency `omega` is exactly the continuous
//! one at the warped frequency `(2/h) tan(omega h / 2)` ([`warped_frequency`]), a relative
//! shift of `(omega h)^2 / 12` (`8e-5` at 200 steps per period).
//!
//! The frequencies run in parallel (rayon); each run is independent and deterministic, so
//! the results (in the order of the frequencies) do not depend on the number of threads.

use std::f64::consts::PI;

use fem_beam::TimeFunction;
use rayon::prelude::*;
use serde::Serialize;

use super::error::HybridError;
use super::initial_state;
use super::integrator::{HybridState, Integrator};
use super::linear::Equilibrium;
use super::method::Method;
use super::model::{ExcitationTarget, HybridModel};

/// Settings of the steady-state runs.
#[derive(Clone, Copy, Debug)]
pub struct SteadyOptions {
    /// Index of the harmonic excitation in [`HybridModel::excitations`].
    pub excitation: usize,
    /// Integration scheme.
    pub method: Method,
    /// Time steps per period of the excitation (`h = T / N`; at least 8).
    pub steps_per_period: usize,
    /// Settle tolerance: relative change of the fundamental's phasor per period (and its
    /// geometric tail), see the module documentation.
    pub tolerance: f64,
    /// Periods run before the settle test may succeed (at least 3).
    pub min_periods: usize,
    /// Periods run at most.
    pub max_periods: usize,
    /// Polled before every period: when it returns `true` the run ends there with the
    /// values of the last period run (`settled = false`), as at `max_periods` (a caller
    /// that asks the runs to stop, such as an interrupted Python call, discards them).
    pub stop: Option<fn() -> bool>,
}

impl Default for SteadyOptions {
    fn default() -> Self {
        SteadyOptions {
            excitation: 0,
            method: Method::Newmark,
            steps_per_period: 200,
            tolerance: 1e-3,
            min_periods: 10,
            max_periods: 1000,
            stop: None,
        }
    }
}

/// The steady state at one frequency.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SteadyState {
    /// Excitation frequency (Hz).
    pub frequency_hz: f64,
    /// Amplitude `A` of the output's fundamental (m, rad).
    pub amplitude: f64,
    /// Phase `phi` of the response relative to the excitation (rad, `(-pi, pi]`): the
    /// response is `A sin(omega t + phi_e + phi)`.
    pub phase: f64,
    /// Mean `a` of the output over the last period (m, rad).
    pub mean: f64,
    /// RMS of the fit's residual relative to `A` (0 for a linear system; 0 when `A = 0`).
    pub distortion: f64,
    /// Periods run.
    pub periods: usize,
    /// Whether the settle criterion was met.
    pub settled: bool,
    /// Last relative change of the phasor, `d_k`.
    pub change: f64,
    /// Time step used (s).
    pub dt: f64,
    /// Mean power dissipated in each force element over the last period (W), in the order
    /// of [`HybridModel::forces`] (a generator: `(R_a + R_L) i^2` and its gear's loss).
    pub mean_power_dissipated: Vec<f64>,
    /// Of it, the mean power lost in each generator's gear (W; 0 for other elements).
    pub mean_power_gearbox: Vec<f64>,
    /// Mean input power of each excitation over the last period (W), in the order of
    /// [`HybridModel::excitations`].
    pub mean_input_power: Vec<f64>,
    /// Mean power dissipated by the structure's damping over the last period (W).
    pub mean_power_structure: f64,
}

/// A steady-state run that stopped (singular position, no convergence).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("f = {frequency_hz} Hz, period {period}: {error}")]
pub struct SteadyError {
    /// Excitation frequency (Hz).
    pub frequency_hz: f64,
    /// The period in which it stopped (0-based).
    pub period: usize,
    /// Why.
    pub error: HybridError,
}

/// The average-acceleration rule's equivalent continuous frequency of a sampled sinusoid of
/// angular frequency `omega` at step `h`: `(2/h) tan(omega h / 2)` (the bilinear transform;
/// see the module documentation).
pub fn warped_frequency(omega: f64, h: f64) -> f64 {
    2.0 / h * (omega * h / 2.0).tan()
}

/// The state at rest in the static equilibrium `eq` (from
/// [`super::Linearization::new`]): beam at `eq.beam_q`, every mechanism assembled from
/// `eq.mech_q`, velocities and currents zero. `model` is changed to start from there (its
/// mechanisms' initial coordinates).
pub fn rest_state(model: &mut HybridModel, eq: &Equilibrium) -> Result<HybridState, HybridError> {
    for (m, q) in model.mechanisms.iter_mut().zip(&eq.mech_q) {
        m.initial_q.clone_from(q);
    }
    let n = model.structure_dofs();
    initial_state(model, eq.beam_q.clone(), vec![0.0; n])
}

/// The output's value in a state: a beam point's transverse displacement, or a mechanism
/// coordinate (the supports, relative to which every state is written, give 0).
pub fn output_value(output: &ExcitationTarget, state: &HybridState) -> f64 {
    match output {
        ExcitationTarget::Beam(p) => p.value(&state.q),
        ExcitationTarget::Joint { mechanism, joint } => state.mechanisms[*mechanism].q[*joint],
        ExcitationTarget::Base { .. } => 0.0,
    }
}

/// Periods per window of the settle test's decay-rate estimate.
const WINDOW: usize = 8;

/// `cos` and `sin` of `2 pi j / n` for the `n` samples `j` of one period.
fn harmonic_basis(n: usize) -> (Vec<f64>, Vec<f64>) {
    (0..n)
        .map(|j| (2.0 * PI * j as f64 / n as f64).sin_cos())
        .map(|(s, c)| (c, s))
        .unzip()
}

/// The fit of one period: `(a, C = c + i b, RMS residual)`.
fn fit(y: &[f64], cos: &[f64], sin: &[f64]) -> (f64, [f64; 2], f64) {
    let n = y.len() as f64;
    let a = y.iter().sum::<f64>() / n;
    let b = 2.0 / n * y.iter().zip(cos).map(|(y, c)| y * c).sum::<f64>();
    let c = 2.0 / n * y.iter().zip(sin).map(|(y, s)| y * s).sum::<f64>();
    let rss: f64 = y
        .iter()
        .zip(cos.iter().zip(sin))
        .map(|(y, (co, si))| (y - a - b * co - c * si).powi(2))
        .sum();
    (a, [c, b], (rss / n).sqrt())
}

/// Wraps an angle to `(-pi, pi]`.
fn wrap(x: f64) -> f64 {
    let y = (x + PI).rem_euclid(2.0 * PI) - PI;
    if y <= -PI { y + 2.0 * PI } else { y }
}

/// The steady state at `frequency_hz` from `start` (see the module documentation).
///
/// # Panics
///
/// When `options.excitation` is not an excitation of `model`, or `frequency_hz` is not
/// positive and finite.
pub fn steady_state(
    model: &HybridModel,
    start: &HybridState,
    output: &ExcitationTarget,
    frequency_hz: f64,
    options: &SteadyOptions,
) -> Result<SteadyState, SteadyError> {
    assert!(
        frequency_hz > 0.0 && frequency_hz.is_finite(),
        "frequency {frequency_hz} Hz"
    );
    let mut model = model.clone();
    let exc = &mut model.excitations[options.excitation];
    let phase_e = match exc.time {
        TimeFunction::Harmonic { phase, .. } => phase,
        _ => 0.0,
    } + if exc.amplitude < 0.0 { PI } else { 0.0 };
    exc.time = TimeFunction::Harmonic {
        frequency_hz,
        phase: match exc.time {
            TimeFunction::Harmonic { phase, .. } => phase,
            _ => 0.0,
        },
    };
    let n = options.steps_per_period.max(8);
    let period = 1.0 / frequency_hz;
    let h = period / n as f64;
    let (cos, sin) = harmonic_basis(n);
    let stop = |k: usize, error: HybridError| SteadyError {
        frequency_hz,
        period: k,
        error,
    };
    let mut state = start.clone();
    state.t = 0.0;
    let mut integrator =
        Integrator::new(&model, options.method, h, &state).map_err(|e| stop(0, e))?;
    let mut y = vec![0.0; n];
    let mut previous: Option<[f64; 2]> = None;
    let mut changes: Vec<f64> = Vec::new(); // |dC_k|
    let min_periods = options.min_periods.max(3);
    let max_periods = options.max_periods.max(min_periods);
    let tol = options.tolerance;
    let mut last = None;
    // The account at the last sample of the previous period (one period before this
    // period's last sample).
    let mut account_before = state.account.clone();
    let mut t_before = state.t;
    for k in 0..max_periods {
        if k > 0 && options.stop.is_some_and(|stop| stop()) {
            break;
        }
        for (j, yj) in y.iter_mut().enumerate() {
            if k > 0 || j > 0 {
                integrator
                    .step(&model, &mut state)
                    .map_err(|e| stop(k, e))?;
                // Steps counted from the start, so the sample times are exact multiples of
                // h (no drift of the excitation's phase against the fit's tables).
                state.t = (k * n + j) as f64 * h;
            }
            *yj = output_value(output, &state);
        }
        let (a, ph, rms) = fit(&y, &cos, &sin);
        let amp = ph[0].hypot(ph[1]);
        // Mean powers over the window ending at this period's last sample: a whole period
        // from the second period on (the first one's window is N - 1 steps).
        let span = state.t - t_before;
        let mean = |now: &[f64], before: &[f64]| -> Vec<f64> {
            now.iter()
                .zip(before)
                .map(|(n, b)| if span > 0.0 { (n - b) / span } else { 0.0 })
                .collect()
        };
        let mean_power_dissipated = mean(&state.account.dissipated, &account_before.dissipated);
        let mean_power_gearbox = mean(&state.account.gearbox_loss, &account_before.gearbox_loss);
        let mean_input_power = mean(
            &state.account.excitation_work,
            &account_before.excitation_work,
        );
        let mean_power_structure = if span > 0.0 {
            (state.account.dissipated_structure - account_before.dissipated_structure) / span
        } else {
            0.0
        };
        account_before.clone_from(&state.account);
        t_before = state.t;
        let mut result = SteadyState {
            frequency_hz,
            amplitude: amp,
            phase: wrap(ph[1].atan2(ph[0]) - phase_e),
            mean: a,
            distortion: if amp > 0.0 { rms / amp } else { 0.0 },
            periods: k + 1,
            settled: false,
            change: f64::MAX,
            dt: h,
            mean_power_dissipated,
            mean_power_gearbox,
            mean_input_power,
            mean_power_structure,
        };
        if let Some(p) = previous {
            let dc = (ph[0] - p[0]).hypot(ph[1] - p[1]);
            changes.push(dc);
            let d = if amp > 0.0 {
                dc / amp
            } else if dc == 0.0 {
                0.0
            } else {
                f64::MAX
            };
            result.change = d;
            let m = changes.len();
            if k + 1 >= min_periods && d <= tol {
                // The envelope of the last `W` changes against the `W` before it (one
                // change alone beats when the transient has several components).
                let window =
                    |r: std::ops::Range<usize>| changes[r].iter().fold(0.0f64, |a, &b| a.max(b));
                let settled = if d <= 1e-3 * tol {
                    true
                } else if m >= 2 * WINDOW {
                    let now = window(m - WINDOW..m);
                    let before = window(m - 2 * WINDOW..m - WINDOW);
                    let r = if before > 0.0 {
                        (now / before).powf(1.0 / WINDOW as f64)
                    } else {
                        f64::MAX
                    };
                    let dmax = now / amp;
                    r < 1.0 && dmax <= tol && dmax * r / (1.0 - r) <= tol
                } else {
                    false
                };
                if settled {
                    result.settled = true;
                    return Ok(result);
                }
            }
        }
        previous = Some(ph);
        last = Some(result);
    }
    Ok(last.expect("at least one period is run"))
}

/// [`steady_state`] at every frequency, in parallel (rayon); the results are in the order of
/// `frequencies_hz` and do not depend on the number of threads. `done` is called once as
/// each frequency finishes (in completion order, from the worker threads: a progress
/// report).
pub fn steady_states(
    model: &HybridModel,
    start: &HybridState,
    output: &ExcitationTarget,
    frequencies_hz: &[f64],
    options: &SteadyOptions,
    done: &(dyn Fn() + Sync),
) -> Vec<Result<SteadyState, SteadyError>> {
    frequencies_hz
        .par_iter()
        .map(|&f| {
            let r = steady_state(model, start, output, f, options);
            done();
            r
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fit_of_a_sampled_sinusoid_is_exact() {
        let n = 16;
        let (cos, sin) = harmonic_basis(n);
        let y: Vec<f64> = (0..n)
            .map(|j| 0.3 + 2.0 * (2.0 * PI * j as f64 / n as f64 + 0.7).sin())
            .collect();
        let (a, ph, rms) = fit(&y, &cos, &sin);
        assert!((a - 0.3).abs() < 1e-15);
        assert!((ph[0].hypot(ph[1]) - 2.0).abs() < 1e-14);
        assert!((ph[1].atan2(ph[0]) - 0.7).abs() < 1e-14);
        assert!(rms < 1e-14);
        // A third harmonic is left in the residual: its RMS is its amplitude / sqrt(2).
        let y3: Vec<f64> = y
            .iter()
            .enumerate()
            .map(|(j, v)| v + 0.1 * (6.0 * PI * j as f64 / n as f64).cos())
            .collect();
        let (_, ph3, rms3) = fit(&y3, &cos, &sin);
        assert!((ph3[0] - ph[0]).abs() < 1e-14 && (ph3[1] - ph[1]).abs() < 1e-14);
        assert!((rms3 - 0.1 / 2f64.sqrt()).abs() < 1e-14);
    }

    #[test]
    fn wrap_is_in_the_half_open_interval() {
        for x in [-7.0, -PI, -1.0, 0.0, 1.0, PI, 4.0, 10.0] {
            let w = wrap(x);
            assert!(w > -PI && w <= PI, "{x} -> {w}");
            assert!(
                ((x - w) / (2.0 * PI)).fract().abs() < 1e-12
                    || ((x - w) / (2.0 * PI)).fract().abs() > 1.0 - 1e-12
            );
        }
    }
}
