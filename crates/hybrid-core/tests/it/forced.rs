//! The forced response (issue #11, item 4): the nonlinear steady state from time-domain runs
//! ([`hybrid_core::hybrid::steady_states`]) against the linear receptance of the
//! linearisation ([`Linearization::harmonic_response`]).
//!
//! The average-acceleration rule is the bilinear transform: on a linear system its steady
//! response at `omega` is exactly the continuous one at `(2/h) tan(omega h / 2)`
//! ([`warped_frequency`]); the comparisons are made there, so that what is measured is the
//! steady-state extraction (fit, settling) and the system's own nonlinearity, not the
//! scheme's period error (printed too, against the unwarped receptance).

use crate::common;

use std::f64::consts::PI;

use common::*;
use fem_beam::TimeFunction;
use hybrid_core::hybrid::{
    BeamPoint, EigenMethod, EquilibriumOptions, Excitation, ExcitationTarget, HybridModel,
    Linearization, SteadyOptions, SteadyState, modes, rest_state, steady_states, warped_frequency,
};
use nalgebra::Complex;

fn linearize(model: &HybridModel) -> Linearization {
    let t = tangents(model, &[]);
    let refs: Vec<_> = t.iter().collect();
    Linearization::new(model, &refs, EquilibriumOptions::default()).unwrap()
}

/// The receptance at the beam point `p` for a unit force there, at `omega` (rad/s).
fn receptance(lin: &Linearization, p: &BeamPoint, omega: f64) -> Complex<f64> {
    let f = lin.force_vector(&ExcitationTarget::Beam(p.clone()));
    let z = lin.harmonic_response(&f, omega).unwrap();
    let re: Vec<f64> = z.iter().map(|v| v.re).collect();
    let im: Vec<f64> = z.iter().map(|v| v.im).collect();
    Complex::new(p.value(&re), p.value(&im))
}

fn with_shaker(mut model: HybridModel, p: &BeamPoint, amplitude: f64) -> HybridModel {
    model.excitations.push(Excitation {
        name: "shaker".into(),
        target: ExcitationTarget::Beam(p.clone()),
        amplitude,
        time: TimeFunction::Harmonic {
            frequency_hz: 1.0,
            phase: 0.4,
        },
    });
    model
}

/// Relative amplitude error and phase error (rad) of a steady state against `amplitude * h`.
fn errors(s: &SteadyState, h: Complex<f64>, amplitude: f64) -> (f64, f64) {
    let expected = h.norm() * amplitude;
    let mut dphi = s.phase - h.arg();
    dphi = (dphi + PI).rem_euclid(2.0 * PI) - PI;
    ((s.amplitude - expected) / expected, dphi)
}

fn run_all(
    model: &HybridModel,
    lin: &Linearization,
    tip: &BeamPoint,
    freqs: &[f64],
    options: &SteadyOptions,
) -> Vec<SteadyState> {
    let mut m = model.clone();
    let start = rest_state(&mut m, &lin.equilibrium).unwrap();
    steady_states(
        &m,
        &start,
        &ExcitationTarget::Beam(tip.clone()),
        freqs,
        options,
        &|| {},
    )
    .into_iter()
    .map(|r| r.unwrap_or_else(|e| panic!("{e}")))
    .collect()
}

#[test]
fn bare_beam_steady_state_is_the_linear_receptance() {
    // 1 % Rayleigh damping on modes 1 and 2 (the transient at resonance decays by 1e-3 in
    // about 110 periods).
    let bm = beam(20, &[(0.0, "clamped")], Some(0.01));
    let f1 = bm.modes(1).unwrap().frequencies_hz()[0];
    let tip = BeamPoint::on(&bm, 1.0).unwrap();
    let model = HybridModel::new(Some(bm.into()), vec![], vec![], vec![], vec![]).unwrap();
    let lin = linearize(&model);
    let amplitude = 0.5;
    let model = with_shaker(model, &tip, amplitude);
    let options = SteadyOptions {
        steps_per_period: 64,
        tolerance: 1e-3,
        // At 30 Hz the first mode's transient (started by the force's jump at t = 0, phase
        // 0.4) is 1e3 times the tiny forced response and decays at zeta_1 omega_1: about
        // 1,100 periods.
        max_periods: 3000,
        ..SteadyOptions::default()
    };
    let freqs = [2.0, 0.98 * f1, f1, 12.0, 30.0];
    let found = run_all(&model, &lin, &tip, &freqs, &options);
    for s in &found {
        let omega = 2.0 * PI * s.frequency_hz;
        let h = receptance(&lin, &tip, warped_frequency(omega, s.dt));
        let h0 = receptance(&lin, &tip, omega);
        let (ea, ep) = errors(s, h, amplitude);
        let (ea0, ep0) = errors(s, h0, amplitude);
        println!(
            "bare beam f = {:.4} Hz: A = {:.6e} m, phi = {:.5} rad, {} periods, settled {}, distortion {:.1e}; vs H(warped): {ea:.1e} / {ep:.1e} rad; vs H(omega): {ea0:.1e} / {ep0:.1e} rad",
            s.frequency_hz, s.amplitude, s.phase, s.periods, s.settled, s.distortion
        );
        assert!(s.settled, "{s:?}");
        // The settle tolerance 1e-3 bounds the transient left (estimated by its geometric
        // tail); the fit itself is exact.
        assert!(ea.abs() < 1e-3 && ep.abs() < 1e-3, "{s:?}: {ea:e} {ep:e}");
        assert!(
            s.distortion < 1e-3,
            "a linear system has no harmonics: {s:?}"
        );
    }
}

#[test]
fn paper_damper_small_amplitude_is_linear_and_large_amplitude_is_not() {
    let (model, _) = paper_damper(20, true, true, 0.0);
    let lin = linearize(&model);
    let first = &modes(&lin, 1, EigenMethod::Dense).unwrap()[0];
    let fd = first.damped_frequency_hz;
    println!(
        "damper: first mode {:.4} Hz, zeta {:.4}",
        first.natural_frequency_hz, first.damping_ratio
    );
    let tip = BeamPoint::on(model.beam().unwrap(), 1.0).unwrap();
    let reach = model.mechanisms[0].reach.expect("the double bar's reach");
    let peak = receptance(&lin, &tip, 2.0 * PI * fd).norm();
    let options = SteadyOptions {
        steps_per_period: 100,
        tolerance: 1e-3,
        ..SteadyOptions::default()
    };
    let freqs = [0.7 * fd, fd, 1.3 * fd];
    // Small: a tip amplitude of 1e-3 of the reach at resonance.
    let small = 1e-3 * reach / peak;
    let found = run_all(
        &with_shaker(model.clone(), &tip, small),
        &lin,
        &tip,
        &freqs,
        &options,
    );
    for s in &found {
        let h = receptance(
            &lin,
            &tip,
            warped_frequency(2.0 * PI * s.frequency_hz, s.dt),
        );
        let (ea, ep) = errors(s, h, small);
        println!(
            "small F = {small:.3e} N, f = {:.4} Hz: A = {:.4e} m, {} periods, settled {}, distortion {:.1e}; vs linear {ea:.2e} / {ep:.2e} rad",
            s.frequency_hz, s.amplitude, s.periods, s.settled, s.distortion
        );
        assert!(s.settled, "{s:?}");
        assert!(ea.abs() < 1e-2 && ep.abs() < 1e-2, "{s:?}: {ea:e} {ep:e}");
        // The measured mean powers: the generator's against the linear steady state (its
        // current `k_e n i omega' q_j / (R + i omega' L)`, omega' the warped frequency, at
        // which the scheme's velocity is `i omega'` times its displacement; a sampled
        // sinusoid's trapezoidal mean square over a whole period is `|i|^2 / 2`), and the
        // excitation's input against the total dissipation (a periodic state stores nothing
        // over a period).
        let omega = warped_frequency(2.0 * PI * s.frequency_hz, s.dt);
        let f = lin.force_vector(&ExcitationTarget::Beam(tip.clone()));
        let motion = lin.mechanism_motion(&lin.harmonic_response(&f, omega).unwrap());
        for (k, e) in model.forces.iter().enumerate() {
            let Some(g) = e.generator() else { continue };
            let speed = motion[e.mechanism][e.joint] * Complex::new(0.0, omega) * g.gear_ratio;
            let current = g.ke * speed / Complex::new(g.resistance(), omega * g.inductance);
            let linear = 0.5 * g.resistance() * (small * current).norm_sqr();
            let rel = (s.mean_power_dissipated[k] - linear) / linear;
            println!(
                "  generator power {:.6e} W, linear {linear:.6e} W ({rel:.1e})",
                s.mean_power_dissipated[k]
            );
            assert!(rel.abs() < 2e-2, "{s:?}: {rel:e}");
        }
        let input: f64 = s.mean_input_power.iter().sum();
        let dissipated = s.mean_power_structure + s.mean_power_dissipated.iter().sum::<f64>();
        let rel = (input - dissipated) / dissipated;
        println!("  input {input:.6e} W, dissipated {dissipated:.6e} W ({rel:.1e})");
        assert!(rel.abs() < 1e-2, "{s:?}: {rel:e}");
    }
    // The same results, in the same order, on one thread and on two.
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let again = pool.install(|| {
            run_all(
                &with_shaker(model.clone(), &tip, small),
                &lin,
                &tip,
                &freqs,
                &options,
            )
        });
        assert_eq!(again, found, "{threads} thread(s)");
    }
    // Large: the linear tip amplitude at resonance is 70 % of the reach.
    let large = 0.7 * reach / peak;
    let found = run_all(
        &with_shaker(model, &tip, large),
        &lin,
        &tip,
        &[fd],
        &options,
    );
    let s = &found[0];
    let h = receptance(&lin, &tip, warped_frequency(2.0 * PI * fd, s.dt));
    let (ea, ep) = errors(s, h, large);
    println!(
        "large F = {large:.3e} N (reach {reach:.3e} m), f = {fd:.4} Hz: A = {:.4e} m, {} periods, settled {}, distortion {:.2e}; vs linear {ea:.3e} / {ep:.3e} rad",
        s.amplitude, s.periods, s.settled, s.distortion
    );
    assert!(
        ea.abs() > 0.05,
        "near the toggle the response is not linear: {ea:e}"
    );
}

#[test]
fn a_stop_ends_every_run_after_its_first_period_and_no_stop_changes_nothing() {
    let bm = beam(10, &[(0.0, "clamped")], Some(0.01));
    let tip = BeamPoint::on(&bm, 1.0).unwrap();
    let model = HybridModel::new(Some(bm.into()), vec![], vec![], vec![], vec![]).unwrap();
    let lin = linearize(&model);
    let model = with_shaker(model, &tip, 0.5);
    let options = SteadyOptions {
        steps_per_period: 32,
        max_periods: 200,
        ..SteadyOptions::default()
    };
    let freqs = [2.0, 5.0];
    let free = run_all(&model, &lin, &tip, &freqs, &options);
    let never = run_all(
        &model,
        &lin,
        &tip,
        &freqs,
        &SteadyOptions {
            stop: Some(|| false),
            ..options
        },
    );
    assert_eq!(free, never);
    assert!(free.iter().all(|s| s.periods > 1));
    let stopped = run_all(
        &model,
        &lin,
        &tip,
        &freqs,
        &SteadyOptions {
            stop: Some(|| true),
            ..options
        },
    );
    for s in &stopped {
        assert!(
            s.periods == 1 && !s.settled && s.amplitude.is_finite(),
            "{s:?}"
        );
    }
}
