//! The linearised hybrid system (issue #11): static equilibrium, exact reduced tangents
//! (against central differences of the independent dense KKT accelerations), modes
//! (against fem-beam's modes and Rayleigh's damping, dense against shift-invert Arnoldi).

use crate::common;

use common::*;
use fem_beam::TimeFunction;
use hybrid_core::hybrid::reference;
use hybrid_core::hybrid::{
    BeamPoint, EigenMethod, EquilibriumOptions, Excitation, ExcitationTarget, ForceKind,
    HybridModel, JointForce, Linearization, Matrix, ModeKind, first_mode, modes,
};
use mbs_symbolic::samples::SplitMix64;
use nalgebra::{Complex, DMatrix, DVector};

fn linearize(model: &HybridModel, params: &[(&str, f64)]) -> Linearization {
    let t = tangents(model, params);
    let refs: Vec<_> = t.iter().collect();
    Linearization::new(model, &refs, EquilibriumOptions::default()).unwrap()
}

#[test]
fn bare_beam_modes_are_fem_beam_modes_with_rayleigh_damping() {
    for (elements, supports) in [
        (20, &[(0.0, "clamped")][..]),
        (13, &[(0.0, "pinned"), (1.0, "pinned")][..]),
    ] {
        let bm = beam(elements, supports, Some(0.002));
        let (a, b) = bm.rayleigh_coefficients();
        let reference = bm.modes(5).unwrap().angular_frequencies();
        let model = HybridModel::new(Some(bm.into()), vec![], vec![], vec![], vec![]).unwrap();
        let lin = linearize(&model, &[]);
        for method in [EigenMethod::Dense, EigenMethod::ShiftInvert] {
            let found = modes(&lin, 5, method).unwrap();
            assert_eq!(found.len(), 5);
            for (m, w) in found.iter().zip(&reference) {
                assert_eq!(m.kind, ModeKind::Oscillatory);
                let wn = m.natural_frequency_hz * 2.0 * std::f64::consts::PI;
                let zeta = a / (2.0 * w) + b * w / 2.0;
                println!(
                    "{method:?}: omega {wn} vs {w} ({:e}), zeta {} vs {zeta} ({:e}), residual {:e}",
                    (wn - w).abs() / w,
                    m.damping_ratio,
                    (m.damping_ratio - zeta).abs() / zeta,
                    m.residual
                );
                assert!((wn - w).abs() <= 1e-10 * w);
                assert!((m.damping_ratio - zeta).abs() <= 1e-10 * zeta);
                assert!(m.residual < 1e-12, "backward error {:e}", m.residual);
            }
        }
    }
}

/// Springs on every mechanism's first joint (so that free coordinates have a stiffness and
/// the equilibrium is isolated), preloaded by a random offset, and constant loads: a beam
/// force and a joint torque.
fn preloaded(mut case: Case, rng: &mut SplitMix64) -> HybridModel {
    let model = &mut case.model;
    for (i, m) in model.mechanisms.iter().enumerate() {
        model.forces.push(JointForce {
            name: format!("preload{i}"),
            mechanism: i,
            joint: 0,
            kind: ForceKind::Spring {
                k: rng.uniform(0.05, 0.5),
                q0: m.initial_q[0] + rng.uniform(-0.05, 0.05),
            },
        });
    }
    let beam = model.beam().unwrap();
    model.excitations = vec![
        Excitation {
            name: "dead_load".into(),
            target: ExcitationTarget::Beam(BeamPoint::on(beam, rng.uniform(0.3, 1.0)).unwrap()),
            amplitude: rng.uniform(-20.0, 20.0),
            time: TimeFunction::Constant,
        },
        Excitation {
            name: "joint_torque".into(),
            target: ExcitationTarget::Joint {
                mechanism: 0,
                joint: 0,
            },
            amplitude: rng.uniform(-0.02, 0.02),
            time: TimeFunction::Constant,
        },
    ];
    case.model
}

#[test]
fn reduced_tangents_equal_central_differences_of_the_kkt_system() {
    let mut rng = SplitMix64::new(7);
    let mut worst_all = 0.0f64;
    let mut seen = Vec::new();
    for seed in 0..16u64 {
        let case = random_case(2000 + seed, None, seed % 2 == 0);
        let model = preloaded(case, &mut rng);
        for m in &model.mechanisms {
            if !seen.contains(&m.name) {
                seen.push(m.name.clone());
            }
        }
        let lin = linearize(&model, &[]);
        let eq = &lin.equilibrium;
        let h = reference::constraints(&model, &eq.beam_q, &eq.mech_q);
        assert!(
            h.iter().all(|v| v.abs() < 1e-12),
            "seed {seed}: equilibrium off the constraints: {h:?}"
        );
        let worst = reference::tangent_error(&model, &lin, 100 + seed);
        println!(
            "seed {seed}: {:?}, {} Newton iterations, free {:?}: worst relative {worst:e}",
            model
                .mechanisms
                .iter()
                .map(|m| m.name.as_str())
                .collect::<Vec<_>>(),
            eq.iterations,
            eq.free
        );
        assert!(worst < 1e-7, "seed {seed}: {worst:e}");
        worst_all = worst_all.max(worst);
    }
    println!("worst over the random systems: {worst_all:e}");
    assert_eq!(seen.len(), 6, "every shape drawn: {seen:?}");
}

#[test]
fn the_paper_damper_with_in_plane_gravity_is_preloaded_and_its_tangents_are_exact() {
    for inductance in [0.0, 2e-3] {
        let (mut model, _) = paper_damper(20, true, true, inductance);
        let gravity = [("gx", 0.0), ("gy", -9.81)];
        for (name, value) in gravity {
            model.mechanisms[0].system.set_param(name, value).unwrap();
        }
        let lin = linearize(&model, &gravity);
        let lambda = &lin.equilibrium.multipliers[0];
        println!(
            "L = {inductance}: equilibrium tip {:e} m, multipliers {lambda:?}",
            lin.equilibrium.beam_q[lin.structure_dofs() - 2]
        );
        assert!(
            lambda.iter().any(|l| l.abs() > 1e-3),
            "gravity preloads the pin"
        );
        let worst = reference::tangent_error(&model, &lin, 3);
        println!("worst relative {worst:e}");
        assert!(worst < 1e-7, "{worst:e}");
    }
}

#[test]
fn dense_and_shift_invert_modes_agree_on_a_100_element_damper() {
    let (model, _) = paper_damper(100, true, true, 2e-3);
    let lin = linearize(&model, &[]);
    let dense = modes(&lin, 6, EigenMethod::Dense).unwrap();
    let arnoldi = modes(&lin, 6, EigenMethod::ShiftInvert).unwrap();
    for (a, b) in dense.iter().zip(&arnoldi) {
        let (la, lb) = (a.lambda(), b.lambda());
        println!(
            "{:?} {la} vs {lb}: {:e}, zeta {}, residuals {:e} {:e}",
            a.kind,
            (la - lb).norm() / la.norm(),
            a.damping_ratio,
            a.residual,
            b.residual
        );
        assert_eq!(a.kind, b.kind);
        assert!((la - lb).norm() <= 1e-9 * la.norm());
        assert!(a.residual < 1e-12 && b.residual < 1e-12);
    }
}

/// `first_mode` (Arnoldi's method at the zero shift) finds the dense solver's first mode:
/// the same eigenvalue to 1e-12 relative (the damped damper near its toggle is the
/// worst-conditioned, 1.6e-13), both refined to a backward error at rounding.
#[test]
fn first_mode_is_the_dense_solvers_first_mode() {
    let bare = |elements, supports: &[(f64, &str)]| {
        let bm = beam(elements, supports, Some(0.002));
        HybridModel::new(Some(bm.into()), vec![], vec![], vec![], vec![]).unwrap()
    };
    let cases = [
        (
            "paper damper, 20 elements",
            paper_damper(20, true, true, 0.0).0,
        ),
        (
            "paper damper, 20 elements, L = 2 mH",
            paper_damper(20, true, true, 2e-3).0,
        ),
        (
            "paper damper at 3 degrees, 60 elements",
            paper_damper_at(60, true, true, 2e-3, 3.0).0,
        ),
        (
            "paper damper, generator open",
            paper_damper(20, true, false, 0.0).0,
        ),
        (
            "pinned-pinned beam",
            bare(13, &[(0.0, "pinned"), (1.0, "pinned")]),
        ),
    ];
    for (name, model) in cases {
        let lin = linearize(&model, &[]);
        let dense = modes(&lin, 1, EigenMethod::Dense).unwrap();
        let first = first_mode(&lin).unwrap().expect("a mode");
        let (ld, lf) = (dense[0].lambda(), first.lambda());
        println!(
            "{name}: {:?} {ld} vs {lf}: {:e}, residuals {:e} {:e}",
            first.kind,
            (ld - lf).norm() / ld.norm().max(f64::MIN_POSITIVE),
            dense[0].residual,
            first.residual
        );
        assert_eq!(first.kind, dense[0].kind, "{name}");
        assert!((ld - lf).norm() <= 1e-12 * ld.norm(), "{name}");
        assert!(first.residual < 1e-12, "{name}: {:e}", first.residual);
    }
}

#[test]
fn harmonic_response_solves_the_dense_dynamic_stiffness_to_rounding() {
    let (model, _) = paper_damper(20, true, true, 2e-3);
    let lin = linearize(&model, &[]);
    let beam = model.beam().unwrap();
    let tip = BeamPoint::on(beam, 1.0).unwrap();
    let f = lin.force_vector(&ExcitationTarget::Beam(tip.clone()));
    // omega = 0: the static deflection of the beam stiffened by the mechanism, K_R z = f
    // (backward error at rounding: the cantilever's K_R has cond ~1e9, so two solvers'
    // answers differ by more than their residuals do).
    let z0 = lin.harmonic_response(&f, 0.0).unwrap();
    assert!(z0.iter().all(|v| v.im == 0.0));
    let re: Vec<f64> = z0.iter().map(|v| v.re).collect();
    let mut kz = vec![0.0; lin.dim()];
    lin.mul(Matrix::Stiffness, &re, &mut kz);
    let amax = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let backward = kz
        .iter()
        .zip(&f)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
        / (lin.norm_bound(Matrix::Stiffness) * amax(&re));
    println!(
        "static: tip {:e} m/N, backward error {backward:e}",
        tip.value(&re)
    );
    assert!(backward < 1e-15);
    // omega > 0: the dense complex system with the current eliminated by hand.
    let c64 = |m: DMatrix<f64>| m.map(|v| Complex::new(v, 0.0));
    for omega in [10.0, 37.0, 240.0, 1000.0] {
        let s = Complex::new(0.0, omega);
        let mut a = c64(lin.dense(Matrix::Stiffness))
            + c64(lin.dense(Matrix::Damping)) * s
            + c64(lin.dense(Matrix::Mass)) * (s * s);
        for e in &lin.electrical {
            let (mut b, mut g) = (vec![0.0; lin.dim()], vec![0.0; lin.dim()]);
            lin.add_from_small(e.torque.as_slice(), &mut b);
            lin.add_from_small(e.emf.as_slice(), &mut g);
            let c = s / (Complex::new(e.resistance, 0.0) + s * e.inductance);
            for r in 0..lin.dim() {
                for col in 0..lin.dim() {
                    a[(r, col)] += c * b[r] * g[col];
                }
            }
        }
        // Backward error of the structured solve against the independently assembled dense
        // matrix (a wrong block would leave a residual of the size of the terms).
        let z = lin.harmonic_response(&f, omega).unwrap();
        let zv = DVector::from_column_slice(&z);
        let r = &a * &zv - DVector::from_iterator(f.len(), f.iter().map(|&v| Complex::new(v, 0.0)));
        let norm = |m: &DMatrix<Complex<f64>>| {
            (0..m.nrows())
                .map(|i| m.row(i).iter().map(|v| v.norm()).sum::<f64>())
                .fold(0.0, f64::max)
        };
        let inf = |v: &DVector<Complex<f64>>| v.iter().fold(0.0f64, |m, x| m.max(x.norm()));
        let backward = inf(&r) / (norm(&a) * inf(&zv));
        println!(
            "omega {omega}: |w_tip| {:e} m/N, backward error {backward:e}",
            tip.value(&z.iter().map(|v| v.re).collect::<Vec<_>>())
                .hypot(tip.value(&z.iter().map(|v| v.im).collect::<Vec<_>>()))
        );
        assert!(backward < 1e-15, "{backward:e}");
    }
}

/// Issue 23 item 1, the hang's regression input: the paper's damper with a generator
/// inductance of 1e301..1e308 H (`--set generator.inductance=1e308`) made nalgebra's
/// uncapped Schur iteration run forever inside `modes`. Such a generator is now refused by
/// its range (`GeneratorSpec::validate`, used by `HybridModel::new` and the scenario
/// loader); the eigen-solver is given the
/// linearisation with the inductance set directly. Both eigen-solvers return: an error
/// naming the matrix or the decomposition, or modes with finite eigenvalues.
#[test]
fn a_huge_generator_inductance_returns_instead_of_hanging() {
    use hybrid_core::hybrid::LinearError;
    let err = generator(1e308, true).validate().unwrap_err().to_string();
    assert!(
        err.contains("generator.inductance = 1e308 is outside"),
        "{err}"
    );
    for inductance in [1e301, 1e305, 1e308] {
        let (model, _) = paper_damper(20, true, true, 2e-3);
        let mut lin = linearize(&model, &[]);
        lin.electrical[0].inductance = inductance;
        for method in [EigenMethod::Dense, EigenMethod::ShiftInvert] {
            let found = modes(&lin, 3, method);
            println!("L = {inductance:e}, {method:?}: {found:?}");
            match found {
                Ok(found) => {
                    for m in &found {
                        assert!(m.lambda().norm().is_finite(), "{m:?}");
                    }
                }
                Err(e) => {
                    assert!(
                        matches!(
                            e,
                            LinearError::NonFinite { .. } | LinearError::NoEigenConvergence { .. }
                        ),
                        "{e}"
                    );
                    assert!(!e.to_string().contains('\n'));
                }
            }
        }
    }
}

/// A mechanism whose model has a point spring-damper with coincident points at the
/// equilibrium (a zero-length tether, `l = 0`) has no tangent there: the linearisation is
/// refused with [`LinearError::ForceElement`] naming the mechanism and the element.
#[test]
fn a_force_element_without_tangent_is_refused_by_name() {
    use hybrid_core::hybrid::{Attachment, AttachmentKind, LinearError, MountedMechanism};
    let bm = beam(8, &[(0.0, "clamped")], None);
    let x = 0.8;
    let bp = BeamPoint::on(&bm, x).unwrap();
    let system = fixture("carriage_tethered");
    let roller = system.point_index("roller").unwrap();
    let q = vec![0.0, 0.0];
    let mount = mount_for(system.as_ref(), roller, &q, 0.0, [x, 0.0]);
    let model = HybridModel::new(
        Some(bm.into()),
        vec![MountedMechanism {
            name: "tethered".into(),
            system,
            mount,
            max_condition: 1e8,
            reach: None,
            initial_q: q,
        }],
        vec![Attachment {
            name: "roller".into(),
            mechanism: 0,
            point: roller,
            kind: AttachmentKind::Roller,
            beam: bp,
        }],
        vec![],
        vec![],
    )
    .unwrap();
    let path = format!(
        "{}/tests/fixtures/carriage_tethered.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let mm = mbs_symbolic::model::load(std::path::Path::new(&path)).unwrap();
    let tangent = mbs_symbolic::runtime::TangentSystem::new(&mm);
    let err = Linearization::new(&model, &[&tangent], EquilibriumOptions::default()).unwrap_err();
    let text = err.to_string();
    assert!(
        matches!(
            &err,
            LinearError::ForceElement { mechanism, source }
                if mechanism == "tethered"
                    && matches!(&**source, mbs_symbolic::runtime::TangentError::CoincidentSpringPoints { element, .. } if element == "tether")
        ),
        "{err:?}"
    );
    assert!(
        text.contains("tethered") && text.contains("tether") && text.contains("coincide"),
        "{text}"
    );
}

/// The gear's loss linearises as its damping at rest on the generator's joint,
/// `n^2 (tau_c / w_s + b + b_eta)` (the smooth Coulomb friction by its slope at 0; see
/// `hybrid_core::generator`): the reduced matrices of the damper with a lossy gear equal
/// those of the damper without it plus a scenario damper of that coefficient on the same
/// joint — with and without inductance.
#[test]
fn the_gear_loss_linearises_as_its_damping_at_rest_on_the_joint() {
    for inductance in [0.0, 2e-3] {
        let (mut geared, _) = paper_damper(20, true, true, inductance);
        let (mut plain, _) = paper_damper(20, true, true, inductance);
        let k = geared
            .forces
            .iter()
            .position(|f| f.generator().is_some())
            .unwrap();
        let ForceKind::Generator(g) = &mut geared.forces[k].kind else {
            unreachable!()
        };
        g.gear_efficiency = 0.8;
        g.gear_friction = hybrid_core::generator::GearFriction {
            coulomb: 5e-4,
            viscous: 2e-6,
            smoothing_speed: 0.5,
        };
        let c = g.gear_damping_at_rest();
        let (mechanism, joint) = (plain.forces[k].mechanism, plain.forces[k].joint);
        plain.forces.push(JointForce {
            name: "gear".into(),
            mechanism,
            joint,
            kind: ForceKind::Damper { c },
        });
        let (a, b) = (linearize(&geared, &[]), linearize(&plain, &[]));
        for which in [Matrix::Mass, Matrix::Damping, Matrix::Stiffness] {
            let (x, y) = (a.small(which), b.small(which));
            let diff = (x - y).amax();
            println!(
                "L = {inductance}: {which:?}: |diff| {diff:e} of {:e}",
                y.amax()
            );
            assert!(diff <= 1e-13 * y.amax(), "{which:?}: {diff:e}");
        }
        // The gear's damping is not negligible next to the generator's own.
        assert!(c > paper_generator_damping(), "{c}");
    }
}

/// `c_g` of the paper's generator, `n^2 k_t k_e / (R_a + R_L)`.
fn paper_generator_damping() -> f64 {
    25.0 * 0.0235 * 0.0235 / 5.0
}
