//! Parameter expressions: a small recursive-descent parser from text to [`Scalar`].
//!
//! ```text
//! expr   := term (('+' | '-') term)*
//! term   := unary (('*' | '/') unary)*
//! unary  := ('-' | '+') unary | power
//! power  := atom ('^' unary)?            right-associative: 2^3^2 = 2^9; -x^2 = -(x^2)
//! atom   := number | 'pi' | parameter | func '(' expr ')' | '(' expr ')'
//! func   := sin | cos | tan | sqrt | exp | ln | abs
//! ```
//!
//! Numbers are decimal (`12`, `0.5`, `.5`, `1e-3`). Names are resolved while parsing (no
//! look-up at evaluation time); `pi` and sub-expressions of literals only are folded to
//! numbers (with exactly the arithmetic `Scalar::eval` would do). Errors give the 1-based
//! character column in the expression. Nesting is limited to [`MAX_DEPTH`] levels, both
//! while parsing and in the resulting tree, so that evaluating, printing or dropping a
//! parsed expression can never overflow the stack.

use super::types::{BinOp, Func, Scalar};

/// Deepest nesting accepted (parentheses, operators, function calls).
pub(crate) const MAX_DEPTH: usize = 200;

/// Names that cannot be parameters because expressions give them another meaning.
pub(crate) const RESERVED: [&str; 8] = ["pi", "sin", "cos", "tan", "sqrt", "exp", "ln", "abs"];

/// A parse error at a 1-based character column of the expression.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message} (at column {column})")]
pub(crate) struct ExprError {
    pub column: usize,
    pub message: String,
}

/// Why a name in an expression is not a parameter it may use.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub(crate) enum NameError {
    /// No parameter has that name.
    #[error("unknown parameter `{0}`")]
    Unknown(String),
    /// A parameter's expression uses the parameter itself.
    #[error("parameter `{0}` refers to itself")]
    SelfReference(String),
    /// A parameter's expression uses a parameter declared after it.
    #[error("parameter `{0}` is declared later (a parameter may only use earlier ones)")]
    Later(String),
}

/// Parses `src`; `lookup` maps a parameter name to its index, or returns the message to
/// report (unknown parameter, declared later, ...).
pub(crate) fn parse_expr(
    src: &str,
    lookup: &dyn Fn(&str) -> Result<usize, NameError>,
) -> Result<Scalar, ExprError> {
    let tokens = lex(src)?;
    let mut p = Parser {
        tokens,
        pos: 0,
        level: 0,
        lookup,
    };
    if matches!(p.peek().tok, Tok::End) {
        return Err(ExprError {
            column: 1,
            message: "empty expression".into(),
        });
    }
    let (value, _) = p.expr()?;
    let next = p.peek();
    if !matches!(next.tok, Tok::End) {
        return Err(p.error_here(format!(
            "expected an operator or the end of the expression, found {}",
            next.describe()
        )));
    }
    Ok(value)
}

/// Tree depth of a parsed expression.
#[cfg(test)]
fn depth(s: &Scalar) -> usize {
    match s {
        Scalar::Num(_) | Scalar::Param(_) => 1,
        Scalar::Neg(a) | Scalar::Call(_, a) => depth(a) + 1,
        Scalar::Bin(_, a, b) => depth(a).max(depth(b)) + 1,
    }
}

/// Pushes the parameter indices used by `s` (with repetitions).
pub(crate) fn params_used(s: &Scalar, out: &mut Vec<usize>) {
    match s {
        Scalar::Num(_) => {}
        Scalar::Param(i) => out.push(*i),
        Scalar::Neg(a) | Scalar::Call(_, a) => params_used(a, out),
        Scalar::Bin(_, a, b) => {
            params_used(a, out);
            params_used(b, out);
        }
    }
}

fn func_by_name(name: &str) -> Option<Func> {
    Some(match name {
        "sin" => Func::Sin,
        "cos" => Func::Cos,
        "tan" => Func::Tan,
        "sqrt" => Func::Sqrt,
        "exp" => Func::Exp,
        "ln" => Func::Ln,
        "abs" => Func::Abs,
        _ => return None,
    })
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Num(f64),
    Ident(String),
    Op(char),
    End,
}

#[derive(Clone, Debug)]
struct Token {
    tok: Tok,
    /// 1-based character column.
    column: usize,
    text: String,
}

impl Token {
    fn describe(&self) -> String {
        match self.tok {
            Tok::End => "the end of the expression".into(),
            _ => format!("`{}`", self.text),
        }
    }
}

fn lex(src: &str) -> Result<Vec<Token>, ExprError> {
    let chars: Vec<char> = src.chars().collect();
    let mut tokens = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let column = i + 1;
        if c.is_whitespace() {
            i += 1;
        } else if c.is_ascii_digit()
            || (c == '.' && chars.get(i + 1).is_some_and(char::is_ascii_digit))
        {
            let start = i;
            while chars.get(i).is_some_and(char::is_ascii_digit) {
                i += 1;
            }
            if chars.get(i) == Some(&'.') {
                i += 1;
                while chars.get(i).is_some_and(char::is_ascii_digit) {
                    i += 1;
                }
            }
            if matches!(chars.get(i), Some('e' | 'E')) {
                let mut j = i + 1;
                if matches!(chars.get(j), Some('+' | '-')) {
                    j += 1;
                }
                if chars.get(j).is_some_and(char::is_ascii_digit) {
                    i = j;
                    while chars.get(i).is_some_and(char::is_ascii_digit) {
                        i += 1;
                    }
                } else {
                    return Err(ExprError {
                        column: i + 1,
                        message: "malformed exponent: expected digits after `e`".into(),
                    });
                }
            }
            let text: String = chars[start..i].iter().collect();
            let value = match text.parse::<f64>() {
                Ok(v) if v.is_finite() => v,
                _ => {
                    return Err(ExprError {
                        column,
                        message: format!("number `{text}` is out of range"),
                    });
                }
            };
            tokens.push(Token {
                tok: Tok::Num(value),
                column,
                text,
            });
        } else if c.is_alphabetic() || c == '_' {
            let start = i;
            while chars
                .get(i)
                .is_some_and(|c| c.is_alphanumeric() || *c == '_')
            {
                i += 1;
            }
            let text: String = chars[start..i].iter().collect();
            tokens.push(Token {
                tok: Tok::Ident(text.clone()),
                column,
                text,
            });
        } else if "+-*/^()".contains(c) {
            tokens.push(Token {
                tok: Tok::Op(c),
                column,
                text: c.to_string(),
            });
            i += 1;
        } else {
            return Err(ExprError {
                column,
                message: format!("unexpected character `{c}`"),
            });
        }
    }
    tokens.push(Token {
        tok: Tok::End,
        column: chars.len() + 1,
        text: String::new(),
    });
    Ok(tokens)
}

/// A parsed sub-expression and its tree depth.
type Parsed = (Scalar, usize);

struct Parser<'a> {
    tokens: Vec<Token>,
    pos: usize,
    /// Current recursion level (parentheses, unary operators, exponents, calls).
    level: usize,
    lookup: &'a dyn Fn(&str) -> Result<usize, NameError>,
}

impl Parser<'_> {
    fn peek(&self) -> Token {
        // The token list always ends with `End`, and `pos` never moves past it.
        self.tokens
            .get(self.pos)
            .or_else(|| self.tokens.last())
            .cloned()
            .unwrap_or(Token {
                tok: Tok::End,
                column: 1,
                text: String::new(),
            })
    }

    fn bump(&mut self) {
        if self.pos + 1 < self.tokens.len() {
            self.pos += 1;
        }
    }

    fn error_here(&self, message: String) -> ExprError {
        ExprError {
            column: self.peek().column,
            message,
        }
    }

    fn is_op(&self, op: char) -> bool {
        self.peek().tok == Tok::Op(op)
    }

    fn enter(&mut self) -> Result<(), ExprError> {
        self.level += 1;
        if self.level > MAX_DEPTH {
            Err(self.error_here(format!(
                "expression nested too deeply (more than {MAX_DEPTH} levels)"
            )))
        } else {
            Ok(())
        }
    }

    fn leave(&mut self) {
        self.level -= 1;
    }

    fn check_depth(&self, parsed: Parsed, column: usize) -> Result<Parsed, ExprError> {
        if parsed.1 > MAX_DEPTH {
            Err(ExprError {
                column,
                message: format!("expression nested too deeply (more than {MAX_DEPTH} levels)"),
            })
        } else {
            Ok(parsed)
        }
    }

    fn binary(&self, op: BinOp, a: Parsed, b: Parsed, column: usize) -> Result<Parsed, ExprError> {
        let depth = a.1.max(b.1) + 1;
        let folded = match (&a.0, &b.0) {
            (Scalar::Num(_), Scalar::Num(_)) => {
                let s = Scalar::Bin(op, Box::new(a.0), Box::new(b.0));
                let v = s.eval(&[]);
                if v.is_finite() {
                    (Scalar::Num(v), 1)
                } else {
                    (s, depth)
                }
            }
            _ => (Scalar::Bin(op, Box::new(a.0), Box::new(b.0)), depth),
        };
        self.check_depth(folded, column)
    }

    fn expr(&mut self) -> Result<Parsed, ExprError> {
        let mut acc = self.term()?;
        loop {
            let op = match self.peek().tok {
                Tok::Op('+') => BinOp::Add,
                Tok::Op('-') => BinOp::Sub,
                _ => return Ok(acc),
            };
            let column = self.peek().column;
            self.bump();
            let rhs = self.term()?;
            acc = self.binary(op, acc, rhs, column)?;
        }
    }

    fn term(&mut self) -> Result<Parsed, ExprError> {
        let mut acc = self.unary()?;
        loop {
            let op = match self.peek().tok {
                Tok::Op('*') => BinOp::Mul,
                Tok::Op('/') => BinOp::Div,
                _ => return Ok(acc),
            };
            let column = self.peek().column;
            self.bump();
            let rhs = self.unary()?;
            acc = self.binary(op, acc, rhs, column)?;
        }
    }

    fn unary(&mut self) -> Result<Parsed, ExprError> {
        let tok = self.peek();
        match tok.tok {
            Tok::Op('-') | Tok::Op('+') => {
                self.bump();
                self.enter()?;
                let (a, d) = self.unary()?;
                self.leave();
                if tok.tok == Tok::Op('+') {
                    return Ok((a, d));
                }
                let parsed = match a {
                    Scalar::Num(v) => (Scalar::Num(-v), 1),
                    a => (Scalar::Neg(Box::new(a)), d + 1),
                };
                self.check_depth(parsed, tok.column)
            }
            _ => self.power(),
        }
    }

    fn power(&mut self) -> Result<Parsed, ExprError> {
        let base = self.atom()?;
        if !self.is_op('^') {
            return Ok(base);
        }
        let column = self.peek().column;
        self.bump();
        self.enter()?;
        let exponent = self.unary()?;
        self.leave();
        self.binary(BinOp::Pow, base, exponent, column)
    }

    fn atom(&mut self) -> Result<Parsed, ExprError> {
        let tok = self.peek();
        match &tok.tok {
            Tok::Num(v) => {
                self.bump();
                Ok((Scalar::Num(*v), 1))
            }
            Tok::Op('(') => {
                self.bump();
                self.enter()?;
                let inner = self.expr()?;
                self.leave();
                self.close(tok.column)?;
                Ok(inner)
            }
            Tok::Ident(name) => {
                self.bump();
                let followed_by_paren = self.is_op('(');
                if let Some(f) = func_by_name(name) {
                    if !followed_by_paren {
                        return Err(ExprError {
                            column: tok.column,
                            message: format!(
                                "function `{name}` needs an argument in parentheses, e.g. `{name}(x)`"
                            ),
                        });
                    }
                    let open = self.peek().column;
                    self.bump();
                    self.enter()?;
                    let (arg, d) = self.expr()?;
                    self.leave();
                    self.close(open)?;
                    let parsed = match arg {
                        Scalar::Num(v) if f.apply(v).is_finite() => (Scalar::Num(f.apply(v)), 1),
                        arg => (Scalar::Call(f, Box::new(arg)), d + 1),
                    };
                    return self.check_depth(parsed, tok.column);
                }
                if followed_by_paren {
                    return Err(ExprError {
                        column: tok.column,
                        message: format!(
                            "unknown function `{name}` (known: sin, cos, tan, sqrt, exp, ln, abs)"
                        ),
                    });
                }
                if name == "pi" {
                    return Ok((Scalar::Num(std::f64::consts::PI), 1));
                }
                match (self.lookup)(name) {
                    Ok(index) => Ok((Scalar::Param(index), 1)),
                    Err(e) => Err(ExprError {
                        column: tok.column,
                        message: e.to_string(),
                    }),
                }
            }
            _ => Err(self.error_here(format!(
                "expected a number, a parameter, a function call or `(`, found {}",
                tok.describe()
            ))),
        }
    }

    fn close(&mut self, open_column: usize) -> Result<(), ExprError> {
        if self.is_op(')') {
            self.bump();
            Ok(())
        } else {
            Err(self.error_here(format!(
                "expected `)` closing the `(` at column {open_column}, found {}",
                self.peek().describe()
            )))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const NAMES: [&str; 3] = ["L1", "m1", "a_2"];
    const VALUES: [f64; 3] = [0.1, 0.024, 2.0];

    fn lookup(name: &str) -> Result<usize, NameError> {
        NAMES
            .iter()
            .position(|n| *n == name)
            .ok_or_else(|| NameError::Unknown(name.to_string()))
    }

    fn parse(src: &str) -> Result<Scalar, ExprError> {
        parse_expr(src, &lookup)
    }

    fn num(v: f64) -> Scalar {
        Scalar::Num(v)
    }
    fn p(i: usize) -> Scalar {
        Scalar::Param(i)
    }
    fn bin(op: BinOp, a: Scalar, b: Scalar) -> Scalar {
        Scalar::Bin(op, Box::new(a), Box::new(b))
    }
    fn neg(a: Scalar) -> Scalar {
        Scalar::Neg(Box::new(a))
    }
    fn call(f: Func, a: Scalar) -> Scalar {
        Scalar::Call(f, Box::new(a))
    }

    #[test]
    fn parses_to_the_expected_tree() {
        use BinOp::*;
        let cases: Vec<(&str, Scalar)> = vec![
            ("0", num(0.0)),
            ("2.5", num(2.5)),
            (".5", num(0.5)),
            ("1e-3", num(1e-3)),
            ("1.5E+2", num(150.0)),
            ("pi", num(PI)),
            ("pi/2", num(PI / 2.0)),
            ("-1", num(-1.0)),
            ("+1", num(1.0)),
            ("L1", p(0)),
            ("a_2", p(2)),
            ("-L1", neg(p(0))),
            ("--L1", neg(neg(p(0)))),
            (
                "m1*L1^2/12",
                bin(Div, bin(Mul, p(1), bin(Pow, p(0), num(2.0))), num(12.0)),
            ),
            ("L1/2", bin(Div, p(0), num(2.0))),
            ("1 + L1 - m1", bin(Sub, bin(Add, num(1.0), p(0)), p(1))),
            ("L1 - m1 - 1", bin(Sub, bin(Sub, p(0), p(1)), num(1.0))),
            ("L1^m1^a_2", bin(Pow, p(0), bin(Pow, p(1), p(2)))),
            ("-L1^2", neg(bin(Pow, p(0), num(2.0)))),
            ("L1^-1", bin(Pow, p(0), num(-1.0))),
            ("(L1 + m1) * 2", bin(Mul, bin(Add, p(0), p(1)), num(2.0))),
            ("sin(L1)", call(Func::Sin, p(0))),
            (
                "sqrt(abs(-m1))",
                call(Func::Sqrt, call(Func::Abs, neg(p(1)))),
            ),
            ("cos(0)", num(1.0)),
            ("2*3+1", num(7.0)),
            ("1/0", bin(Div, num(1.0), num(0.0))),
            ("ln(L1)", call(Func::Ln, p(0))),
            ("exp(tan(L1))", call(Func::Exp, call(Func::Tan, p(0)))),
        ];
        for (src, expected) in cases {
            assert_eq!(parse(src), Ok(expected), "{src}");
        }
    }

    #[test]
    fn evaluates_like_the_written_arithmetic() {
        let (l1, m1, a2) = (VALUES[0], VALUES[1], VALUES[2]);
        let cases: Vec<(&str, f64)> = vec![
            ("m1*L1^2/12", m1 * l1.powf(2.0) / 12.0),
            ("2^3^2", 512.0),
            ("-2^2", -4.0),
            ("(-2)^2", 4.0),
            ("10 - 4 - 3", 3.0),
            ("12 / 3 / 2", 2.0),
            ("a_2 * -L1", -0.2),
            ("sqrt(a_2)^2", a2.sqrt().powf(2.0)),
            ("exp(ln(m1))", m1.ln().exp()),
            ("cos(pi)", -1.0),
            ("abs(-a_2)", 2.0),
        ];
        for (src, expected) in cases {
            let s = parse(src).unwrap_or_else(|e| panic!("{src}: {e:?}"));
            assert_eq!(s.eval(&VALUES), expected, "{src}");
        }
    }

    #[test]
    fn errors_name_the_column() {
        let cases: Vec<(&str, usize, &str)> = vec![
            ("", 1, "empty expression"),
            ("   ", 1, "empty expression"),
            ("L1*", 4, "found the end of the expression"),
            ("m3*2", 1, "unknown parameter `m3`"),
            ("2*m3", 3, "unknown parameter `m3`"),
            ("(L1 + 1", 8, "expected `)` closing the `(` at column 1"),
            ("L1)", 3, "found `)`"),
            ("2 3", 3, "found `3`"),
            ("L1 # 2", 4, "unexpected character `#`"),
            ("sin L1", 1, "function `sin` needs an argument"),
            ("foo(1)", 1, "unknown function `foo`"),
            ("1e", 2, "malformed exponent"),
            ("1e999", 1, "out of range"),
            ("*2", 1, "expected a number"),
            ("sin(1", 6, "closing the `(` at column 4"),
            ("é", 1, "unknown parameter `é`"),
            ("2 ** 3", 4, "expected a number"),
        ];
        for (src, column, message) in cases {
            let err = parse(src).expect_err(src);
            assert_eq!(err.column, column, "{src}: {err:?}");
            assert!(err.message.contains(message), "{src}: {err:?}");
        }
    }

    #[test]
    fn nesting_is_limited_without_overflow() {
        let ok = format!("{}1{}", "(".repeat(150), ")".repeat(150));
        assert_eq!(parse(&ok), Ok(num(1.0)));
        for deep in [
            format!("{}1{}", "(".repeat(100_000), ")".repeat(100_000)),
            format!("{}L1", "-".repeat(100_000)),
            format!("L1{}", "^L1".repeat(100_000)),
            format!("L1{}", "+L1".repeat(100_000)),
            format!("{}L1{}", "sin(".repeat(100_000), ")".repeat(100_000)),
        ] {
            let err = parse(&deep).expect_err("too deep");
            assert!(err.message.contains("nested too deeply"), "{err:?}");
        }
        // A long but flat sum of literals folds to a number.
        assert_eq!(
            parse(&format!("0{}", "+1".repeat(10_000))),
            Ok(num(10_000.0))
        );
    }

    #[test]
    fn depth_and_params_used() {
        let s = parse("m1*L1^2/12 + sin(L1)").unwrap();
        let mut used = Vec::new();
        params_used(&s, &mut used);
        assert_eq!(used, [1, 0, 0]);
        assert_eq!(depth(&s), 5);
    }
}
