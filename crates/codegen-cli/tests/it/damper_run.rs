//! The application's damper run on the bundled scenario: what the scenario loader and the
//! streaming run (`codegen_cli::run::damper`) add to the physics (which is tested in
//! hybrid-core's `damper_physics` and `damper_oracle`): model-level errors naming the file,
//! the streamed samples equal to the reference run, memory flat in `t_end`.

use std::path::PathBuf;

use codegen_cli::scenario::DamperScenario as Scenario;
use codegen_cli::scenario::damper::Comparison;
use hybrid_core::study::{build_model, decay, run_setup};
use mbs_symbolic::runtime::System;

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

/// The paper's double bar, generated from `models/double_bar.toml` (model registry).
fn double_bar() -> Box<dyn System> {
    model_registry::find_by_name("double_bar")
        .expect("models/double_bar.toml is compiled in")
        .system()
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
