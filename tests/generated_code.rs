//! Generated code (compiled from the bundled models at build time) against the numeric
//! recursive reference and the DAG interpreter: `M`, `F`, `Q`, `h`, `J`, `A` and point
//! kinematics at random states, for the double bar, the four-bar, the slider-crank and a
//! spatial arm with prismatic joints and every kind of force element.
//!
//! Tolerance 1e-12 relative to the largest entry of each quantity: three exact formulations
//! evaluated in double precision (see `mbs-symbolic/tests/symbolic_vs_numeric.rs`).

use damper_e2e::fixtures::{
    double_bar::DoubleBar, four_bar::FourBar, slider_crank::SliderCrank, spatial_arm::SpatialArm,
};
use damper_e2e::workspace_root;
use mbs_symbolic::constraints;
use mbs_symbolic::dynamics::Symbolic;
use mbs_symbolic::expr::{EvalInput, Id, Tape};
use mbs_symbolic::model::{self, Model};
use mbs_symbolic::numeric::NumericModel;
use mbs_symbolic::runtime::{Evaluation, Mechanism, PointKinematics};

/// SplitMix64: a tiny deterministic generator for test states.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
    fn array<const N: usize>(&mut self, scale: f64) -> [f64; N] {
        std::array::from_fn(|_| scale * self.next())
    }
}

fn assert_close(what: &str, got: &[f64], want: &[f64]) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    let scale = want.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= 1e-12 * scale,
            "{what}[{k}]: {g} vs {w} (scale {scale})"
        );
    }
}

fn load(rel: &str) -> Model {
    model::load(&workspace_root().join(rel)).unwrap_or_else(|e| panic!("{e}"))
}

/// Compares the generated mechanism `gen` with the numeric reference and the interpreter.
fn compare<const N: usize, const NC: usize>(
    rel: &str,
    mut generated: impl Mechanism<N, NC>,
    overrides: &[(&str, f64)],
) {
    let mut model = load(rel);
    for (name, v) in overrides {
        assert!(generated.set_param(name, *v), "{rel}: set_param({name})");
        let k = model.param_index(name).unwrap();
        model.parameters[k].value = *v;
    }
    assert!(!generated.set_param("no_such_parameter", 1.0));
    let params = model.default_params();
    let num = NumericModel::new(&model, &params);
    let mut sym = Symbolic::derive(&model);
    let pts = constraints::points(&model, &mut sym);
    let cons = constraints::constraints(&model, &mut sym);
    assert_eq!(pts.len(), generated.point_names().len());
    let mut rng = Rng(0xD0B1E ^ N as u64);
    for _ in 0..20 {
        let q: [f64; N] = rng.array(1.5);
        let qd: [f64; N] = rng.array(2.0);
        let t = 0.25;
        let input = EvalInput {
            q: &q,
            qd: &qd,
            qdd: &[],
            t,
            params: &params,
        };
        let interp = |roots: &[Id]| Tape::new(&sym.dag, roots).eval_vec(&input);

        let mut m = [[0.0; N]; N];
        generated.mass_matrix(&q, &mut m);
        let flat: Vec<f64> = m.iter().flatten().copied().collect();
        let mn = num.mass_matrix(&q);
        let mn: Vec<f64> = (0..N)
            .flat_map(|i| (0..N).map(move |j| (i, j)))
            .map(|(i, j)| mn[(i, j)])
            .collect();
        assert_close(&format!("{rel} M"), &flat, &mn);
        assert_close(&format!("{rel} M interp"), &flat, &interp(&sym.mass));

        let mut f = [0.0; N];
        generated.f_vector(&q, &qd, &mut f);
        assert_close(&format!("{rel} F"), &f, num.f_vector(&q, &qd).as_slice());
        assert_close(&format!("{rel} F interp"), &f, &interp(&sym.f));

        let mut qv = [0.0; N];
        generated.q_vector(&q, &qd, t, &mut qv);
        assert_close(
            &format!("{rel} Q"),
            &qv,
            num.q_vector(&q, &qd, t).as_slice(),
        );
        assert_close(&format!("{rel} Q interp"), &qv, &interp(&sym.q));

        let mut h = [0.0; NC];
        generated.constraints(&q, &mut h);
        assert_close(&format!("{rel} h"), &h, num.constraints(&q).as_slice());
        let mut j = [[0.0; N]; NC];
        generated.constraint_jacobian(&q, &mut j);
        let jn = num.constraint_jacobian(&q);
        let jn: Vec<f64> = (0..NC)
            .flat_map(|r| (0..N).map(move |c| (r, c)))
            .map(|(r, c)| jn[(r, c)])
            .collect();
        assert_close(
            &format!("{rel} J"),
            &j.iter().flatten().copied().collect::<Vec<_>>(),
            &jn,
        );
        let mut a = [0.0; NC];
        generated.constraint_bias(&q, &qd, &mut a);
        assert_close(
            &format!("{rel} A"),
            &a,
            num.constraint_bias(&q, &qd).as_slice(),
        );
        assert_close(&format!("{rel} A interp"), &a, &interp(&cons.a));

        let v = [generated.potential_energy(&q)];
        assert_close(&format!("{rel} V"), &v, &[num.potential_energy(&q)]);
        assert_close(&format!("{rel} V interp"), &v, &interp(&[sym.potential]));

        // The fused evaluation is bit-identical to the separate methods (same DAG nodes,
        // same operations in the same order).
        let mut all = Evaluation::<N, NC>::default();
        generated.evaluate(&q, &qd, t, &mut all);
        assert_eq!(
            all,
            Evaluation {
                mass: m,
                f,
                q: qv,
                h,
                j,
                a
            },
            "{rel}: fused evaluate"
        );

        for k in 0..pts.len() {
            let mut pk = PointKinematics::<N>::default();
            assert!(generated.point_kinematics(k, &q, &qd, &mut pk));
            assert_close(
                &format!("{rel} point {k} p"),
                &pk.p,
                num.point_position(k, &q).as_slice(),
            );
            let jn = num.point_jacobian(k, &q);
            let jn: Vec<f64> = (0..3)
                .flat_map(|r| (0..N).map(move |c| (r, c)))
                .map(|(r, c)| jn[(r, c)])
                .collect();
            assert_close(
                &format!("{rel} point {k} J"),
                &pk.j.iter().flatten().copied().collect::<Vec<_>>(),
                &jn,
            );
            assert_close(
                &format!("{rel} point {k} A"),
                &pk.a,
                num.point_bias(k, &q, &qd).as_slice(),
            );
        }
        let mut pk = PointKinematics::<N>::default();
        assert!(!generated.point_kinematics(pts.len(), &q, &qd, &mut pk));
    }
}

#[test]
fn double_bar_generated_equals_numeric_and_interpreter() {
    compare::<2, 0>("models/double_bar.toml", DoubleBar::default(), &[]);
    compare::<2, 0>(
        "models/double_bar.toml",
        DoubleBar::default(),
        &[("gx", 1.5), ("gy", -9.81)],
    );
}

#[test]
fn four_bar_generated_equals_numeric_and_interpreter() {
    compare::<3, 2>("models/four_bar.toml", FourBar::default(), &[("mb", 0.4)]);
}

#[test]
fn slider_crank_generated_equals_numeric_and_interpreter() {
    compare::<3, 2>("models/slider_crank.toml", SliderCrank::default(), &[]);
}

#[test]
fn spatial_arm_generated_equals_numeric_and_interpreter() {
    compare::<4, 1>(
        "tests/fixtures/spatial_arm.toml",
        SpatialArm::default(),
        &[],
    );
    compare::<4, 1>(
        "tests/fixtures/spatial_arm.toml",
        SpatialArm::default(),
        &[("k_slide", 321.0), ("m_base", 3.5)],
    );
}

/// `J` against central differences of `h`, and `A` against central differences of `J q'`
/// along `q(s) = q + s q'` (so that `d(J q')/ds = A`). Step 1e-6: truncation error O(h^2)
/// ~ 1e-12 times the third derivative, rounding ~ 1e-16/1e-6 = 1e-10; tolerance 1e-7.
#[test]
fn jacobian_and_bias_match_finite_differences() {
    fn check<const N: usize, const NC: usize>(m: &impl Mechanism<N, NC>) {
        let mut rng = Rng(77);
        for _ in 0..10 {
            let q: [f64; N] = rng.array(1.5);
            let qd: [f64; N] = rng.array(2.0);
            let mut j = [[0.0; N]; NC];
            m.constraint_jacobian(&q, &mut j);
            let eps = 1e-6;
            for c in 0..N {
                let (mut qp, mut qm) = (q, q);
                qp[c] += eps;
                qm[c] -= eps;
                let (mut hp, mut hm) = ([0.0; NC], [0.0; NC]);
                m.constraints(&qp, &mut hp);
                m.constraints(&qm, &mut hm);
                for r in 0..NC {
                    let fd = (hp[r] - hm[r]) / (2.0 * eps);
                    assert!(
                        (fd - j[r][c]).abs() < 1e-7,
                        "J[{r}][{c}]: {} vs fd {fd}",
                        j[r][c]
                    );
                }
            }
            let jqd = |qq: &[f64; N]| {
                let mut jj = [[0.0; N]; NC];
                m.constraint_jacobian(qq, &mut jj);
                let mut v = [0.0; NC];
                for r in 0..NC {
                    v[r] = (0..N).map(|c| jj[r][c] * qd[c]).sum();
                }
                v
            };
            let qp: [f64; N] = std::array::from_fn(|i| q[i] + eps * qd[i]);
            let qm: [f64; N] = std::array::from_fn(|i| q[i] - eps * qd[i]);
            let (vp, vm) = (jqd(&qp), jqd(&qm));
            let mut a = [0.0; NC];
            m.constraint_bias(&q, &qd, &mut a);
            for r in 0..NC {
                let fd = (vp[r] - vm[r]) / (2.0 * eps);
                assert!(
                    (fd - a[r]).abs() < 1e-7 * (1.0 + a[r].abs()),
                    "A[{r}]: {} vs fd {fd}",
                    a[r]
                );
            }
        }
    }
    check(&FourBar::default());
    check(&SliderCrank::default());
    check(&SpatialArm::default());
}

/// Regenerating a model is byte-identical, and equal to what the build script compiled.
#[test]
fn regeneration_is_byte_identical() {
    use mbs_symbolic::emit::{EmitOptions, generate};
    let built = include_str!(concat!(env!("OUT_DIR"), "/four_bar.rs"));
    let a = generate(&load("models/four_bar.toml"), &EmitOptions::default())
        .unwrap()
        .source;
    let b = generate(&load("models/four_bar.toml"), &EmitOptions::default())
        .unwrap()
        .source;
    assert_eq!(a, b);
    assert_eq!(a, built);
}
