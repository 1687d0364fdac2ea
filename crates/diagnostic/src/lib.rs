//! The one diagnostic type of the workspace: a problem in a file the user wrote (a mechanism
//! model, a beam description, a scenario), with the file, the line and column when known,
//! the entity the user named (`body "crank"`, `segment 2`, `attachment "tip"`), a message,
//! and a machine-readable [`Kind`].
//!
//! Every loader reports *all* problems of a file at once as [`Diagnostics`], in source order;
//! displayed, each diagnostic is one line:
//!
//! ```text
//! models/double_bar.toml:31:5: body "coupler": unknown parent `crnk`
//! ```
//!
//! Lines and columns come from byte offsets (parser spans) through [`LineIndex`], the one
//! place that turns a position in a text into a line and a column.

#![warn(missing_docs)]

mod input;
mod suggest;

use std::fmt;

use serde::Serialize;

pub use input::{MAX_INPUT_BYTES, check_input, read_input, read_input_bytes};
pub use suggest::{closest, did_you_mean, levenshtein, nearest, suggest_field};

/// What kind of problem a [`Diagnostic`] reports (machine-readable; serialised in
/// `snake_case`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// The file could not be read.
    Io,
    /// The text is not valid TOML / JSON, or a value has the wrong type.
    Syntax,
    /// A field the format does not know.
    UnknownField,
    /// A required field is missing.
    MissingField,
    /// A reference to a name that is not defined (a parent body, a point, a joint).
    UnknownName,
    /// Two entities with the same name.
    Duplicate,
    /// A value out of its physical or numerical range (non-positive mass, NaN, dt > t_end).
    InvalidValue,
    /// A structure the tool cannot use (a cycle of bodies, a model of the wrong shape).
    Unsupported,
}

/// One problem in a user file.
///
/// Displayed as `FILE:LINE:COLUMN: ENTITY: message`, leaving out the parts that are missing
/// (no line without a file prefix is written as `line N: ...`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Diagnostic {
    /// File name as given by the user (may be empty for text given in memory).
    pub file: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// 1-based column (in characters), when known.
    pub column: Option<usize>,
    /// The entity concerned, as the user wrote it, e.g. `body "crank"`, `segment 2`.
    pub entity: Option<String>,
    /// What is wrong, and where possible what would be right.
    pub message: String,
    /// Machine-readable kind of problem.
    pub kind: Kind,
}

impl Diagnostic {
    /// A diagnostic of `kind` in `file` with `message`, without position or entity.
    pub fn new(kind: Kind, file: impl Into<String>, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            file: file.into(),
            line: None,
            column: None,
            entity: None,
            message: message.into(),
            kind,
        }
    }

    /// Sets the line (builder style).
    pub fn at_line(mut self, line: Option<usize>) -> Diagnostic {
        self.line = line;
        self
    }

    /// Sets line and column from a byte offset into the file's text (builder style).
    pub fn at_offset(mut self, index: &LineIndex, offset: usize) -> Diagnostic {
        let (line, column) = index.locate(offset);
        self.line = Some(line);
        self.column = Some(column);
        self
    }

    /// Sets the entity (builder style).
    pub fn entity(mut self, entity: impl Into<String>) -> Diagnostic {
        self.entity = Some(entity.into());
        self
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if !self.file.is_empty() {
            f.write_str(&self.file)?;
            if let Some(line) = self.line {
                write!(f, ":{line}")?;
                if let Some(column) = self.column {
                    write!(f, ":{column}")?;
                }
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

impl std::error::Error for Diagnostic {}

/// Every problem found in one or more files, in source order. Displayed one per line.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(transparent)]
pub struct Diagnostics(pub Vec<Diagnostic>);

impl Diagnostics {
    /// Number of problems.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// True when there is no problem.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The problems, in order.
    pub fn iter(&self) -> std::slice::Iter<'_, Diagnostic> {
        self.0.iter()
    }

    /// Adds a problem.
    pub fn push(&mut self, d: Diagnostic) {
        self.0.push(d);
    }

    /// Sorts by file, then line, then column (missing positions last), keeping the order of
    /// equal positions: deterministic output whatever order the checks ran in.
    pub fn sort(&mut self) {
        fn key(d: &Diagnostic) -> (&str, usize, usize) {
            (
                &d.file,
                d.line.unwrap_or(usize::MAX),
                d.column.unwrap_or(usize::MAX),
            )
        }
        self.0.sort_by(|a, b| key(a).cmp(&key(b)));
    }

    /// `Ok(value)` when there is no problem, otherwise `Err(self)`.
    pub fn into_result<T>(self, value: T) -> Result<T, Diagnostics> {
        if self.is_empty() {
            Ok(value)
        } else {
            Err(self)
        }
    }
}

/// Most problems [`Diagnostics`] displays; the others are counted on one last line, so an
/// error output stays short whatever the input (a 10^6-element array of bad values).
pub const MAX_SHOWN: usize = 20;

impl fmt::Display for Diagnostics {
    /// One line per problem, the first [`MAX_SHOWN`] of them, then `... and N more
    /// problems` when there are more.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (k, d) in self.0.iter().take(MAX_SHOWN).enumerate() {
            if k > 0 {
                f.write_str("\n")?;
            }
            write!(f, "{d}")?;
        }
        let more = self.0.len().saturating_sub(MAX_SHOWN);
        if more > 0 {
            let s = if more == 1 { "" } else { "s" };
            write!(f, "\n... and {more} more problem{s}")?;
        }
        Ok(())
    }
}

impl std::error::Error for Diagnostics {}

impl From<Diagnostic> for Diagnostics {
    fn from(d: Diagnostic) -> Diagnostics {
        Diagnostics(vec![d])
    }
}

impl From<Vec<Diagnostic>> for Diagnostics {
    fn from(v: Vec<Diagnostic>) -> Diagnostics {
        Diagnostics(v)
    }
}

impl<'a> IntoIterator for &'a Diagnostics {
    type Item = &'a Diagnostic;
    type IntoIter = std::slice::Iter<'a, Diagnostic>;

    fn into_iter(self) -> Self::IntoIter {
        self.0.iter()
    }
}

impl IntoIterator for Diagnostics {
    type Item = Diagnostic;
    type IntoIter = std::vec::IntoIter<Diagnostic>;

    fn into_iter(self) -> Self::IntoIter {
        self.0.into_iter()
    }
}

/// Bytes between two character-count checkpoints of a [`LineIndex`].
const CHECKPOINT: usize = 256;

/// Line starts of a text: turns byte offsets (parser spans) into 1-based line and column.
///
/// Both are found in O(log n) (a binary search of the line starts; the column from a
/// character count kept every `CHECKPOINT` bytes), so locating every value of a long line
/// (a 10^6-element array) stays linear in the text.
#[derive(Clone, Debug)]
pub struct LineIndex {
    starts: Vec<usize>,
    /// `(byte, characters before it)`: the first character boundary at or after every
    /// multiple of [`CHECKPOINT`].
    checkpoints: Vec<(usize, usize)>,
    text: String,
}

impl LineIndex {
    /// Indexes `text`.
    pub fn new(text: &str) -> LineIndex {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        let mut checkpoints = Vec::with_capacity(text.len() / CHECKPOINT + 1);
        checkpoints.push((0, 0));
        let mut next = CHECKPOINT;
        for (count, (i, _)) in text.char_indices().enumerate() {
            while i >= next {
                checkpoints.push((i, count));
                next += CHECKPOINT;
            }
        }
        LineIndex {
            starts,
            checkpoints,
            text: text.to_string(),
        }
    }

    /// 1-based line of byte `offset` (clamped to the text).
    pub fn line(&self, offset: usize) -> usize {
        let offset = offset.min(self.text.len());
        self.starts.partition_point(|&s| s <= offset)
    }

    /// 1-based line and column (in characters) of byte `offset` (clamped to the text; an
    /// offset inside a multi-byte character counts from that character).
    pub fn locate(&self, offset: usize) -> (usize, usize) {
        let offset = offset.min(self.text.len());
        let line = self.line(offset);
        let start = self.starts[line - 1];
        let mut end = offset;
        while !self.text.is_char_boundary(end) {
            end -= 1;
        }
        let column = self.chars_before(end) - self.chars_before(start) + 1;
        (line, column)
    }

    /// Characters before byte `offset` (a character boundary).
    fn chars_before(&self, offset: usize) -> usize {
        let mut k = (offset / CHECKPOINT).min(self.checkpoints.len() - 1);
        while self.checkpoints[k].0 > offset {
            k -= 1;
        }
        let (byte, count) = self.checkpoints[k];
        count + self.text[byte..offset].chars().count()
    }
}

/// `text` cut to at most `max` characters, with `…` appended when cut: for echoing user
/// input in one-line messages.
pub fn truncate(text: &str, max: usize) -> String {
    match text.char_indices().nth(max) {
        None => text.to_string(),
        Some((i, _)) => format!("{}…", &text[..i]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_omits_missing_parts() {
        let d = Diagnostic::new(Kind::InvalidValue, "m.toml", "bad");
        assert_eq!(d.to_string(), "m.toml: bad");
        assert_eq!(d.clone().at_line(Some(3)).to_string(), "m.toml:3: bad");
        let full = Diagnostic {
            column: Some(7),
            ..d.clone().at_line(Some(3)).entity("body \"a\"")
        };
        assert_eq!(full.to_string(), "m.toml:3:7: body \"a\": bad");
        let nofile = Diagnostic::new(Kind::Syntax, "", "bad").at_line(Some(2));
        assert_eq!(nofile.to_string(), "line 2: bad");
        let all = Diagnostics(vec![d.clone().at_line(Some(1)), d.at_line(Some(2))]);
        assert_eq!(all.to_string(), "m.toml:1: bad\nm.toml:2: bad");
    }

    #[test]
    fn a_long_list_is_summarised() {
        let d = |k: usize| Diagnostic::new(Kind::InvalidValue, "m.toml", format!("bad {k}"));
        let all = Diagnostics((0..1000).map(d).collect());
        let text = all.to_string();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), MAX_SHOWN + 1);
        assert_eq!(lines[0], "m.toml: bad 0");
        assert_eq!(lines[MAX_SHOWN - 1], "m.toml: bad 19");
        assert_eq!(lines[MAX_SHOWN], "... and 980 more problems");
        let one_more = Diagnostics((0..=MAX_SHOWN).map(d).collect());
        assert!(one_more.to_string().ends_with("\n... and 1 more problem"));
        let exact = Diagnostics((0..MAX_SHOWN).map(d).collect());
        assert_eq!(exact.to_string().lines().count(), MAX_SHOWN);
    }

    #[test]
    fn line_index_locates_offsets() {
        let text = "a = 1\nbé = 2\n\nc";
        let ix = LineIndex::new(text);
        assert_eq!(ix.locate(0), (1, 1));
        assert_eq!(ix.locate(4), (1, 5));
        assert_eq!(ix.locate(6), (2, 1));
        // 'é' is two bytes: the '=' after it is column 4.
        assert_eq!(ix.locate(10), (2, 4));
        // An offset inside 'é' counts from that character.
        assert_eq!(ix.locate(8), (2, 2));
        assert_eq!(ix.locate(text.len()), (4, 2));
        assert_eq!(ix.locate(usize::MAX), (4, 2));
        assert_eq!(ix.line(13), 2);
        assert_eq!(ix.line(14), 3);
    }

    /// Columns on long lines with multi-byte characters, across the checkpoints, equal a
    /// plain character count.
    #[test]
    fn columns_across_checkpoints_equal_a_character_count() {
        let text: String = (0..3000)
            .map(|k| match k % 7 {
                0 => 'é',
                3 => '🦀',
                5 if k % 500 == 5 => '\n',
                _ => 'a',
            })
            .collect();
        let ix = LineIndex::new(&text);
        for offset in (0..=text.len()).step_by(3) {
            let mut end = offset;
            while !text.is_char_boundary(end) {
                end -= 1;
            }
            let start = text[..end].rfind('\n').map_or(0, |i| i + 1);
            let line = text[..end].matches('\n').count() + 1;
            let column = text[start..end].chars().count() + 1;
            assert_eq!(ix.locate(offset), (line, column), "offset {offset}");
        }
        assert_eq!(LineIndex::new("").locate(5), (1, 1));
    }

    #[test]
    fn sort_is_by_position_and_stable() {
        let d = |line: Option<usize>, m: &str| Diagnostic::new(Kind::Syntax, "f", m).at_line(line);
        let mut all = Diagnostics(vec![
            d(None, "x"),
            d(Some(5), "a"),
            d(Some(2), "b"),
            d(Some(5), "c"),
        ]);
        all.sort();
        let msgs: Vec<_> = all.iter().map(|d| d.message.as_str()).collect();
        assert_eq!(msgs, ["b", "a", "c", "x"]);
    }

    #[test]
    fn truncate_cuts_on_characters() {
        assert_eq!(truncate("abc", 5), "abc");
        assert_eq!(truncate("abcdef", 3), "abc…");
        assert_eq!(truncate("ééé", 2), "éé…");
    }
}
