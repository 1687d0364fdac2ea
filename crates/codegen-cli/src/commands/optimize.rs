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
//! objective, constraint values, error). An infeasible problem is an error naming the least
//! infeasible point (exit status 2).

use std::path::PathBuf;

use crate::Error;
use crate::budget::{self, Quantity};
use crate::commands::sweep::Constraint;
use crate::optimize::{self, MAX_EVALS, MAX_GRID, MAX_STARTS, Problem, Variable, figure_name};
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
    /// Maximise this figure (`zeta1`, `f1`, `reach`, `amplification` or any `linear.*`).
    #[arg(long, value_name = "FIGURE")]
    pub maximize: Option<String>,
    /// Minimise this figure.
    #[arg(long, value_name = "FIGURE")]
    pub minimize: Option<String>,
    /// A constraint `FIGURE>=VALUE` or `FIGURE<=VALUE` (repeatable; e.g. `reach>=0.002`).
    #[arg(long = "constraint", value_name = "FIGURE>=VALUE")]
    pub constraints: Vec<String>,
    /// A fixed override of the scenario: `--set PATH=VALUE` (repeatable).
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub set: Vec<Override>,
    /// Points per variable of the start grid (at most 125 points in all).
    #[arg(long, default_value_t = 5)]
    pub grid: usize,
    /// Print the result as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Also write `optimize.json` and `optimize_history.csv` into this directory.
    #[arg(short = 'o', long = "out")]
    pub out: Option<PathBuf>,
    /// Run even when the estimated evaluations are above the limit (1e4).
    #[arg(long)]
    pub allow_long: bool,
}

/// Most evaluations without `--allow-long` (each a linearisation: milliseconds).
const MAX_EVALUATIONS: f64 = 1e4;

/// Runs `damper optimize`.
pub fn run(args: Args) -> Result<(), Error> {
    let file = args.scenario.display().to_string();
    let vary: Vec<Variable> = args
        .vary
        .iter()
        .map(|v| v.parse())
        .collect::<Result<_, _>>()?;
    let parsed: Vec<Constraint> = args
        .constraints
        .iter()
        .map(|c| c.parse())
        .collect::<Result<_, _>>()?;
    let text = scenario::read(&args.scenario)?;
    // The fixed overrides and the scenario must load before any search.
    scenario::parse_with(&text, &args.scenario, &args.set)?;
    let d = vary.len();
    let evaluations = (MAX_GRID as f64).min((args.grid.max(2) as f64).powi(d as i32))
        + (MAX_STARTS * (MAX_EVALS + 4 * d)) as f64;
    budget::refuse_above(
        &format!("optimize of {file}"),
        &[Quantity::count("evaluations", evaluations, MAX_EVALUATIONS)],
        "use fewer variables",
        args.allow_long,
    )?;
    let (objective, maximize) = match (&args.maximize, &args.minimize) {
        (Some(f), None) => (figure_name(f), true),
        (None, Some(f)) => (figure_name(f), false),
        _ => return Err(Error::Usage("give one of --maximize or --minimize".into())),
    };
    let constraints: Vec<Constraint> = parsed
        .iter()
        .map(|c| Constraint {
            figure: figure_name(&c.figure),
            ..c.clone()
        })
        .collect();
    let _lock = match &args.out {
        Some(out) => Some(OutputLock::acquire(out).map_err(ReportError::from)?),
        None => None,
    };
    let problem = Problem {
        path: &args.scenario,
        text: &text,
        fixed: &args.set,
        variables: &vary,
        objective: objective.clone(),
        maximize,
        constraints: &constraints,
        grid: args.grid,
    };
    let started = std::time::Instant::now();
    let outcome = optimize::optimize(&problem).map_err(|e| Error::Usage(format!("{file}: {e}")))?;
    let json = serde_json::to_vec_pretty(&outcome).map_err(ReportError::from)?;
    if let Some(out) = &args.out {
        let mut csv = ::csv::Writer::from_writer(vec![]);
        let mut header = vec!["stage".to_string()];
        header.extend(vary.iter().map(|v| v.path.clone()));
        header.push(objective.clone());
        header.extend(constraints.iter().map(|c| c.figure.clone()));
        header.push("error".into());
        let csv_err = |e: ::csv::Error| Error::from(ReportError::from(e));
        csv.write_record(&header).map_err(csv_err)?;
        for e in &outcome.history {
            let mut row = vec![e.stage.clone()];
            row.extend(e.x.iter().map(|x| cell(Some(*x))));
            row.push(cell(e.objective));
            row.extend(e.values.iter().map(|v| cell(*v)));
            row.push(e.error.clone().unwrap_or_default());
            csv.write_record(&row).map_err(csv_err)?;
        }
        let csv = csv
            .into_inner()
            .map_err(|e| csv_err(e.into_error().into()))?;
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
    for (p, side) in &outcome.at_bounds {
        text.push_str(&format!("  {p} at its {side} bound\n"));
    }
    for c in &outcome.constraints {
        let state = if c.active { "active" } else { "inactive" };
        let mult = c
            .multiplier
            .map_or(String::new(), |m| format!(", multiplier {m:.3e}"));
        text.push_str(&format!(
            "  {}: value {}, margin {:.3e}, {state}{mult}\n",
            c.constraint,
            cell(Some(c.value)),
            c.margin
        ));
    }
    text.push_str(&format!(
        "  KKT residual {:.1e}; {} of {} local search(es) ended here; {} evaluations in {:.1} s\n",
        outcome.kkt_residual,
        outcome.starts_agreeing,
        outcome.starts,
        outcome.history.len(),
        started.elapsed().as_secs_f64()
    ));
    crate::print(&text)
}
