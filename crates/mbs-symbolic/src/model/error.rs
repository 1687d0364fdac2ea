//! Diagnostics of model loading: every problem of a model file, with the file, the line and
//! the entity (body, point, force, ...) the user wrote.

use std::fmt;

/// One problem found while reading or validating a model file.
///
/// Displayed as `FILE:LINE: ENTITY: message`, leaving out the parts that are missing, e.g.
///
/// ```text
/// models/double_bar.toml:31: body "coupler": unknown parent `crnk`
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ModelError {
    /// File name as given by the user (or the name passed to [`parse_str`](super::parse_str)).
    pub file: String,
    /// 1-based line of the problem, when known.
    pub line: Option<usize>,
    /// The entity concerned, e.g. `body "crank"`, `parameter "m1"`, `force "spring_2"`.
    pub entity: Option<String>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if !self.file.is_empty() {
            f.write_str(&self.file)?;
            if let Some(line) = self.line {
                write!(f, ":{line}")?;
            }
            f.write_str(": ")?;
        } else if let Some(line) = self.line {
            write!(f, "line {line}: ")?;
        }
        if let Some(entity) = &self.entity {
            write!(f, "{entity}: ")?;
        }
        f.write_str(&self.message)
    }
}

impl std::error::Error for ModelError {}

/// All the problems of a model file, in line order (validation never stops at the first).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{}", display_lines(.0))]
pub struct ModelErrors(pub Vec<ModelError>);

fn display_lines(errors: &[ModelError]) -> String {
    errors
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join("\n")
}

impl ModelErrors {
    /// Number of problems.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// True when there is no problem (never the case for an `Err` returned by this module).
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The problems, in line order.
    pub fn iter(&self) -> std::slice::Iter<'_, ModelError> {
        self.0.iter()
    }
}

impl<'a> IntoIterator for &'a ModelErrors {
    type Item = &'a ModelError;
    type IntoIter = std::slice::Iter<'a, ModelError>;

    fn into_iter(self) -> Self::IntoIter {
        self.0.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(line: Option<usize>, entity: Option<&str>) -> ModelError {
        ModelError {
            file: "m.toml".into(),
            line,
            entity: entity.map(str::to_string),
            message: "bad".into(),
        }
    }

    #[test]
    fn display_omits_missing_parts() {
        assert_eq!(
            e(Some(3), Some("body \"a\"")).to_string(),
            "m.toml:3: body \"a\": bad"
        );
        assert_eq!(
            e(None, Some("body \"a\"")).to_string(),
            "m.toml: body \"a\": bad"
        );
        assert_eq!(e(Some(3), None).to_string(), "m.toml:3: bad");
        assert_eq!(e(None, None).to_string(), "m.toml: bad");
        let all = ModelErrors(vec![e(Some(1), None), e(Some(2), None)]);
        assert_eq!(all.to_string(), "m.toml:1: bad\nm.toml:2: bad");
    }
}
