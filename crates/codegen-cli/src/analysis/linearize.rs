//! The linearisation of a loaded scenario ([`LinearizeRequest`] → [`linearize`] →
//! [`Linearized`]), what `damper linearize` prints and Python's `Scenario.linearize`
//! returns: the static equilibrium and the first modes of the linearised reduced equations
//! `M_R z'' + C_R z' + K_R z = 0` with the generators connected, disconnected and of the
//! bare beam ([`crate::linear`]), and on request the dense `M_R`, `C_R`, `K_R`.
//!
//! **Limits** ([`crate::budget`]): before the eigen-solves, their memory and work are
//! estimated from the number of states (`2 (beam DOFs + mechanism coordinates) +
//! generators`, an upper bound), the modes and the method (dense: every state; Arnoldi:
//! `2 K + 20` Krylov vectors), for the three variants; the dense matrices take
//! `3 * 8 d^2` bytes for `d` reduced coordinates. Above 1 GiB or 1e12 flops the request is
//! refused unless `allow_long`.

use hybrid_core::hybrid::{EigenMethod, Matrix};
use nalgebra::DMatrix;

use crate::Error;
use crate::analysis::AnalysisError;
use crate::budget::{self, Quantity};
use crate::linear::{LinearReport, analyse_linearization, analyse_linearization_with};
use crate::report::structure::{CoupledCheck, StructureReport};
use crate::scenario::{Loaded, Scenario};
use crate::setup::{Linearizable, tangents_for};

/// What to compute: the linearisation of a loaded scenario.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearizeRequest {
    /// The scenario file as messages name it.
    pub file: String,
    /// Modes of each variant (at least 1).
    pub modes: usize,
    /// The eigen-solver.
    pub method: EigenMethod,
    /// Also the dense reduced matrices `M_R`, `C_R`, `K_R`.
    pub matrices: bool,
    /// Run even above the limits of [`crate::budget`].
    pub allow_long: bool,
}

/// The result of [`linearize`].
pub struct Linearized {
    /// The report (`damper linearize --json`), with the overrides applied.
    pub report: LinearReport,
    /// `(M_R, C_R, K_R)` when the request asks for them.
    pub matrices: Option<(DMatrix<f64>, DMatrix<f64>, DMatrix<f64>)>,
}

/// An eigen-solver name the command line and Python do not know.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown method {0:?}: expected auto, dense or shift-invert")]
pub struct UnknownMethod(String);

/// Parses `auto`, `dense` or `shift-invert`.
pub fn parse_method(s: &str) -> Result<EigenMethod, UnknownMethod> {
    match s {
        "auto" => Ok(EigenMethod::Auto),
        "dense" => Ok(EigenMethod::Dense),
        "shift-invert" => Ok(EigenMethod::ShiftInvert),
        other => Err(UnknownMethod(other.to_string())),
    }
}

/// Checks the options of `req` that do not need the scenario.
pub fn check(req: &LinearizeRequest) -> Result<(), Error> {
    if req.modes == 0 {
        return Err(AnalysisError::argument("--modes", "--modes must be at least 1").into());
    }
    Ok(())
}

/// The linearisation of the loaded scenario (its structure already within the budget) as
/// `req` asks ([`check`]ed); a problem of the scenario found by the lowering names the file
/// and the overrides the user wrote.
pub fn linearize(req: &LinearizeRequest, loaded: &Loaded) -> Result<Linearized, Error> {
    let remap = |e: Error| match e {
        Error::Input(d) => Error::Input(loaded.remap(d)),
        e => e,
    };
    let input = tangents_for(&loaded.scenario).map_err(remap)?;
    check_work(&req.file, &input, req.modes, req.method, req.allow_long)?;
    let (mut report, lin) =
        analyse_linearization(&req.file, &input, req.modes, req.method).map_err(remap)?;
    report.overrides = loaded.applied.records();
    report.structure = structure_report(req, loaded, &input, &report);
    let matrices = if req.matrices {
        let d = lin.dim() as f64;
        budget::refuse_above(
            &req.file,
            &[Quantity::bytes(
                "memory of M_R, C_R, K_R",
                3.0 * 8.0 * d * d,
                budget::MAX_MEMORY,
            )],
            &format!("{d} reduced coordinates: use fewer beam elements or matrices=False"),
            req.allow_long,
        )?;
        Some((
            lin.dense(Matrix::Mass),
            lin.dense(Matrix::Damping),
            lin.dense(Matrix::Stiffness),
        ))
    } else {
        None
    };
    Ok(Linearized { report, matrices })
}

/// An imported host structure's report ([`StructureReport`]; `None` on a beam); for a
/// Craig–Bampton reduction, its first coupled mode against the full model's, linearised
/// from the same scenario without the reduction when that is within the work limits
/// (shift-invert, one mode, no comparison variants).
fn structure_report(
    req: &LinearizeRequest,
    loaded: &Loaded,
    input: &Linearizable,
    report: &LinearReport,
) -> Option<StructureReport> {
    if input.model.beam().is_some() {
        // The beam's size is in its scenario; the report is about imported models.
        return None;
    }
    let mut structure = StructureReport::of(&input.model)?;
    let (Some(check), Some(reduced), Scenario::Hybrid(sc)) = (
        structure.reduction.as_mut(),
        report.modes.first(),
        &loaded.scenario,
    ) else {
        return Some(structure);
    };
    let mut full = sc.clone();
    if let Some(entry) = full.structure.as_mut() {
        entry.reduction_modes = None;
    }
    let full = Scenario::Hybrid(full);
    let first = tangents_for(&full).and_then(|full_input| {
        check_work(&req.file, &full_input, 1, EigenMethod::ShiftInvert, false)?;
        analyse_linearization_with(
            &req.file,
            &full_input,
            1,
            EigenMethod::ShiftInvert,
            false,
            None,
        )
    });
    check.first_coupled = Some(match first {
        Ok((full_report, _)) => match full_report.modes.first() {
            Some(f) => CoupledCheck::Compared {
                reduced_hz: reduced.natural_frequency_hz,
                full_hz: f.natural_frequency_hz,
                reduced_damping_ratio: reduced.damping_ratio,
                full_damping_ratio: f.damping_ratio,
                frequency_error: (reduced.natural_frequency_hz - f.natural_frequency_hz)
                    / f.natural_frequency_hz,
                damping_error: (reduced.damping_ratio - f.damping_ratio) / f.damping_ratio,
            },
            None => CoupledCheck::Skipped {
                reason: "the full model has no mode".into(),
            },
        },
        Err(e) => CoupledCheck::Skipped {
            reason: e.to_string(),
        },
    });
    Some(structure)
}

/// Refuses the eigen-solves of `modes` modes by `method` estimated above the limits unless
/// `allow_long`.
pub fn check_work(
    file: &str,
    input: &Linearizable,
    modes: usize,
    method: EigenMethod,
    allow_long: bool,
) -> Result<(), Error> {
    let states = input.first_order_states();
    let dense = method.is_dense(states);
    let (bytes, flops) = budget::eigen_work(states, modes, dense);
    budget::refuse_above(
        file,
        &[
            Quantity::bytes("memory", bytes, budget::MAX_MEMORY),
            Quantity::count("flops", 3.0 * flops, budget::MAX_FLOPS),
        ],
        &format!(
            "{states} states, {} modes, {} eigen-solver: ask fewer --modes, use --method shift-invert or a coarser beam",
            modes,
            if dense { "dense" } else { "Arnoldi" }
        ),
        allow_long,
    )
}
