//! Work guards: before a run starts, its time steps, output rows and output size are
//! estimated and a run above the documented limits is refused with the estimate and the
//! flag that lifts the limits (`--allow-long`). Memory is not limited by these: time
//! histories are streamed to disk and a run keeps a bounded digest of its rows
//! (`report::stream`, `report::digest`), so memory does not grow with `t_end`.
//!
//! | limit | value | a run of about |
//! | --- | --- | --- |
//! | time steps | 2e7 | a minute of the damper's Newmark steps (3.6e5 steps/s measured) |
//! | output rows | 2e6 | 2e6 CSV lines of one run |
//! | CSV text written | 1 GiB | |
//!
//! Estimates: damper and hybrid `round(t_end / dt)` steps per run (one run more per
//! comparison), one row every `every` steps, a row of one cell per column (25 bytes a
//! cell);
//! mechanism rows `(t_end - t_start) / output_step + 1`, CSV text of `2 n + 6` cells a row,
//! steps `span / step` for RK4, and for Dormand–Prince `span / h` with the typical step
//! (see [`dopri_typical_step`])
//!
//! ```text
//!   h = min(max_step, output_step * (rtol / 1e-7)^(1/5), span, 1 s)
//! ```
//!
//! A fifth-order method's step grows like `rtol^(1/5)` times the time scale of the motion;
//! the output step stands for that scale (the user asks for rows fine enough to see the
//! motion). The constant 1e-7 is calibrated on the bundled scenarios (rtol 1e-10, output
//! step 0.01 s: estimate 1991 steps; measured 2279 for the four-bar, 3133 for the
//! slider-crank). The estimate cannot see a motion much faster than the output grid (a
//! huge initial velocity); such a run is stopped by its step limit, `max_steps`, which
//! without `--allow-long` is at most [`MAX_STEPS`] ([`capped_max_steps`]).
//!
//! # The other commands
//!
//! Every command estimates its work and memory before it starts ([`Quantity`],
//! [`refuse_above`]) and refuses above these limits unless `--allow-long`, with the estimate
//! and the way out in one line. The limits are each about an hour of one core's work or
//! 1 GiB of memory, well above anything the bundled examples need:
//!
//! | command | estimate | limit |
//! | --- | --- | --- |
//! | `frf` | memory of the linear response, [`FRF_BYTES_PER_FREQUENCY`] a frequency | 1 GiB (about 260,000 frequencies) |
//! | `frf --nonlinear M` | time steps `M * max_periods * steps_per_period` (the most it can run) | [`MAX_STEPS`] |
//! | `linearize` | memory and work of the eigen-solve: `m` Krylov vectors of `n` states (`m = n` dense), `8 (4 m^2 + m n)` bytes, `10 m^3` flops per variant | 1 GiB, [`MAX_FLOPS`] |
//! | `sweep` | grid points of the shard (product of the axes, overflow-checked) | [`MAX_SWEEP_POINTS`] |
//! | `sweep` | memory of the grid, [`SWEEP_BYTES_PER_POINT`] a point | 1 GiB |
//! | `sweep --time-domain` | steps of one point (the `simulate` estimate) | [`MAX_STEPS`] |
//! | `sweep` | core time of the shard's points: `points (t_p + steps / r)`, `t_p` = [`SWEEP_POINT_SECONDS`], `r` = [`SWEEP_STEPS_PER_SECOND`] (`steps` 0 without `--time-domain`) | [`MAX_SWEEP_SECONDS`] |
//! | every command on a beam (and every Python call) | beam elements; memory [`BEAM_BYTES_PER_ELEMENT`] an element | [`MAX_BEAM_ELEMENTS`]; 1 GiB |
//! | every command on a reduced structure (and every Python call) | the Craig–Bampton reduction's memory and flops from the structure's size ([`reduction_work`]) | 1 GiB; [`MAX_FLOPS`] |
//! | `merge` | bytes of the part files; grid points | 1 GiB; [`MAX_MERGE_POINTS`] |
//! | `generate` | source size `400 ((n + n_c)^2 + 3 p n)` bytes (`n` coordinates, `n_c` constraint rows, `p` points; 354 to 408 measured on chains of 200 to 1000 bodies), memory about 4 times that | [`MAX_SOURCE_BYTES`] |
//!
//! Some bounds hold even with `--allow-long`: a memory estimate above the machine's
//! physical memory (`MemTotal` of `/proc/meminfo`, [`machine_memory`]) is refused by
//! [`refuse_above`] whatever the flag, and a beam whose memory estimate is above it is
//! refused by the scenario loader before it is built; a grid whose point count does not fit in a
//! machine word, or whose values cannot be allocated, is refused; `sweep --threads T` is
//! capped to the machine's available parallelism; `merge` reads regular files only and
//! needs exactly one part per shard; an error listing many items names the first few and
//! the count ([`summarise`]).

use std::fmt;

use hybrid_core::closed_loop::Method;

use crate::Error;
use crate::scenario::{HybridScenario, MechanismScenario, Scenario};

/// Largest estimated number of time steps of a run without `--allow-long`.
pub const MAX_STEPS: f64 = 2e7;
/// Largest estimated number of output rows without `--allow-long`.
pub const MAX_ROWS: f64 = 2e6;
/// Largest estimated CSV text of a run without `--allow-long` (bytes).
pub const MAX_BYTES: f64 = 1024.0 * 1024.0 * 1024.0;

/// Largest estimated memory of a command without `--allow-long` (bytes).
pub const MAX_MEMORY: f64 = 1024.0 * 1024.0 * 1024.0;
/// Largest number of grid points of a sweep (of its shard) without `--allow-long`: about
/// an hour of one core at 10-40 ms a linearised point (measured on the bundled scenarios).
pub const MAX_SWEEP_POINTS: f64 = 1e5;
/// Core time of one linearised sweep point (s): 18 ms measured a point of the bundled
/// damper (`--threads 1`, 20 points in 0.36 s), rounded up.
pub const SWEEP_POINT_SECONDS: f64 = 0.02;
/// Time steps a second of one core in a time-domain sweep point (its run and comparison
/// runs with their figures): 1.5e5 measured on the bundled damper (10 points of 7,500
/// steps in 0.70 s with one thread, less the linearised part).
pub const SWEEP_STEPS_PER_SECOND: f64 = 1.5e5;
/// Largest estimated core time of a sweep (of its shard) without `--allow-long` (s): an
/// hour of one core.
pub const MAX_SWEEP_SECONDS: f64 = 3600.0;
/// Largest number of beam elements without `--allow-long`: 1e5 elements took 26 s and
/// 450 MB for `linearize` of the bundled damper (measured), 1e6 more than a minute.
pub const MAX_BEAM_ELEMENTS: f64 = 1e5;
/// Peak memory of an analysis a beam element (bytes): 450 MB measured for `linearize` at
/// 1e5 elements, rounded up.
pub const BEAM_BYTES_PER_ELEMENT: f64 = 4.6e3;
/// Memory of one sweep point while the sweep runs: its grid index, its result (about 25
/// named figures) and its rows in the CSV and JSON held until the commit (bytes).
pub const SWEEP_BYTES_PER_POINT: f64 = 4096.0;
/// Largest grid of a merge without `--allow-long` (points): ten times a sweep's, since a
/// merge only joins the shards' results.
pub const MAX_MERGE_POINTS: f64 = 1e6;
/// Memory of one frequency of `frf` (its values, CSV and JSON rows, the plot's path),
/// measured 4.0 kB a frequency at 20,000 frequencies (bytes).
pub const FRF_BYTES_PER_FREQUENCY: f64 = 4096.0;
/// Largest floating-point work of an eigen-solve of `linearize` (all variants) without
/// `--allow-long`: a few minutes of one core.
pub const MAX_FLOPS: f64 = 1e12;
/// Largest estimated generated source of `generate` without `--allow-long` (bytes): a
/// model of about 290 coordinates (a few seconds, a few hundred MB of memory).
pub const MAX_SOURCE_BYTES: f64 = 32.0 * 1024.0 * 1024.0;
/// Bytes of generated source per entry of `(n + n_c)^2 + 3 p n` (see [`generated_source_bytes`]).
const SOURCE_BYTES_PER_ENTRY: f64 = 400.0;
/// Items an error message lists before summarising the rest as a count.
pub const LISTED: usize = 5;

/// Bytes of one CSV cell (a number printed in full precision and its comma).
const CELL_BYTES: f64 = 25.0;

/// The longest typical step assumed of an adaptive run (s): the mechanisms of this tool move
/// on time scales of milliseconds to seconds, so an output step of hours (or `1e30`) says
/// nothing about the steps the integrator will take.
pub const MAX_TYPICAL_STEP: f64 = 1.0;

/// The typical step of Dormand–Prince 5(4) for a run of length `span` with this output step,
/// relative tolerance and optional largest step: `min(max_step, output_step * (rtol /
/// 1e-7)^(1/5), span, MAX_TYPICAL_STEP)` (module documentation).
pub fn dopri_typical_step(span: f64, output_step: f64, rtol: f64, max_step: Option<f64>) -> f64 {
    (output_step * (rtol / 1e-7).powf(0.2))
        .min(max_step.unwrap_or(f64::INFINITY))
        .min(span)
        .min(MAX_TYPICAL_STEP)
}

/// The time steps of one time-domain run of a damper or hybrid scenario (all its runs: the
/// comparisons too), as `simulate` estimates them; `None` for a mechanism scenario
/// (adaptive: not known before the run).
pub fn steps_per_run(sc: &Scenario) -> Option<f64> {
    match sc {
        Scenario::Hybrid(h) => Estimate::hybrid(h, 0, 0).steps,
        Scenario::Mechanism(_) => None,
    }
}

/// The step limit a run gets: the scenario's `max_steps`, at most [`MAX_STEPS`] unless
/// `allow_long` — the guard for adaptive runs whose step count the estimate cannot see.
pub fn capped_max_steps(max_steps: usize, allow_long: bool) -> usize {
    if allow_long {
        max_steps
    } else {
        max_steps.min(MAX_STEPS as usize)
    }
}

/// The estimated work of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Time steps, all runs together (`None`: not known before the run).
    pub steps: Option<f64>,
    /// Output rows, all files together.
    pub rows: f64,
    /// CSV text written (bytes).
    pub bytes: f64,
}

impl fmt::Display for Estimate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(s) = self.steps {
            write!(f, "{s:.2e} steps, ")?;
        }
        write!(
            f,
            "{:.2e} output rows and {:.1} MiB of CSV",
            self.rows,
            self.bytes / (1024.0 * 1024.0)
        )
    }
}

impl Estimate {
    /// A damper or hybrid scenario whose time history has `cells` columns and whose beam
    /// has `series` attachments plotted: the run as described and every comparison run
    /// (counted as full runs: the bare beam's is cheaper), a row every `every` steps.
    pub fn hybrid(sc: &HybridScenario, cells: usize, series: usize) -> Estimate {
        let runs = 1.0 + sc.compare.len() as f64;
        let steps = (sc.integrator.t_end / sc.integrator.dt).round() * runs;
        let rows = ((steps / runs / sc.every.max(1) as f64).floor() + 2.0) * runs;
        Estimate {
            steps: Some(steps),
            rows,
            bytes: rows * (cells as f64 * CELL_BYTES + series as f64 * 16.0),
        }
    }

    /// A closed-loop mechanism scenario with `dof` coordinates.
    pub fn mechanism(sc: &MechanismScenario, dof: usize) -> Estimate {
        let s = &sc.settings;
        let span = s.t_end - s.t_start;
        let rows = (span / s.output_step).floor() + 1.0;
        let steps = match s.method {
            Method::Rk4 { step } => (span / step).ceil(),
            Method::Dopri5 { rtol, max_step, .. } => {
                (span / dopri_typical_step(span, s.output_step, rtol, max_step)).ceil()
            }
        };
        Estimate {
            steps: Some(steps),
            rows,
            bytes: rows * (2 * dof + 6) as f64 * CELL_BYTES,
        }
    }

    /// Whether the run is within the limits.
    pub fn within_limits(&self) -> bool {
        // `!(x <= max)` also refuses a NaN estimate.
        self.steps.is_none_or(|s| s <= MAX_STEPS)
            && self.rows <= MAX_ROWS
            && self.bytes <= MAX_BYTES
    }

    /// Refuses a run above the limits unless `allow_long`; `file` names the scenario.
    pub fn check(&self, file: &str, allow_long: bool) -> Result<(), Error> {
        if allow_long || self.within_limits() {
            return Ok(());
        }
        Err(Error::TooLong(format!(
            "{file}: the run is estimated at {self}, above the limits ({MAX_STEPS:.0e} steps, {MAX_ROWS:.0e} rows, {} MiB); shorten t_end or coarsen the output step, or pass --allow-long to run it anyway",
            MAX_BYTES / (1024.0 * 1024.0)
        )))
    }
}

/// One estimated quantity of a command's work and its limit without `--allow-long`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantity {
    /// What is counted, plural (`grid points`, `time steps`); for bytes, what they are
    /// (`memory`, `generated source`).
    pub what: &'static str,
    /// The estimate.
    pub value: f64,
    /// The limit.
    pub limit: f64,
    /// Whether the value is a number of bytes (shown in MiB / GiB).
    pub bytes: bool,
}

impl Quantity {
    /// A count of `what`.
    pub fn count(what: &'static str, value: f64, limit: f64) -> Quantity {
        Quantity {
            what,
            value,
            limit,
            bytes: false,
        }
    }

    /// A number of bytes of `what`.
    pub fn bytes(what: &'static str, value: f64, limit: f64) -> Quantity {
        Quantity {
            what,
            value,
            limit,
            bytes: true,
        }
    }

    /// Whether the estimate is above the limit (a NaN estimate is).
    pub fn over(&self) -> bool {
        self.value.is_nan() || self.value > self.limit
    }

    fn show(&self, v: f64) -> String {
        if !self.bytes {
            return format!("{v:.2e} {}", self.what);
        }
        const MIB: f64 = 1024.0 * 1024.0;
        let gib = v / (1024.0 * MIB);
        if gib >= 1e4 {
            format!("{gib:.2e} GiB of {}", self.what)
        } else if gib >= 1.0 {
            format!("{gib:.1} GiB of {}", self.what)
        } else {
            format!("{:.1} MiB of {}", v / MIB, self.what)
        }
    }
}

/// Refuses work estimated above any of its limits unless `allow_long`: one line naming
/// `subject`, the estimates above their limits and the limits, `remedy` (what to change)
/// and `--allow-long`.
pub fn refuse_above(
    subject: &str,
    work: &[Quantity],
    remedy: &str,
    allow_long: bool,
) -> Result<(), Error> {
    // With --allow-long, memory beyond the machine is still refused (without it, such an
    // estimate is above its limit anyway and reported with the others).
    if allow_long && let Some(machine) = machine_memory() {
        let beyond: Vec<&Quantity> = work
            .iter()
            .filter(|q| q.bytes && (q.value.is_nan() || q.value > machine))
            .collect();
        if !beyond.is_empty() {
            let estimates: Vec<String> = beyond.iter().map(|q| q.show(q.value)).collect();
            return Err(Error::TooLong(format!(
                "{subject}: estimated at {}, more than this machine's memory ({:.1} GiB), even with --allow-long; {remedy}",
                estimates.join(", "),
                machine / (1024.0 * 1024.0 * 1024.0)
            )));
        }
    }
    let over: Vec<&Quantity> = work.iter().filter(|q| q.over()).collect();
    if allow_long || over.is_empty() {
        return Ok(());
    }
    let estimates: Vec<String> = over.iter().map(|q| q.show(q.value)).collect();
    let limits: Vec<String> = over.iter().map(|q| q.show(q.limit)).collect();
    Err(Error::TooLong(format!(
        "{subject}: estimated at {}, above the limit ({}); {remedy}, or pass --allow-long to run it anyway",
        estimates.join(", "),
        limits.join(", ")
    )))
}

/// The machine's physical memory (bytes): `MemTotal` of `/proc/meminfo`, read once;
/// `None` where it cannot be read (then no estimate is refused for it).
pub fn machine_memory() -> Option<f64> {
    static MEMORY: std::sync::OnceLock<Option<f64>> = std::sync::OnceLock::new();
    *MEMORY.get_or_init(|| {
        let text = std::fs::read_to_string("/proc/meminfo").ok()?;
        let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
        let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
        Some(kib * 1024.0)
    })
}

/// The beam elements of a beam description (all segments; in `f64`, so that no count
/// overflows).
pub fn beam_elements(spec: &fem_beam::BeamSpec) -> f64 {
    spec.segments.iter().map(|s| s.elements as f64).sum()
}

/// The work quantities of a scenario's structure: a beam's elements and their memory
/// ([`MAX_BEAM_ELEMENTS`], [`BEAM_BYTES_PER_ELEMENT`]); an imported structure's
/// Craig–Bampton reduction ([`reduction_work`]); none otherwise.
pub fn structure_work(sc: &Scenario) -> Vec<Quantity> {
    let Scenario::Hybrid(h) = sc else {
        return vec![];
    };
    if let Some(entry) = &h.structure {
        return reduction_work(h, entry);
    }
    let Some((spec, _)) = &h.beam else {
        return vec![];
    };
    let elements = beam_elements(spec);
    vec![
        Quantity::count("beam elements", elements, MAX_BEAM_ELEMENTS),
        Quantity::bytes(
            "memory of the beam",
            elements * BEAM_BYTES_PER_ELEMENT,
            MAX_MEMORY,
        ),
    ]
}

/// Iterations of the fixed-interface eigen-solve assumed by [`reduction_work`]: 21 on the
/// bundled frame (30 modes of 1,990 equations, measured), rounded up.
pub const REDUCTION_ITERATIONS: f64 = 30.0;

/// The memory and work of an imported structure's Craig–Bampton reduction to `k` modes,
/// from its size (the mass matrix's size line, or the given parts) before anything is read:
/// with `n` equations, `r` interface DOFs (at most two per attachment node and loaded node)
/// and the eigen-solver's block of `p = min(n, max(2 k, k + 8))` vectors,
///
/// ```text
/// memory = 8 n (4 p + r + k) bytes          (the block X, M X, Y, M Y; the basis T)
/// flops  = 30 * 8 n p^2                     (p < n: the projections and updates per iteration)
///        = 10 n^3                           (p = n: the dense pencil)
/// ```
///
/// against [`MAX_MEMORY`] and [`MAX_FLOPS`]; none without a reduction or when the size
/// cannot be read (the loader then reports the file's problem).
pub fn reduction_work(
    h: &HybridScenario,
    entry: &crate::scenario::hybrid::StructureEntry,
) -> Vec<Quantity> {
    use crate::scenario::hybrid::{StructureSource, TargetEntry};
    let Some(k) = entry.reduction_modes else {
        return vec![];
    };
    let n = match &entry.source {
        StructureSource::Files(f) => fem_structure::mtx::read_size(&f.mass).map(|s| s.0),
        StructureSource::Given { parts, .. } => Some(parts.mass.n),
    };
    let Some(n) = n.map(|n| n as f64) else {
        return vec![];
    };
    let nodes = h.attachments.iter().filter(|a| a.node.is_some()).count()
        + h.excitations
            .iter()
            .filter(|e| matches!(e.target, TargetEntry::Node { .. }))
            .count();
    let (k, r) = (k as f64, 2.0 * nodes as f64);
    let p = n.min((2.0 * k).max(k + 8.0));
    let flops = if p >= n {
        10.0 * n * n * n
    } else {
        REDUCTION_ITERATIONS * 8.0 * n * p * p
    };
    vec![
        Quantity::bytes(
            "memory of the Craig–Bampton reduction",
            8.0 * n * (4.0 * p + r + k),
            MAX_MEMORY,
        ),
        Quantity::count(
            "floating-point operations of the reduction",
            flops,
            MAX_FLOPS,
        ),
    ]
}

/// Refuses a scenario whose structure is above the limits unless `allow_long` (every
/// command and Python call, before any work): `subject` names the scenario.
pub fn structure(sc: &Scenario, subject: &str, allow_long: bool) -> Result<(), Error> {
    let reduced = matches!(sc, Scenario::Hybrid(h) if h.structure.is_some());
    refuse_above(
        subject,
        &structure_work(sc),
        if reduced {
            "use fewer reduction modes"
        } else {
            "use fewer beam elements"
        },
        allow_long,
    )
}

/// Refuses a sweep of `points` points (of its shard) estimated above the limits unless
/// `allow_long`: their count, `memory` (bytes), and their core time, each point
/// [`SWEEP_POINT_SECONDS`] plus, in the time domain, its `steps` (one point's, all its runs;
/// `None` for a linearised sweep) at [`SWEEP_STEPS_PER_SECOND`]; with `steps`, also the
/// steps of one point against [`MAX_STEPS`]. `first`: the scenario of the first point,
/// whose structure stands for the others'.
pub fn sweep(
    subject: &str,
    points: f64,
    memory: f64,
    steps: Option<f64>,
    first: Option<&Scenario>,
    allow_long: bool,
) -> Result<(), Error> {
    let seconds = points * (SWEEP_POINT_SECONDS + steps.unwrap_or(0.0) / SWEEP_STEPS_PER_SECOND);
    let mut work = vec![
        Quantity::count("grid points", points, MAX_SWEEP_POINTS),
        Quantity::bytes("memory", memory, MAX_MEMORY),
        Quantity::count("core seconds", seconds, MAX_SWEEP_SECONDS),
    ];
    if let Some(steps) = steps {
        work.push(Quantity::count("time steps a point", steps, MAX_STEPS));
    }
    if let Some(sc) = first {
        work.extend(structure_work(sc));
    }
    refuse_above(
        subject,
        &work,
        "use fewer points, a shorter --t-end or fewer beam elements, or split the sweep with --shard I/N",
        allow_long,
    )
}

/// A list for an error line: the first [`LISTED`] items and the count of the others.
pub fn summarise<T: fmt::Display>(items: &[T]) -> String {
    let shown: Vec<String> = items.iter().take(LISTED).map(T::to_string).collect();
    match items.len().saturating_sub(LISTED) {
        0 => shown.join(", "),
        rest => format!("{} and {rest} more", shown.join(", ")),
    }
}

/// The estimated generated source of a model with `dof` coordinates, `constraint_rows`
/// constraint rows and `points` named points: `400 ((n + n_c)^2 + 3 p n)` bytes
/// (module documentation).
pub fn generated_source_bytes(dof: usize, constraint_rows: usize, points: usize) -> f64 {
    let (n, c, p) = (dof as f64, constraint_rows as f64, points as f64);
    SOURCE_BYTES_PER_ENTRY * ((n + c) * (n + c) + 3.0 * p * n)
}

/// The estimated memory (bytes) and work (flops) of one eigen-solve of `k` modes of a
/// system of `states` states: `m = states` dense, else `min(states, 2 k + 20)` Krylov
/// vectors; `8 (4 m^2 + m n)` bytes and `10 m^3` flops (module documentation).
pub fn eigen_work(states: usize, k: usize, dense: bool) -> (f64, f64) {
    let n = states as f64;
    let m = if dense {
        n
    } else {
        n.min(2.0 * k as f64 + 20.0)
    };
    (8.0 * (4.0 * m * m + m * n), 10.0 * m * m * m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantities_above_their_limit_are_refused_in_one_line_with_the_estimate() {
        let ok = [
            Quantity::count("grid points", 10.0, 1e5),
            Quantity::bytes("memory", 1e6, MAX_MEMORY),
        ];
        assert!(refuse_above("sweep", &ok, "use fewer points", false).is_ok());
        let bad = [
            Quantity::count("grid points", 1e9, 1e5),
            Quantity::bytes("memory", 4.0 * MAX_MEMORY, MAX_MEMORY),
            Quantity::count("time steps", 1.0, MAX_STEPS),
        ];
        let e = refuse_above("sweep", &bad, "use fewer points", false)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "sweep: estimated at 1.00e9 grid points, 4.0 GiB of memory, above the limit (1.00e5 grid points, 1.0 GiB of memory); use fewer points, or pass --allow-long to run it anyway"
        );
        assert!(refuse_above("sweep", &bad, "x", true).is_ok());
        let nan = [Quantity::count("time steps", f64::NAN, 1.0)];
        assert!(refuse_above("frf", &nan, "x", false).is_err());
    }

    #[test]
    fn long_lists_are_summarised() {
        assert_eq!(summarise(&[1, 2, 3]), "1, 2, 3");
        let many: Vec<usize> = (0..1_000_000).collect();
        assert_eq!(summarise(&many), "0, 1, 2, 3, 4 and 999995 more");
    }

    #[test]
    fn generated_source_estimate_matches_the_measured_chains() {
        // Measured: 14.2 MB for a 200-body chain, 408 MB for a 1000-body chain.
        let at = |n| generated_source_bytes(n, 0, 0);
        assert!((at(200) / 14.16e6 - 1.0).abs() < 0.15, "{}", at(200));
        assert!((at(1000) / 408e6 - 1.0).abs() < 0.15, "{}", at(1000));
        assert!(at(200) < MAX_SOURCE_BYTES && at(1000) > MAX_SOURCE_BYTES);
        let (bytes, flops) = eigen_work(12_000, 5, true);
        assert!(bytes > MAX_MEMORY && flops > MAX_FLOPS);
        let (bytes, flops) = eigen_work(12_000, 5, false);
        assert!(bytes < 1e7 && flops < 1e6);
    }

    #[test]
    fn dopri_typical_step_follows_tolerance_output_step_and_max_step() {
        // rtol = 1e-7: the output step itself; each decade of rtol is 10^(1/5) smaller.
        assert_eq!(dopri_typical_step(5.0, 0.01, 1e-7, None), 0.01);
        let h = dopri_typical_step(5.0, 0.01, 1e-10, None);
        assert!((h - 0.01 * 1e-3f64.powf(0.2)).abs() < 1e-15, "{h}");
        assert!((5.0 / h).ceil() == 1991.0, "{}", 5.0 / h);
        assert_eq!(dopri_typical_step(5.0, 0.01, 1e-7, Some(1e-3)), 1e-3);
        assert_eq!(dopri_typical_step(0.001, 0.01, 1e-7, None), 0.001);
        // An output step far above the mechanism's time scales (mutation campaign: 1e30
        // with t_end = 9.2e18 ran to the step cap) is not taken as the step size.
        assert_eq!(
            dopri_typical_step(9.2e18, 1e30, 1e-7, None),
            MAX_TYPICAL_STEP
        );
        assert_eq!(capped_max_steps(usize::MAX, false), 20_000_000);
        assert_eq!(capped_max_steps(usize::MAX, true), usize::MAX);
        assert_eq!(capped_max_steps(1000, false), 1000);
    }

    #[test]
    fn estimates_above_any_limit_are_refused_with_the_flag_named() {
        let ok = Estimate {
            steps: Some(5e4),
            rows: 1e4,
            bytes: 1e6,
        };
        assert!(ok.check("s.toml", false).is_ok());
        for bad in [
            Estimate {
                steps: Some(1e9),
                ..ok
            },
            Estimate { rows: 1e11, ..ok },
            Estimate { bytes: 2e9, ..ok },
            Estimate {
                steps: Some(f64::NAN),
                ..ok
            },
        ] {
            let e = bad.check("s.toml", false).unwrap_err().to_string();
            assert!(e.contains("--allow-long") && e.contains("s.toml"), "{e}");
            assert!(bad.check("s.toml", true).is_ok());
        }
    }

    #[test]
    fn a_sweep_is_refused_by_its_core_time_not_its_point_count() {
        // 99,999 time-domain points of 7,500 steps: under the point and step limits, but
        // 99,999 (0.02 + 0.05) s = 7,000 s of one core.
        let e = sweep("sweep", 99_999.0, 1e6, Some(7_500.0), None, false)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("core seconds") && !e.contains("grid points"),
            "{e}"
        );
        assert!(sweep("sweep", 99_999.0, 1e6, Some(7_500.0), None, true).is_ok());
        // The same points linearised: 2,000 s, accepted.
        assert!(sweep("sweep", 99_999.0, 1e6, None, None, false).is_ok());
    }

    #[test]
    fn memory_beyond_the_machine_is_refused_even_with_allow_long() {
        let Some(machine) = machine_memory() else {
            return;
        };
        let q = [Quantity::bytes("memory", 2.0 * machine, MAX_MEMORY)];
        let e = refuse_above("x", &q, "less", true).unwrap_err().to_string();
        assert!(e.contains("more than this machine's memory"), "{e}");
        let q = [Quantity::bytes("memory", 2.0 * MAX_MEMORY, MAX_MEMORY)];
        if 2.0 * MAX_MEMORY < machine {
            assert!(refuse_above("x", &q, "less", true).is_ok());
        }
    }
}
