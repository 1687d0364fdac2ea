//! Building the engine model of a hybrid scenario: the mechanism models loaded (generated
//! code when compiled in, the interpreter otherwise), every name resolved against them,
//! the two-bar chains placed, the attachments checked (points on ground, over-constraint,
//! beam points), the hybrid system and its initial state assembled. Every problem is
//! reported at once, each with file:line:column and the entity.

use std::ops::Range;

use diagnostic::{Diagnostic, Diagnostics, Kind};
use fem_beam::BeamModel;
use fem_structure::tables::NodeDof;
use fem_structure::{ImportedStructure, Reduced};
use hybrid_core::hybrid::{
    Attachment, BeamPoint, Excitation, ExcitationTarget, HybridError, HybridModel, HybridState,
    JointForce, Mount, MountedMechanism, Placement, Structure, initial_deflection, initial_state,
    place_two_bar,
};
use mbs_symbolic::model::Model;
use mbs_symbolic::runtime::{ParamError, System};

use crate::scenario::HybridScenario;
use crate::scenario::hybrid::{AttachmentEntry, MechanismEntry, PointAt, TargetEntry, list};
use crate::setup::Probes;

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
    /// The displacements of `[output] points`, each named by its column and seen along its
    /// direction ([`output_points`]).
    pub points: Probes,
}

/// Loads the mechanism models (generated code when compiled in, the interpreter
/// otherwise), resolves every name against them, places the two-bar chains, checks the
/// attachments (points on ground, over-constraint, beam points), builds the hybrid model
/// and its initial state. Every problem is reported at once.
pub fn build(sc: &HybridScenario) -> Result<Built, Diagnostics> {
    let (mut model, models) = build_model(sc)?;
    let points = output_points(sc, &model)?;
    realise_random(sc, &mut model)?;
    let n = model.structure_dofs();
    let q0 = match (sc.initial, model.beam()) {
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
        let d = in_file(sc, format!("initial state: {e}"));
        Diagnostics::from(match span {
            Some(s) => d.at_offset(&sc.index, s.start),
            None => d,
        })
    })?;
    Ok(Built {
        model,
        state,
        models,
        points,
    })
}

/// The points of `[output] points` on the built host: a beam abscissa's transverse
/// displacement ([`BeamPoint::on`]), a node's `ux` or `uy` ([`structure_node`] seen along
/// the axis: on a reduced model the row of `T`, `q = T z`). Every problem at once, at its
/// entry: a point a support locks, an unknown node, a node held along the DOF.
pub fn output_points(sc: &HybridScenario, model: &HybridModel) -> Result<Probes, Diagnostics> {
    let mut diags = vec![];
    let mut out = vec![];
    for p in &sc.points {
        let point = match (p.at, model.structure.as_ref()) {
            (PointAt::Beam { x }, _) => model
                .beam()
                .and_then(|b| BeamPoint::on(b, x))
                .filter(|p| !p.is_locked())
                .ok_or_else(|| format!("{}: a support locks the beam there", p.name)),
            (PointAt::Node { node, direction }, Some(st)) => structure_node(st, node)
                .map_err(|m| format!("{}: {m}", p.name))
                .map(|q| q.along(direction))
                .and_then(|q| match q.weights.is_empty() {
                    true => Err(format!("{}: a support holds node {node} along it", p.name)),
                    false => Ok(q),
                }),
            (PointAt::Node { .. }, None) => Err(format!("{}: no [structure]", p.name)),
        };
        match point {
            Ok(q) => out.push((p.name.clone(), q)),
            Err(msg) => {
                diags.push(sc.at(Kind::InvalidValue, Some(&p.span), "[output] points", msg))
            }
        }
    }
    if diags.is_empty() {
        Ok(out)
    } else {
        Err(Diagnostics(diags))
    }
}

/// The displacements a time history writes of the structure's point `p` (an attachment's,
/// named `name`): on the beam its transverse displacement `name.w` (`p` itself); at a node
/// of an imported structure its two in-plane components `name.ux`, `name.uy` (0 where a
/// support holds the node that way), read from the node whatever the attachment's kind (a
/// roller's point is seen along its own direction).
pub fn readings(model: &HybridModel, name: &str, p: &BeamPoint) -> Probes {
    let node = model
        .structure
        .as_ref()
        .filter(|s| s.beam().is_none())
        .and_then(|s| Some((s, node_at(s, p)?)))
        .and_then(|(s, n)| structure_node(s, n).ok());
    match node {
        Some(q) => vec![
            (format!("{name}.ux"), q.along([1.0, 0.0])),
            (format!("{name}.uy"), q.along([0.0, 1.0])),
        ],
        None => vec![(format!("{name}.w"), p.clone())],
    }
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
                &named("excitation", &e.name),
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
    let structure = match beam_model(sc)? {
        Some(b) => Some(Structure::Beam(b)),
        None => imported_model(sc)?,
    };
    let mut r = Resolver { sc, diags: vec![] };
    let loaded = r.load_mechanisms();
    let mut initial_q = r.initial_coordinates(&loaded);
    let points = r.attachment_points(structure.as_ref(), &loaded);
    let mounts = r.place_mechanisms(&loaded, &points, &mut initial_q);
    r.check_points_move(&loaded, &points, &initial_q);
    let forces = r.joint_forces(&loaded);
    let excitations = r.excitations(structure.as_ref(), &loaded);
    r.finish()?;
    assemble(
        sc,
        Resolved {
            structure,
            loaded,
            mounts,
            initial_q,
            points,
            forces,
            excitations,
        },
    )
}

/// A mechanism's model and its system (generated code or interpreter), the scenario's
/// parameter values set.
struct Loaded {
    model: Model,
    system: Box<dyn System>,
}

/// Where a mechanism stands: its mount and, for a two-bar chain placed without rotation,
/// its reach.
type Placed = (Mount, Option<f64>);

/// An attachment resolved: the index of its mechanism point and the beam point it follows.
type AttachedPoint = (usize, BeamPoint);

/// Everything the stages of [`build_model`] resolved, before the assembly: per mechanism
/// (loaded model, placement, initial coordinates), per attachment, the forces and the
/// excitations.
struct Resolved {
    structure: Option<Structure>,
    loaded: Vec<Option<Loaded>>,
    mounts: Vec<Placed>,
    initial_q: Vec<Vec<f64>>,
    points: Vec<Option<AttachedPoint>>,
    forces: Vec<JointForce>,
    excitations: Vec<Excitation>,
}

/// The entity a diagnostic names: `what "name"` (e.g. `mechanism "arm"`).
fn named(what: &str, name: &str) -> String {
    format!("{what} \"{name}\"")
}

/// A problem of the scenario file as a whole (no span, no entity).
fn in_file(sc: &HybridScenario, msg: impl Into<String>) -> Diagnostic {
    Diagnostic::new(Kind::InvalidValue, sc.path.display().to_string(), msg)
}

/// The finite-element beam of `[beam]`, if any. A beam the FE model rejects stops
/// [`build_model`] at once: one `InvalidValue` at `[beam]` (the error's lines joined by
/// `; `), reported alone, nothing after it being checked.
fn beam_model(sc: &HybridScenario) -> Result<Option<BeamModel>, Diagnostics> {
    let Some((_, b)) = &sc.beam else {
        return Ok(None);
    };
    BeamModel::new(b).map(Some).map_err(|e| {
        let msg = e.to_string().replace('\n', "; ");
        sc.at(Kind::InvalidValue, sc.beam_span.as_ref(), "[beam]", msg)
            .into()
    })
}

/// The imported structure of `[structure]`, if any: its files read and checked
/// ([`ImportedStructure::from_files`]: every problem with its file and line), reduced by
/// Craig–Bampton when asked (both once per distinct input: [`super::structures`]), the interface being the attachment nodes' and loaded nodes'
/// `ux`, `uy` (unknown nodes are left to the resolver, which reports them).
fn imported_model(sc: &HybridScenario) -> Result<Option<Structure>, Diagnostics> {
    let Some(entry) = &sc.structure else {
        return Ok(None);
    };
    let full = super::structures::load(&entry.source)?;
    let Some(modes) = entry.reduction_modes else {
        return Ok(Some(Structure::Imported(full)));
    };
    let nodes =
        sc.attachments
            .iter()
            .filter_map(|a| a.node)
            .chain(sc.excitations.iter().filter_map(|e| match e.target {
                TargetEntry::Node { node, .. } => Some(node),
                _ => None,
            }));
    let equation = &full.dofs.equation;
    let mut interface: Vec<usize> = nodes
        .flat_map(|n| {
            [NodeDof::Ux, NodeDof::Uy]
                .into_iter()
                .filter_map(move |d| equation.get(&(n, d)).copied())
        })
        .collect();
    interface.sort_unstable();
    interface.dedup();
    let at = |msg: String| -> Diagnostics {
        sc.at(
            Kind::InvalidValue,
            Some(&entry.span),
            "[structure] reduction",
            msg,
        )
        .into()
    };
    if interface.is_empty() {
        return Err(at(
            "Craig–Bampton needs an interface: attach a mechanism or apply a force at a node"
                .into(),
        ));
    }
    let reduced = super::structures::reduce(&entry.source, &full, &interface, modes).map_err(at)?;
    Ok(Some(Structure::Reduced {
        full: Box::new(full),
        reduced: Box::new(reduced),
    }))
}

/// The point of an imported structure at node `node`: its position and the weights of its
/// `ux`, `uy` (on a reduced model: weight 1 on the interface's reduced coordinate, or the
/// row of the reduction's `T` for a node off the interface); `Err` for a node that
/// `nodes.csv` lacks or whose translations are both held.
fn node_point(
    full: &ImportedStructure,
    reduced: Option<&Reduced>,
    node: u64,
) -> Result<BeamPoint, String> {
    let Some(n) = full.nodes.iter().find(|n| n.id == node) else {
        return Err(format!(
            "no node {node} in the structure's nodes table ({} nodes)",
            full.nodes.len()
        ));
    };
    let weights = |d: NodeDof| -> Vec<(usize, f64)> {
        let Some(&eq) = full.dofs.equation.get(&(node, d)) else {
            return vec![];
        };
        match reduced {
            None => vec![(eq, 1.0)],
            Some(r) => match r.interface.iter().position(|&i| i == eq) {
                Some(k) => vec![(k, 1.0)],
                None => r
                    .transform
                    .row(eq)
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| **v != 0.0)
                    .map(|(j, &v)| (j, v))
                    .collect(),
            },
        }
    };
    let p = BeamPoint {
        x: n.position[0],
        y: n.position[1],
        weights: weights(NodeDof::Uy),
        axial: weights(NodeDof::Ux),
        direction: [0.0, 1.0],
    };
    if p.is_locked() {
        return Err(format!(
            "node {node} has no ux or uy equation (a support holds it)"
        ));
    }
    Ok(p)
}

/// The point of `structure` at node `node`: its position and the weights of its `ux`, `uy`
/// (on a reduced model the interface coordinate, or the row of `T` off the interface);
/// `Err` on the beam (whose points are abscissae) or for an unknown or held node.
pub fn structure_node(structure: &Structure, node: u64) -> Result<BeamPoint, String> {
    match structure {
        Structure::Beam(_) => Err(format!(
            "node {node}: the beam's points are abscissae, not nodes"
        )),
        Structure::Imported(s) => node_point(s, None, node),
        Structure::Reduced { full, reduced } => node_point(full, Some(reduced), node),
    }
}

/// The node of an imported structure at the position of `p` (the attachment's node), if
/// any.
pub fn node_at(structure: &Structure, p: &BeamPoint) -> Option<u64> {
    structure
        .imported()?
        .nodes
        .iter()
        .find(|n| n.position[0] == p.x && n.position[1] == p.y)
        .map(|n| n.id)
}

/// The stages of [`build_model`] after the beam: each resolves one kind of name of the
/// scenario against the models and adds its problems to those of the stages before, so
/// that every problem is reported at once ([`Resolver::finish`]).
struct Resolver<'a> {
    sc: &'a HybridScenario,
    diags: Vec<Diagnostic>,
}

impl Resolver<'_> {
    /// Records a problem at `span` of the scenario file, about `entity`.
    fn report(
        &mut self,
        kind: Kind,
        span: Option<&Range<usize>>,
        entity: &str,
        msg: impl Into<String>,
    ) {
        self.diags.push(self.sc.at(kind, span, entity, msg));
    }

    /// Every problem the stages recorded, sorted by place, or nothing.
    fn finish(self) -> Result<(), Diagnostics> {
        if self.diags.is_empty() {
            return Ok(());
        }
        let mut d = Diagnostics(self.diags);
        d.sort();
        Err(d)
    }

    /// Every mechanism's model loaded and its system built with the written parameters,
    /// in the order of the mechanisms (`None` where the model could not be loaded or has
    /// no system). Records the model loader's diagnostics, `Unsupported` at `model` when
    /// no system can be built, and the parameter diagnostics of
    /// [`Resolver::set_parameters`].
    fn load_mechanisms(&mut self) -> Vec<Option<Loaded>> {
        let sc = self.sc;
        sc.mechanisms
            .iter()
            .map(|m| {
                let model = match mbs_symbolic::model::load(&m.model) {
                    Ok(model) => model,
                    Err(d) => {
                        self.diags.extend(d.0);
                        return None;
                    }
                };
                let entity = named("mechanism", &m.name);
                let mut system = match crate::system_for(&model, None) {
                    Ok(r) => r.system,
                    Err(e) => {
                        self.report(
                            Kind::Unsupported,
                            Some(&m.model_span),
                            &entity,
                            e.to_string(),
                        );
                        return None;
                    }
                };
                self.set_parameters(m, &model, system.as_mut(), &entity);
                Some(Loaded { model, system })
            })
            .collect()
    }

    /// Sets a mechanism's written parameters on its system and, when every one was
    /// accepted, checks the resulting values against the model's bounds. Records, at each
    /// parameter, `UnknownName` for a name the model lacks or `InvalidValue` for a value
    /// the system refuses; then the model's own checks of the values, at the first
    /// parameter (or the mechanism when none is written), their entity prefixed by
    /// `mechanism "…": parameters`.
    fn set_parameters(
        &mut self,
        m: &MechanismEntry,
        model: &Model,
        system: &mut dyn System,
        entity: &str,
    ) {
        let sc = self.sc;
        let mut values = model.default_params();
        let mut params_ok = true;
        for (name, value, span) in &m.parameters {
            match system.set_param(name, *value) {
                Ok(()) => {
                    if let Some(k) = model.param_index(name) {
                        values[k] = *value;
                    }
                }
                Err(e) => {
                    let kind = match &e {
                        ParamError::Unknown { .. } => Kind::UnknownName,
                        _ => Kind::InvalidValue,
                    };
                    let what = format!("{entity}: parameters");
                    self.report(kind, Some(span), &what, e.to_string());
                    params_ok = false;
                }
            }
        }
        if !params_ok {
            return;
        }
        let at = m
            .parameters
            .first()
            .map(|p| p.2.clone())
            .unwrap_or(m.span.clone());
        let file = sc.path.display().to_string();
        if let Err(d) = mbs_symbolic::model::check_parameter_values(model, &values, &file) {
            for mut d in d.0 {
                let what = d.entity.take().unwrap_or_default();
                d = d
                    .entity(format!("{entity}: parameters: {what}"))
                    .at_offset(&sc.index, at.start);
                self.diags.push(d);
            }
        }
    }

    /// Every mechanism's initial coordinates from its `initial` entries by name (zero
    /// where not written; empty for a mechanism not loaded). Records `UnknownName` at an
    /// entry whose coordinate the model lacks, listing the model's coordinates.
    fn initial_coordinates(&mut self, loaded: &[Option<Loaded>]) -> Vec<Vec<f64>> {
        let sc = self.sc;
        sc.mechanisms
            .iter()
            .zip(loaded)
            .map(|(m, l)| {
                let Some(Loaded { system: sys, .. }) = l else {
                    return vec![];
                };
                let mut q = vec![0.0; sys.dof()];
                for (name, value, span) in &m.initial {
                    match sys.coordinate_index(name) {
                        Some(k) => q[k] = *value,
                        None => self.report(
                            Kind::UnknownName,
                            Some(span),
                            &format!("{}: initial", named("mechanism", &m.name)),
                            format!(
                                "unknown coordinate {name:?} (the model has {})",
                                list(sys.coordinate_names())
                            ),
                        ),
                    }
                }
                q
            })
            .collect()
    }

    /// Every attachment's mechanism point ([`Resolver::mechanism_point`]) and beam point
    /// ([`Resolver::attached_beam_point`]): `None` where either is missing or its
    /// mechanism is not loaded, with the diagnostics of those two.
    fn attachment_points(
        &mut self,
        beam: Option<&Structure>,
        loaded: &[Option<Loaded>],
    ) -> Vec<Option<AttachedPoint>> {
        let sc = self.sc;
        sc.attachments
            .iter()
            .map(|a| {
                let l = loaded[a.mechanism].as_ref()?;
                let entity = named("attachment", &a.name);
                let point = self.mechanism_point(a, l, &entity);
                let beam_point = self.attached_beam_point(beam, a, &entity);
                point.zip(beam_point)
            })
            .collect()
    }

    /// The index of the point an attachment names in its mechanism's system. Records, at
    /// `point`, `UnknownName` for a point the mechanism lacks (listing its points) or
    /// `InvalidValue` for a point on the ground body.
    fn mechanism_point(&mut self, a: &AttachmentEntry, l: &Loaded, entity: &str) -> Option<usize> {
        let Loaded { model, system: sys } = l;
        match sys.point_index(&a.point) {
            None => {
                let msg = format!(
                    "no point {:?} in mechanism \"{}\" (points: {})",
                    a.point,
                    self.sc.mechanisms[a.mechanism].name,
                    list(sys.point_names())
                );
                self.report(Kind::UnknownName, Some(&a.point_span), entity, msg);
                None
            }
            Some(_)
                if model
                    .point_index(&a.point)
                    .is_some_and(|i| model.points[i].body.is_none()) =>
            {
                let msg = format!(
                    "point {:?} is on the ground body: it cannot follow the beam",
                    a.point
                );
                self.report(Kind::InvalidValue, Some(&a.point_span), entity, msg);
                None
            }
            Some(k) => Some(k),
        }
    }

    /// The beam point an attachment follows. Records, at `x`, `InvalidValue` for a point
    /// off the beam ([`Resolver::on_beam`]) or one a support locks.
    fn attached_beam_point(
        &mut self,
        structure: Option<&Structure>,
        a: &AttachmentEntry,
        entity: &str,
    ) -> Option<BeamPoint> {
        if let Some(node) = a.node {
            let p = self.at_node(structure, node, &a.x_span, entity)?;
            // A roller follows the node's displacement along its direction only.
            let Some(d) = a.direction else {
                return Some(p);
            };
            let p = p.along(d);
            if p.is_locked() {
                let msg = format!(
                    "node {node} cannot move along [{}, {}] (a support holds it)",
                    d[0], d[1]
                );
                self.report(Kind::InvalidValue, Some(&a.x_span), entity, msg);
                return None;
            }
            return Some(p);
        }
        let beam = structure.and_then(Structure::beam);
        let p = self.on_beam(beam, a.x, &a.x_span, entity)?;
        if !p.is_locked() {
            return Some(p);
        }
        let msg = format!(
            "the beam cannot move transversely at x = {} (a support locks it)",
            a.x
        );
        self.report(Kind::InvalidValue, Some(&a.x_span), entity, msg);
        None
    }

    /// The point of an imported structure at `node` ([`node_point`]). Records
    /// `UnknownName` at `span` for a node the structure lacks, `InvalidValue` for one held.
    fn at_node(
        &mut self,
        structure: Option<&Structure>,
        node: u64,
        span: &Range<usize>,
        entity: &str,
    ) -> Option<BeamPoint> {
        let structure = structure?;
        if structure.beam().is_some() {
            return None;
        }
        match structure_node(structure, node) {
            Ok(p) => Some(p),
            Err(msg) => {
                let kind = if msg.starts_with("no node") {
                    Kind::UnknownName
                } else {
                    Kind::InvalidValue
                };
                self.report(kind, Some(span), entity, msg);
                None
            }
        }
    }

    /// The point of the beam at `x`. Records `InvalidValue` at `span` when there is no
    /// beam or `x` is not on it.
    fn on_beam(
        &mut self,
        beam: Option<&BeamModel>,
        x: f64,
        span: &Range<usize>,
        entity: &str,
    ) -> Option<BeamPoint> {
        let p = beam.and_then(|b| BeamPoint::on(b, x));
        if p.is_none() {
            let msg = format!("x = {x} is not a point of the beam");
            self.report(Kind::InvalidValue, Some(span), entity, msg);
        }
        p
    }

    /// Every mechanism's mount and reach ([`Resolver::place_two_bar_chain`] for one with a
    /// `placement`, as written otherwise), each loaded mechanism's rows checked
    /// ([`Resolver::check_rows`]). Records the diagnostics of those two.
    fn place_mechanisms(
        &mut self,
        loaded: &[Option<Loaded>],
        points: &[Option<AttachedPoint>],
        initial_q: &mut [Vec<f64>],
    ) -> Vec<Placed> {
        let sc = self.sc;
        let mut attached = vec![0usize; sc.mechanisms.len()];
        for a in &sc.attachments {
            attached[a.mechanism] += a.kind.rows();
        }
        sc.mechanisms
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let entity = named("mechanism", &m.name);
                let mut mount = Mount {
                    origin: m.origin,
                    angle: m.angle,
                };
                let sys = loaded[i].as_ref().map(|l| l.system.as_ref());
                let mut reach = None;
                if let (Some(placement), Some(sys)) = (m.placement, sys) {
                    let q = &mut initial_q[i];
                    reach =
                        self.place_two_bar_chain(m, sys, placement, points, &mut mount, q, &entity);
                }
                if let Some(sys) = sys {
                    self.check_rows(m, sys, attached[i], &entity);
                }
                (mount, reach)
            })
            .collect()
    }

    /// Places a two-bar chain so that its attached point lies on the beam: the mount's
    /// origin and the initial coordinates `q` replaced, its reach returned (at a node: along
    /// the pivot -> node axis; on the beam: along y, when its angle is zero) (nothing done
    /// when the attachment is not resolved). Records, at
    /// `placement`, `Unsupported` for a model that is not a two-bar chain and
    /// `InvalidValue` for a placement that fails.
    fn place_two_bar_chain(
        &mut self,
        m: &MechanismEntry,
        sys: &dyn System,
        (a, how): (usize, Placement),
        points: &[Option<AttachedPoint>],
        mount: &mut Mount,
        q: &mut Vec<f64>,
        entity: &str,
    ) -> Option<f64> {
        if sys.dof() != 2 || sys.rows() != 0 {
            self.report(
                Kind::Unsupported,
                m.placement_span.as_ref(),
                entity,
                format!("placement is for a two-bar chain (2 coordinates, no loop rows); this model has {} coordinate(s) and {} loop row(s): give origin and initial instead", sys.dof(), sys.rows()),
            );
            return None;
        }
        let (point, _) = points[a].as_ref()?;
        // A pivot direction is written in the structure's frame: into the mechanism's.
        let how = match how {
            Placement::Along {
                half_angle_deg,
                direction,
                knee,
            } => Placement::Along {
                half_angle_deg,
                direction: mount.to_ground(direction),
                knee,
            },
            other => other,
        };
        match place_two_bar(sys, *point, how) {
            Ok(two) => {
                // The beam point (x_b, 0) = origin + R(angle) target.
                let r = mount.rotate(two.target);
                let (_, at) = points[a].as_ref()?;
                mount.origin = [at.x - r[0], at.y - r[1]];
                *q = two.guess.to_vec();
                // A node moves in the plane: its reach is along the pivot -> node axis,
                // whatever the mount's angle; a beam point moves along y only.
                if self.sc.attachments[a].node.is_some() {
                    Some(two.stretch)
                } else {
                    (m.angle == 0.0).then_some(two.reach)
                }
            }
            Err(e) => {
                let msg = format!("placement: {e}");
                self.report(Kind::InvalidValue, m.placement_span.as_ref(), entity, msg);
                None
            }
        }
    }

    /// Records `InvalidValue` at the mechanism when its loop rows and the `attached` rows
    /// of its attachments outnumber its coordinates (over-constrained).
    fn check_rows(&mut self, m: &MechanismEntry, sys: &dyn System, attached: usize, entity: &str) {
        let (loops, dof) = (sys.rows(), sys.dof());
        if loops + attached > dof {
            self.report(
                Kind::InvalidValue,
                Some(&m.span),
                entity,
                format!("over-constrained: {} constraint rows ({loops} loop row(s) + {attached} attachment row(s)) for {dof} coordinate(s)", loops + attached),
            );
        }
    }

    /// Checks that every resolved attachment point moves in the plane at its mechanism's
    /// initial configuration (skipped where the coordinates are not all known). Records
    /// `InvalidValue` at `point` when its Jacobian is zero: the point is fixed to ground.
    fn check_points_move(
        &mut self,
        loaded: &[Option<Loaded>],
        points: &[Option<AttachedPoint>],
        initial_q: &[Vec<f64>],
    ) {
        let sc = self.sc;
        for (a, p) in sc.attachments.iter().zip(points) {
            let (Some((point, _)), Some(Loaded { system: sys, .. })) = (p, &loaded[a.mechanism])
            else {
                continue;
            };
            let q = &initial_q[a.mechanism];
            if q.len() != sys.dof() {
                continue;
            }
            let mut ws = sys.workspace();
            sys.point_kinematics(*point, q, &vec![0.0; q.len()], &mut ws);
            let moves =
                (0..sys.dof()).any(|c| ws.point_j[(0, c)] != 0.0 || ws.point_j[(1, c)] != 0.0);
            if !moves {
                self.report(
                    Kind::InvalidValue,
                    Some(&a.point_span),
                    &named("attachment", &a.name),
                    format!("point {:?} does not move in the plane at the initial configuration (its Jacobian is zero): it is fixed to ground", a.point),
                );
            }
        }
    }

    /// The force elements on joints, each joint resolved by [`Resolver::joint_index`] (a
    /// force whose joint is unknown or whose mechanism is not loaded is left out).
    /// Records the `UnknownName` of [`Resolver::joint_index`] at `joint`.
    fn joint_forces(&mut self, loaded: &[Option<Loaded>]) -> Vec<JointForce> {
        let sc = self.sc;
        sc.forces
            .iter()
            .filter_map(|f| {
                let entity = named("force", &f.name);
                let j = self.joint_index(loaded, f.mechanism, &f.joint, &f.joint_span, &entity)?;
                Some(JointForce {
                    name: f.name.clone(),
                    mechanism: f.mechanism,
                    joint: j,
                    kind: f.kind.clone(),
                })
            })
            .collect()
    }

    /// The excitations with their targets resolved: a beam point
    /// ([`Resolver::on_beam`]), a joint ([`Resolver::joint_index`]) or the base (one whose
    /// target is not resolved is left out). Records, at `at`, `InvalidValue` for a beam
    /// target off the beam and `UnknownName` for an unknown joint.
    fn excitations(
        &mut self,
        structure: Option<&Structure>,
        loaded: &[Option<Loaded>],
    ) -> Vec<Excitation> {
        let sc = self.sc;
        sc.excitations
            .iter()
            .filter_map(|e| {
                let entity = named("excitation", &e.name);
                let target = match &e.target {
                    TargetEntry::Beam { x } => self
                        .on_beam(structure.and_then(Structure::beam), *x, &e.at_span, &entity)
                        .map(ExcitationTarget::Beam),
                    TargetEntry::Node { node, direction } => self
                        .at_node(structure, *node, &e.at_span, &entity)
                        // The force along `direction`: weights d . e of ux and uy.
                        .map(|p| ExcitationTarget::Beam(p.along(*direction))),
                    TargetEntry::Joint {
                        mechanism,
                        joint: name,
                    } => self
                        .joint_index(loaded, *mechanism, name, &e.at_span, &entity)
                        .map(|j| ExcitationTarget::Joint {
                            mechanism: *mechanism,
                            joint: j,
                        }),
                    TargetEntry::Base { direction } => Some(ExcitationTarget::Base {
                        direction: *direction,
                    }),
                };
                target.map(|target| Excitation {
                    name: e.name.clone(),
                    target,
                    amplitude: e.amplitude,
                    time: e.time.clone(),
                })
            })
            .collect()
    }

    /// The index of body (joint) `name` of mechanism `m`, `None` when the mechanism is
    /// not loaded. Records `UnknownName` at `span` for a body the model lacks, listing
    /// its bodies.
    fn joint_index(
        &mut self,
        loaded: &[Option<Loaded>],
        m: usize,
        name: &str,
        span: &Range<usize>,
        entity: &str,
    ) -> Option<usize> {
        let model = &loaded[m].as_ref()?.model;
        let k = model.body_index(name);
        if k.is_none() {
            let bodies: Vec<String> = model.bodies.iter().map(|b| b.name.clone()).collect();
            let msg = format!(
                "no body {name:?} in mechanism \"{}\" (bodies: {})",
                self.sc.mechanisms[m].name,
                list(&bodies)
            );
            self.report(Kind::UnknownName, Some(span), entity, msg);
        }
        k
    }
}

/// The hybrid model from what every stage resolved (called only when no stage recorded
/// a problem, so every mechanism is loaded and every attachment resolved), with the
/// mechanism models in the order of the mechanisms. Emits an `InvalidValue` of the file
/// when [`HybridModel::new`] refuses the assembly.
fn assemble(sc: &HybridScenario, r: Resolved) -> Result<(HybridModel, Vec<Model>), Diagnostics> {
    let (models, systems): (Vec<Model>, Vec<Box<dyn System>>) = r
        .loaded
        .into_iter()
        .flatten()
        .map(|l| (l.model, l.system))
        .unzip();
    let mechanisms = sc
        .mechanisms
        .iter()
        .zip(systems)
        .zip(r.mounts)
        .zip(r.initial_q)
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
        .zip(r.points.into_iter().flatten())
        .map(|(a, (point, beam))| Attachment {
            name: a.name.clone(),
            mechanism: a.mechanism,
            point,
            kind: a.kind,
            beam,
        })
        .collect();
    let model = HybridModel::new(
        r.structure,
        mechanisms,
        attachments,
        r.forces,
        r.excitations,
    )
    .map_err(|e| Diagnostics::from(in_file(sc, e.to_string())))?;
    Ok((model, models))
}
