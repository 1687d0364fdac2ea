//! `damper random SCENARIO [--output POINT]... [--json] [--method M] [--modes K]
//! [--set PATH=VALUE ...]`: the stationary random response of a hybrid scenario under its
//! random excitations, about the static equilibrium ([`crate::random`]): the RMS of every
//! output, every generator's RMS current and rotor speed and its mean dissipated and load
//! power. A table on standard output, or one JSON object with `--json` (`outputs`,
//! `generators`, `method`, and the accuracy figures).
//!
//! **Limits** (`crate::budget`): the memory and work of the modes (as `linearize` estimates
//! them) and, dense, of the Lyapunov equation (complex Schur form: about `100 N^3` flops and
//! `10` complex `N x N` matrices for `N` first-order states); above 1 GiB or 1e12 flops the
//! command is refused unless `--allow-long`.

use std::fmt::Write as _;
use std::path::PathBuf;

use crate::Error;
use crate::budget::{self, Quantity};
use crate::random::{DENSE_STATES, RandomMethod, RandomOptions, RandomReport, analyse};
use crate::report::ReportError;
use crate::report::summary::json_bytes;
use crate::scenario::{self, Override};
use crate::setup::{Linearizable, tangents_for};

/// Arguments of `damper random`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scenario file (`kind = "hybrid"` with a random excitation).
    pub scenario: PathBuf,
    /// An output: a beam abscissa in m (`1.0`) or `MECHANISM/COORDINATE` (repeatable; its
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
    if args.modes == 0 {
        return Err(Error::Usage("--modes must be at least 1".into()));
    }
    let loaded = scenario::load_with(&args.scenario, &args.set)?;
    let file = args.scenario.display().to_string();
    budget::structure(&loaded.scenario, &file, args.allow_long)?;
    let remap = |e: Error| match e {
        Error::Input(d) => Error::Input(loaded.remap(d)),
        e => e,
    };
    let input = tangents_for(&loaded.scenario).map_err(remap)?;
    check_work(&file, &input, method, args.modes, args.allow_long)?;
    let report = analyse(
        &file,
        &loaded.scenario,
        &RandomOptions {
            method,
            modes: args.modes,
            outputs: args.output.clone(),
        },
    )
    .map_err(remap)?;
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

/// Refuses the random response's solves (`method`, `modes`) estimated above the limits
/// unless `allow_long` (the command line and the Python package).
pub fn check_work(
    file: &str,
    input: &Linearizable,
    method: RandomMethod,
    modes: usize,
    allow_long: bool,
) -> Result<(), Error> {
    let states = input.first_order_states();
    let dense = match method {
        RandomMethod::Auto => states <= DENSE_STATES,
        RandomMethod::Dense => true,
        _ => false,
    };
    let (mut bytes, mut flops) = budget::eigen_work(states, modes, states <= 600);
    if dense {
        let n = states as f64;
        bytes += 10.0 * 16.0 * n * n;
        flops += 100.0 * n * n * n;
    }
    budget::refuse_above(
        file,
        &[
            Quantity::bytes("memory", bytes, budget::MAX_MEMORY),
            Quantity::count("flops", flops, budget::MAX_FLOPS),
        ],
        &format!("{states} states: use --method modal or a coarser beam"),
        allow_long,
    )
}
