//! Building the engine model of a hybrid scenario: the mechanism models loaded (generated
//! code when compiled in, the interpreter otherwise), every name resolved against them,
//! the two-bar chains placed, the attachments checked (points on ground, over-constraint,
//! beam points), the hybrid system and its initial state assembled. Every problem is
//! reported at once, each with file:line:column and the entity.

use std::ops::Range;

use diagnostic::{Diagnostic, Diagnostics, Kind};
use fem_beam::BeamModel;
use hybrid_core::hybrid::{
    Attachment, BeamPoint, Excitation, ExcitationTarget, HybridError, HybridModel, HybridState,
    JointForce, Mount, MountedMechanism, initial_deflection, initial_state, place_two_bar,
};
use mbs_symbolic::model::Model;
use mbs_symbolic::runtime::{ParamError, System};

use crate::scenario::HybridScenario;
use crate::scenario::hybrid::{TargetEntry, list};

/// A hybrid scenario resolved against its models: the model, its initial state and what
/// the reports need.
#[derive(Debug)]
pub struct Built {
    /// The hybrid system.
    pub model: HybridModel,
    /// Its initial state (consistent accelerations).
    pub state: HybridState,
    /// The mechanism models, in the order of the mechanisms.
    pub models: Vec<Model>,
}

/// Loads the mechanism models (generated code when compiled in, the interpreter
/// otherwise), resolves every name against them, places the two-bar chains, checks the
/// attachments (points on ground, over-constraint, beam points), builds the hybrid model
/// and its initial state. Every problem is reported at once.
pub fn build(sc: &HybridScenario) -> Result<Built, Diagnostics> {
    let (mut model, models) = build_model(sc)?;
    realise_random(sc, &mut model)?;
    let n = model.beam_dofs();
    let q0 = match (sc.initial, &model.beam) {
        (Some((d, x)), Some(b)) => {
            let point = BeamPoint::on(b, x).filter(|p| !p.is_locked());
            let Some(point) = point else {
                return Err(sc
                    .at(
                        Kind::InvalidValue,
                        sc.initial_x_span.as_ref(),
                        "[initial] x",
                        "a support locks the beam there: no static shape of a load",
                    )
                    .into());
            };
            initial_deflection(b, &point, d).map_err(|e| {
                sc.at(
                    Kind::InvalidValue,
                    sc.initial_x_span.as_ref(),
                    "[initial]",
                    e.to_string(),
                )
            })?
        }
        _ => vec![0.0; n],
    };
    let state = initial_state(&model, q0, vec![0.0; n]).map_err(|e| {
        let span = match &e {
            HybridError::Partition { mechanism, .. }
            | HybridError::Singular { mechanism, .. }
            | HybridError::NoAssembly { mechanism, .. } => sc
                .mechanisms
                .iter()
                .find(|m| &m.name == mechanism)
                .map(|m| &m.span),
            _ => None,
        };
        let d = Diagnostic::new(
            Kind::InvalidValue,
            sc.path.display().to_string(),
            format!("initial state: {e}"),
        );
        Diagnostics::from(match span {
            Some(s) => d.at_offset(&sc.index, s.start),
            None => d,
        })
    })?;
    Ok(Built {
        model,
        state,
        models,
    })
}

/// Replaces every random excitation's time function by its seeded realisation on the run's
/// time grid ([`fem_beam::random::realise`]: the step `dt`, covering `t_end`), drawn from
/// the written seed or [`fem_beam::random::DEFAULT_SEED`] plus the excitation's index: once,
/// before the run, so that a step only interpolates.
fn realise_random(sc: &HybridScenario, model: &mut HybridModel) -> Result<(), Diagnostics> {
    let ig = &sc.integrator;
    for (k, e) in model.excitations.iter_mut().enumerate() {
        if !matches!(
            e.time,
            fem_beam::TimeFunction::WhiteNoise { .. } | fem_beam::TimeFunction::Psd { .. }
        ) {
            continue;
        }
        let seed = e
            .time
            .seed()
            .unwrap_or(fem_beam::random::DEFAULT_SEED + k as u64);
        let samples = fem_beam::random::realise(&e.time, ig.dt, ig.t_end, seed).map_err(|err| {
            let span = sc
                .excitations
                .iter()
                .find(|x| x.name == e.name)
                .map(|x| &x.at_span);
            sc.at(
                Kind::InvalidValue,
                span,
                &format!("excitation \"{}\"", e.name),
                format!("time: {err}"),
            )
        })?;
        e.time = fem_beam::TimeFunction::Sampled(samples);
    }
    Ok(())
}

/// The hybrid system of the scenario and its mechanism models (in the order of the
/// mechanisms), without the initial state: what a linearisation about the rest position
/// needs (an initial displacement out of the mechanism's reach does not stop it).
pub fn build_model(sc: &HybridScenario) -> Result<(HybridModel, Vec<Model>), Diagnostics> {
    let mut diags: Vec<Diagnostic> = vec![];
    let beam = match &sc.beam {
        Some((_, b)) => match BeamModel::new(b) {
            Ok(m) => Some(m),
            Err(e) => {
                let msg = e.to_string().replace('\n', "; ");
                return Err(sc
                    .at(Kind::InvalidValue, sc.beam_span.as_ref(), "[beam]", msg)
                    .into());
            }
        },
        None => None,
    };
    // Models and systems.
    let mut models = vec![];
    let mut systems: Vec<Option<Box<dyn System>>> = vec![];
    for m in &sc.mechanisms {
        let entity = format!("mechanism \"{}\"", m.name);
        let model = match mbs_symbolic::model::load(&m.model) {
            Ok(model) => model,
            Err(d) => {
                diags.extend(d.0);
                models.push(None);
                systems.push(None);
                continue;
            }
        };
        let mut system = match crate::system_for(&model, None) {
            Ok(r) => r.system,
            Err(e) => {
                diags.push(sc.at(
                    Kind::Unsupported,
                    Some(&m.model_span),
                    &entity,
                    e.to_string(),
                ));
                models.push(None);
                systems.push(None);
                continue;
            }
        };
        let mut values = model.default_params();
        let mut params_ok = true;
        for (name, value, span) in &m.parameters {
            match system.set_param(name, *value) {
                Ok(()) => {
                    if let Some(k) = model.param_index(name) {
                        values[k] = *value;
                    }
                }
                Err(e @ ParamError::Unknown { .. }) => {
                    diags.push(sc.at(
                        Kind::UnknownName,
                        Some(span),
                        &format!("{entity}: parameters"),
                        e.to_string(),
                    ));
                    params_ok = false;
                }
                Err(e) => {
                    diags.push(sc.at(
                        Kind::InvalidValue,
                        Some(span),
                        &format!("{entity}: parameters"),
                        e.to_string(),
                    ));
                    params_ok = false;
                }
            }
        }
        if params_ok {
            let at = m
                .parameters
                .first()
                .map(|p| p.2.clone())
                .unwrap_or(m.span.clone());
            if let Err(d) = mbs_symbolic::model::check_parameter_values(
                &model,
                &values,
                &sc.path.display().to_string(),
            ) {
                for mut d in d.0 {
                    let what = d.entity.take().unwrap_or_default();
                    d = d
                        .entity(format!("{entity}: parameters: {what}"))
                        .at_offset(&sc.index, at.start);
                    diags.push(d);
                }
            }
        }
        models.push(Some(model));
        systems.push(Some(system));
    }
    // Initial coordinates by name.
    let mut initial_q: Vec<Vec<f64>> = vec![];
    for (m, sys) in sc.mechanisms.iter().zip(&systems) {
        let Some(sys) = sys else {
            initial_q.push(vec![]);
            continue;
        };
        let mut q = vec![0.0; sys.dof()];
        for (name, value, span) in &m.initial {
            match sys.coordinate_index(name) {
                Some(k) => q[k] = *value,
                None => diags.push(sc.at(
                    Kind::UnknownName,
                    Some(span),
                    &format!("mechanism \"{}\": initial", m.name),
                    format!(
                        "unknown coordinate {name:?} (the model has {})",
                        list(sys.coordinate_names())
                    ),
                )),
            }
        }
        initial_q.push(q);
    }
    // Attachments: points and beam points.
    let mut points = vec![];
    for a in &sc.attachments {
        let entity = format!("attachment \"{}\"", a.name);
        let (Some(model), Some(sys)) = (&models[a.mechanism], &systems[a.mechanism]) else {
            points.push(None);
            continue;
        };
        let point = sys.point_index(&a.point);
        let point = match point {
            None => {
                diags.push(sc.at(
                    Kind::UnknownName,
                    Some(&a.point_span),
                    &entity,
                    format!(
                        "no point {:?} in mechanism \"{}\" (points: {})",
                        a.point,
                        sc.mechanisms[a.mechanism].name,
                        list(sys.point_names())
                    ),
                ));
                None
            }
            Some(_)
                if model
                    .point_index(&a.point)
                    .is_some_and(|i| model.points[i].body.is_none()) =>
            {
                diags.push(sc.at(
                    Kind::InvalidValue,
                    Some(&a.point_span),
                    &entity,
                    format!(
                        "point {:?} is on the ground body: it cannot follow the beam",
                        a.point
                    ),
                ));
                None
            }
            Some(k) => Some(k),
        };
        let beam_point = beam.as_ref().and_then(|b| BeamPoint::on(b, a.x));
        let beam_point = match beam_point {
            Some(p) if p.is_locked() => {
                diags.push(sc.at(
                    Kind::InvalidValue,
                    Some(&a.x_span),
                    &entity,
                    format!(
                        "the beam cannot move transversely at x = {} (a support locks it)",
                        a.x
                    ),
                ));
                None
            }
            Some(p) => Some(p),
            None => {
                diags.push(sc.at(
                    Kind::InvalidValue,
                    Some(&a.x_span),
                    &entity,
                    format!("x = {} is not a point of the beam", a.x),
                ));
                None
            }
        };
        points.push(point.zip(beam_point));
    }
    // Placements, reach and over-constraint per mechanism.
    let mut mounts = vec![];
    for (i, m) in sc.mechanisms.iter().enumerate() {
        let entity = format!("mechanism \"{}\"", m.name);
        let mut mount = Mount {
            origin: m.origin,
            angle: m.angle,
        };
        let mut reach = None;
        if let (Some((a, how)), Some(sys)) = (m.placement, &systems[i]) {
            if sys.dof() != 2 || sys.rows() != 0 {
                diags.push(sc.at(
                    Kind::Unsupported,
                    m.placement_span.as_ref(),
                    &entity,
                    format!("placement is for a two-bar chain (2 coordinates, no loop rows); this model has {} coordinate(s) and {} loop row(s): give origin and initial instead", sys.dof(), sys.rows()),
                ));
            } else if let Some((point, _)) = &points[a] {
                match place_two_bar(sys.as_ref(), *point, how) {
                    Ok(two) => {
                        // The beam point (x_b, 0) = origin + R(angle) target.
                        let r = mount.rotate(two.target);
                        mount.origin = [sc.attachments[a].x - r[0], -r[1]];
                        initial_q[i] = two.guess.to_vec();
                        reach = (m.angle == 0.0).then_some(two.reach);
                    }
                    Err(e) => diags.push(sc.at(
                        Kind::InvalidValue,
                        m.placement_span.as_ref(),
                        &entity,
                        format!("placement: {e}"),
                    )),
                }
            }
        }
        if let Some(sys) = &systems[i] {
            let attached: usize = sc
                .attachments
                .iter()
                .filter(|a| a.mechanism == i)
                .map(|a| a.kind.rows())
                .sum();
            let (loops, dof) = (sys.rows(), sys.dof());
            if loops + attached > dof {
                diags.push(sc.at(
                    Kind::InvalidValue,
                    Some(&m.span),
                    &entity,
                    format!("over-constrained: {} constraint rows ({loops} loop row(s) + {attached} attachment row(s)) for {dof} coordinate(s)", loops + attached),
                ));
            }
        }
        mounts.push((mount, reach));
    }
    // Points that do not move at the initial configuration.
    for (a, p) in sc.attachments.iter().zip(&points) {
        let (Some((point, _)), Some(sys)) = (p, &systems[a.mechanism]) else {
            continue;
        };
        let q = &initial_q[a.mechanism];
        if q.len() != sys.dof() {
            continue;
        }
        let mut ws = sys.workspace();
        sys.point_kinematics(*point, q, &vec![0.0; q.len()], &mut ws);
        let moves = (0..sys.dof()).any(|c| ws.point_j[(0, c)] != 0.0 || ws.point_j[(1, c)] != 0.0);
        if !moves {
            diags.push(sc.at(
                Kind::InvalidValue,
                Some(&a.point_span),
                &format!("attachment \"{}\"", a.name),
                format!("point {:?} does not move in the plane at the initial configuration (its Jacobian is zero): it is fixed to ground", a.point),
            ));
        }
    }
    // Forces and excitations on joints.
    let joint = |m: usize,
                 name: &str,
                 span: &Range<usize>,
                 entity: &str,
                 diags: &mut Vec<Diagnostic>|
     -> Option<usize> {
        let model = models[m].as_ref()?;
        let k = model.body_index(name);
        if k.is_none() {
            let bodies: Vec<String> = model.bodies.iter().map(|b| b.name.clone()).collect();
            diags.push(sc.at(
                Kind::UnknownName,
                Some(span),
                entity,
                format!(
                    "no body {name:?} in mechanism \"{}\" (bodies: {})",
                    sc.mechanisms[m].name,
                    list(&bodies)
                ),
            ));
        }
        k
    };
    let mut forces = vec![];
    for f in &sc.forces {
        let entity = format!("force \"{}\"", f.name);
        if let Some(j) = joint(f.mechanism, &f.joint, &f.joint_span, &entity, &mut diags) {
            forces.push(JointForce {
                name: f.name.clone(),
                mechanism: f.mechanism,
                joint: j,
                kind: f.kind.clone(),
            });
        }
    }
    let mut excitations = vec![];
    for e in &sc.excitations {
        let entity = format!("excitation \"{}\"", e.name);
        let target = match &e.target {
            TargetEntry::Beam { x } => match beam.as_ref().and_then(|b| BeamPoint::on(b, *x)) {
                Some(p) => Some(ExcitationTarget::Beam(p)),
                None => {
                    diags.push(sc.at(
                        Kind::InvalidValue,
                        Some(&e.at_span),
                        &entity,
                        format!("x = {x} is not a point of the beam"),
                    ));
                    None
                }
            },
            TargetEntry::Joint {
                mechanism,
                joint: name,
            } => joint(*mechanism, name, &e.at_span, &entity, &mut diags).map(|j| {
                ExcitationTarget::Joint {
                    mechanism: *mechanism,
                    joint: j,
                }
            }),
            TargetEntry::Base => Some(ExcitationTarget::Base),
        };
        if let Some(target) = target {
            excitations.push(Excitation {
                name: e.name.clone(),
                target,
                amplitude: e.amplitude,
                time: e.time.clone(),
            });
        }
    }
    if !diags.is_empty() {
        let mut d = Diagnostics(diags);
        d.sort();
        return Err(d);
    }
    // Everything resolved: the model.
    let models: Vec<Model> = models.into_iter().flatten().collect();
    let mechanisms = sc
        .mechanisms
        .iter()
        .zip(systems.into_iter().flatten())
        .zip(mounts)
        .zip(initial_q)
        .map(|(((m, system), (mount, reach)), q)| MountedMechanism {
            name: m.name.clone(),
            system,
            mount,
            max_condition: m.max_condition,
            reach,
            initial_q: q,
        })
        .collect();
    let attachments = sc
        .attachments
        .iter()
        .zip(points.into_iter().flatten())
        .map(|(a, (point, beam))| Attachment {
            name: a.name.clone(),
            mechanism: a.mechanism,
            point,
            kind: a.kind,
            beam,
        })
        .collect();
    let model =
        HybridModel::new(beam, mechanisms, attachments, forces, excitations).map_err(|e| {
            Diagnostics::from(Diagnostic::new(
                Kind::InvalidValue,
                sc.path.display().to_string(),
                e.to_string(),
            ))
        })?;
    Ok((model, models))
}
