//! Entry points: read a model file or a string, parse it and validate it into a [`Model`].

use std::path::Path;

use diagnostic::{Diagnostic, Diagnostics, Kind, LineIndex};

use super::source::{Position, fnv1a_hex, json_to_node, toml_to_node};
use super::types::{Model, SourceInfo};
use super::validate::validate;

/// The text format of a model file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// TOML (`.toml`), the preferred format for hand-written models.
    Toml,
    /// JSON (`.json`), same structure as the TOML format.
    Json,
}

impl Format {
    /// The format given by a file extension (`.toml` or `.json`, any letter case).
    pub fn from_path(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "toml" => Some(Format::Toml),
            "json" => Some(Format::Json),
            _ => None,
        }
    }
}

/// Reads and validates a model file (format from the extension: `.toml` or `.json`).
///
/// Every problem is reported at once, each with the file, the line and the entity.
pub fn load(path: &Path) -> Result<Model, Diagnostics> {
    let file = path.display().to_string();
    let single =
        |kind: Kind, message: String| Diagnostics::from(Diagnostic::new(kind, &file, message));
    let Some(format) = Format::from_path(path) else {
        return Err(single(
            Kind::Unsupported,
            "unknown model file extension (expected .toml or .json)".into(),
        ));
    };
    let src = diagnostic::read_input(path, "model file").map_err(Diagnostics::from)?;
    parse_str(&src, &file, format)
}

/// Parses and validates model text; `file` is the name used in messages and in
/// [`SourceInfo::path`].
pub fn parse_str(src: &str, file: &str, format: Format) -> Result<Model, Diagnostics> {
    let lines = LineIndex::new(src);
    let tree = match format {
        Format::Toml => toml_to_node(src, &lines),
        Format::Json => json_to_node(src, &lines),
    };
    let root = tree.map_err(|errors| {
        Diagnostics(
            errors
                .into_iter()
                .map(|(position, message)| {
                    let mut d =
                        Diagnostic::new(Kind::Syntax, file, format!("syntax error: {message}"));
                    match position {
                        Position::Offset(offset) => d = d.at_offset(&lines, offset),
                        Position::Line(line) => d = d.at_line(Some(line)),
                        Position::Unknown => {}
                    }
                    d
                })
                .collect(),
        )
    })?;
    let source = SourceInfo {
        path: file.to_string(),
        hash: fnv1a_hex(src.as_bytes()),
    };
    validate(&root, file, source).map_err(Diagnostics)
}
