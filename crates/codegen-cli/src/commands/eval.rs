//! `damper eval`: evaluate the equations of a mechanism model at one state.
//!
//! Prints one JSON object (keys in alphabetical order):
//!
//! - `model`, `backend`, the state `q`, `qd`, `t`;
//! - `M` (array of rows, eq. 11), `F` (eq. 12), `Q` (eq. 13);
//! - `constraint_names` (one per row: `"<constraint>.<component>"` or the constraint's name
//!   for an angle closure), `h` (eq. 14), `J` (one row of `n` per constraint row, eq. 15) and
//!   `A = J' q'` (eq. 16);
//! - `points`: for every named point, `{"p": [x, y, z], "J": [[row x], [row y], [row z]],
//!   "A": [x, y, z]}` — ground position, Jacobian `dp/dq` (3 rows of `n`) and bias `J' q'`
//!   (the point's acceleration when `q'' = 0`, eqs. 49–50);
//! - `op_count`: operation counts of the symbolic `M`, `F` and `M+F`.
//!
//! Three backends compute the same numbers: the symbolic equations evaluated by the DAG
//! interpreter (`interp`, default), the independent numeric recursive Newton–Euler
//! (`numeric`), and the Rust code generated at build time for the bundled models
//! (`generated`; see [`crate::compiled`]).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use mbs_symbolic::constraints;
use mbs_symbolic::dynamics::Symbolic;
use mbs_symbolic::expr::{EvalInput, Id, OpCount, Tape};
use mbs_symbolic::interp::Interpreter;
use mbs_symbolic::model::{self, Model};
use mbs_symbolic::numeric::NumericModel;
use mbs_symbolic::runtime::{Mechanism, PointKinematics};
use serde_json::{Map, Value, json};

use crate::compiled::{self, Bundled};

/// Which implementation evaluates the equations.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// The symbolic equations, evaluated by the DAG interpreter.
    Interp,
    /// The independent numeric recursive Newton–Euler reference.
    Numeric,
    /// The Rust code generated at build time (bundled models only: double_bar, four_bar,
    /// slider_crank, unedited).
    Generated,
}

impl Backend {
    fn name(self) -> &'static str {
        match self {
            Backend::Interp => "interp",
            Backend::Numeric => "numeric",
            Backend::Generated => "generated",
        }
    }
}

/// Arguments of `damper eval`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Mechanism model file (.toml or .json).
    pub model: PathBuf,
    /// Joint coordinates, comma separated (default: all zero).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, num_args = 1)]
    pub q: Vec<f64>,
    /// Joint velocities, comma separated (default: all zero).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, num_args = 1)]
    pub qd: Vec<f64>,
    /// Time (for time-dependent force elements).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub t: f64,
    /// Override a parameter: NAME=VALUE (repeatable). With `--backend generated` only
    /// run-time parameters can be set (folded ones are baked into the generated code).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Implementation used for the evaluation.
    #[arg(long, value_enum, default_value = "interp")]
    pub backend: Backend,
}

/// Applies `NAME=VALUE` overrides to the model's parameter values; returns the indices of
/// the overridden parameters (into [`Model::parameters`]), in command-line order.
fn apply_params(model: &mut Model, overrides: &[String]) -> Result<Vec<usize>> {
    let mut applied = Vec::with_capacity(overrides.len());
    for o in overrides {
        let Some((name, value)) = o.split_once('=') else {
            bail!("--param {o:?}: expected NAME=VALUE");
        };
        let name = name.trim();
        let value: f64 = value
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .with_context(|| {
                format!("--param {name}: {:?} is not a finite number", value.trim())
            })?;
        let Some(k) = model.param_index(name) else {
            let known: Vec<&str> = model.parameters.iter().map(|p| p.name.as_str()).collect();
            bail!(
                "--param {name}: no such parameter in model {:?} (known: {})",
                model.name,
                known.join(", ")
            );
        };
        if model.parameters[k].derived {
            bail!("--param {name}: parameter is derived from other parameters; set those instead");
        }
        model.parameters[k].value = value;
        applied.push(k);
    }
    Ok(applied)
}

fn state(name: &str, v: &[f64], n: usize) -> Result<Vec<f64>> {
    if v.is_empty() {
        return Ok(vec![0.0; n]);
    }
    if v.len() != n {
        bail!(
            "--{name}: expected {n} values (one per joint coordinate), got {}",
            v.len()
        );
    }
    if let Some(bad) = v.iter().find(|x| !x.is_finite()) {
        bail!("--{name}: {bad} is not a finite number");
    }
    Ok(v.to_vec())
}

fn count_json(c: OpCount) -> Value {
    json!({"adds": c.adds, "muls": c.muls, "divs": c.divs, "funcs": c.funcs, "negs": c.negs, "total": c.total()})
}

fn finite(name: &str, v: &[f64]) -> Result<()> {
    if v.iter().any(|x| !x.is_finite()) {
        bail!("{name} is not finite at this state (check the parameters: a zero length or mass?)");
    }
    Ok(())
}

/// Kinematics of one named point, backend-independent.
struct PointOut {
    /// Ground position.
    p: [f64; 3],
    /// `dp/dq`, row-major 3 x n.
    j: Vec<f64>,
    /// `J' q'`.
    a: [f64; 3],
}

/// Everything one evaluation computes; matrices row-major.
struct Outputs {
    /// `M`, n x n (eq. 11).
    m: Vec<f64>,
    /// `F` (eq. 12).
    f: Vec<f64>,
    /// `Q` (eq. 13).
    q: Vec<f64>,
    /// `h` (eq. 14).
    h: Vec<f64>,
    /// `J`, nc x n (eq. 15).
    j: Vec<f64>,
    /// `A = J' q'` (eq. 16).
    a: Vec<f64>,
    /// In the model's point order.
    points: Vec<PointOut>,
}

/// The symbolic equations evaluated by the DAG interpreter (`cons` and `pts` were derived
/// on `sym`'s DAG).
fn eval_interp(
    model: &Model,
    sym: &Symbolic,
    cons: &constraints::ConstraintExprs,
    pts: &[constraints::PointExprs],
    q: &[f64],
    qd: &[f64],
    t: f64,
) -> Outputs {
    let params = model.default_params();
    let it = Interpreter::from_symbolic(sym, params.clone());
    let input = EvalInput {
        q,
        qd,
        qdd: &[],
        t,
        params: &params,
    };
    let eval = |roots: &[Id]| Tape::new(&sym.dag, roots).eval_vec(&input);
    let flat = |rows: &[Vec<Id>]| -> Vec<Id> { rows.iter().flatten().copied().collect() };
    Outputs {
        m: it.mass_matrix(q),
        f: it.f_vector(q, qd),
        q: it.q_vector(q, qd, t),
        h: eval(&cons.h),
        j: eval(&flat(&cons.j)),
        a: eval(&cons.a),
        points: pts
            .iter()
            .map(|pt| {
                let (p, a) = (eval(&pt.p), eval(&pt.a));
                PointOut {
                    p: [p[0], p[1], p[2]],
                    j: eval(&flat(&pt.j)),
                    a: [a[0], a[1], a[2]],
                }
            })
            .collect(),
    }
}

/// The independent numeric reference.
fn eval_numeric(model: &Model, q: &[f64], qd: &[f64], t: f64) -> Outputs {
    let n = model.dof();
    let nm = NumericModel::new(model, &model.default_params());
    let mm = nm.mass_matrix(q);
    let jm = nm.constraint_jacobian(q);
    Outputs {
        m: (0..n * n).map(|k| mm[(k / n, k % n)]).collect(),
        f: nm.f_vector(q, qd).as_slice().to_vec(),
        q: nm.q_vector(q, qd, t).as_slice().to_vec(),
        h: nm.constraints(q).as_slice().to_vec(),
        j: (0..jm.nrows() * n).map(|k| jm[(k / n, k % n)]).collect(),
        a: nm.constraint_bias(q, qd).as_slice().to_vec(),
        points: (0..model.points.len())
            .map(|k| {
                let (p, a) = (nm.point_position(k, q), nm.point_bias(k, q, qd));
                let jp = nm.point_jacobian(k, q);
                PointOut {
                    p: [p[0], p[1], p[2]],
                    j: (0..3 * n).map(|i| jp[(i / n, i % n)]).collect(),
                    a: [a[0], a[1], a[2]],
                }
            })
            .collect(),
    }
}

/// The code generated at build time for a bundled model, through the [`Mechanism`] trait.
/// `overrides` are the run-time parameters set on the command line (indices into
/// [`Model::parameters`], values already in `model`).
fn eval_generated<const N: usize, const NC: usize>(
    mut mech: impl Mechanism<N, NC>,
    model: &Model,
    overrides: &[usize],
    q: &[f64],
    qd: &[f64],
    t: f64,
) -> Result<Outputs> {
    for &k in overrides {
        let p = &model.parameters[k];
        if !mech.set_param(&p.name, p.value) {
            bail!(
                "internal error: the compiled-in `{}` has no run-time parameter `{}`",
                model.name,
                p.name
            );
        }
    }
    let sizes = || {
        format!(
            "internal error: the compiled-in `{}` has {N} coordinates, the model {}",
            model.name,
            model.dof()
        )
    };
    let q: &[f64; N] = q.try_into().ok().with_context(sizes)?;
    let qd: &[f64; N] = qd.try_into().ok().with_context(sizes)?;
    let (mut m, mut f, mut qv) = ([[0.0; N]; N], [0.0; N], [0.0; N]);
    let (mut h, mut j, mut a) = ([0.0; NC], [[0.0; N]; NC], [0.0; NC]);
    mech.mass_matrix(q, &mut m);
    mech.f_vector(q, qd, &mut f);
    mech.q_vector(q, qd, t, &mut qv);
    mech.constraints(q, &mut h);
    mech.constraint_jacobian(q, &mut j);
    mech.constraint_bias(q, qd, &mut a);
    let mut points = Vec::with_capacity(model.points.len());
    for k in 0..model.points.len() {
        let mut pk = PointKinematics::<N>::default();
        if !mech.point_kinematics(k, q, qd, &mut pk) {
            bail!(
                "internal error: the compiled-in `{}` has no point {k}",
                model.name
            );
        }
        points.push(PointOut {
            p: pk.p,
            j: pk.j.iter().flatten().copied().collect(),
            a: pk.a,
        });
    }
    Ok(Outputs {
        m: m.iter().flatten().copied().collect(),
        f: f.to_vec(),
        q: qv.to_vec(),
        h: h.to_vec(),
        j: j.iter().flatten().copied().collect(),
        a: a.to_vec(),
        points,
    })
}

/// Picks the compiled-in mechanism for `model` (by content hash) and evaluates it.
fn dispatch_generated(
    args: &Args,
    model: &Model,
    overrides: &[usize],
    q: &[f64],
    qd: &[f64],
) -> Result<Outputs> {
    let Some(bundled) = Bundled::from_hash(&model.source.hash) else {
        let names: Vec<&str> = Bundled::ALL.iter().map(|b| b.name()).collect();
        bail!(
            "model {} is not compiled into this binary (compiled in: {}); use --backend interp or numeric, or rebuild",
            args.model.display(),
            names.join(", ")
        );
    };
    for &k in overrides {
        let p = &model.parameters[k];
        if !p.runtime {
            bail!(
                "--param {}: parameter is folded into the generated code (not `runtime = true` in the model), so it cannot be changed with --backend generated; use --backend interp or numeric",
                p.name
            );
        }
    }
    let t = args.t;
    match bundled {
        Bundled::DoubleBar => eval_generated(
            compiled::double_bar::DoubleBar::default(),
            model,
            overrides,
            q,
            qd,
            t,
        ),
        Bundled::FourBar => eval_generated(
            compiled::four_bar::FourBar::default(),
            model,
            overrides,
            q,
            qd,
            t,
        ),
        Bundled::SliderCrank => eval_generated(
            compiled::slider_crank::SliderCrank::default(),
            model,
            overrides,
            q,
            qd,
            t,
        ),
    }
}

/// Runs `damper eval`.
pub fn run(args: Args) -> Result<()> {
    let mut model = model::load(&args.model).map_err(|e| anyhow::anyhow!("{e}"))?;
    let overrides = apply_params(&mut model, &args.params)?;
    let n = model.dof();
    let q = state("q", &args.q, n)?;
    let qd = state("qd", &args.qd, n)?;
    // The symbolic derivation gives the operation counts and the constraint row names for
    // every backend (and the expressions for the interpreter).
    let mut sym = Symbolic::derive(&model);
    let pts = constraints::points(&model, &mut sym);
    let cons = constraints::constraints(&model, &mut sym);
    let out = match args.backend {
        Backend::Interp => eval_interp(&model, &sym, &cons, &pts, &q, &qd, args.t),
        Backend::Numeric => eval_numeric(&model, &q, &qd, args.t),
        Backend::Generated => dispatch_generated(&args, &model, &overrides, &q, &qd)?,
    };
    finite("M", &out.m)?;
    finite("F", &out.f)?;
    finite("Q", &out.q)?;
    finite("h", &out.h)?;
    finite("J", &out.j)?;
    finite("A", &out.a)?;
    let rows = |v: &[f64]| -> Vec<Vec<f64>> { v.chunks(n.max(1)).map(<[f64]>::to_vec).collect() };
    let mut points = Map::new();
    for (pt, po) in model.points.iter().zip(&out.points) {
        finite(&format!("point {:?}", pt.name), &po.p)?;
        finite(&format!("point {:?} J", pt.name), &po.j)?;
        finite(&format!("point {:?} A", pt.name), &po.a)?;
        points.insert(
            pt.name.clone(),
            json!({"p": po.p, "J": rows(&po.j), "A": po.a}),
        );
    }
    let json = json!({
        "model": model.name,
        "backend": args.backend.name(),
        "q": q,
        "qd": qd,
        "t": args.t,
        "M": rows(&out.m),
        "F": out.f,
        "Q": out.q,
        "constraint_names": cons.names,
        "h": out.h,
        "J": rows(&out.j),
        "A": out.a,
        "points": points,
        "op_count": {
            "M": count_json(sym.op_count_m()),
            "F": count_json(sym.op_count_f()),
            "M+F": count_json(sym.op_count_mf()),
        },
    });
    crate::print(&(serde_json::to_string_pretty(&json)? + "\n"))?;
    Ok(())
}
