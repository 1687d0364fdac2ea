//! The simulation step allocates nothing: a counting global allocator observes 2,000 steps of
//! the default damper scenario (generated double bar, generator with and without inductance).

use crate::common;

use codegen_cli::scenario::DamperScenario as Scenario;
use damper_e2e::alloc_counter::allocations;
use hybrid_core::damper::Integrator;
use hybrid_core::study::build_model;

#[test]
fn damper_step_does_not_allocate() {
    let path = std::path::PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/damper.toml"
    ));
    let text = std::fs::read_to_string(&path).unwrap();
    for (inductance, method) in [("0.0", "\"newmark\""), ("1e-4", "\"hht\"")] {
        let text = text
            .replace("inductance = 0.0", &format!("inductance = {inductance}"))
            .replace("\"newmark\"", method);
        let sc = Scenario::from_str(&text, &path).unwrap();
        let (model, guess) =
            build_model(&sc.setup, &double_bar_model(), double_bar(), true).unwrap();
        let mut state = model.initial_state(1e-3, guess).unwrap();
        let mut integ = Integrator::new(&model, sc.setup.method, 1e-4).unwrap();
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
            "{} allocations in 2000 steps (inductance {inductance}, {method})",
            after - before
        );
    }
}

/// The bundled double bar's model description (body names for the generator joint).
fn double_bar_model() -> mbs_symbolic::model::Model {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/double_bar.toml");
    mbs_symbolic::model::load(std::path::Path::new(path)).unwrap_or_else(|e| panic!("{e}"))
}

/// The paper's double bar from the model registry (generated code).
fn double_bar() -> Box<dyn mbs_symbolic::runtime::System> {
    model_registry::find_by_name("double_bar")
        .expect("models/double_bar.toml is compiled in")
        .system()
}

/// The general hybrid integrator allocates nothing per step either: the paper's damper
/// (Newmark, and HHT with an inductive generator) and the damper with two more double bars
/// on the beam (three mechanisms, three attachments); stored energies at output steps too.
#[test]
fn hybrid_step_does_not_allocate() {
    use hybrid_core::hybrid::{Integrator as HybridIntegrator, Stored, initial_state};
    use hybrid_core::study::hybrid_of;
    let path = std::path::PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/damper.toml"
    ));
    let text = std::fs::read_to_string(&path).unwrap();
    for (inductance, method, extra) in [
        ("0.0", "\"newmark\"", 0usize),
        ("1e-4", "\"hht\"", 0),
        ("0.0", "\"newmark\"", 2),
    ] {
        let text = text
            .replace("inductance = 0.0", &format!("inductance = {inductance}"))
            .replace("\"newmark\"", method);
        let sc = Scenario::from_str(&text, &path).unwrap();
        let (model, guess) =
            build_model(&sc.setup, &double_bar_model(), double_bar(), true).unwrap();
        let (mut hm, q0) = hybrid_of(&sc.setup, &model, guess).unwrap();
        for x in [0.5, 0.75].into_iter().take(extra) {
            let mut setup = sc.setup.clone();
            setup.x = x;
            let (m, g) = build_model(&setup, &double_bar_model(), double_bar(), true).unwrap();
            let (more, _) = hybrid_of(&setup, &m, g).unwrap();
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
        let mut integ = HybridIntegrator::new(&hm, sc.setup.method, 1e-4, &state).unwrap();
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
            "{} allocations in 2000 hybrid steps (inductance {inductance}, {method}, {} mechanisms)",
            after - before,
            1 + extra
        );
    }
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
        let built = sc.build().unwrap_or_else(|e| panic!("{e}"));
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
