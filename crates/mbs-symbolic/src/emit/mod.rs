//! Rust source emission (Fisette–Samin / ROBOTRAN style) and the `build.rs` entry point.
//!
//! The symbolic equations ([`crate::dynamics::Symbolic`], [`crate::constraints`]) become one
//! Rust module: a struct holding the model's run-time parameters and methods that evaluate
//! `M^b`, `F^b`, `Q^b` (eqs. 11–13), `h`, `J`, `A` (eqs. 14–16) and point kinematics
//! (eqs. 49–50) into caller-owned fixed-size arrays. Each method computes only the nodes its
//! outputs need, as scalar intermediate variables (`s1 = q[0].sin()`, `x12 = ...`); a node
//! used once is inlined into its user, zero terms were never built. Only `core` float
//! arithmetic is used: no allocation, no panics (all indices are constants into fixed-size
//! arrays), no `unsafe`.
//!
//! Tokens are built with `quote`, parsed as a `syn::File` (a failure reports the tokens) and
//! formatted with `prettyplease`; the same model always produces byte-identical source.
//!
//! # Layout
//!
//! * `names.rs`: the struct, field and point-method names (checked identifiers, no clashes).
//! * `statements.rs`: DAG expressions to `let` statements and output assignments.
//! * `methods.rs`: one function per emitted evaluation method (eqs. 11–16, 49–50).
//! * `items.rs`: the struct, its `Default`, the inherent `impl` and the `Mechanism` impl.
//! * `header.rs`: the `// @generated` header (version, content hash, operation counts).
//! * `write.rs`: write-if-changed; `build.rs`: the build-script entry point
//!   [`compile_model`], returning [`Compiled`].

mod build;
mod header;
mod items;
mod methods;
mod names;
mod statements;
mod write;

use proc_macro2::{Ident, Span, TokenStream};

use crate::constraints::{self, ConstraintExprs, PointExprs};
use crate::dynamics::Symbolic;
use crate::expr::OpCount;
use crate::model::Model;

pub use build::{Compiled, compile_model};
pub use names::sanitize_ident;
pub use write::write_if_changed;

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
    let pts: Vec<PointExprs> = constraints::points(model, &mut sym);
    let cons: ConstraintExprs = constraints::constraints(model, &mut sym);
    let nc = cons.h.len();

    let param_idents = names::param_idents(model)?;
    let point_fns = names::point_fns(model)?;
    let struct_name = names::struct_name(model, opts)?;
    let sname = Ident::new(&struct_name, Span::call_site());
    let rt: syn::Path = syn::parse_str(&opts.runtime_path).map_err(|e| EmitError::Parse {
        message: e.to_string(),
        tokens: opts.runtime_path.clone(),
    })?;

    let mut m = methods::Methods {
        em: statements::FnEmitter {
            dag: &sym.dag,
            params: &param_idents,
        },
        n,
        nc,
        rt: &rt,
        stats: Vec::new(),
    };
    let mut methods = TokenStream::new();
    methods.extend(m.mass_matrix(&sym));
    methods.extend(m.f_vector(&sym));
    methods.extend(m.q_vector(&sym));
    methods.extend(m.constraints(&cons));
    methods.extend(m.constraint_jacobian(&cons));
    methods.extend(m.constraint_bias(&cons));
    methods.extend(m.potential_energy(&sym));
    methods.extend(m.evaluate(&sym, &cons));
    for (pt, fname) in pts.iter().zip(&point_fns) {
        methods.extend(m.point(pt, fname));
    }
    let stats = m.stats;

    let items = items::Items {
        model,
        sname: &sname,
        rt: &rt,
        param_idents: &param_idents,
        n,
        nc,
    };
    let names = items::Names {
        points: model.points.iter().map(|p| p.name.as_str()).collect(),
        coordinates: model.bodies.iter().map(|b| b.coordinate.as_str()).collect(),
        constraints: cons.names.iter().map(String::as_str).collect(),
    };
    let mut tokens = items.struct_item();
    tokens.extend(items.default_impl());
    tokens.extend(items.inherent_impl(&names, methods));
    tokens.extend(items.mechanism_impl(&point_fns));

    let file: syn::File = syn::parse2(tokens.clone()).map_err(|e| EmitError::Parse {
        message: e.to_string(),
        tokens: tokens.to_string(),
    })?;
    let mut source = header::header(model, &stats);
    source.push_str(&prettyplease::unparse(&file));
    Ok(Generated {
        source,
        struct_name,
        stats,
    })
}
