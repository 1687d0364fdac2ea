//! The exact tangent matrices of [`TangentSystem`] against central finite differences of the
//! interpreter's own `M`, `F`, `Q`, `h`, `J`, point `J` and `V`, on every bundled model and on
//! seeded random trees (spatial and planar, prismatic joints, loop, fixed-point and angle
//! constraints, every kind of force element, run-time parameters).
//!
//! Tolerances. First derivatives are central differences with the step
//! `h_j = 1e-6 max(1, |x_j|)`: the truncation error is `h² |f'''| / 6 ~ 1e-13` of the
//! function's scale and the rounding error `eps |f| / h ~ 2e-10` of it, so a relative
//! agreement of `1e-7` (of the larger of the function's and the derivative's magnitudes)
//! has a margin of about 500 — while a missing term (`dM/dq q''`, a sign, a forgotten
//! parameter) is an error of order one (measured worst over every check: 8e-10). The
//! Hessian of `V` is a Richardson-extrapolated second difference (steps `1e-3` and `5e-4`:
//! truncation `O(h⁴) ~ 1e-12`, rounding `~ 5 eps |V| / h² ~ 5e-9` of `|V|`; measured worst
//! 4e-9), checked to `1e-7` of `max(|V|, |K|)`. The curvature matrices and `K` at rest are
//! symmetric to rounding: `1e-14` of their largest entry (measured worst 3e-16).

use crate::common;

use std::path::PathBuf;

use common::{RandomOpts, SplitMix64, random_model, random_state};
use mbs_symbolic::model::{self, ForceElement, JointKind, Model, Scalar};
use mbs_symbolic::runtime::{InterpretedSystem, System, TangentSystem, TangentWorkspace};
use nalgebra::{DMatrix, DVector};

const REL: f64 = 1e-7;

fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Every bundled model: `models/*.toml` and `models/pendulum.json`.
fn bundled() -> Vec<(String, Model)> {
    let dir = workspace_root().join("models");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    paths.push(dir.join("pendulum.json"));
    paths.sort();
    paths
        .into_iter()
        .map(|p| {
            let m = model::load(&p).unwrap_or_else(|e| panic!("{e}"));
            (p.file_name().unwrap().to_string_lossy().into_owned(), m)
        })
        .collect()
}

/// Central differences of `f: R^m -> R^k` at `x`, `k x m`; also returns `max |f(x)|`.
fn fd(x: &[f64], mut f: impl FnMut(&[f64]) -> Vec<f64>) -> (DMatrix<f64>, f64) {
    let f0 = f(x);
    let mut d = DMatrix::zeros(f0.len(), x.len());
    let mut xp = x.to_vec();
    for j in 0..x.len() {
        let h = 1e-6 * x[j].abs().max(1.0);
        xp[j] = x[j] + h;
        let fp = f(&xp);
        xp[j] = x[j] - h;
        let fm = f(&xp);
        xp[j] = x[j];
        for i in 0..f0.len() {
            d[(i, j)] = (fp[i] - fm[i]) / (2.0 * h);
        }
    }
    (d, max_abs(&f0))
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |a, x| a.max(x.abs()))
}

/// `|got - want|_max <= REL * max(|want|, |got|, fscale, tiny)`.
fn assert_near(what: &str, got: &DMatrix<f64>, want: &DMatrix<f64>, fscale: f64, rel: f64) {
    assert_eq!(got.shape(), want.shape(), "{what}: shape");
    let scale = max_abs(got.as_slice())
        .max(max_abs(want.as_slice()))
        .max(fscale)
        .max(1e-12);
    let err = (got - want).abs().max();
    assert!(
        err <= rel * scale,
        "{what}: error {err:e} > {rel:e} * {scale:e}\n got {got}\n want {want}"
    );
}

fn assert_symmetric(what: &str, a: &DMatrix<f64>) {
    let scale = a.abs().max().max(1e-12);
    let err = (a - a.transpose()).abs().max();
    assert!(
        err <= 1e-14 * scale,
        "{what}: asymmetry {err:e} of {scale:e}\n{a}"
    );
}

/// `r = M q'' + F + Q` from the interpreter.
fn residual(sys: &InterpretedSystem, q: &[f64], qd: &[f64], qdd: &[f64], t: f64) -> Vec<f64> {
    let mut ws = sys.workspace();
    sys.evaluate(q, qd, t, &mut ws);
    let r = &ws.m * DVector::from_column_slice(qdd) + &ws.f + &ws.q;
    r.as_slice().to_vec()
}

/// A random vector with entries in `[-s, s)`.
fn random_vec(rng: &mut SplitMix64, len: usize, s: f64) -> Vec<f64> {
    (0..len).map(|_| rng.uniform(-s, s)).collect()
}

/// Everything [`TangentSystem`] evaluates, against the interpreter at one random state.
fn check_state(what: &str, sys: &InterpretedSystem, tan: &TangentSystem, seed: u64) {
    let n = sys.dof();
    let rows = sys.rows();
    assert_eq!((tan.dof(), tan.rows()), (n, rows), "{what}: sizes");
    assert_eq!(tan.names(), sys.names(), "{what}: names");
    let (q, qd, qdd) = random_state(seed, n);
    let mut rng = SplitMix64::new(seed ^ 0x7A46_E471);
    let t = rng.uniform(0.0, 2.0);
    let mut tw: TangentWorkspace = tan.workspace();
    let mut ws = sys.workspace();

    // M, K = dr/dq, C = dr/dq'.
    tan.evaluate_dynamics(&q, &qd, &qdd, t, &mut tw);
    sys.evaluate(&q, &qd, t, &mut ws);
    // The same DAG nodes evaluated by the same operations: bit-identical.
    assert_eq!(tw.m, ws.m, "{what}: M");
    let (k_fd, rs) = fd(&q, |x| residual(sys, x, &qd, &qdd, t));
    assert_near(&format!("{what}: K"), &tw.k, &k_fd, rs, REL);
    let (c_fd, rs) = fd(&qd, |x| residual(sys, &q, x, &qdd, t));
    assert_near(&format!("{what}: C"), &tw.c, &c_fd, rs, REL);

    // h, J, G(lambda) = d(J^T lambda)/dq.
    let lambda = random_vec(&mut rng, rows, 5.0);
    tan.evaluate_constraints(&q, &lambda, &mut tw);
    assert_eq!(tw.h, ws.h, "{what}: h");
    assert_eq!(tw.j, ws.j, "{what}: J");
    if rows > 0 {
        let (j_fd, hs) = fd(&q, |x| {
            let mut w = sys.workspace();
            sys.evaluate_positions(x, &mut w);
            w.h.as_slice().to_vec()
        });
        assert_near(&format!("{what}: J = dh/dq"), &tw.j, &j_fd, hs, REL);
    }
    let lam = DVector::from_column_slice(&lambda);
    let (g_fd, js) = fd(&q, |x| {
        let mut w = sys.workspace();
        sys.evaluate_positions(x, &mut w);
        (w.j.transpose() * &lam).as_slice().to_vec()
    });
    assert_near(
        &format!("{what}: d(J^T lambda)/dq"),
        &tw.constraint_curvature,
        &g_fd,
        js,
        REL,
    );
    assert_symmetric(
        &format!("{what}: d(J^T lambda)/dq"),
        &tw.constraint_curvature,
    );

    // Points: p, J_k, G_k(f) = d(J_k^T f)/dq.
    for k in 0..sys.point_names().len() {
        let f: [f64; 3] = [0, 1, 2].map(|_| rng.uniform(-20.0, 20.0));
        let pname = format!("{what}: point {}", sys.point_names()[k]);
        assert!(tan.evaluate_point(k, &q, f, &mut tw), "{pname}");
        assert!(sys.point_kinematics(k, &q, &qd, &mut ws), "{pname}");
        assert_eq!(tw.point_p, ws.point_p, "{pname}: p");
        assert_eq!(tw.point_j, ws.point_j, "{pname}: J");
        let (jp_fd, ps) = fd(&q, |x| {
            let mut w = sys.workspace();
            sys.point_kinematics(k, x, &qd, &mut w);
            w.point_p.as_slice().to_vec()
        });
        assert_near(&format!("{pname}: J = dp/dq"), &tw.point_j, &jp_fd, ps, REL);
        let fv = DVector::from_column_slice(&f);
        let (gp_fd, js) = fd(&q, |x| {
            let mut w = sys.workspace();
            sys.point_kinematics(k, x, &qd, &mut w);
            (w.point_j.transpose() * &fv).as_slice().to_vec()
        });
        assert_near(
            &format!("{pname}: d(J^T f)/dq"),
            &tw.point_curvature,
            &gp_fd,
            js,
            REL,
        );
        assert_symmetric(&format!("{pname}: d(J^T f)/dq"), &tw.point_curvature);
    }
    let n_points = sys.point_names().len();
    assert!(
        !tan.evaluate_point(n_points, &q, [1.0; 3], &mut tw),
        "{what}: no point past the last"
    );
}

/// Whether every force element is potential or dissipative (no constant joint force, no
/// external force): then `F + Q` at `q' = 0` is the gradient of `V`.
fn conservative_at_rest(m: &Model) -> bool {
    m.forces.iter().all(|f| match f {
        ForceElement::Joint { constant, .. } => *constant == Scalar::ZERO,
        ForceElement::PointSpring { .. } => true,
        ForceElement::External { .. } => false,
    })
}

/// Richardson-extrapolated second differences of `V` at `q`.
fn hessian_of_potential(sys: &InterpretedSystem, q: &[f64]) -> (DMatrix<f64>, f64) {
    let mut ws = sys.workspace();
    let n = q.len();
    let mut v = |x: &[f64]| sys.potential_energy(x, &mut ws);
    let v0 = v(q);
    let mut second = |h: f64| {
        let mut d = DMatrix::zeros(n, n);
        let mut x = q.to_vec();
        for i in 0..n {
            for j in 0..=i {
                let mut at = |si: f64, sj: f64| {
                    x.copy_from_slice(q);
                    x[i] += si * h;
                    x[j] += sj * h;
                    v(&x)
                };
                let e = if i == j {
                    (at(0.5, 0.5) - 2.0 * v0 + at(-0.5, -0.5)) / (h * h)
                } else {
                    (at(1.0, 1.0) - at(1.0, -1.0) - at(-1.0, 1.0) + at(-1.0, -1.0)) / (4.0 * h * h)
                };
                d[(i, j)] = e;
                d[(j, i)] = e;
            }
        }
        d
    };
    let (d1, d2) = (second(1e-3), second(5e-4));
    ((d2 * 4.0 - d1) / 3.0, v0.abs())
}

/// At rest (`q' = 0`, `q'' = 0`) a conservative system's `K` is the Hessian of `V`
/// (symmetric).
fn check_potential(
    what: &str,
    model: &Model,
    sys: &InterpretedSystem,
    tan: &TangentSystem,
    seed: u64,
) {
    let n = sys.dof();
    let (q, _, _) = random_state(seed, n);
    let zero = vec![0.0; n];
    let mut tw = tan.workspace();
    tan.evaluate_dynamics(&q, &zero, &zero, 0.0, &mut tw);
    let (hess, vs) = hessian_of_potential(sys, &q);
    assert_near(
        &format!("{what}: K at rest = d²V/dq²"),
        &tw.k,
        &hess,
        vs,
        REL,
    );
    assert_symmetric(&format!("{what}: K at rest"), &tw.k);
    // At rest the velocity terms of F (quadratic in q') have no q'-derivative: C is the
    // damping of the force elements alone.
    if undamped(model) {
        assert_eq!(tw.c.abs().max(), 0.0, "{what}: C at rest without dampers");
    }
}

/// Whether no force element has damping.
fn undamped(m: &Model) -> bool {
    m.forces.iter().all(|f| match f {
        ForceElement::Joint { damping, .. } | ForceElement::PointSpring { damping, .. } => {
            *damping == Scalar::ZERO
        }
        ForceElement::External { .. } => true,
    })
}

#[test]
fn bundled_models_tangents_equal_finite_differences() {
    let models = bundled();
    assert!(models.len() >= 6, "bundled models: {}", models.len());
    // Coverage: a closed loop through a prismatic joint (the slider-crank).
    assert!(
        models.iter().any(|(_, m)| {
            !m.constraints.is_empty()
                && m.bodies
                    .iter()
                    .any(|b| b.joint.kind == JointKind::Prismatic)
        }),
        "no bundled model with a loop constraint and a prismatic joint"
    );
    for (name, m) in &models {
        let sys = InterpretedSystem::new(m);
        let tan = TangentSystem::new(m);
        for seed in 0..4 {
            check_state(&format!("{name} seed {seed}"), &sys, &tan, seed);
        }
        assert!(conservative_at_rest(m), "{name}");
        for seed in 0..3 {
            check_potential(&format!("{name} seed {seed}"), m, &sys, &tan, seed);
        }
    }
}

#[test]
fn run_time_parameters_reach_the_tangents() {
    // The four-bar's masses and gravity are run-time parameters: change them on both.
    let (_, m) = bundled()
        .into_iter()
        .find(|(n, _)| n == "four_bar.toml")
        .expect("four_bar.toml");
    let mut sys = InterpretedSystem::new(&m);
    let mut tan = TangentSystem::new(&m);
    let (q, qd, qdd) = random_state(3, sys.dof());
    let mut before = tan.workspace();
    tan.evaluate_dynamics(&q, &qd, &qdd, 0.0, &mut before);
    for (p, v) in [("mb", 0.4), ("g", 3.7)] {
        sys.set_param(p, v).unwrap();
        tan.set_param(p, v).unwrap();
    }
    let mut after = tan.workspace();
    tan.evaluate_dynamics(&q, &qd, &qdd, 0.0, &mut after);
    assert!((&after.k - &before.k).abs().max() > 1e-3 * before.k.abs().max());
    check_state("four_bar (mb = 0.4, g = 3.7)", &sys, &tan, 11);
    assert!(tan.set_param("nope", 1.0).is_err());
    assert!(tan.set_param("g", f64::NAN).is_err());
}

fn random_opts() -> Vec<RandomOpts> {
    let mut out = Vec::new();
    for bodies in 1..=5 {
        out.push(RandomOpts {
            bodies,
            ..RandomOpts::default()
        });
        out.push(RandomOpts {
            bodies,
            planar: true,
            ..RandomOpts::default()
        });
        out.push(RandomOpts {
            bodies,
            branching: false,
            runtime_params: false,
            ..RandomOpts::default()
        });
    }
    out
}

#[test]
fn random_trees_tangents_equal_finite_differences() {
    let mut loops = 0;
    let mut prismatic = 0;
    for opts in random_opts() {
        for s in 0..4u64 {
            let seed = s * 7919 + 31 * opts.bodies as u64 + u64::from(opts.planar);
            let m = random_model(seed, &opts);
            loops += usize::from(!m.constraints.is_empty());
            prismatic += usize::from(
                m.bodies
                    .iter()
                    .any(|b| b.joint.kind == JointKind::Prismatic),
            );
            let mut sys = InterpretedSystem::new(&m);
            let mut tan = TangentSystem::new(&m);
            let what = format!("random {opts:?} seed {seed}");
            check_state(&what, &sys, &tan, seed);
            if opts.runtime_params {
                for (p, v) in [("mscale", 1.7), ("len", 0.45), ("kscale", 0.6)] {
                    sys.set_param(p, v).unwrap();
                    tan.set_param(p, v).unwrap();
                }
                check_state(&format!("{what} (parameters set)"), &sys, &tan, seed + 1);
            }
        }
    }
    assert!(
        loops > 20 && prismatic > 10,
        "coverage: {loops} loops, {prismatic} prismatic"
    );
}

#[test]
fn random_conservative_trees_stiffness_at_rest_is_the_hessian_of_the_potential() {
    for bodies in 1..=5 {
        for planar in [false, true] {
            for s in 0..3u64 {
                let opts = RandomOpts {
                    bodies,
                    planar,
                    force_elements: s != 0,
                    ..RandomOpts::default()
                };
                let seed = 1000 + s * 104_729 + bodies as u64;
                let mut m = random_model(seed, &opts);
                // Keep the potential and dissipative elements only.
                m.forces
                    .retain(|f| !matches!(f, ForceElement::External { .. }));
                for f in &mut m.forces {
                    match f {
                        ForceElement::Joint {
                            constant, damping, ..
                        } => {
                            *constant = Scalar::ZERO;
                            if s == 2 {
                                *damping = Scalar::ZERO;
                            }
                        }
                        ForceElement::PointSpring { damping, .. } if s == 2 => {
                            *damping = Scalar::ZERO;
                        }
                        _ => {}
                    }
                }
                if s == 2 {
                    assert!(undamped(&m) && !m.forces.is_empty());
                }
                assert!(conservative_at_rest(&m));
                let sys = InterpretedSystem::new(&m);
                let tan = TangentSystem::new(&m);
                check_potential(
                    &format!("random {opts:?} seed {seed}"),
                    &m,
                    &sys,
                    &tan,
                    seed,
                );
            }
        }
    }
}

/// A point spring-damper has no tangent where its points coincide (`l = 0`: no direction):
/// `check_elements` refuses that state naming the element and its points, and accepts the
/// others (where `K` and `C` are exact, checked by `check_state` on every kind of element).
#[test]
fn a_spring_whose_points_coincide_is_refused() {
    let src = r#"
name = "tethered_rod"
gravity = [0, 0, 0]

[[bodies]]
name = "rod"
parent = "ground"
joint = "R3"
mass = 1.0
com = [0.25, 0, 0]
inertia = { xx = 0.01, yy = 0.02, zz = 0.02 }

[[points]]
name = "tip"
body = "rod"
position = [0.5, 0, 0]

[[points]]
name = "anchor"
body = "ground"
position = [0.5, 0, 0]

[[forces]]
type = "spring"
name = "tether"
a = "anchor"
b = "tip"
stiffness = 10
damping = 0.1
"#;
    let m = model::parse_str(src, "tethered_rod.toml", model::Format::Toml)
        .unwrap_or_else(|e| panic!("{e:?}"));
    let tan = TangentSystem::new(&m);
    let mut tw = tan.workspace();
    let err = tan.check_elements(&[0.0], &mut tw).unwrap_err();
    let text = err.to_string();
    assert!(
        matches!(
            &err,
            mbs_symbolic::runtime::TangentError::CoincidentSpringPoints { element, a, b, length }
                if element == "tether" && a == "anchor" && b == "tip" && *length == 0.0
        ),
        "{err:?}"
    );
    assert!(
        text.contains("tether") && text.contains("coincide"),
        "{text}"
    );
    assert!(tan.check_elements(&[0.4], &mut tw).is_ok());
    // There the tangent is finite; at the coincident state it is not.
    tan.evaluate_dynamics(&[0.4], &[0.3], &[0.0], 0.0, &mut tw);
    assert!(tw.k.iter().chain(tw.c.iter()).all(|x| x.is_finite()));
    tan.evaluate_dynamics(&[0.0], &[0.3], &[0.0], 0.0, &mut tw);
    assert!(!tw.k.iter().chain(tw.c.iter()).all(|x| x.is_finite()));
}
