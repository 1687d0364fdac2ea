//! Placement helpers: a two-bar chain (the paper's double bar) placed for a beam point by
//! the half-angle at its pivot (the pivot on the point's line of motion, or along a given
//! direction with the knee on a given side) or by the pivot's position, with its initial
//! guess and its reach to the singular (stretched) position; and the initial deflection of a
//! free decay released from a beam point (the static shape of a point load there).
//!
//! With bars `L1`, `L2` at half-angle `a` (the angle at the pivot between the crank and the
//! pivot -> point axis) the point is at
//!
//! ```text
//! d = L1 cos a + sqrt(L2^2 - L1^2 sin^2 a)        (2 L cos a for equal bars)
//! ```
//!
//! from the pivot (docs/theory.md section 13.3).

use fem_beam::{BeamError, BeamModel};
use mbs_symbolic::runtime::System;

use super::model::BeamPoint;

/// Where the ground pivot of the double bar is, relative to the undeformed beam point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Placement {
    /// On the point's line of motion, the bars at this half-angle at the pivot (degrees;
    /// 0 = the singular, straight position).
    HalfAngle(f64),
    /// The pivot at `[x, y]` (m) from the undeformed beam point.
    Pivot([f64; 2]),
    /// The pivot at the distance `d` of the half-angle (module documentation) from the point
    /// along `direction` (the mechanism's ground frame; any length, normalised here), the
    /// knee on the side `knee` of the pivot -> point axis. `HalfAngle(deg)` is the pivot
    /// along `[0, -1]` with the knee on the clockwise side.
    Along {
        /// The half-angle at the pivot (degrees).
        half_angle_deg: f64,
        /// From the point towards the pivot (mechanism frame; not zero).
        direction: [f64; 2],
        /// The side of the knee.
        knee: Knee,
    },
}

/// The side of the pivot -> point axis the knee of a double bar lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Knee {
    /// Counter-clockwise from the axis (`"+"`: to the left looking from the pivot).
    CounterClockwise,
    /// Clockwise from the axis (`"-"`; the side of [`Placement::HalfAngle`]).
    Clockwise,
}

/// Why a double bar cannot be placed for a beam point.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PlacementError {
    /// The point is not the end of a two-bar chain.
    #[error("the point is not at the end of a two-bar chain (bar lengths {l1}, {l2})")]
    NotTwoBar {
        /// First bar length read off the kinematics.
        l1: f64,
        /// Second bar length.
        l2: f64,
    },
    /// The half-angle cannot be reached.
    #[error("{deg} degrees cannot be reached with bars {l1} m and {l2} m")]
    AngleUnreachable {
        /// The half-angle (degrees).
        deg: f64,
        /// First bar length.
        l1: f64,
        /// Second bar length.
        l2: f64,
    },
    /// A pivot direction that is zero or not finite.
    #[error("the pivot direction [{x}, {y}] must be finite and not zero")]
    Direction {
        /// Its x component.
        x: f64,
        /// Its y component.
        y: f64,
    },
    /// The pivot is out of reach.
    #[error("the beam point is {d} m from the pivot, out of the reach of bars {l1} m and {l2} m")]
    PivotUnreachable {
        /// Distance from the pivot to the beam point.
        d: f64,
        /// First bar length.
        l1: f64,
        /// Second bar length.
        l2: f64,
    },
}

/// Link lengths `(L1, L2)` of a double bar read off its point kinematics: the point at
/// `q = (0, 0)` lies at `L1 + L2` along x, at `q = (0, pi)` at `L1 - L2`.
fn bar_lengths<M: System + ?Sized>(m: &M, point: usize) -> (f64, f64) {
    let mut ws = m.workspace();
    m.point_kinematics(point, &[0.0, 0.0], &[0.0; 2], &mut ws);
    let s = ws.point_p[0];
    m.point_kinematics(point, &[0.0, std::f64::consts::PI], &[0.0; 2], &mut ws);
    let d = ws.point_p[0];
    ((s + d) / 2.0, (s - d) / 2.0)
}

/// A double bar placed for a beam point: where the point is relative to the ground pivot,
/// the initial guess of its coordinates and its reach.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoBar {
    /// The attached point relative to the ground pivot, `[x0, y0]` (m, mechanism axes):
    /// the pivot is at the beam point minus this.
    pub target: [f64; 2],
    /// Initial guess `(q1, q2)` (crank angle, coupler angle relative to the crank; rad).
    pub guess: [f64; 2],
    /// How far the point can move along the mechanism's `y` axis from `target` before the
    /// bars are in line (m): `sqrt((L1 + L2)^2 - x0^2) - y0`, for `x0 = 0` and equal bars
    /// `2 L (1 - cos a0)`.
    pub reach: f64,
    /// How far the point can move away from the pivot along the pivot -> point axis before
    /// the bars are in line (m): `L1 + L2 - |target|` (the reach of a point that moves in
    /// the plane, a structure's node; equal to `reach` when `x0 = 0`).
    pub stretch: f64,
}

/// Places a two-bar chain (2 coordinates, no loop rows: crank on the ground pivot, coupler
/// on the crank) so that its point `point` reaches a beam point: on the point's line of
/// motion at a half-angle, or with the pivot at a given offset. The bar lengths are read off
/// the point kinematics.
///
/// # Panics
///
/// When `mechanism` does not have exactly 2 coordinates and no loop rows.
pub fn place_two_bar<M: System + ?Sized>(
    mechanism: &M,
    point: usize,
    placement: Placement,
) -> Result<TwoBar, PlacementError> {
    assert!(
        mechanism.dof() == 2 && mechanism.rows() == 0,
        "place_two_bar: a two-bar chain has 2 coordinates and no loop rows"
    );
    let (l1, l2) = bar_lengths(mechanism, point);
    if !(l1 > 0.0 && l2 > 0.0) {
        return Err(PlacementError::NotTwoBar { l1, l2 });
    }
    // The pivot-to-point distance at half-angle `deg` (module documentation).
    let distance = |deg: f64| {
        let a = deg.to_radians();
        let rad = l2 * l2 - (l1 * a.sin()).powi(2);
        if rad < 0.0 {
            return Err(PlacementError::AngleUnreachable { deg, l1, l2 });
        }
        Ok((l1 * a.cos() + rad.sqrt(), a))
    };
    let mut side = Knee::Clockwise;
    // Target of the point in the mechanism frame (pivot at the origin) and the initial guess.
    let (x0, y0, alpha) = match placement {
        Placement::HalfAngle(deg) => {
            let (d, a) = distance(deg)?;
            (0.0, d, a)
        }
        Placement::Along {
            half_angle_deg,
            direction: [dx, dy],
            knee,
        } => {
            let norm = dx.hypot(dy);
            if !(norm.is_finite() && norm > 0.0) {
                return Err(PlacementError::Direction { x: dx, y: dy });
            }
            let (d, a) = distance(half_angle_deg)?;
            side = knee;
            (-d * dx / norm, -d * dy / norm, a)
        }
        Placement::Pivot(p) => {
            let (x0, y0) = (-p[0], -p[1]);
            let d = x0.hypot(y0);
            let c = (l1 * l1 + d * d - l2 * l2) / (2.0 * l1 * d);
            if !(-1.0..=1.0).contains(&c) {
                return Err(PlacementError::PivotUnreachable { d, l1, l2 });
            }
            (x0, y0, c.acos())
        }
    };
    let d = x0.hypot(y0);
    let theta = y0.atan2(x0);
    let knee = ((l1 * l1 + l2 * l2 - d * d) / (2.0 * l1 * l2))
        .clamp(-1.0, 1.0)
        .acos();
    // The stretched mechanism (bars in line) bounds the beam point's travel:
    // |p - pivot| <= L1 + L2, i.e. for x0 = 0 and equal bars 2 L (1 - cos a0).
    let reach = ((l1 + l2).powi(2) - x0 * x0).max(0.0).sqrt() - y0;
    // The crank turned from the pivot -> point axis towards the knee's side; the coupler
    // bent back by the knee's exterior angle.
    let guess = match side {
        Knee::Clockwise => [theta - alpha, std::f64::consts::PI - knee],
        Knee::CounterClockwise => [theta + alpha, knee - std::f64::consts::PI],
    };
    Ok(TwoBar {
        target: [x0, y0],
        guess,
        reach,
        stretch: l1 + l2 - d,
    })
}

/// The beam's initial deflection of a free decay released from a beam point: the static shape of a transverse load
/// at `point`, scaled so that the point is displaced by `displacement` (m).
pub fn initial_deflection(
    beam: &BeamModel,
    point: &BeamPoint,
    displacement: f64,
) -> Result<Vec<f64>, BeamError> {
    let mut p = vec![0.0; beam.dof_count()];
    point.add_force(1.0, &mut p);
    let shape = beam.static_deflection(&p)?;
    let y1 = point.value(&shape);
    Ok(shape.iter().map(|s| s * displacement / y1).collect())
}
