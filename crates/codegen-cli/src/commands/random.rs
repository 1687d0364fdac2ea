//! `damper random SCENARIO [--output POINT]... [--json] [--method M] [--modes K]
//! [--set PATH=VALUE ...]`: the stationary random response of a hybrid scenario under its
//! random excitations, about the static equilibrium ([`crate::random`]): the RMS of every
//! output, every generator's RMS current and rotor speed and its mean dissipated and load
//! power. A table on standard output, or one JSON object with `--json` (`outputs`,
//! `generators`, `method`, and the accuracy figures).
//!
//! The analysis and its limits are [`crate::analysis::stationary`]; above them the command
//! is refused unless `--allow-long`.

use std::fmt::Write as _;
use std::path::PathBuf;

use crate::Error;
use crate::analysis::stationary::{RandomRequest, check, random};
use crate::budget;
use crate::random::{RandomMethod, RandomOptions, RandomReport};
use crate::report::ReportError;
use crate::report::summary::json_bytes;
use crate::scenario::{self, Override};

/// Arguments of `damper random`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scenario file (`kind = "hybrid"` with a random excitation).
    pub scenario: PathBuf,
    /// An output: a beam abscissa in m (`1.0`), `NODE:DOF` on an imported structure
    /// (`613:ux`) or `MECHANISM/COORDINATE` (repeatable; its
    /// value and rate are reported). Default: every attachment and mechanism coordinate.
    #[arg(long)]
    pub output: Vec<String>,
    /// Print the report as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// `auto` (PSD tables alone by quadrature; white noise dense up to 600 first-order
    /// states, modal above), `dense`, `modal` or `quadrature` (every input by PSD
    /// integration).
    #[arg(long, default_value = "auto")]
    pub method: String,
    /// Modes of the modal basis (and of the quadrature's breakpoints).
    #[arg(long, default_value_t = 20)]
    pub modes: usize,
    /// Override a field of the scenario file: `--set PATH=VALUE` (repeatable).
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub set: Vec<Override>,
    /// Run even when the estimated memory (1 GiB) or work (1e12 flops) are above the limits.
    #[arg(long)]
    pub allow_long: bool,
}

/// Runs `damper random`.
pub fn run(args: Args) -> Result<(), Error> {
    let method = RandomMethod::parse(&args.method).ok_or_else(|| {
        Error::Usage(format!(
            "--method {:?}: expected auto, dense, modal or quadrature",
            args.method
        ))
    })?;
    let req = RandomRequest {
        file: args.scenario.display().to_string(),
        options: RandomOptions {
            method,
            modes: args.modes,
            outputs: args.output.clone(),
            points: vec![],
        },
        allow_long: args.allow_long,
    };
    check(&req)?;
    let loaded = scenario::load_with(&args.scenario, &args.set)?;
    budget::structure(&loaded.scenario, &req.file, args.allow_long)?;
    let report = random(&req, &loaded)?;
    if args.json {
        let bytes = json_bytes(&report).map_err(ReportError::Json)?;
        return crate::print(&String::from_utf8_lossy(&bytes));
    }
    crate::print(&table(&report))
}

/// The terminal table.
fn table(r: &RandomReport) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "scenario: {}", r.scenario);
    for e in &r.excitations {
        let _ = writeln!(
            out,
            "excitation \"{}\" ({}): mean square {:.6e}",
            e.name, e.kind, e.mean_square
        );
    }
    let _ = writeln!(
        out,
        "method: {} ({} first-order states)",
        r.method, r.states
    );
    if let (Some(b), Some(m)) = (r.basis, r.modes) {
        let _ = writeln!(
            out,
            "modal basis: {b} vectors from {m} modes; truncation (change from half the modes) {:.2e}",
            r.truncation.unwrap_or(0.0)
        );
    }
    if let Some(res) = r.lyapunov_residual {
        let _ = writeln!(out, "Lyapunov residual: {res:.2e}");
    }
    if let Some(e) = r.quadrature_error {
        let _ = writeln!(out, "quadrature error estimate: {e:.2e}");
    }
    if let Some(b) = r.out_of_band {
        let _ = writeln!(
            out,
            "white-noise variance outside the bands: at most {:.3} %",
            100.0 * b
        );
    }
    let _ = writeln!(out, "\n{:<28}  {:>14}  {:<8}", "output", "RMS", "unit");
    for o in &r.outputs {
        let _ = writeln!(out, "{:<28}  {:>14.6e}  {:<8}", o.name, o.rms, o.unit);
    }
    for g in &r.generators {
        let _ = writeln!(
            out,
            "generator \"{}\": RMS current {:.6e} A, RMS rotor speed {:.6e} rad/s, mean power dissipated {:.6e} W, in the load {:.6e} W",
            g.name, g.rms_current, g.rms_rotor_speed, g.mean_power_dissipated, g.mean_power_load
        );
    }
    out
}
