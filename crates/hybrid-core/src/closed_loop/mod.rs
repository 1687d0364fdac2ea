//! Pure (rigid) closed-loop mechanisms: assembly, automatic coordinate partitioning and
//! accurate time integration (paper section 2.2, eqs. 14–25; docs/theory.md §§2–3).
//!
//! A closed chain is cut into a tree (coordinates `q`, equations (10)) plus constraints
//! `h(q) = 0` (eqs. 14–16). This module
//!
//! - assembles a consistent initial configuration and velocity from a partial
//!   specification (`assembly`: damped Newton / Levenberg–Marquardt with step limiting,
//!   the guess selecting the branch; infeasible loops reported with the residual of every
//!   row);
//! - chooses the independent coordinates `u` (by the user, or automatically by LU with full
//!   pivoting of `J`, [`crate::partition::choose_partition`]), diagnoses redundant
//!   constraint rows by name, and monitors `cond(J_v)`, changing the partition when it
//!   degrades (`partitioning.rs`);
//! - evaluates `M^R u'' + F^R + Q^R = 0` (eqs. 22–25, `rhs.rs`), recovering `v` by Newton
//!   projection on `h(u, v) = 0` (`projection.rs`) and `v'` from eq. (18);
//! - integrates it ([`Simulator`], configured by [`Settings`]) with Dormand–Prince 5(4)
//!   (`dopri.rs`: tableau, PI step control, dense output and the adaptive driver) or
//!   fixed-step RK4 (`rk4.rs`: tableau, Hermite output and the driver), recording energy and
//!   constraint residuals ([`Trajectory`]);
//!
//! Everything is written against the one dynamic mechanism interface
//! [`mbs_symbolic::runtime::System`] (re-exported here), whose three backends are
//! compiled-in generated code, the DAG interpreter and the numeric reference, so any model
//! the generator accepts can be simulated, compiled in or read at run time.

mod assembly;
mod dopri;
mod error;
mod partitioning;
mod projection;
mod rhs;
mod rk4;
mod settings;
mod simulator;
mod trajectory;

pub use assembly::{
    Assembly, AssemblyError, AssemblyOptions, RowResidual, assemble_positions, assemble_velocities,
};
pub use error::{
    PartitionChoiceError, RedundancyReport, RedundantRow, SettingsError, SimError, SingularReport,
};
pub use mbs_symbolic::runtime::{
    GeneratedSystem, InterpretedSystem, NumericSystem, System, Workspace,
};
pub use projection::ProjectionError;
pub use settings::{Method, PartitionSettings, Settings};
pub use simulator::{Simulator, simulate};
pub use trajectory::{Event, OutputRow, PartitionChange, Stats, Trajectory};

/// Consistent initial positions and velocities: [`assemble_positions`] holding the
/// coordinates `fixed` of `q0` (the others are guesses), then [`assemble_velocities`]
/// holding the velocities `qd_given` of `qd0`.
pub fn assemble<S: System + ?Sized>(
    sys: &S,
    q0: &[f64],
    fixed: &[usize],
    qd0: &[f64],
    qd_given: &[usize],
    opts: &AssemblyOptions,
) -> Result<(Vec<f64>, Vec<f64>), AssemblyError> {
    let mut ws = sys.workspace();
    let a = assemble_positions(sys, &mut ws, q0, fixed, opts)?;
    let qd = assemble_velocities(sys, &mut ws, &a.q, qd0, qd_given)?;
    Ok((a.q, qd))
}
