//! The mechanism description: file format (TOML or JSON), parameter expressions and
//! validation into the typed tree of [`types`].
//!
//! [`load`] reads a `.toml` or `.json` file, [`parse_str`] the same from a string; both
//! return a validated [`Model`] or [`Diagnostics`] listing **every** problem, each with the
//! file, the line and the entity (`models/x.toml:12: body "crank": mass: ...`).
//!
//! # File format
//!
//! TOML first; JSON with the same structure is accepted. Units SI, angles in radians.
//! `models/README.md` has the same description with more examples.
//!
//! ```toml
//! name = "double_bar"                # optional, default: the file stem
//! description = "free text"          # optional, ignored
//! gravity = ["gx", "gy", 0.0]        # ground frame, m/s^2 (default [0, 0, 0])
//!
//! [parameters]                       # in order; a value may use EARLIER parameters
//! L1 = 0.10                          # folded into the equations at generation time
//! m1 = { value = 0.024, runtime = true }   # a run-time field of the generated code
//! I1 = "m1*L1^2/12"                  # derived: inlined where used, follows run-time m1
//!
//! [[bodies]]                         # any order: sorted parent-before-child on load
//! name = "crank"
//! parent = "ground"                  # a body name or "ground" (default "ground")
//! joint = "R3"                       # R1 R2 R3 (revolute about x y z), T1 T2 T3 (prismatic)
//! # joint = { type = "revolute", axis = "z", anchor = [0, 0, 0],
//! #           rotation = [{ axis = "x", angle = "pi/2" }] }
//! anchor = [0, 0, 0]                 # joint origin in the parent frame (default 0)
//! rotation = []                      # constant joint-frame rotation (default none)
//! coordinate = "q1"                  # default: the body name
//! mass = "m1"                        # must be > 0 at the default parameter values
//! com = ["L1/2", 0, 0]               # centre of mass, body frame (default 0)
//! inertia = { yy = "I1", zz = "I1" } # about the com, body axes; missing entries 0;
//!                                    # xy, xz, yz are the tensor's off-diagonal entries;
//!                                    # or a symmetric 3x3 array [[..], [..], [..]]
//!
//! [[points]]
//! name = "tip"
//! body = "crank"                     # or "ground"
//! position = ["L1", 0, 0]            # body frame (default 0)
//!
//! [[forces]]
//! type = "joint"                     # on the joint of `body`: -stiffness (q - rest)
//! name = "crank_spring"              #   - damping q' + constant; all default 0
//! body = "crank"
//! stiffness = 0.5
//!
//! [[forces]]
//! type = "spring"                    # spring-damper between points a and b:
//! a = "anchor"                       #   stiffness, damping, rest_length (default 0)
//! b = "tip"
//!
//! [[forces]]
//! type = "external"                  # constant force at a point and torque on a body:
//! body = "crank"                     #   point: body-frame coordinates or a point name
//! point = "tip"                      #   (then `body` may be omitted); force, torque
//! force = [0, -1, 0]                 #   (default 0); frame = "ground" (default) or "body"
//!
//! [[constraints]]
//! type = "loop"                      # points a and b coincide; components = ["x", "y"]
//! a = "tip"                          #   (ground-frame components, default all three)
//! b = "anchor"
//!
//! [[constraints]]
//! type = "fixed"                     # point held at a ground position: point, position,
//! point = "tip"                      #   components
//! position = [0.2, 0, 0]
//!
//! [[constraints]]
//! type = "angle"                     # relative angle of body b to body a ("ground" allowed)
//! a = "ground"                       #   about axis, minus offset (default 0), is zero; every
//! b = "crank"                        #   joint between them must be a revolute about that
//! axis = "z"                         #   axis, without constant rotation
//! ```
//!
//! `name` is optional for forces and constraints (default `<type>_<n>`, `n` counting from 1
//! in its section). Unknown keys are errors (typos are caught).
//!
//! # Numbers and expressions
//!
//! Every numeric field takes a number or a string expression: numbers, parameter names,
//! `pi`, `+ - * / ^` (`^` right-associative, binding tighter than unary minus:
//! `-x^2 = -(x^2)`), parentheses and `sin cos tan sqrt exp ln abs`. Expressions are parsed
//! into [`Scalar`]s (parameter names resolved to indices; sub-expressions of literals only
//! folded to numbers) and must be finite at the default parameter values. Nesting is limited
//! to 200 levels.
//!
//! # What validation checks
//!
//! Parameter values given later (`damper eval --param`, a scenario's overrides) pass the
//! same physical checks through [`check_parameter_values`].
//!
//! Syntax (with the parser's line); unknown keys and wrong value types; duplicate names of
//! parameters, bodies, coordinates, points, forces and constraints; parameter names (an
//! identifier, not `pi` or a function) and their use of earlier parameters only; unknown
//! parents, bodies, points and parameters; cycles in the parent graph; joint types and
//! axes; positive mass; inertia finite, positive semi-definite and satisfying the triangle
//! inequality of principal moments (tolerance 1e-9 of the trace); non-finite values;
//! constraints between points of the same body (or of ground); angle constraints whose path
//! has a joint that is not a revolute about the constraint axis; a model without bodies.
//!
//! Line numbers come from the parsers' spans (TOML) or from the scanner of the JSON text,
//! so they are exact for both formats: the line of the offending key or value, or of the
//! entity's `name` for problems of a whole entity.

mod check;
mod expr_parse;
mod load;
mod node;
mod raw;
mod source;
pub mod types;
mod validate;

pub use check::check_parameter_values;
pub use diagnostic::{Diagnostic, Diagnostics, Kind};
pub use load::{Format, load, parse_str};
pub use types::*;
