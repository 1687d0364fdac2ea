//! One point of a sweep: the scenario text with the point's `--set` overrides applied,
//! loaded by the one loader, run, and reduced to an ordered list of named figures.
//!
//! The linearised figures come from the report `damper linearize` prints
//! ([`crate::linear::analyse`]): the first mode's natural frequency and damping ratio with
//! the generator(s) connected and disconnected, the first mode's decay rate
//! (`linear.decay1`, `-Re lambda`) and whether it is overdamped (`linear.overdamped1`, 0/1),
//! the bare beam's first frequency, the first generator's amplification, the smallest
//! remaining reach to a singular position, the admissible load (`linear.max_force`: the
//! smallest over the mechanisms of reach / |H_att| at `linear.f1` for the scenario's first
//! excitation, [`crate::linear::max_force_at`]; N, or N m for a joint excitation) and the
//! mechanisms' largest cond(J_d) at the equilibrium.
//!
//! Under a random excitation, the random figures of one stationary random response (the
//! mean load and generator powers, RMS currents, each mechanism's reach in RMS of its
//! attachment's motion and its rate of reaching the toggle, `random.rms:OUTPUT` on request:
//! `random` below). The names and units are the catalogue's ([`crate::analysis::figures`]).
//!
//! With `--time-domain`, the figures of the run's own summary, the one `damper simulate`
//! writes (nothing is recomputed here), with the outputs kept in memory (no file is
//! written):
//!
//! the [`crate::report::hybrid::HybridSummary`] of a damper or hybrid scenario: damping
//! ratio of the free decay (and `damping_ratio_<comparison>` of every comparison run of
//! `[output] compare`), first beam frequency, peak amplitude, per attachment its peak and
//! final amplitude, per generator its dissipated and harvested energy and peak current, the
//! energy account.
//!
//! Every figure is a pure function of the scenario, the overrides and the options: the same
//! point gives the same figures bit for bit on any thread. A figure the run does not give is
//! absent; a figure that comes out non-finite (an overflow, a division by zero) is an error
//! of the point naming it, never a value. A time-domain run above the `simulate` step limit
//! (`crate::budget`) is an error of the point unless `--allow-long`.

use std::path::Path;

use hybrid_core::hybrid::EigenMethod;

use crate::Error;
use crate::analysis::AnalysisError;
use crate::analysis::figures;
use crate::budget::{self, Quantity};
use crate::random::RandomMethod;
use crate::scenario::{self, Loaded, Override, Scenario};
use crate::setup::Linearizable;
use hybrid_core::hybrid::Linearization;

/// A named figure of a sweep point.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    /// Name (a summary field, e.g. `zeta_with_generator`, `energy.harvested_in_load`).
    pub name: String,
    /// Unit (`-` for a ratio).
    pub unit: &'static str,
    /// Value; `None` when the run does not give it (e.g. a damping ratio from fewer than
    /// three peaks). Always finite in a result of [`evaluate`].
    pub value: Option<f64>,
}

impl Figure {
    /// The catalogued figure `name` ([`crate::analysis::figures`]) with its usual unit.
    pub fn of(name: impl Into<String>, value: impl Into<Option<f64>>) -> Figure {
        let name = name.into();
        let unit = figures::entry_of(&name).unit();
        Figure {
            name,
            unit,
            value: value.into(),
        }
    }

    /// The CSV header of the figure: `name [unit]`.
    pub fn header(&self) -> String {
        format!("{} [{}]", self.name, self.unit)
    }
}

/// Why a point has no figures (recorded as its one-line message).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PointError {
    /// The scenario with the point's overrides is refused by the loader.
    #[error(transparent)]
    Input(#[from] diagnostic::Diagnostics),
    /// The point's linearisation or run failed, or it is above the step limit.
    #[error(transparent)]
    Run(#[from] Box<Error>),
    /// A figure came out non-finite.
    #[error("figure {name} is not finite ({value})")]
    NotFinite {
        /// The figure.
        name: String,
        /// Its value.
        value: f64,
    },
    /// The evaluation panicked (a bug: reported as the point's error, the sweep goes on).
    #[error("the evaluation panicked")]
    Panicked,
}

/// What a point evaluates.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PointOptions {
    /// Run the scenario in the time domain and report its summary figures.
    pub time_domain: bool,
    /// Run a time-domain point even above the `simulate` step limit.
    pub allow_long: bool,
    /// How the random figures are computed (`--method`; automatic by default).
    pub method: crate::random::RandomMethod,
    /// Compute the random figures only when a requested figure is one (the optimiser's
    /// points: its objective and constraints), not as default columns (a sweep's).
    pub only_requested: bool,
}

/// The figures of a point, and why its time-domain run failed when it did (the linearised
/// figures are kept: a design whose free decay reaches the toggle still has its modes).
#[derive(Debug)]
pub struct Evaluated {
    /// The figures (the linearised ones, then the time domain's when it ran).
    pub figures: Vec<Figure>,
    /// Why the time-domain run of the point failed.
    pub time_domain_error: Option<PointError>,
}

/// Evaluates one point: `text` (the scenario file `path`, the base of its relative paths)
/// with `overrides` applied in order. An error of the point as a whole (a value the loader
/// rejects, no static equilibrium) is a [`PointError`]; a time-domain run that fails (stops
/// at the singular position, diverges, is above the step limit) keeps the linearised
/// figures and records its error apart.
pub fn evaluate(
    path: &Path,
    text: &str,
    overrides: &[Override],
    options: &PointOptions,
) -> Result<Evaluated, PointError> {
    evaluate_with(path, text, overrides, options, &[])
}

/// [`evaluate`] with the figures `requested` (canonical names, [`figures::resolve`]) that
/// are computed only when asked for ([`figures::Entry::on_request`]: the receptance peak,
/// the harmonic load power) after the linearised ones, from the same linearisation (not for
/// a mechanism scenario); a requested figure that is a default one is not repeated. An
/// error computing one is an error of the point.
pub fn evaluate_with(
    path: &Path,
    text: &str,
    overrides: &[Override],
    options: &PointOptions,
    requested: &[String],
) -> Result<Evaluated, PointError> {
    // Asked to stop (`crate::interrupt::StopToken::stop`): the optimiser's and the sweeps'
    // remaining points fail at once.
    if crate::interrupt::stop_requested() {
        return Err(PointError::Run(Box::new(Error::Interrupted)));
    }
    let loaded = scenario::parse_with(text, path, overrides)?;
    // A point's own structure (an axis may be the beam's elements) within the limits.
    budget::structure(
        &loaded.scenario,
        &path.display().to_string(),
        options.allow_long,
    )
    .map_err(|e| PointError::Run(Box::new(e)))?;
    let mut figures = vec![];
    let remap = |e: Error| {
        Box::new(match e {
            Error::Input(d) => Error::Input(loaded.remap(d)),
            e => e,
        })
    };
    // The comparison variants' figures (generator(s) disconnected, bare beam) unless only
    // the requested figures are wanted and none of them is one.
    let comparisons = !options.only_requested
        || requested.iter().any(|n| {
            n.ends_with("_generator_disconnected")
                || n.ends_with("_bare_beam")
                || n.ends_with("_bare_structure")
        });
    // The random figures: wanted unless only the requested ones are and none is random.
    let wanted = !options.only_requested
        || requested.iter().any(|n| {
            figures::resolve(n, None).is_ok_and(|r| r.entry.producer == figures::Producer::Random)
        });
    let has_random = match &loaded.scenario {
        Scenario::Hybrid(h) => h.excitations.iter().any(|e| e.time.is_random()),
        Scenario::Mechanism(_) => false,
    };
    // One dense modal decomposition for the linear and the random figures.
    let mut all = vec![];
    let keep = (wanted && has_random && options.method != RandomMethod::Modal).then_some(&mut all);
    if let Some((input, lin)) =
        linearised(path, &loaded, comparisons, keep, &mut figures).map_err(remap)?
    {
        let file = path.display().to_string();
        figures.extend(on_request(&file, &input, &lin, requested).map_err(remap)?);
        if wanted {
            let given = (!all.is_empty()).then_some(all.as_slice());
            figures.extend(
                random(&file, &input, &lin, requested, options.method, given).map_err(remap)?,
            );
        }
    }
    finite(&figures)?;
    let mut time_domain_error = None;
    if options.time_domain {
        let linear = figures.len();
        let run = |figures: &mut Vec<Figure>| -> Result<(), PointError> {
            if let Some(steps) = budget::steps_per_run(&loaded.scenario) {
                budget::refuse_above(
                    &path.display().to_string(),
                    &[Quantity::count("time steps", steps, budget::MAX_STEPS)],
                    "shorten t_end",
                    options.allow_long,
                )
                .map_err(Box::new)?;
            }
            time_domain(path, &loaded, figures).map_err(remap)?;
            finite(figures)
        };
        if let Err(e) = run(&mut figures) {
            figures.truncate(linear);
            time_domain_error = Some(e);
        }
    }
    Ok(Evaluated {
        figures,
        time_domain_error,
    })
}

/// The figures of `requested` computed only on request, from the point's linearisation.
fn on_request(
    file: &str,
    input: &Linearizable,
    lin: &Linearization,
    requested: &[String],
) -> Result<Vec<Figure>, Error> {
    let model = &input.model;
    let mut out: Vec<Figure> = vec![];
    for name in requested {
        let Ok(r) = figures::resolve(name, None) else {
            continue;
        };
        if !r.entry.on_request || out.iter().any(|f| f.name == r.name) {
            continue;
        }
        let value = match crate::linear::PeakSpec::parse(&r.name) {
            Some(spec) => crate::linear::peak_of(file, model, lin, &spec)?.1,
            None if r.name == "harmonic.load_power" => {
                let responses = crate::linear::harmonic_responses(file, model, lin)?;
                crate::linear::load_power(model, lin, &responses)
            }
            None => continue,
        };
        out.push(Figure::of(r.name, value));
    }
    Ok(out)
}

/// The random figures of a scenario with a random excitation (none otherwise), from one
/// stationary random response of the point's linearisation ([`crate::random`]: `method`,
/// automatic by default; 20 modes where modal): `random.rms:OUTPUT` of every requested
/// output, the mean load and dissipated powers of all generators and of each, each
/// generator's RMS current, and per mechanism with a reach `a` and an attachment whose
/// displacement `x` towards the toggle ([`crate::linear::LoadLimit::point`]: a beam point's
/// `w`, a node's displacement along the pivot -> node axis) has RMS `sigma_x` and rate RMS
/// `sigma_v`:
///
/// ```text
/// random.reach_sigma  = a / sigma_x
/// random.toggle_rate  = (1 / 2 pi) (sigma_v / sigma_x) exp(-a^2 / (2 sigma_x^2))
/// ```
///
/// the second Rice's rate of up-crossings of the level `a` by a Gaussian stationary
/// zero-mean `x`: one side only, because the toggle lies on one side of the equilibrium
/// (the motion away from it bends the bars further, no singular position there).
fn random(
    file: &str,
    input: &Linearizable,
    lin: &Linearization,
    requested: &[String],
    method: RandomMethod,
    all: Option<&[hybrid_core::hybrid::Mode]>,
) -> Result<Vec<Figure>, Error> {
    let model = &input.model;
    if !model.excitations.iter().any(|e| e.time.is_random()) {
        return Ok(vec![]);
    }
    // The reach figures read each limit's point along its reach (a beam point's `w`; a
    // node's displacement along its pivot -> node axis), after the requested outputs.
    let limits = crate::linear::LoadLimit::of(model, lin);
    let asked: Vec<&str> = requested
        .iter()
        .filter_map(|n| n.strip_prefix("random.rms:"))
        .collect();
    let report = crate::random::figures_of(
        file,
        input,
        lin,
        all,
        &crate::random::RandomOptions {
            method,
            modes: 20,
            outputs: asked.iter().map(|o| o.to_string()).collect(),
            points: limits
                .iter()
                .map(|l| (format!("reach:{}", l.name), l.point.clone()))
                .collect(),
        },
    )?;
    // The outputs come in pairs: the displacement, then its rate.
    let rms = |k: usize| report.outputs.get(2 * k).map(|o| (o.rms, o.unit.as_str()));
    let rate = |k: usize| report.outputs.get(2 * k + 1).map(|o| o.rms);
    let mut out = vec![];
    for (j, name) in asked.iter().enumerate() {
        if let Some((v, unit)) = rms(j) {
            out.push(Figure {
                name: format!("random.rms:{name}"),
                unit: if unit == "rad" { "rad" } else { "m" },
                value: Some(v),
            });
        }
    }
    if !report.generators.is_empty() {
        let sum = |f: fn(&crate::random::GeneratorRms) -> f64| {
            report.generators.iter().map(f).sum::<f64>()
        };
        out.push(Figure::of("random.load_power", sum(|g| g.mean_power_load)));
        out.push(Figure::of("random.power", sum(|g| g.mean_power_dissipated)));
    }
    for g in &report.generators {
        out.push(Figure::of(
            format!("random.load_power:{}", g.name),
            g.mean_power_load,
        ));
        out.push(Figure::of(
            format!("random.rms_current:{}", g.name),
            g.rms_current,
        ));
    }
    for (k, l) in limits.iter().enumerate() {
        let (Some((sx, _)), Some(sv)) = (rms(asked.len() + k), rate(asked.len() + k)) else {
            continue;
        };
        let moves = sx > 0.0;
        let a = l.reach;
        out.push(Figure::of(
            format!("random.reach_sigma:{}", l.name),
            moves.then(|| a / sx),
        ));
        out.push(Figure::of(
            format!("random.toggle_rate:{}", l.name),
            moves.then(|| sv / sx * (-a * a / (2.0 * sx * sx)).exp() / std::f64::consts::TAU),
        ));
    }
    Ok(out)
}

/// Refuses figures of which one is not finite, naming it (the point's error).
fn finite(figures: &[Figure]) -> Result<(), PointError> {
    match figures
        .iter()
        .find(|f| f.value.is_some_and(|v| !v.is_finite()))
    {
        Some(f) => Err(PointError::NotFinite {
            name: f.name.clone(),
            value: f.value.unwrap_or_default(),
        }),
        None => Ok(()),
    }
}

/// The linearised figures of a loaded scenario (see the module documentation), those of the
/// comparison variants only with `comparisons` (else absent), every mode of the dense
/// eigen-solution kept in `all` when given, and the system and its linearisation they come
/// from (`None` for a mechanism scenario).
fn linearised(
    path: &Path,
    loaded: &Loaded,
    comparisons: bool,
    all: Option<&mut Vec<hybrid_core::hybrid::Mode>>,
    figures: &mut Vec<Figure>,
) -> Result<Option<(Linearizable, Linearization)>, Error> {
    if let Scenario::Mechanism(_) = loaded.scenario {
        return Ok(None);
    }
    let file = path.display().to_string();
    let (r, max_force, input, lin) = crate::linear::analyse_with_max_force(
        &file,
        &loaded.scenario,
        1,
        EigenMethod::Auto,
        comparisons,
        all,
    )?;
    // Every figure read from the linear report, in the catalogue's order; the admissible
    // load has its own analysis and its unit follows the excitation (absent, no column,
    // without an excitation; without a reach, no value).
    for e in figures::CATALOGUE {
        if let Some(read) = e.from_linear {
            figures.push(Figure::of(e.pattern, read(&r)));
        } else if e.pattern == "linear.max_force"
            && let Scenario::Hybrid(h) = &loaded.scenario
            && !h.excitations.is_empty()
        {
            figures.push(Figure {
                unit: max_force.map_or("N", |m| m.unit),
                ..Figure::of(e.pattern, max_force.map(|m| m.value))
            });
        }
    }
    Ok(Some((input, lin)))
}

/// The figures of the time-domain run of a loaded scenario.
fn time_domain(path: &Path, loaded: &Loaded, figures: &mut Vec<Figure>) -> Result<(), Error> {
    match &loaded.scenario {
        Scenario::Hybrid(sc) => {
            let built = crate::setup::build(sc)?;
            let run = crate::run_hybrid::evaluate(sc, &built, &[], None, vec![], false)?;
            let s = &run.summary;
            figures.push(Figure::of("damping_ratio", s.damping_ratio));
            let file = path.display().to_string();
            for &c in &sc.compare {
                if let Some((variant, probes)) = crate::setup::comparison(&file, &built, c)? {
                    let r =
                        crate::run_hybrid::evaluate(sc, &variant, &probes, None, vec![], false)?;
                    let name = format!("damping_ratio_{}", c.key());
                    figures.push(Figure::of(name, r.summary.damping_ratio));
                }
            }
            figures.extend([
                Figure::of("beam_first_frequency", s.beam_first_frequency_hz),
                Figure::of("peak_amplitude", s.peak_amplitude),
            ]);
            for a in &s.attachments {
                let name = |f: &str| format!("attachment.{}.{f}", a.name);
                figures.push(Figure::of(
                    name("peak_displacement"), a.peak_displacement,
                ));
                figures.push(Figure::of(name("final_amplitude"), a.final_amplitude));
            }
            for g in &s.generators {
                let name = |f: &str| format!("generator.{}.{f}", g.name);
                figures.push(Figure::of(name("dissipated"), g.dissipated));
                figures.push(Figure::of(
                    name("harvested_in_load"), g.harvested_in_load,
                ));
                figures.push(Figure::of(name("peak_current"), g.peak_current));
            }
            let e = &s.energy;
            let generators = |f: fn(&crate::report::hybrid::GeneratorReport) -> f64| {
                (!s.generators.is_empty()).then(|| s.generators.iter().map(f).sum::<f64>())
            };
            figures.extend([
                Figure::of("energy.initial", e.initial),
                Figure::of(
                    "energy.dissipated_generators", generators(|g| g.dissipated),
                ),
                Figure::of(
                    "energy.harvested_in_load", generators(|g| g.harvested_in_load),
                ),
                Figure::of("energy.dissipated_structure", e.dissipated_structure),
                Figure::of("energy.final_stored", e.final_stored),
                Figure::of("energy_balance_rel_error", s.energy_balance_rel_error),
            ]);
            Ok(())
        }
        Scenario::Mechanism(_) => Err(AnalysisError::Unavailable {
            file: None,
            message: "sweeps evaluate `kind = \"damper\"` and `kind = \"hybrid\"` scenarios (a rigid mechanism has no sweep figures yet)".into(),
        }
        .into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_non_finite_figure_is_an_error_naming_it_and_an_absent_one_is_not() {
        let ok = [
            Figure::of("linear.f1", 5.9),
            Figure {
                name: "zeta_with_generator".into(),
                unit: "-",
                value: None,
            },
        ];
        assert!(finite(&ok).is_ok());
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let figures = [ok[0].clone(), Figure::of("energy.initial", bad)];
            let e = finite(&figures).unwrap_err().to_string();
            assert!(e.contains("figure energy.initial is not finite"), "{e}");
        }
    }
}
