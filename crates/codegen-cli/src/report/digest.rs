//! What a run keeps of a plotted series while its rows are streamed to the CSV: the
//! points decimated to at most [`MAX_PLOT_POINTS`] — memory independent of `t_end`. (The
//! decay estimate is computed online by `hybrid_core::decay::DecayTracker`.)
//!
//! Plot decimation: a series of at most [`MAX_PLOT_POINTS`] samples is kept whole; a longer
//! one is cut into fewer than `MAX_PLOT_POINTS / 2` buckets of equal sample count, each kept
//! as its lowest and highest value in time order, with the first and the last
//! sample (min/max decimation: the envelope of the decay is drawn exactly, no oscillation
//! is aliased away). 20,000 points are about 20 per pixel column of the 1000-pixel plot.

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_series_are_plotted_whole_long_ones_by_min_max_buckets() {
        let short: Vec<(f64, f64)> = (0..20_000).map(|k| (k as f64, (k % 7) as f64)).collect();
        let mut d = Decimator::new(20_000);
        short.iter().for_each(|s| d.push(*s));
        assert_eq!(d.points(), short);
        for n in [20_001u64, 123_457, 2_000_000] {
            let mut d = Decimator::new(n);
            for k in 0..n {
                // A fast oscillation under a slow envelope.
                let t = k as f64 * 1e-3;
                d.push((t, (-t / 500.0).exp() * (t * 50.0).sin()));
            }
            assert!(d.retained() as u64 <= MAX_PLOT_POINTS + 2);
            let p = d.points();
            assert!(p.len() as u64 <= MAX_PLOT_POINTS, "{n}: {}", p.len());
            assert!(p.windows(2).all(|w| w[0].0 < w[1].0), "time order");
            assert_eq!(p.first().unwrap().0, 0.0);
            assert_eq!(p.last().unwrap().0, (n - 1) as f64 * 1e-3);
            // The envelope survives: the largest plotted value is the largest sample.
            let top = p.iter().map(|s| s.1).fold(f64::MIN, f64::max);
            assert!(top > 0.99, "{n}: {top}");
        }
    }
}
