//! The beam description as written in TOML (serde types), before validation.
//!
//! ```toml
//! name = "damper cantilever"
//!
//! [[segment]]              # straight segments along x, in order from x = 0
//! length = 1.0             # m
//! youngs_modulus = 210e9   # Pa
//! density = 7850.0         # kg/m^3
//! width = 0.040            # rectangular b x h section (I = b h^3 / 12, bending across h) ...
//! height = 0.008
//! # area = 3.2e-4          # ... or area (m^2) and second_moment (m^4)
//! # second_moment = 1.7067e-9
//! elements = 20
//!
//! [[support]]
//! x = 0.0                  # or node = 0
//! kind = "clamped"         # "clamped" | "pinned" | "free", or locked = ["transverse", "rotation"]
//!
//! [damping]                # Rayleigh damping, eq. (40); omitted = undamped
//! alpha = 0.1              # 1/s
//! beta = 1e-5              # s
//! # or target modal damping ratios on two modes (numbered from 1, counting rigid modes):
//! # ratios = [{ mode = 1, ratio = 0.01 }, { mode = 2, ratio = 0.01 }]
//!
//! [[load]]                 # nodal force (N) and moment (N m); time = constant by default
//! x = 1.0
//! force = -10.0
//! time = { kind = "harmonic", frequency_hz = 6.5, phase = 0.0 }   # or { kind = "step", at = 0.1 }
//! # random kinds (see `random`): { kind = "white_noise", psd = 1e-4, band = [1.0, 50.0] }
//! # or { kind = "psd", table = [[1.0, 1e-4], [50.0, 1e-5]] }, optional seed = 7
//!
//! [[distributed_load]]     # uniform transverse load on a segment, N/m (consistent nodal loads)
//! segment = 0
//! q = -5.0
//! ```
//!
//! Unknown fields are rejected (a typo is an error, not a silently ignored value). The types
//! implement `Serialize` as well, so a description round-trips and can be embedded in a
//! larger file (the scenario files of the coupled simulation).

use serde::{Deserialize, Serialize};

use crate::error::BeamError;
use crate::source;

/// A whole beam description.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BeamSpec {
    /// Optional name, for reports.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Segments along x from x = 0, in order (`[[segment]]`).
    #[serde(rename = "segment", default, skip_serializing_if = "Vec::is_empty")]
    pub segments: Vec<SegmentSpec>,
    /// Supports (`[[support]]`). No support: a free–free beam.
    #[serde(rename = "support", default, skip_serializing_if = "Vec::is_empty")]
    pub supports: Vec<SupportSpec>,
    /// Rayleigh damping (`[damping]`). Omitted: undamped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping: Option<DampingSpec>,
    /// Nodal loads (`[[load]]`).
    #[serde(rename = "load", default, skip_serializing_if = "Vec::is_empty")]
    pub loads: Vec<NodalLoadSpec>,
    /// Uniformly distributed loads on segments (`[[distributed_load]]`).
    #[serde(
        rename = "distributed_load",
        default,
        skip_serializing_if = "Vec::is_empty"
    )]
    pub distributed_loads: Vec<DistributedLoadSpec>,
}

/// A straight prismatic segment, meshed into equal elements.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SegmentSpec {
    /// Length, m.
    pub length: f64,
    /// Young's modulus E, Pa.
    pub youngs_modulus: f64,
    /// Density rho, kg/m^3.
    pub density: f64,
    /// Number of elements.
    pub elements: usize,
    /// Cross-section area F, m^2 (with `second_moment`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub area: Option<f64>,
    /// Second moment of area J about the bending axis, m^4 (with `area`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub second_moment: Option<f64>,
    /// Width b of a rectangular section, m (with `height`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width: Option<f64>,
    /// Height h of a rectangular section (in the bending direction), m (with `width`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height: Option<f64>,
}

impl SegmentSpec {
    /// A segment with a rectangular `width x height` section.
    pub fn rectangular(
        length: f64,
        youngs_modulus: f64,
        density: f64,
        width: f64,
        height: f64,
        elements: usize,
    ) -> Self {
        Self {
            length,
            youngs_modulus,
            density,
            elements,
            width: Some(width),
            height: Some(height),
            ..Self::default()
        }
    }

    /// A segment with a given area and second moment of area.
    pub fn with_section(
        length: f64,
        youngs_modulus: f64,
        density: f64,
        area: f64,
        second_moment: f64,
        elements: usize,
    ) -> Self {
        Self {
            length,
            youngs_modulus,
            density,
            elements,
            area: Some(area),
            second_moment: Some(second_moment),
            ..Self::default()
        }
    }
}

/// A degree of freedom of a node (two per node, eq. 26).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Dof {
    /// Transverse displacement q_2 (along y), m.
    Transverse,
    /// Rotation q_6 of the cross-section (about z), rad.
    Rotation,
}

impl Dof {
    /// 0 for the transverse displacement, 1 for the rotation (position within a node).
    pub fn offset(self) -> usize {
        match self {
            Dof::Transverse => 0,
            Dof::Rotation => 1,
        }
    }
}

/// Standard support kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SupportKind {
    /// Displacement and rotation locked.
    Clamped,
    /// Displacement locked, rotation free.
    Pinned,
    /// Nothing locked (explicitly free end).
    Free,
}

impl SupportKind {
    /// The locked DOFs.
    pub fn locked(self) -> &'static [Dof] {
        match self {
            SupportKind::Clamped => &[Dof::Transverse, Dof::Rotation],
            SupportKind::Pinned => &[Dof::Transverse],
            SupportKind::Free => &[],
        }
    }
}

/// A support at one node: where (`node` or `x`) and what (`kind` or `locked`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SupportSpec {
    /// Node index (0 at x = 0), or
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<usize>,
    /// position along the beam (must coincide with a node), m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<f64>,
    /// A standard kind, or
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kind: Option<SupportKind>,
    /// any set of locked DOFs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub locked: Option<Vec<Dof>>,
}

impl SupportSpec {
    /// A support of the given kind at a node.
    pub fn at_node(node: usize, kind: SupportKind) -> Self {
        Self {
            node: Some(node),
            kind: Some(kind),
            ..Self::default()
        }
    }

    /// A support of the given kind at position `x`.
    pub fn at_x(x: f64, kind: SupportKind) -> Self {
        Self {
            x: Some(x),
            kind: Some(kind),
            ..Self::default()
        }
    }

    /// Locks the given DOFs at a node.
    pub fn locked_at_node(node: usize, locked: &[Dof]) -> Self {
        Self {
            node: Some(node),
            locked: Some(locked.to_vec()),
            ..Self::default()
        }
    }
}

/// Rayleigh damping `B = alpha A + beta C` (40): either the coefficients or two target modal
/// damping ratios (then `zeta_i = alpha / (2 omega_i) + beta omega_i / 2` is solved for
/// alpha and beta).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DampingSpec {
    /// Mass-proportional coefficient, 1/s (default 0 when `beta` is given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f64>,
    /// Stiffness-proportional coefficient, s (default 0 when `alpha` is given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beta: Option<f64>,
    /// Two target modal damping ratios (instead of alpha and beta).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ratios: Option<Vec<ModalRatioSpec>>,
}

/// A target damping ratio for one mode.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModalRatioSpec {
    /// Mode number, from 1 in ascending frequency (rigid-body modes count).
    pub mode: usize,
    /// Damping ratio (fraction of critical), e.g. 0.01.
    pub ratio: f64,
}

/// Time dependence of a load: the load is `value * f(t)`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TimeFunction {
    /// `f(t) = 1`.
    #[default]
    Constant,
    /// `f(t) = sin(2 pi frequency_hz t + phase)`.
    Harmonic {
        /// Frequency, Hz.
        frequency_hz: f64,
        /// Phase, rad.
        #[serde(default)]
        phase: f64,
    },
    /// `f(t) = 0` for `t < at`, `1` from `at` on.
    Step {
        /// Switch-on time, s.
        at: f64,
    },
    /// Piecewise linear through `[t, value]` points (times strictly increasing), held at
    /// the first value before the first time and at the last value after the last time
    /// (`points = [[0.0, 0.0], [0.1, 1.0]]`: a ramp to 1 over 0.1 s).
    Table {
        /// `[t (s), value]` points.
        points: Vec<[f64; 2]>,
    },
    /// Band-limited Gaussian white noise: one-sided PSD `G = psd` per Hz (N²/Hz for a
    /// force) on `band = [f1, f2]` (Hz), zero outside ([`crate::random`]). The level is in
    /// the PSD: the excitation has no amplitude.
    WhiteNoise {
        /// One-sided PSD `G` per Hz (the excitation's unit squared per Hz).
        psd: f64,
        /// `[f1, f2]` (Hz), `0 <= f1 < f2`.
        band: [f64; 2],
        /// Seed of the time-domain realisation (a fixed default when omitted).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        seed: Option<u64>,
    },
    /// A Gaussian random signal of one-sided PSD `G(f)` per Hz, piecewise linear through
    /// `table = [[f (Hz), G], ...]` (frequencies strictly increasing), zero outside.
    Psd {
        /// `[f (Hz), G (unit²/Hz)]` points.
        table: Vec<[f64; 2]>,
        /// Seed of the time-domain realisation (a fixed default when omitted).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        seed: Option<u64>,
    },
    /// A realisation of a random kind sampled on a uniform grid, periodic
    /// ([`crate::random::realise`], made by the setup stage of a run; never read from a file).
    #[serde(skip)]
    Sampled(crate::random::Samples),
}

/// Why a [`TimeFunction`] cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TimeFunctionError {
    /// A value that must be finite is not.
    #[error("{field} = {value} is not finite")]
    NotFinite {
        /// The field (`time.frequency_hz`, `time.points`, ...).
        field: &'static str,
        /// The value.
        value: f64,
    },
    /// A value that must not be negative is.
    #[error("{field} = {value} must not be negative")]
    Negative {
        /// The field.
        field: &'static str,
        /// The value.
        value: f64,
    },
    /// A table without points.
    #[error("a table needs at least one [t, value] point")]
    EmptyTable,
    /// A white-noise band whose upper end is not above its lower end.
    #[error("time.band = [{f1}, {f2}]: the upper frequency must be above the lower one")]
    EmptyBand {
        /// Lower end (Hz).
        f1: f64,
        /// Upper end (Hz).
        f2: f64,
    },
    /// A PSD table with fewer than two points.
    #[error("a PSD table needs at least two [f, G] points")]
    ShortPsdTable,
    /// A PSD table whose frequencies do not increase strictly.
    #[error(
        "PSD table frequencies must increase strictly: point {index} (f = {f}) does not come after f = {previous}"
    )]
    FrequenciesNotIncreasing {
        /// Index of the offending point (0-based).
        index: usize,
        /// Its frequency.
        f: f64,
        /// The frequency of the point before it.
        previous: f64,
    },
    /// A table whose times do not increase strictly.
    #[error(
        "table times must increase strictly: point {index} (t = {t}) does not come after t = {previous}"
    )]
    NotIncreasing {
        /// Index of the offending point (0-based).
        index: usize,
        /// Its time.
        t: f64,
        /// The time of the point before it.
        previous: f64,
    },
}

impl TimeFunction {
    /// `f(t)`.
    pub fn value(&self, t: f64) -> f64 {
        match self {
            TimeFunction::Constant => 1.0,
            TimeFunction::Harmonic {
                frequency_hz,
                phase,
            } => (2.0 * std::f64::consts::PI * frequency_hz * t + phase).sin(),
            TimeFunction::Step { at } => {
                if t >= *at {
                    1.0
                } else {
                    0.0
                }
            }
            TimeFunction::Table { points } => table_value(points, t),
            // Not realised yet (the linear analyses read the PSD): no deterministic value.
            TimeFunction::WhiteNoise { .. } | TimeFunction::Psd { .. } => 0.0,
            TimeFunction::Sampled(s) => s.value(t),
        }
    }

    /// Whether this is a random kind (`white_noise`, `psd`, or a realisation of one).
    pub fn is_random(&self) -> bool {
        matches!(
            self,
            TimeFunction::WhiteNoise { .. } | TimeFunction::Psd { .. } | TimeFunction::Sampled(_)
        )
    }

    /// The one-sided PSD `G(f)` per Hz at `f` (Hz) of a random kind (zero outside its band or
    /// table; piecewise linear in a table); `None` for the deterministic kinds and for a
    /// realisation.
    pub fn psd(&self, f: f64) -> Option<f64> {
        match self {
            TimeFunction::WhiteNoise { psd, band, .. } => Some(if f >= band[0] && f <= band[1] {
                *psd
            } else {
                0.0
            }),
            TimeFunction::Psd { table, .. } => Some(crate::random::table_psd(table, f)),
            _ => None,
        }
    }

    /// The written seed of a random kind.
    pub fn seed(&self) -> Option<u64> {
        match self {
            TimeFunction::WhiteNoise { seed, .. } | TimeFunction::Psd { seed, .. } => *seed,
            _ => None,
        }
    }

    /// Every problem of the function's values (the one check of a time function, used by
    /// the beam's validation and by every other user of the type).
    pub fn problems(&self) -> Vec<TimeFunctionError> {
        let mut out = vec![];
        match self {
            TimeFunction::Constant => {}
            TimeFunction::Harmonic {
                frequency_hz,
                phase,
            } => {
                if !frequency_hz.is_finite() {
                    out.push(TimeFunctionError::NotFinite {
                        field: "time.frequency_hz",
                        value: *frequency_hz,
                    });
                } else if *frequency_hz < 0.0 {
                    out.push(TimeFunctionError::Negative {
                        field: "time.frequency_hz",
                        value: *frequency_hz,
                    });
                }
                if !phase.is_finite() {
                    out.push(TimeFunctionError::NotFinite {
                        field: "time.phase",
                        value: *phase,
                    });
                }
            }
            TimeFunction::Step { at } => {
                if !at.is_finite() {
                    out.push(TimeFunctionError::NotFinite {
                        field: "time.at",
                        value: *at,
                    });
                }
            }
            TimeFunction::Table { points } => {
                if points.is_empty() {
                    out.push(TimeFunctionError::EmptyTable);
                }
                if let Some(&v) = points.iter().flatten().find(|v| !v.is_finite()) {
                    out.push(TimeFunctionError::NotFinite {
                        field: "time.points",
                        value: v,
                    });
                } else if let Some(k) =
                    (1..points.len()).find(|&k| points[k][0] <= points[k - 1][0])
                {
                    out.push(TimeFunctionError::NotIncreasing {
                        index: k,
                        t: points[k][0],
                        previous: points[k - 1][0],
                    });
                }
            }
            TimeFunction::WhiteNoise { psd, band, .. } => {
                if !psd.is_finite() {
                    out.push(TimeFunctionError::NotFinite {
                        field: "time.psd",
                        value: *psd,
                    });
                } else if *psd < 0.0 {
                    out.push(TimeFunctionError::Negative {
                        field: "time.psd",
                        value: *psd,
                    });
                }
                if let Some(&v) = band.iter().find(|v| !v.is_finite()) {
                    out.push(TimeFunctionError::NotFinite {
                        field: "time.band",
                        value: v,
                    });
                } else if band[0] < 0.0 {
                    out.push(TimeFunctionError::Negative {
                        field: "time.band",
                        value: band[0],
                    });
                } else if band[1] <= band[0] {
                    out.push(TimeFunctionError::EmptyBand {
                        f1: band[0],
                        f2: band[1],
                    });
                }
            }
            TimeFunction::Psd { table, .. } => {
                if table.len() < 2 {
                    out.push(TimeFunctionError::ShortPsdTable);
                }
                if let Some(&v) = table.iter().flatten().find(|v| !v.is_finite()) {
                    out.push(TimeFunctionError::NotFinite {
                        field: "time.table",
                        value: v,
                    });
                } else if let Some(&[f, g]) = table.iter().find(|p| p[0] < 0.0 || p[1] < 0.0) {
                    out.push(TimeFunctionError::Negative {
                        field: "time.table",
                        value: if f < 0.0 { f } else { g },
                    });
                } else if let Some(k) = (1..table.len()).find(|&k| table[k][0] <= table[k - 1][0]) {
                    out.push(TimeFunctionError::FrequenciesNotIncreasing {
                        index: k,
                        f: table[k][0],
                        previous: table[k - 1][0],
                    });
                }
            }
            TimeFunction::Sampled(_) => {}
        }
        out
    }
}

/// Piecewise-linear interpolation in a table with strictly increasing times, held constant
/// outside (binary search: `O(log n)` a call).
fn table_value(points: &[[f64; 2]], t: f64) -> f64 {
    let (Some(first), Some(last)) = (points.first(), points.last()) else {
        return 0.0;
    };
    if t <= first[0] {
        return first[1];
    }
    if t >= last[0] {
        return last[1];
    }
    // First point with time > t; 1 <= k <= len - 1 here.
    let k = points.partition_point(|p| p[0] <= t);
    let ([t0, v0], [t1, v1]) = (points[k - 1], points[k]);
    v0 + (v1 - v0) * (t - t0) / (t1 - t0)
}

/// A nodal force and moment (27), at a node given by index or position.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodalLoadSpec {
    /// Node index, or
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<usize>,
    /// position (must coincide with a node), m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<f64>,
    /// Transverse force P_2, N.
    #[serde(default)]
    pub force: f64,
    /// Moment P_6, N m.
    #[serde(default)]
    pub moment: f64,
    /// Time dependence (constant by default).
    #[serde(default)]
    pub time: TimeFunction,
}

/// A uniformly distributed transverse load on one segment, turned into consistent nodal
/// loads element by element.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DistributedLoadSpec {
    /// Segment index (0-based).
    pub segment: usize,
    /// Load per unit length, N/m (positive along +y).
    pub q: f64,
    /// Time dependence (constant by default).
    #[serde(default)]
    pub time: TimeFunction,
}

impl BeamSpec {
    /// Parses TOML text. `origin` (usually the file name) names the file in the
    /// diagnostic, which carries the line and column of the problem.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, BeamError> {
        toml::from_str(text)
            .map_err(|e| BeamError::Input(source::parse_diagnostic(&e, text, origin).into()))
    }

    /// Serialises to TOML text.
    pub fn to_toml_string(&self) -> Result<String, toml::ser::Error> {
        toml::to_string(self)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A beam file using every table (shared with the source-map tests).
    pub(crate) const SAMPLE: &str = r#"
name = "x"

[[segment]]
length = 1.0
youngs_modulus = 2e11
density = 7800.0
width = 0.04
height = 0.008
elements = 4

[[segment]]
length = 0.5
youngs_modulus = 2e11
density = 7800.0
area = 1e-4
second_moment = 1e-9
elements = 2

[[support]]
node = 0
kind = "clamped"

[[support]]
x = 1.5
locked = ["transverse"]

[damping]
ratios = [{ mode = 1, ratio = 0.01 }, { mode = 2, ratio = 0.02 }]

[[load]]
x = 1.0
force = -3.0
time = { kind = "harmonic", frequency_hz = 5.0 }

[[distributed_load]]
segment = 1
q = 2.0
time = { kind = "step", at = 0.5 }
"#;

    #[test]
    fn parses_every_table() {
        let s = BeamSpec::from_toml_str(SAMPLE, "t.toml").unwrap();
        assert_eq!(s.segments.len(), 2);
        assert_eq!(s.segments[0].width, Some(0.04));
        assert_eq!(
            s.supports[1].locked.as_deref(),
            Some(&[Dof::Transverse][..])
        );
        assert_eq!(
            s.damping.as_ref().unwrap().ratios.as_ref().unwrap()[1],
            ModalRatioSpec {
                mode: 2,
                ratio: 0.02
            }
        );
        assert_eq!(
            s.loads[0].time,
            TimeFunction::Harmonic {
                frequency_hz: 5.0,
                phase: 0.0
            }
        );
        assert_eq!(s.distributed_loads[0].time, TimeFunction::Step { at: 0.5 });
        // Round trip through the serialiser.
        let again = BeamSpec::from_toml_str(&s.to_toml_string().unwrap(), "again").unwrap();
        assert_eq!(again, s);
    }

    #[test]
    fn unknown_field_reports_file_line_column() {
        let text = "[[segment]]\nlength = 1.0\nlenght = 2.0\n";
        let e = BeamSpec::from_toml_str(text, "bad.toml").unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.starts_with("bad.toml:3:1: unknown field `lenght`"),
            "{msg}"
        );
    }

    #[test]
    fn wrong_type_reports_line() {
        let text = "[[segment]]\nlength = \"long\"\n";
        let msg = BeamSpec::from_toml_str(text, "b.toml")
            .unwrap_err()
            .to_string();
        assert!(msg.starts_with("b.toml:2:"), "{msg}");
    }

    #[test]
    fn time_functions() {
        assert_eq!(TimeFunction::Constant.value(3.0), 1.0);
        assert_eq!(TimeFunction::Step { at: 1.0 }.value(0.999), 0.0);
        assert_eq!(TimeFunction::Step { at: 1.0 }.value(1.0), 1.0);
        let h = TimeFunction::Harmonic {
            frequency_hz: 2.0,
            phase: std::f64::consts::FRAC_PI_2,
        };
        assert!(
            (h.value(0.25) - (std::f64::consts::PI + std::f64::consts::FRAC_PI_2).sin()).abs()
                < 1e-15
        );
    }

    #[test]
    fn table_is_piecewise_linear_and_held_outside() {
        let f = TimeFunction::Table {
            points: vec![[0.0, 0.0], [0.1, 1.0], [0.3, -1.0]],
        };
        assert_eq!(f.value(-1.0), 0.0);
        assert_eq!(f.value(0.05), 0.5);
        assert_eq!(f.value(0.1), 1.0);
        assert!((f.value(0.2) - 0.0).abs() < 1e-15);
        assert_eq!(f.value(0.3), -1.0);
        assert_eq!(f.value(7.0), -1.0);
        assert!(f.problems().is_empty());
        let spec: NodalLoadSpec =
            toml::from_str("node = 1\nforce = 2.0\ntime = { kind = \"table\", points = [[0.0, 1.0], [1.0, 3.0]] }\n").unwrap();
        assert_eq!(spec.time.value(0.5), 2.0);
        let bad = TimeFunction::Table {
            points: vec![[0.0, 0.0], [0.0, 1.0]],
        };
        assert!(matches!(
            bad.problems()[..],
            [TimeFunctionError::NotIncreasing { index: 1, .. }]
        ));
        assert_eq!(
            TimeFunction::Table { points: vec![] }.problems(),
            vec![TimeFunctionError::EmptyTable]
        );
    }
}
