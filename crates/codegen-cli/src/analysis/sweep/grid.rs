//! The grid of a sweep: `--set PATH=VALUES` specs read into axes (`a:b:n`, `a:b:n:log`, a
//! comma list of TOML values), the cartesian product (the last axis varying fastest),
//! counted without building it ([`Shape`]), and the shards `index % N == I`.
//!
//! `a:b:n` is `a + (b - a) k / (n - 1)`, k = 0..n-1, the endpoints exact (integers when a
//! and b are integers and the step is a whole number); `a:b:n:log` is
//! `a (b / a)^(k / (n - 1))` (a, b > 0).

use toml_edit::Value;

use crate::analysis::figures::{ConstraintError, UnknownFigure};
use crate::budget;
use crate::scenario::overrides::PathError;
use crate::scenario::overrides::{parse_value, value_text};
use crate::scenario::{self, Override};

/// Why VALUES (`a:b:n` or a comma list) cannot be read.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ValuesError {
    /// An item of the comma list is empty.
    #[error("empty value in the list `{text}`")]
    EmptyItem {
        /// VALUES.
        text: String,
    },
    /// `n` of `a:b:n` is not a whole number.
    #[error(
        "`{text}`: n in a:b:n must be a whole number of points (at most {})",
        usize::MAX
    )]
    Count {
        /// VALUES.
        text: String,
    },
    /// `n < 2`.
    #[error("`{text}`: a:b:n needs n >= 2 points")]
    TooFew {
        /// VALUES.
        text: String,
    },
    /// `a` or `b` is not finite.
    #[error("`{text}`: a and b must be finite")]
    NotFinite {
        /// VALUES.
        text: String,
    },
    /// `a:b:n:log` with `a` or `b` not positive.
    #[error("`{text}`: a:b:n:log needs a > 0 and b > 0")]
    LogNotPositive {
        /// VALUES.
        text: String,
    },
    /// The values do not fit in memory.
    #[error("`{text}`: {n} values do not fit in memory")]
    Memory {
        /// VALUES.
        text: String,
        /// The number of values.
        n: usize,
    },
}

/// Why the `--set PATH=VALUES` or `--shard I/N` options of a sweep cannot be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SpecError {
    /// No `=`.
    #[error("--set {spec}: expected PATH=VALUES")]
    NoValues {
        /// The option's text.
        spec: String,
    },
    /// A bad PATH.
    #[error("--set {spec}: {source}")]
    Path {
        /// The option's text.
        spec: String,
        /// What is wrong with it.
        source: PathError,
    },
    /// Bad VALUES.
    #[error("--set {spec}: {source}")]
    Values {
        /// The option's text.
        spec: String,
        /// What is wrong with them.
        source: ValuesError,
    },
    /// More points than a machine word counts.
    #[error(
        "--set: the grid has {factors} = {product:.2e} points, more than a machine word counts ({})",
        usize::MAX
    )]
    Overflow {
        /// The factors (or their number).
        factors: String,
        /// Their product.
        product: f64,
    },
    /// A `--vary` that is not `PATH=LO:HI` with finite `LO < HI`.
    #[error("--vary {text}: expected PATH=LO:HI with finite LO < HI")]
    Vary {
        /// The option's value.
        text: String,
    },
    /// A `--constraint` that cannot be read, or a figure the catalogue does not know.
    #[error(transparent)]
    Constraint(#[from] ConstraintError),
    /// A `--map` figure the catalogue does not know.
    #[error("--map: {0}")]
    Map(UnknownFigure),
    /// `--shard` is not `I/N` with `0 <= I < N`.
    #[error("--shard {text}: expected I/N with 0 <= I < N")]
    Shard {
        /// The option's value.
        text: String,
    },
}

/// One swept field: its PATH and its values.
#[derive(Clone, Debug)]
pub struct Axis {
    /// PATH.
    pub path: String,
    /// The values, in order.
    pub values: Vec<Value>,
}

impl Axis {
    /// `PATH=VALUES`.
    pub fn parse(spec: &str) -> Result<Axis, SpecError> {
        let (path, values) = split_spec(spec)?;
        let values = parse_values(values).map_err(|source| SpecError::Values {
            spec: spec.to_string(),
            source,
        })?;
        Ok(Axis {
            path: path.to_string(),
            values,
        })
    }

    /// The number of values of `PATH=VALUES`, without building them.
    pub fn count(spec: &str) -> Result<usize, SpecError> {
        let (_, values) = split_spec(spec)?;
        count_values(values).map_err(|source| SpecError::Values {
            spec: spec.to_string(),
            source,
        })
    }
}

/// `PATH=VALUES` split, PATH checked.
fn split_spec(spec: &str) -> Result<(&str, &str), SpecError> {
    let (path, values) = spec.split_once('=').ok_or_else(|| SpecError::NoValues {
        spec: spec.to_string(),
    })?;
    let path = path.trim();
    scenario::overrides::parse_path(path).map_err(|source| SpecError::Path {
        spec: spec.to_string(),
        source,
    })?;
    Ok((path, values.trim()))
}

/// VALUES: `a:b:n` or a comma list of TOML values.
pub fn parse_values(text: &str) -> Result<Vec<Value>, ValuesError> {
    if let Some(range) = parse_range(text)? {
        return range.values(text);
    }
    let items = list_items(text)?;
    Ok(items.iter().map(|i| parse_value(i.trim())).collect())
}

/// The number of values of VALUES (`a:b:n`: n), without building them.
pub fn count_values(text: &str) -> Result<usize, ValuesError> {
    match parse_range(text)? {
        Some(range) => Ok(range.n),
        None => Ok(list_items(text)?.len()),
    }
}

/// The items of a comma list.
fn list_items(text: &str) -> Result<Vec<&str>, ValuesError> {
    let items = split_top_level(text);
    if items.iter().any(|i| i.trim().is_empty()) {
        return Err(ValuesError::EmptyItem {
            text: text.to_string(),
        });
    }
    Ok(items)
}

/// `a:b:n`, checked, not yet expanded.
struct Range {
    a: Value,
    b: Value,
    fa: f64,
    fb: f64,
    n: usize,
    /// `a:b:n:log`: a geometric progression.
    log: bool,
}

impl Range {
    /// The `n` values (memory reserved first: a range too large for it is an error, not an
    /// abort).
    fn values(&self, text: &str) -> Result<Vec<Value>, ValuesError> {
        let n = self.n;
        let mut out: Vec<Value> = Vec::new();
        out.try_reserve_exact(n).map_err(|_| ValuesError::Memory {
            text: text.to_string(),
            n,
        })?;
        if self.log {
            let (la, lb) = (self.fa.ln(), self.fb.ln());
            out.extend((0..n).map(|k| {
                let x = match k {
                    0 => self.fa,
                    k if k + 1 == n => self.fb,
                    k => (la + (lb - la) * k as f64 / (n - 1) as f64).exp(),
                };
                Value::from(x)
            }));
            return Ok(out);
        }
        if let (Value::Integer(ia), Value::Integer(ib), Ok(steps)) =
            (&self.a, &self.b, i64::try_from(n - 1))
        {
            let (ia, ib) = (*ia.value(), *ib.value());
            if let Some(d) = ib.checked_sub(ia).filter(|d| d % steps == 0) {
                let step = d / steps;
                out.extend((0..=steps).map(|k| Value::from(ia + step * k)));
                return Ok(out);
            }
        }
        let (fa, fb) = (self.fa, self.fb);
        out.extend((0..n).map(|k| {
            let x = if k + 1 == n {
                fb
            } else {
                fa + (fb - fa) * k as f64 / (n - 1) as f64
            };
            Value::from(x)
        }));
        Ok(out)
    }
}

/// A TOML value as a number (an integer or a float), `None` otherwise.
pub fn number(v: &Value) -> Option<f64> {
    match v {
        Value::Integer(i) => Some(*i.value() as f64),
        Value::Float(f) => Some(*f.value()),
        _ => None,
    }
}

/// `a:b:n` when the text is three numbers separated by colons.
fn parse_range(text: &str) -> Result<Option<Range>, ValuesError> {
    let parts: Vec<&str> = text.split(':').map(str::trim).collect();
    let (a, b, n, log) = match parts[..] {
        [a, b, n] => (a, b, n, false),
        [a, b, n, "log"] => (a, b, n, true),
        [a, b, n, "lin"] => (a, b, n, false),
        _ => return Ok(None),
    };
    let (a, b) = (parse_value(a), parse_value(b));
    let (Some(fa), Some(fb)) = (number(&a), number(&b)) else {
        return Ok(None);
    };
    let text = || text.to_string();
    let n: usize = n.parse().map_err(|_| ValuesError::Count { text: text() })?;
    if n < 2 {
        return Err(ValuesError::TooFew { text: text() });
    }
    if !(fa.is_finite() && fb.is_finite()) {
        return Err(ValuesError::NotFinite { text: text() });
    }
    if log && !(fa > 0.0 && fb > 0.0) {
        return Err(ValuesError::LogNotPositive { text: text() });
    }
    Ok(Some(Range {
        a,
        b,
        fa,
        fb,
        n,
        log,
    }))
}

/// Splits at the commas outside brackets, braces and quotes.
fn split_top_level(text: &str) -> Vec<&str> {
    let (mut depth, mut quote, mut start) = (0i32, None::<char>, 0);
    let mut items = vec![];
    let mut escaped = false;
    for (i, c) in text.char_indices() {
        match quote {
            Some(q) => {
                if escaped {
                    escaped = false;
                } else if c == '\\' && q == '"' {
                    escaped = true;
                } else if c == q {
                    quote = None;
                }
            }
            None => match c {
                '"' | '\'' => quote = Some(c),
                '[' | '{' => depth += 1,
                ']' | '}' => depth -= 1,
                ',' if depth == 0 => {
                    items.push(&text[start..i]);
                    start = i + 1;
                }
                _ => {}
            },
        }
    }
    items.push(&text[start..]);
    items
}

/// The cartesian grid of the swept fields (the last axis fastest).
#[derive(Clone, Debug)]
pub struct Grid {
    /// The axes, in command-line order.
    pub axes: Vec<Axis>,
}

/// The size of a grid, counted without building it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Shape {
    /// The number of values of each axis.
    pub counts: Vec<usize>,
    /// Their product: the number of points.
    pub points: usize,
}

impl Shape {
    /// The shape of the `--set` specs; a grid of more points than a machine word holds is
    /// refused (with or without `--allow-long`: it cannot be indexed).
    pub fn of(specs: &[String]) -> Result<Shape, SpecError> {
        let counts = specs
            .iter()
            .map(|s| Axis::count(s))
            .collect::<Result<Vec<_>, _>>()?;
        let points = counts
            .iter()
            .try_fold(1usize, |p, &c| p.checked_mul(c))
            .ok_or_else(|| {
                let product: f64 = counts.iter().map(|&c| c as f64).product();
                // The factors, or only their number when there are many (a short line).
                let factors = if counts.len() <= budget::LISTED {
                    let c: Vec<String> = counts.iter().map(usize::to_string).collect();
                    c.join(" x ")
                } else {
                    format!("the product of {} axes", counts.len())
                };
                SpecError::Overflow { factors, product }
            })?;
        Ok(Shape { counts, points })
    }

    /// The points of shard `i` of `n` ([`shard_points`]).
    pub fn shard_points(&self, i: usize, n: usize) -> usize {
        shard_points(self.points, i, n)
    }

    /// The estimated memory of a sweep of `points` of this grid (bytes): every value of
    /// every axis and the points' results ([`budget::SWEEP_BYTES_PER_POINT`]).
    pub fn memory(&self, points: usize) -> f64 {
        let values: f64 = self.counts.iter().map(|&c| c as f64).sum();
        values * std::mem::size_of::<Value>() as f64 + points as f64 * budget::SWEEP_BYTES_PER_POINT
    }
}

impl Grid {
    /// The grid of `--set` specs (its size checked first: [`Shape::of`]).
    pub fn parse(specs: &[String]) -> Result<Grid, SpecError> {
        Shape::of(specs)?;
        let axes = specs
            .iter()
            .map(|s| Axis::parse(s))
            .collect::<Result<_, _>>()?;
        Ok(Grid { axes })
    }

    /// Number of points (never overflows: checked by [`Grid::parse`]).
    pub fn len(&self) -> usize {
        self.axes.iter().map(|a| a.values.len()).product()
    }

    /// Whether the grid has no point (never: every axis has a value).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The values of point `index` (one per axis).
    pub fn point(&self, index: usize) -> Vec<&Value> {
        let mut rest = index;
        let mut values: Vec<&Value> = self
            .axes
            .iter()
            .rev()
            .map(|a| {
                let v = &a.values[rest % a.values.len()];
                rest /= a.values.len();
                v
            })
            .collect();
        values.reverse();
        values
    }

    /// The fields every point shares (axes of one value) as `PATH = VALUE` with its unit,
    /// comma-separated, for plot titles; empty when every axis varies.
    pub fn fixed_text(&self) -> String {
        let fixed: Vec<String> = self
            .axes
            .iter()
            .filter(|a| a.values.len() == 1)
            .map(|a| {
                let v = value_text(&a.values[0]);
                match crate::scenario::units::field_unit(&a.path) {
                    Some(u) if u != "-" => format!("{} = {v} {u}", a.path),
                    _ => format!("{} = {v}", a.path),
                }
            })
            .collect();
        fixed.join(", ")
    }

    /// The overrides of point `index`.
    pub fn overrides(&self, index: usize) -> Vec<Override> {
        self.axes
            .iter()
            .zip(self.point(index))
            .map(|(a, v)| Override::new(&a.path, v.clone(), &value_text(v)).expect("PATH checked"))
            .collect()
    }
}

/// The number of the `points` grid indices in shard `i` of `n` (`index % n == i`, `n > 0`).
pub fn shard_points(points: usize, i: usize, n: usize) -> usize {
    if points > i {
        (points - i - 1) / n + 1
    } else {
        0
    }
}

/// `--shard I/N`.
pub fn parse_shard(text: &str) -> Result<(usize, usize), SpecError> {
    let bad = || SpecError::Shard {
        text: text.to_string(),
    };
    let (i, n) = text.split_once('/').ok_or_else(bad)?;
    let (i, n): (usize, usize) = (
        i.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if n == 0 || i >= n {
        return Err(bad());
    }
    Ok((i, n))
}
