//! Where the problems of a beam description are in its TOML text: the one way this crate
//! finds a line. The text is parsed once into a span-carrying document (`toml::de::DeTable`),
//! the span of the entity's table or field is looked up, and [`LineIndex`] turns its byte
//! offset into a line; no scanning of the text for keys.
//!
//! Validation problems ([`InputError`]) are located at their field (`segment 1: length` ->
//! the line of `length` in the second `[[segment]]`), at the entity's table when the field is
//! absent, at the array when the entry is absent; TOML syntax and type errors at the span
//! the parser reports, with the column.

use diagnostic::{Diagnostic, Diagnostics, Kind, LineIndex};
use toml::de::{DeTable, DeValue};

use crate::error::InputError;

/// A beam description's TOML text, parsed once for spans, with its line index.
struct SourceMap<'t> {
    root: Option<DeValue<'t>>,
    lines: LineIndex,
}

impl<'t> SourceMap<'t> {
    fn new(text: &'t str) -> Self {
        Self {
            root: DeTable::parse(text)
                .ok()
                .map(|t| DeValue::Table(t.into_inner())),
            lines: LineIndex::new(text),
        }
    }

    /// The byte offset of `[prefix..][key][index].field`, or of the closest enclosing item
    /// found (`None` when not even `key` is there).
    fn offset(
        &self,
        prefix: &[&str],
        key: &str,
        index: Option<usize>,
        field: Option<&str>,
    ) -> Option<usize> {
        let mut cur = self.root.as_ref()?;
        for p in prefix {
            cur = cur.get(*p)?.get_ref();
        }
        let item = cur.get(key)?;
        let mut span = item.span();
        let mut cur = item.get_ref();
        if let Some(i) = index {
            match cur.get(i) {
                Some(v) => {
                    span = v.span();
                    cur = v.get_ref();
                }
                None => return Some(span.start),
            }
        }
        if let Some(v) = field.and_then(|f| cur.get(f)) {
            span = v.span();
        }
        Some(span.start)
    }

    /// The 1-based line of a validation problem's field (see the module documentation).
    fn line(&self, prefix: &[&str], error: &InputError) -> Option<usize> {
        let (entity, field) = error.location();
        let (key, index) = entity?.toml_key();
        // Nested fields (`time.at`, `ratios[1].ratio`) are located at their top-level key.
        let field = field.map(|f| f.split(['.', '[']).next().unwrap_or(f));
        self.offset(prefix, key, index, field)
            .map(|offset| self.lines.line(offset))
    }
}

/// Validation problems of a beam description as diagnostics located in its TOML `text`
/// (named `file` in messages), sorted in file order (problems without a line last, in the
/// order found). `prefix` is the path of the beam table inside a larger document (e.g.
/// `["beam"]` in a scenario file; empty for a beam file).
///
/// Lines only, no columns: a problem is about a field's value as a whole.
pub fn input_diagnostics(
    errors: &[InputError],
    text: &str,
    file: &str,
    prefix: &[&str],
) -> Diagnostics {
    let map = SourceMap::new(text);
    let mut all = Diagnostics(
        errors
            .iter()
            .map(|e| e.to_diagnostic(file, map.line(prefix, e)))
            .collect(),
    );
    all.sort();
    all
}

/// A TOML syntax or type error (including unknown and missing fields) as a diagnostic with
/// the line and column of the span the parser reports.
pub(crate) fn parse_diagnostic(error: &toml::de::Error, text: &str, file: &str) -> Diagnostic {
    let message = error.message().trim();
    // serde's messages for these two start with fixed words.
    let kind = if message.starts_with("unknown field") {
        Kind::UnknownField
    } else if message.starts_with("missing field") {
        Kind::MissingField
    } else {
        Kind::Syntax
    };
    let d = Diagnostic::new(kind, file, message);
    match error.span() {
        Some(span) => d.at_offset(&LineIndex::new(text), span.start),
        None => d,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Entity;

    // The spec module's sample beam file (the same lines; it only adds a distributed load at
    // the end).
    use crate::spec::tests::SAMPLE;

    fn line_of(key: &str, index: Option<usize>, field: Option<&str>) -> Option<usize> {
        let map = SourceMap::new(SAMPLE);
        map.offset(&[], key, index, field)
            .map(|o| map.lines.line(o))
    }

    #[test]
    fn locates_fields() {
        assert_eq!(line_of("segment", Some(1), Some("length")), Some(13));
        assert_eq!(line_of("support", Some(1), Some("x")), Some(25));
        assert_eq!(line_of("damping", None, Some("ratios")), Some(29));
        // Field absent: falls back to the table.
        assert_eq!(line_of("support", Some(0), Some("x")), Some(20));
        assert_eq!(line_of("nothing", None, None), None);
    }

    #[test]
    fn diagnostics_are_in_file_order_with_nested_fields_at_their_key() {
        let errors = [
            InputError::NoSegments,
            InputError::NotFinite {
                entity: Entity::Load(0),
                field: "time.frequency_hz",
                value: f64::NAN,
            },
            InputError::Negative {
                entity: Entity::Damping,
                field: "ratios[1].ratio",
                value: -1.0,
            },
            InputError::NoElements { segment: 1 },
        ];
        let all = input_diagnostics(&errors, SAMPLE, "s.toml", &[]);
        let lines: Vec<_> = all.iter().map(|d| d.line).collect();
        assert_eq!(lines, [Some(18), Some(29), Some(34), None]);
        assert_eq!(all.0[0].entity.as_deref(), Some("segment 1"));
        assert_eq!(all.0[3].kind, Kind::MissingField);
        // Inside a larger document.
        let nested = format!(
            "[beam]\n{}",
            SAMPLE
                .replace("[[", "[[beam.")
                .replace("[damping]", "[beam.damping]")
        );
        let all = input_diagnostics(&errors[3..], &nested, "s.toml", &["beam"]);
        assert_eq!(all.0[0].line, Some(19));
    }
}
