//! The constrained design optimisation of a scenario ([`OptimizeRequest`] → [`solve`]),
//! what `damper optimize` reports and Python's `Scenario.optimize` returns: the variables'
//! PATHs and the figures checked against the scenario before any search, the number of
//! evaluations bounded, then [`crate::optimize::optimize`] (its gradients
//! [`crate::sensitivity`]).

use std::path::PathBuf;

use crate::Error;
use crate::analysis::AnalysisError;
use crate::analysis::figures::{self, Bound, Constraint, Entities};
use crate::budget::{self, Quantity};
use crate::optimize::{self, MAX_EVALS, MAX_GRID, MAX_STARTS, Problem, Variable};
use crate::scenario::{self, Override};

/// What to compute: the best design of a scenario.
#[derive(Clone, Debug)]
pub struct OptimizeRequest {
    /// The scenario file (its directory the base of relative paths; messages name it).
    pub scenario: PathBuf,
    /// The scenario's text.
    pub text: String,
    /// Overrides applied before the variables'.
    pub fixed: Vec<Override>,
    /// The variables `PATH=LO:HI`.
    pub vary: Vec<String>,
    /// The objective figure.
    pub objective: String,
    /// Maximise (else minimise) the objective.
    pub maximize: bool,
    /// The constraints `FIGURE>=VALUE` or `FIGURE>=K*FIGURE`, as written.
    pub constraints: Vec<String>,
    /// Start-grid points per variable.
    pub grid: usize,
    /// How the random figures are computed (`damper random --method`).
    pub method: crate::random::RandomMethod,
    /// Run even above the evaluation limit.
    pub allow_long: bool,
}

/// Most evaluations without `--allow-long` (each a linearisation: milliseconds).
const MAX_EVALUATIONS: f64 = 1e4;

/// The optimum `req` asks for; above the evaluation limit unless `allow_long`. Returns the
/// outcome and the constraints, their figure names expanded.
pub fn solve(req: &OptimizeRequest) -> Result<(optimize::Outcome, Vec<Constraint>), Error> {
    let OptimizeRequest {
        scenario: path,
        text,
        fixed,
        vary,
        objective,
        maximize,
        constraints,
        grid,
        method,
        allow_long,
    } = req;
    let (path, text, fixed) = (path.as_path(), text.as_str(), &fixed[..]);
    let (maximize, grid, allow_long) = (*maximize, *grid, *allow_long);
    let file = path.display().to_string();
    let vary: Vec<Variable> = vary.iter().map(|v| v.parse()).collect::<Result<_, _>>()?;
    if vary.is_empty() {
        return Err(AnalysisError::argument(
            "--vary",
            format!("{file}: {}", optimize::OptimizeError::NoVariables),
        )
        .into());
    }
    // The fixed overrides and the scenario must load, the figures be the scenario's and the
    // variables' PATHs fields it takes, before any search.
    let loaded = scenario::parse_with(text, path, fixed)?;
    budget::structure(&loaded.scenario, &file, allow_long)?;
    let entities = Entities::of(&loaded.scenario);
    let spec_error = crate::analysis::sweep::SpecError::from;
    let constraints: Vec<Constraint> = constraints
        .iter()
        .map(|c| c.parse::<Constraint>()?.resolve(Some(&entities)))
        .collect::<Result<_, _>>()
        .map_err(spec_error)?;
    let goal = if maximize { "--maximize" } else { "--minimize" };
    let objective = figures::resolve(objective, Some(&entities))
        .map_err(|e| AnalysisError::unknown_figure(goal, &e))?
        .name;
    crate::analysis::sweep::check_paths(
        path,
        text,
        fixed,
        vary.iter().map(|v| (v.path.as_str(), v.lo)),
    )?;
    let d = vary.len();
    let evaluations = (MAX_GRID as f64).min((grid.max(2) as f64).powi(d as i32))
        + (MAX_STARTS * (MAX_EVALS + 4 * d)) as f64;
    budget::refuse_above(
        &format!("optimize of {file}"),
        &[Quantity::count("evaluations", evaluations, MAX_EVALUATIONS)],
        "use fewer variables",
        allow_long,
    )?;
    let problem = Problem {
        path,
        text,
        fixed,
        variables: &vary,
        objective,
        maximize,
        constraints: &constraints,
        grid,
        method: *method,
    };
    let outcome = optimize::optimize(&problem)
        .map_err(|error| AnalysisError::Optimization { file, error })?;
    Ok((outcome, constraints))
}

/// The time-domain run of an optimum (`damper optimize --verify`): what was run and every
/// figure of the point, or why it failed.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Verified {
    /// What was run.
    pub run: String,
    /// Every figure of the point (the linear ones and the time domain's).
    pub figures: Vec<(String, Option<f64>)>,
    /// Why the time-domain run (or the point) failed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// Runs the optimum of `req` in the time domain: a free decay from `amplitude` (else from
/// the amplitude of a `linear.reach>=A` constraint) when the scenario has an `[initial]`
/// table, else the scenario's own run.
pub fn verify(
    req: &OptimizeRequest,
    outcome: &optimize::Outcome,
    constraints: &[Constraint],
    amplitude: Option<f64>,
) -> Verified {
    let mut overrides = optimize::overrides_at(
        &req.fixed,
        outcome.optimum.iter().map(|(p, x)| (p.as_str(), x)),
    );
    let amplitude = amplitude.or_else(|| {
        constraints
            .iter()
            .find(|c| c.figure == "linear.reach" && c.bound == Bound::AtLeast && c.other.is_none())
            .map(|c| c.value)
    });
    let has_initial = req.text.lines().any(|l| l.trim() == "[initial]");
    let run = match (amplitude, has_initial) {
        (Some(a), true) => {
            let t = crate::report::csv::cell(Some(a));
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
        allow_long: req.allow_long,
        ..Default::default()
    };
    let line = |e: &dyn std::fmt::Display| e.to_string().replace('\n', "; ");
    match crate::sweep_point::evaluate(&req.scenario, &req.text, &overrides, &options) {
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
