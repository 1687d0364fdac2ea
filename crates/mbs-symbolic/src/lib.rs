//! Symbolic multibody modelling of rigid tree mechanisms.
//!
//! Data flows in one direction: [`model`] (the mechanism description, validated) →
//! [`expr`] (the expression DAG) → [`dynamics`] (symbolic recursive Newton–Euler, eqs. 1–13)
//! → [`constraints`] (eqs. 14–16, 45–50) → [`emit`] (Rust source, build-script entry point).
//! [`numeric`] is the independent numeric reference; [`samples`] holds mechanisms built in
//! code and the tests' seeded random generator.
//!
//! # Adding a joint type
//!
//! 1. Model types: a `JointKind` variant (`model/types.rs`) and its joint code in
//!    validation (`model/validate/`).
//! 2. The one place for the symbolic formulas: `dynamics/joint.rs` — one match arm in each
//!    function (placement, ground rotation, angular motion, Coriolis term, unit-motion
//!    wrench, projection, `is_rotation`). Kinematics, `M^b`, `F^b`, `Q^b`, constraints and
//!    emission use only these functions.
//! 3. The numeric reference: `numeric/joint.rs`, the same formulas in the ground frame
//!    (kept independent of the symbolic code, so that the two check each other).
//!
//! # Adding a force element
//!
//! 1. Model types: a `ForceElement` variant (`model/types.rs`) and its validation.
//! 2. The one place for the symbolic formulas: `dynamics/forces.rs` — one function for its
//!    contribution to `Q^b` (like `point_spring`), its arm in `applied_terms`, and its stored
//!    energy in `spring_stretch` (used by `V`, `dynamics/energy.rs`).
//! 3. The numeric reference: its evaluated form (`NForce` and its conversion in
//!    `numeric/mod.rs`), its generalised force and its energy (`generalised_force` and
//!    `potential_energy` in `numeric/dynamics.rs`).

pub mod constraints;
pub mod dynamics;
pub mod emit;
pub mod expr;
pub mod model;
pub mod numeric;
pub mod runtime;
pub mod samples;
