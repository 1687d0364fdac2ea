//! The one scenario loader: a TOML file whose `kind` tag (default `"damper"`) says what it
//! describes.
//!
//! - `kind = "damper"` ([`preset`]): an elastic beam, a double bar pinned to one of its
//!   points (eqs. 45–58) and the DC generator, with initial conditions and the integrator —
//!   a preset: its tables are rewritten into the hybrid tables they mean and read by the
//!   hybrid reader, every problem still reported at the damper file's line;
//! - `kind = "mechanism"` ([`mechanism`]): a rigid closed-loop mechanism integrated in
//!   independent coordinates (eqs. 14–25);
//! - `kind = "hybrid"` ([`hybrid`]): an optional beam, any mechanisms, attachments, force
//!   elements and excitations (eqs. 44–58 in general form).
//!
//! The text is parsed once into a spanned document; the kind tag is read first (a typo gives
//! "unknown kind `mechanizm`, expected one of `damper`, `mechanism`, `hybrid`"), then every section is
//! read on its own, so that every problem of the file — an unknown key in one section, a bad
//! value in another — is reported at once as [`Diagnostics`], each with file:line:column
//! from the parser's spans ([`LineIndex`]).
//!
//! `--set PATH=VALUE` overrides ([`overrides`]) edit the text before it is parsed
//! ([`load_with`], [`parse_with`]): one code path for every kind.

pub mod compare;
pub mod hybrid;
pub mod integrator;
pub mod mechanism;
pub mod overrides;
pub mod preset;
pub mod units;

use std::ops::Range;
use std::path::Path;

use diagnostic::{Diagnostic, Diagnostics, Kind, LineIndex};
use serde::de::DeserializeOwned;
use toml::Spanned;
use toml::de::{DeTable, DeValue, ValueDeserializer};

pub use compare::Comparison;
pub use hybrid::HybridScenario;
pub use mechanism::MechanismScenario;
pub use overrides::{Applied, Override, OverrideRecord};

/// The kinds of scenario, as written after `kind =`.
pub const KINDS: [&str; 3] = ["damper", "mechanism", "hybrid"];

/// A loaded and checked scenario of either kind.
#[derive(Clone, Debug)]
pub enum Scenario {
    /// `kind = "mechanism"`.
    Mechanism(Box<MechanismScenario>),
    /// `kind = "hybrid"`, and `kind = "damper"` read as the hybrid scenario it is a preset
    /// of ([`preset`]).
    Hybrid(Box<HybridScenario>),
}

/// Reads and checks a scenario file of any kind; every problem is reported at once.
pub fn load(path: &Path) -> Result<Scenario, Diagnostics> {
    load_with(path, &[]).map(|l| l.scenario)
}

/// The text of a scenario file: a regular file of at most [`diagnostic::MAX_INPUT_BYTES`]
/// (a fifo, a device, a directory is refused in one line: [`diagnostic::read_input`]).
pub fn read(path: &Path) -> Result<String, Diagnostics> {
    diagnostic::read_input(path, "scenario file").map_err(Diagnostics::from)
}

/// A scenario loaded with `--set` overrides.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// The scenario, overrides applied.
    pub scenario: Scenario,
    /// The overrides applied; [`Applied::remap`] reports later problems of the scenario
    /// (run-time checks against the model) against the file and the options.
    pub applied: Applied,
    file: String,
}

impl Loaded {
    /// Later problems of this scenario (checks against its model) about the file and the
    /// options the user wrote.
    pub fn remap(&self, diags: Diagnostics) -> Diagnostics {
        self.applied.remap(&self.file, diags)
    }
}

/// Reads a scenario file, applies the `--set` overrides (in order) and checks the result;
/// every problem is reported at once, a problem with an overridden value naming its option.
pub fn load_with(path: &Path, overrides: &[Override]) -> Result<Loaded, Diagnostics> {
    parse_with(&read(path)?, path, overrides)
}

/// [`parse`] after applying the overrides to `text` ([`overrides::apply`]).
pub fn parse_with(text: &str, path: &Path, overrides: &[Override]) -> Result<Loaded, Diagnostics> {
    let base = path.parent().unwrap_or(Path::new("."));
    parse_with_in(text, &path.display().to_string(), base, overrides)
}

/// [`parse_with`] with the file's name and the directory of relative paths given apart
/// (text that is not read from a file: the Python package's `Scenario.from_str`).
pub fn parse_with_in(
    text: &str,
    file: &str,
    base: &Path,
    overrides: &[Override],
) -> Result<Loaded, Diagnostics> {
    let file = file.to_string();
    let applied = overrides::apply(text, &file, overrides)?;
    let given = overrides.iter().rev().find_map(|o| o.structure.clone());
    match parse_given(&applied.text, &file, base, given) {
        Ok(scenario) => Ok(Loaded {
            scenario,
            applied,
            file,
        }),
        Err(d) => Err(applied.remap(&file, d)),
    }
}

/// Parses and checks scenario text; `path` names the file in messages and is the base of
/// relative paths.
pub fn parse(text: &str, path: &Path) -> Result<Scenario, Diagnostics> {
    let base = path.parent().unwrap_or(Path::new("."));
    parse_in(text, &path.display().to_string(), base)
}

/// [`parse`] with the file's name and the directory of relative paths given apart.
pub fn parse_in(text: &str, file: &str, base: &Path) -> Result<Scenario, Diagnostics> {
    parse_given(text, file, base, None)
}

/// [`parse_in`] with the structure that `[structure] kind = "given"` stands for.
fn parse_given(
    text: &str,
    file: &str,
    base: &Path,
    given: Option<std::sync::Arc<fem_structure::StructureParts>>,
) -> Result<Scenario, Diagnostics> {
    let mut doc = Doc::parse(text, file, base)?;
    doc.given = given;
    let kind = doc.kind();
    let scenario = match kind.as_deref() {
        Some("damper") => {
            preset::expand(&mut doc);
            hybrid::from_doc(&mut doc).map(|s| Scenario::Hybrid(Box::new(s)))
        }
        Some("mechanism") => {
            mechanism::from_doc(&mut doc).map(|s| Scenario::Mechanism(Box::new(s)))
        }
        Some("hybrid") => hybrid::from_doc(&mut doc).map(|s| Scenario::Hybrid(Box::new(s))),
        _ => None,
    };
    let diags = doc.finish();
    match scenario {
        Some(s) if diags.is_empty() => Ok(s),
        _ => Err(diags),
    }
}

/// The kinds, quoted: "`damper`, `mechanism`, `hybrid`".
fn kinds() -> String {
    KINDS.map(|k| format!("`{k}`")).join(", ")
}

/// A parsed scenario text: the spanned document, the line index and the problems found so
/// far.
pub(crate) struct Doc<'a> {
    file: String,
    base: &'a Path,
    index: LineIndex,
    root: DeTable<'a>,
    diags: Diagnostics,
    /// Problems that follow from another one (a name unknown because the table that
    /// defines it could not be read): reported after every root cause.
    cascades: Diagnostics,
    /// `[[mechanism]]` tables that could not be read (their names are unknown).
    pub(crate) unread_mechanisms: usize,
    /// The structure given in memory ([`Override::structure`]) that `[structure] kind =
    /// "given"` stands for.
    given: Option<std::sync::Arc<fem_structure::StructureParts>>,
}

impl<'a> Doc<'a> {
    /// Parses `text`; a syntax error is the only problem reported alone.
    fn parse(text: &'a str, file: &str, base: &'a Path) -> Result<Doc<'a>, Diagnostics> {
        let file = file.to_string();
        let index = LineIndex::new(text);
        let root = DeTable::parse(text).map_err(|e| {
            let d = Diagnostic::new(Kind::Syntax, file.clone(), e.message().trim());
            Diagnostics::from(match e.span() {
                Some(s) => d.at_offset(&index, s.start),
                None => d,
            })
        })?;
        Ok(Doc {
            file,
            base,
            index,
            root: root.into_inner(),
            diags: Diagnostics::default(),
            cascades: Diagnostics::default(),
            unread_mechanisms: 0,
            given: None,
        })
    }

    /// The structure given in memory, if any ([`Override::structure`]).
    pub(crate) fn given(&self) -> Option<std::sync::Arc<fem_structure::StructureParts>> {
        self.given.clone()
    }

    /// The scenario file as given.
    pub(crate) fn file(&self) -> &str {
        &self.file
    }

    /// The directory relative paths are resolved against.
    pub(crate) fn base(&self) -> &Path {
        self.base
    }

    /// The line index of the text.
    pub(crate) fn index(&self) -> &LineIndex {
        &self.index
    }

    /// The `kind` tag (`"damper"` when absent), or `None` after reporting a bad one.
    fn kind(&mut self) -> Option<String> {
        let Some(v) = self.root.get("kind") else {
            return Some("damper".into());
        };
        let span = v.span();
        match v.get_ref() {
            DeValue::String(s) if KINDS.contains(&s.as_ref()) => Some(s.to_string()),
            DeValue::String(s) => {
                let msg = format!(
                    "unknown kind `{}`, expected one of {}",
                    diagnostic::truncate(s, 40),
                    kinds()
                );
                self.push(Kind::InvalidValue, Some(span), Some("kind"), msg);
                None
            }
            _ => {
                let msg = format!("must be a string, one of {}", kinds());
                self.push(Kind::Syntax, Some(span), Some("kind"), msg);
                None
            }
        }
    }

    /// Records a problem at a span of the text.
    pub(crate) fn push(
        &mut self,
        kind: Kind,
        span: Option<Range<usize>>,
        entity: Option<&str>,
        message: impl Into<String>,
    ) {
        let d = self.diagnostic(kind, span, entity, message);
        self.diags.push(d);
    }

    /// Records a problem ([`Doc::diagnostic`]) that follows from another one: reported
    /// after the root causes.
    pub(crate) fn push_cascade(&mut self, d: Diagnostic) {
        self.cascades.push(d);
    }

    /// A problem at a span of the text (not recorded); an unknown field's gets the nearest
    /// expected names ([`diagnostic::suggest_field`]: "did you mean `elements`?").
    pub(crate) fn diagnostic(
        &self,
        kind: Kind,
        span: Option<Range<usize>>,
        entity: Option<&str>,
        message: impl Into<String>,
    ) -> Diagnostic {
        let message = diagnostic::suggest_field(&message.into());
        let mut d = Diagnostic::new(kind, self.file.clone(), message);
        if let Some(s) = span {
            d = d.at_offset(&self.index, s.start);
        }
        if let Some(e) = entity {
            d = d.entity(e);
        }
        d
    }

    /// Reports every top-level key not in `known`.
    pub(crate) fn check_keys(&mut self, known: &[&str]) {
        let unknown: Vec<(String, Range<usize>)> = self
            .root
            .iter()
            .filter(|(k, _)| !known.contains(&k.get_ref().as_ref()))
            .map(|(k, _)| (k.get_ref().to_string(), k.span()))
            .collect();
        for (key, span) in unknown {
            let expected = known
                .iter()
                .map(|k| format!("`{k}`"))
                .collect::<Vec<_>>()
                .join(", ");
            self.push(
                Kind::UnknownField,
                Some(span),
                None,
                format!("unknown field `{key}`, expected one of {expected}"),
            );
        }
    }

    /// Deserializes the top-level entry `key` on its own, with its span; a missing entry is
    /// `None` (reported when `required`), a malformed one is reported and `None`.
    pub(crate) fn section<T: DeserializeOwned>(
        &mut self,
        key: &str,
        required: bool,
    ) -> Option<Spanned<T>> {
        let Some(v) = self.root.get(key) else {
            if required {
                self.push(
                    Kind::MissingField,
                    None,
                    None,
                    format!("missing field `{key}`"),
                );
            }
            return None;
        };
        let span = v.span();
        let entity = format!("[{key}]");
        match T::deserialize(ValueDeserializer::from(v.clone())) {
            Ok(t) => Some(Spanned::new(span, t)),
            Err(e) => {
                let at = e.span().or(Some(span));
                self.push(Kind::Syntax, at, Some(&entity), e.message().trim());
                None
            }
        }
    }

    /// The span of the value at `path` (keys of nested tables), when it is written.
    pub(crate) fn span(&self, path: &[&str]) -> Option<Range<usize>> {
        let (first, rest) = path.split_first()?;
        let mut v = self.root.get(*first)?;
        for key in rest {
            match v.get_ref() {
                DeValue::Table(t) => v = t.get(*key)?,
                _ => return None,
            }
        }
        Some(v.span())
    }

    /// The problems found, in source order: the root causes, then their cascades.
    fn finish(self) -> Diagnostics {
        let mut d = self.diags;
        d.sort();
        let mut cascades = self.cascades;
        cascades.sort();
        for c in cascades {
            d.push(c);
        }
        d
    }
}
