//! `damper figures SCENARIO [--json]`: the figures the scenario offers, from the one
//! catalogue ([`crate::analysis::figures`]): name, unit, which analysis computes it, whether
//! its gradient is exact (adjoint) and what it means — the names `sweep` (`--map`,
//! `--constraint`) and `optimize` (objective, constraints) accept. A parameter that the
//! user chooses (`peak:X:F1:F2`, `random.rms:OUTPUT`) is shown with its placeholder; the
//! earlier short names (aliases) follow.

use std::fmt::Write as _;
use std::path::PathBuf;

use crate::Error;
use crate::analysis::figures::{CATALOGUE, Entities, listing};
use crate::report::ReportError;
use crate::scenario;

/// Arguments of `damper figures`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scenario file (`kind = "damper"` or `kind = "hybrid"`).
    pub scenario: PathBuf,
    /// Print one JSON array of `{name, unit, producer, gradient, on_request, meaning}`.
    #[arg(long)]
    pub json: bool,
}

/// Runs `damper figures`.
pub fn run(args: Args) -> Result<(), Error> {
    let loaded = scenario::load_with(&args.scenario, &[])?;
    if let scenario::Scenario::Mechanism(_) = loaded.scenario {
        return Err(Error::Usage(format!(
            "{}: a `kind = \"mechanism\"` scenario has no design figures (sweeps and optimize take damper and hybrid scenarios)",
            args.scenario.display()
        )));
    }
    let entities = Entities::of(&loaded.scenario);
    let rows = listing(&loaded.scenario);
    if args.json {
        let mut v = serde_json::to_vec_pretty(&rows).map_err(ReportError::from)?;
        v.push(b'\n');
        return crate::print(&String::from_utf8_lossy(&v));
    }
    let width = rows.iter().map(|r| r.name.len()).max().unwrap_or(4).max(4);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<width$}  {:<15}  {:<11}  {:<11}  meaning",
        "name", "unit", "producer", "gradient"
    );
    for r in &rows {
        let gradient = match r.gradient {
            crate::analysis::figures::Gradient::Adjoint => "adjoint",
            crate::analysis::figures::Gradient::Differences => "differences",
        };
        let asked = if r.on_request { " (on request)" } else { "" };
        let _ = writeln!(
            out,
            "{:<width$}  {:<15}  {:<11}  {:<11}  {}{asked}",
            r.name, r.unit, r.producer, gradient, r.meaning
        );
    }
    let aliases: Vec<String> = CATALOGUE
        .iter()
        .filter(|e| entities.offers(e))
        .flat_map(|e| {
            e.aliases
                .iter()
                .map(move |a| format!("{} = {}", e.display_alias(a), e.display()))
        })
        .collect();
    let _ = writeln!(out, "\naliases: {}", aliases.join(", "));
    crate::print(&out)
}
