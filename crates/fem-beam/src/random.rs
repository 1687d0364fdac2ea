//! Random time functions: the one-sided PSD of the random kinds of [`TimeFunction`] and
//! their seeded time-domain realisation.
//!
//! # Convention
//!
//! `G(f)` is the **one-sided** power spectral density **per Hz** (N²/Hz for a force): the
//! mean square of the signal is `E[x²] = ∫_0^∞ G(f) df`. The two-sided PSD per rad/s of the
//! random-vibration texts (Crandall & Mark 1963), `S(ω)` with `E[x²] = ∫_{-∞}^{∞} S dω`, is
//! `S = G / (4 π)`; ideal white noise of two-sided PSD `S0` has the correlation
//! `E[x(t) x(s)] = 2 π S0 δ(t − s) = (G / 2) δ(t − s)`.
//!
//! # Realisation (spectral representation, Shinozuka & Deodatis 1991)
//!
//! On a uniform grid `t_m = m Δt`, `m = 0 .. M−1` (`M` a power of two with `M Δt` at least
//! the run), with `Δf = 1 / (M Δt)`:
//!
//! ```text
//! x(t_m) = Σ_{k=1}^{M/2−1} A_k cos(2 π k Δf t_m + φ_k),   A_k = sqrt(2 ∫_{(k−½)Δf}^{(k+½)Δf} G df)
//! ```
//!
//! with `φ_k` uniform on `[0, 2π)`, the `k`-th draw of a SplitMix64 stream (Steele, Lea &
//! Flood 2014) from the seed: a fixed, documented generator whose stream never changes with
//! a dependency's version, so a seed gives the same signal forever. The sum is one inverse
//! FFT ([`rustfft`]). The signal is periodic with period `M Δt` and its mean square over a
//! period is `Σ A_k² / 2 = ∫ G df` over `(Δf/2, f_Nyquist − Δf/2)`, exactly (the bin
//! integrals of the piecewise-linear `G` are exact): the whole `∫ G df` when the PSD lies
//! inside. Between grid points the value is interpolated linearly, so it is exact at the
//! integrator's step times (the grid is the step).
//!
//! Its zero-mean periodic integrals (a support's velocity and displacement when the signal
//! is its acceleration) come from the same coefficients divided by `i ω_k` and `(i ω_k)²`
//! (two more inverse FFTs), exact at the grid points and interpolated linearly between
//! them ([`Samples::integrals`]).

use std::sync::Arc;

use rustfft::FftPlanner;
use rustfft::num_complex::Complex;

use crate::spec::TimeFunction;

/// The seed of a realisation when the scenario gives none (an excitation's index is added,
/// so that two excitations are independent).
pub const DEFAULT_SEED: u64 = 20_260_101;

/// The largest realisation grid (`2^25` samples: 512 MiB of complex FFT buffer, past the
/// runs' step limit of 2e7; a longer run is refused).
pub const MAX_SAMPLES: usize = 1 << 25;

/// A realisation of a random kind on a uniform, periodic grid (see the module
/// documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Samples {
    dt: f64,
    values: Arc<[f64]>,
    /// The zero-mean periodic first and second integrals at the grid points.
    first: Arc<[f64]>,
    second: Arc<[f64]>,
    seed: u64,
    psd_mean_square: f64,
    /// The highest frequency of the realised PSD (Hz).
    highest_hz: f64,
}

impl Samples {
    /// The value at `t` (linear between grid points, periodic).
    pub fn value(&self, t: f64) -> f64 {
        interpolate(&self.values, self.dt, t)
    }

    /// The zero-mean periodic integrals `(∫∫ x, ∫ x)` at `t` (exact at the grid points,
    /// linear between them): a support's displacement and velocity when the signal is its
    /// acceleration.
    pub fn integrals(&self, t: f64) -> (f64, f64) {
        (
            interpolate(&self.second, self.dt, t),
            interpolate(&self.first, self.dt, t),
        )
    }

    /// The grid step (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The period `M Δt` (s).
    pub fn period(&self) -> f64 {
        self.dt * self.values.len() as f64
    }

    /// The seed it was drawn from.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The samples over one period.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// `∫ G df` of the PSD it realises.
    pub fn psd_mean_square(&self) -> f64 {
        self.psd_mean_square
    }

    /// The highest frequency of the PSD realised (Hz): [`top_frequency`] of the random kind
    /// it was made from.
    pub fn highest_hz(&self) -> f64 {
        self.highest_hz
    }

    /// The mean square over one period.
    pub fn mean_square(&self) -> f64 {
        self.values.iter().map(|v| v * v).sum::<f64>() / self.values.len().max(1) as f64
    }
}

/// The periodic grid `values` of step `dt` at `t` (linear between grid points; 0 for a
/// time that is not finite).
fn interpolate(values: &[f64], dt: f64, t: f64) -> f64 {
    let m = values.len();
    let u = t / dt;
    if !u.is_finite() || m == 0 {
        return 0.0;
    }
    let u = u.rem_euclid(m as f64);
    let i = (u.floor() as usize).min(m - 1);
    let frac = u - i as f64;
    let (a, b) = (values[i], values[(i + 1) % m]);
    a + frac * (b - a)
}

/// Why a random time function cannot be realised on a grid.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RealiseError {
    /// Not a random kind.
    #[error("not a random time function")]
    NotRandom,
    /// The PSD reaches above what the grid can carry.
    #[error(
        "the PSD reaches {f_max} Hz, above the time step's Nyquist frequency less half a bin, {limit} Hz (1/(2 dt) = {nyquist} Hz): use a smaller dt or a lower band"
    )]
    AboveNyquist {
        /// The highest frequency with a positive PSD (Hz).
        f_max: f64,
        /// The highest frequency the grid carries (Hz).
        limit: f64,
        /// `1 / (2 dt)` (Hz).
        nyquist: f64,
    },
    /// The grid would be too large.
    #[error("the realisation needs {samples} samples (more than {MAX_SAMPLES})")]
    TooLong {
        /// The samples needed.
        samples: usize,
    },
    /// A step or a duration that is not positive and finite.
    #[error("dt = {dt} and t_end = {t_end} must be positive and finite")]
    BadGrid {
        /// The step.
        dt: f64,
        /// The duration.
        t_end: f64,
    },
}

/// The PSD of a table: piecewise linear inside, zero outside.
pub(crate) fn table_psd(table: &[[f64; 2]], f: f64) -> f64 {
    let (Some(first), Some(last)) = (table.first(), table.last()) else {
        return 0.0;
    };
    if f < first[0] || f > last[0] {
        return 0.0;
    }
    let k = table.partition_point(|p| p[0] <= f);
    if k == 0 || k >= table.len() {
        return last[1];
    }
    let ([f0, g0], [f1, g1]) = (table[k - 1], table[k]);
    g0 + (g1 - g0) * (f - f0) / (f1 - f0)
}

/// The frequencies where `G` changes slope (the band's ends, the table's points); `None`
/// for a deterministic kind.
pub fn breakpoints(time: &TimeFunction) -> Option<Vec<f64>> {
    match time {
        TimeFunction::WhiteNoise { band, .. } => Some(band.to_vec()),
        TimeFunction::Psd { table, .. } => Some(table.iter().map(|p| p[0]).collect()),
        _ => None,
    }
}

/// `∫_a^b G(f) df`, exact for the piecewise-linear `G` of a random kind (0 for the others).
pub fn psd_integral(time: &TimeFunction, a: f64, b: f64) -> f64 {
    if b <= a {
        return 0.0;
    }
    match time {
        TimeFunction::WhiteNoise { psd, band, .. } => {
            psd * (b.min(band[1]) - a.max(band[0])).max(0.0)
        }
        TimeFunction::Psd { table, .. } => table
            .windows(2)
            .map(|w| {
                let (lo, hi) = (a.max(w[0][0]), b.min(w[1][0]));
                if hi <= lo {
                    return 0.0;
                }
                let g =
                    |f: f64| w[0][1] + (w[1][1] - w[0][1]) * (f - w[0][0]) / (w[1][0] - w[0][0]);
                0.5 * (g(lo) + g(hi)) * (hi - lo)
            })
            .sum(),
        _ => 0.0,
    }
}

/// The highest frequency a time function carries (Hz): a harmonic's frequency, the upper
/// band edge of a white noise, the last frequency of a PSD table where the density is not
/// zero, a realisation's; `None` for the kinds without a stated upper frequency (constant,
/// step, table) and for a zero PSD.
pub fn top_frequency(time: &TimeFunction) -> Option<f64> {
    match time {
        TimeFunction::Harmonic { frequency_hz, .. } => Some(*frequency_hz),
        TimeFunction::WhiteNoise { .. } | TimeFunction::Psd { .. } => {
            Some(highest(time)).filter(|f| *f > 0.0)
        }
        TimeFunction::Sampled(s) => Some(s.highest_hz),
        _ => None,
    }
}

/// The highest frequency with a positive PSD (0 when there is none).
fn highest(time: &TimeFunction) -> f64 {
    match time {
        TimeFunction::WhiteNoise { psd, band, .. } if *psd > 0.0 => band[1],
        TimeFunction::Psd { table, .. } => table
            .windows(2)
            .filter(|w| w[0][1] > 0.0 || w[1][1] > 0.0)
            .map(|w| w[1][0])
            .fold(0.0, f64::max),
        _ => 0.0,
    }
}

/// SplitMix64 (Steele, Lea & Flood 2014): the next 64-bit output of the state `s`.
fn splitmix64(s: &mut u64) -> u64 {
    *s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *s;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A realisation of the random `time` on the grid of step `dt` covering `[0, t_end]` (see
/// the module documentation), drawn from `seed`.
pub fn realise(
    time: &TimeFunction,
    dt: f64,
    t_end: f64,
    seed: u64,
) -> Result<Samples, RealiseError> {
    if !matches!(
        time,
        TimeFunction::WhiteNoise { .. } | TimeFunction::Psd { .. }
    ) {
        return Err(RealiseError::NotRandom);
    }
    if !(dt.is_finite() && dt > 0.0 && t_end.is_finite() && t_end > 0.0) {
        return Err(RealiseError::BadGrid { dt, t_end });
    }
    let needed = (t_end / dt).ceil() + 2.0;
    if needed > MAX_SAMPLES as f64 {
        return Err(RealiseError::TooLong {
            samples: needed as usize,
        });
    }
    let m = (needed as usize).next_power_of_two().max(4);
    if m > MAX_SAMPLES {
        return Err(RealiseError::TooLong { samples: m });
    }
    let df = 1.0 / (m as f64 * dt);
    let nyquist = 0.5 / dt;
    let limit = nyquist - 0.5 * df;
    let f_max = highest(time);
    if f_max > limit {
        return Err(RealiseError::AboveNyquist {
            f_max,
            limit,
            nyquist,
        });
    }
    let mut state = seed;
    let mut c = vec![Complex::new(0.0, 0.0); m];
    for (k, ck) in c.iter_mut().enumerate().take(m / 2).skip(1) {
        let u = (splitmix64(&mut state) >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
        let phi = 2.0 * std::f64::consts::PI * u;
        let lo = (k as f64 - 0.5) * df;
        let a = (2.0 * psd_integral(time, lo, lo + df)).sqrt();
        *ck = Complex::from_polar(a, phi);
    }
    // The integrals: each coefficient over i w_k and (i w_k)^2.
    let omega = |k: usize| 2.0 * std::f64::consts::PI * k as f64 * df;
    let integrate = |c: &[Complex<f64>]| -> Vec<Complex<f64>> {
        c.iter()
            .enumerate()
            .map(|(k, ck)| {
                if k == 0 || k >= m / 2 {
                    Complex::new(0.0, 0.0)
                } else {
                    ck / Complex::new(0.0, omega(k))
                }
            })
            .collect()
    };
    let mut c1 = integrate(&c);
    let mut c2 = integrate(&c1);
    let fft = FftPlanner::new().plan_fft_inverse(m);
    fft.process(&mut c);
    fft.process(&mut c1);
    fft.process(&mut c2);
    Ok(Samples {
        dt,
        values: c.iter().map(|v| v.re).collect(),
        first: c1.iter().map(|v| v.re).collect(),
        second: c2.iter().map(|v| v.re).collect(),
        seed,
        psd_mean_square: psd_integral(time, 0.0, f64::INFINITY),
        highest_hz: f_max,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn white(psd: f64, f1: f64, f2: f64) -> TimeFunction {
        TimeFunction::WhiteNoise {
            psd,
            band: [f1, f2],
            seed: None,
        }
    }

    #[test]
    fn the_integrals_are_the_zero_mean_antiderivatives() {
        // Central differences of the integrals on the grid against the signal and its first
        // integral: O((w dt)^2) = (2 pi 40 Hz 1e-3 s)^2 / 6 = 1e-2 at the band's top, the
        // energy-weighted error far smaller; the integrals have zero mean over the period.
        let s = realise(&white(2e-3, 1.5, 40.0), 1e-3, 10.0, 3).unwrap();
        let (h, m) = (1e-3, s.values().len());
        let (mut err1, mut err2, mut norm1, mut norm2) = (0.0, 0.0, 0.0, 0.0);
        let (mut mean_u, mut mean_v) = (0.0, 0.0);
        for j in 0..m {
            let t = j as f64 * h;
            let (u, v) = s.integrals(t);
            let (u_p, v_p) = s.integrals(t + h);
            let (u_m, v_m) = s.integrals(t - h);
            err1 += ((v_p - v_m) / (2.0 * h) - s.value(t)).powi(2);
            norm1 += s.value(t).powi(2);
            err2 += ((u_p - u_m) / (2.0 * h) - v).powi(2);
            norm2 += v * v;
            mean_u += u;
            mean_v += v;
        }
        let (e1, e2) = ((err1 / norm1).sqrt(), (err2 / norm2).sqrt());
        assert!(e1 < 5e-3 && e2 < 5e-3, "{e1:e} {e2:e}");
        let (rms_u, rms_v) = (
            s.integrals(0.0).0.abs().max(1e-30),
            s.integrals(0.0).1.abs().max(1e-30),
        );
        assert!((mean_u / m as f64).abs() < 1e-9 * rms_u.max(1.0));
        assert!((mean_v / m as f64).abs() < 1e-9 * rms_v.max(1.0));
    }

    #[test]
    fn mean_square_over_a_period_is_the_psd_integral() {
        // Band inside (df/2, f_Nyquist - df/2): the realisation carries all of it.
        let w = white(2e-3, 1.5, 40.0);
        let s = realise(&w, 1e-3, 10.0, 7).unwrap();
        assert_eq!(s.values().len(), 16384);
        let exact = 2e-3 * 38.5;
        assert!(
            (s.mean_square() / exact - 1.0).abs() < 1e-12,
            "{}",
            s.mean_square()
        );
        let p = TimeFunction::Psd {
            table: vec![[2.0, 1e-3], [10.0, 4e-3], [30.0, 0.0]],
            seed: None,
        };
        let s = realise(&p, 2e-3, 20.0, 1).unwrap();
        let exact = 0.5 * (1e-3 + 4e-3) * 8.0 + 0.5 * 4e-3 * 20.0;
        assert!((psd_integral(&p, 0.0, 100.0) - exact).abs() < 1e-15);
        assert!(
            (s.mean_square() / exact - 1.0).abs() < 1e-12,
            "{}",
            s.mean_square()
        );
    }

    #[test]
    fn the_sum_is_the_cosine_series() {
        // The FFT against the direct sum at a few grid points.
        let w = white(1.0, 3.0, 9.0);
        let (dt, t_end, seed) = (0.01, 2.0, 42);
        let s = realise(&w, dt, t_end, seed).unwrap();
        let m = s.values().len();
        let df = 1.0 / (m as f64 * dt);
        let mut state = seed;
        let terms: Vec<(f64, f64)> = (1..m / 2)
            .map(|k| {
                let u = (splitmix64(&mut state) >> 11) as f64 / (1u64 << 53) as f64;
                let lo = (k as f64 - 0.5) * df;
                (
                    (2.0 * psd_integral(&w, lo, lo + df)).sqrt(),
                    2.0 * std::f64::consts::PI * u,
                )
            })
            .collect();
        for i in [0, 1, 17, 100, m - 1] {
            let t = i as f64 * dt;
            let direct: f64 = terms
                .iter()
                .enumerate()
                .map(|(k, (a, p))| {
                    a * (2.0 * std::f64::consts::PI * (k + 1) as f64 * df * t + p).cos()
                })
                .sum();
            assert!(
                (s.value(t) - direct).abs() < 1e-12,
                "{i}: {} vs {direct}",
                s.value(t)
            );
        }
        // Periodic and linear in between.
        assert!((s.value(s.period() + 5.0 * dt) - s.values()[5]).abs() < 1e-12);
        let mid = s.value(5.5 * dt);
        assert!((mid - 0.5 * (s.values()[5] + s.values()[6])).abs() < 1e-12);
    }

    #[test]
    fn same_seed_same_signal_other_seed_other_signal() {
        let w = white(1.0, 1.0, 20.0);
        let a = realise(&w, 0.01, 5.0, 3).unwrap();
        assert_eq!(a, realise(&w, 0.01, 5.0, 3).unwrap());
        assert_ne!(a.values(), realise(&w, 0.01, 5.0, 4).unwrap().values());
    }

    #[test]
    fn refuses_a_band_above_nyquist_and_deterministic_kinds() {
        let e = realise(&white(1.0, 1.0, 60.0), 0.01, 1.0, 0).unwrap_err();
        assert!(matches!(e, RealiseError::AboveNyquist { .. }), "{e}");
        assert_eq!(
            realise(&TimeFunction::Constant, 0.01, 1.0, 0),
            Err(RealiseError::NotRandom)
        );
    }

    #[test]
    fn psd_values_and_problems() {
        let p = TimeFunction::Psd {
            table: vec![[1.0, 2.0], [3.0, 4.0]],
            seed: Some(9),
        };
        assert_eq!(p.psd(0.5), Some(0.0));
        assert_eq!(p.psd(2.0), Some(3.0));
        assert_eq!(p.psd(3.0), Some(4.0));
        assert_eq!(p.psd(3.5), Some(0.0));
        assert_eq!(TimeFunction::Constant.psd(1.0), None);
        assert_eq!(white(5.0, 1.0, 2.0).psd(1.5), Some(5.0));
        assert!(p.problems().is_empty());
        assert_eq!(p.seed(), Some(9));
        assert!(!white(-1.0, 1.0, 2.0).problems().is_empty());
        assert!(!white(1.0, 2.0, 2.0).problems().is_empty());
        let bad = TimeFunction::Psd {
            table: vec![[1.0, 2.0], [1.0, 4.0]],
            seed: None,
        };
        assert!(matches!(
            bad.problems()[..],
            [crate::TimeFunctionError::FrequenciesNotIncreasing { index: 1, .. }]
        ));
        let spec: crate::NodalLoadSpec = toml::from_str(
            "node = 1\ntime = { kind = \"white_noise\", psd = 1e-3, band = [1.0, 9.0], seed = 4 }\n",
        )
        .unwrap();
        assert_eq!(spec.time.seed(), Some(4));
    }
}
