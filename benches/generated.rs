//! Generated code against the numeric recursive reference and the DAG interpreter: the time
//! of one evaluation of everything a simulation step needs — `M`, `F`, `Q` (eqs. 11–13),
//! `h`, `J`, `A` (eqs. 14–16) and the tip point's kinematics (eqs. 49–50) — for the double
//! bar (`models/double_bar.toml`, gravity `gy = -9.81` set at run time; its generated type
//! reached through the model registry's `Visitor`, never by name) and the 16-body spatial
//! chain (`mbs_symbolic::samples::spatial_chain(16)`, a fixture of `tests/support/build.rs`).
//!
//! Group `evaluate_all`, one run reports all three implementations per model:
//!
//! - `generated`: the struct generated at build time, through the `Mechanism` trait
//!   (monomorphised on the real generated type), into
//!   preallocated fixed-size arrays (no allocation);
//! - `numeric`: `NumericModel`, the nalgebra reference (allocates its results);
//! - `interp`: the symbolic expressions evaluated by `Tape`s (one per generated function),
//!   into preallocated scratch and output buffers.
//!
//! Before timing, the three are checked to agree at the benchmark state (1e-12 relative),
//! so the comparison is between equal results. Inputs are seeded (SplitMix64).
//!
//! Run: `cargo bench --bench generated -- --warm-up-time 1 --measurement-time 3`, and report
//! the ratios numeric/generated and interp/generated of one run (STYLE.md, benchmarks).
#![allow(missing_docs)] // criterion's macros generate undocumented items

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use damper_e2e::fixtures::chain16::Chain16;
use damper_e2e::workspace_root;
use mbs_symbolic::constraints;
use mbs_symbolic::dynamics::Symbolic;
use mbs_symbolic::expr::{EvalInput, Id, Tape};
use mbs_symbolic::model::Model;
use mbs_symbolic::numeric::NumericModel;
use mbs_symbolic::runtime::{Evaluation, Mechanism, PointKinematics};
use mbs_symbolic::samples::SplitMix64;
use model_registry::Visitor;

/// Seeded values in [-scale, scale).
fn seeded<const N: usize>(seed: u64, scale: f64) -> [f64; N] {
    SplitMix64::new(seed).array(scale)
}

/// Caller-owned outputs of the generated evaluation.
struct Buffers<const N: usize, const NC: usize> {
    m: [[f64; N]; N],
    f: [f64; N],
    q: [f64; N],
    h: [f64; NC],
    j: [[f64; N]; NC],
    a: [f64; NC],
    tip: PointKinematics<N>,
}

impl<const N: usize, const NC: usize> Buffers<N, NC> {
    fn new() -> Self {
        Buffers {
            m: [[0.0; N]; N],
            f: [0.0; N],
            q: [0.0; N],
            h: [0.0; NC],
            j: [[0.0; N]; NC],
            a: [0.0; NC],
            tip: PointKinematics::default(),
        }
    }

    /// Everything, flattened in a fixed order (for the agreement check).
    fn flat(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self.m.iter().flatten().copied().collect();
        v.extend(self.f.iter().chain(&self.q).chain(&self.h));
        v.extend(self.j.iter().flatten());
        v.extend(&self.a);
        v.extend(&self.tip.p);
        v.extend(self.tip.j.iter().flatten());
        v.extend(&self.tip.a);
        v
    }
}

/// (a) The generated code: one call per function into preallocated arrays.
#[inline(never)]
fn generated_all<const N: usize, const NC: usize>(
    mech: &impl Mechanism<N, NC>,
    tip: usize,
    q: &[f64; N],
    qd: &[f64; N],
    t: f64,
    out: &mut Buffers<N, NC>,
) {
    mech.mass_matrix(q, &mut out.m);
    mech.f_vector(q, qd, &mut out.f);
    mech.q_vector(q, qd, t, &mut out.q);
    mech.constraints(q, &mut out.h);
    mech.constraint_jacobian(q, &mut out.j);
    mech.constraint_bias(q, qd, &mut out.a);
    mech.point_kinematics(tip, q, qd, &mut out.tip);
}

/// (a') The generated code's fused `evaluate` (M, F, Q, h, J, A in one body) plus the tip.
#[inline(never)]
fn generated_fused<const N: usize, const NC: usize>(
    mech: &impl Mechanism<N, NC>,
    tip: usize,
    q: &[f64; N],
    qd: &[f64; N],
    t: f64,
    all: &mut Evaluation<N, NC>,
    pk: &mut PointKinematics<N>,
) {
    mech.evaluate(q, qd, t, all);
    mech.point_kinematics(tip, q, qd, pk);
}

/// (b) The numeric reference, allocating its results as its API does.
#[inline(never)]
fn numeric_all(nm: &NumericModel, tip: usize, q: &[f64], qd: &[f64], t: f64) -> Vec<f64> {
    let n = q.len();
    let m = nm.mass_matrix(q);
    let f = nm.f_vector(q, qd);
    let qv = nm.q_vector(q, qd, t);
    let h = nm.constraints(q);
    let j = nm.constraint_jacobian(q);
    let a = nm.constraint_bias(q, qd);
    let p = nm.point_position(tip, q);
    let jp = nm.point_jacobian(tip, q);
    let ap = nm.point_bias(tip, q, qd);
    // Row-major, the order of `Buffers::flat`.
    let mut v: Vec<f64> = (0..n * n).map(|k| m[(k / n, k % n)]).collect();
    v.extend(f.iter().chain(qv.iter()).chain(h.iter()));
    v.extend((0..j.nrows() * n).map(|k| j[(k / n, k % n)]));
    v.extend(a.iter().chain(p.iter()));
    v.extend((0..3 * n).map(|k| jp[(k / n, k % n)]));
    v.extend(ap.iter());
    v
}

/// (c) The interpreter: one tape per generated function, preallocated buffers.
struct Interp {
    tapes: Vec<Tape>,
    scratch: Vec<Vec<f64>>,
    out: Vec<Vec<f64>>,
    params: Vec<f64>,
}

impl Interp {
    fn new(model: &Model, tip: usize) -> Interp {
        let mut sym = Symbolic::derive(model);
        let pts = constraints::points(model, &mut sym);
        let cons = constraints::constraints(model, &mut sym);
        let flat = |rows: &[Vec<Id>]| -> Vec<Id> { rows.iter().flatten().copied().collect() };
        let pt = &pts[tip];
        let mut tip_roots = pt.p.to_vec();
        tip_roots.extend(flat(&pt.j));
        tip_roots.extend(pt.a);
        let tapes: Vec<Tape> = [
            sym.mass.clone(),
            sym.f.clone(),
            sym.q.clone(),
            cons.h.clone(),
            flat(&cons.j),
            cons.a.clone(),
            tip_roots,
        ]
        .iter()
        .map(|roots| Tape::new(&sym.dag, roots))
        .collect();
        Interp {
            scratch: tapes.iter().map(|t| vec![0.0; t.scratch_len()]).collect(),
            out: tapes.iter().map(|t| vec![0.0; t.output_len()]).collect(),
            tapes,
            params: model.default_params(),
        }
    }

    #[inline(never)]
    fn eval_all(&mut self, q: &[f64], qd: &[f64], t: f64) {
        let input = EvalInput {
            q,
            qd,
            qdd: &[],
            t,
            params: &self.params,
        };
        for ((tape, scratch), out) in self.tapes.iter().zip(&mut self.scratch).zip(&mut self.out) {
            tape.eval(&input, scratch, out);
        }
    }
}

fn assert_agree(what: &str, got: &[f64], want: &[f64]) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    let scale = want.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= 1e-12 * scale,
            "{what}[{k}]: {g} vs {w} (scale {scale})"
        );
    }
}

fn bench_model<const N: usize, const NC: usize>(
    c: &mut Criterion,
    name: &str,
    model: &Model,
    mech: &impl Mechanism<N, NC>,
) {
    let tip = model.point_index("tip").expect("a point `tip`");
    let q: [f64; N] = seeded(0x5EED ^ N as u64, 1.2);
    let qd: [f64; N] = seeded(0xBEEF ^ N as u64, 2.0);
    let t = 0.5;
    let nm = NumericModel::new(model, &model.default_params());
    let mut interp = Interp::new(model, tip);
    let mut bufs = Buffers::<N, NC>::new();

    // Equal results first: the timings compare like with like.
    generated_all(mech, tip, &q, &qd, t, &mut bufs);
    let reference = numeric_all(&nm, tip, &q, &qd, t);
    assert_agree(
        &format!("{name} generated vs numeric"),
        &bufs.flat(),
        &reference,
    );
    interp.eval_all(&q, &qd, t);
    let interp_flat: Vec<f64> = interp.out.iter().flatten().copied().collect();
    assert_agree(
        &format!("{name} interp vs numeric"),
        &interp_flat,
        &reference,
    );

    let mut group = c.benchmark_group("evaluate_all");
    group.bench_function(BenchmarkId::new("generated", name), |b| {
        b.iter(|| {
            generated_all(mech, tip, black_box(&q), black_box(&qd), t, &mut bufs);
            black_box(&bufs.m);
        })
    });
    let (mut all, mut pk) = (
        Evaluation::<N, NC>::default(),
        PointKinematics::<N>::default(),
    );
    generated_fused(mech, tip, &q, &qd, t, &mut all, &mut pk);
    assert_eq!(
        (all.mass, all.f, all.q),
        (bufs.m, bufs.f, bufs.q),
        "{name}: fused evaluate"
    );
    group.bench_function(BenchmarkId::new("generated_fused", name), |b| {
        b.iter(|| {
            generated_fused(
                mech,
                tip,
                black_box(&q),
                black_box(&qd),
                t,
                &mut all,
                &mut pk,
            );
            black_box(&all.mass);
        })
    });
    group.bench_function(BenchmarkId::new("numeric", name), |b| {
        b.iter(|| black_box(numeric_all(&nm, tip, black_box(&q), black_box(&qd), t)))
    });
    group.bench_function(BenchmarkId::new("interp", name), |b| {
        b.iter(|| {
            interp.eval_all(black_box(&q), black_box(&qd), t);
            black_box(&interp.out);
        })
    });
    group.finish();
}

/// [`bench_model`] on a compiled-in model's generated type, with run-time parameters set.
struct Bench<'a> {
    c: &'a mut Criterion,
    name: &'a str,
    model: &'a Model,
    params: &'a [(&'a str, f64)],
}

impl Visitor for Bench<'_> {
    type Output = ();
    fn visit<T, const N: usize, const NC: usize>(self, mut mechanism: T, _: &[&str], _: &[&str])
    where
        T: Mechanism<N, NC> + Clone + Send + Sync + 'static,
    {
        for (p, v) in self.params {
            assert!(mechanism.set_param(p, *v), "{}: set_param({p})", self.name);
        }
        bench_model::<N, NC>(self.c, self.name, self.model, &mechanism);
    }
}

fn evaluate_all(c: &mut Criterion) {
    // The double bar with gravity on (a run-time parameter), as mounted vertically.
    let double_bar =
        model_registry::find_by_name("double_bar").expect("models/double_bar.toml is compiled in");
    let mut model =
        mbs_symbolic::model::load(&workspace_root().join("models").join(double_bar.file))
            .unwrap_or_else(|e| panic!("{e}"));
    let params = [("gy", -9.81)];
    for (p, v) in params {
        let k = model.param_index(p).expect("parameter gy");
        model.parameters[k].value = v;
    }
    double_bar.visit(Bench {
        c,
        name: "double_bar",
        model: &model,
        params: &params,
    });

    let chain = mbs_symbolic::samples::spatial_chain(16);
    bench_model::<16, 0>(c, "chain16", &chain, &Chain16::default());
}

criterion_group!(benches, evaluate_all);
criterion_main!(benches);
