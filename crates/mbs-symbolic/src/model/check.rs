//! Checks of parameter values given after the model was validated (`--param`, scenario
//! overrides): the same physical checks as the model file gets at its default values.
//!
//! Derived parameters are inlined into the expressions that use them, so evaluating every
//! numeric field with the new values checks them too. Checked: each body's mass > 0, its
//! inertia tensor finite, positive semi-definite and satisfying the triangle inequality of
//! principal moments (the model file's tolerance), and every other numeric field (joint
//! anchors and rotations, centres of mass, points, gravity, force elements, constraint
//! targets) finite. Each problem names the entity and the parameters its expression uses,
//! with their values.

use diagnostic::{Diagnostic, Diagnostics, Kind};

use super::types::{Constraint, ForceElement, Model, Scalar};
use super::validate::fmt_num;

/// The parameters an expression uses, in first-use order.
fn params_of(s: &Scalar, out: &mut Vec<usize>) {
    match s {
        Scalar::Num(_) => {}
        Scalar::Param(i) => {
            if !out.contains(i) {
                out.push(*i);
            }
        }
        Scalar::Neg(a) | Scalar::Call(_, a) => params_of(a, out),
        Scalar::Bin(_, a, b) => {
            params_of(a, out);
            params_of(b, out);
        }
    }
}

/// `" (with m1 = -1, L1 = 0.1)"` for the parameters the fields use, or `""`.
fn with_params(model: &Model, values: &[f64], fields: &[&Scalar]) -> String {
    let mut used = vec![];
    for f in fields {
        params_of(f, &mut used);
    }
    if used.is_empty() {
        return String::new();
    }
    let shown: Vec<String> = used
        .iter()
        .map(|&k| {
            format!(
                "{} = {}",
                diagnostic::truncate(&model.parameters[k].name, 80),
                fmt_num(values[k])
            )
        })
        .collect();
    format!(" (with {})", shown.join(", "))
}

/// Checks `values` (indexed like [`Model::parameters`]) against the model: every problem,
/// each naming its entity and the parameters involved. `file` names where the values come
/// from in the messages (`--param`, a scenario file).
pub fn check_parameter_values(
    model: &Model,
    values: &[f64],
    file: &str,
) -> Result<(), Diagnostics> {
    let mut out = Diagnostics::default();
    let mut report = |entity: String, message: String| {
        out.push(Diagnostic::new(Kind::InvalidValue, file, message).entity(entity));
    };
    if values.len() != model.parameters.len() {
        report(
            format!("model {:?}", model.name),
            format!(
                "expected {} parameter values, got {}",
                model.parameters.len(),
                values.len()
            ),
        );
        return out.into_result(());
    }
    for (k, (p, v)) in model.parameters.iter().zip(values).enumerate() {
        if !v.is_finite() && !p.derived {
            report(
                format!("parameter {:?}", diagnostic::truncate(&p.name, 80)),
                format!("value {v} is not finite (parameter {})", k + 1),
            );
        }
    }
    let finite = |fields: &[&Scalar]| fields.iter().all(|s| s.eval(values).is_finite());
    for b in &model.bodies {
        let entity = format!("body {:?}", diagnostic::truncate(&b.name, 80));
        let m = b.mass.eval(values);
        if !(m > 0.0 && m.is_finite()) {
            report(
                entity.clone(),
                format!(
                    "mass must be positive and finite, got {}{}",
                    fmt_num(m),
                    with_params(model, values, &[&b.mass])
                ),
            );
        }
        let inertia: [[f64; 3]; 3] =
            std::array::from_fn(|r| std::array::from_fn(|c| b.inertia[r][c].eval(values)));
        if let Some(problem) = super::validate::inertia_problem(&inertia) {
            let fields: Vec<&Scalar> = b.inertia.iter().flatten().collect();
            report(
                entity.clone(),
                format!("inertia: {problem}{}", with_params(model, values, &fields)),
            );
        }
        let mut geometry: Vec<&Scalar> = b.com.iter().chain(&b.joint.anchor).collect();
        geometry.extend(b.joint.rotation.iter().map(|(_, a)| a));
        if !finite(&geometry) {
            report(
                entity,
                format!(
                    "joint anchor, rotation or centre of mass is not finite{}",
                    with_params(model, values, &geometry)
                ),
            );
        }
    }
    for p in &model.points {
        let fields: Vec<&Scalar> = p.position.iter().collect();
        if !finite(&fields) {
            report(
                format!("point {:?}", diagnostic::truncate(&p.name, 80)),
                format!(
                    "position is not finite{}",
                    with_params(model, values, &fields)
                ),
            );
        }
    }
    let gravity: Vec<&Scalar> = model.gravity.iter().collect();
    if !finite(&gravity) {
        report(
            "gravity".into(),
            format!("not finite{}", with_params(model, values, &gravity)),
        );
    }
    for f in &model.forces {
        let fields: Vec<&Scalar> = match f {
            ForceElement::Joint {
                stiffness,
                damping,
                rest,
                constant,
                ..
            } => vec![stiffness, damping, rest, constant],
            ForceElement::PointSpring {
                stiffness,
                damping,
                rest_length,
                ..
            } => vec![stiffness, damping, rest_length],
            ForceElement::External {
                point,
                force,
                torque,
                ..
            } => point.iter().chain(force).chain(torque).collect(),
        };
        if !finite(&fields) {
            report(
                format!("force {:?}", diagnostic::truncate(f.name(), 80)),
                format!(
                    "a value is not finite{}",
                    with_params(model, values, &fields)
                ),
            );
        }
    }
    for c in &model.constraints {
        let fields: Vec<&Scalar> = match c {
            Constraint::Loop { .. } => vec![],
            Constraint::Fixed { position, .. } => position.iter().collect(),
            Constraint::Angle { offset, .. } => vec![offset],
        };
        if !finite(&fields) {
            report(
                format!("constraint {:?}", diagnostic::truncate(c.name(), 80)),
                format!(
                    "a value is not finite{}",
                    with_params(model, values, &fields)
                ),
            );
        }
    }
    out.into_result(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODEL: &str = r#"
        [parameters]
        L1 = 0.1
        m1 = { value = 0.024, runtime = true }
        I1 = "m1*L1^2/12"
        [[bodies]]
        name = "crank"
        joint = "R3"
        mass = "m1"
        com = ["L1/2", 0, 0]
        inertia = { yy = "I1", zz = "I1" }
    "#;

    fn model() -> Model {
        super::super::parse_str(MODEL, "m.toml", super::super::Format::Toml).unwrap()
    }

    #[test]
    fn default_values_pass() {
        let m = model();
        check_parameter_values(&m, &m.default_params(), "m.toml").unwrap();
    }

    #[test]
    fn negative_mass_override_names_the_body_and_the_parameter() {
        let m = model();
        let mut v = m.default_params();
        v[m.param_index("m1").unwrap()] = -1.0;
        let e = check_parameter_values(&m, &v, "--param").unwrap_err();
        let text = e.to_string();
        assert!(text.contains("body \"crank\""), "{text}");
        assert!(text.contains("mass must be positive"), "{text}");
        assert!(text.contains("m1 = -1"), "{text}");
        // I1 = m1 L1^2/12 follows m1: the inertia is negative too, reported as well.
        assert!(text.contains("not positive semi-definite"), "{text}");
        assert_eq!(e.len(), 2, "{text}");
    }

    #[test]
    fn zero_mass_and_overflowing_lengths_are_refused() {
        let m = model();
        let mut v = m.default_params();
        v[m.param_index("m1").unwrap()] = 0.0;
        assert!(check_parameter_values(&m, &v, "s.toml").is_err());
        let mut v = m.default_params();
        v[m.param_index("L1").unwrap()] = 1e300; // L1^2 overflows the inertia
        let text = check_parameter_values(&m, &v, "s.toml")
            .unwrap_err()
            .to_string();
        assert!(
            text.contains("non-finite") && text.contains("L1 = 1.00000e300"),
            "{text}"
        );
    }
}
