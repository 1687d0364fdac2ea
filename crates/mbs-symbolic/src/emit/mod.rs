//! Rust source emission (Fisette–Samin / ROBOTRAN style) and the `build.rs` entry point.
//!
//! The symbolic equations ([`crate::dynamics::Symbolic`], [`crate::constraints`]) become one
//! Rust module: a struct holding the model's run-time parameters and methods that evaluate
//! `M^b`, `F^b`, `Q^b` (eqs. 11–13), `h`, `J`, `A` (eqs. 14–16) and point kinematics
//! (eqs. 49–50) into caller-owned fixed-size arrays. Each method computes only the nodes its
//! outputs need, as scalar intermediate variables (the sines and cosines of all the
//! coordinates at once, `let ([s1, s2], [c1, c2]) = rt::sin_cos([q[0], q[1]]);`, then
//! `x12 = ...`); a node used once is inlined into its user, zero terms were never built.
//! Subexpressions of the run-time parameters alone are computed once per parameter change
//! into a private cache (`hoist.rs`). `evaluate_with_points` computes everything, the named
//! points included, in one body; `position_<name>` a point's position and Jacobian alone
//! (no `q'`, no bias). Only `core` float arithmetic is used: no allocation, no
//! panics (all indices are constants into fixed-size arrays), no `unsafe`.
//!
//! The small skeleton (struct, impls, signatures) is built with `quote`, parsed as a
//! `syn::File` (a failure reports the tokens) and formatted with `prettyplease`; each method
//! body in it is a marker statement `__mbs_body!(k);`, replaced afterwards by the body's text,
//! which `statements.rs` and `printer.rs` write directly in the same layout. Re-parsing and
//! re-printing the large straight-line bodies was most of the generation time. The same
//! model always produces byte-identical source.
//!
//! # Layout
//!
//! * `names.rs`: the struct, field and point-method names (checked identifiers, no clashes).
//! * `hoist.rs`: the parameter-only subexpressions cached in the struct.
//! * `statements.rs`: DAG expressions to `let` statements and output assignments;
//!   `printer.rs`: their text layout.
//! * `methods.rs`: one function per emitted evaluation method (eqs. 11–16, 49–50).
//! * `items.rs`: the struct, its constructors, the inherent `impl` and the `Mechanism` impl.
//! * `header.rs`: the `// @generated` header (version, content hash, operation counts).
//! * `write.rs`: write-if-changed; `build.rs`: the build-script entry point
//!   [`compile_model`], returning [`Compiled`].

mod build;
mod header;
mod hoist;
mod items;
mod methods;
mod names;
mod printer;
mod statements;
mod trig;
mod write;

use proc_macro2::{Ident, Span, TokenStream};

use crate::constraints::{self, ConstraintExprs, PointExprs};
use crate::dynamics::Symbolic;
use crate::expr::{Id, OpCount};
use crate::model::Model;

pub use build::{Compiled, compile_model};
pub use names::sanitize_ident;
pub use write::{Target, target, write_if_changed};

/// Version of the generator, written into every `@generated` header.
pub const GENERATOR_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Errors of code generation.
#[derive(Debug, thiserror::Error)]
pub enum EmitError {
    /// The model file could not be read or is invalid.
    #[error("{0}")]
    Model(#[from] diagnostic::Diagnostics),
    /// Two parameters or points sanitise to the same Rust identifier.
    #[error("{file}: {what} {a:?} and {b:?} both become the Rust identifier `{ident}`")]
    IdentClash {
        /// Model file.
        file: String,
        /// "parameters" or "points".
        what: &'static str,
        /// First name.
        a: String,
        /// Second name.
        b: String,
        /// The identifier.
        ident: String,
    },
    /// The requested struct name (`EmitOptions::struct_name`) is not a Rust identifier.
    #[error(
        "struct name {name:?} is not a Rust identifier (ASCII letters, digits and `_`, not starting with a digit, not a keyword)"
    )]
    StructName {
        /// The rejected name.
        name: String,
    },
    /// The emitted tokens did not parse as Rust (a generator bug); carries the tokens.
    #[error("internal error: generated tokens do not parse as Rust ({message}); tokens: {tokens}")]
    Parse {
        /// The parser's message.
        message: String,
        /// The offending tokens.
        tokens: String,
    },
    /// Writing the output failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
}

/// Options of the emitter.
#[derive(Clone, Debug)]
pub struct EmitOptions {
    /// Name of the generated struct (default: the model name in UpperCamelCase).
    pub struct_name: Option<String>,
    /// Path of the runtime module in the crate that includes the code.
    pub runtime_path: String,
}

impl Default for EmitOptions {
    fn default() -> Self {
        EmitOptions {
            struct_name: None,
            runtime_path: "::mbs_symbolic::runtime".into(),
        }
    }
}

/// Generated source and statistics.
#[derive(Clone, Debug)]
pub struct Generated {
    /// The formatted Rust source.
    pub source: String,
    /// Name of the generated struct.
    pub struct_name: String,
    /// Operation count of each generated function, in emission order.
    pub stats: Vec<(String, OpCount)>,
}

/// Generates the Rust module for a model.
pub fn generate(model: &Model, opts: &EmitOptions) -> Result<Generated, EmitError> {
    let n = model.dof();
    let mut sym = Symbolic::derive(model);
    let mut cons: ConstraintExprs = constraints::constraints(model, &mut sym);
    // Points last: a formulation of a point's Jacobian that shares more with everything
    // `evaluate_with_points` computes wins a tie.
    let context = all_roots(&sym, &cons, &[]);
    let mut pts: Vec<PointExprs> = constraints::points_in_context(model, &mut sym, &context);
    let nc = cons.h.len();

    let param_idents = names::param_idents(model)?;
    let point_fns = names::point_fns(model)?;
    let position_fns = names::position_fns(&point_fns);
    let struct_name = names::struct_name(model, opts)?;
    let sname = Ident::new(&struct_name, Span::call_site());
    let rt: syn::Path = syn::parse_str(&opts.runtime_path).map_err(|e| EmitError::Parse {
        message: e.to_string(),
        tokens: opts.runtime_path.clone(),
    })?;

    // Sines and cosines of angle sums by angle addition, decided once for all the functions
    // that must stay bit-identical (the separate methods, `evaluate`, the points and
    // `evaluate_with_points`); `potential_energy` and `element_power` are tied to none of
    // them and decide alone.
    let potential = sym.potential;
    let power = [sym.dissipation, sym.input_power];
    let gravity = std::mem::take(&mut sym.gravity_jacobian);
    sym.potential = sym.dag.zero();
    sym.dissipation = sym.dag.zero();
    sym.input_power = sym.dag.zero();
    let roots = all_roots(&sym, &cons, &pts);
    let mut rewrite = trig::angle_addition(&mut sym.dag, &roots);
    rewrite.map_all(&mut sym.mass);
    rewrite.map_all(&mut sym.f);
    rewrite.map_all(&mut sym.q);
    rewrite.map_all(&mut cons.h);
    for row in &mut cons.j {
        rewrite.map_all(row);
    }
    rewrite.map_all(&mut cons.a);
    for pt in &mut pts {
        rewrite.map_all(&mut pt.p);
        for row in &mut pt.j {
            rewrite.map_all(row);
        }
        rewrite.map_all(&mut pt.a);
    }
    let alone = trig::angle_addition(&mut sym.dag, &[potential]);
    sym.potential = alone.map(potential);
    rewrite.names.extend(alone.names);
    let alone = trig::angle_addition(&mut sym.dag, &power);
    sym.dissipation = alone.map(power[0]);
    sym.input_power = alone.map(power[1]);
    rewrite.names.extend(alone.names);
    let alone = trig::angle_addition(&mut sym.dag, &gravity);
    sym.gravity_jacobian = gravity.iter().map(|&g| alone.map(g)).collect();
    rewrite.names.extend(alone.names);
    // The cache of parameter-only subexpressions, over everything any method computes.
    let hoisting = hoist::hoist(&sym.dag, &all_roots(&sym, &cons, &pts));
    let cache_field = names::cache_field(&param_idents);
    let param_names: Vec<String> = param_idents.iter().map(ToString::to_string).collect();
    let cache_name = cache_field.to_string();
    let runtime_text: String = opts.runtime_path.split_whitespace().collect();

    let mut m = methods::Methods {
        em: statements::FnEmitter {
            dag: &sym.dag,
            params: &param_names,
            names: &rewrite.names,
            hoisted: &hoisting.index,
            cache_field: &cache_name,
            runtime: &runtime_text,
        },
        n,
        nc,
        rt: &rt,
        stats: Vec::new(),
        jobs: Vec::new(),
    };
    let mut methods = TokenStream::new();
    methods.extend(m.mass_matrix(&sym));
    methods.extend(m.f_vector(&sym));
    methods.extend(m.q_vector(&sym));
    methods.extend(m.constraints(&cons));
    methods.extend(m.constraint_jacobian(&cons));
    methods.extend(m.constraint_bias(&cons));
    methods.extend(m.potential_energy(&sym));
    methods.extend(m.element_power(&sym));
    methods.extend(m.gravity_load_jacobian(&sym));
    methods.extend(m.evaluate(&sym, &cons));
    for (pt, fname) in pts.iter().zip(&point_fns) {
        methods.extend(m.point(pt, fname));
    }
    for (pt, fname) in pts.iter().zip(&position_fns) {
        methods.extend(m.position(pt, fname));
    }
    methods.extend(m.evaluate_with_points(&sym, &cons, &pts));
    if !hoisting.frontier.is_empty() {
        methods.extend(m.hoisted_values(&hoisting.frontier));
    }
    let stats = m.stats;
    let bodies = methods::write_bodies(&m.jobs);

    let items = items::Items {
        model,
        sname: &sname,
        rt: &rt,
        param_idents: &param_idents,
        n,
        nc,
        hoisted: hoisting.frontier.len(),
        cache_field: &cache_field,
    };
    let names = items::Names {
        points: model.points.iter().map(|p| p.name.as_str()).collect(),
        coordinates: model.bodies.iter().map(|b| b.coordinate.as_str()).collect(),
        constraints: cons.names.iter().map(String::as_str).collect(),
        units: model
            .bodies
            .iter()
            .map(|b| b.joint.kind.coordinate_unit())
            .collect(),
    };
    let mut tokens = items.struct_item();
    tokens.extend(items.default_impl());
    tokens.extend(items.inherent_impl(&names, methods));
    tokens.extend(items.mechanism_impl(&point_fns, &position_fns));

    let file: syn::File = syn::parse2(tokens.clone()).map_err(|e| EmitError::Parse {
        message: e.to_string(),
        tokens: tokens.to_string(),
    })?;
    let mut source = header::header(model, &stats);
    splice(&prettyplease::unparse(&file), &bodies, &mut source)?;
    Ok(Generated {
        source,
        struct_name,
        stats,
    })
}

/// Every output of every emitted function.
fn all_roots(sym: &Symbolic, cons: &ConstraintExprs, pts: &[PointExprs]) -> Vec<Id> {
    let mut roots: Vec<Id> = sym.mf_roots();
    roots.extend(&sym.q);
    roots.extend(&cons.h);
    roots.extend(cons.j.iter().flatten());
    roots.extend(&cons.a);
    roots.push(sym.potential);
    roots.push(sym.dissipation);
    roots.push(sym.input_power);
    roots.extend(&sym.gravity_jacobian);
    for pt in pts {
        roots.extend(pt.p.iter().chain(pt.j.iter().flatten()).chain(&pt.a));
    }
    roots
}

/// Appends `skeleton` to `out` with every marker line `__mbs_body!(k);` replaced by
/// `bodies[k]` (written for an indentation of `statements::BODY_INDENT`, re-indented if the
/// marker sits elsewhere).
fn splice(skeleton: &str, bodies: &[String], out: &mut String) -> Result<(), EmitError> {
    out.reserve(skeleton.len() + bodies.iter().map(String::len).sum::<usize>());
    let mut used = vec![false; bodies.len()];
    for line in skeleton.split_inclusive('\n') {
        let trimmed = line.trim_start();
        let Some(k) = trimmed
            .strip_prefix(methods::MARKER)
            .and_then(|rest| rest.trim_end().strip_suffix(");"))
            .and_then(|k| k.parse::<usize>().ok())
            .filter(|&k| k < bodies.len())
        else {
            out.push_str(line);
            continue;
        };
        used[k] = true;
        let indent = line.len() - trimmed.len();
        if indent == statements::BODY_INDENT {
            out.push_str(&bodies[k]);
        } else {
            for body_line in bodies[k].split_inclusive('\n') {
                let text = body_line.trim_start_matches(' ');
                let own = body_line.len() - text.len();
                let depth = (own + indent).saturating_sub(statements::BODY_INDENT);
                out.extend(std::iter::repeat_n(' ', depth));
                out.push_str(text);
            }
        }
    }
    if let Some(k) = used.iter().position(|u| !u) {
        return Err(EmitError::Parse {
            message: format!("body marker {k} not found in the formatted skeleton"),
            tokens: skeleton.to_string(),
        });
    }
    Ok(())
}
