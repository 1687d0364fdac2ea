//! `damper modes BEAM.toml [--count K] [--json]`: natural frequencies of a finite-element
//! beam (`fem-beam`), with the closed-form Euler–Bernoulli values alongside when the
//! boundary conditions have them (cantilever, simply supported, clamped–clamped, free–free,
//! clamped–pinned, pinned–free on a uniform beam). The file is a beam description or a
//! scenario (one with a `kind` or a `[beam]` table): then its beam, without mechanisms.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use fem_beam::{Beam, BeamModel, analytic};

use crate::Error;
use crate::report::ReportError;
use crate::scenario::{self, Scenario};

/// Arguments of `damper modes`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Beam description (TOML, e.g. beams/cantilever.toml) or a scenario: its beam alone.
    pub beam: PathBuf,
    /// Number of modes (lowest first; rigid-body modes count).
    #[arg(long, default_value_t = 5)]
    pub count: usize,
    /// Print `{"frequencies_hz": [...], "analytic_hz": [...] or null}` instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Runs the subcommand: reads and validates the beam, assembles it, computes the lowest
/// `count` modes and prints them (table or JSON).
pub fn run(args: Args) -> Result<(), Error> {
    crate::print(&report(&args)?)
}

/// The beam of `path`: a scenario's (a file with a `kind` key or a `[beam]` table, loaded
/// and checked as `simulate` loads it), else the file read as a beam description.
fn beam_of(path: &Path) -> Result<Beam, Error> {
    let text =
        diagnostic::read_input(path, "beam or scenario").map_err(diagnostic::Diagnostics::from)?;
    let is_scenario = text
        .parse::<toml::Table>()
        .is_ok_and(|t| t.contains_key("kind") || t.contains_key("beam"));
    if !is_scenario {
        return Ok(Beam::from_file(path)?);
    }
    let no_beam = |what: &str| {
        Error::Input(
            diagnostic::Diagnostic::new(
                diagnostic::Kind::InvalidValue,
                path.display().to_string(),
                format!("{what} has no beam: `damper modes` gives a beam's modes (`damper linearize` the coupled system's)"),
            )
            .into(),
        )
    };
    match scenario::load_with(path, &[])?.scenario {
        Scenario::Hybrid(sc) => sc
            .beam
            .map(|(_, beam)| beam)
            .ok_or_else(|| no_beam("this scenario")),
        Scenario::Mechanism(_) => Err(no_beam("a mechanism scenario")),
    }
}

/// The text `damper modes` prints.
fn report(args: &Args) -> Result<String, Error> {
    // Library errors already name the file, line and entity.
    let beam = beam_of(&args.beam)?;
    let model = BeamModel::new(&beam)?;
    let modes = model.modes(args.count)?;
    let fe = modes.frequencies_hz();
    let reference = analytic::frequencies_hz(&beam, args.count);
    // Physically absurd input (density 5e-324) overflows: refuse instead of printing inf/NaN.
    let file = args.beam.display().to_string();
    let not_finite = |what: &str, k: usize, f: f64| {
        Error::Input(
            diagnostic::Diagnostic::new(
                diagnostic::Kind::InvalidValue,
                file.clone(),
                format!("{what} frequency of mode {} is {f}, not a finite number (check density, stiffness and sizes)", k + 1),
            )
            .entity(format!("beam {:?}", diagnostic::truncate(beam.name().unwrap_or("(unnamed)"), 80)))
            .into(),
        )
    };
    if let Some((k, f)) = fe.iter().enumerate().find(|(_, f)| !f.is_finite()) {
        return Err(not_finite("the finite-element", k, *f));
    }
    if let Some((k, f)) = reference
        .iter()
        .flat_map(|(_, a)| a.iter().enumerate())
        .find(|(_, f)| !f.is_finite())
    {
        return Err(not_finite("the analytic", k, *f));
    }

    if args.json {
        // Written by hand to keep the documented key order (serde_json's map sorts keys).
        let analytic = reference.as_ref().map(|(_, f)| f);
        let json = |r: serde_json::Result<String>| r.map_err(ReportError::Json);
        return Ok(format!(
            "{{\"frequencies_hz\": {}, \"analytic_hz\": {}}}\n",
            json(serde_json::to_string(&fe))?,
            json(serde_json::to_string(&analytic))?
        ));
    }

    let mut out = String::new();
    let elements: usize = beam.segments().iter().map(|s| s.elements).sum();
    let segments = beam.segments().len();
    let _ = writeln!(out, "beam: {}", beam.name().unwrap_or("(unnamed)"));
    let _ = writeln!(
        out,
        "file: {}; {segments} segment{}, {elements} elements, {} free DOFs, length {} m",
        args.beam.display(),
        if segments == 1 { "" } else { "s" },
        model.dof_count(),
        beam.length()
    );
    let _ = match &reference {
        Some((case, _)) => writeln!(
            out,
            "boundary conditions: {case}; reference: Euler-Bernoulli closed form"
        ),
        None => writeln!(
            out,
            "boundary conditions: no closed-form reference (non-uniform beam or other supports)"
        ),
    };
    let _ = writeln!(out);
    match &reference {
        Some((_, exact)) => {
            let _ = writeln!(
                out,
                "{:>4}  {:>18}  {:>18}  {:>11}",
                "mode", "FE [Hz]", "analytic [Hz]", "rel. error"
            );
            for (i, (f, a)) in fe.iter().zip(exact).enumerate() {
                let err = if *a == 0.0 {
                    "rigid".to_string()
                } else {
                    format!("{:+.3e}", f / a - 1.0)
                };
                let _ = writeln!(out, "{:>4}  {:>18.9}  {:>18.9}  {:>11}", i + 1, f, a, err);
            }
        }
        None => {
            let _ = writeln!(out, "{:>4}  {:>18}", "mode", "FE [Hz]");
            for (i, f) in fe.iter().enumerate() {
                let _ = writeln!(out, "{:>4}  {:>18.9}", i + 1, f);
            }
        }
    }
    Ok(out)
}
