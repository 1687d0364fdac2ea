//! The coupled beam + double bar + generator (issue: hybrid-core), checked against
//! independent references: the full constrained model (q^b, q^c and lambda solved together,
//! eqs. 51–54), fem-beam's modal analysis, energy conservation and the energy account, the
//! numeric recursive implementation of the mechanism, and the singular position.

use std::path::PathBuf;

use codegen_cli::scenario::DamperScenario as Scenario;
use codegen_cli::scenario::damper::Comparison;
use fem_beam::BandedFactor;
use hybrid_core::damper::{DamperModel, Integrator, full};
use hybrid_core::study::{build_model, damping_ratio, decay, run_setup};
use mbs_symbolic::runtime::{NumericSystem, System};
use mbs_symbolic::samples::SplitMix64;

fn scenario_path() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/damper.toml"
    ))
}

/// The bundled scenario with textual edits (`(old, new)` replacements that must apply).
fn scenario(edits: &[(&str, &str)]) -> Scenario {
    let mut text = std::fs::read_to_string(scenario_path()).unwrap();
    for (old, new) in edits {
        assert!(text.contains(old), "edit {old:?} does not apply");
        text = text.replacen(old, new, 1);
    }
    Scenario::from_str(&text, &scenario_path()).unwrap_or_else(|e| panic!("{e}"))
}

const NO_RAYLEIGH: (&str, &str) = (
    "ratios = [{ mode = 1, ratio = 0.002 }, { mode = 2, ratio = 0.002 }]",
    "alpha = 0.0\nbeta = 0.0",
);

/// The paper's double bar, generated from `models/double_bar.toml` (model registry).
fn double_bar() -> Box<dyn System> {
    model_registry::find_by_name("double_bar")
        .expect("models/double_bar.toml is compiled in")
        .system()
}

/// A random beam state with the beam point at `y` (m): a random mix of the static shape and
/// noise on every DOF.
fn random_state<M: System>(
    model: &DamperModel<M>,
    rng: &mut SplitMix64,
    amp: f64,
) -> (Vec<f64>, Vec<f64>) {
    let n = model.beam.dof_count();
    let base = model
        .initial_state(amp * rng.symmetric(1.0), [1.4, 0.35])
        .unwrap();
    let q: Vec<f64> = base
        .q
        .iter()
        .map(|x| x * (1.0 + 0.2 * rng.symmetric(1.0)) + 1e-5 * rng.symmetric(1.0))
        .collect();
    let v: Vec<f64> = (0..n).map(|_| 0.05 * rng.symmetric(1.0)).collect();
    (q, v)
}

/// Reduced model (56)–(58) == full constrained model (51)–(54) in accelerations at random
/// states, pinned at a node and inside an element (shape functions, eq. 35). Both are exact
/// linear-algebra solutions of the same equations; 1e-10 relative to the largest
/// acceleration leaves room for the conditioning of the dense KKT solve (~1e4).
#[test]
fn reduced_model_equals_full_constrained_model_in_accelerations() {
    for (x, connected) in [("x = 1.0", true), ("x = 0.9625", true), ("x = 1.0", false)] {
        let sc = scenario(&[("x = 1.0", x)]);
        let (model, _) =
            build_model(&sc.setup, &double_bar_model(), double_bar(), connected).unwrap();
        let mass_factor: BandedFactor = model.beam.mass().factorize().unwrap();
        let mut rng = SplitMix64::new(17);
        for _ in 0..20 {
            let (q, v) = random_state(&model, &mut rng, 2e-3);
            let t = 0.3;
            let link = model.follow(t, &q, &v, 0.0, [1.4, 0.35]).unwrap();
            let reduced = model.accelerations(&mass_factor, t, &q, &v, &link);
            let fa = full::accelerations(&model, t, &q, &v, link.q, link.qd).unwrap();
            let scale = reduced.iter().fold(0.0f64, |m, a| m.max(a.abs()));
            for (k, (r, f)) in reduced.iter().zip(fa.beam.iter()).enumerate() {
                assert!(
                    (r - f).abs() <= 1e-10 * scale,
                    "{x}: a[{k}] reduced {r} vs full {f}"
                );
            }
            // The mechanism accelerations follow from eq. (19): q^b'' = g a_y - J^b^-1 A^b.
            let ay = model.point_value(&reduced);
            let mech_scale = fa.mechanism.iter().fold(1e-12f64, |m, a| m.max(a.abs()));
            let (jb, g) = (link.jb, link.g);
            let (_, _, pa) = model.link.point(&link.q, &link.qd);
            let det = jb[0][0] * jb[1][1] - jb[0][1] * jb[1][0];
            let (ab0, ab1) = (pa[1], pa[0]);
            let s = [
                (ab0 * jb[1][1] - ab1 * jb[0][1]) / det,
                (jb[0][0] * ab1 - jb[1][0] * ab0) / det,
            ];
            for c in 0..2 {
                let qbdd = g[c] * ay - s[c];
                assert!(
                    (qbdd - fa.mechanism[c]).abs() <= 1e-10 * mech_scale,
                    "{x}: q^b''[{c}] {qbdd} vs {}",
                    fa.mechanism[c]
                );
            }
        }
    }
}

/// Reduced vs full model integrated along the same trajectory for 0.5 s with classical RK4 at
/// a step below the stability limit of the stiffest beam mode (a 4-element beam keeps that
/// affordable): the tip displacement agrees to 1e-6 of the amplitude.
#[test]
fn reduced_and_full_models_give_the_same_trajectory() {
    let sc = scenario(&[("elements = 20", "elements = 4")]);
    let (model, guess) = build_model(&sc.setup, &double_bar_model(), double_bar(), true).unwrap();
    let init = model.initial_state(1e-3, guess).unwrap();
    let n = model.beam.dof_count();
    let omega_max = model
        .beam
        .modes(n)
        .unwrap()
        .frequencies_hz()
        .last()
        .copied()
        .unwrap()
        * 2.0
        * std::f64::consts::PI;
    let steps = (0.5 * omega_max / 1.0).ceil() as usize;
    let h = 0.5 / steps as f64;
    let mass_factor = model.beam.mass().factorize().unwrap();

    // Reduced: state (q, v); the mechanism follows by Newton (warm start).
    let mut warm = init.link.q;
    let mut reduced = |t: f64, x: &[f64]| -> Vec<f64> {
        let (q, v) = x.split_at(n);
        let link = model.follow(t, q, v, 0.0, warm).unwrap();
        warm = link.q;
        let a = model.accelerations(&mass_factor, t, q, v, &link);
        v.iter().copied().chain(a).collect()
    };
    // Full: state (q, v, q^b, q^b'), accelerations from the KKT system.
    let full_rhs = |t: f64, x: &[f64]| -> Vec<f64> {
        let (q, rest) = x.split_at(n);
        let (v, rest) = rest.split_at(n);
        let (qb, qbd) = ([rest[0], rest[1]], [rest[2], rest[3]]);
        let fa = full::accelerations(&model, t, q, v, qb, qbd).unwrap();
        v.iter()
            .copied()
            .chain(fa.beam.iter().copied())
            .chain(qbd)
            .chain(fa.mechanism)
            .collect()
    };
    fn rk4(f: &mut dyn FnMut(f64, &[f64]) -> Vec<f64>, t: f64, x: &[f64], h: f64) -> Vec<f64> {
        let add = |x: &[f64], k: &[f64], s: f64| -> Vec<f64> {
            x.iter().zip(k).map(|(a, b)| a + s * b).collect()
        };
        let k1 = f(t, x);
        let k2 = f(t + h / 2.0, &add(x, &k1, h / 2.0));
        let k3 = f(t + h / 2.0, &add(x, &k2, h / 2.0));
        let k4 = f(t + h, &add(x, &k3, h));
        x.iter()
            .enumerate()
            .map(|(i, xi)| xi + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
            .collect()
    }
    let mut xr: Vec<f64> = init.q.iter().chain(&init.v).copied().collect();
    let mut xf: Vec<f64> = init
        .q
        .iter()
        .chain(&init.v)
        .copied()
        .chain(init.link.q)
        .chain(init.link.qd)
        .collect();
    let mut full_fn = full_rhs;
    let mut max_diff: f64 = 0.0;
    for k in 0..steps {
        let t = k as f64 * h;
        xr = rk4(&mut reduced, t, &xr, h);
        xf = rk4(&mut full_fn, t, &xf, h);
        let (yr, yf) = (model.point_value(&xr[..n]), model.point_value(&xf[..n]));
        max_diff = max_diff.max((yr - yf).abs());
    }
    assert!(
        max_diff <= 1e-6 * 1e-3,
        "tip displacement differs by {max_diff:e} m over 0.5 s"
    );
}

/// Without dissipation (Rayleigh 0, generator disconnected) the stored energy of beam and
/// mechanism is conserved: the average-acceleration rule conserves it exactly for the linear
/// beam, and to O(h^2) for the mechanism's configuration-dependent reflected mass.
#[test]
fn energy_is_conserved_without_dissipation() {
    // dt = 5e-5: the drift is O(h^2), 1.6e-6 at the scenario's 1e-4.
    let sc = scenario(&[
        NO_RAYLEIGH,
        ("t_end = 5.0", "t_end = 2.0"),
        ("dt = 1e-4", "dt = 5e-5"),
        (
            "rotor_inertia = 1e-6",
            "rotor_inertia = 1e-6\nconnected = false",
        ),
    ]);
    let (_, r) = run_setup(
        &sc.setup,
        &double_bar_model(),
        double_bar(),
        true,
        &mut |_| {},
    )
    .unwrap();
    let e = r.state.energy;
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
    let err = |dt: &str| {
        let sc = scenario(&[("t_end = 5.0", "t_end = 1.0"), ("dt = 1e-4", dt)]);
        let (_, r) = run_setup(
            &sc.setup,
            &double_bar_model(),
            double_bar(),
            true,
            &mut |_| {},
        )
        .unwrap();
        let e = r.state.energy;
        assert!(
            e.dissipated_load > 0.0 && e.dissipated_armature > 0.0 && e.dissipated_structure > 0.0
        );
        r.energy_balance_rel_error
    };
    let (e1, e2) = (err("dt = 1e-4"), err("dt = 5e-5"));
    let e3 = err("dt = 2.5e-5");
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
    let sc = scenario(&[
        ("t_end = 5.0", "t_end = 1.0"),
        ("dt = 1e-4", "dt = 2.5e-5"),
        (
            "max_condition = 1e4",
            "max_condition = 1e4\nparameters = { gx = 3.0, gy = -9.81 }",
        ),
    ]);
    let (_, r) = run_setup(
        &sc.setup,
        &double_bar_model(),
        double_bar(),
        true,
        &mut |_| {},
    )
    .unwrap();
    let e = r.state.energy;
    assert!(e.mechanism_potential != 0.0);
    assert!(
        r.energy_balance_rel_error < 1e-6,
        "energy balance error {:e}",
        r.energy_balance_rel_error
    );
}

/// With massless bars, no rotor and the generator off, the mechanism exerts no force: the
/// beam vibrates at fem-beam's first natural frequency (0.1 %). The first modal coordinate
/// `phi_1^T A q` filters out the higher modes excited by the initial shape.
#[test]
fn massless_mechanism_leaves_the_first_beam_frequency() {
    let sc = scenario(&[
        NO_RAYLEIGH,
        (
            "rotor_inertia = 1e-6",
            "rotor_inertia = 0.0\nconnected = false",
        ),
        (
            "max_condition = 1e4",
            "max_condition = 1e4\nparameters = { m1 = 0.0, m2 = 0.0 }",
        ),
    ]);
    let (model, guess) = build_model(&sc.setup, &double_bar_model(), double_bar(), true).unwrap();
    let modes = model.beam.modes(1).unwrap();
    let f1 = modes.frequencies_hz()[0];
    let phi: Vec<f64> = modes.shape(0).to_vec();
    let filter = hybrid_core::decay::ModalFilter::new(&phi, model.beam.mass()).unwrap();
    let mut state = model.initial_state(1e-3, guess).unwrap();
    let mut integ = Integrator::new(&model, sc.setup.method, 1e-4).unwrap();
    let (mut t, mut y) = (vec![], vec![]);
    for _ in 0..20_000 {
        integ.step(&model, &mut state).unwrap();
        t.push(state.t);
        y.push(filter.apply(&state.q));
    }
    let e = hybrid_core::decay::estimate(&t, &y);
    let f = e.frequency_hz().unwrap();
    assert!(e.cycles().len() > 10, "{e:?}");
    assert!(
        (f - f1).abs() / f1 < 1e-3,
        "simulated {f} Hz vs first mode {f1} Hz"
    );
}

/// The damper works: the generator raises the first mode's damping ratio far above the
/// structural 0.2 %, and the energy it dissipates dominates.
#[test]
fn generator_damps_the_first_mode() {
    let sc = scenario(&[("t_end = 5.0", "t_end = 2.0")]);
    let (_, with) = run_setup(
        &sc.setup,
        &double_bar_model(),
        double_bar(),
        true,
        &mut |_| {},
    )
    .unwrap();
    let (_, without) = run_setup(
        &sc.setup,
        &double_bar_model(),
        double_bar(),
        false,
        &mut |_| {},
    )
    .unwrap();
    let (zw, zo) = (
        damping_ratio(&with.samples).unwrap(),
        damping_ratio(&without.samples).unwrap(),
    );
    assert!(zo > 0.0015 && zo < 0.0025, "structural damping ratio {zo}");
    assert!(zw > 10.0 * zo, "with generator {zw}, without {zo}");
    let e = with.state.energy;
    assert!(e.dissipated_armature + e.dissipated_load > 5.0 * e.dissipated_structure);
}

/// The same trajectory with the generated code and with the numeric recursive
/// implementation of the runtime trait (independent formulations of the mechanism).
#[test]
fn generated_and_numeric_mechanisms_give_the_same_trajectory() {
    let sc = scenario(&[("t_end = 5.0", "t_end = 0.2")]);
    let model_file = mbs_symbolic::model::load(&sc.model_path).unwrap();
    let numeric = NumericSystem::new(&model_file);
    let (_, g) = run_setup(
        &sc.setup,
        &double_bar_model(),
        double_bar(),
        true,
        &mut |_| {},
    )
    .unwrap();
    let (_, n) = run_setup(&sc.setup, &double_bar_model(), numeric, true, &mut |_| {}).unwrap();
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
    let sc0 = scenario(&[("t_end = 5.0", "t_end = 1.0")]);
    let sc1 = scenario(&[
        ("t_end = 5.0", "t_end = 1.0"),
        ("inductance = 0.0", "inductance = 1e-4"),
    ]);
    let (_, r0) = run_setup(
        &sc0.setup,
        &double_bar_model(),
        double_bar(),
        true,
        &mut |_| {},
    )
    .unwrap();
    let (_, r1) = run_setup(
        &sc1.setup,
        &double_bar_model(),
        double_bar(),
        true,
        &mut |_| {},
    )
    .unwrap();
    let (z0, z1) = (
        damping_ratio(&r0.samples).unwrap(),
        damping_ratio(&r1.samples).unwrap(),
    );
    assert!(
        (z0 - z1).abs() < 0.01 * z0,
        "zeta {z0} (L = 0) vs {z1} (L = 0.1 mH)"
    );
    assert!(r1.state.energy.magnetic >= 0.0 && r1.energy_balance_rel_error < 1e-4);
}

/// HHT-alpha: on the linear beam (massless mechanism) the physical energy never exceeds its
/// initial value (HHT dissipates in its own energy norm, so the physical energy may wiggle
/// below it) and some is removed (numerical damping of the high modes); with the
/// mechanism, the first mode is barely touched at omega h = 0.004: over 1 s the tip history
/// stays within 1 % of the amplitude of Newmark's.
#[test]
fn hht_damps_high_modes_and_leaves_the_first_mode() {
    let base = [
        NO_RAYLEIGH,
        ("t_end = 5.0", "t_end = 1.0"),
        (
            "rotor_inertia = 1e-6",
            "rotor_inertia = 1e-6\nconnected = false",
        ),
    ];
    let hht = ("method = \"newmark\"", "method = \"hht\"\nalpha = -0.1");
    let massless = (
        "max_condition = 1e4",
        "max_condition = 1e4\nparameters = { m1 = 0.0, m2 = 0.0 }",
    );
    let mut edits = base.to_vec();
    edits.extend([
        hht,
        massless,
        (
            "rotor_inertia = 1e-6\nconnected",
            "rotor_inertia = 0.0\nconnected",
        ),
    ]);
    let (_, linear) = run_setup(
        &scenario(&edits).setup,
        &double_bar_model(),
        double_bar(),
        true,
        &mut |_| {},
    )
    .unwrap();
    for s in &linear.samples {
        assert!(
            s.total_energy <= linear.initial_energy * (1.0 + 1e-12),
            "energy above the initial at t = {}",
            s.t
        );
    }
    assert!(
        linear.state.energy.total() < linear.initial_energy * (1.0 - 1e-5),
        "HHT should remove some energy"
    );

    let (_, newmark) = run_setup(
        &scenario(&base).setup,
        &double_bar_model(),
        double_bar(),
        true,
        &mut |_| {},
    )
    .unwrap();
    let mut edits = base.to_vec();
    edits.push(hht);
    let (_, hht) = run_setup(
        &scenario(&edits).setup,
        &double_bar_model(),
        double_bar(),
        true,
        &mut |_| {},
    )
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
    let sc = scenario(&[
        ("displacement = 0.001", "displacement = -0.0035"),
        NO_RAYLEIGH,
        (
            "rotor_inertia = 1e-6",
            "rotor_inertia = 1e-6\nconnected = false",
        ),
    ]);
    let err = match run_setup(
        &sc.setup,
        &double_bar_model(),
        double_bar(),
        true,
        &mut |_| {},
    ) {
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
    let sc = scenario(&[("displacement = 0.001", "displacement = 0.004")]);
    let err = run_setup(
        &sc.setup,
        &double_bar_model(),
        double_bar(),
        true,
        &mut |_| {},
    )
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
    let sc = scenario(&[("t_end = 5.0", "t_end = 0.1")]);
    let (_, a) = run_setup(
        &sc.setup,
        &double_bar_model(),
        double_bar(),
        true,
        &mut |_| {},
    )
    .unwrap();
    let (_, b) = run_setup(
        &sc.setup,
        &double_bar_model(),
        double_bar(),
        true,
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(a.state, b.state);
}

/// The structured fast path (rank-one update of the beam matrices) == the general
/// coordinate-partitioning routine (eqs. 18–25) with u = q^c and v = q^b (THEORY.md 6), in
/// M^R, F^R + Q^R and the resulting accelerations, at random states.
#[test]
fn structured_fast_path_equals_general_partitioning() {
    use hybrid_core::partition::{Partition, reduce};
    use nalgebra::{DMatrix, DVector};
    let sc = scenario(&[("elements = 20", "elements = 8")]);
    let (model, _) = build_model(&sc.setup, &double_bar_model(), double_bar(), true).unwrap();
    let n = model.beam.dof_count();
    let mass_factor = model.beam.mass().factorize().unwrap();
    let mut rng = SplitMix64::new(99);
    for _ in 0..10 {
        let (q, v) = random_state(&model, &mut rng, 2e-3);
        let link = model.follow(0.1, &q, &v, 0.0, [1.4, 0.35]).unwrap();
        let (mf, rhs, j, a) = full::pieces(&model, 0.1, &q, &v, link.q, link.qd);
        let part = Partition::from_independent(n + 2, &(0..n).collect::<Vec<_>>()).unwrap();
        let general = reduce(&mf, &(-rhs), &DVector::zeros(n + 2), &j, &a, &part).unwrap();
        // Structured: M^R = A + m_eff n n^T, F^R + Q^R = B v + C q - P - n f.
        let mut nvec = DVector::zeros(n);
        for &(k, w) in &model.coupling {
            nvec[k] = w;
        }
        let m_struct = model.beam.mass().to_dense() + link.m_eff * &nvec * nvec.transpose();
        let mut p = vec![0.0; n];
        model.beam.load_into(0.1, &mut p);
        let f_struct = model.beam.damping().to_dense() * DVector::from_column_slice(&v)
            + model.beam.stiffness().to_dense() * DVector::from_column_slice(&q)
            - DVector::from_vec(p)
            - link.force * &nvec;
        let mscale = m_struct.amax();
        assert!(
            (&general.m - &m_struct).amax() <= 1e-12 * mscale,
            "M^R differs by {:e}",
            (&general.m - &m_struct).amax()
        );
        let fr = &general.f + &general.q;
        let fscale = f_struct.amax().max(1e-300);
        assert!(
            (&fr - &f_struct).amax() <= 1e-10 * fscale,
            "F^R + Q^R differs by {:e} (scale {fscale:e})",
            (&fr - &f_struct).amax()
        );
        let a_general = general.accelerations().unwrap();
        let a_struct = model.accelerations(&mass_factor, 0.1, &q, &v, &link);
        let ascale = a_struct.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for k in 0..n {
            assert!(
                (a_general[k] - a_struct[k]).abs() <= 1e-9 * ascale,
                "a[{k}]: {} vs {}",
                a_general[k],
                a_struct[k]
            );
        }
        let _: &DMatrix<f64> = &general.b;
    }
}

/// The bundled double bar's model description (body names for the generator joint).
fn double_bar_model() -> mbs_symbolic::model::Model {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/double_bar.toml");
    mbs_symbolic::model::load(std::path::Path::new(path)).unwrap_or_else(|e| panic!("{e}"))
}

/// A model the damper cannot use (a double bar given a third body) is refused with a
/// model-level message naming the file — at run time, whatever backend runs it.
#[test]
fn a_mechanism_of_the_wrong_shape_is_a_model_level_error() {
    let sc = scenario(&[]);
    let file = double_bar_model().source.path;
    let text = std::fs::read_to_string(&file).unwrap().replace(
        "[[points]]",
        "[[bodies]]\nname = \"third\"\nparent = \"coupler\"\njoint = \"R3\"\nanchor = [\"L2\", 0, 0]\nmass = \"m2\"\ncom = [\"L2/2\", 0, 0]\ninertia = { xx = 0, yy = \"m2*L2^2/12\", zz = \"m2*L2^2/12\" }\n\n[[points]]",
    );
    let model =
        mbs_symbolic::model::parse_str(&text, &file, mbs_symbolic::model::Format::Toml).unwrap();
    assert_eq!(model.dof(), 3);
    let sys = mbs_symbolic::runtime::InterpretedSystem::new(&model);
    let err = match build_model(&sc.setup, &model, sys, true) {
        Ok(_) => panic!("a three-coordinate mechanism must be refused"),
        Err(e) => sc.diagnostic(&e).to_string(),
    };
    assert!(
        err.contains("double_bar.toml") && err.contains("3 coordinate"),
        "{err}"
    );
    assert!(!err.contains('\n'), "one line: {err}");
}

/// Regression: near the toggle a converged Newton (|h| at rounding, the steps jittering on
/// the ill-conditioned J^b instead of settling) was reported as "cannot reach the beam
/// point" (NoAssembly). Beam points 3e-17 m to 3e-14 m beyond the double bar's full
/// extension are reached to rounding; the cause is conditioning, reported as Singular
/// (with a finite condition number, which only the after-the-iterations test of
/// `solve_positions` gives). A point clearly beyond the reach stays NoAssembly.
#[test]
fn converged_newton_at_the_toggle_is_singular_not_cannot_reach() {
    use hybrid_core::coupling::KinematicError;
    let sc = scenario(&[]);
    let (model, q0) = build_model(&sc.setup, &double_bar_model(), double_bar(), true).unwrap();
    let link = &model.link;
    let reach = link.reach.expect("the double bar's reach 2 L (1 - cos a0)");
    for excess in [1e-14, 1e-13, 1e-12, 1e-11] {
        let y = reach * (1.0 + excess);
        match link.solve_positions(y, q0) {
            Err(KinematicError::Singular {
                condition,
                sigma_min,
                q,
            }) => {
                assert!(
                    condition.is_finite() && condition > sc.setup.max_condition,
                    "excess {excess:e}: cond {condition:e}"
                );
                assert!(sigma_min < 1e-6, "excess {excess:e}: {sigma_min:e}");
                // Straight: the coupler's relative angle is (nearly) zero.
                assert!(q[1].abs() < 1e-5, "excess {excess:e}: q = {q:?}");
                let (p, _, _) = link.point(&q, &[0.0; 2]);
                let h = (p[1] - (link.attachment.y0 + y)).hypot(p[0] - link.attachment.x0);
                assert!(
                    h <= 1e-12,
                    "excess {excess:e}: |h| = {h:e} is not converged"
                );
            }
            other => panic!("excess {excess:e}: expected Singular, got {other:?}"),
        }
    }
    assert!(matches!(
        link.solve_positions(reach * (1.0 + 1e-9), q0),
        Err(KinematicError::NoAssembly { .. })
    ));
    assert!(link.solve_positions(reach * (1.0 - 1e-6), q0).is_ok());
}

/// The CLI's streaming damper run (`codegen_cli::run::damper`, samples to a sink, only a
/// digest kept) is `hybrid_core::study::run_setup` bit for bit: the same samples, final
/// state, energy account, peak and damping ratios — with and without the generator.
#[test]
fn streaming_run_equals_run_setup_bit_for_bit() {
    let sc = scenario(&[
        ("t_end = 5.0", "t_end = 0.6"),
        (
            "compare = [\"generator_disconnected\", \"bare_beam\"]",
            "compare = [\"generator_disconnected\"]",
        ),
    ]);
    let model = double_bar_model();
    let (mut with, mut without) = (vec![], vec![]);
    let o = codegen_cli::run::damper(
        &sc,
        &model,
        false,
        &mut |s| {
            with.push(*s);
            Ok(())
        },
        &mut [&mut |s| {
            without.push(*s);
            Ok(())
        }],
    )
    .unwrap();
    let disconnected = o.comparison(Comparison::GeneratorDisconnected).unwrap();
    for (connected, streamed, run) in [(true, &with, &o.with), (false, &without, disconnected)] {
        let (_, reference) =
            run_setup(&sc.setup, &model, double_bar(), connected, &mut |_| {}).unwrap();
        assert_eq!(streamed.len(), 601);
        assert_eq!(*streamed, reference.samples, "connected = {connected}");
        assert_eq!(run.state, reference.state);
        assert_eq!(run.initial_energy, reference.initial_energy);
        assert_eq!(
            run.energy_balance_rel_error,
            reference.energy_balance_rel_error
        );
        assert_eq!(run.digest.count(), 601);
        assert_eq!(run.digest.decay(), decay(&reference.samples));
        // 601 samples are plotted whole.
        assert_eq!(run.digest.plot_points(), reference.samples);
    }
    assert!(
        o.with.digest.damping_ratio().is_some() && disconnected.digest.damping_ratio().is_some()
    );
}

/// Memory stays flat whatever t_end: a run keeps at most 20,000 plot points a series (plus
/// its first and last sample), whether it takes 25,001 or 50,001 samples.
#[test]
fn retained_samples_do_not_grow_with_t_end() {
    use codegen_cli::report::digest::MAX_PLOT_POINTS;
    let mut retained = vec![];
    for t_end in ["2.5", "5.0"] {
        let sc = scenario(&[
            ("t_end = 5.0", &format!("t_end = {t_end}")),
            ("every = 10", "every = 1"),
            (
                "compare = [\"generator_disconnected\", \"bare_beam\"]",
                "compare = []",
            ),
        ]);
        let mut streamed = 0u64;
        let o = codegen_cli::run::damper(
            &sc,
            &double_bar_model(),
            false,
            &mut |_| {
                streamed += 1;
                Ok(())
            },
            &mut [],
        )
        .unwrap();
        assert_eq!(o.with.digest.count(), streamed);
        let points = o.with.digest.plot_points();
        assert!(points.len() as u64 <= MAX_PLOT_POINTS, "{}", points.len());
        assert!(o.with.digest.retained() as u64 <= MAX_PLOT_POINTS + 2);
        retained.push((streamed, points.len()));
    }
    assert_eq!(retained[0].0, 25_001);
    assert_eq!(retained[1].0, 50_001);
    // Both decimated to nearly the same bound, not in proportion to the samples.
    let (a, b) = (retained[0].1 as f64, retained[1].1 as f64);
    assert!(
        a > 15_000.0 && b > 15_000.0 && (a - b).abs() < 0.05 * a,
        "{retained:?}"
    );
}
