//! The time-integration scheme of the engine: Newmark's average acceleration or HHT-alpha
//! (see the module documentation of [`crate::hybrid`], "Time integration").

/// The time-integration scheme.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// Newmark's average acceleration (trapezoidal rule): `beta = 1/4`, `gamma = 1/2`.
    Newmark,
    /// Hilber–Hughes–Taylor with `alpha` in [-1/3, 0] (numerical damping of high modes).
    Hht {
        /// The HHT parameter (0 = Newmark).
        alpha: f64,
    },
}

impl Method {
    /// `(alpha, beta, gamma)` of the scheme.
    pub fn coefficients(self) -> (f64, f64, f64) {
        let alpha = match self {
            Method::Newmark => 0.0,
            Method::Hht { alpha } => alpha,
        };
        (alpha, (1.0 - alpha).powi(2) / 4.0, 0.5 - alpha)
    }
}
