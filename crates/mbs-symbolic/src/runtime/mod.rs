//! The one mechanism interface of the workspace.
//!
//! - [`Mechanism<N, NC>`](Mechanism): the fixed-size trait that generated code implements
//!   (const-generic sizes, caller-owned arrays, nothing allocated, nothing out of bounds).
//! - [`System`]: the one object-safe, dynamic-size interface used everywhere else (the CLI's
//!   `eval`, the closed-loop simulator, the damper), evaluated into a preallocated
//!   [`Workspace`]. It has exactly three backends:
//!   - [`GeneratedSystem`]: any [`Mechanism`] (code generated from a model file and
//!     compiled in);
//!   - [`InterpretedSystem`]: the symbolic equations of a model read at run time,
//!     evaluated by the DAG interpreter ([`crate::expr::Tape`]) — complete: `M`, `F`, `Q`,
//!     `h`, `J`, `A`, `V` and every named point, nothing borrowed from another backend;
//!   - [`NumericSystem`]: the independent numeric recursive reference
//!     ([`crate::numeric::NumericModel`]).
//!
//! Every backend follows the paper's convention `M q'' + F + Q + J^T lambda = 0`
//! (eqs. 10 and 17), with `M^b`, `F^b`, `Q^b` of eqs. 11–13, `h`, `J`, `A` of eqs. 14–16 and
//! point kinematics of eqs. 49–50; their agreement is tested to 1e-12.

mod generated;
mod interpreted;
mod mechanism;
mod numeric;
mod system;
mod tangent;
mod trig;

pub use crate::model::CoordinateUnit;
pub use generated::GeneratedSystem;
pub use generated::NameCount;
pub use interpreted::InterpretedSystem;
pub use mechanism::{Evaluation, Mechanism, PointKinematics};
pub use numeric::NumericSystem;
pub use system::{
    Backend, ElementPower, Names, ParamError, System, Workspace, constraint_row_names,
    coordinate_names,
};
pub use tangent::{TangentError, TangentSystem, TangentWorkspace};
pub use trig::sin_cos;
