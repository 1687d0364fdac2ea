//! A format-independent document tree that remembers the line of every key and value.
//!
//! TOML and JSON text are both read into [`Node`]s (see `source.rs`); table entries keep the
//! order in which they were written, and every entry knows the line of its key. The tree
//! implements `serde::Deserializer`, so the `raw` structures are derived with serde
//! (`deny_unknown_fields` catches typos) while each entity is deserialized on its own: one
//! bad body does not hide the problems of the next, and a deserialization error carries the
//! line of the innermost key or value it concerns.

use std::fmt;

use diagnostic::Kind;
use serde::de::{self, DeserializeSeed, IntoDeserializer, MapAccess, SeqAccess, Visitor};

/// A value with the (1-based) line where it starts.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Node {
    pub line: usize,
    pub value: Value,
}

/// The value of a [`Node`].
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Value {
    /// JSON `null`.
    Null,
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
    /// A TOML date-time (not used by the model format; kept for the error message).
    Datetime(String),
    Array(Vec<Node>),
    /// Entries in the order they were written.
    Table(Vec<Entry>),
}

/// One `key = value` entry of a table.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Entry {
    pub key: String,
    /// Line of the key.
    pub line: usize,
    pub node: Node,
}

/// One step of a path into a [`Node`]: a table key or an array index.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Seg<'a> {
    Key(&'a str),
    Idx(usize),
}

impl Node {
    /// The entries, when the node is a table.
    pub fn entries(&self) -> Option<&[Entry]> {
        match &self.value {
            Value::Table(entries) => Some(entries),
            _ => None,
        }
    }

    /// The first entry with this key, when the node is a table.
    pub fn entry(&self, key: &str) -> Option<&Entry> {
        self.entries()?.iter().find(|e| e.key == key)
    }

    /// The string value of `key`, when the node is a table holding a string there.
    pub fn str_field(&self, key: &str) -> Option<&str> {
        match &self.entry(key)?.node.value {
            Value::Str(s) => Some(s),
            _ => None,
        }
    }

    /// The line of the deepest node reached by following `path` (the key line for table
    /// entries); `self.line` when the first step already fails.
    pub fn line_at(&self, path: &[Seg<'_>]) -> usize {
        let mut node = self;
        let mut line = self.line;
        for seg in path {
            match (seg, &node.value) {
                (Seg::Key(k), Value::Table(entries)) => {
                    match entries.iter().find(|e| e.key == *k) {
                        Some(e) => {
                            line = e.line;
                            node = &e.node;
                        }
                        None => break,
                    }
                }
                (Seg::Idx(i), Value::Array(items)) => match items.get(*i) {
                    Some(item) => {
                        line = item.line;
                        node = item;
                    }
                    None => break,
                },
                _ => break,
            }
        }
        line
    }

    /// A copy of this table without the entries named `key` (used to drop the `type` tag
    /// before deserializing a tagged entity into its variant structure).
    pub fn without_key(&self, key: &str) -> Node {
        match &self.value {
            Value::Table(entries) => Node {
                line: self.line,
                value: Value::Table(entries.iter().filter(|e| e.key != key).cloned().collect()),
            },
            _ => self.clone(),
        }
    }

    /// Human-readable kind of the value, for messages.
    pub fn kind(&self) -> &'static str {
        match self.value {
            Value::Null => "null",
            Value::Bool(_) => "a boolean",
            Value::Int(_) => "an integer",
            Value::Float(_) => "a number",
            Value::Str(_) => "a string",
            Value::Datetime(_) => "a date-time",
            Value::Array(_) => "an array",
            Value::Table(_) => "a table",
        }
    }

    /// Deserializes a value of type `T` from this node.
    pub fn deserialize<T: de::DeserializeOwned>(&self) -> Result<T, DeError> {
        T::deserialize(self)
    }
}

/// A deserialization error with the line of the key or value it concerns, when known, and
/// the path to it from the deserialized node.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct DeError {
    pub message: String,
    /// What kind of problem: a missing or unknown field, or else a value of the wrong type.
    pub kind: Kind,
    pub line: Option<usize>,
    /// Path segments (`key` or `[i]`), innermost first.
    path: Vec<String>,
}

impl DeError {
    /// The path to the offending value (`joint.rotation[0].angle`), empty at the top.
    pub fn path(&self) -> String {
        let mut s = String::new();
        for seg in self.path.iter().rev() {
            if !s.is_empty() && !seg.starts_with('[') {
                s.push('.');
            }
            s.push_str(seg);
        }
        s
    }

    /// The message prefixed by the path, as shown to the user.
    pub fn describe(&self) -> String {
        let path = self.path();
        if path.is_empty() {
            self.message.clone()
        } else {
            format!("{path}: {}", self.message)
        }
    }

    fn within(mut self, seg: String) -> Self {
        self.path.push(seg);
        self
    }

    /// Attaches `line` unless a more precise (inner) line is already known.
    fn at(mut self, line: usize) -> Self {
        if self.line.is_none() {
            self.line = Some(line);
        }
        self
    }
}

impl fmt::Display for DeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for DeError {}

impl de::Error for DeError {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        DeError {
            message: msg.to_string(),
            kind: Kind::Syntax,
            line: None,
            path: Vec::new(),
        }
    }

    // The two messages below are serde's own wording; only the kind is added.
    fn missing_field(field: &'static str) -> Self {
        DeError {
            kind: Kind::MissingField,
            ..DeError::custom(format_args!("missing field `{field}`"))
        }
    }

    fn unknown_field(field: &str, expected: &'static [&'static str]) -> Self {
        let message = match expected {
            [] => format!("unknown field `{field}`, there are no fields"),
            [a] => format!("unknown field `{field}`, expected `{a}`"),
            [a, b] => format!("unknown field `{field}`, expected `{a}` or `{b}`"),
            _ => {
                let all: Vec<String> = expected.iter().map(|e| format!("`{e}`")).collect();
                format!(
                    "unknown field `{field}`, expected one of {}",
                    all.join(", ")
                )
            }
        };
        DeError {
            kind: Kind::UnknownField,
            ..DeError::custom(message)
        }
    }
}

impl<'de> de::Deserializer<'de> for &Node {
    type Error = DeError;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, DeError> {
        let result = match &self.value {
            Value::Null => Err(de::Error::invalid_type(
                de::Unexpected::Other("null"),
                &visitor,
            )),
            Value::Bool(b) => visitor.visit_bool(*b),
            Value::Int(i) => visitor.visit_i64(*i),
            Value::Float(x) => visitor.visit_f64(*x),
            Value::Str(s) => visitor.visit_str(s),
            Value::Datetime(_) => Err(de::Error::invalid_type(
                de::Unexpected::Other("date-time"),
                &visitor,
            )),
            Value::Array(items) => {
                let mut seq = NodeSeq {
                    items: items.iter(),
                    index: 0,
                };
                visitor.visit_seq(&mut seq).and_then(|v| {
                    // Fixed-size arrays read only what they need: refuse the rest.
                    let left = seq.items.len();
                    if left == 0 {
                        Ok(v)
                    } else {
                        Err(de::Error::invalid_length(
                            items.len(),
                            &format!("{} elements", items.len() - left).as_str(),
                        ))
                    }
                })
            }
            Value::Table(entries) => {
                let mut map = NodeMap {
                    entries: entries.iter(),
                    value: None,
                };
                visitor
                    .visit_map(&mut map)
                    .and_then(|v| match map.entries.next() {
                        None => Ok(v),
                        Some(e) => Err(DeError {
                            message: format!("unexpected key `{}`", e.key),
                            kind: Kind::UnknownField,
                            line: Some(e.line),
                            path: Vec::new(),
                        }),
                    })
            }
        };
        result.map_err(|e| e.at(self.line))
    }

    fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, DeError> {
        match self.value {
            Value::Null => visitor.visit_none(),
            _ => visitor.visit_some(self),
        }
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value, DeError> {
        visitor.visit_newtype_struct(self)
    }

    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, DeError> {
        match &self.value {
            // Unit variants written as strings.
            Value::Str(s) => visitor
                .visit_enum(s.as_str().into_deserializer())
                .map_err(|e: DeError| e.at(self.line)),
            _ => self.deserialize_any(visitor),
        }
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
        bytes byte_buf unit unit_struct seq tuple tuple_struct map struct identifier
        ignored_any
    }
}

struct NodeSeq<'a> {
    items: std::slice::Iter<'a, Node>,
    index: usize,
}

impl<'de> SeqAccess<'de> for NodeSeq<'_> {
    type Error = DeError;

    fn next_element_seed<T: DeserializeSeed<'de>>(
        &mut self,
        seed: T,
    ) -> Result<Option<T::Value>, DeError> {
        match self.items.next() {
            Some(node) => {
                let index = self.index;
                self.index += 1;
                seed.deserialize(node)
                    .map(Some)
                    .map_err(|e| e.at(node.line).within(format!("[{index}]")))
            }
            None => Ok(None),
        }
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.items.len())
    }
}

struct NodeMap<'a> {
    entries: std::slice::Iter<'a, Entry>,
    value: Option<&'a Entry>,
}

impl<'de> MapAccess<'de> for NodeMap<'_> {
    type Error = DeError;

    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, DeError> {
        match self.entries.next() {
            Some(entry) => {
                self.value = Some(entry);
                let key: de::value::StrDeserializer<'_, DeError> =
                    entry.key.as_str().into_deserializer();
                seed.deserialize(key)
                    .map(Some)
                    .map_err(|e| e.at(entry.line))
            }
            None => Ok(None),
        }
    }

    fn next_value_seed<V: DeserializeSeed<'de>>(&mut self, seed: V) -> Result<V::Value, DeError> {
        match self.value.take() {
            Some(entry) => seed
                .deserialize(&entry.node)
                .map_err(|e| e.at(entry.line).within(entry.key.clone())),
            None => Err(de::Error::custom("value requested before its key")),
        }
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.entries.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    fn n(line: usize, value: Value) -> Node {
        Node { line, value }
    }

    fn entry(key: &str, line: usize, value: Value) -> Entry {
        Entry {
            key: key.into(),
            line,
            node: n(line, value),
        }
    }

    #[derive(Debug, Deserialize, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct S {
        a: f64,
        b: Option<Vec<String>>,
    }

    #[test]
    fn deserializes_and_locates_errors() {
        let ok = n(
            1,
            Value::Table(vec![
                entry("a", 2, Value::Int(3)),
                entry("b", 3, Value::Array(vec![n(4, Value::Str("x".into()))])),
            ]),
        );
        assert_eq!(
            ok.deserialize::<S>(),
            Ok(S {
                a: 3.0,
                b: Some(vec!["x".into()])
            })
        );
        let unknown = n(
            1,
            Value::Table(vec![
                entry("a", 2, Value::Int(3)),
                entry("c", 7, Value::Null),
            ]),
        );
        let err = unknown.deserialize::<S>().unwrap_err();
        assert_eq!(err.line, Some(7));
        assert!(err.message.contains("unknown field `c`"), "{}", err.message);
        let inner = n(
            1,
            Value::Table(vec![
                entry("a", 2, Value::Int(3)),
                entry("b", 3, Value::Array(vec![n(5, Value::Bool(true))])),
            ]),
        );
        assert_eq!(inner.deserialize::<S>().unwrap_err().line, Some(5));
        let long = n(
            1,
            Value::Array(vec![
                n(1, Value::Int(1)),
                n(1, Value::Int(2)),
                n(2, Value::Int(3)),
            ]),
        );
        let nested = n(
            1,
            Value::Table(vec![
                entry("a", 2, Value::Int(3)),
                entry(
                    "b",
                    3,
                    Value::Array(vec![n(3, Value::Str("x".into())), n(4, Value::Int(1))]),
                ),
            ]),
        );
        let err = nested.deserialize::<S>().unwrap_err();
        assert_eq!((err.line, err.path()), (Some(4), "b[1]".to_string()));
        assert!(
            err.describe()
                .starts_with("b[1]: invalid type: integer `1`"),
            "{}",
            err.describe()
        );
        let err = long.deserialize::<[f64; 2]>().unwrap_err();
        assert_eq!(err.message, "invalid length 3, expected 2 elements");
        assert_eq!(long.deserialize::<[f64; 3]>(), Ok([1.0, 2.0, 3.0]));
        let missing = n(9, Value::Table(vec![]));
        let err = missing.deserialize::<S>().unwrap_err();
        assert_eq!(err.line, Some(9));
        assert!(err.message.contains("missing field `a`"));
    }

    #[test]
    fn line_at_follows_the_deepest_existing_step() {
        let node = n(
            1,
            Value::Table(vec![entry(
                "com",
                4,
                Value::Array(vec![n(4, Value::Int(0)), n(5, Value::Int(1))]),
            )]),
        );
        assert_eq!(node.line_at(&[Seg::Key("com"), Seg::Idx(1)]), 5);
        assert_eq!(node.line_at(&[Seg::Key("com"), Seg::Idx(7)]), 4);
        assert_eq!(node.line_at(&[Seg::Key("mass")]), 1);
    }
}
