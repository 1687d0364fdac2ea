//! The one model registry: every mechanism model file under the workspace's `models/`
//! folder, generated into Rust at build time by this crate's `build.rs` and compiled in, and
//! [`system_for`], the one function that matches a model file to its compiled code.
//!
//! A model file is matched by its FNV-1a content hash
//! ([`mbs_symbolic::model::SourceInfo::hash`]): only a byte-identical copy of a compiled-in
//! model uses the generated code, so an edited model can never run with stale equations.
//! **The fallback** for a model that is not compiled in (a file elsewhere, an edited file not
//! yet rebuilt, a model whose generation failed at build time) is the DAG interpreter
//! ([`mbs_symbolic::runtime::InterpretedSystem`]): the same symbolic equations, evaluated
//! without generated code.
//!
//! **A stale model** is a file that takes the place of a compiled-in model — the very file
//! under `models/` the code was generated from, or a copy elsewhere with the same file
//! name — but whose content hash is no longer the compiled one (it was edited after the
//! build). [`system_for`] still falls back to the interpreter for it and says so
//! ([`Resolved::stale`]: which file, why, how to rebuild); the application announces it
//! once per process ([`Stale::first_notice`]), so that an edit is never silently run
//! slower than the user expects. The library prints nothing.
//!
//! Nothing outside this crate names a generated model's Rust type: callers get a
//! [`Box<dyn System>`](System) and check its shape at run time (so a model the product
//! cannot use where it is used gives a model-level message, never a compile error), or
//! visit the fixed-size type generically through [`Visitor`] (benchmarks, allocation tests).

use std::collections::BTreeSet;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use mbs_symbolic::model::Model;
use mbs_symbolic::runtime::{
    Backend, GeneratedSystem, InterpretedSystem, Mechanism, NumericSystem, ParamError, System,
};

include!(concat!(env!("OUT_DIR"), "/registry.rs"));

/// A model compiled into this build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Compiled {
    /// File stem under `models/` (`"double_bar"`).
    pub name: &'static str,
    /// File name under `models/` (`"double_bar.toml"`).
    pub file: &'static str,
    /// FNV-1a 64 content hash of the file the code was generated from.
    pub hash: &'static str,
    /// Name of the generated struct (`"DoubleBar"`).
    pub struct_name: &'static str,
    /// Number of coordinates.
    pub dof: usize,
    /// Number of constraint rows.
    pub rows: usize,
    /// The generated Rust source that was compiled in.
    pub source: &'static str,
    index: usize,
}

/// Generic access to a compiled-in model's fixed-size type (for code that must be
/// monomorphised: benchmarks of the generated functions, allocation tests).
pub trait Visitor {
    /// What the visit returns.
    type Output;
    /// Called with a default instance of the generated struct and its name constants.
    fn visit<T, const N: usize, const NC: usize>(
        self,
        mechanism: T,
        coordinate_names: &[&str],
        constraint_names: &[&str],
    ) -> Self::Output
    where
        T: Mechanism<N, NC> + Clone + Send + Sync + 'static;
}

/// Boxes generated code as a [`System`].
struct Boxer;

impl Visitor for Boxer {
    type Output = Box<dyn System>;
    fn visit<T, const N: usize, const NC: usize>(
        self,
        mechanism: T,
        coordinate_names: &[&str],
        constraint_names: &[&str],
    ) -> Box<dyn System>
    where
        T: Mechanism<N, NC> + Clone + Send + Sync + 'static,
    {
        match GeneratedSystem::new(mechanism, coordinate_names, constraint_names) {
            Ok(s) => Box::new(s),
            // The generated constants have the generated sizes.
            Err(e) => unreachable!("generated names do not match the generated sizes: {e}"),
        }
    }
}

impl Compiled {
    /// The generated code as a [`System`], with the model file's parameter values.
    pub fn system(&self) -> Box<dyn System> {
        visit(self.index, Boxer)
    }

    /// Calls `v` with the generated struct's fixed-size type.
    pub fn visit<V: Visitor>(&self, v: V) -> V::Output {
        visit(self.index, v)
    }
}

/// Every model compiled into this build, sorted by file name.
pub fn compiled() -> &'static [Compiled] {
    COMPILED
}

/// Model files under `models/` that could not be compiled in at build time, with the reason
/// (the build reports them as warnings; using one falls back to the interpreter).
pub fn skipped() -> &'static [(&'static str, &'static str)] {
    SKIPPED
}

/// The compiled-in model generated from a file with this content hash.
pub fn find_by_hash(hash: &str) -> Option<&'static Compiled> {
    COMPILED.iter().find(|c| c.hash == hash)
}

/// The compiled-in model with this file stem (`"double_bar"`).
pub fn find_by_name(name: &str) -> Option<&'static Compiled> {
    COMPILED.iter().find(|c| c.name == name)
}

/// The folder the compiled-in models were generated from: the workspace's `models/` at
/// build time.
pub fn models_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

/// How to rebuild so that the files under `models/` are compiled in again.
pub const REBUILD: &str = "cargo build --release -p codegen-cli";

/// A model file that takes the place of a compiled-in model but is not byte-identical to
/// it (see the crate documentation): it runs with the interpreter.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Stale {
    /// The model file, as given.
    pub file: String,
    /// Its content hash.
    pub hash: String,
    /// The compiled-in model it takes the place of.
    pub compiled: &'static Compiled,
    /// Whether it is the very file under `models/` the compiled code was generated from
    /// (edited since the build); otherwise a copy elsewhere with the same file name.
    pub edited_in_place: bool,
}

impl Stale {
    /// The stale model `model` is, if any: its file name is a compiled-in model's (or its
    /// path that model's file under `models/`) and its content hash is not that model's —
    /// nor any other compiled-in model's, which would run as generated code.
    pub fn of(model: &Model) -> Option<Stale> {
        if find_by_hash(&model.source.hash).is_some() {
            return None;
        }
        let path = Path::new(&model.source.path);
        let name = path.file_name()?.to_str()?;
        let compiled = COMPILED.iter().find(|c| c.file == name)?;
        let canonical = |p: &Path| std::fs::canonicalize(p).ok();
        let edited_in_place = canonical(path)
            .is_some_and(|p| canonical(&models_dir().join(compiled.file)).is_some_and(|m| m == p));
        Some(Stale {
            file: model.source.path.clone(),
            hash: model.source.hash.clone(),
            compiled,
            edited_in_place,
        })
    }
}

impl fmt::Display for Stale {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = self.compiled;
        if self.edited_in_place {
            write!(
                f,
                "note: model {} changed since this build compiled it (content hash {}, compiled {}): running it with the DAG interpreter (slower); rebuild to compile it in: {REBUILD}",
                self.file, self.hash, c.hash
            )
        } else {
            write!(
                f,
                "note: model {} is not the compiled-in models/{} (content hash {}, compiled {}): running it with the DAG interpreter (slower); to compile it in, put it under models/ and rebuild: {REBUILD}",
                self.file, c.file, self.hash, c.hash
            )
        }
    }
}

impl Stale {
    /// Whether this is the first time this process meets this file with this content as a
    /// stale model (a run resolves a model several times: comparison runs, linearisations,
    /// sweep points): the application announces it then, once. The library prints nothing.
    pub fn first_notice(&self) -> bool {
        static NOTICED: Mutex<BTreeSet<(String, String)>> = Mutex::new(BTreeSet::new());
        NOTICED
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .insert((self.file.clone(), self.hash.clone()))
    }
}

/// Why [`system_for`] could not provide the backend asked for.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RegistryError {
    /// Generated code was asked for a model that is not compiled in.
    #[error(
        "model {file} is not compiled into this build (compiled in: {}); use the interpreter or the numeric reference, or put the file under models/ and rebuild",
        .compiled.join(", ")
    )]
    NotCompiled {
        /// The model file.
        file: String,
        /// File names of the compiled-in models.
        compiled: Vec<String>,
    },
    /// A parameter value of the model could not be given to the generated code.
    #[error("model {file}: {error}")]
    Param {
        /// The model file.
        file: String,
        /// The problem.
        error: ParamError,
    },
}

/// A model's equations behind the one dynamic interface, and where they come from.
#[derive(Debug)]
pub struct Resolved {
    /// The equations.
    pub system: Box<dyn System>,
    /// The compiled-in model used, when the backend is generated code.
    pub compiled: Option<&'static Compiled>,
    /// When the interpreter stands in for a stale model (see [`Stale`]): which, and why.
    pub stale: Option<Stale>,
}

/// THE function that matches a model to an implementation of its equations.
///
/// - `backend = None`: generated code when the model file is compiled in (same content
///   hash), otherwise the documented fallback, the DAG interpreter — with
///   [`Resolved::stale`] when the model is [`Stale`] (the application announces it once,
///   [`Stale::first_notice`]);
/// - `Some(Backend::Generated)`: generated code, or [`RegistryError::NotCompiled`];
/// - `Some(Backend::Interpreted)` / `Some(Backend::Numeric)`: that backend.
///
/// The run-time parameters of generated code are set to the model's values (which the
/// caller may have overridden); the interpreter and the numeric reference are built from
/// the model as it is.
pub fn system_for(model: &Model, backend: Option<Backend>) -> Result<Resolved, RegistryError> {
    let compiled = find_by_hash(&model.source.hash);
    let file = || model.source.path.clone();
    match (backend, compiled) {
        (None | Some(Backend::Generated), Some(c)) => {
            let mut system = c.system();
            for p in model.parameters.iter().filter(|p| p.runtime && !p.derived) {
                system
                    .set_param(&p.name, p.value)
                    .map_err(|error| RegistryError::Param {
                        file: file(),
                        error,
                    })?;
            }
            Ok(Resolved {
                system,
                compiled: Some(c),
                stale: None,
            })
        }
        (Some(Backend::Generated), None) => Err(RegistryError::NotCompiled {
            file: file(),
            compiled: COMPILED.iter().map(|c| c.file.to_string()).collect(),
        }),
        (None, None) => {
            // The fallback: reported (`stale`) when the user may expect the compiled code.
            let stale = Stale::of(model);
            Ok(Resolved {
                system: Box::new(InterpretedSystem::new(model)),
                compiled: None,
                stale,
            })
        }
        (Some(Backend::Interpreted), _) => Ok(Resolved {
            system: Box::new(InterpretedSystem::new(model)),
            compiled: None,
            stale: None,
        }),
        (Some(Backend::Numeric), _) => Ok(Resolved {
            system: Box::new(NumericSystem::new(model)),
            compiled: None,
            stale: None,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bundled_model_is_compiled_in_and_matched_by_hash() {
        for name in [
            "double_bar",
            "four_bar",
            "slider_crank",
            "pendulum",
            "absorber",
            "slider_crank_damper",
        ] {
            let c = find_by_name(name).unwrap_or_else(|| panic!("{name} not compiled in"));
            let model = mbs_symbolic::model::load(&models_dir().join(c.file))
                .unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(find_by_hash(&model.source.hash), Some(c));
            assert_eq!((c.dof, c.rows), (model.dof(), model.constraint_rows()));
            let r = system_for(&model, None).unwrap();
            assert_eq!(r.system.backend(), Backend::Generated);
            assert_eq!(r.compiled, Some(c));
            assert_eq!(r.system.dof(), model.dof());
        }
        assert!(skipped().is_empty(), "{:?}", skipped());
        assert_eq!(find_by_hash("0000000000000000"), None);
    }

    /// `A = J' q'` and every point bias of the generated code are bitwise `0.0` at `q' = 0`
    /// (every term is a product with a joint rate; `mbs-symbolic`'s `tests/bias_at_rest.rs`
    /// checks the interpreter and the numeric reference on random spatial trees), with
    /// gravity on, at a few configurations of every compiled-in model.
    #[test]
    fn generated_bias_is_exactly_zero_at_rest() {
        for c in compiled() {
            let sys = c.system();
            let n = sys.dof();
            let mut ws = sys.workspace();
            let zero = vec![0.0; n];
            for s in 0..4 {
                let q: Vec<f64> = (0..n)
                    .map(|k| 0.3 + 0.7 * s as f64 - 0.45 * k as f64)
                    .collect();
                let mut biases = vec![];
                sys.evaluate(&q, &zero, 0.0, &mut ws);
                biases.extend(ws.a.iter().copied());
                for k in 0..sys.point_names().len() {
                    assert!(sys.point_kinematics(k, &q, &zero, &mut ws));
                    biases.extend(ws.point_a.iter().copied());
                    assert!(sys.evaluate_with_point(k, &q, &zero, 0.0, &mut ws));
                    biases.extend(ws.point_a.iter().chain(&ws.a).copied());
                }
                for v in biases {
                    assert_eq!(
                        v.to_bits(),
                        0,
                        "{}: J'q' = {v:e} at q' = 0, q = {q:?}",
                        c.file
                    );
                }
            }
        }
    }

    /// `G(q) = dF^b/dg` (the base-acceleration load, [`System::gravity_load_jacobian`]):
    /// the generated code, the DAG interpreter and the numeric reference (mass-weighted
    /// centre-of-mass Jacobians, an independent formulation) agree to 1e-12 at a few
    /// configurations of every compiled-in model; where gravity is a pair of run-time
    /// parameters `gx`, `gy`, its first two columns are the change of `F^b` per unit of
    /// each (F^b is linear in g, so the difference quotient is exact up to rounding) at
    /// non-zero joint rates.
    #[test]
    fn gravity_load_jacobian_agrees_across_backends_and_with_f() {
        let mut checked_fd = 0;
        for c in compiled() {
            let model = mbs_symbolic::model::load(&models_dir().join(c.file))
                .unwrap_or_else(|e| panic!("{e}"));
            let systems: [Box<dyn System>; 3] = [
                c.system(),
                Box::new(InterpretedSystem::new(&model)),
                Box::new(NumericSystem::new(&model)),
            ];
            let n = model.dof();
            for s in 0..4 {
                let q: Vec<f64> = (0..n)
                    .map(|k| 0.3 + 0.7 * s as f64 - 0.45 * k as f64)
                    .collect();
                let qd: Vec<f64> = (0..n).map(|k| 0.8 - 0.3 * k as f64).collect();
                let mut g = vec![];
                for sys in &systems {
                    let mut ws = sys.workspace();
                    sys.gravity_load_jacobian(&q, &mut ws);
                    g.push(ws.gravity_jacobian.clone());
                }
                let scale = g[2].amax().max(1e-300);
                assert!(g[2].amax() > 0.0, "{}: G = 0", c.file);
                for (k, other) in g.iter().enumerate().skip(1) {
                    let err = (other - &g[0]).amax();
                    assert!(
                        err <= 1e-12 * scale,
                        "{} backend {k}: |dG| = {err:e} of {scale:e}",
                        c.file
                    );
                }
                if !model.parameters.iter().any(|p| p.name == "gx" && p.runtime) {
                    continue;
                }
                let mut sys = c.system();
                let mut ws = sys.workspace();
                sys.evaluate(&q, &qd, 0.0, &mut ws);
                let f0 = ws.f.clone();
                for (col, name) in ["gx", "gy"].into_iter().enumerate() {
                    let k = model
                        .parameters
                        .iter()
                        .position(|p| p.name == name)
                        .unwrap();
                    let g0 = model.default_params()[k];
                    sys.set_param(name, g0 + 1.0).unwrap();
                    sys.evaluate(&q, &qd, 0.0, &mut ws);
                    sys.set_param(name, g0).unwrap();
                    let fd = &ws.f - &f0;
                    let err = (fd - g[0].column(col)).amax();
                    assert!(
                        err <= 1e-12 * scale,
                        "{} {name}: |dF - G| = {err:e}",
                        c.file
                    );
                }
                checked_fd += 1;
            }
        }
        assert!(
            checked_fd >= 8,
            "gx, gy checked on {checked_fd} configurations"
        );
    }

    /// A stale model is one that takes a compiled-in model's place (its file under
    /// `models/`, or a copy with its file name) with other content; a model of another
    /// name, or an unedited copy, is not.
    #[test]
    fn stale_models_are_recognised_by_name_or_path_and_content() {
        let original = models_dir().join("double_bar.toml");
        let text = std::fs::read_to_string(&original).unwrap();
        let load = |path: &std::path::Path| mbs_symbolic::model::load(path).unwrap();
        let dir = std::env::temp_dir().join(format!("registry-stale-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // An unedited copy runs the generated code: not stale.
        let copy = dir.join("double_bar.toml");
        std::fs::write(&copy, &text).unwrap();
        assert_eq!(Stale::of(&load(&copy)), None);
        // Edited, same name: stale, a copy elsewhere.
        std::fs::write(&copy, text.clone() + "\n# edited\n").unwrap();
        let edited = load(&copy);
        let stale = Stale::of(&edited).expect("an edited copy named double_bar.toml is stale");
        assert_eq!(stale.compiled.name, "double_bar");
        assert!(!stale.edited_in_place);
        let message = stale.to_string();
        for part in [
            copy.to_str().unwrap(),
            "not the compiled-in models/double_bar.toml",
            &edited.source.hash,
            stale.compiled.hash,
            "DAG interpreter",
            REBUILD,
        ] {
            assert!(message.contains(part), "{part:?} not in {message}");
        }
        let r = system_for(&edited, None).unwrap();
        assert_eq!(r.system.backend(), Backend::Interpreted);
        assert_eq!(r.stale, Some(stale.clone()));
        // Noticed once per file and content, whatever the number of look-ups.
        assert!(stale.first_notice());
        assert!(!stale.first_notice());
        assert!(!r.stale.as_ref().unwrap().first_notice());
        // Asking for the interpreter is not a fallback: nothing to announce.
        assert_eq!(
            system_for(&edited, Some(Backend::Interpreted))
                .unwrap()
                .stale,
            None
        );
        // Another name: not stale (nothing compiled in it could stand for).
        let other = dir.join("my_bar.toml");
        std::fs::write(&other, text.clone() + "\n# edited\n").unwrap();
        assert_eq!(Stale::of(&load(&other)), None);
        std::fs::remove_dir_all(&dir).unwrap();
        // The file under models/ itself, with content the build did not see: edited in
        // place, and the message says to rebuild.
        let mut in_place = load(&original);
        in_place.source.hash = "0123456789abcdef".into();
        let stale = Stale::of(&in_place).expect("models/double_bar.toml with a new hash");
        assert!(stale.edited_in_place);
        let message = stale.to_string();
        assert!(
            message.contains("changed since this build compiled it")
                && message.contains("0123456789abcdef")
                && message.contains(REBUILD),
            "{message}"
        );
    }

    #[test]
    fn an_edited_model_falls_back_to_the_interpreter() {
        let path = models_dir().join("double_bar.toml");
        let text = std::fs::read_to_string(&path).unwrap() + "\n# edited\n";
        let model =
            mbs_symbolic::model::parse_str(&text, "edited.toml", mbs_symbolic::model::Format::Toml)
                .unwrap();
        let r = system_for(&model, None).unwrap();
        assert_eq!(r.system.backend(), Backend::Interpreted);
        assert!(r.compiled.is_none());
        let err = system_for(&model, Some(Backend::Generated)).unwrap_err();
        assert!(
            err.to_string().contains("edited.toml is not compiled"),
            "{err}"
        );
        let r = system_for(&model, Some(Backend::Numeric)).unwrap();
        assert_eq!(r.system.backend(), Backend::Numeric);
    }
}
