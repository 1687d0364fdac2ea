//! What a run keeps of its samples while they are streamed to the CSV: the first
//! sample, the peak amplitude, the equivalent damping ratio computed on the fly, and the
//! plot's points decimated to at most [`MAX_PLOT_POINTS`] — memory independent of `t_end`.
//!
//! The decay estimate is `hybrid_core::study::decay` of all the samples, computed online by
//! the same [`DecayTracker`] (the one estimator, `hybrid_core::decay`): half-cycle peaks
//! of the samples' `signal` and the least-squares fits, bit for bit.
//!
//! Plot decimation: a series of at most [`MAX_PLOT_POINTS`] samples is kept whole; a longer
//! one is cut into fewer than `MAX_PLOT_POINTS / 2` buckets of equal sample count, each kept
//! as its lowest and highest tip displacement in time order, with the first and the last
//! sample (min/max decimation: the envelope of the decay is drawn exactly, no oscillation
//! is aliased away). 20,000 points are about 20 per pixel column of the 1000-pixel plot.
//! The hybrid kind decimates its plotted beam point displacements with the same
//! [`Decimator`].

use hybrid_core::decay::{DecayEstimate, DecayTracker};
use hybrid_core::study::Sample;

/// Largest number of points of one plotted series.
pub const MAX_PLOT_POINTS: u64 = 20_000;

/// A point of a plotted series: its time and the value the decimation keeps the lowest
/// and highest of.
pub trait PlotPoint: Copy {
    /// Time (s).
    fn t(&self) -> f64;
    /// The plotted value.
    fn y(&self) -> f64;
}

impl PlotPoint for Sample {
    fn t(&self) -> f64 {
        self.t
    }
    fn y(&self) -> f64 {
        self.tip_displacement
    }
}

impl PlotPoint for (f64, f64) {
    fn t(&self) -> f64 {
        self.0
    }
    fn y(&self) -> f64 {
        self.1
    }
}

/// Min/max decimation of a series whose length is known in advance (see the module
/// documentation): at most [`MAX_PLOT_POINTS`] points, the first and the last included.
#[derive(Clone, Debug)]
pub struct Decimator<P> {
    bucket: u64,
    in_bucket: u64,
    low: Option<P>,
    high: Option<P>,
    first: Option<P>,
    last: Option<P>,
    points: Vec<P>,
}

impl<P: PlotPoint> Decimator<P> {
    /// A decimator for a series of `expected` points (more or fewer are fine: the plot then
    /// has a few points more or fewer).
    pub fn new(expected: u64) -> Decimator<P> {
        let bucket = if expected <= MAX_PLOT_POINTS {
            1
        } else {
            expected.div_ceil(MAX_PLOT_POINTS / 2 - 1)
        };
        Decimator {
            bucket,
            in_bucket: 0,
            low: None,
            high: None,
            first: None,
            last: None,
            points: Vec::with_capacity(expected.min(MAX_PLOT_POINTS) as usize),
        }
    }

    /// Takes the next point.
    pub fn push(&mut self, p: P) {
        self.first.get_or_insert(p);
        self.last = Some(p);
        if self.bucket == 1 {
            self.points.push(p);
            return;
        }
        let y = p.y();
        if self.low.is_none_or(|l| y < l.y()) {
            self.low = Some(p);
        }
        if self.high.is_none_or(|h| y > h.y()) {
            self.high = Some(p);
        }
        self.in_bucket += 1;
        if self.in_bucket == self.bucket {
            self.flush();
        }
    }

    fn flush(&mut self) {
        match (self.low.take(), self.high.take()) {
            (Some(l), Some(h)) if l.t() == h.t() => self.points.push(l),
            (Some(l), Some(h)) => {
                let (a, b) = if l.t() < h.t() { (l, h) } else { (h, l) };
                self.points.push(a);
                self.points.push(b);
            }
            _ => {}
        }
        self.in_bucket = 0;
    }

    /// The points to plot (at most [`MAX_PLOT_POINTS`], the first and last included).
    pub fn points(&self) -> Vec<P> {
        let mut p = self.clone();
        p.flush();
        let mut points = p.points;
        if p.bucket > 1 {
            if let Some(first) = self.first {
                if points.first().is_none_or(|p| p.t() > first.t()) {
                    points.insert(0, first);
                }
            }
            if let Some(last) = self.last {
                if points.last().is_none_or(|p| p.t() < last.t()) {
                    points.push(last);
                }
            }
        }
        points
    }

    /// Points retained so far (bounded by [`MAX_PLOT_POINTS`] + 2).
    pub fn retained(&self) -> usize {
        self.points.len() + 2
    }
}

/// What is kept of a damper run's samples (see the module documentation).
#[derive(Clone, Debug)]
pub struct SampleDigest {
    count: u64,
    first: Option<Sample>,
    last: Option<Sample>,
    peak: f64,
    decay: DecayTracker,
    plot: Decimator<Sample>,
}

impl SampleDigest {
    /// A digest for a run of `expected` samples (sets the plot's decimation; more or fewer
    /// samples are fine, the plot then has a few points more or fewer).
    pub fn new(expected: u64) -> SampleDigest {
        SampleDigest {
            count: 0,
            first: None,
            last: None,
            peak: 0.0,
            decay: DecayTracker::default(),
            plot: Decimator::new(expected),
        }
    }

    /// Takes the next sample.
    pub fn push(&mut self, s: &Sample) {
        self.first.get_or_insert(*s);
        self.last = Some(*s);
        self.peak = self.peak.max(s.tip_displacement.abs());
        self.decay.push(s.t, s.signal);
        self.plot.push(*s);
        self.count += 1;
    }

    /// Samples taken.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// The first sample.
    pub fn first(&self) -> Option<&Sample> {
        self.first.as_ref()
    }

    /// The last sample.
    pub fn last(&self) -> Option<&Sample> {
        self.last.as_ref()
    }

    /// Largest |tip displacement| (m).
    pub fn peak(&self) -> f64 {
        self.peak
    }

    /// How the free decay decays, as `study::decay` of all the samples.
    pub fn decay(&self) -> DecayEstimate {
        self.decay.estimate()
    }

    /// Equivalent damping ratio of the free decay, as `study::damping_ratio` of all the
    /// samples (`None` when the decay is not oscillatory: see [`Self::decay`]).
    pub fn damping_ratio(&self) -> Option<f64> {
        self.decay().zeta()
    }

    /// The plot's points (at most [`MAX_PLOT_POINTS`], the first and last samples included).
    pub fn plot_points(&self) -> Vec<Sample> {
        self.plot.points()
    }

    /// Points retained for the plot so far (bounded by [`MAX_PLOT_POINTS`] + 2).
    pub fn retained(&self) -> usize {
        self.plot.retained()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hybrid_core::study::decay;
    use mbs_symbolic::samples::SplitMix64;

    fn sample(t: f64, y: f64) -> Sample {
        Sample {
            t,
            tip_displacement: y,
            signal: y,
            ..Sample::default()
        }
    }

    /// Decaying oscillations with ripple and noise, sampled coarsely and finely: the online
    /// decay estimate is identical to `study::decay` of all the samples.
    #[test]
    fn online_decay_estimate_equals_the_batch_one_bit_for_bit() {
        let mut rng = SplitMix64::new(7);
        for case in 0..40 {
            let n = 50 + (rng.symmetric(1.0).abs() * 5000.0) as usize;
            let zeta = 0.001 + 0.05 * rng.symmetric(1.0).abs();
            let f = 1.0 + 10.0 * rng.symmetric(1.0).abs();
            let dt = 1e-3 * (1.0 + 9.0 * rng.symmetric(1.0).abs());
            let ripple = 0.05 * rng.symmetric(1.0);
            let samples: Vec<Sample> = (0..n)
                .map(|k| {
                    let t = k as f64 * dt;
                    let w = 2.0 * std::f64::consts::PI * f;
                    let y = (-zeta * w * t).exp() * (w * t).cos()
                        + ripple * (7.3 * w * t).sin() * (-zeta * w * t).exp()
                        + 1e-4 * rng.symmetric(1.0);
                    sample(t, y)
                })
                .collect();
            let mut d = SampleDigest::new(n as u64);
            samples.iter().for_each(|s| d.push(s));
            let batch = decay(&samples);
            assert_eq!(d.decay(), batch, "case {case}");
            let peak = samples
                .iter()
                .map(|s| s.tip_displacement.abs())
                .fold(0.0, f64::max);
            assert_eq!(d.peak(), peak);
        }
    }

    #[test]
    fn short_series_are_plotted_whole_long_ones_by_min_max_buckets() {
        let short: Vec<Sample> = (0..20_000)
            .map(|k| sample(k as f64, (k % 7) as f64))
            .collect();
        let mut d = SampleDigest::new(20_000);
        short.iter().for_each(|s| d.push(s));
        assert_eq!(d.plot_points(), short);
        for n in [20_001u64, 123_457, 2_000_000] {
            let mut d = SampleDigest::new(n);
            for k in 0..n {
                // A fast oscillation under a slow envelope.
                let t = k as f64 * 1e-3;
                d.push(&sample(t, (-t / 500.0).exp() * (t * 50.0).sin()));
            }
            let p = d.plot_points();
            assert!(p.len() as u64 <= MAX_PLOT_POINTS, "{n}: {}", p.len());
            assert!(d.retained() as u64 <= MAX_PLOT_POINTS + 2);
            assert!(p.windows(2).all(|w| w[0].t < w[1].t), "time order");
            assert_eq!(p.first().unwrap().t, 0.0);
            assert_eq!(p.last().unwrap().t, (n - 1) as f64 * 1e-3);
            // The envelope survives: the largest plotted value is the largest sample.
            let top = p
                .iter()
                .map(|s| s.tip_displacement)
                .fold(f64::MIN, f64::max);
            assert!(top > 0.99, "{n}: {top}");
        }
    }
}
