//! The validated beam: segments meshed into elements, nodes, locked DOFs, damping and loads.
//!
//! [`Beam::validate`] checks a [`BeamSpec`] and returns every problem found as typed
//! [`InputError`]s; [`Beam::new`] reports them as diagnostics ([`BeamError::Input`]), and
//! [`Beam::from_toml_str`] and [`Beam::from_file`] add the file and the line of each problem
//! ([`crate::input_diagnostics`]), in file order.

use std::path::Path;

use diagnostic::Diagnostics;

use crate::element;
use crate::error::{BeamError, Entity, InputError};
use crate::source;
use crate::spec::{BeamSpec, Dof, SegmentSpec, SupportKind, TimeFunction, TimeFunctionError};

/// A validated prismatic segment.
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    /// Length, m.
    pub length: f64,
    /// Young's modulus E, Pa.
    pub youngs_modulus: f64,
    /// Density rho, kg/m^3.
    pub density: f64,
    /// Cross-section area F, m^2.
    pub area: f64,
    /// Second moment of area J, m^4.
    pub second_moment: f64,
    /// Number of elements.
    pub elements: usize,
    /// Position of the segment's first node, m.
    pub x_start: f64,
    /// Global index of the segment's first element.
    pub first_element: usize,
}

impl Segment {
    /// Bending stiffness E J, N m^2.
    pub fn bending_stiffness(&self) -> f64 {
        self.youngs_modulus * self.second_moment
    }

    /// Mass per unit length rho F, kg/m.
    pub fn mass_per_length(&self) -> f64 {
        self.density * self.area
    }

    /// Length of each of its elements, m.
    pub fn element_length(&self) -> f64 {
        self.length / self.elements as f64
    }
}

/// One finite element: nodes `index` and `index + 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Element {
    /// Index of the segment it belongs to.
    pub segment: usize,
    /// Position of its first node, m.
    pub x_start: f64,
    /// Length, m.
    pub length: f64,
}

/// Validated Rayleigh damping, eq. (40).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Damping {
    /// Given coefficients.
    Rayleigh {
        /// Mass-proportional coefficient, 1/s.
        alpha: f64,
        /// Stiffness-proportional coefficient, s.
        beta: f64,
    },
    /// Target damping ratios on two modes (mode numbers from 1, ascending frequency);
    /// alpha and beta are solved when the model is built.
    ModalRatios {
        /// The two mode numbers.
        modes: [usize; 2],
        /// Their target damping ratios.
        ratios: [f64; 2],
    },
}

/// A validated nodal load.
#[derive(Clone, Debug, PartialEq)]
pub struct NodalLoad {
    /// Node index.
    pub node: usize,
    /// Transverse force, N.
    pub force: f64,
    /// Moment, N m.
    pub moment: f64,
    /// Time dependence.
    pub time: TimeFunction,
}

/// A validated uniformly distributed load on a segment.
#[derive(Clone, Debug, PartialEq)]
pub struct DistributedLoad {
    /// Segment index.
    pub segment: usize,
    /// Load per unit length, N/m.
    pub q: f64,
    /// Time dependence.
    pub time: TimeFunction,
}

/// A validated, meshed beam description. Node 0 is at x = 0; element `e` joins nodes `e`
/// and `e + 1`.
#[derive(Clone, Debug, PartialEq)]
pub struct Beam {
    name: Option<String>,
    segments: Vec<Segment>,
    elements: Vec<Element>,
    node_x: Vec<f64>,
    locked: Vec<[bool; 2]>,
    damping: Damping,
    nodal_loads: Vec<NodalLoad>,
    distributed_loads: Vec<DistributedLoad>,
}

/// Largest number of elements of a beam (all segments together): 10 million elements
/// already need ~2 GB for the three banded matrices; a larger count is a typo, reported
/// instead of exhausting memory.
pub const MAX_ELEMENTS: usize = 10_000_000;

/// Relative tolerance (of the beam length) for a position `x` to coincide with a node.
/// Positions in files are decimal numbers and node positions are sums of element lengths;
/// both are exact to ~1e-15 L, so 1e-9 L only forgives rounding, never a wrong node.
const NODE_TOLERANCE: f64 = 1e-9;

/// The physical range `(field, min, max, unit)` of every numeric segment field, checked by
/// [`Beam::new_in_physical_range`] (the entry of scenario files): values outside are typing
/// or unit mistakes that would leave finite but hopeless matrices (issue 23:
/// `youngs_modulus = 1e305` overflowed the damping matrix, `density = 1e300` ran with a
/// beam that does not move). Generous on purpose:
///
/// - `length` 1 um (MEMS) to 10 km;
/// - `youngs_modulus` 1 kPa (soft foams, gels) to 10 TPa (diamond and graphene: ~1 TPa);
/// - `density` 1 kg/m^3 (aerogels) to 1e6 kg/m^3 (osmium: 2.26e4, so room for lumped
///   added masses smeared over a segment);
/// - `width`, `height` 0.1 um to 1 km, and so `area` 1e-14 to 1e6 m^2 and `second_moment`
///   1e-28 to 1e12 m^4 (`b h^3 / 12` over those sides, rounded outwards).
///
/// [`Beam::new`] itself accepts idealised values (a nearly rigid test beam).
pub const PHYSICAL_RANGES: [(&str, f64, f64, &str); 7] = [
    ("length", 1e-6, 1e4, "m"),
    ("youngs_modulus", 1e3, 1e13, "Pa"),
    ("density", 1.0, 1e6, "kg/m^3"),
    ("width", 1e-7, 1e3, "m"),
    ("height", 1e-7, 1e3, "m"),
    ("area", 1e-14, 1e6, "m^2"),
    ("second_moment", 1e-28, 1e12, "m^4"),
];

/// Every finite segment value outside its [`PHYSICAL_RANGES`] entry, in segment and field
/// order (non-finite and non-positive values are left to [`Beam::validate`]).
pub fn physical_range_problems(spec: &BeamSpec) -> Vec<InputError> {
    let mut out = vec![];
    for (s, seg) in spec.segments.iter().enumerate() {
        let values = [
            Some(seg.length),
            Some(seg.youngs_modulus),
            Some(seg.density),
            seg.width,
            seg.height,
            seg.area,
            seg.second_moment,
        ];
        for (value, &(field, min, max, unit)) in values.iter().zip(&PHYSICAL_RANGES) {
            if let Some(v) = *value {
                if v.is_finite() && v > 0.0 && !(min..=max).contains(&v) {
                    out.push(InputError::OutsidePhysicalRange {
                        entity: Entity::Segment(s),
                        field,
                        value: v,
                        min,
                        max,
                        unit,
                    });
                }
            }
        }
    }
    out
}

fn check_positive(
    errors: &mut Vec<InputError>,
    entity: Entity,
    field: &'static str,
    value: f64,
) -> bool {
    if !value.is_finite() {
        errors.push(InputError::NotFinite {
            entity,
            field,
            value,
        });
        false
    } else if value <= 0.0 {
        errors.push(InputError::NotPositive {
            entity,
            field,
            value,
        });
        false
    } else {
        true
    }
}

fn check_non_negative(
    errors: &mut Vec<InputError>,
    entity: Entity,
    field: &'static str,
    value: f64,
) -> bool {
    if !value.is_finite() {
        errors.push(InputError::NotFinite {
            entity,
            field,
            value,
        });
        false
    } else if value < 0.0 {
        errors.push(InputError::Negative {
            entity,
            field,
            value,
        });
        false
    } else {
        true
    }
}

fn check_finite(
    errors: &mut Vec<InputError>,
    entity: Entity,
    field: &'static str,
    value: f64,
) -> bool {
    if value.is_finite() {
        true
    } else {
        errors.push(InputError::NotFinite {
            entity,
            field,
            value,
        });
        false
    }
}

/// Checks that a segment whose values are each valid gives element matrices (38), (39) with
/// finite entries and normal (not zero or subnormal) diagonals, and finite element
/// frequencies (so finite `omega^2` of the whole beam, [`element::ELEMENT_EIGENVALUE_MAX`]):
/// absurd magnitudes (`density = 5e-324`, usually wrong units) are reported here instead of
/// producing non-finite matrices or frequencies later.
fn check_representable(
    errors: &mut Vec<InputError>,
    entity: Entity,
    seg: &SegmentSpec,
    area: f64,
    second_moment: f64,
) -> bool {
    let h = seg.length / seg.elements as f64;
    let fits = |m: &element::ElementMatrix| {
        m.iter().flatten().all(|v| v.is_finite()) && (0..4).all(|i| m[i][i].is_normal())
    };
    let bending = seg.youngs_modulus * second_moment;
    let mass = seg.density * area;
    let problem = if !fits(&element::mass_matrix(seg.density, area, h)) {
        Some(("density", seg.density, "element mass matrix (38)"))
    } else if !fits(&element::stiffness_matrix(
        seg.youngs_modulus,
        second_moment,
        h,
    )) {
        Some((
            "youngs_modulus",
            seg.youngs_modulus,
            "element stiffness matrix (39)",
        ))
    } else if !(element::ELEMENT_EIGENVALUE_MAX * bending / mass / h.powi(4)).is_finite() {
        Some(("density", seg.density, "element frequencies"))
    } else {
        None
    };
    match problem {
        Some((field, value, what)) => {
            errors.push(InputError::OutOfRange {
                entity,
                field,
                value,
                what,
            });
            false
        }
        None => true,
    }
}

fn check_time(errors: &mut Vec<InputError>, entity: Entity, time: &TimeFunction) {
    if time.is_random() {
        errors.push(InputError::Choice {
            entity,
            field: "time",
            message: "a random kind (white_noise, psd) drives an [[excitation]], not a beam load",
        });
        return;
    }
    for e in time.problems() {
        errors.push(match e {
            TimeFunctionError::NotFinite { field, value } => InputError::NotFinite {
                entity,
                field,
                value,
            },
            TimeFunctionError::Negative { field, value } => InputError::Negative {
                entity,
                field,
                value,
            },
            TimeFunctionError::EmptyTable => InputError::Choice {
                entity,
                field: "time",
                message: "a table needs at least one [t, value] point",
            },
            TimeFunctionError::NotIncreasing { .. } => InputError::Choice {
                entity,
                field: "time",
                message: "table times must increase strictly",
            },
            // Random kinds are refused above.
            TimeFunctionError::EmptyBand { .. }
            | TimeFunctionError::ShortPsdTable
            | TimeFunctionError::FrequenciesNotIncreasing { .. } => InputError::Choice {
                entity,
                field: "time",
                message: "not a load's time function",
            },
        });
    }
}

impl Beam {
    /// Validates and meshes a description; every problem is reported at once, as
    /// diagnostics without file or line (see [`from_toml_str`](Self::from_toml_str)).
    pub fn new(spec: &BeamSpec) -> Result<Self, BeamError> {
        Self::validate(spec).map_err(|errors| {
            BeamError::Input(Diagnostics(
                errors.iter().map(|e| e.to_diagnostic("", None)).collect(),
            ))
        })
    }

    /// [`Beam::new`] with every segment value also within its physical range
    /// ([`PHYSICAL_RANGES`]): the entry for user input (scenario files, `--set`).
    pub fn new_in_physical_range(spec: &BeamSpec) -> Result<Self, BeamError> {
        let mut problems = physical_range_problems(spec);
        match Self::validate(spec) {
            Ok(beam) if problems.is_empty() => return Ok(beam),
            Ok(_) => {}
            Err(errors) => {
                // A segment already blamed for a range is not blamed again for what that
                // value does to its matrices.
                let blamed: Vec<_> = problems.iter().map(|e| e.entity()).collect();
                problems.extend(errors.into_iter().filter(|e| {
                    !(matches!(e, InputError::OutOfRange { .. }) && blamed.contains(&e.entity()))
                }));
            }
        }
        Err(BeamError::Input(Diagnostics(
            problems.iter().map(|e| e.to_diagnostic("", None)).collect(),
        )))
    }

    /// Validates and meshes a description, returning every problem found as the typed
    /// cause (segments, supports, damping, loads, each in the order of the spec).
    pub fn validate(spec: &BeamSpec) -> Result<Self, Vec<InputError>> {
        Self::build(spec)
    }

    /// Parses and validates TOML text; errors name `origin` (the file name) and the line,
    /// in file order.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, BeamError> {
        let spec = BeamSpec::from_toml_str(text, origin)?;
        Self::build(&spec).map_err(|errors| {
            BeamError::Input(source::input_diagnostics(&errors, text, origin, &[]))
        })
    }

    /// Reads, parses and validates a TOML beam file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self, BeamError> {
        let path = path.as_ref();
        // A regular file within the size limit (a fifo or a device is refused, not read).
        let text = diagnostic::read_input(path, "beam file")
            .map_err(|d| BeamError::Input(diagnostic::Diagnostics::from(d)))?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    fn build(spec: &BeamSpec) -> Result<Self, Vec<InputError>> {
        let mut errors = Vec::new();
        if spec.segments.is_empty() {
            errors.push(InputError::NoSegments);
        }

        // Segments and mesh.
        let mut segments = Vec::with_capacity(spec.segments.len());
        let mut mesh_ok = !spec.segments.is_empty();
        let (mut x, mut first_element) = (0.0, 0);
        for (s, seg) in spec.segments.iter().enumerate() {
            let ent = Entity::Segment(s);
            let mut ok = check_positive(&mut errors, ent, "length", seg.length);
            ok &= check_positive(&mut errors, ent, "youngs_modulus", seg.youngs_modulus);
            ok &= check_positive(&mut errors, ent, "density", seg.density);
            if seg.elements == 0 {
                errors.push(InputError::NoElements { segment: s });
                ok = false;
            }
            if seg.elements > MAX_ELEMENTS || first_element + seg.elements > MAX_ELEMENTS {
                errors.push(InputError::TooManyElements {
                    segment: s,
                    got: seg.elements,
                    max: MAX_ELEMENTS,
                });
                ok = false;
            }
            let section = match (seg.area, seg.second_moment, seg.width, seg.height) {
                (Some(a), Some(i), None, None) => {
                    let ok_a = check_positive(&mut errors, ent, "area", a);
                    let ok_i = check_positive(&mut errors, ent, "second_moment", i);
                    (ok_a && ok_i).then_some((a, i))
                }
                (None, None, Some(b), Some(h)) => {
                    let ok_b = check_positive(&mut errors, ent, "width", b);
                    let ok_h = check_positive(&mut errors, ent, "height", h);
                    (ok_b && ok_h).then_some((b * h, b * h * h * h / 12.0))
                }
                (None, None, None, None) => {
                    errors.push(InputError::Choice {
                        entity: ent,
                        field: "length",
                        message: "no cross-section: give `area` and `second_moment`, or `width` and `height`",
                    });
                    None
                }
                (a, i, b, h) if (a.is_some() || i.is_some()) && (b.is_some() || h.is_some()) => {
                    errors.push(InputError::Choice {
                        entity: ent,
                        field: if a.is_some() { "area" } else { "second_moment" },
                        message: "cross-section given twice: give either `area` and `second_moment`, or `width` and `height`",
                    });
                    None
                }
                (a, _, None, None) => {
                    errors.push(InputError::Choice {
                        entity: ent,
                        field: if a.is_some() { "area" } else { "second_moment" },
                        message: "`area` and `second_moment` must be given together",
                    });
                    None
                }
                (_, _, b, _) => {
                    errors.push(InputError::Choice {
                        entity: ent,
                        field: if b.is_some() { "width" } else { "height" },
                        message: "`width` and `height` must be given together",
                    });
                    None
                }
            };
            match section {
                Some((area, second_moment))
                    if ok && check_representable(&mut errors, ent, seg, area, second_moment) =>
                {
                    segments.push(Segment {
                        length: seg.length,
                        youngs_modulus: seg.youngs_modulus,
                        density: seg.density,
                        area,
                        second_moment,
                        elements: seg.elements,
                        x_start: x,
                        first_element,
                    });
                    x += seg.length;
                    first_element += seg.elements;
                }
                _ => mesh_ok = false,
            }
        }

        let (mut elements, mut node_x) = (Vec::new(), Vec::new());
        if mesh_ok {
            node_x.reserve(first_element + 1);
            node_x.push(0.0);
            for (s, seg) in segments.iter().enumerate() {
                let h = seg.element_length();
                for e in 0..seg.elements {
                    elements.push(Element {
                        segment: s,
                        x_start: seg.x_start + e as f64 * h,
                        length: h,
                    });
                    // The segment's last node is placed at its exact end, so segment
                    // boundaries do not accumulate rounding.
                    node_x.push(if e + 1 == seg.elements {
                        seg.x_start + seg.length
                    } else {
                        seg.x_start + (e + 1) as f64 * h
                    });
                }
            }
        }
        let nodes = node_x.len();
        let total_length = segments.iter().map(|s| s.length).sum::<f64>();

        // Resolves `node` / `x` to a node index (only when the mesh is valid).
        let resolve = |errors: &mut Vec<InputError>,
                       ent: Entity,
                       node: Option<usize>,
                       x: Option<f64>|
         -> Option<usize> {
            match (node, x) {
                (Some(_), Some(_)) => {
                    errors.push(InputError::Choice {
                        entity: ent,
                        field: "node",
                        message: "give either `node` or `x`, not both",
                    });
                    None
                }
                (None, None) => {
                    errors.push(InputError::Choice {
                        entity: ent,
                        field: "node",
                        message: "no position: give `node` or `x`",
                    });
                    None
                }
                (Some(n), None) => {
                    if !mesh_ok {
                        None
                    } else if n >= nodes {
                        errors.push(InputError::NodeOutOfRange {
                            entity: ent,
                            node: n,
                            nodes,
                        });
                        None
                    } else {
                        Some(n)
                    }
                }
                (None, Some(x)) => {
                    if !check_finite(errors, ent, "x", x) || !mesh_ok {
                        return None;
                    }
                    let i = node_x.partition_point(|&xn| xn < x);
                    let nearest = if i == 0 {
                        0
                    } else if i >= nodes || (x - node_x[i - 1]) <= (node_x[i] - x) {
                        i - 1
                    } else {
                        i
                    };
                    if (node_x[nearest] - x).abs() <= NODE_TOLERANCE * total_length {
                        Some(nearest)
                    } else {
                        errors.push(InputError::NotAtNode {
                            entity: ent,
                            x,
                            nearest,
                            nearest_x: node_x[nearest],
                        });
                        None
                    }
                }
            }
        };

        // Supports.
        let mut locked = vec![[false; 2]; nodes];
        for (k, sup) in spec.supports.iter().enumerate() {
            let ent = Entity::Support(k);
            let node = resolve(&mut errors, ent, sup.node, sup.x);
            let dofs: Option<Vec<Dof>> = match (&sup.kind, &sup.locked) {
                (Some(kind), None) => Some(kind.locked().to_vec()),
                (None, Some(list)) => Some(list.clone()),
                (Some(_), Some(_)) => {
                    errors.push(InputError::Choice {
                        entity: ent,
                        field: "kind",
                        message: "give either `kind` or `locked`, not both",
                    });
                    None
                }
                (None, None) => {
                    errors.push(InputError::Choice {
                        entity: ent,
                        field: "node",
                        message: "no support type: give `kind` (clamped, pinned, free) or `locked` (a list of transverse, rotation)",
                    });
                    None
                }
            };
            if let (Some(n), Some(dofs)) = (node, dofs) {
                for d in dofs {
                    locked[n][d.offset()] = true;
                }
            }
        }

        // Damping.
        let damping = match &spec.damping {
            None => Damping::Rayleigh {
                alpha: 0.0,
                beta: 0.0,
            },
            Some(d) => {
                let ent = Entity::Damping;
                match (&d.ratios, d.alpha, d.beta) {
                    (Some(_), Some(_), _) | (Some(_), _, Some(_)) => {
                        errors.push(InputError::Choice {
                            entity: ent,
                            field: "ratios",
                            message: "give either `alpha`/`beta` or `ratios`, not both",
                        });
                        Damping::Rayleigh {
                            alpha: 0.0,
                            beta: 0.0,
                        }
                    }
                    (None, alpha, beta) => {
                        let (alpha, beta) = (alpha.unwrap_or(0.0), beta.unwrap_or(0.0));
                        check_non_negative(&mut errors, ent, "alpha", alpha);
                        check_non_negative(&mut errors, ent, "beta", beta);
                        Damping::Rayleigh { alpha, beta }
                    }
                    (Some(r), None, None) => {
                        if r.len() != 2 {
                            errors.push(InputError::RatioCount { got: r.len() });
                            Damping::Rayleigh {
                                alpha: 0.0,
                                beta: 0.0,
                            }
                        } else {
                            for (i, m) in r.iter().enumerate() {
                                if m.mode == 0 {
                                    errors.push(InputError::ModeZero { index: i });
                                }
                                check_non_negative(
                                    &mut errors,
                                    ent,
                                    if i == 0 {
                                        "ratios[0].ratio"
                                    } else {
                                        "ratios[1].ratio"
                                    },
                                    m.ratio,
                                );
                            }
                            if r[0].mode == r[1].mode && r[0].mode != 0 {
                                errors.push(InputError::SameMode { mode: r[0].mode });
                            }
                            Damping::ModalRatios {
                                modes: [r[0].mode, r[1].mode],
                                ratios: [r[0].ratio, r[1].ratio],
                            }
                        }
                    }
                }
            }
        };

        // Loads.
        let mut nodal_loads = Vec::new();
        for (k, l) in spec.loads.iter().enumerate() {
            let ent = Entity::Load(k);
            let node = resolve(&mut errors, ent, l.node, l.x);
            let ok = check_finite(&mut errors, ent, "force", l.force)
                & check_finite(&mut errors, ent, "moment", l.moment);
            check_time(&mut errors, ent, &l.time);
            if let (Some(node), true) = (node, ok) {
                nodal_loads.push(NodalLoad {
                    node,
                    force: l.force,
                    moment: l.moment,
                    time: l.time.clone(),
                });
            }
        }
        let mut distributed_loads = Vec::new();
        for (k, l) in spec.distributed_loads.iter().enumerate() {
            let ent = Entity::DistributedLoad(k);
            if l.segment >= spec.segments.len() {
                errors.push(InputError::SegmentOutOfRange {
                    entity: ent,
                    segment: l.segment,
                    segments: spec.segments.len(),
                });
            }
            check_finite(&mut errors, ent, "q", l.q);
            check_time(&mut errors, ent, &l.time);
            distributed_loads.push(DistributedLoad {
                segment: l.segment,
                q: l.q,
                time: l.time.clone(),
            });
        }

        if errors.is_empty() {
            Ok(Self {
                name: spec.name.clone(),
                segments,
                elements,
                node_x,
                locked,
                damping,
                nodal_loads,
                distributed_loads,
            })
        } else {
            Err(errors)
        }
    }

    /// The name given in the description.
    pub fn name(&self) -> Option<&str> {
        self.name.as_deref()
    }

    /// The segments, in order along x.
    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// The elements, in order along x (element `e` joins nodes `e` and `e + 1`).
    pub fn elements(&self) -> &[Element] {
        &self.elements
    }

    /// Number of nodes (elements + 1).
    pub fn node_count(&self) -> usize {
        self.node_x.len()
    }

    /// Node positions along x, m.
    pub fn node_positions(&self) -> &[f64] {
        &self.node_x
    }

    /// Total length, m.
    pub fn length(&self) -> f64 {
        *self.node_x.last().unwrap_or(&0.0)
    }

    /// Whether a DOF of a node is locked (false for a node that does not exist).
    pub fn is_locked(&self, node: usize, dof: Dof) -> bool {
        self.locked.get(node).is_some_and(|l| l[dof.offset()])
    }

    /// The damping specification.
    pub fn damping(&self) -> Damping {
        self.damping
    }

    /// The nodal loads.
    pub fn nodal_loads(&self) -> &[NodalLoad] {
        &self.nodal_loads
    }

    /// The distributed loads.
    pub fn distributed_loads(&self) -> &[DistributedLoad] {
        &self.distributed_loads
    }

    /// The node at position `x` (within a rounding tolerance of 1e-9 L), if any.
    pub fn node_at(&self, x: f64) -> Option<usize> {
        let tol = NODE_TOLERANCE * self.length();
        let i = self.node_x.partition_point(|&xn| xn < x - tol);
        (i < self.node_x.len() && (self.node_x[i] - x).abs() <= tol).then_some(i)
    }

    /// The rigid-body motions the supports leave free, as full-length DOF vectors
    /// (`w = a + b x`, `theta = b`): none when the beam is held, one (a translation, or a
    /// rotation about the only transversely locked node) or two (free–free).
    pub fn rigid_body_motions(&self) -> Vec<Vec<f64>> {
        let any_rotation_locked = self.locked.iter().any(|l| l[1]);
        let w_locked: Vec<usize> = (0..self.node_count())
            .filter(|&n| self.locked[n][0])
            .collect();
        let translation = || {
            let mut v = vec![0.0; 2 * self.node_count()];
            (0..self.node_count()).for_each(|n| v[2 * n] = 1.0);
            v
        };
        let rotation_about = |x0: f64| {
            let mut v = vec![0.0; 2 * self.node_count()];
            for (n, &x) in self.node_x.iter().enumerate() {
                v[2 * n] = x - x0;
                v[2 * n + 1] = 1.0;
            }
            v
        };
        match (any_rotation_locked, w_locked.len()) {
            (true, 0) => vec![translation()],
            (true, _) => vec![],
            (false, 0) => vec![translation(), rotation_about(0.5 * self.length())],
            // Locked nodes are distinct, hence at distinct positions: two or more pin it.
            (false, 1) => vec![rotation_about(self.node_x[w_locked[0]])],
            (false, _) => vec![],
        }
    }

    /// Support kind at a node when it is one of the standard ones (for reports).
    pub fn support_kind(&self, node: usize) -> Option<SupportKind> {
        match self.locked.get(node)? {
            [true, true] => Some(SupportKind::Clamped),
            [true, false] => Some(SupportKind::Pinned),
            [false, false] => Some(SupportKind::Free),
            [false, true] => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::{
        DampingSpec, DistributedLoadSpec, ModalRatioSpec, NodalLoadSpec, SupportSpec,
    };

    fn seg(len: f64, n: usize) -> SegmentSpec {
        SegmentSpec::with_section(len, 2e11, 7800.0, 1e-4, 1e-9, n)
    }

    #[test]
    fn meshes_segments_with_exact_boundaries() {
        let spec = BeamSpec {
            segments: vec![seg(0.3, 3), seg(0.7, 7)],
            ..Default::default()
        };
        let b = Beam::new(&spec).unwrap();
        assert_eq!(b.node_count(), 11);
        assert_eq!(b.node_positions()[3], 0.3);
        assert_eq!(b.length(), 0.3 + 0.7);
        assert_eq!(b.elements()[3].segment, 1);
        assert_eq!(b.node_at(0.5), Some(5));
        assert_eq!(b.node_at(0.55), None);
    }

    #[test]
    fn rectangle_section() {
        let spec = BeamSpec {
            segments: vec![SegmentSpec::rectangular(
                1.0, 2.1e11, 7850.0, 0.04, 0.008, 4,
            )],
            ..Default::default()
        };
        let b = Beam::new(&spec).unwrap();
        let s = &b.segments()[0];
        assert_eq!(s.area, 0.04 * 0.008);
        assert!((s.second_moment - 0.04 * 0.008f64.powi(3) / 12.0).abs() < 1e-24);
    }

    #[test]
    fn every_problem_is_reported_at_once() {
        let mut bad = seg(-1.0, 0);
        bad.density = f64::NAN;
        bad.width = Some(0.1);
        let spec = BeamSpec {
            segments: vec![seg(1.0, 2), bad],
            supports: vec![SupportSpec {
                node: Some(0),
                x: Some(0.0),
                kind: Some(SupportKind::Clamped),
                locked: None,
            }],
            damping: Some(DampingSpec {
                alpha: Some(-1.0),
                beta: None,
                ratios: None,
            }),
            loads: vec![NodalLoadSpec {
                x: Some(0.2),
                force: f64::INFINITY,
                ..Default::default()
            }],
            distributed_loads: vec![DistributedLoadSpec {
                segment: 5,
                q: 1.0,
                time: TimeFunction::Constant,
            }],
            ..Default::default()
        };
        let errors = Beam::validate(&spec).unwrap_err();
        let msgs: Vec<String> = errors.iter().map(|e| e.to_string()).collect();
        let expect = [
            "segment 1: length must be positive (got -1)",
            "segment 1: density must be a finite number (got NaN)",
            "segment 1: elements must be at least 1 (got 0)",
            "segment 1: cross-section given twice",
            "support 0: give either `node` or `x`, not both",
            "damping: alpha must not be negative (got -1)",
            "load 0: force must be a finite number (got inf)",
            "distributed_load 0: segment 5 does not exist (the beam has 2 segments)",
        ];
        for e in expect {
            assert!(
                msgs.iter().any(|m| m.starts_with(e)),
                "missing {e:?} in {msgs:#?}"
            );
        }
    }

    #[test]
    fn positions_must_be_nodes() {
        let spec = BeamSpec {
            segments: vec![seg(1.0, 4)],
            supports: vec![
                SupportSpec::at_x(0.3, SupportKind::Pinned),
                SupportSpec::at_node(9, SupportKind::Pinned),
            ],
            ..Default::default()
        };
        let msg = Beam::new(&spec).unwrap_err().to_string();
        assert!(
            msg.contains("support 0: x = 0.3 is not at a node (nearest is node 1 at x = 0.25)"),
            "{msg}"
        );
        assert!(
            msg.contains("support 1: node 9 does not exist (the beam has 5 nodes, 0 to 4)"),
            "{msg}"
        );
    }

    #[test]
    fn modal_ratio_checks() {
        let mk = |ratios: Vec<ModalRatioSpec>| BeamSpec {
            segments: vec![seg(1.0, 4)],
            damping: Some(DampingSpec {
                ratios: Some(ratios),
                ..Default::default()
            }),
            ..Default::default()
        };
        let one = ModalRatioSpec {
            mode: 1,
            ratio: 0.01,
        };
        assert!(
            Beam::new(&mk(vec![one]))
                .unwrap_err()
                .to_string()
                .contains("exactly two entries")
        );
        assert!(
            Beam::new(&mk(vec![one, one]))
                .unwrap_err()
                .to_string()
                .contains("mode 1 twice")
        );
        let zero = ModalRatioSpec {
            mode: 0,
            ratio: -0.1,
        };
        let msg = Beam::new(&mk(vec![one, zero])).unwrap_err().to_string();
        assert!(
            msg.contains("ratios[1]: mode numbers start at 1")
                && msg.contains("ratios[1].ratio must not be negative"),
            "{msg}"
        );
    }

    #[test]
    fn rigid_body_motions_follow_the_supports() {
        let with = |supports: Vec<SupportSpec>| {
            Beam::new(&BeamSpec {
                segments: vec![seg(1.0, 4)],
                supports,
                ..Default::default()
            })
            .unwrap()
            .rigid_body_motions()
            .len()
        };
        assert_eq!(with(vec![]), 2);
        assert_eq!(with(vec![SupportSpec::at_node(2, SupportKind::Pinned)]), 1);
        assert_eq!(
            with(vec![SupportSpec::locked_at_node(2, &[Dof::Rotation])]),
            1
        );
        assert_eq!(with(vec![SupportSpec::at_node(0, SupportKind::Clamped)]), 0);
        assert_eq!(
            with(vec![
                SupportSpec::at_node(0, SupportKind::Pinned),
                SupportSpec::at_node(3, SupportKind::Pinned)
            ]),
            0
        );
        assert_eq!(with(vec![SupportSpec::at_node(0, SupportKind::Free)]), 2);
    }

    #[test]
    fn absurd_magnitudes_are_rejected_not_turned_into_infinities() {
        let check = |seg: SegmentSpec, expect: &str| {
            let errors = Beam::validate(&BeamSpec {
                segments: vec![seg],
                ..Default::default()
            })
            .unwrap_err();
            assert_eq!(errors.len(), 1, "{errors:?}");
            assert!(errors[0].to_string().starts_with(expect), "{errors:?}");
        };
        let steel = |e: f64, rho: f64, a: f64, i: f64, n: usize| {
            SegmentSpec::with_section(1.0, e, rho, a, i, n)
        };
        // rho A l underflows to zero: a zero mass matrix, infinite frequencies.
        check(
            SegmentSpec::rectangular(1.0, 210e9, 5e-324, 0.04, 0.008, 20),
            "segment 0: density = 5e-324 puts the element mass matrix (38) out of",
        );
        check(
            steel(1e308, 7850.0, 1.0, 10.0, 1),
            "segment 0: youngs_modulus = 1e308 puts the element stiffness matrix (39) out of",
        );
        // Both matrices representable, their ratio omega^2 is not.
        check(
            steel(1e300, 1e-20, 1.0, 1e-9, 1),
            "segment 0: density = 1e-20 puts the element frequencies out of",
        );
        // Extreme but representable values stay accepted.
        assert!(
            Beam::new(&BeamSpec {
                segments: vec![steel(1e-3, 1e-3, 1e-6, 1e-12, 1000)],
                ..Default::default()
            })
            .is_ok()
        );
    }
}
