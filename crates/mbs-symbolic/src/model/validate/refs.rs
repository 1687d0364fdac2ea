//! Points, forces and constraints: name resolution against the validated bodies and
//! points, and the checks of each kind (e.g. no constraint on a body's own point, angle
//! constraints only across revolutes about their axis).

use std::collections::{BTreeMap, BTreeSet};

use diagnostic::Kind;

use super::super::node::{Node, Seg};
use super::super::raw::{
    RawAngle, RawExternal, RawFixed, RawJointForce, RawLoop, RawPoint, RawPointRef, RawSpring,
};
use super::super::types::{Axis, Constraint, ForceElement, JointKind, Point, Scalar};
use super::{BodyRef, Ent, FilePoint, ParentRef, Validator, parse_axis};

impl<'n> Validator<'_, 'n> {
    pub(super) fn points_section(&mut self, nodes: Vec<&'n Node>) {
        for (i, node) in nodes.into_iter().enumerate() {
            let name = node.str_field("name").map(str::to_string);
            let ent = Ent {
                node,
                label: match &name {
                    Some(n) => format!("point \"{n}\""),
                    None => format!("point #{}", i + 1),
                },
            };
            if let Some(n) = &name {
                let line = ent.line();
                if n.is_empty() {
                    self.error(
                        Kind::InvalidValue,
                        Some(line),
                        Some(&ent.label),
                        "empty point name",
                    );
                } else if let Some(&first) = self.point_index.get(n) {
                    let first_line = self.point_lines.get(first).copied().unwrap_or(line);
                    self.error(
                        Kind::Duplicate,
                        Some(line),
                        Some(&ent.label),
                        format!("duplicate point name (first declared on line {first_line})"),
                    );
                } else {
                    self.point_index.insert(n.clone(), i);
                }
            }
            self.point_lines.push(ent.line());
            let raw: Option<RawPoint> = self.read(node, &ent.label);
            let mut body = BodyRef::Unusable;
            let mut point = None;
            if let Some(raw) = raw {
                let resolved = self.body_ref(&ent, &[Seg::Key("body")], &raw.body);
                let position = self.vec3(&ent, &[Seg::Key("position")], &raw.position);
                if let Some(b) = resolved {
                    body = b;
                    if let (Some(position), BodyRef::Ground | BodyRef::Body(_)) = (position, b) {
                        point = Some(Point {
                            name: raw.name,
                            body: match b {
                                BodyRef::Body(k) => Some(k),
                                _ => None,
                            },
                            position,
                        });
                    }
                }
            }
            self.points.push(FilePoint { body, point });
        }
    }

    /// Resolves a body name; reports unknown names (`None`).
    fn body_ref(&mut self, ent: &Ent<'_>, path: &[Seg<'_>], name: &str) -> Option<BodyRef> {
        if name == "ground" {
            return Some(BodyRef::Ground);
        }
        match self.body_index.get(name) {
            Some(&i) => {
                let usable = self.bodies[i].raw.is_some();
                Some(match self.placed.get(i).copied().flatten() {
                    Some(k) if usable => BodyRef::Body(k),
                    _ => BodyRef::Unusable,
                })
            }
            None => {
                self.error_at(
                    Kind::UnknownName,
                    &ent.at(path),
                    format!("unknown body `{name}` (not a body name, nor \"ground\")"),
                );
                None
            }
        }
    }

    /// Resolves a point name to its index and body; reports unknown names (`None`).
    fn point_ref(&mut self, ent: &Ent<'_>, key: &str, name: &str) -> Option<(usize, BodyRef)> {
        match self.point_index.get(name) {
            Some(&i) => Some((i, self.points[i].body)),
            None => {
                self.error_at(
                    Kind::UnknownName,
                    &ent.at(&[Seg::Key(key)]),
                    format!("unknown point `{name}`"),
                );
                None
            }
        }
    }

    fn body_name(&self, b: BodyRef) -> String {
        match b {
            BodyRef::Ground => "ground".into(),
            BodyRef::Body(k) => self
                .order
                .get(k)
                .and_then(|&i| self.bodies[i].name.clone())
                .unwrap_or_default(),
            BodyRef::Unusable => String::new(),
        }
    }

    /// Common part of forces and constraints: the `type` tag, the label, the name.
    fn tagged<'a>(
        &mut self,
        node: &'a Node,
        i: usize,
        what: &str,
        types: &[&str],
        names: &mut BTreeMap<String, usize>,
    ) -> (Ent<'a>, Option<String>, String) {
        let kind = node.str_field("type").map(str::to_string);
        let name = match (node.str_field("name"), &kind) {
            (Some(n), _) => Some(n.to_string()),
            (None, Some(k)) if types.contains(&k.as_str()) => Some(format!("{k}_{}", i + 1)),
            _ => None,
        };
        let ent = Ent {
            node,
            label: match &name {
                Some(n) => format!("{what} \"{n}\""),
                None => format!("{what} #{}", i + 1),
            },
        };
        if let Some(n) = &name {
            let line = ent.line();
            if n.is_empty() {
                self.error(
                    Kind::InvalidValue,
                    Some(line),
                    Some(&ent.label),
                    format!("empty {what} name"),
                );
            } else if let Some(first) = names.get(n) {
                self.error(
                    Kind::Duplicate,
                    Some(line),
                    Some(&ent.label),
                    format!("duplicate {what} name (first declared on line {first})"),
                );
            } else {
                names.insert(n.clone(), line);
            }
        }
        let expected = types.join(", ");
        let kind = match (node.entry("type"), kind) {
            (None, _) => {
                self.error(
                    Kind::MissingField,
                    Some(ent.line()),
                    Some(&ent.label),
                    format!("missing `type` (one of: {expected})"),
                );
                String::new()
            }
            (Some(e), None) => {
                self.error(
                    Kind::Syntax,
                    Some(e.line),
                    Some(&ent.label),
                    format!("`type` must be a string (one of: {expected})"),
                );
                String::new()
            }
            (Some(e), Some(k)) if !types.contains(&k.as_str()) => {
                self.error(
                    Kind::InvalidValue,
                    Some(e.line),
                    Some(&ent.label),
                    format!("unknown {what} type `{k}` (expected one of: {expected})"),
                );
                String::new()
            }
            (Some(_), Some(k)) => k,
        };
        (ent, name, kind)
    }

    pub(super) fn forces_section(&mut self, nodes: Vec<&'n Node>) -> Vec<Option<ForceElement>> {
        let mut names = BTreeMap::new();
        let mut out = Vec::new();
        for (i, node) in nodes.into_iter().enumerate() {
            let (ent, name, kind) = self.tagged(
                node,
                i,
                "force",
                &["joint", "spring", "external"],
                &mut names,
            );
            let name = name.unwrap_or_default();
            let body_node = node.without_key("type");
            let force = match kind.as_str() {
                "joint" => self
                    .read::<RawJointForce>(&body_node, &ent.label)
                    .and_then(|raw| self.joint_force(&ent, name, raw)),
                "spring" => self
                    .read::<RawSpring>(&body_node, &ent.label)
                    .and_then(|raw| self.spring(&ent, name, raw)),
                "external" => self
                    .read::<RawExternal>(&body_node, &ent.label)
                    .and_then(|raw| self.external(&ent, name, raw)),
                _ => None,
            };
            out.push(force);
        }
        out
    }

    fn moving_body(&mut self, ent: &Ent<'_>, key: &str, name: &str, what: &str) -> Option<usize> {
        match self.body_ref(ent, &[Seg::Key(key)], name)? {
            BodyRef::Body(k) => Some(k),
            BodyRef::Ground => {
                self.error_at(
                    Kind::InvalidValue,
                    &ent.at(&[Seg::Key(key)]),
                    format!("{what} needs a moving body, not ground"),
                );
                None
            }
            BodyRef::Unusable => None,
        }
    }

    fn joint_force(
        &mut self,
        ent: &Ent<'_>,
        name: String,
        raw: RawJointForce,
    ) -> Option<ForceElement> {
        let body = self.moving_body(ent, "body", &raw.body, "a joint force");
        let stiffness = self.scalar_or_zero(ent, "stiffness", &raw.stiffness);
        let damping = self.scalar_or_zero(ent, "damping", &raw.damping);
        let rest = self.scalar_or_zero(ent, "rest", &raw.rest);
        let constant = self.scalar_or_zero(ent, "constant", &raw.constant);
        Some(ForceElement::Joint {
            name,
            body: body?,
            stiffness: stiffness?,
            damping: damping?,
            rest: rest?,
            constant: constant?,
        })
    }

    fn spring(&mut self, ent: &Ent<'_>, name: String, raw: RawSpring) -> Option<ForceElement> {
        let a = self.point_ref(ent, "a", &raw.a);
        let b = self.point_ref(ent, "b", &raw.b);
        let mut ok = true;
        if raw.a == raw.b && a.is_some() {
            self.error_at(
                Kind::InvalidValue,
                &ent.at(&[Seg::Key("b")]),
                format!("the spring connects point `{}` to itself", raw.a),
            );
            ok = false;
        }
        let stiffness = self.scalar_or_zero(ent, "stiffness", &raw.stiffness);
        let damping = self.scalar_or_zero(ent, "damping", &raw.damping);
        let rest_length = self.scalar_or_zero(ent, "rest_length", &raw.rest_length);
        if !ok {
            return None;
        }
        Some(ForceElement::PointSpring {
            name,
            a: a?.0,
            b: b?.0,
            stiffness: stiffness?,
            damping: damping?,
            rest_length: rest_length?,
        })
    }

    fn external(&mut self, ent: &Ent<'_>, name: String, raw: RawExternal) -> Option<ForceElement> {
        let body = raw
            .body
            .as_ref()
            .map(|b| self.moving_body(ent, "body", b, "an external force"));
        let point_at = ent.at(&[Seg::Key("point")]);
        let (point_body, point) = match &raw.point {
            None => (None, Some([Scalar::ZERO, Scalar::ZERO, Scalar::ZERO])),
            Some(RawPointRef::Coords(c)) => {
                (None, self.vec3(ent, &[Seg::Key("point")], &Some(c.clone())))
            }
            Some(RawPointRef::Name(p)) => match self.point_ref(ent, "point", p) {
                None => (Some(None), None),
                Some((i, BodyRef::Body(k))) => (
                    Some(Some(k)),
                    self.points[i].point.as_ref().map(|pt| pt.position.clone()),
                ),
                Some((_, BodyRef::Ground)) => {
                    self.error_at(
                        Kind::InvalidValue,
                        &point_at,
                        format!("point `{p}` is on ground: an external force needs a moving body"),
                    );
                    (Some(None), None)
                }
                Some((_, BodyRef::Unusable)) => (Some(None), None),
            },
        };
        let body = match (body, point_body) {
            (Some(Some(b)), Some(Some(pb))) if b != pb => {
                let (bn, pn) = (
                    self.body_name(BodyRef::Body(b)),
                    self.body_name(BodyRef::Body(pb)),
                );
                self.error_at(
                    Kind::InvalidValue,
                    &point_at,
                    format!("point is on body `{pn}`, not on the force's body `{bn}`"),
                );
                None
            }
            (Some(b), _) => b,
            (None, Some(pb)) => pb,
            (None, None) => {
                self.error(
                    Kind::MissingField,
                    Some(ent.line()),
                    Some(&ent.label),
                    "missing `body` (or a `point` given by name)",
                );
                None
            }
        };
        let in_body_frame = match raw.frame.as_deref() {
            None | Some("ground") => Some(false),
            Some("body") => Some(true),
            Some(other) => {
                self.error_at(
                    Kind::InvalidValue,
                    &ent.at(&[Seg::Key("frame")]),
                    format!("unknown frame `{other}` (expected \"ground\" or \"body\")"),
                );
                None
            }
        };
        let force = self.vec3(ent, &[Seg::Key("force")], &raw.force);
        let torque = self.vec3(ent, &[Seg::Key("torque")], &raw.torque);
        Some(ForceElement::External {
            name,
            body: body?,
            point: point?,
            force: force?,
            torque: torque?,
            in_body_frame: in_body_frame?,
        })
    }

    fn components(&mut self, ent: &Ent<'_>, raw: &Option<Vec<String>>) -> Option<Vec<Axis>> {
        let Some(list) = raw else {
            return Some(vec![Axis::X, Axis::Y, Axis::Z]);
        };
        let at = ent.at(&[Seg::Key("components")]);
        if list.is_empty() {
            self.error_at(
                Kind::InvalidValue,
                &at,
                "empty list (omit `components` to constrain x, y and z)",
            );
            return None;
        }
        let mut out = Vec::new();
        let mut ok = true;
        for c in list {
            match parse_axis(c) {
                Some(a) if out.contains(&a) => {
                    self.error_at(
                        Kind::Duplicate,
                        &at,
                        format!("component `{c}` listed twice"),
                    );
                    ok = false;
                }
                Some(a) => out.push(a),
                None => {
                    self.error_at(
                        Kind::InvalidValue,
                        &at,
                        format!("unknown component `{c}` (expected x, y or z)"),
                    );
                    ok = false;
                }
            }
        }
        ok.then_some(out)
    }

    pub(super) fn constraints_section(&mut self, nodes: Vec<&'n Node>) -> Vec<Option<Constraint>> {
        let mut names = BTreeMap::new();
        let mut out = Vec::new();
        for (i, node) in nodes.into_iter().enumerate() {
            let (ent, name, kind) = self.tagged(
                node,
                i,
                "constraint",
                &["loop", "fixed", "angle"],
                &mut names,
            );
            let name = name.unwrap_or_default();
            let body_node = node.without_key("type");
            let constraint = match kind.as_str() {
                "loop" => self
                    .read::<RawLoop>(&body_node, &ent.label)
                    .and_then(|raw| self.loop_constraint(&ent, name, raw)),
                "fixed" => self
                    .read::<RawFixed>(&body_node, &ent.label)
                    .and_then(|raw| self.fixed_constraint(&ent, name, raw)),
                "angle" => self
                    .read::<RawAngle>(&body_node, &ent.label)
                    .and_then(|raw| self.angle_constraint(&ent, name, raw)),
                _ => None,
            };
            out.push(constraint);
        }
        out
    }

    fn loop_constraint(&mut self, ent: &Ent<'_>, name: String, raw: RawLoop) -> Option<Constraint> {
        let a = self.point_ref(ent, "a", &raw.a);
        let b = self.point_ref(ent, "b", &raw.b);
        let components = self.components(ent, &raw.components);
        let (a, b) = (a?, b?);
        match (a.1, b.1) {
            (BodyRef::Unusable, _) | (_, BodyRef::Unusable) => return None,
            (ba, bb) if ba == bb => {
                let on = match ba {
                    BodyRef::Ground => "both on ground".to_string(),
                    _ => format!("both on body `{}`", self.body_name(ba)),
                };
                self.error(Kind::InvalidValue,
                    Some(ent.line()),
                    Some(&ent.label),
                    format!(
                        "points `{}` and `{}` are {on}: a constraint on a body's own point is either always satisfied or never",
                        raw.a, raw.b
                    ),
                );
                return None;
            }
            _ => {}
        }
        Some(Constraint::Loop {
            name,
            a: a.0,
            b: b.0,
            components: components?,
        })
    }

    fn fixed_constraint(
        &mut self,
        ent: &Ent<'_>,
        name: String,
        raw: RawFixed,
    ) -> Option<Constraint> {
        let point = self.point_ref(ent, "point", &raw.point);
        let position = self.vec3(ent, &[Seg::Key("position")], &Some(raw.position));
        let components = self.components(ent, &raw.components);
        let (point, body) = point?;
        match body {
            BodyRef::Unusable => return None,
            BodyRef::Ground => {
                self.error_at(Kind::InvalidValue,
                    &ent.at(&[Seg::Key("point")]),
                    format!(
                        "point `{}` is on ground: a constraint on ground's own point is either always satisfied or never",
                        raw.point
                    ),
                );
                return None;
            }
            BodyRef::Body(_) => {}
        }
        Some(Constraint::Fixed {
            name,
            point,
            position: position?,
            components: components?,
        })
    }

    fn angle_constraint(
        &mut self,
        ent: &Ent<'_>,
        name: String,
        raw: RawAngle,
    ) -> Option<Constraint> {
        let a = self.body_ref(ent, &[Seg::Key("a")], &raw.a);
        let b = self.body_ref(ent, &[Seg::Key("b")], &raw.b);
        let axis = parse_axis(&raw.axis);
        if axis.is_none() {
            self.error_at(
                Kind::InvalidValue,
                &ent.at(&[Seg::Key("axis")]),
                format!("unknown axis `{}` (expected x, y or z)", raw.axis),
            );
        }
        let offset = self.scalar_or_zero(ent, "offset", &raw.offset);
        let (a, b, axis) = (a?, b?, axis?);
        let index = |r: BodyRef| match r {
            BodyRef::Ground => Some(None),
            BodyRef::Body(k) => Some(Some(k)),
            BodyRef::Unusable => None,
        };
        let (ia, ib) = (index(a)?, index(b)?);
        if ia == ib {
            self.error(Kind::InvalidValue,
                Some(ent.line()),
                Some(&ent.label),
                format!(
                    "`a` and `b` are both `{}`: a constraint on a body's own angle is either always satisfied or never",
                    raw.a
                ),
            );
            return None;
        }
        // The joints on the path between a and b must all be revolutes about `axis`.
        let bad = self.angle_path_problems(ia, ib, axis)?;
        if !bad.is_empty() {
            self.error(Kind::Unsupported,
                Some(ent.line()),
                Some(&ent.label),
                format!(
                    "the path between `{}` and `{}` contains {}; an angle constraint about {axis} needs every joint on the path to be a revolute about {axis} without a constant rotation",
                    raw.a,
                    raw.b,
                    bad.join(", ")
                ),
            );
            return None;
        }
        Some(Constraint::Angle {
            name,
            a: ia,
            b: ib,
            axis,
            offset: offset?,
        })
    }

    /// Descriptions of the joints on the tree path between two bodies (validated indices,
    /// `None` = ground) that are not revolutes about `axis` (or carry a constant rotation).
    /// `None` when some joint on the path could not be read (already reported).
    fn angle_path_problems(
        &self,
        a: Option<usize>,
        b: Option<usize>,
        axis: Axis,
    ) -> Option<Vec<String>> {
        let chain = |start: Option<usize>| -> Option<Vec<usize>> {
            let mut out = Vec::new();
            let mut cur = start;
            while let Some(k) = cur {
                out.push(k);
                let body = &self.bodies[*self.order.get(k)?];
                cur = match body.parent {
                    ParentRef::Ground => None,
                    ParentRef::Body(p) => Some(self.placed.get(p).copied().flatten()?),
                    ParentRef::Unresolved => return None,
                };
                if out.len() > self.order.len() {
                    return None;
                }
            }
            Some(out)
        };
        let (ca, cb) = (chain(a)?, chain(b)?);
        let common: BTreeSet<usize> = ca.iter().filter(|k| cb.contains(k)).copied().collect();
        let mut problems = Vec::new();
        for &k in ca.iter().chain(&cb).filter(|k| !common.contains(k)) {
            let body = &self.bodies[*self.order.get(k)?];
            let joint = body.joint.as_ref()?;
            let name = body.name.clone().unwrap_or_default();
            if joint.kind != JointKind::Revolute {
                problems.push(format!("the prismatic joint of `{name}`"));
            } else if joint.axis != axis {
                problems.push(format!(
                    "the revolute joint of `{name}` about {}",
                    joint.axis
                ));
            } else if joint.rotation.iter().any(|(_, angle)| !angle.is_zero()) {
                problems.push(format!(
                    "the joint of `{name}`, which has a constant rotation"
                ));
            }
        }
        Some(problems)
    }
}
