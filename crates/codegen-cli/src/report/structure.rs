//! What a run's host structure is (issue #30): the beam or an imported model, its size,
//! and for a Craig–Bampton reduction its check — the reduced bare structure's natural
//! frequencies against the full model's up to the cutoff (the highest fixed-interface mode
//! kept), a warning when an excitation (a harmonic's frequency, a random excitation's band)
//! reaches above that cutoff, and in `damper linearize` the first coupled mode against the
//! full model's.
//!
//! Each reduced frequency lies at or above the full model's (the reduced model is a
//! Rayleigh–Ritz projection of the full one), and the agreement improves as modes are
//! added; the report gives the relative difference per mode so that the cutoff can be
//! chosen for the band that matters (docs/theory.md section 13).

use std::f64::consts::PI;

use fem_beam::TimeFunction;
use hybrid_core::hybrid::{HybridModel, LinearStructure, Structure};
use serde::Serialize;

/// Modes compared at most.
pub const CHECKED_MODES: usize = 10;

/// The host structure of a run.
#[derive(Clone, Debug, Serialize)]
pub struct StructureReport {
    /// `beam`, `matrices` or `matrices, Craig–Bampton`.
    pub kind: &'static str,
    /// Equations of the model (the full model of a reduction).
    pub equations: usize,
    /// Coordinates the engine integrates (the reduced ones of a reduction).
    pub coordinates: usize,
    /// The reduction's check, when reduced.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reduction: Option<ReductionCheck>,
}

/// A Craig–Bampton reduction and its check.
#[derive(Clone, Debug, Serialize)]
pub struct ReductionCheck {
    /// Interface DOFs kept.
    pub interface: usize,
    /// Fixed-interface modes kept.
    pub modes: usize,
    /// The highest fixed-interface frequency kept (Hz): the cutoff.
    pub cutoff_hz: f64,
    /// The full model's lowest natural frequencies up to the cutoff (Hz; at most
    /// [`CHECKED_MODES`]).
    pub full_hz: Vec<f64>,
    /// The reduced bare structure's (Hz), mode for mode.
    pub reduced_hz: Vec<f64>,
    /// The largest `(reduced - full) / full` over them.
    pub max_relative_error: f64,
    /// An excitation above the cutoff (a harmonic's frequency, a random excitation's band),
    /// or the check that could not be made.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
    /// The first coupled mode (generators connected) of the reduced model against the full
    /// model's: `damper linearize` only (a simulation does not linearise the full model).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub first_coupled: Option<CoupledCheck>,
}

/// The first coupled mode of a reduced model against the full model's, or why it was not
/// compared.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum CoupledCheck {
    /// Both linearised.
    Compared {
        /// The reduced model's natural frequency (Hz).
        reduced_hz: f64,
        /// The full model's (Hz).
        full_hz: f64,
        /// The reduced model's damping ratio.
        reduced_damping_ratio: f64,
        /// The full model's.
        full_damping_ratio: f64,
        /// `(reduced - full) / full` of the frequency.
        frequency_error: f64,
        /// `(reduced - full) / full` of the damping ratio.
        damping_error: f64,
    },
    /// The full model's linearisation was not made: the reason (above the work limits, or
    /// its error).
    Skipped {
        /// Why.
        reason: String,
    },
}

impl StructureReport {
    /// The report of `model`'s host (`None` without one). A reduction's check solves the
    /// full model's lowest modes (sparse shift-invert) and the reduced model's (dense).
    pub fn of(model: &HybridModel) -> Option<StructureReport> {
        let s = model.structure.as_ref()?;
        let coordinates = s.dof_count();
        let (equations, reduction) = match s {
            Structure::Beam(_) | Structure::Imported(_) => (coordinates, None),
            Structure::Reduced { full, reduced } => {
                (full.dof_count(), Some(check(model, full, reduced)))
            }
        };
        Some(StructureReport {
            kind: s.kind(),
            equations,
            coordinates,
            reduction,
        })
    }
}

fn hz(eigenvalue: f64) -> f64 {
    eigenvalue.max(0.0).sqrt() / (2.0 * PI)
}

fn check(
    model: &HybridModel,
    full: &fem_structure::ImportedStructure,
    reduced: &fem_structure::Reduced,
) -> ReductionCheck {
    let cutoff_hz = reduced
        .fixed_interface
        .eigenvalues
        .last()
        .copied()
        .map_or(0.0, hz);
    let mut warning = None;
    let reduced_modes = reduced.modes(CHECKED_MODES.min(reduced.dof_count()));
    let (full_hz, reduced_hz) = match reduced_modes {
        Ok(r) => {
            let below: Vec<f64> = r
                .eigenvalues
                .iter()
                .map(|&l| hz(l))
                .filter(|&f| f <= cutoff_hz)
                .collect();
            match full.modes(below.len().max(1)) {
                Ok(f) => (
                    f.eigenvalues
                        .iter()
                        .map(|&l| hz(l))
                        .take(below.len())
                        .collect(),
                    below,
                ),
                Err(e) => {
                    warning = Some(format!("the full model's modes could not be computed: {e}"));
                    (vec![], below)
                }
            }
        }
        Err(e) => {
            warning = Some(format!(
                "the reduced model's modes could not be computed: {e}"
            ));
            (vec![], vec![])
        }
    };
    let max_relative_error = full_hz
        .iter()
        .zip(&reduced_hz)
        .map(|(f, r)| (r - f) / f)
        .fold(0.0f64, f64::max);
    let above: Vec<String> = model
        .excitations
        .iter()
        .filter_map(|e| {
            let top = fem_beam::random::top_frequency(&e.time)?;
            let what = match e.time {
                TimeFunction::Harmonic { .. } => "at",
                _ => "band up to",
            };
            (top > cutoff_hz).then(|| format!("{} ({what} {top} Hz)", e.name))
        })
        .collect();
    if !above.is_empty() && warning.is_none() {
        warning = Some(format!(
            "excitation {} above the reduction's cutoff {cutoff_hz:.4} Hz: keep more fixed-interface modes (reduction.modes)",
            above.join(", ")
        ));
    }
    ReductionCheck {
        interface: reduced.interface.len(),
        modes: reduced.fixed_interface.eigenvalues.len(),
        cutoff_hz,
        full_hz,
        reduced_hz,
        max_relative_error,
        warning,
        first_coupled: None,
    }
}
