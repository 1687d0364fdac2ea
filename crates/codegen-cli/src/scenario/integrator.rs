//! `[integrator]` of a scenario: the Newmark / HHT scheme (docs/theory.md section 8), its time
//! step and end time, checked at load.

use diagnostic::Kind;
use hybrid_core::hybrid::Method;
use serde::{Deserialize, Serialize};

use super::Doc;

/// `[integrator]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorSpec {
    /// `"newmark"` (average acceleration) or `"hht"`.
    #[serde(default = "default_method")]
    pub method: String,
    /// HHT parameter in [-1/3, 0] (`method = "hht"` only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f64>,
    /// Time step (s).
    pub dt: f64,
    /// End time (s).
    pub t_end: f64,
}

fn default_method() -> String {
    "newmark".into()
}

/// Checks `[integrator]`; the scheme when it is usable.
pub(crate) fn check_integrator(doc: &mut Doc<'_>, ig: &IntegratorSpec) -> Option<Method> {
    let at = |doc: &Doc<'_>, key: &str| doc.span(&["integrator", key]);
    let mut ok = true;
    if !(ig.dt.is_finite() && ig.dt > 0.0) {
        let msg = format!("must be positive (got {})", ig.dt);
        doc.push(
            Kind::InvalidValue,
            at(doc, "dt"),
            Some("[integrator] dt"),
            msg,
        );
        ok = false;
    }
    if !(ig.t_end.is_finite() && ig.t_end > 0.0) {
        let msg = format!("must be positive (got {})", ig.t_end);
        let span = at(doc, "t_end");
        doc.push(Kind::InvalidValue, span, Some("[integrator] t_end"), msg);
        ok = false;
    }
    if ok && ig.dt > ig.t_end {
        let msg = format!(
            "must not exceed t_end (dt = {}, t_end = {}: not one step would be taken)",
            ig.dt, ig.t_end
        );
        doc.push(
            Kind::InvalidValue,
            at(doc, "dt"),
            Some("[integrator] dt"),
            msg,
        );
        ok = false;
    }
    if ok && ig.t_end / ig.dt > 1e9 {
        let msg = format!("t_end / dt = {:.3e} steps is too many", ig.t_end / ig.dt);
        doc.push(Kind::InvalidValue, at(doc, "dt"), Some("[integrator]"), msg);
        ok = false;
    }
    let method = match (ig.method.as_str(), ig.alpha) {
        ("newmark", None) => Some(Method::Newmark),
        ("newmark", Some(_)) => {
            let msg = "alpha is for method = \"hht\"";
            let span = at(doc, "alpha");
            doc.push(Kind::InvalidValue, span, Some("[integrator] alpha"), msg);
            None
        }
        ("hht", a) => {
            let alpha = a.unwrap_or(-0.05);
            if (-1.0 / 3.0..=0.0).contains(&alpha) {
                Some(Method::Hht { alpha })
            } else {
                let msg = format!("must be in [-1/3, 0] (got {alpha})");
                let span = at(doc, "alpha");
                doc.push(Kind::InvalidValue, span, Some("[integrator] alpha"), msg);
                None
            }
        }
        (other, _) => {
            let msg = format!("unknown method {other:?} (expected \"newmark\" or \"hht\")");
            let span = at(doc, "method");
            doc.push(Kind::InvalidValue, span, Some("[integrator] method"), msg);
            None
        }
    };
    method.filter(|_| ok)
}
