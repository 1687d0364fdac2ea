//! Validation: the [`Node`] tree of a model file to a [`Model`], reporting every problem.
//!
//! Order of work: top-level keys, `[parameters]` (in written order, each may use earlier
//! ones), gravity, bodies (names, coordinates, parents, stable topological sort, joints,
//! mass properties), points, forces, constraints. Nothing stops at the first problem: an
//! entity that cannot be read is still known by name, so references to it do not produce
//! follow-up errors, and expressions that use a broken parameter are not evaluated.
//!
//! `bodies.rs` and `refs.rs` hold the checks of the bodies and of the entities that refer
//! to them (points, forces, constraints).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use super::expr_parse::{ExprError, NameError, RESERVED, params_used, parse_expr};
use super::node::{Node, Seg, Value};
use super::raw::{RawBody, RawParam, RawScalar, RawVec3};
use super::types::{Axis, Body, Joint, JointKind, Model, Parameter, Point, Scalar, SourceInfo};
use diagnostic::{Diagnostic, Kind};

mod bodies;
pub(crate) use bodies::inertia_problem;
mod refs;

const TOP_LEVEL_KEYS: [&str; 8] = [
    "name",
    "description",
    "gravity",
    "parameters",
    "bodies",
    "points",
    "forces",
    "constraints",
];

/// Relative tolerance of the inertia checks, times the trace.
const INERTIA_TOL: f64 = 1e-9;

/// Validates the tree of a model file. `file` is the name used in messages.
pub(crate) fn validate(
    root: &Node,
    file: &str,
    source: SourceInfo,
) -> Result<Model, Vec<Diagnostic>> {
    let mut v = Validator {
        file,
        errors: Vec::new(),
        params: Vec::new(),
        param_ok: Vec::new(),
        derived: Vec::new(),
        param_index: BTreeMap::new(),
        bodies: Vec::new(),
        body_index: BTreeMap::new(),
        placed: Vec::new(),
        order: Vec::new(),
        points: Vec::new(),
        point_index: BTreeMap::new(),
        point_lines: Vec::new(),
    };
    let model = v.run(root, source);
    let mut errors = v.errors;
    if errors.is_empty() {
        model.ok_or_else(|| {
            vec![Diagnostic::new(
                Kind::Unsupported,
                file,
                "internal error: model incomplete although no problem was found",
            )]
        })
    } else {
        errors.sort_by_key(|e| e.line);
        Err(errors)
    }
}

/// Where a problem is: line, entity label, field (may be empty).
struct At<'a> {
    line: usize,
    label: &'a str,
    field: String,
}

/// An entity of the file: its node and its label for messages.
struct Ent<'n> {
    node: &'n Node,
    label: String,
}

impl Ent<'_> {
    /// The line of the entity: its `name` key, else its start.
    fn line(&self) -> usize {
        self.node.entry("name").map_or(self.node.line, |e| e.line)
    }

    /// The location of a field; the entity's line when the field is absent.
    fn at(&self, path: &[Seg<'_>]) -> At<'_> {
        let present = match path.first() {
            Some(Seg::Key(k)) => self.node.entry(k).is_some(),
            _ => true,
        };
        At {
            line: if present {
                self.node.line_at(path)
            } else {
                self.line()
            },
            label: &self.label,
            field: path_string(path),
        }
    }
}

fn path_string(path: &[Seg<'_>]) -> String {
    let mut s = String::new();
    for seg in path {
        match seg {
            Seg::Key(k) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(k);
            }
            Seg::Idx(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

fn with<'a>(path: &[Seg<'a>], seg: Seg<'a>) -> Vec<Seg<'a>> {
    let mut p = path.to_vec();
    p.push(seg);
    p
}

/// Short number formatting for messages (6 significant digits).
pub(crate) fn fmt_num(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let a = x.abs();
    if (1e-4..1e6).contains(&a) {
        let decimals = (5 - a.log10().floor() as i32).clamp(0, 10) as usize;
        let s = format!("{x:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{x:.5e}")
    }
}

fn parse_axis(s: &str) -> Option<Axis> {
    match s {
        "x" | "X" => Some(Axis::X),
        "y" | "Y" => Some(Axis::Y),
        "z" | "Z" => Some(Axis::Z),
        _ => None,
    }
}

/// ROBOTRAN joint codes R1..R3 (revolute about x, y, z) and T1..T3 (prismatic).
fn parse_joint_code(s: &str) -> Option<(JointKind, Axis)> {
    let mut chars = s.chars();
    let kind = match chars.next()? {
        'R' | 'r' => JointKind::Revolute,
        'T' | 't' => JointKind::Prismatic,
        _ => return None,
    };
    let axis = match chars.as_str() {
        "1" => Axis::X,
        "2" => Axis::Y,
        "3" => Axis::Z,
        _ => return None,
    };
    Some((kind, axis))
}

fn is_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    chars.next().is_some_and(|c| c.is_alphabetic() || c == '_')
        && chars.all(|c| c.is_alphanumeric() || c == '_')
}

/// A parent as resolved by name.
#[derive(Clone, Copy, Debug, PartialEq)]
enum ParentRef {
    Ground,
    /// File index of the parent body.
    Body(usize),
    /// Unknown parent (reported) or unreadable body.
    Unresolved,
}

/// A body as resolved by name from a point, force or constraint.
#[derive(Clone, Copy, Debug, PartialEq)]
enum BodyRef {
    Ground,
    /// Index in the validated (topological) order.
    Body(usize),
    /// A body whose own problems were already reported: no follow-up checks.
    Unusable,
}

/// A body in file order, while being validated.
struct FileBody<'n> {
    ent: Ent<'n>,
    name: Option<String>,
    raw: Option<RawBody>,
    coordinate: String,
    parent: ParentRef,
    joint: Option<Joint>,
    mass: Option<Scalar>,
    com: Option<[Scalar; 3]>,
    inertia: Option<[[Scalar; 3]; 3]>,
}

/// A point in file order.
struct FilePoint {
    body: BodyRef,
    point: Option<Point>,
}

struct Validator<'f, 'n> {
    file: &'f str,
    errors: Vec<Diagnostic>,
    params: Vec<Parameter>,
    /// False for parameters whose value could not be computed (already reported).
    param_ok: Vec<bool>,
    /// For a derived parameter (value written as an expression), that expression in terms of
    /// literal parameters; references to it are replaced by the expression, so a derived
    /// parameter always follows the run-time values of the parameters it uses.
    derived: Vec<Option<Scalar>>,
    /// Parameter name to index (first declaration).
    param_index: BTreeMap<String, usize>,
    bodies: Vec<FileBody<'n>>,
    /// Body name to file index (first declaration).
    body_index: BTreeMap<String, usize>,
    /// File index to validated index, for bodies reachable from ground.
    placed: Vec<Option<usize>>,
    /// Validated order: file indices, parent before child.
    order: Vec<usize>,
    points: Vec<FilePoint>,
    /// Point name to index (first declaration).
    point_index: BTreeMap<String, usize>,
    /// Line of each point, in file order.
    point_lines: Vec<usize>,
}

impl<'n> Validator<'_, 'n> {
    fn error(
        &mut self,
        kind: Kind,
        line: Option<usize>,
        entity: Option<&str>,
        message: impl Into<String>,
    ) {
        let mut d = Diagnostic::new(kind, self.file, message).at_line(line);
        d.entity = entity.map(str::to_string);
        self.errors.push(d);
    }

    fn error_at(&mut self, kind: Kind, at: &At<'_>, message: impl AsRef<str>) {
        let message = if at.field.is_empty() {
            message.as_ref().to_string()
        } else {
            format!("{}: {}", at.field, message.as_ref())
        };
        let (line, label) = (at.line, at.label.to_string());
        self.error(kind, Some(line), Some(&label), message);
    }

    /// Deserializes an entity node, reporting a failure at the line the error concerns.
    fn read<T: serde::de::DeserializeOwned>(&mut self, node: &Node, label: &str) -> Option<T> {
        match node.deserialize::<T>() {
            Ok(v) => Some(v),
            Err(e) => {
                let line = e.line.unwrap_or(node.line);
                self.error(e.kind, Some(line), Some(label), e.describe());
                None
            }
        }
    }

    /// Value at the default parameters, `None` when it uses a broken parameter.
    fn value(&self, s: &Scalar) -> Option<f64> {
        let mut used = Vec::new();
        params_used(s, &mut used);
        if used
            .iter()
            .all(|&i| self.param_ok.get(i).copied().unwrap_or(false))
        {
            let values: Vec<f64> = self.params.iter().map(|p| p.value).collect();
            Some(s.eval(&values))
        } else {
            None
        }
    }

    /// Parses a numeric field and checks that it is finite at the default parameters.
    fn scalar(&mut self, at: &At<'_>, raw: &RawScalar) -> Option<Scalar> {
        let scalar = match raw {
            RawScalar::Num(v) => {
                if !v.is_finite() {
                    self.error_at(
                        Kind::InvalidValue,
                        at,
                        format!("{v} is not a finite number"),
                    );
                    return None;
                }
                Scalar::Num(*v)
            }
            RawScalar::Expr(src) => {
                let index = &self.param_index;
                let lookup = |name: &str| {
                    index
                        .get(name)
                        .copied()
                        .ok_or_else(|| NameError::Unknown(name.to_string()))
                };
                match parse_expr(src, &lookup) {
                    Ok(s) => self.inline_derived(s),
                    Err(e) => {
                        self.error_at(
                            Kind::Syntax,
                            at,
                            format!("{} (in \"{src}\" at column {})", e.message, e.column),
                        );
                        return None;
                    }
                }
            }
        };
        match self.value(&scalar) {
            Some(v) if !v.is_finite() => {
                let shown = match raw {
                    RawScalar::Expr(src) => format!("\"{src}\""),
                    RawScalar::Num(x) => x.to_string(),
                };
                self.error_at(
                    Kind::InvalidValue,
                    at,
                    format!("{shown} evaluates to {v} at the default parameter values"),
                );
                None
            }
            _ => Some(scalar),
        }
    }

    /// An optional numeric field, zero when absent.
    fn scalar_or_zero(
        &mut self,
        ent: &Ent<'_>,
        key: &str,
        raw: &Option<RawScalar>,
    ) -> Option<Scalar> {
        match raw {
            Some(raw) => self.scalar(&ent.at(&[Seg::Key(key)]), raw),
            None => Some(Scalar::ZERO),
        }
    }

    /// Three numeric fields at `path` (zero when absent).
    fn vec3(
        &mut self,
        ent: &Ent<'_>,
        path: &[Seg<'_>],
        raw: &Option<RawVec3>,
    ) -> Option<[Scalar; 3]> {
        let Some(raw) = raw else {
            return Some([Scalar::ZERO, Scalar::ZERO, Scalar::ZERO]);
        };
        let [x, y, z] = [0, 1, 2].map(|i| self.scalar(&ent.at(&with(path, Seg::Idx(i))), &raw[i]));
        Some([x?, y?, z?])
    }

    fn run(&mut self, root: &'n Node, source: SourceInfo) -> Option<Model> {
        let Some(entries) = root.entries() else {
            self.error(
                Kind::Syntax,
                Some(root.line),
                None,
                format!("the top level must be a table, not {}", root.kind()),
            );
            return None;
        };

        // The model name first: it labels the model-level messages.
        let name_entry = root.entry("name");
        let written = match name_entry.map(|e| &e.node.value) {
            Some(Value::Str(s)) if !s.is_empty() => Some(s.clone()),
            _ => None,
        };
        let name = written.clone().unwrap_or_else(|| {
            Path::new(&source.path)
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| source.path.clone())
        });
        let model_label = format!("model \"{name}\"");
        if let Some(e) = name_entry {
            if written.is_none() {
                self.error(
                    Kind::Syntax,
                    Some(e.line),
                    Some(&model_label),
                    "`name` must be a non-empty string",
                );
            }
        }

        // Top-level keys.
        let mut section: BTreeMap<&str, &'n Node> = BTreeMap::new();
        let mut section_line: BTreeMap<&str, usize> = BTreeMap::new();
        for entry in entries {
            match TOP_LEVEL_KEYS.iter().find(|k| **k == entry.key) {
                Some(k) if section.contains_key(k) => self.error(
                    Kind::Duplicate,
                    Some(entry.line),
                    Some(&model_label),
                    format!("duplicate key `{k}`"),
                ),
                Some(k) => {
                    section.insert(k, &entry.node);
                    section_line.insert(k, entry.line);
                }
                None => self.error(
                    Kind::UnknownField,
                    Some(entry.line),
                    Some(&model_label),
                    format!(
                        "unknown key `{}` (expected one of: {})",
                        entry.key,
                        TOP_LEVEL_KEYS.join(", ")
                    ),
                ),
            }
        }
        if let Some(node) = section.get("description") {
            if !matches!(node.value, Value::Str(_)) {
                let line = section_line.get("description").copied();
                self.error(
                    Kind::Syntax,
                    line,
                    Some(&model_label),
                    "`description` must be a string",
                );
            }
        }

        if let Some(node) = section.get("parameters") {
            self.parameters(node, &model_label);
        }

        let gravity = match section.get("gravity") {
            Some(node) => {
                let raw = match node.deserialize::<RawVec3>() {
                    Ok(raw) => Some(raw),
                    Err(e) => {
                        let line = e.line.or(section_line.get("gravity").copied());
                        let message = format!("gravity{}: {}", e.path(), e.message);
                        self.error(e.kind, line, Some(&model_label), message);
                        None
                    }
                };
                let ent = Ent {
                    node: root,
                    label: model_label.clone(),
                };
                raw.and_then(|raw| self.vec3(&ent, &[Seg::Key("gravity")], &Some(raw)))
            }
            None => Some([Scalar::ZERO, Scalar::ZERO, Scalar::ZERO]),
        };

        let body_nodes = self.items(section.get("bodies").copied(), "bodies", &model_label);
        let bodies_absent = !section.contains_key("bodies");
        if bodies_absent || body_nodes.as_ref().is_some_and(Vec::is_empty) {
            let line = section_line.get("bodies").copied().unwrap_or(1);
            self.error(
                Kind::Unsupported,
                Some(line),
                Some(&model_label),
                "the model has no bodies (add at least one [[bodies]] entry)",
            );
        }
        self.bodies_section(body_nodes.unwrap_or_default());

        let point_nodes = self.items(section.get("points").copied(), "points", &model_label);
        self.points_section(point_nodes.unwrap_or_default());

        let force_nodes = self.items(section.get("forces").copied(), "forces", &model_label);
        let forces = self.forces_section(force_nodes.unwrap_or_default());

        let constraint_nodes = self.items(
            section.get("constraints").copied(),
            "constraints",
            &model_label,
        );
        let constraints = self.constraints_section(constraint_nodes.unwrap_or_default());

        // Assemble (only reached with everything valid when no error was reported).
        let mut bodies = Vec::with_capacity(self.order.len());
        for &i in &self.order {
            let b = &self.bodies[i];
            let parent = match b.parent {
                ParentRef::Ground => None,
                ParentRef::Body(p) => Some(self.placed.get(p).copied().flatten()?),
                ParentRef::Unresolved => return None,
            };
            bodies.push(Body {
                name: b.name.clone()?,
                coordinate: b.coordinate.clone(),
                parent,
                joint: b.joint.clone()?,
                mass: b.mass.clone()?,
                com: b.com.clone()?,
                inertia: b.inertia.clone()?,
            });
        }
        if bodies.len() != self.bodies.len() {
            return None;
        }
        let points = self
            .points
            .iter()
            .map(|p| p.point.clone())
            .collect::<Option<Vec<_>>>()?;
        Some(Model {
            name,
            source,
            parameters: self.params.clone(),
            gravity: gravity?,
            bodies,
            points,
            forces: forces.into_iter().collect::<Option<Vec<_>>>()?,
            constraints: constraints.into_iter().collect::<Option<Vec<_>>>()?,
        })
    }

    /// The tables of an array section (`None` when absent or not an array).
    fn items(&mut self, node: Option<&'n Node>, key: &str, label: &str) -> Option<Vec<&'n Node>> {
        let node = node?;
        let Value::Array(items) = &node.value else {
            self.error(
                Kind::Syntax,
                Some(node.line),
                Some(label),
                format!(
                    "`{key}` must be an array of tables (write each entry under [[{key}]]), not {}",
                    node.kind()
                ),
            );
            return None;
        };
        let mut tables = Vec::new();
        for (i, item) in items.iter().enumerate() {
            if item.entries().is_some() {
                tables.push(item);
            } else {
                self.error(
                    Kind::Syntax,
                    Some(item.line),
                    Some(label),
                    format!("`{key}[{i}]` must be a table, not {}", item.kind()),
                );
            }
        }
        Some(tables)
    }

    /// `[parameters]`: in written order, each value may use earlier parameters only.
    fn parameters(&mut self, node: &Node, model_label: &str) {
        let Some(entries) = node.entries() else {
            self.error(
                Kind::Syntax,
                Some(node.line),
                Some(model_label),
                format!(
                    "`parameters` must be a table of `name = value` entries, not {}",
                    node.kind()
                ),
            );
            return;
        };
        let all_names: BTreeSet<&str> = entries.iter().map(|e| e.key.as_str()).collect();
        for entry in entries {
            let name = entry.key.clone();
            let label = format!("parameter \"{name}\"");
            let mut ok = true;
            if !is_identifier(&name) {
                self.error(Kind::InvalidValue,
                    Some(entry.line),
                    Some(&label),
                    "not a valid parameter name (letters, digits and `_`, not starting with a digit)",
                );
                ok = false;
            } else if RESERVED.contains(&name.as_str()) {
                self.error(
                    Kind::InvalidValue,
                    Some(entry.line),
                    Some(&label),
                    format!("`{name}` is reserved in expressions and cannot be a parameter name"),
                );
                ok = false;
            }
            if self.param_index.contains_key(&name) {
                let first_line = entries
                    .iter()
                    .filter(|e| e.key == name)
                    .map(|e| e.line)
                    .next()
                    .unwrap_or(entry.line);
                self.error(
                    Kind::Duplicate,
                    Some(entry.line),
                    Some(&label),
                    format!("duplicate parameter name (first declared on line {first_line})"),
                );
                ok = false;
            }
            let raw: Option<RawParam> = self.read(&entry.node, &label);
            let mut value = f64::NAN;
            let mut runtime = false;
            let mut derived = None;
            if let Some(raw) = raw {
                runtime = raw.runtime;
                let line = if raw.table {
                    entry.node.line_at(&[Seg::Key("value")])
                } else {
                    entry.line
                };
                if raw.runtime && matches!(raw.value, RawScalar::Expr(_)) {
                    self.error(
                        Kind::InvalidValue,
                        Some(line),
                        Some(&label),
                        "a run-time parameter must be a number: a parameter written as an \
                         expression is derived and follows the parameters it uses"
                            .to_string(),
                    );
                    ok = false;
                }
                match self.param_value(&name, &raw.value, &all_names) {
                    Ok((Some(v), expr)) if v.is_finite() => {
                        value = v;
                        derived = expr;
                    }
                    Ok((Some(v), _)) => {
                        self.error(
                            Kind::InvalidValue,
                            Some(line),
                            Some(&label),
                            format!("value {v} is not finite"),
                        );
                        ok = false;
                    }
                    // Uses a broken parameter: already reported.
                    Ok((None, _)) => ok = false,
                    Err(e) => {
                        let message = match &raw.value {
                            RawScalar::Expr(src) => {
                                format!("{} (in \"{src}\" at column {})", e.message, e.column)
                            }
                            RawScalar::Num(_) => e.to_string(),
                        };
                        self.error(Kind::InvalidValue, Some(line), Some(&label), message);
                        ok = false;
                    }
                }
            } else {
                ok = false;
            }
            let index = self.params.len();
            self.param_index.entry(name.clone()).or_insert(index);
            self.params.push(Parameter {
                name,
                value,
                runtime,
                derived: derived.is_some(),
            });
            self.param_ok.push(ok);
            self.derived.push(derived);
        }
    }

    /// Replaces references to derived parameters by their expressions.
    fn inline_derived(&self, s: Scalar) -> Scalar {
        match s {
            Scalar::Param(k) => match self.derived.get(k) {
                Some(Some(e)) => e.clone(),
                _ => Scalar::Param(k),
            },
            Scalar::Num(_) => s,
            Scalar::Neg(a) => Scalar::Neg(Box::new(self.inline_derived(*a))),
            Scalar::Bin(op, a, b) => Scalar::Bin(
                op,
                Box::new(self.inline_derived(*a)),
                Box::new(self.inline_derived(*b)),
            ),
            Scalar::Call(f, a) => Scalar::Call(f, Box::new(self.inline_derived(*a))),
        }
    }

    /// The default value of a parameter from earlier parameters.
    fn param_value(
        &self,
        name: &str,
        raw: &RawScalar,
        all_names: &BTreeSet<&str>,
    ) -> Result<(Option<f64>, Option<Scalar>), ExprError> {
        match raw {
            RawScalar::Num(v) => Ok((Some(*v), None)),
            RawScalar::Expr(src) => {
                let index = &self.param_index;
                let lookup = |n: &str| match index.get(n) {
                    Some(&i) => Ok(i),
                    None if n == name => Err(NameError::SelfReference(n.to_string())),
                    None if all_names.contains(n) => Err(NameError::Later(n.to_string())),
                    None => Err(NameError::Unknown(n.to_string())),
                };
                let scalar = parse_expr(src, &lookup)?;
                let scalar = self.inline_derived(scalar);
                Ok((self.value(&scalar), Some(scalar)))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn number_formatting() {
        assert_eq!(fmt_num(0.0), "0");
        assert_eq!(fmt_num(-0.1), "-0.1");
        assert_eq!(fmt_num(2.0), "2");
        assert_eq!(fmt_num(1.0 / 3.0), "0.333333");
        assert_eq!(fmt_num(123456.0), "123456");
        assert_eq!(fmt_num(2e-5), "2.00000e-5");
    }

    #[test]
    fn joint_codes_and_identifiers() {
        assert_eq!(parse_joint_code("R3"), Some((JointKind::Revolute, Axis::Z)));
        assert_eq!(
            parse_joint_code("t1"),
            Some((JointKind::Prismatic, Axis::X))
        );
        assert_eq!(parse_joint_code("R4"), None);
        assert_eq!(parse_joint_code(""), None);
        assert!(is_identifier("m_1"));
        assert!(!is_identifier("1m"));
        assert!(!is_identifier("a.b"));
        assert!(!is_identifier(""));
    }
}
