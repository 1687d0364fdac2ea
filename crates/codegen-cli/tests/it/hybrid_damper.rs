//! The general hybrid system (`hybrid_core::hybrid`) on the paper's damper against the
//! specialised rank-one damper (`hybrid_core::damper`): the same trajectory.

use crate::common;

use std::path::PathBuf;

use codegen_cli::scenario::DamperScenario as Scenario;
use hybrid_core::damper::Integrator as DamperIntegrator;
use hybrid_core::hybrid::{Integrator, initial_state};
use hybrid_core::study::{build_model, hybrid_of};
use mbs_symbolic::runtime::System;

fn scenario(edits: &[(&str, &str)]) -> Scenario {
    let path = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/damper.toml"
    ));
    let mut text = std::fs::read_to_string(&path).unwrap();
    for (old, new) in edits {
        assert!(text.contains(old), "edit {old:?} does not apply");
        text = text.replacen(old, new, 1);
    }
    Scenario::from_str(&text, &path).unwrap_or_else(|e| panic!("{e}"))
}

fn double_bar() -> Box<dyn System> {
    model_registry::find_by_name("double_bar").unwrap().system()
}

fn compare(edits: &[(&str, &str)], t_end: f64) {
    let sc = scenario(edits);
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/double_bar.toml");
    let model = mbs_symbolic::model::load(std::path::Path::new(path)).unwrap();
    let (coupled, guess) = build_model(&sc.setup, &model, double_bar(), true).unwrap();
    let mut old = coupled
        .initial_state(sc.setup.initial_displacement, guess)
        .unwrap();
    let mut oi = DamperIntegrator::new(&coupled, sc.setup.method, sc.setup.dt).unwrap();
    let (hm, q0) = hybrid_of(&sc.setup, &coupled, guess).unwrap();
    let n = q0.len();
    let mut new = initial_state(&hm, q0, vec![0.0; n]).unwrap();
    let mut ni = Integrator::new(&hm, sc.setup.method, sc.setup.dt, &new).unwrap();
    let qmax = old.q.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let check = |old: &hybrid_core::damper::State, new: &hybrid_core::hybrid::HybridState| {
        let vmax = old.v.iter().fold(1e-30f64, |m, x| m.max(x.abs()));
        for i in 0..n {
            assert!(
                (old.q[i] - new.q[i]).abs() <= 1e-9 * qmax,
                "t={} q[{i}] {} vs {}",
                old.t,
                old.q[i],
                new.q[i]
            );
            assert!(
                (old.v[i] - new.v[i]).abs() <= 1e-9 * vmax.max(1e-3),
                "t={} v[{i}]",
                old.t
            );
        }
        for c in 0..2 {
            let (a, b) = (old.link.q[c], new.mechanisms[0].q[c]);
            assert!(
                (a - b).abs() <= 1e-9 * a.abs().max(1.0),
                "t={} qb[{c}] {a} vs {b}",
                old.t
            );
        }
        assert!((old.current - new.currents[0]).abs() <= 1e-9 * old.current.abs().max(1e-3));
    };
    check(&old, &new);
    let steps = (t_end / sc.setup.dt).round() as usize;
    for _ in 0..steps {
        oi.step(&coupled, &mut old).unwrap();
        ni.step(&hm, &mut new).unwrap();
        check(&old, &new);
    }
}

#[test]
fn the_paper_damper_follows_the_same_trajectory() {
    compare(&[], 0.5);
}

#[test]
fn the_inductive_hht_damper_follows_the_same_trajectory() {
    compare(
        &[
            ("inductance = 0.0", "inductance = 0.002"),
            ("method = \"newmark\"", "method = \"hht\"\nalpha = -0.1"),
        ],
        0.3,
    );
}

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
        let built = sc.build().unwrap_or_else(|e| panic!("{e}"));
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
                let b = model.beam.as_ref().unwrap();
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
