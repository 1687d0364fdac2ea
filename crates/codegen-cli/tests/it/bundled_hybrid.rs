//! The bundled hybrid scenarios (`scenarios/*.toml` of kind "hybrid", loaded and built by
//! the application): along their runs the engine's accelerations equal the full constrained
//! system's, and their steps allocate nothing (counting allocator installed in `main.rs`).
//! The same properties on hybrid systems built without the application are hybrid-core's
//! tests (`hybrid_reference`, `step_alloc`).

use crate::common;

use damper_e2e::alloc_counter::allocations;
use hybrid_core::hybrid::Integrator;

/// Every bundled hybrid scenario's shape (two double bars; the absorber with its free
/// coordinate on a roller; the slider-crank with its loop on a roller; the forced damper):
/// along 0.2 s of its run, the partitioned accelerations (beam and every mechanism
/// coordinate) equal those of the full constrained system with multipliers, all
/// coordinates and lambda solved together (`hybrid::reference`, dense KKT), to 1e-10 of the
/// largest acceleration of the block over the compared states (for the beam, or of its
/// elastic acceleration A^-1 C q, if larger).
#[test]
fn bundled_hybrid_shapes_match_the_full_constrained_system() {
    use codegen_cli::scenario::{self, Scenario};
    use hybrid_core::hybrid::reference;
    let files = common::bundled_scenarios();
    let mut checked = 0;
    for path in &files {
        let Scenario::Hybrid(sc) = scenario::load(path).unwrap() else {
            continue;
        };
        // The reference formulation assembles the beam's dense matrices: beam hosts only (an
        // imported structure's runs are checked against the beam written as matrices,
        // `structure_cli`).
        if sc.structure.is_some() {
            continue;
        }
        let built = codegen_cli::setup::build(&sc).unwrap_or_else(|e| panic!("{e}"));
        let model = &built.model;
        let mut state = built.state.clone();
        let mut integ = Integrator::new(model, sc.method, sc.integrator.dt, &state).unwrap();
        // (engine, reference) pairs of every compared state, per block.
        let (mut beam, mut mech) = (vec![], vec![]);
        let mut beam_scale = 0.0f64;
        for k in 0..=2000 {
            if k % 200 == 0 {
                let mq: Vec<Vec<f64>> = state.mechanisms.iter().map(|m| m.q.clone()).collect();
                let mqd: Vec<Vec<f64>> = state.mechanisms.iter().map(|m| m.qd.clone()).collect();
                let (a, qdd, _) = reference::accelerations(
                    model,
                    state.t,
                    &state.q,
                    &state.v,
                    &mq,
                    &mqd,
                    &state.currents,
                );
                // The beam block's scale includes the elastic acceleration A^-1 C q: where the
                // accelerations pass through zero, the elastic and inertial terms still cancel
                // at that size, and round-off is relative to it.
                let b = model.beam().unwrap();
                let mut elastic = vec![0.0; state.q.len()];
                b.stiffness().mul_add_into(1.0, &state.q, &mut elastic);
                b.mass().factorize().unwrap().solve_in_place(&mut elastic);
                beam_scale = elastic.iter().fold(beam_scale, |m, x| m.max(x.abs()));
                beam.extend(state.a.iter().copied().zip(a));
                for (m, r) in state.mechanisms.iter().zip(&qdd) {
                    mech.extend(m.qdd.iter().copied().zip(r.iter().copied()));
                }
            }
            integ.step(model, &mut state).unwrap();
        }
        for (what, pairs, floor) in [("beam", &beam, beam_scale), ("mechanism", &mech, 0.0)] {
            let scale = pairs.iter().fold(floor, |m, (_, r)| m.max(r.abs()));
            let worst = pairs.iter().fold(0.0f64, |m, (e, r)| m.max((e - r).abs()));
            eprintln!(
                "{}: {what}: {:.2e} of {scale:.3e}",
                path.display(),
                worst / scale
            );
            assert!(
                worst <= 1e-10 * scale,
                "{}: {what} accelerations differ by {:.2e} of {scale:.3e}",
                path.display(),
                worst / scale
            );
        }
        checked += 1;
    }
    assert!(checked >= 4, "{checked} hybrid scenarios");
}

/// Every bundled hybrid scenario (scenarios/*.toml of kind "hybrid": two dampers, the
/// absorber with its free coordinate, the slider-crank with its loop, the forced damper)
/// steps without allocating, stored energies at output steps included.
#[test]
fn every_bundled_hybrid_scenario_steps_without_allocating() {
    use codegen_cli::scenario::{self, Scenario};
    use hybrid_core::hybrid::{Integrator as HybridIntegrator, Stored};
    let files = common::bundled_scenarios();
    let mut checked = 0;
    for path in &files {
        let Scenario::Hybrid(sc) = scenario::load(path).unwrap() else {
            continue;
        };
        let built = codegen_cli::setup::build(&sc).unwrap_or_else(|e| panic!("{e}"));
        let mut state = built.state.clone();
        let mut integ =
            HybridIntegrator::new(&built.model, sc.method, sc.integrator.dt, &state).unwrap();
        let mut stored = Stored::default();
        integ.step(&built.model, &mut state).unwrap();
        integ.stored_into(&built.model, &state, &mut stored);
        let before = allocations();
        for k in 0..2000 {
            integ.step(&built.model, &mut state).unwrap();
            if k % 10 == 0 {
                integ.stored_into(&built.model, &state, &mut stored);
            }
        }
        let after = allocations();
        assert!(state.q.iter().all(|x| x.is_finite()) && stored.total().is_finite());
        assert_eq!(
            after - before,
            0,
            "{}: {} allocations in 2000 steps",
            path.display(),
            after - before
        );
        checked += 1;
    }
    assert!(checked >= 4, "{checked} hybrid scenarios");
}

/// The response spectrum's estimator, fed at every step of a random run, allocates
/// nothing once built: 39 segments of 1024 samples of 8 signals (the FFTs included, an odd
/// signal transformed alone), counted by the allocator.
#[test]
fn the_spectrum_estimator_does_not_allocate_per_sample() {
    use codegen_cli::report::random_psd::Welch;
    for signals in [8, 7] {
        let mut w = Welch::new(signals, 1024, 1e4);
        let mut x = vec![0.0; signals];
        let before = allocations();
        for n in 0..1024 * 20 {
            let t = n as f64 * 1e-4;
            for (k, x) in x.iter_mut().enumerate() {
                *x = (t * (k + 1) as f64).sin();
            }
            w.push(&x);
        }
        let after = allocations();
        assert_eq!(w.segments(), 39);
        assert_eq!(after - before, 0, "{} allocations", after - before);
    }
}
