//! Rust names of the model's things: the struct name, the fields of the run-time parameters
//! and the point functions, each checked to be an identifier and not to clash.

use std::collections::BTreeMap;

use proc_macro2::{Ident, Span};

use super::{EmitError, EmitOptions};
use crate::model::Model;

/// Turns a model name into a Rust identifier: ASCII letters, digits and `_`, not starting
/// with a digit, not a keyword.
pub fn sanitize_ident(name: &str) -> String {
    let mut s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.starts_with(|c: char| c.is_ascii_digit()) {
        s.insert(0, '_');
    }
    if syn::parse_str::<Ident>(&s).is_err() || s == "_" || s == "self" || s == "Self" {
        s.push('_');
    }
    s
}

fn camel_case(name: &str) -> String {
    let mut out = String::new();
    for part in name
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|p| !p.is_empty())
    {
        let mut cs = part.chars();
        if let Some(f) = cs.next() {
            out.push(f.to_ascii_uppercase());
            out.extend(cs);
        }
    }
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, 'M');
    }
    sanitize_ident(&out)
}

/// The struct name: `opts.struct_name` if given (checked to be a plain ASCII identifier),
/// else the model name in UpperCamelCase.
pub(super) fn struct_name(model: &Model, opts: &EmitOptions) -> Result<String, EmitError> {
    match &opts.struct_name {
        // `Ident::new` panics on a string that is no identifier (or a raw `r#` one) and
        // accepts keywords, which would only fail later as an internal parse error: check
        // with syn's parser and allow plain ASCII identifiers only.
        Some(name) => match syn::parse_str::<Ident>(name) {
            Ok(_) if name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') => {
                Ok(name.clone())
            }
            _ => Err(EmitError::StructName { name: name.clone() }),
        },
        None => Ok(camel_case(&model.name)),
    }
}

/// The field name of every parameter, by parameter index (run-time parameters become struct
/// fields, so two of them must not share a name).
pub(super) fn param_idents(model: &Model) -> Result<Vec<Ident>, EmitError> {
    let mut idents: Vec<Ident> = Vec::with_capacity(model.parameters.len());
    let mut seen: BTreeMap<String, String> = BTreeMap::new();
    for p in &model.parameters {
        let id = sanitize_ident(&p.name);
        if p.runtime {
            if let Some(prev) = seen.insert(id.clone(), p.name.clone()) {
                return Err(EmitError::IdentClash {
                    file: model.source.path.clone(),
                    what: "parameters",
                    a: prev,
                    b: p.name.clone(),
                    ident: id,
                });
            }
        }
        idents.push(Ident::new(&id, Span::call_site()));
    }
    Ok(idents)
}

/// The method name `point_<name>` of every named point, by point index.
pub(super) fn point_fns(model: &Model) -> Result<Vec<Ident>, EmitError> {
    let mut fns: Vec<Ident> = Vec::new();
    let mut seen: BTreeMap<String, String> = BTreeMap::new();
    for p in &model.points {
        let id = sanitize_ident(&format!("point_{}", p.name.to_lowercase()));
        if let Some(prev) = seen.insert(id.clone(), p.name.clone()) {
            return Err(EmitError::IdentClash {
                file: model.source.path.clone(),
                what: "points",
                a: prev,
                b: p.name.clone(),
                ident: id,
            });
        }
        fns.push(Ident::new(&id, Span::call_site()));
    }
    Ok(fns)
}

/// The method name `position_<name>` (position and Jacobian only) of every named point, by
/// point index: `point_<name>` with the other prefix, so unique when those are.
pub(super) fn position_fns(point_fns: &[Ident]) -> Vec<Ident> {
    point_fns
        .iter()
        .map(|f| {
            let name = f.to_string();
            let rest = name.strip_prefix("point_").unwrap_or(&name);
            Ident::new(&format!("position_{rest}"), Span::call_site())
        })
        .collect()
}

/// The name of the cache field of hoisted subexpressions: `hoisted`, with `_` appended
/// until it differs from every parameter field.
pub(super) fn cache_field(param_idents: &[Ident]) -> Ident {
    let mut name = String::from("hoisted");
    while param_idents.iter().any(|p| *p == name) {
        name.push('_');
    }
    Ident::new(&name, Span::call_site())
}
