//! Closed-form natural frequencies of uniform Euler–Bernoulli beams, the reference the
//! finite-element frequencies are checked against:
//!
//! ```text
//!   f_n = (beta_n L)^2 / (2 pi L^2) * sqrt(E J / (rho F))
//! ```
//!
//! with `beta_n L` the n-th positive root of the characteristic equation of the end
//! conditions:
//!
//! | case | equation | first roots |
//! | --- | --- | --- |
//! | clamped–free (cantilever) | `cos x cosh x + 1 = 0` | 1.8751, 4.6941, 7.8548, ... |
//! | pinned–pinned | `sin x = 0` | n pi |
//! | clamped–clamped, free–free | `cos x cosh x - 1 = 0` | 4.7300, 7.8532, 10.9956, ... |
//! | clamped–pinned, pinned–free | `tan x = tanh x` | 3.9266, 7.0686, ... |
//!
//! The free–free beam has two rigid-body modes (0 Hz) listed first, the pinned–free beam one.
//! The first five roots are tabulated (to 16 digits); further roots are found by Newton's
//! method from the asymptotic values `(2n-1) pi/2`, `(2n+1) pi/2`, `(4n+1) pi/4`, on the
//! forms `cos x + 1/cosh x = 0`, `cos x - 1/cosh x = 0`, `sin x - cos x tanh x = 0`, which
//! stay well scaled for large `x`.

use std::f64::consts::PI;
use std::fmt;

use crate::beam::Beam;
use crate::spec::{Dof, SupportKind};

/// Boundary conditions with a closed-form solution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoundaryCase {
    /// Clamped at one end, free at the other.
    Cantilever,
    /// Pinned at both ends.
    SimplySupported,
    /// Clamped at both ends.
    ClampedClamped,
    /// No support at all.
    FreeFree,
    /// Clamped at one end, pinned at the other.
    ClampedPinned,
    /// Pinned at one end, free at the other.
    PinnedFree,
}

impl BoundaryCase {
    /// Number of rigid-body (0 Hz) modes.
    pub fn rigid_body_modes(self) -> usize {
        match self {
            BoundaryCase::FreeFree => 2,
            BoundaryCase::PinnedFree => 1,
            _ => 0,
        }
    }

    /// `beta_n L` of the n-th elastic mode (`n >= 1`).
    pub fn beta_l(self, n: usize) -> f64 {
        assert!(n >= 1, "elastic modes are numbered from 1");
        match self {
            BoundaryCase::SimplySupported => n as f64 * PI,
            BoundaryCase::Cantilever => CANTILEVER
                .get(n - 1)
                .copied()
                .unwrap_or_else(|| newton(Equation::CantileverEq, (2 * n - 1) as f64 * PI / 2.0)),
            BoundaryCase::ClampedClamped | BoundaryCase::FreeFree => {
                CLAMPED_CLAMPED.get(n - 1).copied().unwrap_or_else(|| {
                    newton(Equation::ClampedClampedEq, (2 * n + 1) as f64 * PI / 2.0)
                })
            }
            BoundaryCase::ClampedPinned | BoundaryCase::PinnedFree => {
                newton(Equation::TanTanh, (4 * n + 1) as f64 * PI / 4.0)
            }
        }
    }
}

impl fmt::Display for BoundaryCase {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            BoundaryCase::Cantilever => "cantilever (clamped-free)",
            BoundaryCase::SimplySupported => "simply supported (pinned-pinned)",
            BoundaryCase::ClampedClamped => "clamped-clamped",
            BoundaryCase::FreeFree => "free-free",
            BoundaryCase::ClampedPinned => "clamped-pinned",
            BoundaryCase::PinnedFree => "pinned-free",
        })
    }
}

/// Roots of `cos x cosh x + 1 = 0`.
const CANTILEVER: [f64; 5] = [
    1.875104068711961,
    4.694091132974175,
    7.854757438237613,
    10.995540734875467,
    14.137_168_391_046_47,
];
/// Roots of `cos x cosh x - 1 = 0` (clamped–clamped and free–free).
///
/// The fifth root is 17.278759657399481 (checked to 30 digits): near `11 pi / 2` the root
/// lies at `11 pi/2 + 2 e^-x`, above the asymptote. The value 17.27875953208824 found in
/// some tables is `11 pi/2 - 2 e^-x`, on the wrong side: there `cos x cosh x - 1 = -2`.
const CLAMPED_CLAMPED: [f64; 5] = [
    4.730040744862704,
    7.853204624095838,
    10.995607838001671,
    14.137165491257464,
    17.278_759_657_399_48,
];

#[derive(Clone, Copy)]
enum Equation {
    CantileverEq,
    ClampedClampedEq,
    TanTanh,
}

/// Newton's method on the well-scaled form of the characteristic equation.
fn newton(eq: Equation, mut x: f64) -> f64 {
    for _ in 0..50 {
        let (s, c) = x.sin_cos();
        let (sech, tanh) = (1.0 / x.cosh(), x.tanh());
        let (g, dg) = match eq {
            Equation::CantileverEq => (c + sech, -s - sech * tanh),
            Equation::ClampedClampedEq => (c - sech, -s + sech * tanh),
            Equation::TanTanh => (s - c * tanh, c + s * tanh - c * sech * sech),
        };
        let dx = g / dg;
        x -= dx;
        if dx.abs() <= 1e-16 * x {
            break;
        }
    }
    x
}

/// Relative tolerance for "the same" section properties in different segments.
const UNIFORM_TOL: f64 = 1e-12;

/// The closed-form case of a beam: uniform `E J` and `rho F` along the length, supports only
/// at the two ends, each end clamped, pinned or free. `None` otherwise.
pub fn classify(beam: &Beam) -> Option<BoundaryCase> {
    let segs = beam.segments();
    let (ej, ra) = (segs[0].bending_stiffness(), segs[0].mass_per_length());
    let same = |a: f64, b: f64| (a - b).abs() <= UNIFORM_TOL * a.abs().max(b.abs());
    if !segs
        .iter()
        .all(|s| same(s.bending_stiffness(), ej) && same(s.mass_per_length(), ra))
    {
        return None;
    }
    let last = beam.node_count() - 1;
    if (1..last).any(|n| beam.is_locked(n, Dof::Transverse) || beam.is_locked(n, Dof::Rotation)) {
        return None;
    }
    use SupportKind::*;
    let ends = (beam.support_kind(0)?, beam.support_kind(last)?);
    Some(match ends {
        (Clamped, Free) | (Free, Clamped) => BoundaryCase::Cantilever,
        (Pinned, Pinned) => BoundaryCase::SimplySupported,
        (Clamped, Clamped) => BoundaryCase::ClampedClamped,
        (Free, Free) => BoundaryCase::FreeFree,
        (Clamped, Pinned) | (Pinned, Clamped) => BoundaryCase::ClampedPinned,
        (Pinned, Free) | (Free, Pinned) => BoundaryCase::PinnedFree,
    })
}

/// The first `count` natural frequencies (Hz) of a uniform beam of length `length`, bending
/// stiffness `ej` and mass per length `rho_a`, rigid-body modes (0 Hz) first.
pub fn frequencies_hz_of(
    case: BoundaryCase,
    length: f64,
    ej: f64,
    rho_a: f64,
    count: usize,
) -> Vec<f64> {
    let r = case.rigid_body_modes();
    (0..count)
        .map(|i| {
            if i < r {
                0.0
            } else {
                let bl = case.beta_l(i - r + 1);
                bl * bl / (2.0 * PI * length * length) * (ej / rho_a).sqrt()
            }
        })
        .collect()
}

/// The first `count` closed-form natural frequencies (Hz) of a beam, when its boundary
/// conditions and properties have them ([`classify`]); `None` otherwise.
pub fn frequencies_hz(beam: &Beam, count: usize) -> Option<(BoundaryCase, Vec<f64>)> {
    let case = classify(beam)?;
    let s = &beam.segments()[0];
    Some((
        case,
        frequencies_hz_of(
            case,
            beam.length(),
            s.bending_stiffness(),
            s.mass_per_length(),
            count,
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newton_reproduces_the_tabulated_roots() {
        for (n, &x) in CANTILEVER.iter().enumerate() {
            let r = newton(Equation::CantileverEq, (2 * n + 1) as f64 * PI / 2.0);
            // Newton converges to the root to within a couple of ulps.
            assert!((r - x).abs() < 4e-15 * x, "cantilever {n}: {r} vs {x}");
        }
        for (n, &x) in CLAMPED_CLAMPED.iter().enumerate() {
            let r = newton(Equation::ClampedClampedEq, (2 * n + 3) as f64 * PI / 2.0);
            assert!((r - x).abs() < 4e-15 * x, "clamped-clamped {n}: {r} vs {x}");
        }
    }

    #[test]
    fn tabulated_roots_satisfy_their_equations() {
        // Residuals of the well-scaled forms are pure rounding (~1e-15) at a root.
        for &x in &CANTILEVER {
            assert!((x.cos() + 1.0 / x.cosh()).abs() < 1e-14, "{x}");
        }
        for &x in &CLAMPED_CLAMPED {
            assert!((x.cos() - 1.0 / x.cosh()).abs() < 1e-14, "{x}");
        }
        // The misprinted fifth clamped-clamped root is not a root at all.
        let wrong: f64 = 17.27875953208824;
        assert!((wrong.cos() * wrong.cosh() - 1.0 + 2.0).abs() < 1e-6);
    }

    #[test]
    fn higher_roots_approach_the_asymptotes() {
        let x6 = BoundaryCase::Cantilever.beta_l(6);
        assert!((x6 - 11.0 * PI / 2.0).abs() < 1e-7);
        assert!((x6.cos() * x6.cosh() + 1.0).abs() < 1e-6 * x6.cosh());
        let y6 = BoundaryCase::ClampedClamped.beta_l(6);
        assert!((y6 - 13.0 * PI / 2.0).abs() < 1e-7);
        // tan x = tanh x: known first roots 3.926602312047919, 7.068582745628732.
        assert!((BoundaryCase::ClampedPinned.beta_l(1) - 3.926_602_312_047_919).abs() < 1e-13);
        assert!((BoundaryCase::PinnedFree.beta_l(2) - 7.068_582_745_628_732).abs() < 1e-13);
    }

    #[test]
    fn rigid_modes_first() {
        let f = frequencies_hz_of(BoundaryCase::FreeFree, 1.0, 1.0, 1.0, 3);
        assert_eq!(&f[..2], &[0.0, 0.0]);
        assert!((f[2] - CLAMPED_CLAMPED[0].powi(2) / (2.0 * PI)).abs() < 1e-15);
    }
}
