//! The simulation step allocates nothing: a counting global allocator observes 2,000 steps of
//! the default damper scenario (generated double bar, generator with and without inductance).

use codegen_cli::scenario::DamperScenario as Scenario;
use damper_e2e::alloc_counter::{CountingAllocator, allocations};
use hybrid_core::damper::Integrator;
use hybrid_core::study::build_model;

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

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
