//! `damper optimize SCENARIO --vary PATH=LO:HI.. (--maximize|--minimize) FIGURE
//! [--constraint FIGURE>=VALUE].. [--set PATH=VALUE].. [--grid N] [-o DIR] [--json]`: the
//! best design within bounds under constraints ([`crate::optimize`]), every figure from the
//! linearised system about its static equilibrium (a sweep point's figures: `zeta1`, `f1`,
//! `reach`, `amplification`, or any `linear.*` name).
//!
//! Prints the optimum (every variable, those at a bound), the objective, every constraint
//! with its value, margin, whether it is active and its multiplier, the KKT residual, how
//! many local searches agreed and the evaluations; `--json` prints the same as one object
//! (`optimum`, `objective`, `constraints`, `kkt_residual`, `history`). With `-o DIR`:
//! `optimize.json` and `optimize_history.csv` (every evaluation: stage, variables,
//! objective, constraint values, the right-hand figures of constraints between figures, error). An infeasible problem is an error naming the least
//! infeasible point (exit status 2). `--verify` runs the optimum in the time domain (a free
//! decay from the amplitude of a `reach>=A` constraint) and reports its figures (`verify`).

use std::path::PathBuf;

use crate::Error;
use crate::analysis::figures::Constraint;
use crate::analysis::optimization::{OptimizeRequest, solve, verify};
use crate::optimize::Variable;
use crate::report::optimize::{self, Report};
use crate::report::{OutputLock, ReportError, commit_files};
use crate::scenario::{self, Override};

/// Arguments of `damper optimize`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("goal").required(true).args(["maximize", "minimize"])))]
pub struct Args {
    /// Scenario file (`kind = "damper"` or `kind = "hybrid"`).
    pub scenario: PathBuf,
    /// A design variable and its bounds: `PATH=LO:HI` (repeatable).
    #[arg(long = "vary", value_name = "PATH=LO:HI", required = true)]
    pub vary: Vec<String>,
    /// Maximise this figure (`zeta1`, `f1`, `reach`, `amplification`, any `linear.*`,
    /// `peak:X:F1:F2`, `power` or `rms:OUTPUT`).
    #[arg(long, value_name = "FIGURE")]
    pub maximize: Option<String>,
    /// Minimise this figure (the same names).
    #[arg(long, value_name = "FIGURE")]
    pub minimize: Option<String>,
    /// A constraint `FIGURE>=VALUE` or `FIGURE<=VALUE`, or between two figures,
    /// `FIGURE>=K*FIGURE` or `FIGURE<=K*FIGURE` (repeatable; e.g. `reach>=0.002`,
    /// `linear.reach>=4*random.rms:1.0`).
    #[arg(long = "constraint", value_name = "FIGURE>=VALUE")]
    pub constraints: Vec<String>,
    /// A fixed override of the scenario: `--set PATH=VALUE` (repeatable).
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub set: Vec<Override>,
    /// Points per variable of the start grid (at most 125 points in all).
    #[arg(long, default_value_t = 5)]
    pub grid: usize,
    /// How the random figures are computed, as `damper random --method` (`auto`, `dense`,
    /// `modal`, `quadrature`).
    #[arg(long, default_value = "auto")]
    pub method: String,
    /// Print the result as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Also write `optimize.json` and `optimize_history.csv` into this directory.
    #[arg(short = 'o', long = "out")]
    pub out: Option<PathBuf>,
    /// Run the optimum in the time domain and report its figures beside the linear ones: a
    /// free decay from the amplitude of a `reach>=A` constraint (`initial.displacement = A`,
    /// when the scenario has an `[initial]` table), else the scenario's own run.
    #[arg(long)]
    pub verify: bool,
    /// The amplitude of `--verify`'s free decay (m), instead of the reach constraint's.
    #[arg(long, value_name = "A", requires = "verify")]
    pub verify_amplitude: Option<f64>,
    /// Run even when the estimated evaluations are above the limit (1e4).
    #[arg(long)]
    pub allow_long: bool,
}

/// Runs `damper optimize`.
pub fn run(args: Args) -> Result<(), Error> {
    // The options are checked before the scenario is read.
    for v in &args.vary {
        v.parse::<Variable>()?;
    }
    for c in &args.constraints {
        c.parse::<Constraint>()
            .map_err(crate::analysis::sweep::SpecError::from)?;
    }
    let text = scenario::read(&args.scenario)?;
    let (objective, maximize) = match (&args.maximize, &args.minimize) {
        (Some(f), None) => (f.clone(), true),
        (None, Some(f)) => (f.clone(), false),
        _ => return Err(Error::Usage("give one of --maximize or --minimize".into())),
    };
    let started = std::time::Instant::now();
    let request = OptimizeRequest {
        scenario: args.scenario.clone(),
        text,
        fixed: args.set.clone(),
        vary: args.vary.clone(),
        objective,
        maximize,
        constraints: args.constraints.clone(),
        grid: args.grid,
        method: crate::commands::sweep::parse_method(&args.method)?,
        allow_long: args.allow_long,
    };
    let (outcome, constraints) = solve(&request)?;
    let _lock = match &args.out {
        Some(out) => Some(OutputLock::acquire(out).map_err(ReportError::from)?),
        None => None,
    };
    let verified = args
        .verify
        .then(|| verify(&request, &outcome, &constraints, args.verify_amplitude));
    let json = Report {
        outcome: &outcome,
        verify: verified.as_ref(),
    }
    .json()?;
    if let Some(out) = &args.out {
        commit_files(&optimize::files(out, &json, &outcome, &constraints)?)
            .map_err(ReportError::from)?;
    }
    if args.json {
        return crate::print(&(String::from_utf8_lossy(&json).into_owned() + "\n"));
    }
    crate::print(&optimize::text(
        &args.scenario.display().to_string(),
        &outcome,
        &constraints,
        maximize,
        verified.as_ref(),
        started.elapsed().as_secs_f64(),
    ))
}
