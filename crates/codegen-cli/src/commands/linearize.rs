//! `damper linearize SCENARIO [--modes K] [--json] [--method M] [--set PATH=VALUE ...]`:
//! the static equilibrium of a damper or hybrid scenario and the first `K` modes of its
//! linearised reduced equations ([`crate::linear`]): undamped and damped natural
//! frequencies, damping ratios, decay rates, mode shapes (beam deflection and mechanism
//! motion), with the generators connected, disconnected, and for the bare beam; the
//! generators' velocity amplification at the equilibrium. A table on standard output, or the
//! whole report as JSON with `--json`.
//!
//! **Limits** (`crate::budget`): before the eigen-solves, their memory and work are
//! estimated from the number of states (`2 (beam DOFs + mechanism coordinates) +
//! generators`, an upper bound), `--modes` and the method (dense: every state; Arnoldi:
//! `2 K + 20` Krylov vectors), for the three variants; above 1 GiB or 1e12 flops the command
//! is refused unless `--allow-long`.

use std::fmt::Write as _;
use std::path::PathBuf;

use hybrid_core::hybrid::{EigenMethod, ModeKind};

use crate::Error;
use crate::budget::{self, Quantity};
use crate::linear::{LinearReport, ModeReport, analyse_model};
use crate::report::ReportError;
use crate::report::summary::json_bytes;
use crate::scenario::{self, Override};
use crate::setup::{Linearizable, tangents_for};

/// Arguments of `damper linearize`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Scenario file (`kind = "damper"` or `kind = "hybrid"`).
    pub scenario: PathBuf,
    /// Number of modes (lowest |lambda| first).
    #[arg(long, default_value_t = 5)]
    pub modes: usize,
    /// Print the whole report (equilibrium, amplification, modes with shapes) as JSON.
    #[arg(long)]
    pub json: bool,
    /// Eigen-solver: `auto` (dense below 600 states), `dense` or `shift-invert` (Arnoldi).
    #[arg(long, default_value = "auto", value_parser = parse_method)]
    pub method: EigenMethod,
    /// Override a field of the scenario file: `--set PATH=VALUE` (repeatable).
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub set: Vec<Override>,
    /// Run even when the eigen-solves' estimated memory (1 GiB) or work (1e12 flops) are
    /// above the limits (`codegen_cli::budget`).
    #[arg(long)]
    pub allow_long: bool,
}

/// A `--method` that is not one of the eigen-solvers.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown method {0:?}: expected auto, dense or shift-invert")]
pub struct UnknownMethod(String);

/// The eigen-solver named `auto`, `dense` or `shift-invert`.
pub fn parse_method(s: &str) -> Result<EigenMethod, UnknownMethod> {
    match s {
        "auto" => Ok(EigenMethod::Auto),
        "dense" => Ok(EigenMethod::Dense),
        "shift-invert" => Ok(EigenMethod::ShiftInvert),
        other => Err(UnknownMethod(other.to_string())),
    }
}

/// Runs `damper linearize`.
pub fn run(args: Args) -> Result<(), Error> {
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
    check_work(&file, &input, args.modes, args.method, args.allow_long)?;
    let mut report = analyse_model(&file, &input, args.modes, args.method).map_err(remap)?;
    report.overrides = loaded.applied.records();
    if args.json {
        let bytes = json_bytes(&report).map_err(ReportError::Json)?;
        return crate::print(&String::from_utf8_lossy(&bytes));
    }
    crate::print(&table(&report))
}

/// Refuses eigen-solves estimated above the limits unless `--allow-long` (module
/// documentation).
/// Refuses the eigen-solves of `modes` modes with `method` estimated above the limits
/// unless `allow_long` (the command line and the Python package).
pub fn check_work(
    file: &str,
    input: &Linearizable,
    modes: usize,
    method: EigenMethod,
    allow_long: bool,
) -> Result<(), Error> {
    let states = input.first_order_states();
    let dense = match method {
        EigenMethod::Auto => states <= 600,
        EigenMethod::Dense => true,
        EigenMethod::ShiftInvert => false,
    };
    let (bytes, flops) = budget::eigen_work(states, modes, dense);
    budget::refuse_above(
        file,
        &[
            Quantity::bytes("memory", bytes, budget::MAX_MEMORY),
            Quantity::count("flops", 3.0 * flops, budget::MAX_FLOPS),
        ],
        &format!(
            "{states} states, {} modes, {} eigen-solver: ask fewer --modes, use --method shift-invert or a coarser beam",
            modes,
            if dense { "dense" } else { "Arnoldi" }
        ),
        allow_long,
    )
}

fn mode_rows(out: &mut String, title: &str, modes: &[ModeReport]) {
    let _ = writeln!(out, "\n{title}");
    let _ = writeln!(
        out,
        "{:>4}  {:<12}  {:>14}  {:>14}  {:>12}  {:>12}  {:>9}",
        "mode", "kind", "f_n [Hz]", "f_d [Hz]", "zeta [-]", "decay [1/s]", "bwd err"
    );
    for m in modes {
        let kind = match m.kind {
            ModeKind::Oscillatory => "oscillatory",
            ModeKind::Overdamped => "overdamped",
            ModeKind::Rigid => "rigid",
            ModeKind::Unstable => "UNSTABLE",
        };
        let _ = writeln!(
            out,
            "{:>4}  {:<12}  {:>14.6}  {:>14.6}  {:>12.6e}  {:>12.5e}  {:>9.1e}",
            m.index,
            kind,
            m.natural_frequency_hz,
            m.damped_frequency_hz,
            m.damping_ratio,
            m.decay_rate,
            m.backward_error
        );
    }
}

/// The terminal table.
fn table(r: &LinearReport) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "scenario: {}", r.scenario);
    let eq = &r.equilibrium;
    let _ = writeln!(
        out,
        "static equilibrium: {} Newton iteration(s), residual {:.2e}, largest beam deflection {:.4e} m",
        eq.iterations, eq.residual, eq.beam_max_deflection
    );
    for m in &eq.mechanisms {
        let q: Vec<String> = m.q.iter().map(|(n, v)| format!("{n} = {v:.6}")).collect();
        let reach = m.reach.map_or(String::new(), |r| {
            format!("; reach to the singular position {:.4} mm", r * 1e3)
        });
        let _ = writeln!(
            out,
            "  mechanism \"{}\": {}; free [{}]; cond(J_d) = {:.3e}{reach}",
            m.name,
            q.join(", "),
            m.free.join(", "),
            m.jacobian_condition
        );
    }
    for a in &r.amplification {
        let _ = writeln!(
            out,
            "  amplification: generator \"{}\" per attachment \"{}\": {:.4} rad/m at the joint, {:.4} rad/m at the rotor",
            a.generator, a.attachment, a.joint_per_displacement, a.rotor_per_displacement
        );
    }
    mode_rows(&mut out, "modes with the generator(s) connected:", &r.modes);
    if let Some(m) = &r.generator_disconnected {
        mode_rows(
            &mut out,
            "modes with the generator(s) disconnected (mechanism and rotor inertia attached):",
            m,
        );
    }
    if let Some(m) = &r.bare_beam {
        mode_rows(&mut out, "modes of the bare beam (no mechanism):", m);
    }
    let _ = writeln!(
        out,
        "\n(mode shapes: --json; f_n = |lambda|/2pi, f_d = |Im lambda|/2pi, zeta = -Re lambda/|lambda|)"
    );
    out
}
