//! `damper eval`: evaluate the equations of a mechanism model at one state and print them
//! as one JSON object ([`crate::analysis::eval`] describes it).

use std::path::PathBuf;

use crate::Error;
use crate::analysis::eval::{Backend, EvalRequest, evaluation};
use crate::report::ReportError;

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

impl Args {
    /// The evaluation these arguments ask for.
    pub fn request(self) -> EvalRequest {
        EvalRequest {
            model: self.model,
            q: self.q,
            qd: self.qd,
            t: self.t,
            params: self.params,
            backend: self.backend,
        }
    }
}

/// Runs `damper eval`.
pub fn run(args: Args) -> Result<(), Error> {
    let json = evaluation(&args.request())?;
    let text = serde_json::to_string_pretty(&json).map_err(ReportError::from)?;
    crate::print(&(text + "\n"))?;
    Ok(())
}
