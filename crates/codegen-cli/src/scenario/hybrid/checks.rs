//! The value checks and helpers the hybrid reader shares between its sections: one value
//! deserialized on its own, arrays of tables, unique names, references to mechanisms,
//! finite numbers, abscissae on the beam. Each records its problem in the document.

use std::collections::BTreeMap;

use diagnostic::Kind;
use serde::de::DeserializeOwned;
use toml::Spanned;
use toml::de::{DeTable, DeValue, ValueDeserializer};

use crate::scenario::Doc;

/// Deserializes one value on its own; a malformed one is reported (at the serde error's
/// span) and `None`.
pub(super) fn de<'a, T: DeserializeOwned>(
    doc: &mut Doc<'a>,
    v: Spanned<DeValue<'a>>,
    entity: &str,
) -> Option<T> {
    let span = v.span();
    match T::deserialize(ValueDeserializer::from(v)) {
        Ok(t) => Some(t),
        Err(e) => {
            let at = e.span().or(Some(span));
            doc.push(Kind::Syntax, at, Some(entity), e.message().trim());
            None
        }
    }
}

/// The tables of the array of tables `[[key]]` (empty when absent; reported when `key` is
/// something else).
pub(super) fn tables<'a>(doc: &mut Doc<'a>, key: &str) -> Vec<Spanned<DeValue<'a>>> {
    let Some(v) = doc.root.get(key) else {
        return vec![];
    };
    match v.get_ref() {
        DeValue::Array(items)
            if items
                .iter()
                .all(|i| matches!(i.get_ref(), DeValue::Table(_))) =>
        {
            items.iter().cloned().collect()
        }
        _ => {
            let span = v.span();
            let msg = format!("must be an array of tables, written [[{key}]]");
            doc.push(Kind::Syntax, Some(span), Some(&format!("[[{key}]]")), msg);
            vec![]
        }
    }
}

/// The entries of a table value with `keys` taken out (as a table) and the rest.
pub(super) fn split<'a>(
    v: &Spanned<DeValue<'a>>,
    keys: &[&str],
) -> (DeTable<'a>, Spanned<DeValue<'a>>) {
    let mut taken = DeTable::new();
    let mut rest = DeTable::new();
    if let DeValue::Table(t) = v.get_ref() {
        for (k, x) in t.iter() {
            if keys.contains(&k.get_ref().as_ref()) {
                taken.insert(k.clone(), x.clone());
            } else {
                rest.insert(k.clone(), x.clone());
            }
        }
    }
    (taken, Spanned::new(v.span(), DeValue::Table(rest)))
}

/// Records a duplicate name.
pub(super) fn unique(
    doc: &mut Doc<'_>,
    seen: &mut BTreeMap<String, ()>,
    name: &Spanned<String>,
    what: &str,
) {
    if seen.insert(name.get_ref().clone(), ()).is_some() {
        let entity = format!("{what} \"{}\"", name.get_ref());
        let msg = format!("a {what} of this name is already defined");
        doc.push(Kind::Duplicate, Some(name.span()), Some(&entity), msg);
    }
}

/// The index of the mechanism `name`, or a recorded problem.
pub(super) fn mechanism_ref(
    doc: &mut Doc<'_>,
    names: &[String],
    name: &Spanned<String>,
    entity: &str,
) -> Option<usize> {
    let k = names.iter().position(|n| n == name.get_ref());
    if k.is_none() {
        let msg = format!(
            "unknown mechanism {:?} (mechanisms: {})",
            name.get_ref(),
            list(names)
        );
        if doc.unread_mechanisms > 0 {
            // Most likely a mechanism whose table could not be read: after that problem.
            let msg = format!("{msg}; a [[mechanism]] table could not be read");
            let d = doc.diagnostic(Kind::UnknownName, Some(name.span()), Some(entity), msg);
            doc.push_cascade(d);
        } else {
            doc.push(Kind::UnknownName, Some(name.span()), Some(entity), msg);
        }
    }
    k
}

/// The names, comma-separated (`none` when there is none).
pub(crate) fn list(names: &[String]) -> String {
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}

/// A finite value, or a recorded problem.
pub(super) fn finite(doc: &mut Doc<'_>, v: &Spanned<f64>, entity: &str) -> f64 {
    let x = *v.get_ref();
    if !x.is_finite() {
        let msg = format!("must be a finite number (got {x})");
        doc.push(Kind::InvalidValue, Some(v.span()), Some(entity), msg);
    }
    x
}

/// Where an abscissa can lie: on the beam, when there is one.
pub(super) struct OnBeam {
    /// The beam's length (m), when it is written and valid.
    pub(super) length: Option<f64>,
    /// Whether a `[beam]` is written (valid or not).
    pub(super) written: bool,
    /// Whether a `[structure]` is written (its nodes are read when the model is built).
    pub(super) structure: bool,
}

impl OnBeam {
    /// Whether `x` lies on the beam, or a recorded problem (none when the beam is written but
    /// invalid: the beam's own problem is reported).
    pub(super) fn check(&self, doc: &mut Doc<'_>, x: &Spanned<f64>, entity: &str) -> bool {
        let v = *x.get_ref();
        match self.length {
            Some(l) if v.is_finite() && v >= 0.0 && v <= l * (1.0 + 1e-12) => true,
            Some(l) => {
                let msg = format!("must lie on the beam, 0 to {l} m (got {v})");
                doc.push(Kind::InvalidValue, Some(x.span()), Some(entity), msg);
                false
            }
            None if self.written => false, // the beam's own problem is reported
            None if self.structure => {
                let msg = "the host is a [structure]: name a node (node = ...) instead of a beam abscissa";
                doc.push(Kind::InvalidValue, Some(x.span()), Some(entity), msg);
                false
            }
            None => {
                let msg = "there is no [beam] to attach to or to load";
                doc.push(Kind::InvalidValue, Some(x.span()), Some(entity), msg);
                false
            }
        }
    }

    /// Whether a node can be named (a `[structure]` is written), or a recorded problem. The
    /// node itself is looked up in the structure's `nodes.csv` when the model is built.
    pub(super) fn check_node(&self, doc: &mut Doc<'_>, n: &Spanned<u64>, entity: &str) -> bool {
        if self.structure {
            return true;
        }
        let msg = if self.written {
            "the host is a [beam]: give a beam abscissa (x = ...) instead of a node"
        } else {
            "there is no [structure] whose node this could be"
        };
        doc.push(Kind::InvalidValue, Some(n.span()), Some(entity), msg);
        false
    }
}
