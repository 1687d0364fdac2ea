//! `--set PATH=VALUE` overrides: the scenario text is edited before the loader reads it.
//!
//! PATH addresses a field of the scenario file with dots and indices, exactly as the file
//! nests it: `mechanism.half_angle_deg`, `generator.load_resistance`,
//! `beam.segment[0].elements` (`[[beam.segment]]`), `beam.damping.ratios[1].ratio` (an
//! array of inline tables), `mechanisms[1].parameters.m1`. VALUE is a TOML value (number,
//! boolean, string, array, inline table); a bare word that is not valid TOML is a string.
//!
//! The edit is made on the document with `toml_edit`, which keeps every other byte of the
//! file (comments, spacing, order), so the loader and its checks run unchanged on the edited
//! text: an unknown leaf key is rejected as an unknown field, a bad value is rejected as in a
//! file, relative paths still resolve against the scenario's directory. Only the positions
//! change meaning, so [`Applied::remap`] rewrites the loader's diagnostics: one on a line an
//! override wrote names that override (`--set PATH=VALUE`) instead of a line the user never
//! wrote; one elsewhere gets its line in the original file back (an override that inserts a
//! key inserts a line).
//!
//! What cannot be applied — a parent that does not exist, an index out of range, a path
//! through a value that is not a table or array — is one diagnostic naming the override.

use std::collections::BTreeSet;
use std::fmt;
use std::ops::Range;
use std::str::FromStr;

use diagnostic::{Diagnostic, Diagnostics, Kind, LineIndex};
use serde::Serialize;
use toml_edit::{DocumentMut, Item, Table, Value};

/// One step of a PATH: a key or an index.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Step {
    /// `.name` (or the first name).
    Key(String),
    /// `[i]`.
    Index(usize),
}

/// Why a PATH or a `--set PATH=VALUE` option cannot be read.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum PathError {
    /// The PATH is empty.
    #[error("empty PATH")]
    Empty,
    /// A key is empty or has characters outside `A-Z a-z 0-9 _ -`.
    #[error(
        "bad PATH `{path}`: expected keys separated by dots, each followed by optional [index]"
    )]
    BadKey {
        /// The PATH.
        path: String,
    },
    /// An index is not `[N]`.
    #[error("bad index in PATH `{path}` (expected `[N]`)")]
    BadIndex {
        /// The PATH.
        path: String,
    },
    /// No `=` in the option.
    #[error("--set {option}: expected PATH=VALUE")]
    NoValue {
        /// The option's text.
        option: String,
    },
    /// The option's PATH is bad.
    #[error("--set {option}: {source}")]
    Option {
        /// The option's text.
        option: String,
        /// What is wrong with its PATH.
        source: Box<PathError>,
    },
}

/// One `--set PATH=VALUE`, parsed.
#[derive(Clone, Debug)]
pub struct Override {
    /// PATH as written.
    pub path: String,
    /// The steps of PATH.
    pub steps: Vec<Step>,
    /// VALUE as written.
    pub text: String,
    /// VALUE as a TOML value.
    pub value: Value,
    /// The structure given in memory that VALUE's `kind = "given"` stands for
    /// ([`Override::structure`]).
    pub structure: Option<std::sync::Arc<fem_structure::StructureParts>>,
}

impl Override {
    /// An override of `path` (as written) by `value`.
    pub fn new(path: &str, value: Value, text: &str) -> Result<Override, PathError> {
        Ok(Override {
            path: path.to_string(),
            steps: parse_path(path)?,
            text: text.to_string(),
            value,
            structure: None,
        })
    }

    /// The scenario's host structure replaced by `parts`, given in memory (the Python
    /// package's `Structure.from_matrices`): `structure = { kind = "given", ... }` with the
    /// entries of `table` (its `damping` ratios, its `reduction`), the parts carried along
    /// to the loader. Later overrides may still set `structure.reduction.modes`.
    pub fn structure(
        parts: std::sync::Arc<fem_structure::StructureParts>,
        table: toml_edit::InlineTable,
    ) -> Override {
        let mut t = toml_edit::InlineTable::new();
        t.insert("kind", Value::from("given"));
        t.extend(table);
        let value = Value::InlineTable(t);
        Override {
            path: "structure".into(),
            steps: vec![Step::Key("structure".into())],
            text: value.to_string(),
            value,
            structure: Some(parts),
        }
    }

    /// `--set PATH=VALUE`, as the user wrote it; a VALUE longer than [`OPTION_SHOWN`]
    /// characters cut there with its length (a diagnostic names the option, it does not
    /// copy a long input: memory and time linear in the input however many diagnostics).
    pub fn option(&self) -> String {
        match self.text.char_indices().nth(OPTION_SHOWN) {
            Some((at, _)) => format!(
                "--set {}={}... ({} characters)",
                self.path,
                &self.text[..at],
                self.text.chars().count()
            ),
            None => format!("--set {}={}", self.path, self.text),
        }
    }

    /// What the summary records: `{"path": .., "value": ..}`.
    pub fn record(&self) -> OverrideRecord {
        OverrideRecord {
            path: self.path.clone(),
            value: json_value(&self.value),
        }
    }
}

/// Characters of a VALUE a diagnostic shows ([`Override::option`]).
pub const OPTION_SHOWN: usize = 80;

impl FromStr for Override {
    type Err = PathError;

    /// `PATH=VALUE` (split at the first `=`).
    fn from_str(s: &str) -> Result<Override, PathError> {
        let (path, text) = s.split_once('=').ok_or_else(|| PathError::NoValue {
            option: s.to_string(),
        })?;
        Override::new(path.trim(), parse_value(text.trim()), text.trim()).map_err(|e| {
            PathError::Option {
                option: s.to_string(),
                source: Box::new(e),
            }
        })
    }
}

/// An override as recorded in a run's summary (`"overrides": [{"path":..,"value":..}]`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OverrideRecord {
    /// PATH.
    pub path: String,
    /// VALUE (TOML value as JSON).
    pub value: serde_json::Value,
}

/// VALUE as a TOML value; text that is not a valid TOML value is a string.
pub fn parse_value(text: &str) -> Value {
    match text.parse::<Value>() {
        Ok(mut v) => {
            v.decor_mut().clear();
            v
        }
        Err(_) => Value::from(text),
    }
}

/// The steps of a PATH: bare keys (`A-Z a-z 0-9 _ -`) separated by dots, each followed by
/// any number of `[i]`.
pub fn parse_path(path: &str) -> Result<Vec<Step>, PathError> {
    let mut steps = vec![];
    if path.is_empty() {
        return Err(PathError::Empty);
    }
    for part in path.split('.') {
        let (name, mut rest) = part.split_at(part.find('[').unwrap_or(part.len()));
        let bare = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
        if name.is_empty() || !name.chars().all(bare) {
            return Err(PathError::BadKey {
                path: path.to_string(),
            });
        }
        steps.push(Step::Key(name.to_string()));
        while !rest.is_empty() {
            let index = rest
                .strip_prefix('[')
                .and_then(|r| r.split_once(']'))
                .and_then(|(i, r)| Some((i.parse::<usize>().ok()?, r)));
            match index {
                Some((i, r)) => {
                    steps.push(Step::Index(i));
                    rest = r;
                }
                None => {
                    return Err(PathError::BadIndex {
                        path: path.to_string(),
                    });
                }
            }
        }
    }
    Ok(steps)
}

/// Shows steps as a PATH prefix (`beam.segment[0]`).
fn show(steps: &[Step]) -> String {
    let mut s = String::new();
    for (k, step) in steps.iter().enumerate() {
        match step {
            Step::Key(name) if k == 0 => s.push_str(name),
            Step::Key(name) => {
                s.push('.');
                s.push_str(name);
            }
            Step::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

/// The text after the overrides, and what is needed to report the loader's problems against
/// the file and the options the user wrote.
#[derive(Clone, Debug, Default)]
pub struct Applied {
    /// The edited text.
    pub text: String,
    /// The overrides, in command-line order.
    pub overrides: Vec<Override>,
    /// Lines of the edited text (1-based) written by each override.
    lines: Vec<Range<usize>>,
    /// Line of the original file for each line of the edited text (index = line - 1), when
    /// the edit could be followed line by line.
    line_map: Option<Vec<usize>>,
}

impl Applied {
    /// The text unchanged (no override).
    pub fn none(text: &str) -> Applied {
        Applied {
            text: text.to_string(),
            ..Applied::default()
        }
    }

    /// The records for a summary, in command-line order.
    pub fn records(&self) -> Vec<OverrideRecord> {
        self.overrides.iter().map(Override::record).collect()
    }

    /// The loader's problems, about the file `file` as the user sees it: a problem on a line
    /// an override wrote names that override (no file line), any other gets its line of the
    /// original file.
    pub fn remap(&self, file: &str, diags: Diagnostics) -> Diagnostics {
        if self.overrides.is_empty() {
            return diags;
        }
        diags
            .0
            .into_iter()
            .map(|d| self.remap_one(file, d))
            .collect::<Vec<_>>()
            .into()
    }

    fn remap_one(&self, file: &str, mut d: Diagnostic) -> Diagnostic {
        if d.file != file {
            return d;
        }
        // A check of a whole section (`[beam]`, at its header or without a line) names the
        // last override in it.
        let in_section = || {
            self.overrides.iter().rposition(|o| {
                let Some(Step::Key(section)) = o.steps.first() else {
                    return false;
                };
                d.entity.as_deref().is_some_and(|e| {
                    e.strip_prefix('[')
                        .and_then(|e| e.strip_prefix(section.as_str()))
                        .is_some_and(|rest| rest.starts_with([']', '.', '[']))
                })
            })
        };
        let by = match d.line {
            Some(line) => self
                .lines
                .iter()
                .rposition(|r| r.contains(&line))
                .or_else(in_section),
            None => in_section(),
        };
        match by {
            Some(k) => {
                let entity = match d.entity.take() {
                    Some(e) => format!("{}: {e}", self.overrides[k].option()),
                    None => self.overrides[k].option(),
                };
                d.line = None;
                d.column = None;
                d.entity = Some(entity);
            }
            None => {
                if let (Some(map), Some(line)) = (&self.line_map, d.line) {
                    d.line = map.get(line - 1).copied().or(Some(line));
                }
            }
        }
        d
    }
}

/// Applies the overrides, in order, to the scenario text; `file` names it in the problems.
pub fn apply(text: &str, file: &str, overrides: &[Override]) -> Result<Applied, Diagnostics> {
    if overrides.is_empty() {
        return Ok(Applied::none(text));
    }
    let mut doc = match text.parse::<DocumentMut>() {
        Ok(d) => d,
        // A syntax error is reported by the loader itself, with its position.
        Err(_) => return Ok(Applied::none(text)),
    };
    let bad = |o: &Override, kind: Kind, msg: String| {
        Diagnostics::from(Diagnostic::new(kind, file, msg).entity(o.option()))
    };
    for o in overrides {
        set(doc.as_table_mut(), &o.steps, o.value.clone()).map_err(|(k, m)| {
            match suggest(&doc, o) {
                Some(hint) => bad(o, Kind::UnknownField, format!("{m}{hint}")),
                None => bad(o, k, m),
            }
        })?;
    }
    let edited = doc.to_string();
    let (lines, line_map) = follow_lines(text, &edited, overrides);
    Ok(Applied {
        text: edited,
        overrides: overrides.to_vec(),
        lines,
        line_map,
    })
}

/// What to say after "no `x` in ..." when an override's PATH is not in the document: the
/// same field's path in the other kind's form when the scenario is of the damper or the
/// hybrid kind ([`super::preset::translate`]: "did you mean `force[0].load_resistance`?
/// `generator.load_resistance` is the damper kind's path; ..."), else the PATHs
/// with the first unknown key replaced by its closest names ([`diagnostic::closest`]); only
/// a PATH this document takes is suggested.
fn suggest(doc: &DocumentMut, o: &Override) -> Option<String> {
    let takes = |steps: &[Step]| set(&mut doc.as_table().clone(), steps, o.value.clone()).is_ok();
    let kind = doc.get("kind").map_or(Some("damper"), Item::as_str);
    if let Some(kind @ ("damper" | "hybrid")) = kind {
        let to_hybrid = kind == "hybrid";
        let other = if to_hybrid { "damper" } else { "hybrid" };
        if let Some(path) = super::preset::translate(&o.path, to_hybrid)
            && parse_path(&path).is_ok_and(|steps| takes(&steps))
        {
            return Some(format!(
                " (did you mean `{path}`? `{}` is the {other} kind's path; this scenario is of kind {kind})",
                o.path
            ));
        }
    }
    for (k, step) in o.steps.iter().enumerate() {
        let Step::Key(name) = step else { continue };
        let keys = keys_at(doc.as_table(), &o.steps[..k])?;
        if keys.contains(name) {
            continue;
        }
        let paths: Vec<String> = diagnostic::closest(name, keys)
            .into_iter()
            .map(|key| {
                let mut steps = o.steps.clone();
                steps[k] = Step::Key(key);
                steps
            })
            .filter(|steps| takes(steps))
            .map(|steps| show(&steps))
            .collect();
        return (!paths.is_empty()).then(|| diagnostic::did_you_mean(&paths));
    }
    None
}

/// The keys of the table reached by `steps` below `root` (`None` when the steps do not
/// reach a table).
fn keys_at(root: &Table, steps: &[Step]) -> Option<Vec<String>> {
    let mut node = At::Table(root);
    for step in steps {
        node = match (node, step) {
            (At::Table(t), Step::Key(k)) | (At::Item(Item::Table(t)), Step::Key(k)) => {
                At::Item(t.get(k)?)
            }
            (At::Item(Item::ArrayOfTables(a)), Step::Index(i)) => At::Table(a.get(*i)?),
            (At::Item(Item::Value(v)) | At::Value(v), step) => match (v, step) {
                (Value::InlineTable(t), Step::Key(k)) => At::Value(t.get(k)?),
                (Value::Array(a), Step::Index(i)) => At::Value(a.get(*i)?),
                _ => return None,
            },
            _ => return None,
        };
    }
    match node {
        At::Table(t) | At::Item(Item::Table(t)) => {
            Some(t.iter().map(|(k, _)| k.to_string()).collect())
        }
        At::Item(Item::Value(Value::InlineTable(t))) | At::Value(Value::InlineTable(t)) => {
            Some(t.iter().map(|(k, _)| k.to_string()).collect())
        }
        _ => None,
    }
}

/// A node on the way down a PATH.
enum Node<'a> {
    Table(&'a mut Table),
    Item(&'a mut Item),
    Value(&'a mut Value),
}

/// Sets the value at `steps` below `root`.
fn set(root: &mut Table, steps: &[Step], value: Value) -> Result<(), (Kind, String)> {
    let (last, parents) = steps.split_last().expect("a PATH has a step");
    let mut node = Node::Table(root);
    for (k, step) in parents.iter().enumerate() {
        let here = show(&steps[..k]);
        let there = show(&steps[..=k]);
        node = match (node, step) {
            (Node::Table(t), Step::Key(key)) => match t.get_mut(key) {
                Some(item) => Node::Item(item),
                None => return Err(missing(&here, &there)),
            },
            (Node::Item(item), step) => match (item, step) {
                (Item::Table(t), Step::Key(key)) => match t.get_mut(key) {
                    Some(i) => Node::Item(i),
                    None => return Err(missing(&here, &there)),
                },
                (Item::ArrayOfTables(a), Step::Index(i)) => {
                    let n = a.len();
                    match a.get_mut(*i) {
                        Some(t) => Node::Table(t),
                        None => return Err(out_of_range(&here, *i, n)),
                    }
                }
                (Item::Value(v), step) => descend_value(v, step, &here, &there)?,
                (_, step) => return Err(not_container(&here, step)),
            },
            (Node::Value(v), step) => descend_value(v, step, &here, &there)?,
            (Node::Table(_), Step::Index(_)) => return Err(not_container(&here, step)),
        };
    }
    let here = show(parents);
    match (node, last) {
        (Node::Table(t), Step::Key(key)) => set_in_table(t, key, value),
        (Node::Item(Item::Table(t)), Step::Key(key)) => set_in_table(t, key, value),
        (Node::Item(Item::ArrayOfTables(a)), Step::Index(i)) => Err(match a.get(*i) {
            Some(_) => (
                Kind::InvalidValue,
                format!(
                    "`{here}[{i}]` is a [[table]] entry: set its fields (`{here}[{i}].NAME=VALUE`)"
                ),
            ),
            None => out_of_range(&here, *i, a.len()),
        }),
        (Node::Item(Item::Value(v)) | Node::Value(v), last) => set_in_value(v, last, value, &here),
        (_, last) => Err(not_container(&here, last)),
    }
}

fn descend_value<'a>(
    v: &'a mut Value,
    step: &Step,
    here: &str,
    there: &str,
) -> Result<Node<'a>, (Kind, String)> {
    match (v, step) {
        (Value::InlineTable(t), Step::Key(key)) => match t.get_mut(key) {
            Some(v) => Ok(Node::Value(v)),
            None => Err(missing(here, there)),
        },
        (Value::Array(a), Step::Index(i)) => {
            let n = a.len();
            match a.get_mut(*i) {
                Some(v) => Ok(Node::Value(v)),
                None => Err(out_of_range(here, *i, n)),
            }
        }
        (_, step) => Err(not_container(here, step)),
    }
}

fn set_in_table(t: &mut Table, key: &str, value: Value) -> Result<(), (Kind, String)> {
    match t.get_mut(key) {
        Some(Item::Value(old)) => replace(old, value),
        Some(item) => *item = Item::Value(value),
        None => {
            t.insert(key, Item::Value(value));
        }
    }
    Ok(())
}

fn set_in_value(
    v: &mut Value,
    last: &Step,
    value: Value,
    here: &str,
) -> Result<(), (Kind, String)> {
    match (v, last) {
        (Value::InlineTable(t), Step::Key(key)) => {
            match t.get_mut(key) {
                Some(old) => replace(old, value),
                None => {
                    t.insert(key, value);
                }
            }
            Ok(())
        }
        (Value::Array(a), Step::Index(i)) => {
            let n = a.len();
            match a.get_mut(*i) {
                Some(old) => {
                    replace(old, value);
                    Ok(())
                }
                None => Err(out_of_range(here, *i, n)),
            }
        }
        (_, last) => Err(not_container(here, last)),
    }
}

/// Replaces a value, keeping the spacing and comment around it.
/// Replaces `old` by `value`, keeping its decoration; a whole float (`10.0`, what a range or
/// a numpy array gives) replacing an integer is written as the integer, so an integer field
/// (an element count) takes it.
fn replace(old: &mut Value, mut value: Value) {
    if let (Value::Integer(_), Value::Float(f)) = (&*old, &value) {
        let x = *f.value();
        // Exactly representable: |x| below 2^53.
        if x.fract() == 0.0 && x.abs() < 9.007_199_254_740_992e15 {
            value = Value::from(x as i64);
        }
    }
    *value.decor_mut() = old.decor().clone();
    *old = value;
}

fn missing(here: &str, there: &str) -> (Kind, String) {
    let parent = if here.is_empty() {
        "the scenario".to_string()
    } else {
        format!("`{here}`")
    };
    (
        Kind::UnknownField,
        format!("no `{there}` in {parent} (an override sets a field of an existing table)"),
    )
}

fn out_of_range(here: &str, i: usize, n: usize) -> (Kind, String) {
    (
        Kind::InvalidValue,
        format!(
            "index {i} out of range: `{here}` has {n} entr{}",
            if n == 1 { "y" } else { "ies" }
        ),
    )
}

fn not_container(here: &str, step: &Step) -> (Kind, String) {
    let what = match step {
        Step::Key(_) => "a table",
        Step::Index(_) => "an array",
    };
    let here = if here.is_empty() {
        "the scenario"
    } else {
        here
    };
    (Kind::InvalidValue, format!("`{here}` is not {what}"))
}

/// Read-only node of a parsed (spanned) document.
enum At<'a> {
    Table(&'a Table),
    Item(&'a Item),
    Value(&'a Value),
}

/// The span of the key (when the last step is a key) and of the value at `steps` in a
/// parsed document.
fn span_of(root: &Table, steps: &[Step]) -> Option<(Option<Range<usize>>, Range<usize>)> {
    let mut node = At::Table(root);
    let mut key_span = None;
    for step in steps {
        key_span = None;
        node = match (node, step) {
            (At::Table(t), Step::Key(k)) | (At::Item(Item::Table(t)), Step::Key(k)) => {
                key_span = t.key(k).and_then(|k| k.span());
                At::Item(t.get(k)?)
            }
            (At::Item(Item::ArrayOfTables(a)), Step::Index(i)) => At::Table(a.get(*i)?),
            (At::Item(Item::Value(v)) | At::Value(v), step) => match (v, step) {
                (Value::InlineTable(t), Step::Key(k)) => {
                    key_span = t.key(k).and_then(|k| k.span());
                    At::Value(t.get(k)?)
                }
                (Value::Array(a), Step::Index(i)) => At::Value(a.get(*i)?),
                _ => return None,
            },
            _ => return None,
        };
    }
    let span = match node {
        At::Table(t) => t.span(),
        At::Item(i) => i.span(),
        At::Value(v) => v.span(),
    }?;
    Some((key_span, span))
}

/// The lines each override wrote in the edited text, and the line of the original text for
/// every other line of the edited text (`None` when the edit cannot be followed line by
/// line: then lines are left as they are).
fn follow_lines(
    old: &str,
    new: &str,
    overrides: &[Override],
) -> (Vec<Range<usize>>, Option<Vec<usize>>) {
    let (Ok(old_doc), Ok(new_doc)) = (
        toml_edit::Document::parse(old),
        toml_edit::Document::parse(new),
    ) else {
        return (vec![0..0; overrides.len()], None);
    };
    let (old_ix, new_ix) = (LineIndex::new(old), LineIndex::new(new));
    let lines_of = |ix: &LineIndex, key: Option<Range<usize>>, value: Range<usize>| {
        let start = key.map_or(value.start, |k| k.start.min(value.start));
        ix.line(start)..ix.line(value.end.saturating_sub(1).max(start)) + 1
    };
    let mut written = vec![];
    let mut new_lines = BTreeSet::new();
    let mut old_lines = BTreeSet::new();
    for o in overrides {
        let lines = match span_of(new_doc.as_table(), &o.steps) {
            Some((key, value)) => lines_of(&new_ix, key, value),
            None => 0..0,
        };
        new_lines.extend(lines.clone());
        written.push(lines);
        if let Some((key, value)) = span_of(old_doc.as_table(), &o.steps) {
            old_lines.extend(lines_of(&old_ix, key, value));
        }
    }
    let count = |t: &str| t.lines().count().max(1);
    let new_rest: Vec<usize> = (1..=count(new))
        .filter(|l| !new_lines.contains(l))
        .collect();
    let old_rest: Vec<usize> = (1..=count(old))
        .filter(|l| !old_lines.contains(l))
        .collect();
    if new_rest.len() != old_rest.len() {
        return (written, None);
    }
    let mut map: Vec<usize> = (1..=count(new)).collect();
    for (n, o) in new_rest.iter().zip(&old_rest) {
        map[n - 1] = *o;
    }
    (written, Some(map))
}

/// A TOML value as JSON (datetimes as their text).
pub fn json_value(v: &Value) -> serde_json::Value {
    use serde_json::Value as J;
    match v {
        Value::String(s) => J::String(s.value().clone()),
        Value::Integer(i) => J::from(*i.value()),
        Value::Float(f) => serde_json::Number::from_f64(*f.value())
            .map_or_else(|| J::String(f.value().to_string()), J::Number),
        Value::Boolean(b) => J::Bool(*b.value()),
        Value::Datetime(d) => J::String(d.value().to_string()),
        Value::Array(a) => J::Array(a.iter().map(json_value).collect()),
        Value::InlineTable(t) => J::Object(
            t.iter()
                .map(|(k, v)| (k.to_string(), json_value(v)))
                .collect(),
        ),
    }
}

/// A value's TOML text, without surrounding spacing.
pub fn value_text(v: &Value) -> String {
    let mut v = v.clone();
    v.decor_mut().clear();
    v.to_string()
}

impl fmt::Display for Override {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}={}", self.path, self.text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "\
kind = \"damper\" # the kind
[mechanism]
half_angle_deg = 10.0   # alpha0
point = \"tip\"

[[beam.segment]]
elements = 20
ratios = [{ mode = 1, ratio = 0.002 }, { mode = 2, ratio = 0.002 }]

[output]
every = 10
";

    fn o(s: &str) -> Override {
        s.parse().unwrap()
    }

    #[test]
    fn paths_parse_into_keys_and_indices() {
        assert_eq!(
            parse_path("beam.segment[0].elements").unwrap(),
            vec![
                Step::Key("beam".into()),
                Step::Key("segment".into()),
                Step::Index(0),
                Step::Key("elements".into())
            ]
        );
        assert!(parse_path("a..b").is_err());
        assert!(parse_path("a[x]").is_err());
        assert!(parse_path("a[1").is_err());
        assert!(parse_path("").is_err());
    }

    #[test]
    fn values_are_toml_or_bare_strings() {
        assert_eq!(value_text(&parse_value("5")), "5");
        assert_eq!(value_text(&parse_value("2.5e-3")), "2.5e-3");
        assert_eq!(value_text(&parse_value("[1, 2]")), "[1, 2]");
        assert_eq!(value_text(&parse_value("tip")), "\"tip\"");
        assert_eq!(value_text(&parse_value("\"a b\"")), "\"a b\"");
        assert_eq!(
            json_value(&parse_value("{ a = 1 }")),
            serde_json::json!({"a": 1})
        );
    }

    #[test]
    fn an_override_replaces_the_value_and_keeps_every_other_byte() {
        let a = apply(TEXT, "f.toml", &[o("mechanism.half_angle_deg=5.5")]).unwrap();
        assert_eq!(
            a.text,
            TEXT.replace("half_angle_deg = 10.0 ", "half_angle_deg = 5.5 ")
        );
        let a = apply(
            TEXT,
            "f.toml",
            &[
                o("beam.segment[0].ratios[1].ratio=0.01"),
                o("beam.segment[0].elements=4"),
            ],
        )
        .unwrap();
        assert_eq!(
            a.text,
            TEXT.replace("ratio = 0.002 }]", "ratio = 0.01 }]")
                .replace("elements = 20", "elements = 4")
        );
    }

    #[test]
    fn problems_on_written_lines_name_the_option_and_others_keep_their_file_line() {
        // A new key inserts a line: the lines after it are mapped back.
        let a = apply(TEXT, "f.toml", &[o("mechanism.pivot=[1, 2]")]).unwrap();
        assert_eq!(a.text.lines().count(), TEXT.lines().count() + 1);
        let new_line = a.text.lines().position(|l| l.starts_with("pivot")).unwrap() + 1;
        let every = a.text.lines().position(|l| l.starts_with("every")).unwrap() + 1;
        let at = |line| Diagnostic::new(Kind::InvalidValue, "f.toml", "bad").at_line(Some(line));
        let d = a.remap("f.toml", Diagnostics(vec![at(new_line), at(every)]));
        assert_eq!(
            d.0[0].to_string(),
            "f.toml: --set mechanism.pivot=[1, 2]: bad"
        );
        assert_eq!(d.0[1].line, Some(11));
        assert_eq!(TEXT.lines().nth(10), Some("every = 10"));
        // A problem of a whole section, without a line, names the last override in it.
        let a = apply(
            TEXT,
            "f.toml",
            &[o("beam.segment[0].elements=0"), o("output.every=1")],
        )
        .unwrap();
        let section = |e: &str| Diagnostic::new(Kind::InvalidValue, "f.toml", "bad").entity(e);
        let d = a.remap(
            "f.toml",
            Diagnostics(vec![section("[beam]"), section("[beams]")]),
        );
        assert_eq!(
            d.0[0].to_string(),
            "f.toml: --set beam.segment[0].elements=0: [beam]: bad"
        );
        assert_eq!(d.0[1].to_string(), "f.toml: [beams]: bad");
    }

    #[test]
    fn a_missing_parent_or_index_is_one_problem_naming_the_option() {
        let err = |s: &str| apply(TEXT, "f.toml", &[o(s)]).unwrap_err().to_string();
        assert_eq!(
            err("mechanizm.x=1"),
            "f.toml: --set mechanizm.x=1: no `mechanizm` in the scenario (an override sets a field of an existing table) (did you mean `mechanism.x`?)"
        );
        assert!(
            err("beam.segment[3].elements=1")
                .contains("index 3 out of range: `beam.segment` has 1 entry")
        );
        assert!(err("kind.x=1").contains("`kind` is not a table"));
        assert!(err("beam.segment[0].ratios[2].ratio=1").contains("index 2 out of range"));
    }

    #[test]
    fn a_path_not_in_the_document_gets_the_nearest_paths_or_the_other_kinds_path() {
        let err = |s: &str| apply(TEXT, "f.toml", &[o(s)]).unwrap_err();
        // The nearest key of the table where the PATH leaves the document, checked to apply.
        let e = err("beam.segmnt[0].elements=3");
        assert_eq!(e.0[0].kind, Kind::UnknownField);
        assert!(
            e.to_string()
                .ends_with("(did you mean `beam.segment[0].elements`?)"),
            "{e}"
        );
        // A hybrid-kind path in a damper-kind file: the damper kind's path.
        let e = err("mechanism[0].placement.half_angle_deg=5").to_string();
        assert!(e.contains("`mechanism` is not an array (did you mean `mechanism.half_angle_deg`? `mechanism[0].placement.half_angle_deg` is the hybrid kind's path; this scenario is of kind damper)"), "{e}");
        // Nothing near: no suggestion.
        let e = err("zzzzzzzzzz.x=1").to_string();
        assert!(!e.contains("did you mean"), "{e}");
        // A suggestion the document would not take is not made (no `[generator]` here).
        let e = err("force[0].kt=1").to_string();
        assert!(!e.contains("did you mean"), "{e}");
    }
}
