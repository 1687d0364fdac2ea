//! The design reading of a sweep: which points satisfy every constraint, and the best of
//! them by the map's figure.

use super::grid::{Grid, SpecError};
use super::part::SweepSpec;
use super::point::{PointResult, margin};
use crate::Error;
use crate::analysis::figures::Constraint;
use crate::report::csv::cell;
use crate::scenario::overrides::value_text;

/// The design reading of a sweep: which points satisfy every constraint, and the best of
/// them by the map's figure (the lowest index among equals).
pub struct Design {
    /// The constraints.
    pub constraints: Vec<Constraint>,
    /// Per point (in grid order): whether it satisfies every constraint (a failed point, or
    /// one without a constrained figure, does not).
    pub feasible: Vec<bool>,
    /// The best feasible point and its value of the map's figure.
    pub best: Option<(usize, f64)>,
}

impl Design {
    /// Reads `rows` (every point, in grid order) against the spec's constraints and map.
    pub fn of(spec: &SweepSpec, rows: &[&PointResult]) -> Result<Design, Error> {
        let constraints = spec
            .constraints
            .iter()
            .map(|c| c.parse::<Constraint>()?.resolve(None))
            .collect::<Result<Vec<_>, _>>()
            .map_err(SpecError::from)?;
        let feasible: Vec<bool> = rows
            .iter()
            .map(|r| {
                r.error.is_none()
                    && constraints
                        .iter()
                        .all(|c| margin(c, r).is_some_and(|m| m >= 0.0))
            })
            .collect();
        let mut best: Option<(usize, f64)> = None;
        for (r, ok) in rows.iter().zip(&feasible) {
            let value = r
                .figures
                .iter()
                .find(|f| f.name == spec.map)
                .and_then(|f| f.value);
            if let (true, Some(v)) = (*ok, value) {
                let better = match best {
                    None => true,
                    Some((_, b)) if spec.minimize => v < b,
                    Some((_, b)) => v > b,
                };
                if better {
                    best = Some((r.index, v));
                }
            }
        }
        Ok(Design {
            constraints,
            feasible,
            best,
        })
    }

    /// One line: the best feasible point with its fields and figure, or that no point
    /// satisfies the constraints.
    pub fn describe(&self, spec: &SweepSpec, grid: &Grid) -> String {
        let feasible = self.feasible.iter().filter(|f| **f).count();
        let of = if self.constraints.is_empty() {
            String::new()
        } else {
            let c: Vec<&str> = self.constraints.iter().map(|c| c.text.as_str()).collect();
            format!(" ({feasible} point(s) satisfy {})", c.join(", "))
        };
        match self.best {
            Some((index, value)) => {
                let at: Vec<String> = grid
                    .axes
                    .iter()
                    .zip(grid.point(index))
                    .map(|(a, v)| format!("{}={}", a.path, value_text(v)))
                    .collect();
                let which = if spec.minimize { "lowest" } else { "highest" };
                format!(
                    "best feasible point{of}: #{index} {}: {} = {} ({which})",
                    at.join(" "),
                    spec.map,
                    cell(Some(value))
                )
            }
            None if !self.constraints.is_empty() && feasible == 0 => {
                format!("no grid point satisfies the constraints{of}")
            }
            None => format!("no point gives {}{of}", spec.map),
        }
    }
}
