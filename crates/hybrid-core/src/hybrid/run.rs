//! The run loop of a hybrid system: integrate from a state to `t_end`, hand the state and
//! its stored energies to a caller's sink at the output steps (so that rows can be
//! streamed), and keep the figures of the run (wall time, steps, re-partitions, the worst
//! energy-balance error).
//!
//! The energy balance (see [`Account`]) is
//!
//! ```text
//! error = (E_0 + W_beam loads + sum W_excitations + sum W_model)
//!         - (E + D_structure + sum D_elements + sum D_model)
//! ```
//!
//! with `D_model`, `W_model` the dissipation and the input work of each mechanism model's own
//! force elements (its dampers; its constant joint forces and external loads), integrated
//! like the scenario's elements (docs/theory.md section 8).
//!
//! with `E` the stored energy ([`Stored::total`]). The stored energies cost quadratic forms
//! and a mechanism evaluation each, so they are computed only at the output steps, and the
//! worst error is the worst over those.

use std::time::{Duration, Instant};

use super::error::HybridError;
use super::integrator::{Account, HybridState, Integrator, Repartition, Stored};
use super::model::HybridModel;

/// When to call the sink and when to stop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunOptions {
    /// End time (s); the run takes `round((t_end - t) / dt)` steps.
    pub t_end: f64,
    /// Call the sink every `every` steps (and at the start and the end).
    pub every: usize,
}

/// The figures of a finished run.
#[derive(Clone, Debug, PartialEq)]
pub struct RunFigures {
    /// Wall-clock time of the integration, the sink's calls included.
    pub wall: Duration,
    /// Steps taken.
    pub steps: u64,
    /// Times the sink was called.
    pub outputs: u64,
    /// Every change of independent coordinates (logged by the integrator).
    pub repartitions: Vec<Repartition>,
    /// Stored energy at the start (J).
    pub initial_energy: f64,
    /// Largest |energy-balance error| at the output steps (J).
    pub max_balance_error: f64,
    /// The scale the relative error is taken against: the largest of the initial energy,
    /// the stored energy and the |input work| (beam loads and excitations) at the output
    /// steps (J).
    pub energy_scale: f64,
    /// `max_balance_error / energy_scale` (0 when there is no energy at all).
    pub balance_rel_error: f64,
}

/// A finished run: the final state, its stored energies and the figures.
#[derive(Clone, Debug, PartialEq)]
pub struct RunOutcome {
    /// The state at the end.
    pub state: HybridState,
    /// Its stored energies.
    pub stored: Stored,
    /// The figures of the run.
    pub figures: RunFigures,
}

/// Why a run stopped early.
#[derive(Debug, thiserror::Error)]
pub enum RunError<E> {
    /// The integration stopped (singular position, no convergence, divergence).
    #[error(transparent)]
    Hybrid(#[from] HybridError),
    /// The sink refused a row (e.g. an output file could not be written).
    #[error("output: {0}")]
    Sink(E),
}

/// Work put into the system since the start: beam loads, excitations and the mechanism
/// models' loads without potential (J).
pub fn input_work(account: &Account) -> f64 {
    account.beam_load_work
        + account.excitation_work.iter().sum::<f64>()
        + account.model_input_work.iter().sum::<f64>()
}

/// Energy dissipated since the start: the structure's Rayleigh damping, the scenario's force
/// elements, the mechanism models' own dampers and the generators' conversion mismatch
/// ([`Account::conversion`], zero for ideal machines) (J).
pub fn dissipated(account: &Account) -> f64 {
    let d = account.dissipated_structure
        + account.dissipated.iter().sum::<f64>()
        + account.dissipated_model.iter().sum::<f64>();
    // Added only when there is a mismatch: the ideal machines' balance stays bit for bit.
    if account.conversion.iter().any(|&c| c != 0.0) {
        d + account.conversion.iter().sum::<f64>()
    } else {
        d
    }
}

/// The energy-balance error `(E_0 + W) - (E + D)` (J) of a state with stored energies
/// `stored`, `initial` the stored energy at the start.
pub fn balance_error(initial: f64, stored: &Stored, account: &Account) -> f64 {
    (initial + input_work(account)) - (stored.total() + dissipated(account))
}

/// Integrates `model` from `state` to `options.t_end` with `integrator` (whose step is the
/// time step), calling `sink` with the state, its stored energies and the integrator (for
/// quantities of the last solve, e.g. [`Integrator::amplification`]) at the start, every
/// `options.every` steps and at the end, and `progress` with the fraction done about 200
/// times. The step itself allocates nothing; the sink decides what happens to the rows.
pub fn run<E>(
    model: &HybridModel,
    integrator: &mut Integrator,
    state: HybridState,
    options: RunOptions,
    sink: &mut dyn FnMut(&HybridState, &Stored, &mut Integrator) -> Result<(), E>,
    progress: &mut dyn FnMut(f64),
) -> Result<RunOutcome, RunError<E>> {
    // No observer: the empty closure's calls vanish from the loop.
    run_observed(
        model,
        integrator,
        state,
        options,
        &mut |_| {},
        sink,
        progress,
    )
}

/// [`run`] with an observer of every step: `each_step` sees the state at the start and after
/// every step (before the sink at an output step), at the integrator's own rate — what a
/// figure sampled at every step needs (a spectrum up to the step's Nyquist frequency), at
/// the cost of the observer alone (no stored energies are computed for it). The observer is
/// a type parameter, so that a closure is inlined into the loop (a `&mut dyn FnMut` works
/// too, at the cost of a call a step).
///
/// The steps between two events (a row, a progress report, the end) are taken in an inner
/// loop that tests nothing but its count: the events come at the same steps as with a test
/// after every step.
pub fn run_observed<E, F>(
    model: &HybridModel,
    integrator: &mut Integrator,
    mut state: HybridState,
    options: RunOptions,
    each_step: &mut F,
    sink: &mut dyn FnMut(&HybridState, &Stored, &mut Integrator) -> Result<(), E>,
    progress: &mut dyn FnMut(f64),
) -> Result<RunOutcome, RunError<E>>
where
    F: FnMut(&HybridState) + ?Sized,
{
    let start = Instant::now();
    let every = options.every.max(1) as u64;
    let dt = integrator.step_size();
    let steps = if dt > 0.0 {
        ((options.t_end - state.t) / dt).round().max(0.0) as u64
    } else {
        0
    };
    let mut stored = Stored::default();
    integrator.stored_into(model, &state, &mut stored);
    let e0 = stored.total();
    let mut worst: f64 = 0.0;
    let mut scale = e0.abs();
    let mut outputs = 0;
    let mut output = |state: &HybridState,
                      stored: &Stored,
                      integrator: &mut Integrator,
                      worst: &mut f64,
                      scale: &mut f64|
     -> Result<(), RunError<E>> {
        let err = balance_error(e0, stored, &state.account);
        *worst = worst.max(err.abs());
        *scale = scale
            .max(stored.total().abs())
            .max(input_work(&state.account).abs());
        outputs += 1;
        sink(state, stored, integrator).map_err(RunError::Sink)
    };
    each_step(&state);
    output(&state, &stored, integrator, &mut worst, &mut scale)?;
    let report = (steps / 200).max(1);
    // Steps taken, steps to the next row and to the next progress report: the rows at the
    // multiples of `every` and at the end, the reports at the multiples of `report`.
    let (mut k, mut to_row, mut to_report) = (0, every, report);
    while k < steps {
        // At least one step (each count is at least 1), so the loop ends after `steps`.
        let n = to_row.min(to_report).min(steps - k);
        for _ in 0..n {
            integrator.step(model, &mut state)?;
            each_step(&state);
        }
        k += n;
        to_row -= n;
        to_report -= n;
        if to_row == 0 || k == steps {
            to_row = every;
            integrator.stored_into(model, &state, &mut stored);
            output(&state, &stored, integrator, &mut worst, &mut scale)?;
        }
        if to_report == 0 {
            to_report = report;
            progress(k as f64 / steps as f64);
        }
    }
    progress(1.0);
    let figures = RunFigures {
        wall: start.elapsed(),
        steps,
        outputs,
        repartitions: integrator.repartitions.clone(),
        initial_energy: e0,
        max_balance_error: worst,
        energy_scale: scale,
        balance_rel_error: if scale > 0.0 { worst / scale } else { 0.0 },
    };
    Ok(RunOutcome {
        state,
        stored,
        figures,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hybrid::Method;
    use crate::hybrid::{BeamPoint, Excitation, ExcitationTarget, initial_state};
    use fem_beam::{Beam, BeamModel, TimeFunction};

    fn cantilever() -> BeamModel {
        let text = r#"
[[segment]]
length = 1.0
youngs_modulus = 210e9
density = 7850.0
width = 0.04
height = 0.008
elements = 8
[[support]]
x = 0.0
kind = "clamped"
[damping]
ratios = [{ mode = 1, ratio = 0.01 }, { mode = 2, ratio = 0.01 }]
"#;
        BeamModel::new(&Beam::from_toml_str(text, "c.toml").unwrap()).unwrap()
    }

    /// A forced beam: the sink sees the start, every `every`-th step and the end; the
    /// energy balance of the trapezoidal account closes to round-off under the average
    /// acceleration rule (a linear system: the scheme conserves the discrete energy).
    #[test]
    fn sink_is_called_at_output_steps_and_the_balance_closes() {
        let beam = cantilever();
        let tip = BeamPoint::on(&beam, 1.0).unwrap();
        let n = beam.dof_count();
        let model = HybridModel::new(
            Some(beam.into()),
            vec![],
            vec![],
            vec![],
            vec![Excitation {
                name: "shaker".into(),
                target: ExcitationTarget::Beam(tip),
                amplitude: 0.5,
                time: TimeFunction::Table {
                    points: vec![[0.0, 0.0], [0.01, 1.0], [0.05, -1.0]],
                },
            }],
        )
        .unwrap();
        let state = initial_state(&model, vec![0.0; n], vec![0.0; n]).unwrap();
        let mut integrator = Integrator::new(&model, Method::Newmark, 1e-4, &state).unwrap();
        let mut times = vec![];
        let mut reports = vec![];
        let out = run::<()>(
            &model,
            &mut integrator,
            state,
            RunOptions {
                t_end: 0.1005,
                every: 100,
            },
            &mut |s, e, _| {
                assert!(e.total().is_finite());
                times.push(s.t);
                Ok(())
            },
            &mut |f| reports.push(f),
        )
        .unwrap();
        // 1005 steps: rows at 0, 100, ..., 1000 and the last step.
        assert_eq!(out.figures.steps, 1005);
        // Progress at every 5th step (1005 / 200) and at the end.
        let expected: Vec<f64> = (1..=1005u32)
            .filter(|k| k % 5 == 0)
            .map(|k| f64::from(k) / 1005.0)
            .chain([1.0])
            .collect();
        assert_eq!(reports, expected);
        assert_eq!(times.len(), 12);
        assert_eq!(out.figures.outputs, 12);
        assert!((times[1] - 0.01).abs() < 1e-12 && (times[11] - 0.1005).abs() < 1e-12);
        assert!(out.state.account.excitation_work[0] != 0.0);
        assert!(out.figures.balance_rel_error < 1e-10, "{:?}", out.figures);
    }

    /// The step observer sees the start and every step, in order, at the step's times;
    /// the run's figures and final state are those of [`run`] (bit for bit).
    #[test]
    fn the_step_observer_sees_every_step() {
        let beam = cantilever();
        let n = beam.dof_count();
        let model = HybridModel::new(Some(beam.into()), vec![], vec![], vec![], vec![]).unwrap();
        let mut q = vec![0.0; n];
        q[n - 2] = 1e-3;
        let state = initial_state(&model, q, vec![0.0; n]).unwrap();
        let options = RunOptions {
            t_end: 0.0105,
            every: 10,
        };
        let mut integrator = Integrator::new(&model, Method::Newmark, 1e-4, &state).unwrap();
        let mut seen = vec![];
        let observed = run_observed::<(), _>(
            &model,
            &mut integrator,
            state.clone(),
            options,
            &mut |s| seen.push((s.t, s.q[n - 2])),
            &mut |_, _, _| Ok(()),
            &mut |_| {},
        )
        .unwrap();
        let mut integrator = Integrator::new(&model, Method::Newmark, 1e-4, &state).unwrap();
        let plain = run::<()>(
            &model,
            &mut integrator,
            state.clone(),
            options,
            &mut |_, _, _| Ok(()),
            &mut |_| {},
        )
        .unwrap();
        // 105 steps and the start; as a `dyn` observer too.
        assert_eq!(seen.len(), 106);
        let mut count = 0;
        let observer: &mut dyn FnMut(&HybridState) = &mut |_| count += 1;
        let mut integrator = Integrator::new(&model, Method::Newmark, 1e-4, &state).unwrap();
        let dynamic = run_observed::<(), _>(
            &model,
            &mut integrator,
            state.clone(),
            options,
            observer,
            &mut |_, _, _| Ok(()),
            &mut |_| {},
        )
        .unwrap();
        assert_eq!(count, 106);
        assert_eq!(dynamic.state, observed.state);
        for (k, (t, _)) in seen.iter().enumerate() {
            assert!((t - k as f64 * 1e-4).abs() < 1e-15, "{k}: {t}");
        }
        assert_eq!(seen[0].1, 1e-3);
        assert_eq!(seen[105].1, observed.state.q[n - 2]);
        assert_eq!(observed.state, plain.state);
        assert_eq!(observed.figures.outputs, plain.figures.outputs);
    }

    /// A sink error stops the run and is handed back.
    #[test]
    fn a_sink_error_stops_the_run() {
        let beam = cantilever();
        let n = beam.dof_count();
        let model = HybridModel::new(Some(beam.into()), vec![], vec![], vec![], vec![]).unwrap();
        let mut q = vec![0.0; n];
        q[n - 2] = 1e-3;
        let state = initial_state(&model, q, vec![0.0; n]).unwrap();
        let mut integrator = Integrator::new(&model, Method::Newmark, 1e-4, &state).unwrap();
        let mut calls = 0;
        let e = run(
            &model,
            &mut integrator,
            state,
            RunOptions {
                t_end: 1.0,
                every: 10,
            },
            &mut |_, _, _| {
                calls += 1;
                if calls == 3 { Err("disk full") } else { Ok(()) }
            },
            &mut |_| {},
        )
        .unwrap_err();
        assert!(matches!(e, RunError::Sink("disk full")), "{e}");
        assert_eq!(calls, 3);
    }
}
