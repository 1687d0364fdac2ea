//! `damper eval`: evaluate the equations of motion of a mechanism model at one state.
//!
//! Prints one JSON object: the model name, the backend, the state, `M` (row-major array of
//! rows, eq. 11), `F` (eq. 12), `Q` (eq. 13), and the operation counts of the symbolic `M`
//! and `F`.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use mbs_symbolic::dynamics::Symbolic;
use mbs_symbolic::expr::OpCount;
use mbs_symbolic::interp::Interpreter;
use mbs_symbolic::model::{self, Model};
use mbs_symbolic::numeric::NumericModel;
use serde_json::{Value, json};

/// Which implementation evaluates the equations.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// The symbolic equations, evaluated by the DAG interpreter.
    Interp,
    /// The independent numeric recursive Newton–Euler reference.
    Numeric,
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
    /// Override a parameter: NAME=VALUE (repeatable).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Implementation used for the evaluation.
    #[arg(long, value_enum, default_value = "interp")]
    pub backend: Backend,
}

/// Applies `NAME=VALUE` overrides to the model's parameter values.
fn apply_params(model: &mut Model, overrides: &[String]) -> Result<()> {
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
    }
    Ok(())
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

/// Runs `damper eval`.
pub fn run(args: Args) -> Result<()> {
    let mut model = model::load(&args.model).map_err(|e| anyhow::anyhow!("{e}"))?;
    apply_params(&mut model, &args.params)?;
    let n = model.dof();
    let q = state("q", &args.q, n)?;
    let qd = state("qd", &args.qd, n)?;
    let params = model.default_params();
    let sym = Symbolic::derive(&model);
    let (m, f, qv) = match args.backend {
        Backend::Interp => {
            let it = Interpreter::from_symbolic(&sym, params);
            (
                it.mass_matrix(&q),
                it.f_vector(&q, &qd),
                it.q_vector(&q, &qd, args.t),
            )
        }
        Backend::Numeric => {
            let nm = NumericModel::new(&model, &params);
            let mm = nm.mass_matrix(&q);
            let rows: Vec<f64> = (0..n)
                .flat_map(|i| (0..n).map(move |j| (i, j)))
                .map(|(i, j)| mm[(i, j)])
                .collect();
            (
                rows,
                nm.f_vector(&q, &qd).as_slice().to_vec(),
                nm.q_vector(&q, &qd, args.t).as_slice().to_vec(),
            )
        }
    };
    finite("M", &m)?;
    finite("F", &f)?;
    finite("Q", &qv)?;
    let rows: Vec<&[f64]> = m.chunks(n.max(1)).collect();
    let out = json!({
        "model": model.name,
        "backend": match args.backend { Backend::Interp => "interp", Backend::Numeric => "numeric" },
        "q": q,
        "qd": qd,
        "t": args.t,
        "M": rows,
        "F": f,
        "Q": qv,
        "op_count": {
            "M": count_json(sym.op_count_m()),
            "F": count_json(sym.op_count_f()),
            "M+F": count_json(sym.op_count_mf()),
        },
    });
    println!("{}", serde_json::to_string_pretty(&out)?);
    Ok(())
}
