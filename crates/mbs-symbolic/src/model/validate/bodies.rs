//! Bodies: names and coordinates, parents, the stable topological sort, cycles, joints and
//! mass properties (positive mass; inertia positive semi-definite and satisfying the
//! triangle inequality).

use std::collections::{BTreeMap, BTreeSet};

use nalgebra::{Matrix3, SymmetricEigen};

use diagnostic::Kind;

use super::super::node::{Node, Seg};
use super::super::raw::{RawBody, RawInertia, RawJoint, RawJointTable, RawRotation};
use super::super::types::{Joint, JointKind, Scalar};
use super::{
    Ent, FileBody, INERTIA_TOL, ParentRef, Validator, fmt_num, parse_axis, parse_joint_code, with,
};

impl<'n> Validator<'_, 'n> {
    pub(super) fn bodies_section(&mut self, nodes: Vec<&'n Node>) {
        // Read every body.
        for (i, node) in nodes.into_iter().enumerate() {
            let name = node.str_field("name").map(str::to_string);
            let label = match &name {
                Some(n) => format!("body \"{n}\""),
                None => format!("body #{}", i + 1),
            };
            let raw: Option<RawBody> = self.read(node, &label);
            let coordinate = raw
                .as_ref()
                .map(|r| r.coordinate.clone().unwrap_or_else(|| r.name.clone()))
                .unwrap_or_default();
            self.bodies.push(FileBody {
                ent: Ent { node, label },
                name,
                raw,
                coordinate,
                parent: ParentRef::Unresolved,
                joint: None,
                mass: None,
                com: None,
                inertia: None,
            });
        }

        // Names and coordinates.
        let mut coordinates: BTreeMap<String, usize> = BTreeMap::new();
        for i in 0..self.bodies.len() {
            let b = &self.bodies[i];
            let (line, label) = (b.ent.line(), b.ent.label.clone());
            if let Some(name) = b.name.clone() {
                if name.is_empty() {
                    self.error(
                        Kind::InvalidValue,
                        Some(line),
                        Some(&label),
                        "empty body name",
                    );
                } else if name == "ground" {
                    self.error(
                        Kind::InvalidValue,
                        Some(line),
                        Some(&label),
                        "`ground` is reserved for the fixed frame and cannot name a body",
                    );
                } else if let Some(&first) = self.body_index.get(&name) {
                    let first_line = self.bodies[first].ent.line();
                    self.error(
                        Kind::Duplicate,
                        Some(line),
                        Some(&label),
                        format!("duplicate body name (first declared on line {first_line})"),
                    );
                } else {
                    self.body_index.insert(name, i);
                }
            }
            let b = &self.bodies[i];
            if b.raw.is_some() {
                let coordinate = b.coordinate.clone();
                let coord_line = b.ent.at(&[Seg::Key("coordinate")]).line;
                if coordinate.is_empty() {
                    // An empty body name is reported above; its default coordinate is not.
                    if b.raw.as_ref().is_some_and(|r| r.coordinate.is_some()) {
                        self.error(
                            Kind::InvalidValue,
                            Some(coord_line),
                            Some(&label),
                            "empty coordinate name",
                        );
                    }
                } else if let Some(&first) = coordinates.get(&coordinate) {
                    let other = self.bodies[first].ent.label.clone();
                    let other_line = self.bodies[first].ent.line();
                    self.error(Kind::Duplicate,
                        Some(coord_line),
                        Some(&label),
                        format!(
                            "duplicate coordinate name `{coordinate}` (already used by {other} on line {other_line})"
                        ),
                    );
                } else {
                    coordinates.insert(coordinate, i);
                }
            }
        }

        // Parents.
        for i in 0..self.bodies.len() {
            let Some(raw) = &self.bodies[i].raw else {
                continue;
            };
            let parent_name = raw.parent.clone().unwrap_or_else(|| "ground".into());
            let parent = if parent_name == "ground" {
                ParentRef::Ground
            } else if let Some(&p) = self.body_index.get(&parent_name) {
                ParentRef::Body(p)
            } else {
                let at = self.bodies[i].ent.at(&[Seg::Key("parent")]);
                let (line, label) = (at.line, at.label.to_string());
                self.error(
                    Kind::UnknownName,
                    Some(line),
                    Some(&label),
                    format!("unknown parent `{parent_name}` (not a body name, nor \"ground\")"),
                );
                ParentRef::Unresolved
            };
            self.bodies[i].parent = parent;
        }
        self.sort_bodies();

        // Joints and mass properties.
        for i in 0..self.bodies.len() {
            let Some(raw) = self.bodies[i].raw.clone() else {
                continue;
            };
            let ent = Ent {
                node: self.bodies[i].ent.node,
                label: self.bodies[i].ent.label.clone(),
            };
            let joint = self.joint(&ent, &raw);
            let mass = self.scalar(&ent.at(&[Seg::Key("mass")]), &raw.mass);
            if let Some(m) = mass.as_ref().and_then(|m| self.value(m)) {
                if m <= 0.0 {
                    self.error_at(
                        Kind::InvalidValue,
                        &ent.at(&[Seg::Key("mass")]),
                        format!(
                            "mass must be positive, got {} at the default parameter values",
                            fmt_num(m)
                        ),
                    );
                }
            }
            let com = self.vec3(&ent, &[Seg::Key("com")], &raw.com);
            let inertia = self.inertia(&ent, &raw.inertia);
            let b = &mut self.bodies[i];
            b.joint = joint;
            b.mass = mass;
            b.com = com;
            b.inertia = inertia;
        }
    }

    /// Stable topological order (Kahn, always taking the earliest written body that is
    /// ready), then one error per cycle of the parent graph.
    fn sort_bodies(&mut self) {
        let n = self.bodies.len();
        let mut children: Vec<Vec<usize>> = vec![Vec::new(); n];
        let mut ready = BTreeSet::new();
        for (i, b) in self.bodies.iter().enumerate() {
            match b.parent {
                ParentRef::Ground => {
                    ready.insert(i);
                }
                ParentRef::Body(p) => children[p].push(i),
                ParentRef::Unresolved => {}
            }
        }
        self.placed = vec![None; n];
        while let Some(i) = ready.pop_first() {
            self.placed[i] = Some(self.order.len());
            self.order.push(i);
            ready.extend(children[i].iter().copied());
        }

        // Cycles among the bodies left over.
        let mut state = vec![0u8; n]; // 0 unvisited, 1 on the current walk, 2 done
        for start in 0..n {
            if self.placed[start].is_some() || state[start] != 0 {
                continue;
            }
            let mut walk = Vec::new();
            let mut cur = start;
            loop {
                if self.placed[cur].is_some() || state[cur] == 2 {
                    break;
                }
                if state[cur] == 1 {
                    let k = walk.iter().position(|&x| x == cur).unwrap_or(0);
                    self.report_cycle(&walk[k..]);
                    break;
                }
                state[cur] = 1;
                walk.push(cur);
                match self.bodies[cur].parent {
                    ParentRef::Body(p) => cur = p,
                    _ => break,
                }
            }
            for &x in &walk {
                state[x] = 2;
            }
        }
    }

    fn report_cycle(&mut self, cycle: &[usize]) {
        // Start the cycle at its earliest written body.
        let first = cycle
            .iter()
            .enumerate()
            .min_by_key(|(_, b)| **b)
            .map_or(0, |(k, _)| k);
        let ordered: Vec<usize> = cycle[first..]
            .iter()
            .chain(&cycle[..first])
            .copied()
            .collect();
        let name = |i: usize| self.bodies[i].name.clone().unwrap_or_default();
        let mut names: Vec<String> = ordered.iter().map(|&i| name(i)).collect();
        let head = ordered[0];
        let message = if ordered.len() == 1 {
            format!(
                "cycle in the parent graph: `{}` is its own parent",
                names[0]
            )
        } else {
            names.push(names[0].clone());
            format!(
                "cycle in the parent graph: {} (each body's parent follows it)",
                names.join(" -> ")
            )
        };
        let at = self.bodies[head].ent.at(&[Seg::Key("parent")]);
        let (line, label) = (at.line, at.label.to_string());
        self.error(Kind::Unsupported, Some(line), Some(&label), message);
    }

    fn joint(&mut self, ent: &Ent<'_>, raw: &RawBody) -> Option<Joint> {
        let joint_at = ent.at(&[Seg::Key("joint")]);
        let mut ok = true;
        let (kind_axis, table) = match &raw.joint {
            RawJoint::Code(code) => match parse_joint_code(code) {
                Some(ka) => (Some(ka), None),
                None => {
                    self.error_at(Kind::InvalidValue,
                        &joint_at,
                        format!(
                            "unknown joint type `{code}` (expected R1, R2, R3, T1, T2, T3, or a table {{ type = \"revolute\" or \"prismatic\", axis = \"x\", \"y\" or \"z\" }})"
                        ),
                    );
                    (None, None)
                }
            },
            RawJoint::Table(t) => {
                let type_at = ent.at(&[Seg::Key("joint"), Seg::Key("type")]);
                let axis_at = ent.at(&[Seg::Key("joint"), Seg::Key("axis")]);
                let axis = match &t.axis {
                    Some(a) => match parse_axis(a) {
                        Some(axis) => Some(axis),
                        None => {
                            self.error_at(
                                Kind::InvalidValue,
                                &axis_at,
                                format!("unknown axis `{a}` (expected x, y or z)"),
                            );
                            ok = false;
                            None
                        }
                    },
                    None => None,
                };
                let kind_axis = match t.kind.as_str() {
                    "revolute" | "prismatic" => {
                        let kind = if t.kind == "revolute" {
                            JointKind::Revolute
                        } else {
                            JointKind::Prismatic
                        };
                        if t.axis.is_none() {
                            self.error_at(
                                Kind::MissingField,
                                &joint_at,
                                "missing `axis` (x, y or z)",
                            );
                        }
                        axis.map(|a| (kind, a))
                    }
                    code => match parse_joint_code(code) {
                        Some((kind, code_axis)) => {
                            if axis.is_some_and(|a| a != code_axis) {
                                self.error_at(Kind::InvalidValue,
                                    &axis_at,
                                    format!(
                                        "axis `{}` contradicts joint type `{code}` (about/along {code_axis})",
                                        t.axis.as_deref().unwrap_or_default()
                                    ),
                                );
                                ok = false;
                            }
                            Some((kind, code_axis))
                        }
                        None => {
                            self.error_at(Kind::InvalidValue,
                                &type_at,
                                format!(
                                    "unknown joint type `{code}` (expected revolute, prismatic, R1, R2, R3, T1, T2 or T3)"
                                ),
                            );
                            None
                        }
                    },
                };
                (kind_axis, Some(t))
            }
        };

        // Anchor and rotation: on the body or in the joint table, not both.
        let in_table = |f: &dyn Fn(&RawJointTable) -> bool| table.is_some_and(f);
        let anchor = if in_table(&|t| t.anchor.is_some()) {
            if raw.anchor.is_some() {
                self.error_at(
                    Kind::InvalidValue,
                    &ent.at(&[Seg::Key("anchor")]),
                    "anchor given both here and in `joint`",
                );
                ok = false;
            }
            let t_anchor = table.and_then(|t| t.anchor.clone());
            self.vec3(ent, &[Seg::Key("joint"), Seg::Key("anchor")], &t_anchor)
        } else {
            self.vec3(ent, &[Seg::Key("anchor")], &raw.anchor)
        };
        let (rotation_raw, rotation_path): (Option<Vec<RawRotation>>, Vec<Seg<'_>>) =
            if in_table(&|t| t.rotation.is_some()) {
                if raw.rotation.is_some() {
                    self.error_at(
                        Kind::InvalidValue,
                        &ent.at(&[Seg::Key("rotation")]),
                        "rotation given both here and in `joint`",
                    );
                    ok = false;
                }
                (
                    table.and_then(|t| t.rotation.clone()),
                    vec![Seg::Key("joint"), Seg::Key("rotation")],
                )
            } else {
                (raw.rotation.clone(), vec![Seg::Key("rotation")])
            };
        let mut rotation = Vec::new();
        for (k, r) in rotation_raw.unwrap_or_default().iter().enumerate() {
            let entry_path = with(&rotation_path, Seg::Idx(k));
            let axis = parse_axis(&r.axis);
            if axis.is_none() {
                self.error_at(
                    Kind::InvalidValue,
                    &ent.at(&with(&entry_path, Seg::Key("axis"))),
                    format!("unknown axis `{}` (expected x, y or z)", r.axis),
                );
            }
            let angle = self.scalar(&ent.at(&with(&entry_path, Seg::Key("angle"))), &r.angle);
            match (axis, angle) {
                (Some(a), Some(t)) => rotation.push((a, t)),
                _ => ok = false,
            }
        }
        let (kind, axis) = kind_axis?;
        let anchor = anchor?;
        ok.then_some(Joint {
            kind,
            axis,
            anchor,
            rotation,
        })
    }

    /// The inertia tensor, with the positive semi-definiteness and triangle checks.
    fn inertia(&mut self, ent: &Ent<'_>, raw: &Option<RawInertia>) -> Option<[[Scalar; 3]; 3]> {
        let key = Seg::Key("inertia");
        let zero = || Scalar::ZERO;
        let tensor: [[Scalar; 3]; 3] = match raw {
            None => return Some(std::array::from_fn(|_| std::array::from_fn(|_| zero()))),
            Some(RawInertia::Table(t)) => {
                let fields = [
                    ("xx", &t.xx),
                    ("yy", &t.yy),
                    ("zz", &t.zz),
                    ("xy", &t.xy),
                    ("xz", &t.xz),
                    ("yz", &t.yz),
                ];
                let mut vals = Vec::with_capacity(6);
                for (name, field) in fields {
                    vals.push(match field {
                        Some(f) => self.scalar(&ent.at(&[key, Seg::Key(name)]), f),
                        None => Some(zero()),
                    });
                }
                let vals: Vec<Scalar> = vals.into_iter().collect::<Option<_>>()?;
                let [xx, yy, zz, xy, xz, yz] = <[Scalar; 6]>::try_from(vals).ok()?;
                [
                    [xx, xy.clone(), xz.clone()],
                    [xy, yy, yz.clone()],
                    [xz, yz, zz],
                ]
            }
            Some(RawInertia::Matrix(m)) => {
                let mut rows = Vec::with_capacity(3);
                let mut ok = true;
                for r in 0..3 {
                    let mut row = Vec::with_capacity(3);
                    for c in 0..3 {
                        match self.scalar(&ent.at(&[key, Seg::Idx(r), Seg::Idx(c)]), &m[r][c]) {
                            Some(s) => row.push(s),
                            None => ok = false,
                        }
                    }
                    rows.push(row);
                }
                if !ok {
                    return None;
                }
                let m: [[Scalar; 3]; 3] =
                    std::array::from_fn(|r| std::array::from_fn(|c| rows[r][c].clone()));
                // Symmetry at the default values; the lower triangle then mirrors the upper.
                for (r, c) in [(0, 1), (0, 2), (1, 2)] {
                    if let (Some(a), Some(b)) = (self.value(&m[r][c]), self.value(&m[c][r])) {
                        if (a - b).abs() > 1e-12 * (a.abs() + b.abs()).max(f64::MIN_POSITIVE) {
                            self.error_at(Kind::InvalidValue,
                                &ent.at(&[key]),
                                format!(
                                    "the inertia matrix is not symmetric: [{r}][{c}] = {} but [{c}][{r}] = {}",
                                    fmt_num(a),
                                    fmt_num(b)
                                ),
                            );
                            return None;
                        }
                    }
                }
                std::array::from_fn(|r| std::array::from_fn(|c| m[r.min(c)][r.max(c)].clone()))
            }
        };

        // Principal moments at the default parameter values.
        let mut values = [[0.0; 3]; 3];
        for r in 0..3 {
            for c in 0..3 {
                // A broken parameter is already reported: skip the checks.
                values[r][c] = self.value(&tensor[r][c])?;
            }
        }
        if let Some(message) = inertia_problem(&values) {
            self.error_at(Kind::InvalidValue, &ent.at(&[key]), message);
            return None;
        }
        Some(tensor)
    }
}

/// Checks a symmetric inertia tensor: finite, positive semi-definite, and its principal
/// moments satisfy the triangle inequality `I_i <= I_j + I_k` (tolerance `1e-9` of the trace).
pub(crate) fn inertia_problem(m: &[[f64; 3]; 3]) -> Option<String> {
    if m.iter().flatten().any(|v| !v.is_finite()) {
        return Some("the inertia tensor has non-finite entries".into());
    }
    let scale = m.iter().flatten().fold(0.0_f64, |s, v| s.max(v.abs()));
    if scale == 0.0 {
        return None; // a point mass
    }
    // Scaled to entries of magnitude <= 1 so that the eigen-solver cannot overflow.
    let scaled = Matrix3::from_fn(|r, c| m[r][c] / scale);
    let Some(eig) = SymmetricEigen::try_new(scaled, 1e-15, 1000) else {
        return Some("could not compute the principal moments of inertia".into());
    };
    let mut moments = [0.0; 3];
    for (k, v) in eig.eigenvalues.iter().enumerate() {
        moments[k] = v * scale;
    }
    moments.sort_by(f64::total_cmp);
    let trace: f64 = moments.iter().map(|x| x.abs()).sum();
    let tol = INERTIA_TOL * trace;
    let shown = moments.map(fmt_num).join(", ");
    if moments[0] < -tol {
        return Some(format!(
            "the inertia tensor is not positive semi-definite (principal moments {shown})"
        ));
    }
    if moments[2] > moments[0] + moments[1] + tol {
        return Some(format!(
            "the principal moments of inertia violate the triangle inequality: {} > {} + {} (principal moments {shown})",
            fmt_num(moments[2]),
            fmt_num(moments[0]),
            fmt_num(moments[1])
        ));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inertia_checks() {
        let rod = 0.024 * 0.01 / 12.0;
        assert_eq!(
            inertia_problem(&[[0.0, 0.0, 0.0], [0.0, rod, 0.0], [0.0, 0.0, rod]]),
            None
        );
        assert_eq!(inertia_problem(&[[0.0; 3]; 3]), None);
        assert_eq!(
            inertia_problem(&[[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0]]),
            None
        );
        let e = inertia_problem(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 3.0]]).unwrap();
        assert!(e.contains("triangle"), "{e}");
        let e = inertia_problem(&[[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]).unwrap();
        assert!(e.contains("positive semi-definite"), "{e}");
        // Products of inertia: eigenvalues 1 +- 2 of the xy block.
        let e = inertia_problem(&[[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]).unwrap();
        assert!(e.contains("positive semi-definite"), "{e}");
        assert!(
            inertia_problem(&[[1e300, 0.0, 0.0], [0.0, 1e300, 0.0], [0.0, 0.0, 1e300]]).is_none()
        );
        assert!(inertia_problem(&[[f64::NAN, 0.0, 0.0], [0.0; 3], [0.0; 3]]).is_some());
    }
}
