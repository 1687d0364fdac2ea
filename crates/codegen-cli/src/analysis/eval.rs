//! The equations of a mechanism model at one state ([`EvalRequest`] → [`evaluation`]), what
//! `damper eval` prints and Python's `Model.eval` returns.
//!
//! One JSON object (keys in alphabetical order):
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
//! (`generated`, matched through the one model registry, `model_registry::system_for`).

use std::path::PathBuf;

use mbs_symbolic::dynamics::Symbolic;
use mbs_symbolic::expr::OpCount;
use mbs_symbolic::model::{self, Model};
use mbs_symbolic::runtime::{Backend as RtBackend, System};
use serde_json::{Map, Value, json};

use crate::Error;
use crate::analysis::AnalysisError;

type Result<T> = std::result::Result<T, Error>;

/// Returns an argument error of `argument` (the command line asks for something the model
/// cannot give).
macro_rules! bail {
    ($argument:expr, $($t:tt)*) => {
        return Err(AnalysisError::argument($argument, format!($($t)*)).into())
    };
}

/// Which implementation evaluates the equations.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// The symbolic equations, evaluated by the DAG interpreter.
    Interp,
    /// The independent numeric recursive Newton–Euler reference.
    Numeric,
    /// The Rust code generated at build time (the models under models/ as this build
    /// compiled them, unedited).
    Generated,
}

impl Backend {
    /// The backend named `name` (`interp`, `numeric`, `generated`), if any.
    pub fn parse(name: &str) -> Option<Backend> {
        [Backend::Interp, Backend::Numeric, Backend::Generated]
            .into_iter()
            .find(|b| b.name() == name)
    }

    /// The name the command line and Python use (`interp`, `numeric`, `generated`).
    pub fn name(self) -> &'static str {
        match self {
            Backend::Interp => "interp",
            Backend::Numeric => "numeric",
            Backend::Generated => "generated",
        }
    }
}

/// What to evaluate: a mechanism model at one state (`damper eval`'s options).
#[derive(Clone, Debug, PartialEq)]
pub struct EvalRequest {
    /// Mechanism model file (.toml or .json).
    pub model: PathBuf,
    /// Joint coordinates (empty: all zero).
    pub q: Vec<f64>,
    /// Joint velocities (empty: all zero).
    pub qd: Vec<f64>,
    /// Time (for time-dependent force elements).
    pub t: f64,
    /// Parameter overrides `NAME=VALUE`, in order.
    pub params: Vec<String>,
    /// Implementation used for the evaluation.
    pub backend: Backend,
}

/// Applies `NAME=VALUE` overrides to the model's parameter values; returns the indices of
/// the overridden parameters (into [`Model::parameters`]), in command-line order.
fn apply_params(model: &mut Model, overrides: &[String]) -> Result<Vec<usize>> {
    let mut applied = Vec::with_capacity(overrides.len());
    for o in overrides {
        let Some((name, value)) = o.split_once('=') else {
            bail!(
                "--param",
                "--param {:?}: expected NAME=VALUE",
                diagnostic::truncate(o, 80)
            );
        };
        let (name, shown) = (name.trim(), diagnostic::truncate(name.trim(), 80));
        let value: f64 = value
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| {
                AnalysisError::argument(
                    "--param",
                    format!(
                        "--param {shown}: {:?} is not a finite number",
                        diagnostic::truncate(value.trim(), 80)
                    ),
                )
            })?;
        let Some(k) = model.param_index(name) else {
            let known: Vec<String> = model.parameters.iter().map(|p| p.name.clone()).collect();
            return Err(AnalysisError::UnknownName {
                what: "parameter",
                message: format!(
                    "--param {shown}: no such parameter in model {:?} (known: {})",
                    model.name,
                    known.join(", ")
                ),
                name: shown.to_string(),
                nearest: known,
                file: Some(model.source.path.clone()),
            }
            .into());
        };
        if model.parameters[k].derived {
            bail!(
                "--param",
                "--param {shown}: parameter is derived from other parameters; set those instead"
            );
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
            format!("--{name}"),
            "--{name}: expected {n} values (one per joint coordinate), got {}",
            v.len()
        );
    }
    if let Some(bad) = v.iter().find(|x| !x.is_finite()) {
        bail!(
            format!("--{name}"),
            "--{name}: {bad} is not a finite number"
        );
    }
    Ok(v.to_vec())
}

fn count_json(c: OpCount) -> Value {
    json!({"adds": c.adds, "muls": c.muls, "divs": c.divs, "funcs": c.funcs, "negs": c.negs, "total": c.total()})
}

fn finite(name: &str, v: &[f64]) -> Result<()> {
    if v.iter().any(|x| !x.is_finite()) {
        return Err(AnalysisError::Numerical {
            file: None,
            message: format!(
                "{name} is not finite at this state (check the parameters: a zero length or mass?)"
            ),
        }
        .into());
    }
    Ok(())
}

/// Everything one evaluation computes through the one mechanism interface; matrices as
/// rows.
struct Outputs {
    m: Vec<Vec<f64>>,
    f: Vec<f64>,
    q: Vec<f64>,
    h: Vec<f64>,
    j: Vec<Vec<f64>>,
    a: Vec<f64>,
    /// In the model's point order.
    points: Vec<PointOut>,
}

/// `(p, J rows, A)` of one named point.
type PointOut = ([f64; 3], Vec<Vec<f64>>, [f64; 3]);

fn rows_of(m: &nalgebra::DMatrix<f64>) -> Vec<Vec<f64>> {
    m.row_iter().map(|r| r.iter().copied().collect()).collect()
}

/// Evaluates every equation of `sys` at one state.
fn evaluate(sys: &dyn System, q: &[f64], qd: &[f64], t: f64) -> Outputs {
    let mut ws = sys.workspace();
    sys.evaluate(q, qd, t, &mut ws);
    let points = (0..sys.point_names().len())
        .map(|k| {
            sys.point_kinematics(k, q, qd, &mut ws);
            let (p, a) = (ws.point_p, ws.point_a);
            ([p[0], p[1], p[2]], rows_of(&ws.point_j), [a[0], a[1], a[2]])
        })
        .collect();
    Outputs {
        m: rows_of(&ws.m),
        f: ws.f.as_slice().to_vec(),
        q: ws.q.as_slice().to_vec(),
        h: ws.h.as_slice().to_vec(),
        j: rows_of(&ws.j),
        a: ws.a.as_slice().to_vec(),
        points,
    }
}

/// The implementation of `model`'s equations for `--backend`, through the one registry.
fn system(args: &EvalRequest, model: &Model, overrides: &[usize]) -> Result<Box<dyn System>> {
    let backend = match args.backend {
        Backend::Interp => RtBackend::Interpreted,
        Backend::Numeric => RtBackend::Numeric,
        Backend::Generated => {
            for &k in overrides {
                let p = &model.parameters[k];
                if !p.runtime {
                    bail!(
                        "--param",
                        "--param {}: parameter is folded into the generated code (not `runtime = true` in the model), so it cannot be changed with --backend generated; use --backend interp or numeric",
                        p.name
                    );
                }
            }
            RtBackend::Generated
        }
    };
    let resolved = crate::system_for(model, Some(backend)).map_err(|e| match e {
        model_registry::RegistryError::NotCompiled { .. } => AnalysisError::argument(
            "--backend",
            format!(
                "model {} is not compiled into this binary (compiled in: {}); use --backend interp or numeric, or rebuild",
                args.model.display(),
                model_registry::compiled()
                    .iter()
                    .map(|c| c.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )
        .into(),
        other => Error::Registry(other),
    })?;
    Ok(resolved.system)
}

/// The JSON object `damper eval` prints (see the module documentation) for this request.
pub fn evaluation(args: &EvalRequest) -> Result<Value> {
    let mut model = model::load(&args.model)?;
    let overrides = apply_params(&mut model, &args.params)?;
    // The same physical checks as the model file gets (masses > 0, inertias physical,
    // lengths finite), at the overridden values.
    model::check_parameter_values(&model, &model.default_params(), "--param")?;
    if !args.t.is_finite() {
        bail!("--t", "--t: the time must be a finite number");
    }
    let n = model.dof();
    let q = state("q", &args.q, n)?;
    let qd = state("qd", &args.qd, n)?;
    // The symbolic derivation gives the operation counts and the constraint row names for
    // every backend (and the expressions for the interpreter).
    let sym = Symbolic::derive(&model);
    let sys = system(args, &model, &overrides)?;
    let out = evaluate(sys.as_ref(), &q, &qd, args.t);
    let flat = |rows: &[Vec<f64>]| -> Vec<f64> { rows.iter().flatten().copied().collect() };
    finite("M", &flat(&out.m))?;
    finite("F", &out.f)?;
    finite("Q", &out.q)?;
    finite("h", &out.h)?;
    finite("J", &flat(&out.j))?;
    finite("A", &out.a)?;
    let mut points = Map::new();
    for (name, (p, j, a)) in sys.point_names().iter().zip(&out.points) {
        finite(&format!("point {name:?}"), p)?;
        finite(&format!("point {name:?} J"), &flat(j))?;
        finite(&format!("point {name:?} A"), a)?;
        points.insert(name.clone(), json!({"p": p, "J": j, "A": a}));
    }
    let json = json!({
        "model": model.name,
        "backend": args.backend.name(),
        "q": q,
        "qd": qd,
        "t": args.t,
        "M": out.m,
        "F": out.f,
        "Q": out.q,
        "constraint_names": sys.constraint_names(),
        "h": out.h,
        "J": out.j,
        "A": out.a,
        "points": points,
        "op_count": {
            "M": count_json(sym.op_count_m()),
            "F": count_json(sym.op_count_f()),
            "M+F": count_json(sym.op_count_mf()),
        },
    });
    Ok(json)
}
