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
use crate::analysis::figures::{Bound, Constraint};
use crate::analysis::optimization::{OptimizeRequest, solve};
use crate::optimize::{self, Variable};
use crate::report::csv::cell;
use crate::report::{OutputFile, OutputLock, ReportError, commit_files};
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
    let file = args.scenario.display().to_string();
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
    let (outcome, constraints) = solve(&OptimizeRequest {
        scenario: args.scenario.clone(),
        text: text.clone(),
        fixed: args.set.clone(),
        vary: args.vary.clone(),
        objective,
        maximize,
        constraints: args.constraints.clone(),
        grid: args.grid,
        method: crate::commands::sweep::parse_method(&args.method)?,
        allow_long: args.allow_long,
    })?;
    let _lock = match &args.out {
        Some(out) => Some(OutputLock::acquire(out).map_err(ReportError::from)?),
        None => None,
    };
    let verified = match args.verify {
        true => Some(verify(&args, &text, &outcome, &constraints)),
        false => None,
    };
    let report = Report {
        outcome: &outcome,
        verify: verified.as_ref(),
    };
    let json = serde_json::to_vec_pretty(&report).map_err(ReportError::from)?;
    if let Some(out) = &args.out {
        let csv = crate::report::optimize::history_table(&outcome, &constraints)
            .csv(&|x| cell(Some(x)))
            .map_err(|e| Error::from(ReportError::from(e)))?;
        let mut json_file = json.clone();
        json_file.push(b'\n');
        commit_files(&[
            OutputFile {
                path: out.join("optimize.json"),
                bytes: json_file,
            },
            OutputFile {
                path: out.join("optimize_history.csv"),
                bytes: csv,
            },
        ])
        .map_err(ReportError::from)?;
    }
    if args.json {
        return crate::print(&(String::from_utf8_lossy(&json).into_owned() + "\n"));
    }
    let mut text = format!("{file}: optimum ");
    let xs: Vec<String> = outcome
        .optimum
        .iter()
        .map(|(p, x)| format!("{p} = {}", cell(Some(*x))))
        .collect();
    text.push_str(&xs.join(", "));
    text.push_str(&format!(
        "; {} = {} ({})\n",
        outcome.objective.0,
        cell(Some(outcome.objective.1)),
        if maximize { "maximised" } else { "minimised" }
    ));
    if outcome.overdamped {
        text.push_str("  the first mode is overdamped at the optimum (zeta1 reads 1 there: maximise decay1 for the fastest decay)\n");
    }
    for (k, (p, side)) in outcome.at_bounds.iter().enumerate() {
        let mult = outcome
            .bound_multipliers
            .get(k)
            .map_or(String::new(), |m| format!(", multiplier {m:.3e}"));
        text.push_str(&format!("  {p} at its {side} bound{mult}\n"));
    }
    for (c, spec) in outcome.constraints.iter().zip(&constraints) {
        let state = if c.active { "active" } else { "inactive" };
        let mult = c
            .multiplier
            .map_or(String::new(), |m| format!(", multiplier {m:.3e}"));
        let rhs = match &spec.other {
            Some(b) => format!(
                " against {} * {b} = {}",
                cell(Some(spec.value)),
                cell(Some(c.rhs))
            ),
            None => String::new(),
        };
        text.push_str(&format!(
            "  {}: value {}{rhs}, margin {:.3e}, {state}{mult}\n",
            c.constraint,
            cell(Some(c.value)),
            c.margin
        ));
    }
    for g in &outcome.gradients {
        let parts: Vec<String> = outcome
            .optimum
            .iter()
            .zip(&g.gradient)
            .map(|((path, _), d)| format!("d/d {path} = {d:.6e}"))
            .collect();
        let method = match g.method {
            crate::sensitivity::Method::Adjoint => "adjoint",
            crate::sensitivity::Method::Differences => "differences",
        };
        text.push_str(&format!(
            "  gradient of {}: {} ({method})\n",
            g.figure,
            parts.join(", ")
        ));
    }
    if let Some(e) = &outcome.gradient_error {
        text.push_str(&format!("  no gradients at the optimum: {e}\n"));
    }
    if let Some(v) = &verified {
        text.push_str(&format!("  time domain ({}): ", v.run));
        match &v.error {
            Some(e) => {
                text.push_str(&format!("failed: {e}\n"));
                let reach_active = outcome
                    .constraints
                    .iter()
                    .any(|c| c.active && c.constraint.starts_with("reach"));
                if reach_active && e.contains("singular position") {
                    text.push_str("  (the reach constraint is active: the optimum reaches the toggle at exactly that amplitude; ask for a margin, e.g. reach>=1.1 A, or verify from a smaller amplitude with --verify-amplitude)\n");
                }
            }
            None => {
                let shown: Vec<String> = v
                    .figures
                    .iter()
                    .filter(|(n, _)| !n.starts_with("linear."))
                    .map(|(n, x)| format!("{n} = {}", x.map_or("n/a".into(), |x| cell(Some(x)))))
                    .collect();
                text.push_str(&shown.join(", "));
                text.push('\n');
            }
        }
    }
    text.push_str(&format!("  {}\n", outcome.certificate));
    text.push_str(&format!(
        "  {} of {} local search(es) reached this optimum; {} evaluations in {:.1} s\n",
        outcome.starts_agreeing,
        outcome.starts,
        outcome.history.len(),
        started.elapsed().as_secs_f64()
    ));
    crate::print(&text)
}

/// What `--json` prints and `optimize.json` holds.
#[derive(serde::Serialize)]
struct Report<'a> {
    #[serde(flatten)]
    outcome: &'a optimize::Outcome,
    #[serde(skip_serializing_if = "Option::is_none")]
    verify: Option<&'a Verified>,
}

/// The time-domain run of the optimum (`--verify`).
#[derive(serde::Serialize)]
struct Verified {
    /// What was run.
    run: String,
    /// Every figure of the point (the linear ones and the time domain's).
    figures: Vec<(String, Option<f64>)>,
    /// Why the time-domain run (or the point) failed.
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<String>,
}

/// Runs the optimum in the time domain (see [`Args::verify`]).
fn verify(
    args: &Args,
    text: &str,
    outcome: &optimize::Outcome,
    constraints: &[Constraint],
) -> Verified {
    let mut overrides = optimize::overrides_at(
        &args.set,
        outcome.optimum.iter().map(|(p, x)| (p.as_str(), x)),
    );
    let amplitude = args.verify_amplitude.or_else(|| {
        constraints
            .iter()
            .find(|c| c.figure == "linear.reach" && c.bound == Bound::AtLeast && c.other.is_none())
            .map(|c| c.value)
    });
    let has_initial = text.lines().any(|l| l.trim() == "[initial]");
    let run = match (amplitude, has_initial) {
        (Some(a), true) => {
            let t = cell(Some(a));
            overrides.extend(optimize::overrides_at(
                &[],
                [("initial.displacement", &a)].into_iter(),
            ));
            format!("free decay from {t} m")
        }
        _ => "the scenario's own run".to_string(),
    };
    let options = crate::sweep_point::PointOptions {
        time_domain: true,
        allow_long: args.allow_long,
        ..Default::default()
    };
    let line = |e: &dyn std::fmt::Display| e.to_string().replace('\n', "; ");
    match crate::sweep_point::evaluate(&args.scenario, text, &overrides, &options) {
        Ok(p) => Verified {
            run,
            figures: p.figures.into_iter().map(|f| (f.name, f.value)).collect(),
            error: p.time_domain_error.map(|e| line(&e)),
        },
        Err(e) => Verified {
            run,
            figures: vec![],
            error: Some(line(&e)),
        },
    }
}
