//! The comparison variants of a hybrid system (`HybridModel::generators_disconnected`,
//! `HybridModel::bare_beam`): what each keeps and drops, and that each is the system it
//! names — the disconnected damper is the damper built with its circuit open, the bare
//! beam's modes are fem-beam's.

use crate::common;

use common::*;
use fem_beam::TimeFunction;
use hybrid_core::hybrid::{
    BeamPoint, EigenMethod, EquilibriumOptions, Excitation, ExcitationTarget, ForceKind,
    Integrator, Linearization, initial_state, modes,
};

fn excitations(point: BeamPoint) -> Vec<Excitation> {
    let harmonic = |f: f64| TimeFunction::Harmonic {
        frequency_hz: f,
        phase: 0.0,
    };
    vec![
        Excitation {
            name: "shaker".into(),
            target: ExcitationTarget::Beam(point),
            amplitude: 0.1,
            time: harmonic(5.0),
        },
        Excitation {
            name: "motor".into(),
            target: ExcitationTarget::Joint {
                mechanism: 0,
                joint: 0,
            },
            amplitude: 0.01,
            time: harmonic(3.0),
        },
    ]
}

#[test]
fn disconnected_damper_is_the_damper_built_with_its_circuit_open() {
    for inductance in [0.0, 0.002] {
        let (on, q0) = paper_damper(20, true, true, inductance);
        let (built_off, _) = paper_damper(20, true, false, inductance);
        let off = on.generators_disconnected();
        assert_eq!(off.mechanisms.len(), 1);
        assert_eq!(off.forces.len(), on.forces.len());
        match (&off.forces[0].kind, &built_off.forces[0].kind) {
            (ForceKind::Generator(a), ForceKind::Generator(b)) => assert_eq!(a, b),
            _ => panic!("the generator is kept"),
        }
        // The same trajectory as the damper set up disconnected, and no current ever.
        let n = q0.len();
        let run = |m: &hybrid_core::hybrid::HybridModel| {
            let mut s = initial_state(m, q0.clone(), vec![0.0; n]).unwrap();
            let mut integ =
                Integrator::new(m, hybrid_core::hybrid::Method::Newmark, 1e-4, &s).unwrap();
            let mut currents = 0.0f64;
            for _ in 0..2000 {
                integ.step(m, &mut s).unwrap();
                currents = currents.max(s.currents[0].abs());
            }
            (s, currents)
        };
        let (a, ia) = run(&off);
        let (b, ib) = run(&built_off);
        let (c, ic) = run(&on);
        assert_eq!(a.q, b.q, "inductance {inductance}");
        assert_eq!(ia, 0.0);
        assert_eq!(ib, 0.0);
        assert!(ic > 1e-3, "the connected damper carries a current ({ic})");
        assert!(max_diff(&a.q, &c.q) > 1e-6, "disconnecting changes the run");
    }
}

#[test]
fn bare_beam_keeps_the_beam_and_its_loads_and_has_fem_beam_modes() {
    let (mut damper, _) = paper_damper(20, true, true, 0.0);
    let point = damper.attachments[0].beam.clone();
    damper.excitations = excitations(point);
    let bare = damper.bare_beam().expect("the damper has a beam");
    assert!(bare.mechanisms.is_empty() && bare.attachments.is_empty() && bare.forces.is_empty());
    assert_eq!(bare.excitations.len(), 1);
    assert_eq!(bare.excitations[0].name, "shaker");
    assert_eq!(bare.structure_dofs(), damper.structure_dofs());
    // Its modes are the beam's (fem-beam, Rayleigh damping 0.2 % on modes 1 and 2).
    let bm = bare.beam().cloned().unwrap();
    let reference = bm.modes(3).unwrap().angular_frequencies();
    let lin = Linearization::new(&bare, &[], EquilibriumOptions::default()).unwrap();
    let found = modes(&lin, 3, EigenMethod::Dense).unwrap();
    for (m, w) in found.iter().zip(&reference) {
        let wn = m.natural_frequency_hz * 2.0 * std::f64::consts::PI;
        assert!((wn - w).abs() <= 1e-10 * w, "{wn} vs {w}");
    }
    assert!((found[0].damping_ratio - 0.002).abs() <= 1e-10);
    // A system without a beam has no bare-beam variant.
    let mut rigid = damper.clone();
    rigid.structure = None;
    assert!(rigid.bare_beam().is_none());
}
