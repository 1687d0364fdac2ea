//! Model text to [`Node`] tree, for both formats, with the line of every key and value.
//!
//! - TOML: `toml::de::DeTable::parse_recoverable` keeps the byte span of every key and value
//!   (all syntax errors are reported, not only the first); table entries are put back in
//!   the order they were written by sorting them on the key spans.
//! - JSON: `serde_json` checks the syntax (and its nesting limit) and gives the error
//!   position; a small scanner then builds the tree with lines, keeping the written key
//!   order (and duplicate keys, which validation reports).
//!
//! Also the FNV-1a hash recorded in `SourceInfo`.

use diagnostic::LineIndex;
use serde::de::IgnoredAny;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

use super::node::{Entry, Node, Value};

/// Nesting deeper than this is refused (the model format needs a depth of about 5).
const MAX_DEPTH: usize = 100;

/// Where a syntax error is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Position {
    /// A byte offset into the text (line and column through [`LineIndex`]).
    Offset(usize),
    /// A 1-based line only (the parser gives its column in the message).
    Line(usize),
    /// Unknown.
    Unknown,
}

/// A syntax error: position and message.
pub(crate) type SyntaxError = (Position, String);

/// FNV-1a, 64-bit, of `bytes`, as 16 lower-case hexadecimal digits.
pub(crate) fn fnv1a_hex(bytes: &[u8]) -> String {
    const OFFSET_BASIS: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    let mut hash = OFFSET_BASIS;
    for &b in bytes {
        hash ^= u64::from(b);
        hash = hash.wrapping_mul(PRIME);
    }
    format!("{hash:016x}")
}

/// Parses TOML text into a [`Node`] (a table).
pub(crate) fn toml_to_node(src: &str, lines: &LineIndex) -> Result<Node, Vec<SyntaxError>> {
    let (table, errors) = DeTable::parse_recoverable(src);
    if !errors.is_empty() {
        return Err(errors
            .iter()
            .map(|e| {
                let at = e
                    .span()
                    .map_or(Position::Unknown, |s| Position::Offset(s.start));
                (at, one_line(e.message()))
            })
            .collect());
    }
    let span = table.span();
    let root = Spanned::new(span, DeValue::Table(table.into_inner()));
    let mut errors = Vec::new();
    let mut node = convert_toml(&root, lines, 0, &mut errors);
    // The document table starts at the top of the file whatever its span says.
    node.line = 1;
    if errors.is_empty() {
        Ok(node)
    } else {
        Err(errors)
    }
}

fn one_line(message: &str) -> String {
    message
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}

fn convert_toml(
    v: &Spanned<DeValue<'_>>,
    lines: &LineIndex,
    depth: usize,
    errors: &mut Vec<SyntaxError>,
) -> Node {
    let at = Position::Offset(v.span().start);
    let line = lines.line(v.span().start);
    if depth > MAX_DEPTH {
        if errors.is_empty() {
            errors.push((at, format!("nesting deeper than {MAX_DEPTH} levels")));
        }
        return Node {
            line,
            value: Value::Null,
        };
    }
    let value = match v.get_ref() {
        DeValue::String(s) => Value::Str(s.to_string()),
        DeValue::Integer(i) => match i64::from_str_radix(i.as_str(), i.radix()) {
            Ok(x) => Value::Int(x),
            Err(_) => {
                errors.push((at, format!("integer `{i}` out of range")));
                Value::Null
            }
        },
        DeValue::Float(x) => match x.as_str().parse::<f64>() {
            Ok(x) => Value::Float(x),
            Err(_) => {
                errors.push((at, format!("invalid float `{x}`")));
                Value::Null
            }
        },
        DeValue::Boolean(b) => Value::Bool(*b),
        DeValue::Datetime(d) => Value::Datetime(d.to_string()),
        DeValue::Array(items) => Value::Array(
            items
                .iter()
                .map(|item| convert_toml(item, lines, depth + 1, errors))
                .collect(),
        ),
        DeValue::Table(table) => {
            let mut entries: Vec<_> = table.iter().collect();
            entries.sort_by_key(|(k, _)| k.span().start);
            Value::Table(
                entries
                    .into_iter()
                    .map(|(k, val)| Entry {
                        key: k.get_ref().to_string(),
                        line: lines.line(k.span().start),
                        node: convert_toml(val, lines, depth + 1, errors),
                    })
                    .collect(),
            )
        }
    };
    Node { line, value }
}

/// Parses JSON text into a [`Node`].
pub(crate) fn json_to_node(src: &str, lines: &LineIndex) -> Result<Node, Vec<SyntaxError>> {
    if let Err(e) = serde_json::from_str::<IgnoredAny>(src) {
        let full = e.to_string();
        let suffix = format!(" at line {} column {}", e.line(), e.column());
        let message = full.strip_suffix(&suffix).unwrap_or(&full);
        let at = if e.line() > 0 {
            Position::Line(e.line())
        } else {
            Position::Unknown
        };
        return Err(vec![(at, format!("{message} (column {})", e.column()))]);
    }
    let mut scanner = JsonScanner {
        src,
        bytes: src.as_bytes(),
        pos: 0,
        lines,
    };
    scanner.skip_ws();
    let node = scanner
        .value(0)
        .map_err(|(offset, msg)| vec![(Position::Offset(offset), format!("JSON: {msg}"))])?;
    Ok(node)
}

/// Builds the tree of JSON text already checked by `serde_json` (so errors here are
/// unexpected, but still reported rather than panicking).
struct JsonScanner<'a> {
    src: &'a str,
    bytes: &'a [u8],
    pos: usize,
    lines: &'a LineIndex,
}

type ScanResult<T> = Result<T, (usize, String)>;

impl JsonScanner<'_> {
    fn peek(&self) -> Option<u8> {
        self.bytes.get(self.pos).copied()
    }

    fn rest(&self) -> &[u8] {
        self.bytes.get(self.pos..).unwrap_or(&[])
    }

    fn skip_ws(&mut self) {
        while matches!(self.peek(), Some(b' ' | b'\t' | b'\n' | b'\r')) {
            self.pos += 1;
        }
    }

    fn fail<T>(&self, msg: &str) -> ScanResult<T> {
        Err((self.pos, msg.to_string()))
    }

    fn expect(&mut self, b: u8) -> ScanResult<()> {
        if self.peek() == Some(b) {
            self.pos += 1;
            Ok(())
        } else {
            self.fail(&format!("expected `{}`", b as char))
        }
    }

    /// A value starting at `self.pos` (whitespace already skipped).
    fn value(&mut self, depth: usize) -> ScanResult<Node> {
        if depth > MAX_DEPTH {
            return self.fail(&format!("nesting deeper than {MAX_DEPTH} levels"));
        }
        let line = self.lines.line(self.pos);
        let value = match self.peek() {
            Some(b'{') => {
                self.pos += 1;
                let mut entries = Vec::new();
                self.skip_ws();
                if self.peek() == Some(b'}') {
                    self.pos += 1;
                } else {
                    loop {
                        self.skip_ws();
                        let key_line = self.lines.line(self.pos);
                        let key = self.string()?;
                        self.skip_ws();
                        self.expect(b':')?;
                        self.skip_ws();
                        let node = self.value(depth + 1)?;
                        entries.push(Entry {
                            key,
                            line: key_line,
                            node,
                        });
                        self.skip_ws();
                        match self.peek() {
                            Some(b',') => self.pos += 1,
                            Some(b'}') => {
                                self.pos += 1;
                                break;
                            }
                            _ => return self.fail("expected `,` or `}`"),
                        }
                    }
                }
                Value::Table(entries)
            }
            Some(b'[') => {
                self.pos += 1;
                let mut items = Vec::new();
                self.skip_ws();
                if self.peek() == Some(b']') {
                    self.pos += 1;
                } else {
                    loop {
                        self.skip_ws();
                        items.push(self.value(depth + 1)?);
                        self.skip_ws();
                        match self.peek() {
                            Some(b',') => self.pos += 1,
                            Some(b']') => {
                                self.pos += 1;
                                break;
                            }
                            _ => return self.fail("expected `,` or `]`"),
                        }
                    }
                }
                Value::Array(items)
            }
            Some(b'"') => Value::Str(self.string()?),
            Some(b't') => self.word("true", Value::Bool(true))?,
            Some(b'f') => self.word("false", Value::Bool(false))?,
            Some(b'n') => self.word("null", Value::Null)?,
            Some(b'-' | b'0'..=b'9') => self.number()?,
            _ => return self.fail("expected a value"),
        };
        Ok(Node { line, value })
    }

    fn word(&mut self, word: &str, value: Value) -> ScanResult<Value> {
        if self.rest().starts_with(word.as_bytes()) {
            self.pos += word.len();
            Ok(value)
        } else {
            self.fail("expected a value")
        }
    }

    fn number(&mut self) -> ScanResult<Value> {
        let start = self.pos;
        while matches!(
            self.peek(),
            Some(b'-' | b'+' | b'.' | b'e' | b'E' | b'0'..=b'9')
        ) {
            self.pos += 1;
        }
        let text = self.src.get(start..self.pos).unwrap_or("");
        let is_int = !text.contains(['.', 'e', 'E']);
        if let (true, Ok(i)) = (is_int, text.parse::<i64>()) {
            return Ok(Value::Int(i));
        }
        match text.parse::<f64>() {
            Ok(x) => Ok(Value::Float(x)),
            Err(_) => Err((start, format!("invalid number `{text}`"))),
        }
    }

    /// A string literal starting at `self.pos` (on the opening quote).
    fn string(&mut self) -> ScanResult<String> {
        self.expect(b'"')?;
        let mut out = String::new();
        let mut run = self.pos;
        loop {
            match self.peek() {
                None => return self.fail("unterminated string"),
                Some(b'"') => {
                    out.push_str(self.src.get(run..self.pos).unwrap_or(""));
                    self.pos += 1;
                    return Ok(out);
                }
                Some(b'\\') => {
                    out.push_str(self.src.get(run..self.pos).unwrap_or(""));
                    self.pos += 1;
                    let esc = self.peek();
                    self.pos += 1;
                    match esc {
                        Some(b'"') => out.push('"'),
                        Some(b'\\') => out.push('\\'),
                        Some(b'/') => out.push('/'),
                        Some(b'b') => out.push('\u{8}'),
                        Some(b'f') => out.push('\u{c}'),
                        Some(b'n') => out.push('\n'),
                        Some(b'r') => out.push('\r'),
                        Some(b't') => out.push('\t'),
                        Some(b'u') => {
                            let hi = self.hex4()?;
                            let code = if (0xD800..0xDC00).contains(&hi)
                                && self.rest().starts_with(b"\\u")
                            {
                                self.pos += 2;
                                let lo = self.hex4()?;
                                0x10000 + ((hi - 0xD800) << 10) + (lo.wrapping_sub(0xDC00) & 0x3FF)
                            } else {
                                hi
                            };
                            out.push(char::from_u32(code).unwrap_or('\u{FFFD}'));
                        }
                        _ => return self.fail("invalid escape"),
                    }
                    run = self.pos;
                }
                Some(_) => self.pos += 1,
            }
        }
    }

    fn hex4(&mut self) -> ScanResult<u32> {
        let digits = self.src.get(self.pos..self.pos + 4).unwrap_or("");
        match u32::from_str_radix(digits, 16) {
            Ok(v) if digits.len() == 4 => {
                self.pos += 4;
                Ok(v)
            }
            _ => self.fail("invalid \\u escape"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_reference_values() {
        // Published FNV-1a 64 test vectors.
        assert_eq!(fnv1a_hex(b""), "cbf29ce484222325");
        assert_eq!(fnv1a_hex(b"a"), "af63dc4c8601ec8c");
        assert_eq!(fnv1a_hex(b"foobar"), "85944171f73967e8");
    }

    #[test]
    fn line_index() {
        let idx = LineIndex::new("ab\ncd\n\nx");
        assert_eq!(idx.line(0), 1);
        assert_eq!(idx.line(2), 1);
        assert_eq!(idx.line(3), 2);
        assert_eq!(idx.line(6), 3);
        assert_eq!(idx.line(7), 4);
        assert_eq!(idx.line(100), 4);
    }

    #[test]
    fn json_and_toml_trees_agree() {
        let json = "{\n \"b\": 1,\n \"a\": [2.5, \"x\\u00e9\\ud83d\\ude00\", true, null],\n \"c\": {\"d\": -3e2}\n}";
        let toml = "b = 1\na = [2.5, \"x\u{e9}\u{1F600}\", true]\n[c]\nd = -3e2\n";
        let j = json_to_node(json, &LineIndex::new(json)).unwrap();
        let t = toml_to_node(toml, &LineIndex::new(toml)).unwrap();
        let keys = |n: &Node| {
            n.entries()
                .unwrap()
                .iter()
                .map(|e| e.key.clone())
                .collect::<Vec<_>>()
        };
        assert_eq!(keys(&j), ["b", "a", "c"]);
        assert_eq!(keys(&t), ["b", "a", "c"]);
        assert_eq!(j.entry("a").unwrap().line, 3);
        assert_eq!(t.entry("a").unwrap().line, 2);
        assert_eq!(t.entry("c").unwrap().node.entry("d").unwrap().line, 4);
        let Value::Array(items) = &j.entry("a").unwrap().node.value else {
            panic!()
        };
        assert_eq!(items[1].value, Value::Str("x\u{e9}\u{1F600}".into()));
        assert_eq!(items[3].value, Value::Null);
        assert_eq!(
            j.entry("c").unwrap().node.entry("d").unwrap().node.value,
            Value::Float(-300.0)
        );
    }

    #[test]
    fn syntax_errors_have_lines() {
        let src = "a = 1\nb = = 2\n";
        let lines = LineIndex::new(src);
        let e = toml_to_node(src, &lines).unwrap_err();
        let Position::Offset(offset) = e[0].0 else {
            panic!("{:?}", e[0]);
        };
        assert_eq!(lines.line(offset), 2);
        let src = "{\n\"a\": 1,\n}";
        let e = json_to_node(src, &LineIndex::new(src)).unwrap_err();
        assert_eq!(e[0].0, Position::Line(3));
        assert!(e[0].1.contains("column"), "{}", e[0].1);
    }

    #[test]
    fn deep_nesting_is_refused_without_overflow() {
        let deep = 100_000;
        let toml = format!("a = {}{}", "[".repeat(deep), "]".repeat(deep));
        assert!(toml_to_node(&toml, &LineIndex::new(&toml)).is_err());
        let dotted = format!("{} = 1", vec!["k"; 5_000].join("."));
        assert!(toml_to_node(&dotted, &LineIndex::new(&dotted)).is_err());
        let json = format!("{}{}", "[".repeat(deep), "]".repeat(deep));
        assert!(json_to_node(&json, &LineIndex::new(&json)).is_err());
    }
}
