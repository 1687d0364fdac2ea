//! The figure catalogue: every figure a scenario can yield, with its one canonical name, its
//! unit, what it means, which analysis produces it and whether its gradient is exact (the
//! adjoint of the linear model, [`crate::sensitivity`]) — the one vocabulary of `sweep`
//! (columns, `--map`, `--constraint`), `optimize` (objective, constraints), `merge` (units),
//! `damper figures` and Python.
//!
//! A name is `producer.figure` (`linear.zeta1`), or a pattern with one parameter written
//! `{}` in [`Entry::pattern`] (`attachment.{}.peak_displacement`, `peak:{}`), whose value
//! names an entity of the scenario (an attachment, a generator, a mechanism, a comparison
//! run) or an output (`1.0`, `MECHANISM/COORDINATE`). Short names of earlier versions
//! (`zeta1`, `reach`, `power`, `rms:OUTPUT`) are aliases: [`resolve`] turns them into the
//! canonical name, and an unknown name is an error that lists the nearest valid names
//! (edit distance), before any work.
//!
//! Constraints are `FIGURE>=VALUE` or `FIGURE<=VALUE`, or between two figures,
//! `FIGURE>=K*FIGURE` or `FIGURE<=K*FIGURE` (`A>=B` for `K = 1`) ([`Constraint`]).

use crate::scenario::{Scenario, hybrid::HybridScenario};

/// Which analysis computes a figure.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Producer {
    /// The linearised system about the static equilibrium (modes, reach, ...).
    Linear,
    /// The steady state of the linearised system under the harmonic excitations.
    Harmonic,
    /// The stationary random response of the linearised system under the random
    /// excitations ([`crate::random`]).
    Random,
    /// The time-domain run of the scenario (`sweep --time-domain`).
    TimeDomain,
}

impl Producer {
    /// As `damper figures` prints it.
    pub fn label(self) -> &'static str {
        match self {
            Producer::Linear => "linear",
            Producer::Harmonic => "harmonic",
            Producer::Random => "random",
            Producer::TimeDomain => "time-domain",
        }
    }
}

/// What the parameter of a figure pattern names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Param {
    /// No parameter.
    None,
    /// An attachment's name.
    Attachment,
    /// A generator's (force element's) name.
    Generator,
    /// A comparison run of `[output] compare` (`generator_disconnected`, `bare_beam`).
    Comparison,
    /// A receptance peak `X:F1:F2` (beam abscissa in m, band in Hz).
    Peak,
    /// A mechanism's name.
    Mechanism,
    /// An output as `damper random --output` names it: a beam abscissa in m (`1.0`),
    /// `NODE:DOF` on an imported structure (`613:ux`) or `MECHANISM/COORDINATE`.
    Output,
}

impl Param {
    /// The placeholder shown for the parameter.
    fn placeholder(self) -> &'static str {
        match self {
            Param::None => "",
            Param::Attachment => "ATTACHMENT",
            Param::Generator => "GENERATOR",
            Param::Comparison => "COMPARISON",
            Param::Peak => "X:F1:F2",
            Param::Output => "OUTPUT",
            Param::Mechanism => "MECHANISM",
        }
    }
}

/// How the gradient of a figure is computed ([`crate::sensitivity`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Gradient {
    /// The adjoint of the linear model (exact up to the pencil's difference formula).
    Adjoint,
    /// Differences of re-evaluated figures.
    Differences,
}

/// One figure (or one family of figures) of the catalogue.
#[derive(Clone, Copy, Debug)]
pub struct Entry {
    /// The canonical name; `{}` stands for the parameter.
    pub pattern: &'static str,
    /// Earlier spellings accepted for it (same parameter).
    pub aliases: &'static [&'static str],
    /// What the parameter names.
    pub param: Param,
    /// The units the figure can have, the usual one first (`linear.max_force` follows the
    /// first excitation: N, N m or m/s^2).
    pub units: &'static [&'static str],
    /// What it means (one line).
    pub meaning: &'static str,
    /// Which analysis computes it.
    pub producer: Producer,
    /// How its gradient is computed.
    pub gradient: Gradient,
    /// Computed only when asked for (`--map`, `--constraint`, an objective), not a default
    /// column of a sweep.
    pub on_request: bool,
    /// How a linearised figure is read from the point's linear report (`None`: computed
    /// elsewhere — a figure with a parameter, one needing its own analysis). A figure read
    /// from the report is added by its entry alone: the sweep's point evaluation, the
    /// optimiser (gradients by differences) and `damper figures` take it from here.
    pub from_linear: Option<fn(&LinearReport) -> Option<f64>>,
}

impl Entry {
    /// The unit (the usual one).
    pub fn unit(&self) -> &'static str {
        self.units[0]
    }

    /// The pattern with its placeholder (`attachment.ATTACHMENT.peak_displacement`).
    pub fn display(&self) -> String {
        self.pattern.replace("{}", self.param.placeholder())
    }

    /// The alias `alias` of this entry with its placeholder.
    pub fn display_alias(&self, alias: &str) -> String {
        alias.replace("{}", self.param.placeholder())
    }

    /// The name with the parameter `p`.
    pub fn name_with(&self, p: &str) -> String {
        self.pattern.replace("{}", p)
    }

    /// The parameter of `name` when it is this entry's (canonical or alias) spelling.
    fn matches<'n>(&self, name: &'n str) -> Option<(&'n str, bool)> {
        std::iter::once(self.pattern)
            .chain(self.aliases.iter().copied())
            .enumerate()
            .find_map(|(i, pattern)| match pattern.split_once("{}") {
                None => (pattern == name).then_some(("", i > 0)),
                Some((pre, post)) => name
                    .strip_prefix(pre)
                    .and_then(|r| r.strip_suffix(post))
                    .filter(|p| !p.is_empty())
                    .map(|p| (p, i > 0)),
            })
    }
}

const fn entry(
    pattern: &'static str,
    units: &'static [&'static str],
    producer: Producer,
    gradient: Gradient,
    meaning: &'static str,
) -> Entry {
    Entry {
        pattern,
        aliases: &[],
        param: Param::None,
        units,
        meaning,
        producer,
        gradient,
        on_request: false,
        from_linear: None,
    }
}

/// A linear entry read from the linear report by `read`.
const fn read(e: Entry, read: fn(&LinearReport) -> Option<f64>) -> Entry {
    Entry {
        from_linear: Some(read),
        ..e
    }
}

/// The natural frequency (Hz) and damping ratio of the first mode of `modes`.
fn first_mode(modes: Option<&[ModeReport]>) -> Option<(f64, f64)> {
    modes
        .and_then(|m| m.first())
        .map(|m| (m.natural_frequency_hz, m.damping_ratio))
}

const fn with_param(e: Entry, param: Param) -> Entry {
    Entry { param, ..e }
}

const fn aka(e: Entry, aliases: &'static [&'static str]) -> Entry {
    Entry { aliases, ..e }
}

const fn on_request(e: Entry) -> Entry {
    Entry {
        on_request: true,
        ..e
    }
}

use crate::linear::{LinearReport, ModeReport};
use Gradient::{Adjoint, Differences};
use Producer::{Harmonic, Linear, Random, TimeDomain};
use hybrid_core::hybrid::ModeKind;

/// Every figure, in the order of a sweep's columns (consecutive entries with the same
/// parameter kind are expanded entity by entity: `attachment.A.peak_displacement`,
/// `attachment.A.final_amplitude`, `attachment.B.peak_displacement`, ...).
pub static CATALOGUE: &[Entry] = &[
    aka(
        read(
            entry(
                "linear.f1",
                &["Hz"],
                Linear,
                Adjoint,
                "first mode's natural frequency, generator(s) connected",
            ),
            |r| first_mode(Some(&r.modes)).map(|m| m.0),
        ),
        &["f1"],
    ),
    aka(
        read(
            entry(
                "linear.zeta1",
                &["-"],
                Linear,
                Adjoint,
                "first mode's damping ratio, generator(s) connected (1 when overdamped)",
            ),
            |r| first_mode(Some(&r.modes)).map(|m| m.1),
        ),
        &["zeta1"],
    ),
    aka(
        read(
            entry(
                "linear.decay1",
                &["1/s"],
                Linear,
                Adjoint,
                "first mode's decay rate -Re(lambda_1), ordered across critical damping",
            ),
            |r| r.modes.first().map(|m| m.decay_rate),
        ),
        &["decay1"],
    ),
    aka(
        read(
            entry(
                "linear.overdamped1",
                &["-"],
                Linear,
                Differences,
                "1 when the first mode is overdamped, else 0",
            ),
            |r| {
                r.modes
                    .first()
                    .map(|m| f64::from(u8::from(m.kind == ModeKind::Overdamped)))
            },
        ),
        &["overdamped1"],
    ),
    read(
        entry(
            "linear.f1_generator_disconnected",
            &["Hz"],
            Linear,
            Differences,
            "first mode's natural frequency, generator(s) disconnected",
        ),
        |r| first_mode(r.generator_disconnected.as_deref()).map(|m| m.0),
    ),
    read(
        entry(
            "linear.zeta1_generator_disconnected",
            &["-"],
            Linear,
            Differences,
            "first mode's damping ratio, generator(s) disconnected",
        ),
        |r| first_mode(r.generator_disconnected.as_deref()).map(|m| m.1),
    ),
    read(
        entry(
            "linear.f1_bare_beam",
            &["Hz"],
            Linear,
            Differences,
            "first natural frequency of the beam without mechanism",
        ),
        |r| first_mode(r.bare_beam.as_deref()).map(|m| m.0),
    ),
    read(
        entry(
            "linear.f1_bare_structure",
            &["Hz"],
            Linear,
            Differences,
            "first natural frequency of an imported structure without mechanism",
        ),
        |r| first_mode(r.bare_structure.as_deref()).map(|m| m.0),
    ),
    aka(
        read(
            entry(
                "linear.amplification",
                &["rad/m"],
                Linear,
                Differences,
                "first generator's amplification dq/dw at the equilibrium (a pin at a node: its larger component)",
            ),
            |r| {
                // The first generator's entries for its first attachment: one on the beam,
                // the x and y components of a pin at a node.
                let first = r.amplification.first()?;
                r.amplification
                    .iter()
                    .filter(|a| a.generator == first.generator && a.attachment == first.attachment)
                    .map(|a| a.joint_per_displacement)
                    .max_by(|x, y| x.abs().total_cmp(&y.abs()))
            },
        ),
        &["amplification"],
    ),
    aka(
        read(
            entry(
                "linear.reach",
                &["m"],
                Linear,
                Differences,
                "smallest remaining reach of a mechanism to its singular (toggle) position",
            ),
            |r| {
                r.equilibrium
                    .mechanisms
                    .iter()
                    .filter_map(|m| m.reach)
                    .reduce(f64::min)
            },
        ),
        &["reach"],
    ),
    aka(
        entry(
            "linear.max_force",
            &["N", "N m", "m/s^2"],
            Linear,
            Adjoint,
            "admissible amplitude of the first excitation: min over mechanisms of reach / |H_att(i 2 pi f1)|",
        ),
        &["max_force"],
    ),
    aka(
        read(
            entry(
                "linear.jacobian_condition",
                &["-"],
                Linear,
                Differences,
                "largest cond(J_d) of the mechanisms at the equilibrium",
            ),
            |r| {
                r.equilibrium
                    .mechanisms
                    .iter()
                    .map(|m| m.jacobian_condition)
                    .reduce(f64::max)
            },
        ),
        &["jacobian_condition"],
    ),
    on_request(aka(
        with_param(
            entry(
                "peak:{}",
                &["m"],
                Harmonic,
                Adjoint,
                "largest receptance |H| of the beam at x = X over F1..F2 Hz per unit of the first excitation",
            ),
            Param::Peak,
        ),
        &[],
    )),
    on_request(aka(
        entry(
            "harmonic.load_power",
            &["W"],
            Harmonic,
            Adjoint,
            "mean power in the load resistances in the steady state under the harmonic excitations",
        ),
        &["power"],
    )),
    on_request(aka(
        with_param(
            entry(
                "random.rms:{}",
                &["m", "rad"],
                Random,
                Adjoint,
                "RMS of an output's displacement under the random excitations (white noise: Lyapunov equation; PSD tables: quadrature)",
            ),
            Param::Output,
        ),
        &["rms:{}"],
    )),
    entry(
        "random.load_power",
        &["W"],
        Random,
        Differences,
        "mean power in the load resistances of every generator, sum of R_L sigma_i^2",
    ),
    entry(
        "random.power",
        &["W"],
        Random,
        Differences,
        "mean power dissipated in the generators, sum of (R_a + R_L) sigma_i^2",
    ),
    with_param(
        entry(
            "random.load_power:{}",
            &["W"],
            Random,
            Differences,
            "mean power in one generator's load, R_L sigma_i^2",
        ),
        Param::Generator,
    ),
    with_param(
        entry(
            "random.rms_current:{}",
            &["A"],
            Random,
            Differences,
            "RMS current sigma_i of one generator",
        ),
        Param::Generator,
    ),
    with_param(
        entry(
            "random.reach_sigma:{}",
            &["-"],
            Random,
            Differences,
            "a mechanism's reach over the RMS sigma_x of its attachment's motion towards the toggle",
        ),
        Param::Mechanism,
    ),
    with_param(
        entry(
            "random.toggle_rate:{}",
            &["1/s"],
            Random,
            Differences,
            "expected rate of reaching the toggle (Rice): (sigma_v / sigma_x) exp(-a^2 / 2 sigma_x^2) / 2 pi",
        ),
        Param::Mechanism,
    ),
    entry(
        "damping_ratio",
        &["-"],
        TimeDomain,
        Differences,
        "damping ratio of the free decay (filtered peaks)",
    ),
    with_param(
        entry(
            "damping_ratio_{}",
            &["-"],
            TimeDomain,
            Differences,
            "damping ratio of the free decay of a comparison run of [output] compare",
        ),
        Param::Comparison,
    ),
    entry(
        "beam_first_frequency",
        &["Hz"],
        TimeDomain,
        Differences,
        "first natural frequency of the beam (time-domain run's summary)",
    ),
    entry(
        "peak_amplitude",
        &["m"],
        TimeDomain,
        Differences,
        "largest amplitude of the observed beam point",
    ),
    with_param(
        entry(
            "attachment.{}.peak_displacement",
            &["m"],
            TimeDomain,
            Differences,
            "largest displacement of an attachment point",
        ),
        Param::Attachment,
    ),
    with_param(
        entry(
            "attachment.{}.final_amplitude",
            &["m"],
            TimeDomain,
            Differences,
            "amplitude of an attachment point at the end of the run",
        ),
        Param::Attachment,
    ),
    with_param(
        entry(
            "generator.{}.dissipated",
            &["J"],
            TimeDomain,
            Differences,
            "energy dissipated in a generator's R_a + R_L",
        ),
        Param::Generator,
    ),
    with_param(
        entry(
            "generator.{}.harvested_in_load",
            &["J"],
            TimeDomain,
            Differences,
            "energy harvested in a generator's load R_L",
        ),
        Param::Generator,
    ),
    with_param(
        entry(
            "generator.{}.peak_current",
            &["A"],
            TimeDomain,
            Differences,
            "largest |current| of a generator",
        ),
        Param::Generator,
    ),
    entry(
        "energy.initial",
        &["J"],
        TimeDomain,
        Differences,
        "initial energy of the run",
    ),
    entry(
        "energy.dissipated_generators",
        &["J"],
        TimeDomain,
        Differences,
        "energy dissipated in every generator",
    ),
    entry(
        "energy.harvested_in_load",
        &["J"],
        TimeDomain,
        Differences,
        "energy harvested in every load",
    ),
    entry(
        "energy.dissipated_structure",
        &["J"],
        TimeDomain,
        Differences,
        "energy dissipated in the structure's damping",
    ),
    entry(
        "energy.final_stored",
        &["J"],
        TimeDomain,
        Differences,
        "energy stored at the end of the run",
    ),
    entry(
        "energy_balance_rel_error",
        &["-"],
        TimeDomain,
        Differences,
        "relative error of the energy account",
    ),
];

/// The catalogue entry of the canonical name `name` (a figure a producer emits).
///
/// # Panics
/// When `name` is not in the catalogue: a producer emitting a figure the catalogue does not
/// know is a bug (the catalogue's tests check every producer's names).
pub fn entry_of(name: &str) -> &'static Entry {
    match lookup(name) {
        Some((e, _, false)) => e,
        _ => panic!("figure {name} is not in the catalogue (analysis/figures.rs)"),
    }
}

/// The entry of `name`, its parameter and whether `name` is an alias.
fn lookup(name: &str) -> Option<(&'static Entry, &str, bool)> {
    CATALOGUE
        .iter()
        .find_map(|e| e.matches(name).map(|(p, alias)| (e, p, alias)))
}

/// A figure name read against the catalogue.
#[derive(Clone, Debug)]
pub struct Resolved {
    /// The canonical name (an alias replaced).
    pub name: String,
    /// Its entry.
    pub entry: &'static Entry,
}

/// Why a figure name is refused: unknown, with the nearest valid names.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown figure `{name}`{}; `damper figures SCENARIO` lists them", nearest_text(.nearest))]
pub struct UnknownFigure {
    /// The name as given (truncated).
    pub name: String,
    /// The nearest valid names (edit distance), closest first.
    pub nearest: Vec<String>,
}

fn nearest_text(nearest: &[String]) -> String {
    if nearest.is_empty() {
        String::new()
    } else {
        format!(" (did you mean {}?)", nearest.join(", "))
    }
}

/// The entities of a scenario that figure parameters name.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Entities {
    /// Attachment names.
    pub attachments: Vec<String>,
    /// Generator names.
    pub generators: Vec<String>,
    /// Comparison runs of `[output] compare` (their keys).
    pub comparisons: Vec<String>,
    /// Whether the scenario has an excitation (`linear.max_force`, `peak:`), a harmonic one
    /// (`harmonic.load_power`).
    pub excitation: bool,
    /// Whether an excitation is harmonic.
    pub harmonic: bool,
    /// Whether an excitation is random (white noise or a PSD table).
    pub random: bool,
    /// Mechanism names.
    pub mechanisms: Vec<String>,
}

impl Entities {
    /// The entities of a loaded scenario (none for a rigid mechanism).
    pub fn of(sc: &Scenario) -> Entities {
        match sc {
            Scenario::Hybrid(h) => Entities::of_hybrid(h),
            Scenario::Mechanism(_) => Entities::default(),
        }
    }

    fn of_hybrid(h: &HybridScenario) -> Entities {
        use fem_beam::TimeFunction;
        Entities {
            attachments: h.attachments.iter().map(|a| a.name.clone()).collect(),
            generators: h
                .forces
                .iter()
                .filter(|f| matches!(f.kind, hybrid_core::hybrid::ForceKind::Generator(_)))
                .map(|f| f.name.clone())
                .collect(),
            comparisons: h.compare.iter().map(|c| c.key().to_string()).collect(),
            excitation: !h.excitations.is_empty(),
            harmonic: h
                .excitations
                .iter()
                .any(|e| matches!(e.time, TimeFunction::Harmonic { .. })),
            random: h.excitations.iter().any(|e| e.time.is_random()),
            mechanisms: h.mechanisms.iter().map(|m| m.name.clone()).collect(),
        }
    }

    /// The values the parameter kind takes in this scenario.
    fn values(&self, p: Param) -> &[String] {
        match p {
            Param::Attachment => &self.attachments,
            Param::Generator => &self.generators,
            Param::Comparison => &self.comparisons,
            Param::Mechanism => &self.mechanisms,
            Param::None | Param::Peak | Param::Output => &[],
        }
    }

    /// Whether the scenario can give figures of `e` at all.
    pub fn offers(&self, e: &Entry) -> bool {
        match e.pattern {
            "linear.max_force" | "peak:{}" => self.excitation,
            "harmonic.load_power" => self.harmonic && !self.generators.is_empty(),
            _ if e.producer == Producer::Random => self.random,
            _ => true,
        }
    }

    /// Every concrete figure name the scenario offers (patterns expanded over its
    /// entities; `peak:{}` shown with its placeholder), in catalogue order, and its entry.
    pub fn figures(&self) -> Vec<(String, &'static Entry)> {
        let mut out = vec![];
        let mut k = 0;
        while k < CATALOGUE.len() {
            let e = &CATALOGUE[k];
            if matches!(e.param, Param::None | Param::Peak | Param::Output) {
                if self.offers(e) {
                    out.push((e.display(), e));
                }
                k += 1;
                continue;
            }
            // A run of entries with the same parameter kind: entity by entity.
            let end = CATALOGUE[k..]
                .iter()
                .position(|x| x.param != e.param)
                .map_or(CATALOGUE.len(), |n| k + n);
            for v in self.values(e.param) {
                for x in &CATALOGUE[k..end] {
                    out.push((x.name_with(v), x));
                }
            }
            k = end;
        }
        out
    }
}

/// One figure a scenario offers, as `damper figures --json` and Python list it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Listed {
    /// The name (a user-chosen parameter shown as its placeholder).
    pub name: String,
    /// The units it can have (`N | N m | m/s^2`).
    pub unit: String,
    /// Which analysis computes it.
    pub producer: &'static str,
    /// How its gradient is computed.
    pub gradient: Gradient,
    /// Computed only when named.
    pub on_request: bool,
    /// What it means.
    pub meaning: &'static str,
}

/// The figures a loaded scenario offers ([`Entities::figures`]), in catalogue order.
pub fn listing(sc: &Scenario) -> Vec<Listed> {
    Entities::of(sc)
        .figures()
        .into_iter()
        .map(|(name, e)| Listed {
            name,
            unit: e.units.join(" | "),
            producer: e.producer.label(),
            gradient: e.gradient,
            on_request: e.on_request,
            meaning: e.meaning,
        })
        .collect()
}

/// Reads a figure name against the catalogue: an alias becomes the canonical name; a name
/// the catalogue does not know, or a parameter the scenario (`entities`, when given) does
/// not have, is [`UnknownFigure`] with the nearest valid names.
pub fn resolve(name: &str, entities: Option<&Entities>) -> Result<Resolved, UnknownFigure> {
    let name = name.trim();
    let unknown = || UnknownFigure {
        name: diagnostic::truncate(name, 80),
        nearest: nearest(name, entities),
    };
    let (entry, param, _) = lookup(name).ok_or_else(unknown)?;
    let ok = match entry.param {
        Param::None => true,
        Param::Peak => crate::linear::PeakSpec::parse(&entry.name_with(param)).is_some(),
        Param::Output => match param.split_once('/') {
            // `NODE:DOF` of an imported structure.
            None if param.contains(':') => param.split_once(':').is_some_and(|(n, d)| {
                n.trim().parse::<u64>().is_ok() && matches!(d.trim(), "ux" | "uy")
            }),
            None => param.trim().parse::<f64>().is_ok_and(f64::is_finite),
            Some((m, c)) => {
                !c.is_empty() && entities.is_none_or(|en| en.mechanisms.iter().any(|x| x == m))
            }
        },
        p => entities.is_none_or(|en| en.values(p).iter().any(|v| v == param)),
    };
    if !ok {
        return Err(unknown());
    }
    Ok(Resolved {
        name: entry.name_with(param),
        entry,
    })
}

/// The canonical spelling of `name` (itself when the catalogue does not know it).
pub fn canonical(name: &str) -> String {
    resolve(name, None).map_or_else(|_| name.to_string(), |r| r.name)
}

/// The unit `unit` is one figure `name` can have.
pub fn unit_of(name: &str, unit: &str) -> Option<&'static str> {
    let (e, _, _) = lookup(name)?;
    e.units.iter().find(|u| **u == unit).copied()
}

/// The (at most 3) valid names nearest to `name` by edit distance
/// ([`diagnostic::nearest`]): the scenario's figures when known, else the catalogue's
/// patterns, and the aliases.
fn nearest(name: &str, entities: Option<&Entities>) -> Vec<String> {
    let mut candidates: Vec<String> = match entities {
        Some(en) => en.figures().into_iter().map(|(n, _)| n).collect(),
        None => CATALOGUE.iter().map(Entry::display).collect(),
    };
    for e in CATALOGUE {
        candidates.extend(e.aliases.iter().map(|a| e.display_alias(a)));
    }
    diagnostic::nearest(name, candidates)
}

/// Whether a constraint bounds its figure from below or above.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bound {
    /// `FIGURE>=VALUE`.
    AtLeast,
    /// `FIGURE<=VALUE`.
    AtMost,
}

/// Why a `--constraint` cannot be read.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ConstraintError {
    /// Not `FIGURE>=VALUE`, `FIGURE<=VALUE` (a finite VALUE), `FIGURE>=K*FIGURE` or
    /// `FIGURE<=K*FIGURE` (a finite K).
    #[error(
        "--constraint {text}: expected FIGURE>=VALUE, FIGURE<=VALUE (a finite number), FIGURE>=K*FIGURE or FIGURE<=K*FIGURE (a finite factor K)"
    )]
    Syntax {
        /// The option's value.
        text: String,
    },
    /// A figure is unknown.
    #[error("--constraint {text}: {unknown}")]
    Figure {
        /// The option's value.
        text: String,
        /// Why.
        unknown: UnknownFigure,
    },
}

/// A design constraint between a figure `A` and a number or another figure `B`:
///
/// ```text
/// A >= VALUE    margin = A - VALUE        A <= VALUE    margin = VALUE - A
/// A >= k B      margin = A - k B          A <= k B      margin = k B - A
/// ```
///
/// (`A>=B` is `k = 1`); satisfied where the margin is `>= 0`, in `A`'s unit. The margin's
/// gradient is `dA - k dB` (or its negative), exact where both figures' gradients are.
#[derive(Clone, Debug, PartialEq)]
pub struct Constraint {
    /// The figure `A` (its canonical name once [`Constraint::resolve`]d).
    pub figure: String,
    /// Which side.
    pub bound: Bound,
    /// The bound `VALUE`, or the factor `k` of a constraint between figures.
    pub value: f64,
    /// The figure `B` of `A>=k*B` (canonical once resolved); `None` for a number.
    pub other: Option<String>,
    /// As written.
    pub text: String,
}

impl std::str::FromStr for Constraint {
    type Err = ConstraintError;

    fn from_str(text: &str) -> Result<Constraint, ConstraintError> {
        let bad = || ConstraintError::Syntax {
            text: text.to_string(),
        };
        let (figure, bound, rhs) = if let Some((f, v)) = text.split_once(">=") {
            (f, Bound::AtLeast, v)
        } else if let Some((f, v)) = text.split_once("<=") {
            (f, Bound::AtMost, v)
        } else {
            return Err(bad());
        };
        let figure = figure.trim();
        let rhs = rhs.trim();
        // A number, `K*FIGURE` or `FIGURE` (a figure name never reads as a number).
        let (value, other) = match rhs.parse::<f64>() {
            Ok(v) => (v, None),
            Err(_) => match rhs.split_once('*') {
                Some((k, b)) => (k.trim().parse().map_err(|_| bad())?, Some(b.trim())),
                None => (1.0, Some(rhs)),
            },
        };
        let named = |n: &str| !n.is_empty() && !n.contains(['<', '>', '=', '*', ' ']);
        if !named(figure) || !value.is_finite() || other.is_some_and(|b| !named(b)) {
            return Err(bad());
        }
        Ok(Constraint {
            figure: figure.to_string(),
            bound,
            value,
            other: other.map(str::to_string),
            text: text.trim().to_string(),
        })
    }
}

impl Constraint {
    /// The constraint with its figures checked against the catalogue (and the scenario's
    /// entities when given) and spelt canonically.
    pub fn resolve(self, entities: Option<&Entities>) -> Result<Constraint, ConstraintError> {
        let check = |name: &str| {
            resolve(name, entities)
                .map(|r| r.name)
                .map_err(|unknown| ConstraintError::Figure {
                    text: self.text.clone(),
                    unknown,
                })
        };
        let figure = check(&self.figure)?;
        let other = self.other.as_deref().map(check).transpose()?;
        Ok(Constraint {
            figure,
            other,
            ..self
        })
    }

    /// The figures the constraint reads: `A`, then `B` when it has one.
    pub fn figures(&self) -> impl Iterator<Item = &str> {
        std::iter::once(self.figure.as_str()).chain(self.other.as_deref())
    }

    /// `+1` for `A>=..`, `-1` for `A<=..`: the margin is `side (A - rhs)`.
    pub fn side(&self) -> f64 {
        match self.bound {
            Bound::AtLeast => 1.0,
            Bound::AtMost => -1.0,
        }
    }

    /// The right-hand side: `VALUE`, or `k B` with `B`'s value `b` (`None` without it).
    pub fn rhs(&self, b: Option<f64>) -> Option<f64> {
        match self.other {
            None => Some(self.value),
            Some(_) => b.map(|b| self.value * b),
        }
    }

    /// How far a point is inside the constraint (`>= 0`: satisfied; in `A`'s unit), from
    /// the value of each figure the point gives (`value_of(name)`); `None` when it lacks
    /// one of the constraint's figures.
    pub fn margin(&self, value_of: impl Fn(&str) -> Option<f64>) -> Option<f64> {
        let a = value_of(&self.figure)?;
        let rhs = self.rhs(self.other.as_deref().and_then(&value_of))?;
        Some(self.side() * (a - rhs))
    }

    /// How far a figure's value `v` is inside a constraint against a number (`>= 0`:
    /// satisfied; in the figure's unit); for a constraint between figures, see
    /// [`Constraint::margin`].
    pub fn margin_of(&self, v: f64) -> f64 {
        self.side() * (v - self.value)
    }

    /// The margin's gradient `side (dA - k dB)` from the figures' gradients (`dB` only
    /// for a constraint between figures).
    pub fn margin_gradient(&self, da: &[f64], db: Option<&[f64]>) -> Vec<f64> {
        match (self.other.is_some(), db) {
            (true, Some(db)) => da
                .iter()
                .zip(db)
                .map(|(a, b)| self.side() * (a - self.value * b))
                .collect(),
            _ => da.iter().map(|a| self.side() * a).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_read_from_the_linear_report_are_plain_linear_figures() {
        let read: Vec<&str> = CATALOGUE
            .iter()
            .filter(|e| e.from_linear.is_some())
            .map(|e| e.pattern)
            .collect();
        assert!(
            read.contains(&"linear.zeta1") && read.len() >= 9,
            "{read:?}"
        );
        for e in CATALOGUE.iter().filter(|e| e.from_linear.is_some()) {
            assert_eq!(e.producer, Producer::Linear, "{}", e.pattern);
            assert!(matches!(e.param, Param::None), "{}", e.pattern);
            assert!(!e.on_request, "{}", e.pattern);
        }
    }

    #[test]
    fn aliases_resolve_to_one_canonical_name_and_unknown_names_list_the_nearest() {
        assert_eq!(canonical("zeta1"), "linear.zeta1");
        assert_eq!(canonical("reach"), "linear.reach");
        assert_eq!(canonical("power"), "harmonic.load_power");
        assert_eq!(canonical("linear.reach"), "linear.reach");
        assert_eq!(canonical("peak:1.0:3:12"), "peak:1.0:3:12");
        assert_eq!(canonical("rms:1.0"), "random.rms:1.0");
        assert_eq!(canonical("rms:damper/q1"), "random.rms:damper/q1");
        assert_eq!(canonical("rms:613:ux"), "random.rms:613:ux");
        assert!(resolve("random.rms:613:rz", None).is_err());
        let e = resolve("powr", None).unwrap_err();
        assert!(e.nearest.contains(&"power".to_string()), "{e}");
        let e = resolve("linear.zeta", None).unwrap_err();
        assert_eq!(e.nearest[0], "linear.zeta1", "{e}");
        assert!(resolve("peak:1.0:12:3", None).is_err());
        let en = Entities {
            attachments: vec!["tip".into()],
            ..Entities::default()
        };
        assert!(resolve("attachment.tip.peak_displacement", Some(&en)).is_ok());
        let e = resolve("attachment.tp.peak_displacement", Some(&en)).unwrap_err();
        assert_eq!(e.nearest[0], "attachment.tip.peak_displacement", "{e}");
    }

    #[test]
    fn patterns_expand_entity_by_entity_and_every_name_resolves_to_itself() {
        let en = Entities {
            attachments: vec!["a".into(), "b".into()],
            generators: vec!["g".into()],
            comparisons: vec!["bare_beam".into()],
            excitation: true,
            harmonic: true,
            random: true,
            mechanisms: vec!["m".into()],
        };
        let names: Vec<String> = en.figures().into_iter().map(|(n, _)| n).collect();
        let pos = |n: &str| names.iter().position(|x| x == n).unwrap();
        assert!(pos("attachment.a.final_amplitude") < pos("attachment.b.peak_displacement"));
        for (n, e) in en.figures() {
            if !matches!(e.param, Param::Peak | Param::Output) {
                assert_eq!(resolve(&n, Some(&en)).unwrap().name, n);
            }
        }
    }

    #[test]
    fn constraints_between_figures_parse_resolve_and_give_margins_and_gradients() {
        let c: Constraint = "reach>=4*rms:1.0".parse().unwrap();
        assert_eq!(
            (c.figure.as_str(), c.bound, c.value, c.other.as_deref()),
            ("reach", Bound::AtLeast, 4.0, Some("rms:1.0"))
        );
        let c = c.resolve(None).unwrap();
        assert_eq!(c.figure, "linear.reach");
        assert_eq!(c.other.as_deref(), Some("random.rms:1.0"));
        let value = |n: &str| match n {
            "linear.reach" => Some(3e-3),
            "random.rms:1.0" => Some(5e-4),
            _ => None,
        };
        // 3e-3 - 4 * 5e-4 = 1e-3, exactly representable steps aside.
        assert!((c.margin(value).unwrap() - 1e-3).abs() < 1e-18);
        assert_eq!(c.margin(|n| (n == "linear.reach").then_some(1.0)), None);
        assert_eq!(
            c.margin_gradient(&[1.0, 2.0], Some(&[0.5, -1.0])),
            vec![-1.0, 6.0]
        );
        let c: Constraint = " random.power <= 2.5 * random.load_power ".parse().unwrap();
        assert_eq!((c.bound, c.value), (Bound::AtMost, 2.5));
        assert_eq!(
            c.margin(|n| Some(if n == "random.power" { 2.0 } else { 1.0 })),
            Some(0.5)
        );
        assert_eq!(c.margin_gradient(&[1.0], Some(&[1.0])), vec![1.5]);
        // `A>=B`: k = 1; a number stays a number.
        let c: Constraint = "linear.f1>=linear.f1_bare_beam".parse().unwrap();
        assert_eq!(
            (c.value, c.other.as_deref()),
            (1.0, Some("linear.f1_bare_beam"))
        );
        let c: Constraint = "linear.f1>=-2e-3".parse().unwrap();
        assert_eq!((c.value, c.other.as_deref()), (-2e-3, None));
        assert_eq!(c.margin_gradient(&[3.0], None), vec![3.0]);
        for bad in [
            "reach>=4*",
            "reach>=*rms:1.0",
            "reach>=x*rms:1.0",
            "reach>=inf*rms:1.0",
            ">=4*rms:1.0",
            "reach>=4*rms:1.0*2",
            "reach>=4 * rms 1.0",
            "reach=4",
        ] {
            assert!(
                matches!(
                    bad.parse::<Constraint>(),
                    Err(ConstraintError::Syntax { .. })
                ),
                "{bad}"
            );
        }
        // Both names are checked, the nearest named.
        let e = "reach>=4*rms_x:1.0"
            .parse::<Constraint>()
            .unwrap()
            .resolve(None)
            .unwrap_err();
        assert!(
            matches!(&e, ConstraintError::Figure { unknown, .. } if unknown.name == "rms_x:1.0"),
            "{e}"
        );
        let e = "reech>=linear.f1"
            .parse::<Constraint>()
            .unwrap()
            .resolve(None)
            .unwrap_err();
        assert!(e.to_string().contains("did you mean"), "{e}");
    }
}
