//! `damper linearize SCENARIO [--modes K] [--json] [--method M] [--set PATH=VALUE ...]
//! [-o DIR]`:
//! the static equilibrium of a damper or hybrid scenario and the first `K` modes of its
//! linearised reduced equations ([`crate::linear`]): undamped and damped natural
//! frequencies, damping ratios, decay rates, mode shapes (beam deflection and mechanism
//! motion), with the generators connected, disconnected, and for the bare beam; the
//! generators' velocity amplification at the equilibrium. A table on standard output, or the
//! whole report as JSON with `--json`. With `-o DIR`, the report is also written to
//! `DIR/linearize.json`, and on a `[structure]` with `elements` the first mode shapes are
//! drawn in `DIR/mode_shape.svg` ([`crate::report::shape`]), both by the one atomic writer.
//!
//! The analysis and its limits are [`crate::analysis::linearize`]; above them the command
//! is refused unless `--allow-long`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use hybrid_core::hybrid::{EigenMethod, ModeKind};

use crate::Error;
use crate::analysis::linearize::{LinearizeRequest, check, linearize, parse_method};
use crate::budget;
use crate::linear::{LinearReport, ModeReport};
use crate::report::shape::mode_shape;
use crate::report::structure::{CoupledCheck, StructureReport};
use crate::report::summary::json_bytes;
use crate::report::{OutputFile, OutputLock, ReportError, commit_files};
use crate::scenario::{self, Override};

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
    /// Also write the report into DIR: `linearize.json`, and `mode_shape.svg` when the
    /// scenario's `[structure]` has `elements` (nothing is written without it).
    #[arg(short = 'o', long = "out", value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// Runs `damper linearize`.
pub fn run(args: Args) -> Result<(), Error> {
    let req = LinearizeRequest {
        file: args.scenario.display().to_string(),
        modes: args.modes,
        method: args.method,
        matrices: false,
        allow_long: args.allow_long,
    };
    check(&req)?;
    let loaded = scenario::load_with(&args.scenario, &args.set)?;
    budget::structure(&loaded.scenario, &req.file, args.allow_long)?;
    if let Some(out) = &args.out {
        if std::fs::metadata(out).is_ok_and(|m| !m.is_dir()) {
            return Err(Error::Usage(format!(
                "output directory {} is not a directory",
                out.display()
            )));
        }
    }
    // One run at a time into a directory; the files a killed run left are removed here.
    let _lock = args
        .out
        .as_deref()
        .map(OutputLock::acquire)
        .transpose()
        .map_err(ReportError::from)?;
    let report = linearize(&req, &loaded)?.report;
    if let Some(w) = report
        .structure
        .as_ref()
        .and_then(|s| s.reduction.as_ref())
        .and_then(|r| r.warning.as_ref())
    {
        eprintln!("{}: warning: {w}", req.file);
    }
    let written = match &args.out {
        Some(out) => write(out, &report, &loaded.scenario)?,
        None => String::new(),
    };
    if args.json {
        let bytes = json_bytes(&report).map_err(ReportError::Json)?;
        return crate::print(&String::from_utf8_lossy(&bytes));
    }
    crate::print(&(table(&report) + &written))
}

/// Writes `linearize.json` and, on a structure with elements, `mode_shape.svg` into `out`
/// (together, or nothing); returns the line that names them.
fn write(out: &Path, report: &LinearReport, sc: &scenario::Scenario) -> Result<String, Error> {
    let mut files = vec![OutputFile {
        path: out.join("linearize.json"),
        bytes: json_bytes(report).map_err(ReportError::Json)?,
    }];
    let structure = match sc {
        scenario::Scenario::Hybrid(sc) => sc
            .structure
            .as_ref()
            .and_then(|s| s.drawing.as_ref())
            .map(|d| (sc, d)),
        scenario::Scenario::Mechanism(_) => None,
    };
    if let Some((sc, drawing)) = structure {
        let svg = mode_shape(sc, drawing, report).map_err(ReportError::from)?;
        files.push(OutputFile {
            path: out.join("mode_shape.svg"),
            bytes: svg,
        });
    }
    commit_files(&files).map_err(ReportError::from)?;
    let names: Vec<String> = files
        .iter()
        .filter_map(|f| Some(f.path.file_name()?.to_string_lossy().into_owned()))
        .collect();
    Ok(format!(
        "outputs in {}: {}\n",
        out.display(),
        names.join(", ")
    ))
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

/// The host structure and, for a reduction, its check.
fn structure_lines(out: &mut String, s: &StructureReport) {
    let Some(c) = &s.reduction else {
        let _ = writeln!(out, "structure: {}, {} equations", s.kind, s.equations);
        return;
    };
    let _ = writeln!(
        out,
        "structure: {}, {} equations reduced to {} coordinates ({} interface DOFs, {} fixed-interface modes up to {:.4} Hz)",
        s.kind, s.equations, s.coordinates, c.interface, c.modes, c.cutoff_hz
    );
    let _ = writeln!(
        out,
        "  bare structure: {} mode(s) below the cutoff, reduced frequencies above the full model's by at most {:.2e}",
        c.full_hz.len(),
        c.max_relative_error
    );
    match &c.first_coupled {
        Some(CoupledCheck::Compared {
            reduced_hz,
            full_hz,
            reduced_damping_ratio,
            full_damping_ratio,
            frequency_error,
            damping_error,
        }) => {
            let _ = writeln!(
                out,
                "  first coupled mode: reduced {reduced_hz:.6} Hz, zeta {reduced_damping_ratio:.6e}; full {full_hz:.6} Hz, zeta {full_damping_ratio:.6e} (differences {frequency_error:.2e}, {damping_error:.2e})"
            );
        }
        Some(CoupledCheck::Skipped { reason }) => {
            let _ = writeln!(
                out,
                "  first coupled mode not checked against the full model: {reason}"
            );
        }
        None => {}
    }
}

/// The terminal table.
fn table(r: &LinearReport) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "scenario: {}", r.scenario);
    if let Some(s) = &r.structure {
        structure_lines(&mut out, s);
    }
    let eq = &r.equilibrium;
    let _ = writeln!(
        out,
        "static equilibrium: {} Newton iteration(s), residual {:.2e}, largest {} {:.4e} m",
        eq.iterations,
        eq.residual,
        if r.bare_structure.is_some() || r.amplification.iter().any(|a| a.component.is_some()) {
            "structure displacement"
        } else {
            "beam deflection"
        },
        eq.beam_max_deflection
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
            "  amplification: generator \"{}\" per attachment \"{}\"{}: {:.4} rad/m at the joint, {:.4} rad/m at the rotor",
            a.generator,
            a.attachment,
            a.component.map_or(String::new(), |c| format!(" along {c}")),
            a.joint_per_displacement,
            a.rotor_per_displacement
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
    if let Some(m) = &r.bare_structure {
        mode_rows(&mut out, "modes of the bare structure (no mechanism):", m);
    }
    let _ = writeln!(
        out,
        "\n(mode shapes: --json; f_n = |lambda|/2pi, f_d = |Im lambda|/2pi, zeta = -Re lambda/|lambda|)"
    );
    out
}
