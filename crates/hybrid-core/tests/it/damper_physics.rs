//! The paper's damper (`scenarios/damper.toml`, built by [`PaperDamper`]) on the general
//! engine: energy conservation and the energy account, the generator's damping, the
//! generated against the numeric recursive implementation of the mechanism, the inductive
//! generator, HHT, the singular position and determinism.

use crate::common;

use common::PaperDamper;
use common::damper::damping_ratio;
use hybrid_core::hybrid::Method;
use mbs_symbolic::runtime::NumericSystem;

/// The damper without Rayleigh damping and with its generator disconnected.
fn undamped() -> PaperDamper {
    let mut d = PaperDamper {
        rayleigh: None,
        ..PaperDamper::default()
    };
    d.generator.connected = false;
    d
}

/// Without dissipation (Rayleigh 0, generator disconnected) the stored energy of beam and
/// mechanism is conserved: the average-acceleration rule conserves it exactly for the linear
/// beam, and to O(h^2) for the mechanism's configuration-dependent reflected mass.
#[test]
fn energy_is_conserved_without_dissipation() {
    // dt = 5e-5: the drift is O(h^2), 1.6e-6 at the scenario's 1e-4.
    let r = PaperDamper {
        t_end: 2.0,
        dt: 5e-5,
        ..undamped()
    }
    .run()
    .unwrap();
    let e = r.energy;
    assert_eq!(e.dissipated(), 0.0);
    assert!(
        r.energy_balance_rel_error < 1e-6,
        "energy drift {:e}",
        r.energy_balance_rel_error
    );
    let rel = (e.total() - r.initial_energy).abs() / r.initial_energy;
    assert!(rel < 1e-6, "final energy differs by {rel:e}");
}

/// With dissipation, initial energy = stored energy + dissipated energy (structure and
/// generator), to 1e-6; the error is O(h^2): it drops by ~4 when the step is halved.
#[test]
fn energy_account_balances_with_dissipation() {
    let err = |dt: f64| {
        let r = PaperDamper {
            t_end: 1.0,
            dt,
            ..PaperDamper::default()
        }
        .run()
        .unwrap();
        let e = r.energy;
        assert!(
            e.dissipated_load > 0.0 && e.dissipated_armature > 0.0 && e.dissipated_structure > 0.0
        );
        r.energy_balance_rel_error
    };
    let (e1, e2) = (err(1e-4), err(5e-5));
    let e3 = err(2.5e-5);
    assert!(e3 < 1e-6, "energy balance error {e3:e} at dt = 2.5e-5");
    let order = (e1 / e2).log2();
    assert!(
        order > 1.7,
        "energy balance error should be O(h^2): {e1:e}, {e2:e}, {e3:e}"
    );
}

/// With in-plane gravity on the mechanism (a run-time parameter of the double bar), its
/// potential energy enters the account, which still balances (1e-6 at dt = 2.5e-5): the
/// mechanism's weight also shifts the beam's equilibrium.
#[test]
fn energy_account_balances_with_gravity_on_the_mechanism() {
    let r = PaperDamper {
        t_end: 1.0,
        dt: 2.5e-5,
        parameters: vec![("gx", 3.0), ("gy", -9.81)],
        ..PaperDamper::default()
    }
    .run()
    .unwrap();
    let e = r.energy;
    assert!(e.mechanism_potential != 0.0);
    assert!(
        r.energy_balance_rel_error < 1e-6,
        "energy balance error {:e}",
        r.energy_balance_rel_error
    );
}

/// The damper works: the generator raises the first mode's damping ratio far above the
/// structural 0.2 %, and the energy it dissipates dominates.
#[test]
fn generator_damps_the_first_mode() {
    let damper = PaperDamper {
        t_end: 2.0,
        ..PaperDamper::default()
    };
    let with = damper.run().unwrap();
    let mut off = damper.clone();
    off.generator.connected = false;
    let without = off.run().unwrap();
    let (zw, zo) = (
        damping_ratio(&with.samples).unwrap(),
        damping_ratio(&without.samples).unwrap(),
    );
    assert!(zo > 0.0015 && zo < 0.0025, "structural damping ratio {zo}");
    assert!(zw > 10.0 * zo, "with generator {zw}, without {zo}");
    let e = with.energy;
    assert!(e.dissipated_armature + e.dissipated_load > 5.0 * e.dissipated_structure);
}

/// The same trajectory with the generated code and with the numeric recursive
/// implementation of the runtime trait (independent formulations of the mechanism).
#[test]
fn generated_and_numeric_mechanisms_give_the_same_trajectory() {
    let damper = PaperDamper {
        t_end: 0.2,
        ..PaperDamper::default()
    };
    let numeric = NumericSystem::new(&common::double_bar_model());
    let g = damper.run().unwrap();
    let n = damper.run_with(Box::new(numeric)).unwrap();
    assert_eq!(g.samples.len(), n.samples.len());
    for (a, b) in g.samples.iter().zip(&n.samples) {
        assert!(
            (a.tip_displacement - b.tip_displacement).abs() <= 1e-10 * 1e-3,
            "t = {}: {} vs {}",
            a.t,
            a.tip_displacement,
            b.tip_displacement
        );
        assert!((a.crank_rate - b.crank_rate).abs() <= 1e-9 * (1.0 + a.crank_rate.abs()));
    }
}

/// A generator with inductance has the current as a state; a small inductance (time constant
/// L/R = 2e-5 s) gives nearly the quasi-static result.
#[test]
fn small_inductance_approaches_the_quasi_static_generator() {
    let d0 = PaperDamper {
        t_end: 1.0,
        ..PaperDamper::default()
    };
    let mut d1 = d0.clone();
    d1.generator.inductance = 1e-4;
    let (r0, r1) = (d0.run().unwrap(), d1.run().unwrap());
    let (z0, z1) = (
        damping_ratio(&r0.samples).unwrap(),
        damping_ratio(&r1.samples).unwrap(),
    );
    assert!(
        (z0 - z1).abs() < 0.01 * z0,
        "zeta {z0} (L = 0) vs {z1} (L = 0.1 mH)"
    );
    assert!(r1.energy.magnetic >= 0.0 && r1.energy_balance_rel_error < 1e-4);
}

/// HHT-alpha: on the linear beam (massless mechanism) the physical energy never exceeds its
/// initial value (HHT dissipates in its own energy norm, so the physical energy may wiggle
/// below it) and some is removed (numerical damping of the high modes); with the
/// mechanism, the first mode is barely touched at omega h = 0.004: over 1 s the tip history
/// stays within 1 % of the amplitude of Newmark's.
#[test]
fn hht_damps_high_modes_and_leaves_the_first_mode() {
    let base = PaperDamper {
        t_end: 1.0,
        ..undamped()
    };
    let hht = Method::Hht { alpha: -0.1 };
    let mut massless = PaperDamper {
        method: hht,
        parameters: vec![("m1", 0.0), ("m2", 0.0)],
        ..base.clone()
    };
    massless.generator.rotor_inertia = 0.0;
    let linear = massless.run().unwrap();
    for s in &linear.samples {
        assert!(
            s.total_energy <= linear.initial_energy * (1.0 + 1e-12),
            "energy above the initial at t = {}",
            s.t
        );
    }
    assert!(
        linear.energy.total() < linear.initial_energy * (1.0 - 1e-5),
        "HHT should remove some energy"
    );

    let newmark = base.run().unwrap();
    let hht = PaperDamper {
        method: hht,
        ..base.clone()
    }
    .run()
    .unwrap();
    for (a, b) in newmark.samples.iter().zip(&hht.samples) {
        assert!(
            (a.tip_displacement - b.tip_displacement).abs() < 1e-2 * 1e-3,
            "t = {}",
            a.t
        );
    }
}

/// Driving the mechanism into its straight position gives the clear error, not NaN: the tip
/// is released 3.5 mm away from the pivot side and swings towards the toggle, which it
/// cannot pass (the bars reach full extension 3.04 mm above the undeformed tip).
#[test]
fn driving_into_the_singular_position_stops_with_a_clear_error() {
    let err = match (PaperDamper {
        initial_displacement: -0.0035,
        ..undamped()
    })
    .run()
    {
        Ok(_) => panic!("the run should stop at the singular position"),
        Err(e) => e.to_string(),
    };
    assert!(
        err.contains("t = ") && err.contains("displacement"),
        "{err}"
    );
    assert!(
        err.contains("singular") || err.contains("cannot reach"),
        "{err}"
    );
    assert!(!err.contains("NaN") && !err.contains("inf "), "{err}");
    // An initial position beyond the toggle cannot be assembled.
    let err = PaperDamper {
        initial_displacement: 0.004,
        ..PaperDamper::default()
    }
    .run()
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("t = 0.000000") && err.contains("cannot reach"),
        "{err}"
    );
}

/// The integrator's state after N steps does not depend on anything but the inputs
/// (no hidden global state): two runs are bit-identical.
#[test]
fn runs_are_deterministic() {
    let damper = PaperDamper {
        t_end: 0.1,
        ..PaperDamper::default()
    };
    let (a, b) = (damper.run().unwrap(), damper.run().unwrap());
    assert_eq!(a.state, b.state);
    assert_eq!(a.energy, b.energy);
}
