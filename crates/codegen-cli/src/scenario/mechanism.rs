//! The plain-mechanism scenario file (`kind = "mechanism"`), TOML:
//!
//! ```toml
//! kind = "mechanism"
//! model = "../models/four_bar.toml"   # relative to the scenario file
//! description = "free text"           # optional
//!
//! [initial]
//! q = { q1 = 0.6 }                    # coordinates held during assembly
//! guess = { q2 = 1.2, q3 = 1.9 }      # starting values of the others (select the branch;
//!                                     #   default 0)
//! qd = { q1 = 0.0 }                   # velocities held; the others from J q' = 0
//! t = 0.0                             # start time (default 0)
//!
//! [integrator]
//! method = "dopri5"                   # or "rk4"
//! t_end = 5.0
//! rtol = 1e-10                        # dopri5 (default 1e-8)
//! atol = 1e-12                        # dopri5 (default 1e-10)
//! max_step = 0.05                     # dopri5, optional
//! initial_step = 1e-4                 # dopri5, optional
//! step = 1e-3                         # rk4 (required)
//! output_step = 0.01                  # default (t_end - t) / 500 (rk4: at least step;
//!                                     #   a smaller output_step is refused)
//! max_steps = 10000000                # optional
//!
//! [partition]                         # optional section
//! independent = ["q1"]                # optional; automatic (LU, full pivoting) otherwise
//! allow_redundant = false             # drop redundant constraint rows instead of stopping
//! repartition = true                  # change the partition when J_v degrades
//! switch_ratio = 10.0                 # ... when cond(J_v) > switch_ratio * best
//! max_condition = 1e8                 # ... or when cond(J_v) > max_condition
//! singular_condition = 1e12           # stop when even the best J_v is worse
//! rank_tol = 1e-9                     # relative pivot tolerance of the rank decision
//! projection_tol = 1e-10              # max |h| accepted after the Newton projection
//! ```
//!
//! Unknown keys are errors. Every problem is reported at once, each with the file, the line
//! and the entity (`scenarios/x.toml:7:8: [initial] q.q9: unknown coordinate "q9" ...`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use diagnostic::{Diagnostic, Diagnostics, Kind};
use hybrid_core::closed_loop::{Method, PartitionSettings, Settings};
use serde::Deserialize;
use toml::Spanned;

use super::Doc;

/// A named value with the line it was written on.
#[derive(Clone, Debug, PartialEq)]
pub struct Named {
    /// The coordinate name.
    pub name: String,
    /// The value.
    pub value: f64,
    /// 1-based line in the scenario file.
    pub line: usize,
}

/// The `[initial]` section.
#[derive(Clone, Debug, PartialEq)]
pub struct InitialSpec {
    /// Coordinates held during assembly, by name (sorted by name).
    pub q: Vec<Named>,
    /// Starting guesses for the other coordinates (sorted by name).
    pub guess: Vec<Named>,
    /// Velocities held (sorted by name).
    pub qd: Vec<Named>,
    /// Start time.
    pub t: f64,
}

/// A parsed, checked `kind = "mechanism"` scenario (names not yet resolved against a
/// model: see [`MechanismScenario::resolve`]).
#[derive(Clone, Debug, PartialEq)]
pub struct MechanismScenario {
    /// The scenario file as given.
    pub file: String,
    /// The model file, resolved relative to the scenario's directory.
    pub model: PathBuf,
    /// Free-text description.
    pub description: Option<String>,
    /// Initial conditions.
    pub initial: InitialSpec,
    /// Integration settings; `partition.independent` is left `None` (names are in
    /// [`MechanismScenario::independent`]).
    pub settings: Settings,
    /// Independent coordinates requested by name, with the line.
    pub independent: Option<(Vec<String>, usize)>,
}

/// A scenario resolved against a model's coordinate names.
#[derive(Clone, Debug, PartialEq)]
pub struct ResolvedScenario {
    /// Starting coordinates: the held values and the guesses (0 where nothing is given).
    pub q0: Vec<f64>,
    /// Indices of the held coordinates.
    pub fixed: Vec<usize>,
    /// Starting velocities (0 where nothing is given).
    pub qd0: Vec<f64>,
    /// Indices of the held velocities.
    pub qd_given: Vec<usize>,
    /// Settings with `partition.independent` resolved to indices.
    pub settings: Settings,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawInitial {
    #[serde(default)]
    q: BTreeMap<String, Spanned<f64>>,
    #[serde(default)]
    guess: BTreeMap<String, Spanned<f64>>,
    #[serde(default)]
    qd: BTreeMap<String, Spanned<f64>>,
    #[serde(default)]
    t: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawIntegrator {
    #[serde(default)]
    method: Option<Spanned<String>>,
    t_end: Spanned<f64>,
    #[serde(default)]
    rtol: Option<Spanned<f64>>,
    #[serde(default)]
    atol: Option<Spanned<f64>>,
    #[serde(default)]
    step: Option<Spanned<f64>>,
    #[serde(default)]
    max_step: Option<Spanned<f64>>,
    #[serde(default)]
    initial_step: Option<Spanned<f64>>,
    #[serde(default)]
    output_step: Option<Spanned<f64>>,
    #[serde(default)]
    max_steps: Option<Spanned<u64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPartition {
    #[serde(default)]
    independent: Option<Spanned<Vec<String>>>,
    #[serde(default)]
    allow_redundant: Option<bool>,
    #[serde(default)]
    repartition: Option<bool>,
    #[serde(default)]
    switch_ratio: Option<Spanned<f64>>,
    #[serde(default)]
    max_condition: Option<Spanned<f64>>,
    #[serde(default)]
    singular_condition: Option<Spanned<f64>>,
    #[serde(default)]
    rank_tol: Option<Spanned<f64>>,
    #[serde(default)]
    projection_tol: Option<Spanned<f64>>,
}

/// Range checks of single values, recorded in the document.
trait Check {
    /// A positive finite number, or a recorded problem.
    fn positive(&mut self, v: &Spanned<f64>, entity: &str) -> f64;
}

impl Check for Doc<'_> {
    fn positive(&mut self, v: &Spanned<f64>, entity: &str) -> f64 {
        let x = *v.get_ref();
        if !(x.is_finite() && x > 0.0) {
            self.push(
                Kind::InvalidValue,
                Some(v.span()),
                Some(entity),
                format!("must be a positive number, got {x}"),
            );
        }
        x
    }
}

/// Reads the sections of a mechanism scenario and checks every value.
pub(crate) fn from_doc(c: &mut Doc<'_>) -> Option<MechanismScenario> {
    c.check_keys(&[
        "kind",
        "model",
        "description",
        "initial",
        "integrator",
        "partition",
    ]);
    let file = c.file().to_string();
    let base_dir = c.base().to_path_buf();
    let raw_model = c.section::<String>("model", true);
    let description = c.section::<String>("description", false);
    let raw_initial = c.section::<RawInitial>("initial", false);
    let raw_integrator = c.section::<RawIntegrator>("integrator", true);
    let raw_partition = c.section::<RawPartition>("partition", false);
    let model = raw_model.as_ref().map(|m| {
        let p = Path::new(m.get_ref());
        if m.get_ref().trim().is_empty() {
            c.push(
                Kind::InvalidValue,
                Some(m.span()),
                Some("model"),
                "empty model path",
            );
        }
        let path = if p.is_absolute() {
            p.to_path_buf()
        } else {
            base_dir.join(p)
        };
        // The model file is checked now (a regular file within the size limit), read later.
        if !m.get_ref().trim().is_empty()
            && let Err(d) = diagnostic::check_input(&path, "model file")
        {
            c.push(Kind::Io, Some(m.span()), Some("model"), d.to_string());
        }
        path
    });
    // [initial]
    let named = |map: &BTreeMap<String, Spanned<f64>>, section: &str, c: &mut Doc<'_>| {
        map.iter()
            .map(|(k, v)| {
                let x = *v.get_ref();
                if !x.is_finite() {
                    c.push(
                        Kind::InvalidValue,
                        Some(v.span()),
                        Some(&format!("[initial] {section}.{k}")),
                        format!("must be a finite number, got {x}"),
                    );
                }
                Named {
                    name: k.clone(),
                    value: x,
                    line: c.index().line(v.span().start),
                }
            })
            .collect::<Vec<_>>()
    };
    let initial = match &raw_initial {
        Some(init) => {
            let i = init.get_ref();
            let q = named(&i.q, "q", c);
            let guess = named(&i.guess, "guess", c);
            let qd = named(&i.qd, "qd", c);
            for g in &guess {
                if i.q.contains_key(&g.name) {
                    let span = i.guess.get(&g.name).map(|v| v.span());
                    let entity = format!("[initial] guess.{}", g.name);
                    let msg = "coordinate is both held (q) and guessed";
                    c.push(Kind::Duplicate, span, Some(&entity), msg);
                }
            }
            let t = match &i.t {
                Some(t) if !t.get_ref().is_finite() => {
                    let span = Some(t.span());
                    c.push(
                        Kind::InvalidValue,
                        span,
                        Some("[initial] t"),
                        "must be finite",
                    );
                    0.0
                }
                Some(t) => *t.get_ref(),
                None => 0.0,
            };
            InitialSpec { q, guess, qd, t }
        }
        None => InitialSpec {
            q: vec![],
            guess: vec![],
            qd: vec![],
            t: 0.0,
        },
    };

    // [integrator]
    let raw_integrator = raw_integrator?;
    let ig = raw_integrator.get_ref();
    let t_end = *ig.t_end.get_ref();
    if !(t_end.is_finite() && t_end > initial.t) {
        c.push(
            Kind::InvalidValue,
            Some(ig.t_end.span()),
            Some("[integrator] t_end"),
            format!(
                "must be finite and later than the start time {}, got {t_end}",
                initial.t
            ),
        );
    }
    let method_name = ig
        .method
        .as_ref()
        .map_or("dopri5", |m| m.get_ref().as_str())
        .to_string();
    let forbid = |c: &mut Doc<'_>, v: &Option<Spanned<f64>>, key: &str, method: &str| {
        if let Some(v) = v {
            c.push(
                Kind::InvalidValue,
                Some(v.span()),
                Some(&format!("[integrator] {key}")),
                format!("not used by method \"{method}\""),
            );
        }
    };
    let method = match method_name.as_str() {
        "dopri5" => {
            forbid(c, &ig.step, "step", "dopri5");
            let rtol = ig
                .rtol
                .as_ref()
                .map_or(1e-8, |v| c.positive(v, "[integrator] rtol"));
            let atol = match &ig.atol {
                Some(v) if !(v.get_ref().is_finite() && *v.get_ref() >= 0.0) => {
                    c.push(
                        Kind::InvalidValue,
                        Some(v.span()),
                        Some("[integrator] atol"),
                        "must be a non-negative number",
                    );
                    0.0
                }
                Some(v) => *v.get_ref(),
                None => 1e-10,
            };
            Method::Dopri5 {
                rtol,
                atol,
                initial_step: ig
                    .initial_step
                    .as_ref()
                    .map(|v| c.positive(v, "[integrator] initial_step")),
                max_step: ig
                    .max_step
                    .as_ref()
                    .map(|v| c.positive(v, "[integrator] max_step")),
            }
        }
        "rk4" => {
            forbid(c, &ig.rtol, "rtol", "rk4");
            forbid(c, &ig.atol, "atol", "rk4");
            forbid(c, &ig.max_step, "max_step", "rk4");
            forbid(c, &ig.initial_step, "initial_step", "rk4");
            let step = match &ig.step {
                Some(v) => c.positive(v, "[integrator] step"),
                None => {
                    c.push(
                        Kind::MissingField,
                        Some(raw_integrator.span()),
                        Some("[integrator] step"),
                        "method \"rk4\" needs a fixed step `step`",
                    );
                    1.0
                }
            };
            Method::Rk4 { step }
        }
        other => {
            let span = ig.method.as_ref().map(|m| m.span());
            c.push(
                Kind::InvalidValue,
                span,
                Some("[integrator] method"),
                format!("unknown method {other:?} (expected \"dopri5\" or \"rk4\")"),
            );
            Method::Rk4 { step: 1.0 }
        }
    };
    let span_len = if t_end.is_finite() {
        (t_end - initial.t).max(0.0)
    } else {
        1.0
    };
    // RK4 rows are never closer than its steps (rows between steps would only be
    // interpolated): the default is at least the step, a smaller given one is refused.
    let min_output_step = match method {
        Method::Rk4 { step } if step.is_finite() && step > 0.0 => step,
        _ => 0.0,
    };
    let output_step = match &ig.output_step {
        Some(v) => {
            let o = c.positive(v, "[integrator] output_step");
            if o.is_finite() && o > 0.0 && o < min_output_step {
                c.push(
                    Kind::InvalidValue,
                    Some(v.span()),
                    Some("[integrator] output_step"),
                    format!(
                        "must be at least the rk4 step {min_output_step} (got {o}): rows between steps would only be interpolated"
                    ),
                );
            }
            o
        }
        None => (span_len / 500.0).max(min_output_step),
    };
    let max_steps = ig
        .max_steps
        .as_ref()
        .map_or(10_000_000, |v| *v.get_ref() as usize);

    // [partition]
    let mut ps = PartitionSettings::default();
    let mut projection_tol = 1e-10;
    let mut independent = None;
    if let Some(p) = &raw_partition {
        let p = p.get_ref();
        if let Some(ind) = &p.independent {
            independent = Some((ind.get_ref().clone(), c.index().line(ind.span().start)));
        }
        if let Some(v) = p.allow_redundant {
            ps.allow_redundant = v;
        }
        if let Some(v) = p.repartition {
            ps.repartition = v;
        }
        if let Some(v) = &p.switch_ratio {
            ps.switch_ratio = c.positive(v, "[partition] switch_ratio");
            if ps.switch_ratio < 1.0 {
                let entity = Some("[partition] switch_ratio");
                c.push(
                    Kind::InvalidValue,
                    Some(v.span()),
                    entity,
                    "must be at least 1",
                );
            }
        }
        if let Some(v) = &p.max_condition {
            ps.max_condition = c.positive(v, "[partition] max_condition");
        }
        if let Some(v) = &p.singular_condition {
            ps.singular_condition = c.positive(v, "[partition] singular_condition");
        }
        if let Some(v) = &p.rank_tol {
            ps.rank_tol = c.positive(v, "[partition] rank_tol");
            if ps.rank_tol >= 1.0 {
                let entity = Some("[partition] rank_tol");
                c.push(
                    Kind::InvalidValue,
                    Some(v.span()),
                    entity,
                    "must be below 1",
                );
            }
        }
        if let Some(v) = &p.projection_tol {
            projection_tol = c.positive(v, "[partition] projection_tol");
        }
    }
    let t_start = initial.t;
    Some(MechanismScenario {
        file,
        model: model?,
        description: description.map(Spanned::into_inner),
        initial,
        settings: Settings {
            method,
            t_start,
            t_end,
            output_step,
            partition: ps,
            projection_tol,
            max_steps,
            log: false,
        },
        independent,
    })
}

/// Parses and checks mechanism scenario text; `file` names it in messages, `base_dir`
/// resolves the relative model path.
pub fn parse_str(
    text: &str,
    file: &str,
    base_dir: &Path,
) -> Result<MechanismScenario, Diagnostics> {
    match super::parse_in(text, file, base_dir)? {
        super::Scenario::Mechanism(s) => Ok(*s),
        _ => Err(Diagnostic::new(
            Kind::Unsupported,
            file,
            "not a `kind = \"mechanism\"` scenario",
        )
        .into()),
    }
}

impl MechanismScenario {
    /// Resolves the coordinate names against a model's `coordinate_names`, reporting every
    /// unknown name with its line.
    pub fn resolve(&self, coordinate_names: &[String]) -> Result<ResolvedScenario, Diagnostics> {
        let n = coordinate_names.len();
        let mut errors = vec![];
        let known = coordinate_names.join(", ");
        let mut find = |name: &str, line: usize, entity: String| -> Option<usize> {
            let k = coordinate_names.iter().position(|c| c == name);
            if k.is_none() {
                errors.push(
                    Diagnostic::new(
                        Kind::UnknownName,
                        self.file.clone(),
                        format!("unknown coordinate {name:?} (the model has {known})"),
                    )
                    .at_line(Some(line))
                    .entity(entity),
                );
            }
            k
        };
        let mut q0 = vec![0.0; n];
        let mut fixed = vec![];
        for v in &self.initial.q {
            if let Some(k) = find(&v.name, v.line, format!("[initial] q.{}", v.name)) {
                q0[k] = v.value;
                fixed.push(k);
            }
        }
        for v in &self.initial.guess {
            if let Some(k) = find(&v.name, v.line, format!("[initial] guess.{}", v.name)) {
                q0[k] = v.value;
            }
        }
        let mut qd0 = vec![0.0; n];
        let mut qd_given = vec![];
        for v in &self.initial.qd {
            if let Some(k) = find(&v.name, v.line, format!("[initial] qd.{}", v.name)) {
                qd0[k] = v.value;
                qd_given.push(k);
            }
        }
        let mut settings = self.settings.clone();
        if let Some((names, line)) = &self.independent {
            let mut idx = vec![];
            let mut twice = vec![];
            for name in names {
                if let Some(k) = find(name, *line, "[partition] independent".into()) {
                    if idx.contains(&k) {
                        twice.push(name.clone());
                    }
                    idx.push(k);
                }
            }
            settings.partition.independent = Some(idx);
            for name in twice {
                errors.push(
                    Diagnostic::new(
                        Kind::Duplicate,
                        self.file.clone(),
                        format!("coordinate {name:?} listed twice"),
                    )
                    .at_line(Some(*line))
                    .entity("[partition] independent"),
                );
            }
        }
        if !errors.is_empty() {
            return Err(Diagnostics(errors));
        }
        fixed.sort_unstable();
        qd_given.sort_unstable();
        Ok(ResolvedScenario {
            q0,
            fixed,
            qd0,
            qd_given,
            settings,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bundled scenarios' directory: the model files the tests name exist there (the
    /// loader checks them).
    const SCENARIOS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios");

    const GOOD: &str = r#"
kind = "mechanism"
model = "../models/four_bar.toml"
[initial]
q = { q1 = 0.6 }
guess = { q2 = 1.2, q3 = 1.9 }
qd = { q1 = 0.0 }
[integrator]
method = "dopri5"
t_end = 5.0
rtol = 1e-10
atol = 1e-12
output_step = 0.01
[partition]
independent = ["q1"]
"#;

    #[test]
    fn parses_and_resolves() {
        let s = parse_str(GOOD, "s.toml", Path::new(SCENARIOS)).unwrap();
        assert_eq!(
            s.model,
            Path::new(SCENARIOS).join("../models/four_bar.toml")
        );
        let names: Vec<String> = ["q1", "q2", "q3"].iter().map(|s| s.to_string()).collect();
        let r = s.resolve(&names).unwrap();
        assert_eq!(r.q0, vec![0.6, 1.2, 1.9]);
        assert_eq!(r.fixed, vec![0]);
        assert_eq!(r.settings.partition.independent, Some(vec![0]));
        assert_eq!(r.settings.output_step, 0.01);
    }

    #[test]
    fn unknown_keys_and_names_report_lines() {
        let bad = GOOD.replace("rtol = 1e-10", "rtoll = 1e-10");
        let e = parse_str(&bad, "s.toml", Path::new(SCENARIOS)).unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("s.toml:11:"), "{msg}");
        assert!(msg.contains("rtoll"), "{msg}");

        let s = parse_str(
            &GOOD.replace("q2 = 1.2", "q7 = 1.2"),
            "s.toml",
            Path::new(SCENARIOS),
        )
        .unwrap();
        let names: Vec<String> = ["q1", "q2", "q3"].iter().map(|s| s.to_string()).collect();
        let msg = s.resolve(&names).unwrap_err().to_string();
        assert!(
            msg.contains("s.toml:6: [initial] guess.q7: unknown coordinate \"q7\""),
            "{msg}"
        );
    }

    #[test]
    fn rk4_output_step_below_the_step_is_refused_at_its_line() {
        let rk4 = GOOD
            .replace("method = \"dopri5\"", "method = \"rk4\"")
            .replace("rtol = 1e-10\natol = 1e-12", "step = 0.02");
        let msg = parse_str(&rk4, "s.toml", Path::new(SCENARIOS))
            .unwrap_err()
            .to_string();
        assert!(
            msg.starts_with("s.toml:12:")
                && msg.contains("[integrator] output_step")
                && msg.contains("at least the rk4 step 0.02 (got 0.01)"),
            "{msg}"
        );
        // Without an output step the default, t_end / 500 = 0.01, is raised to the step.
        let s = parse_str(
            &rk4.replace("output_step = 0.01\n", ""),
            "s.toml",
            Path::new(SCENARIOS),
        )
        .unwrap();
        assert_eq!(s.settings.output_step, 0.02);
        let s = parse_str(
            &rk4.replace("step = 0.02", "step = 0.01"),
            "s.toml",
            Path::new(SCENARIOS),
        );
        assert_eq!(s.unwrap().settings.output_step, 0.01);
    }

    #[test]
    fn method_specific_keys_are_checked_together() {
        let bad = GOOD
            .replace("method = \"dopri5\"", "method = \"rk4\"")
            .replace("t_end = 5.0", "t_end = -1.0");
        let e = parse_str(&bad, "s.toml", Path::new(SCENARIOS)).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("t_end"), "{msg}");
        assert!(msg.contains("rtol: not used"), "{msg}");
        assert!(msg.contains("needs a fixed step"), "{msg}");
        assert!(e.0.len() >= 4, "{msg}");
    }
}
