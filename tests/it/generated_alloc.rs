//! The generated evaluators allocate nothing, and neither do the generated and interpreted
//! backends behind the one dynamic interface once their workspace exists: a counting global
//! allocator observes loops of evaluations. (This test binary has its own global allocator.)
//!
//! The models under `models/` are reached through the model registry (their fixed-size types
//! through `model_registry::Visitor`), never by name.

use damper_e2e::alloc_counter::allocations;
use damper_e2e::fixtures::spatial_arm::SpatialArm;
use damper_e2e::workspace_root;
use mbs_symbolic::runtime::{
    Backend, GeneratedSystem, InterpretedSystem, Mechanism, PointKinematics, System,
};
use model_registry::Visitor;

fn exercise<const N: usize, const NC: usize>(m: &impl Mechanism<N, NC>) -> f64 {
    let mut acc = 0.0;
    let (mut mm, mut f, mut qv) = ([[0.0; N]; N], [0.0; N], [0.0; N]);
    let (mut h, mut j, mut a) = ([0.0; NC], [[0.0; N]; NC], [0.0; NC]);
    let mut pk = PointKinematics::<N>::default();
    for step in 0..1000 {
        let s = step as f64 * 1e-3;
        let q: [f64; N] = std::array::from_fn(|i| s + i as f64 * 0.3);
        let qd: [f64; N] = std::array::from_fn(|i| 1.0 - s * i as f64);
        m.mass_matrix(&q, &mut mm);
        m.f_vector(&q, &qd, &mut f);
        m.q_vector(&q, &qd, s, &mut qv);
        m.constraints(&q, &mut h);
        m.constraint_jacobian(&q, &mut j);
        m.constraint_bias(&q, &qd, &mut a);
        for k in 0..m.point_names().len() {
            m.point_kinematics(k, &q, &qd, &mut pk);
            acc += pk.p[0];
            m.point_position(k, &q, &mut pk.p, &mut pk.j);
            acc += pk.j[0][0];
        }
        acc += mm[0][0] + f[0] + qv[0];
    }
    acc
}

/// Counts the allocations of [`exercise`] on a compiled-in model's generated type; the
/// mechanism is built before counting starts.
struct Exercise;

impl Visitor for Exercise {
    type Output = (f64, usize);
    fn visit<T, const N: usize, const NC: usize>(
        self,
        mechanism: T,
        _: &[&str],
        _: &[&str],
    ) -> (f64, usize)
    where
        T: Mechanism<N, NC> + Clone + Send + Sync + 'static,
    {
        let before = allocations();
        let acc = exercise(&mechanism);
        (acc, allocations() - before)
    }
}

fn registered(name: &str) -> &'static model_registry::Compiled {
    model_registry::find_by_name(name).unwrap_or_else(|| panic!("models/{name} not compiled in"))
}

#[test]
fn generated_evaluations_do_not_allocate() {
    let (acc_db, alloc_db) = registered("double_bar").visit(Exercise);
    let (acc_fb, alloc_fb) = registered("four_bar").visit(Exercise);
    let arm = SpatialArm::default();
    let before = allocations();
    let acc = exercise(&arm) + acc_db + acc_fb;
    let after = allocations() - before + alloc_db + alloc_fb;
    assert!(acc.is_finite());
    assert_eq!(after, 0, "generated evaluators allocated {after} times");
}

/// Every method of `s` a simulation step uses, through `&dyn System`, in a loop; returns a
/// checksum and the allocations counted after `workspace()`.
fn exercise_dyn(s: &dyn System) -> (f64, usize) {
    let n = s.dof();
    let mut ws = s.workspace();
    let mut q = vec![0.0; n];
    let mut qd = vec![0.0; n];
    let points = s.point_names().len();
    let before = allocations();
    let mut acc = 0.0;
    for step in 0..200 {
        let t = step as f64 * 1e-3;
        for i in 0..n {
            q[i] = t + i as f64 * 0.3;
            qd[i] = 1.0 - t * i as f64;
        }
        s.evaluate(&q, &qd, t, &mut ws);
        acc += ws.m[(0, 0)] + ws.f[0] + ws.q[0];
        s.evaluate_positions(&q, &mut ws);
        acc += ws.h.iter().sum::<f64>();
        acc += s.potential_energy(&q, &mut ws);
        let power = s.element_power(&q, &qd, &mut ws);
        acc += power.dissipated + power.input;
        for k in 0..points {
            assert!(s.point_kinematics(k, &q, &qd, &mut ws));
            acc += ws.point_p[0] + ws.point_j[(0, 0)] + ws.point_a[0];
            assert!(s.point_position(k, &q, &mut ws));
            acc += ws.point_p[1] + ws.point_j[(1, 0)];
        }
    }
    (acc, allocations() - before)
}

#[test]
fn generated_and_interpreted_systems_do_not_allocate_after_workspace() {
    let mut systems: Vec<(String, Box<dyn System>)> = Vec::new();
    for c in model_registry::compiled() {
        let model = mbs_symbolic::model::load(&workspace_root().join("models").join(c.file))
            .unwrap_or_else(|e| panic!("{e}"));
        systems.push((c.file.to_string(), c.system()));
        systems.push((c.file.to_string(), Box::new(InterpretedSystem::new(&model))));
    }
    let arm = mbs_symbolic::model::load(&workspace_root().join("tests/fixtures/spatial_arm.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    let generated = GeneratedSystem::new(
        SpatialArm::default(),
        &SpatialArm::COORDINATE_NAMES,
        &SpatialArm::CONSTRAINT_NAMES,
    )
    .unwrap();
    systems.push(("spatial_arm".into(), Box::new(generated)));
    systems.push(("spatial_arm".into(), Box::new(InterpretedSystem::new(&arm))));
    assert!(systems.len() >= 6);
    for (name, s) in &systems {
        assert!(
            matches!(s.backend(), Backend::Generated | Backend::Interpreted),
            "{name}"
        );
        let (acc, allocated) = exercise_dyn(s.as_ref());
        assert!(acc.is_finite(), "{name} ({})", s.backend());
        assert_eq!(
            allocated,
            0,
            "{name} ({}) allocated {allocated} times after workspace()",
            s.backend()
        );
    }
}
