//! The response spectrum of a run under random excitation (issue #32): a streaming Welch
//! estimate of the one-sided PSD per Hz of the outputs of the run's `random` block, over
//! its stationary part ([`super::random_run::stationary_start`]), beside the linear
//! prediction `S_y(f) = Σ_k |H_k(f)|² G_k(f)` ([`crate::random::response_psd`]):
//! `random_psd.csv` ([`RandomPsd::table`]) and `random_psd.svg`.
//!
//! **Estimate** (Welch 1967; `docs/theory.md` section 10.1): the signal, sampled at every
//! step of the integrator (`f_s = 1 / dt`: the realisation of the excitation is exact at the
//! steps and has nothing above `f_s / 2`, so nothing is aliased by the sampling), is cut into
//! segments of `L` samples overlapping by half; each segment has its mean removed and is
//! multiplied by the periodic Hann window `w_n = sin²(π n / L)`; with `X_k` its DFT and
//! `U = Σ w_n²`,
//!
//! ```text
//! P_k = c_k |X_k|² / (f_s U),   c_k = 2 for 0 < k < L/2, 1 at k = 0 and k = L/2,
//! G(f_k) = mean of P_k over the K segments,   f_k = k f_s / L
//! ```
//!
//! so that `Σ_k G(f_k) Δf` (`Δf = f_s / L`, the resolution) is the mean over the segments
//! of the window-weighted mean square `Σ w_n² (x_n − m)² / U` (Parseval).
//!
//! **Statistical error**: for a Gaussian signal whose spectrum is smooth over a few `Δf`,
//! the relative standard error of `G(f_k)` is
//!
//! ```text
//! ε² = (1 + 2 (1 − 1/K) ρ²) / K,   ρ = Σ_n w_n w_{n+L/2} / U = 1/6 (Hann)
//! ```
//!
//! (the correlation of adjacent half-overlapping periodograms; ε ≈ 1.03 / √K), twice the
//! variance at `k = 0` and `k = L/2` (real periodograms). Near a sharp peak the window also
//! biases the estimate (it is the spectrum smoothed over about `1.5 Δf`); the segment
//! length is chosen for at least [`MIN_AVERAGES`] averages ([`segment_length`]).
//!
//! **Memory and work**: per output a ring of `L` samples and `L/2 + 1` sums, one complex
//! FFT (rustfft) of two outputs at once per `L/2` samples; the buffers are allocated before
//! the run, and a step only stores its samples ([`Welch::push`] allocates nothing).

use std::sync::Arc;

use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};
use serde::Serialize;

use super::rows::{Cells, Table, TableColumn};

/// Fewest averages the segment length is chosen for.
pub const MIN_AVERAGES: u64 = 16;
/// Shortest segment (samples).
pub const MIN_SEGMENT: usize = 16;
/// Longest segment (samples): a longer run gets more averages, not a finer resolution
/// (2 MiB of ring per output).
pub const MAX_SEGMENT: usize = 1 << 18;

/// Segments of `len` samples overlapping by half in `samples` samples (the samples after
/// the last whole segment are not used).
pub fn averages(samples: u64, len: usize) -> u64 {
    let (n, l) = (samples, len as u64);
    if l < 2 || n < l {
        return 0;
    }
    (n - l) / (l / 2) + 1
}

/// The segment length for `samples` stationary samples: the longest power of two in
/// `[MIN_SEGMENT, MAX_SEGMENT]` that leaves at least [`MIN_AVERAGES`] averages; `None` when
/// even the shortest does not.
pub fn segment_length(samples: u64) -> Option<usize> {
    let mut best = None;
    let mut len = MIN_SEGMENT;
    while len <= MAX_SEGMENT {
        if averages(samples, len) >= MIN_AVERAGES {
            best = Some(len);
        }
        len *= 2;
    }
    best
}

/// A streaming Welch estimator of the one-sided PSD of `n` signals sampled together
/// (module documentation).
pub struct Welch {
    len: usize,
    fs: f64,
    signals: usize,
    window: Vec<f64>,
    /// `Σ w_n²`.
    power: f64,
    /// Per signal, the last `len` samples (position `pos` the oldest once full).
    ring: Vec<f64>,
    /// Where the next sample goes in the ring.
    pos: usize,
    /// Samples until the next segment ends.
    until: usize,
    segments: u64,
    /// Per signal, `Σ |X_k|²` over the segments, `k = 0 ..= len / 2`.
    sums: Vec<f64>,
    fft: Arc<dyn Fft<f64>>,
    buf: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
}

impl std::fmt::Debug for Welch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Welch")
            .field("len", &self.len)
            .field("fs", &self.fs)
            .field("signals", &self.signals)
            .field("segments", &self.segments)
            .finish()
    }
}

impl Welch {
    /// An estimator of `signals` signals sampled at `fs` (Hz) in segments of `len` samples
    /// (even, at least 2); every buffer allocated here.
    pub fn new(signals: usize, len: usize, fs: f64) -> Welch {
        assert!(len >= 2 && len % 2 == 0, "Welch: an even segment length");
        let window: Vec<f64> = (0..len)
            .map(|n| (std::f64::consts::PI * n as f64 / len as f64).sin().powi(2))
            .collect();
        let power = window.iter().map(|w| w * w).sum();
        let fft = FftPlanner::new().plan_fft_forward(len);
        let scratch = vec![Complex::new(0.0, 0.0); fft.get_inplace_scratch_len()];
        Welch {
            len,
            fs,
            signals,
            window,
            power,
            ring: vec![0.0; signals * len],
            pos: 0,
            until: len,
            segments: 0,
            sums: vec![0.0; signals * (len / 2 + 1)],
            fft,
            buf: vec![Complex::new(0.0, 0.0); len],
            scratch,
        }
    }

    /// Adds one sample of every signal (`x`: one value per signal, in order); every
    /// `len / 2` samples from the `len`-th on, the last `len` samples make a segment.
    pub fn push(&mut self, x: &[f64]) {
        let pos = self.pos;
        for (ring, v) in self.ring.chunks_exact_mut(self.len).zip(x) {
            ring[pos] = *v;
        }
        self.pos += 1;
        if self.pos == self.len {
            self.pos = 0;
        }
        self.until -= 1;
        if self.until == 0 {
            self.until = self.len / 2;
            self.segment();
        }
    }

    /// Transforms the last `len` samples of every signal, two signals per complex FFT
    /// (`a + i b`: `A_k = (X_k + conj X_{L−k}) / 2`, `B_k = (X_k − conj X_{L−k}) / 2i`).
    fn segment(&mut self) {
        let len = self.len;
        let start = self.pos;
        let bins = len / 2 + 1;
        let mut k = 0;
        while k < self.signals {
            let pair = k + 1 < self.signals;
            let a = &self.ring[k * len..(k + 1) * len];
            let b = if pair {
                &self.ring[(k + 1) * len..(k + 2) * len]
            } else {
                a
            };
            let ma = a.iter().sum::<f64>() / len as f64;
            let mb = if pair {
                b.iter().sum::<f64>() / len as f64
            } else {
                0.0
            };
            // The ring in time order: from `start` to the end, then from 0.
            let (head, tail) = self.buf.split_at_mut(len - start);
            let (w_head, w_tail) = self.window.split_at(len - start);
            for (range, (z, w)) in [(start..len, (head, w_head)), (0..start, (tail, w_tail))] {
                let (a, b) = (&a[range.clone()], &b[range]);
                for (((z, w), x), y) in z.iter_mut().zip(w).zip(a).zip(b) {
                    let im = if pair { (y - mb) * w } else { 0.0 };
                    *z = Complex::new((x - ma) * w, im);
                }
            }
            self.fft
                .process_with_scratch(&mut self.buf, &mut self.scratch);
            for j in 0..bins {
                let xk = self.buf[j];
                let xm = self.buf[(len - j) % len].conj();
                self.sums[k * bins + j] += 0.25 * (xk + xm).norm_sqr();
                if pair {
                    self.sums[(k + 1) * bins + j] += 0.25 * (xk - xm).norm_sqr();
                }
            }
            k += 2;
        }
        self.segments += 1;
    }

    /// Segments averaged so far.
    pub fn segments(&self) -> u64 {
        self.segments
    }

    /// The segment length (samples).
    pub fn segment_len(&self) -> usize {
        self.len
    }

    /// The sampling frequency (Hz).
    pub fn sampling_hz(&self) -> f64 {
        self.fs
    }

    /// The resolution `Δf = f_s / L` (Hz).
    pub fn resolution_hz(&self) -> f64 {
        self.fs / self.len as f64
    }

    /// The frequencies `f_k = k Δf`, `k = 0 ..= L/2` (Hz).
    pub fn frequencies(&self) -> Vec<f64> {
        (0..=self.len / 2)
            .map(|k| k as f64 * self.resolution_hz())
            .collect()
    }

    /// Signal `k`'s PSD estimate at [`Welch::frequencies`] (unit²/Hz); zeros before the
    /// first segment.
    pub fn psd(&self, k: usize) -> Vec<f64> {
        let bins = self.len / 2 + 1;
        if self.segments == 0 {
            return vec![0.0; bins];
        }
        let scale = 1.0 / (self.fs * self.power * self.segments as f64);
        self.sums[k * bins..(k + 1) * bins]
            .iter()
            .enumerate()
            .map(|(j, s)| {
                let c = if j == 0 || j == bins - 1 { 1.0 } else { 2.0 };
                c * s * scale
            })
            .collect()
    }

    /// The correlation `ρ = Σ_n w_n w_{n+L/2} / Σ w_n²` of the windows of two
    /// half-overlapping segments (1/6 for Hann).
    pub fn overlap_correlation(&self) -> f64 {
        let h = self.len / 2;
        self.window[..h]
            .iter()
            .zip(&self.window[h..])
            .map(|(a, b)| a * b)
            .sum::<f64>()
            / self.power
    }

    /// The relative standard error of the estimate at an inner frequency (module
    /// documentation), `√((1 + 2 (1 − 1/K) ρ²) / K)`; infinite without a segment.
    pub fn relative_error(&self) -> f64 {
        let k = self.segments as f64;
        if k == 0.0 {
            return f64::INFINITY;
        }
        let rho = self.overlap_correlation();
        ((1.0 + 2.0 * (1.0 - 1.0 / k) * rho * rho) / k).sqrt()
    }

    /// The relative standard error at every frequency: [`Welch::relative_error`], `√2`
    /// times it at `f = 0` and at `f_s / 2`.
    pub fn relative_errors(&self) -> Vec<f64> {
        let e = self.relative_error();
        let bins = self.len / 2 + 1;
        (0..bins)
            .map(|j| {
                if j == 0 || j == bins - 1 {
                    e * std::f64::consts::SQRT_2
                } else {
                    e
                }
            })
            .collect()
    }
}

/// One output's spectrum: the estimate and the linear prediction.
#[derive(Clone, Debug)]
pub struct PsdOutput {
    /// As the run's `random` block names it.
    pub name: String,
    /// The output's SI unit (the PSD's is its square per Hz).
    pub unit: String,
    /// The Welch estimate at [`RandomPsd::frequencies`].
    pub estimate: Vec<f64>,
    /// The linear prediction there (`None` where the scenario cannot be linearised).
    pub prediction: Option<Vec<f64>>,
}

/// The response spectra of a run (module documentation): what `random_psd.csv` and
/// `random_psd.svg` hold.
#[derive(Clone, Debug)]
pub struct RandomPsd {
    /// The frequencies `k Δf`, `k = 0 ..= L/2` (Hz).
    pub frequencies: Vec<f64>,
    /// The relative standard error of the estimate at each frequency.
    pub relative_errors: Vec<f64>,
    /// Every output.
    pub outputs: Vec<PsdOutput>,
    /// The figures of the estimate (the summary's `psd` block).
    pub report: PsdReport,
}

/// The `psd` block of a run's `random` summary: how the spectra were estimated.
#[derive(Clone, Debug, Serialize)]
pub struct PsdReport {
    /// The file that holds them.
    pub file: &'static str,
    /// Sampling frequency (Hz): every step.
    pub sampling_hz: f64,
    /// Segment length (samples).
    pub segment_samples: usize,
    /// Resolution `Δf = f_s / L` (Hz).
    pub resolution_hz: f64,
    /// Segments averaged (Hann window, half overlapping).
    pub averages: u64,
    /// Relative standard error of the estimate at an inner frequency.
    pub relative_standard_error: f64,
    /// Whether the linear prediction is given (the scenario linearises).
    pub prediction: bool,
}

/// The unit of a PSD of an output in `unit`: `m^2/Hz`, `(m/s)^2/Hz`.
pub fn psd_unit(unit: &str) -> String {
    if unit.contains('/') || unit.contains(' ') {
        format!("({unit})^2/Hz")
    } else {
        format!("{unit}^2/Hz")
    }
}

impl RandomPsd {
    /// The spectra of `welch`'s signals named `names` (`(name, unit)`, in the signals'
    /// order) with their `predictions` (one vector per signal at the estimate's
    /// frequencies), `None` without a linearisation.
    pub fn of(
        welch: &Welch,
        names: &[(String, String)],
        predictions: Option<Vec<Vec<f64>>>,
    ) -> RandomPsd {
        let mut predictions = predictions.map(|p| p.into_iter());
        let outputs = names
            .iter()
            .enumerate()
            .map(|(k, (name, unit))| PsdOutput {
                name: name.clone(),
                unit: unit.clone(),
                estimate: welch.psd(k),
                prediction: predictions.as_mut().and_then(Iterator::next),
            })
            .collect::<Vec<_>>();
        RandomPsd {
            frequencies: welch.frequencies(),
            relative_errors: welch.relative_errors(),
            report: PsdReport {
                file: "random_psd.csv",
                sampling_hz: welch.sampling_hz(),
                segment_samples: welch.segment_len(),
                resolution_hz: welch.resolution_hz(),
                averages: welch.segments(),
                relative_standard_error: welch.relative_error(),
                prediction: outputs.iter().all(|o| o.prediction.is_some()),
            },
            outputs,
        }
    }

    /// The table of `random_psd.csv`: `f [Hz]`, per output `NAME estimate` and
    /// `NAME prediction` (`[unit^2/Hz]`; the prediction's cells empty without a
    /// linearisation), then `relative standard error [-]` of the estimate.
    pub fn table(&self) -> Table {
        let numbers = |v: &[f64]| Cells::Numbers(v.iter().map(|x| Some(*x)).collect());
        let mut columns = vec![TableColumn::new(
            "f",
            Some("Hz"),
            numbers(&self.frequencies),
        )];
        for o in &self.outputs {
            let unit = psd_unit(&o.unit);
            columns.push(TableColumn::new(
                format!("{} estimate", o.name),
                Some(&unit),
                numbers(&o.estimate),
            ));
            columns.push(TableColumn::new(
                format!("{} prediction", o.name),
                Some(&unit),
                match &o.prediction {
                    Some(p) => numbers(p),
                    None => Cells::Numbers(vec![None; self.frequencies.len()]),
                },
            ));
        }
        columns.push(TableColumn::new(
            "relative standard error",
            Some("-"),
            numbers(&self.relative_errors),
        ));
        Table::new(columns)
    }

    /// The line `simulate` prints about the spectra.
    pub fn line(&self) -> String {
        let r = &self.report;
        format!(
            "  response PSD: {} averages of {} samples (resolution {:.4} Hz, relative standard error {:.3}) in {}{}\n",
            r.averages,
            r.segment_samples,
            r.resolution_hz,
            r.relative_standard_error,
            r.file,
            if r.prediction {
                ", beside the linear prediction"
            } else {
                " (no linear prediction: the scenario does not linearise)"
            }
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A SplitMix64 stream (Steele, Lea & Flood 2014) turned into standard normal draws
    /// (Box–Muller): a fixed generator for the tests.
    struct Normal(u64);

    impl Normal {
        fn uniform(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
        fn next(&mut self) -> f64 {
            let (u, v) = (self.uniform(), self.uniform());
            (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
        }
    }

    #[test]
    fn segment_length_leaves_enough_averages() {
        // 585,000 samples (random_damper.toml's stationary part at 10 kHz): 2^16 samples
        // give (585000 - 65536) / 32768 + 1 = 16 averages, 2^17 only 7.
        assert_eq!(segment_length(585_000), Some(1 << 16));
        assert_eq!(averages(585_000, 1 << 16), 16);
        assert_eq!(averages(585_000, 1 << 17), 7);
        // 16 averages of the shortest segment take 17 half segments: 136 samples.
        assert_eq!(segment_length(136), Some(16));
        assert_eq!(segment_length(135), None);
        // A very long run is capped at MAX_SEGMENT.
        assert_eq!(segment_length(1 << 30), Some(MAX_SEGMENT));
        assert_eq!(averages(10, 16), 0);
    }

    /// A sine of amplitude A at a bin frequency: the estimate is A²/2 spread over the bin
    /// and its two neighbours (Hann: `|X|` of A L/4 and A L/8 twice), nothing elsewhere
    /// (to round-off), in each of two signals transformed together; the Hann correlation
    /// is 1/6.
    #[test]
    fn a_sine_at_a_bin_integrates_to_half_its_square() {
        let (fs, len) = (1000.0, 256);
        let df = fs / len as f64;
        let mut w = Welch::new(3, len, fs);
        let (a, b, c) = (2.0, 0.5, 3.0);
        for n in 0..len * 8 {
            let t = n as f64 / fs;
            let s = |k: f64| (2.0 * std::f64::consts::PI * k * df * t + 0.3).sin();
            // A constant offset is removed with each segment's mean.
            w.push(&[a * s(20.0) + 7.0, b * s(50.0), c * s(3.0) - 1.0]);
        }
        assert_eq!(w.segments(), 15);
        assert!((w.overlap_correlation() - 1.0 / 6.0).abs() < 1e-14);
        for (k, amp, bin) in [(0, a, 20), (1, b, 50), (2, c, 3)] {
            let p = w.psd(k);
            let peak: f64 = p[bin - 1..=bin + 1].iter().sum::<f64>() * df;
            assert!(
                (peak - amp * amp / 2.0).abs() < 1e-12 * amp * amp,
                "{k}: {peak}"
            );
            // Hann's shares: 1/4 at the bin, 1/16 at each neighbour (of 3/8).
            assert!((p[bin] * df - amp * amp / 2.0 * (2.0 / 3.0)).abs() < 1e-12 * amp * amp);
            let rest: f64 = p
                .iter()
                .enumerate()
                .filter(|(j, _)| j.abs_diff(bin) > 1)
                .map(|(_, v)| v)
                .sum::<f64>()
                * df;
            assert!(rest < 1e-20 * amp * amp, "{k}: {rest}");
        }
    }

    /// White Gaussian noise of variance σ² sampled at f_s has the flat one-sided PSD
    /// 2σ²/f_s: the estimate's mean over the inner bins is that level within its standard
    /// error (the bins of one segment nearly independent, so the mean's error is about
    /// ε / √bins), and the spread of the bins about it is the stated ε within 10 %.
    #[test]
    fn white_noise_is_flat_at_two_sigma_squared_over_fs() {
        let (fs, len, sigma) = (500.0, 512, 0.7);
        let mut w = Welch::new(2, len, fs);
        let mut rng = Normal(7);
        for _ in 0..len * 32 {
            w.push(&[sigma * rng.next(), 3.0 * sigma * rng.next()]);
        }
        assert_eq!(w.segments(), 63);
        let eps = w.relative_error();
        // K = 63: sqrt((1 + 2 (62/63) / 36) / 63).
        assert!((eps - ((1.0 + 2.0 * (62.0 / 63.0) / 36.0) / 63.0f64).sqrt()).abs() < 1e-12);
        for (k, s) in [(0, sigma), (1, 3.0 * sigma)] {
            let level = 2.0 * s * s / fs;
            let p = w.psd(k);
            let inner = &p[1..len / 2];
            let mean = inner.iter().sum::<f64>() / inner.len() as f64;
            // Adjacent Hann bins correlate (4/9 of the variance between neighbours): the
            // mean's error is at most ε √(1 + 2 · 4/9 + 2/36) / √bins.
            let se = eps * (1.0 + 8.0 / 9.0 + 1.0 / 18.0f64).sqrt() / (inner.len() as f64).sqrt();
            assert!(
                (mean / level - 1.0).abs() < 3.0 * se,
                "{k}: {mean} against {level} (se {se})"
            );
            let spread = (inner.iter().map(|v| (v / level - 1.0).powi(2)).sum::<f64>()
                / inner.len() as f64)
                .sqrt();
            assert!(
                (spread / eps - 1.0).abs() < 0.1,
                "{k}: {spread} against {eps}"
            );
        }
    }

    /// Parseval: `Σ G Δf` is the mean over the segments of the window-weighted mean square
    /// of each de-meaned segment, computed directly here, to round-off (relative 1e-12: a
    /// sum of 2^10 positive terms and an FFT of 2^10 points, each about 1e-15).
    #[test]
    fn the_spectrum_integrates_to_the_windowed_mean_square() {
        let (fs, len) = (2000.0, 1024);
        let mut w = Welch::new(1, len, fs);
        let mut rng = Normal(11);
        let x: Vec<f64> = (0..len * 5)
            .map(|n| 0.3 + rng.next() + (n as f64 * 0.01).sin())
            .collect();
        for v in &x {
            w.push(&[*v]);
        }
        let window: Vec<f64> = (0..len)
            .map(|n| (std::f64::consts::PI * n as f64 / len as f64).sin().powi(2))
            .collect();
        let u: f64 = window.iter().map(|v| v * v).sum();
        let mut direct = 0.0;
        let mut segments = 0;
        let mut start = 0;
        while start + len <= x.len() {
            let s = &x[start..start + len];
            let m = s.iter().sum::<f64>() / len as f64;
            direct += s
                .iter()
                .zip(&window)
                .map(|(v, w)| (w * (v - m)).powi(2))
                .sum::<f64>()
                / u;
            segments += 1;
            start += len / 2;
        }
        direct /= segments as f64;
        assert_eq!(w.segments(), segments);
        let integral: f64 = w.psd(0).iter().sum::<f64>() * w.resolution_hz();
        assert!(
            (integral / direct - 1.0).abs() < 1e-12,
            "{integral} against {direct}"
        );
    }

    #[test]
    fn the_table_names_the_columns_with_units() {
        let mut w = Welch::new(2, 16, 100.0);
        for n in 0..64 {
            w.push(&[n as f64, 1.0]);
        }
        let names = [
            ("w(x=1)".to_string(), "m".to_string()),
            ("w(x=1)'".to_string(), "m/s".to_string()),
        ];
        let psd = RandomPsd::of(&w, &names, None);
        let t = psd.table();
        assert_eq!(
            t.header(),
            [
                "f [Hz]",
                "w(x=1) estimate [m^2/Hz]",
                "w(x=1) prediction [m^2/Hz]",
                "w(x=1)' estimate [(m/s)^2/Hz]",
                "w(x=1)' prediction [(m/s)^2/Hz]",
                "relative standard error [-]"
            ]
        );
        assert_eq!(t.rows(), 9);
        assert!(!psd.report.prediction);
    }
}
