//! `damper modes BEAM.toml [--count K] [--json]`: natural frequencies of a finite-element
//! beam (`fem-beam`), with the closed-form Euler–Bernoulli values alongside when the
//! boundary conditions have them (cantilever, simply supported, clamped–clamped, free–free,
//! clamped–pinned, pinned–free on a uniform beam).

use std::path::PathBuf;

use fem_beam::{Beam, BeamModel, analytic};

/// Arguments of `damper modes`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Beam description (TOML), e.g. beams/cantilever.toml.
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
pub fn run(args: Args) -> anyhow::Result<()> {
    // Library errors already name the file, line and entity.
    let beam = Beam::from_file(&args.beam)?;
    let model = BeamModel::new(&beam)?;
    let modes = model.modes(args.count)?;
    let fe = modes.frequencies_hz();
    let reference = analytic::frequencies_hz(&beam, args.count);

    if args.json {
        // Written by hand to keep the documented key order (serde_json's map sorts keys).
        println!(
            "{{\"frequencies_hz\": {}, \"analytic_hz\": {}}}",
            serde_json::to_string(&fe)?,
            serde_json::to_string(&reference.as_ref().map(|(_, f)| f))?
        );
        return Ok(());
    }

    let elements: usize = beam.segments().iter().map(|s| s.elements).sum();
    let segments = beam.segments().len();
    println!("beam: {}", beam.name().unwrap_or("(unnamed)"));
    println!(
        "file: {}; {segments} segment{}, {elements} elements, {} free DOFs, length {} m",
        args.beam.display(),
        if segments == 1 { "" } else { "s" },
        model.dof_count(),
        beam.length()
    );
    match &reference {
        Some((case, _)) => {
            println!("boundary conditions: {case}; reference: Euler-Bernoulli closed form")
        }
        None => println!(
            "boundary conditions: no closed-form reference (non-uniform beam or other supports)"
        ),
    }
    println!();
    match &reference {
        Some((_, exact)) => {
            println!(
                "{:>4}  {:>18}  {:>18}  {:>11}",
                "mode", "FE [Hz]", "analytic [Hz]", "rel. error"
            );
            for (i, (f, a)) in fe.iter().zip(exact).enumerate() {
                let err = if *a == 0.0 {
                    "rigid".to_string()
                } else {
                    format!("{:+.3e}", f / a - 1.0)
                };
                println!("{:>4}  {:>18.9}  {:>18.9}  {:>11}", i + 1, f, a, err);
            }
        }
        None => {
            println!("{:>4}  {:>18}", "mode", "FE [Hz]");
            for (i, f) in fe.iter().enumerate() {
                println!("{:>4}  {:>18.9}", i + 1, f);
            }
        }
    }
    Ok(())
}
