//! The simulation step allocates nothing: a counting global allocator (per thread, installed
//! in `main.rs`) observes 2,000 steps of the paper's damper (generated double bar, generator
//! with and without inductance), on the rank-one oracle and on the general engine.

use crate::common;

use common::PaperDamper;
use damper_e2e::alloc_counter::allocations;
use fem_beam::TimeFunction;
use hybrid_core::hybrid::{
    Excitation, ExcitationTarget, Integrator, Method, Stored, initial_state,
};

/// The scenario's damper with the generator's `inductance` and the scheme `method`.
fn damper(inductance: f64, method: Method) -> PaperDamper {
    let mut d = PaperDamper {
        method,
        ..PaperDamper::default()
    };
    d.generator.inductance = inductance;
    d
}

const HHT: Method = Method::Hht { alpha: -0.1 };

#[test]
fn damper_step_does_not_allocate() {
    for (inductance, method) in [(0.0, Method::Newmark), (1e-4, HHT)] {
        let d = damper(inductance, method);
        let (model, guess) = d.oracle();
        let (mut state, mut integ) = d.oracle_start(&model, guess);
        integ.step(&model, &mut state).unwrap();
        let before = allocations();
        for _ in 0..2000 {
            integ.step(&model, &mut state).unwrap();
        }
        let after = allocations();
        assert!(state.q.iter().all(|x| x.is_finite()));
        assert_eq!(
            after - before,
            0,
            "{} allocations in 2000 steps (inductance {inductance}, {method:?})",
            after - before
        );
    }
}

/// The general hybrid integrator allocates nothing per step either: the paper's damper
/// (Newmark, and HHT with an inductive generator) and the damper with two more double bars
/// on the beam (three mechanisms, three attachments), and the damper under a harmonic
/// support acceleration (inertial loads on beam and mechanism, the supports' work);
/// stored energies at output steps too.
#[test]
fn hybrid_step_does_not_allocate() {
    for (inductance, method, extra, base) in [
        (0.0, Method::Newmark, 0usize, false),
        (1e-4, HHT, 0, false),
        (0.0, Method::Newmark, 2, false),
        (0.0, Method::Newmark, 0, true),
    ] {
        let d = damper(inductance, method);
        let (mut hm, q0) = d.hybrid();
        if base {
            hm.excitations.push(Excitation {
                name: "support".into(),
                target: ExcitationTarget::BASE_Y,
                amplitude: 0.5,
                time: TimeFunction::Harmonic {
                    frequency_hz: 6.0,
                    phase: 0.0,
                },
            });
        }
        for x in [0.5, 0.75].into_iter().take(extra) {
            let (more, _) = PaperDamper { x, ..d.clone() }.hybrid();
            let i = hm.mechanisms.len();
            hm.mechanisms.push(more.mechanisms[0].clone());
            let mut a = more.attachments[0].clone();
            a.mechanism = i;
            hm.attachments.push(a);
            let mut f = more.forces[0].clone();
            f.mechanism = i;
            hm.forces.push(f);
        }
        let n = q0.len();
        let mut state = initial_state(&hm, q0, vec![0.0; n]).unwrap();
        let mut integ = Integrator::new(&hm, method, 1e-4, &state).unwrap();
        let mut stored = Stored::default();
        integ.step(&hm, &mut state).unwrap();
        integ.stored_into(&hm, &state, &mut stored);
        let before = allocations();
        for k in 0..2000 {
            integ.step(&hm, &mut state).unwrap();
            if k % 10 == 0 {
                integ.stored_into(&hm, &state, &mut stored);
            }
        }
        let after = allocations();
        assert!(state.q.iter().all(|x| x.is_finite()) && stored.total().is_finite());
        assert_eq!(
            after - before,
            0,
            "{} allocations in 2000 hybrid steps (inductance {inductance}, {method:?}, {} mechanisms)",
            after - before,
            1 + extra
        );
    }
}
