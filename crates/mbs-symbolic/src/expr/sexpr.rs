//! S-expressions: [`Dag::sexpr`] writes a node as `(+ q0 (* 2 qd1))`, [`Dag::parse_sexpr`]
//! builds one through the folding constructors, so that a simplification is tested as a
//! table of strings (`"(+ q0 0)" => "q0"`).
//!
//! Syntax: numbers (`2`, `-0.5`, `1e-3`); variables `q<i>`, `qd<i>`, `qdd<i>`, `t`, `p<k>`;
//! `(- a)`, `(+ a b)`, `(- a b)`, `(* a b)`, `(/ a b)`, `(^ a b)` and `(<fn> a)` with the
//! function names of the model's expressions (`sin`, `cos`, `tan`, `sqrt`, `exp`, `ln`,
//! `abs`). `+` and `*` take two or more operands, folded from the left.

use super::{Dag, Fun, Id, Node, Var};

impl Dag {
    /// Writes the expression as an s-expression, e.g. `(+ q0 (* 2 qd1))`. Variables print as
    /// `q0`, `qd0`, `qdd0`, `t`, `p0`.
    pub fn sexpr(&self, id: Id) -> String {
        let mut s = String::new();
        self.write_sexpr(id, &mut s);
        s
    }

    fn write_sexpr(&self, id: Id, out: &mut String) {
        use std::fmt::Write;
        let bin = |op: &str, a: Id, b: Id, out: &mut String| {
            out.push('(');
            out.push_str(op);
            out.push(' ');
            self.write_sexpr(a, out);
            out.push(' ');
            self.write_sexpr(b, out);
            out.push(')');
        };
        match self.node(id) {
            Node::Const(bits) => {
                let _ = write!(out, "{}", f64::from_bits(bits));
            }
            Node::Var(v) => {
                let _ = write!(out, "{v}");
            }
            Node::Neg(a) => {
                out.push_str("(- ");
                self.write_sexpr(a, out);
                out.push(')');
            }
            Node::Add(a, b) => bin("+", a, b, out),
            Node::Sub(a, b) => bin("-", a, b, out),
            Node::Mul(a, b) => bin("*", a, b, out),
            Node::Div(a, b) => bin("/", a, b, out),
            Node::Pow(a, b) => bin("^", a, b, out),
            Node::Fun(f, a) => {
                out.push('(');
                out.push_str(f.name());
                out.push(' ');
                self.write_sexpr(a, out);
                out.push(')');
            }
        }
    }

    /// Builds the s-expression `src` through the folding constructors ([`Dag::add`], ...),
    /// so the result is the simplified node. The error names the offending token.
    pub fn parse_sexpr(&mut self, src: &str) -> Result<Id, SexprError> {
        let spaced = src.replace('(', " ( ").replace(')', " ) ");
        let tokens: Vec<&str> = spaced.split_whitespace().collect();
        let mut pos = 0;
        let id = self.parse_tokens(&tokens, &mut pos)?;
        match tokens.get(pos) {
            None => Ok(id),
            Some(t) => Err(SexprError::Trailing(t.to_string())),
        }
    }

    fn parse_tokens(&mut self, tokens: &[&str], pos: &mut usize) -> Result<Id, SexprError> {
        let tok = *tokens.get(*pos).ok_or(SexprError::End)?;
        *pos += 1;
        if tok != "(" {
            return self.parse_atom(tok);
        }
        let op = *tokens.get(*pos).ok_or(SexprError::EndAfterParen)?;
        *pos += 1;
        let mut args = vec![];
        while tokens.get(*pos) != Some(&")") {
            if *pos >= tokens.len() {
                return Err(SexprError::Unclosed(op.to_string()));
            }
            args.push(self.parse_tokens(tokens, pos)?);
        }
        *pos += 1;
        let fun = [
            Fun::Sin,
            Fun::Cos,
            Fun::Tan,
            Fun::Sqrt,
            Fun::Exp,
            Fun::Ln,
            Fun::Abs,
        ]
        .into_iter()
        .find(|f| f.name() == op);
        match (op, args.as_slice()) {
            ("-", [a]) => Ok(self.neg(*a)),
            ("-", [a, b]) => Ok(self.sub(*a, *b)),
            ("/", [a, b]) => Ok(self.div(*a, *b)),
            ("^", [a, b]) => Ok(self.pow(*a, *b)),
            ("+" | "*", [first, rest @ ..]) if !rest.is_empty() => {
                let mut acc = *first;
                for &r in rest {
                    acc = if op == "+" {
                        self.add(acc, r)
                    } else {
                        self.mul(acc, r)
                    };
                }
                Ok(acc)
            }
            (_, [a]) if fun.is_some() => Ok(self.fun(fun.unwrap_or(Fun::Abs), *a)),
            _ => Err(SexprError::Arity {
                op: op.to_string(),
                operands: args.len(),
            }),
        }
    }

    fn parse_atom(&mut self, tok: &str) -> Result<Id, SexprError> {
        if let Ok(v) = tok.parse::<f64>() {
            return Ok(self.constant(v));
        }
        let index = |rest: &str| {
            rest.parse::<u32>()
                .map_err(|_| SexprError::Atom(tok.to_string()))
        };
        let var = if tok == "t" {
            Var::Time
        } else if let Some(r) = tok.strip_prefix("qdd") {
            Var::Qdd(index(r)?)
        } else if let Some(r) = tok.strip_prefix("qd") {
            Var::Qd(index(r)?)
        } else if let Some(r) = tok.strip_prefix('q') {
            Var::Q(index(r)?)
        } else if let Some(r) = tok.strip_prefix('p') {
            Var::Param(index(r)?)
        } else {
            return Err(SexprError::Atom(tok.to_string()));
        };
        Ok(self.var(var))
    }
}

/// Why an s-expression cannot be read ([`Dag::parse_sexpr`]); each names the token.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SexprError {
    /// The input ends where an expression is expected.
    #[error("unexpected end of input")]
    End,
    /// The input ends after `(`.
    #[error("unexpected end of input after `(`")]
    EndAfterParen,
    /// An operator's list is not closed.
    #[error("missing `)` for `({0}`")]
    Unclosed(String),
    /// An operator with a number of operands it does not take.
    #[error("`({op}` with {operands} operands")]
    Arity {
        /// The operator.
        op: String,
        /// The operands given.
        operands: usize,
    },
    /// Not a number, `t`, `qN`, `qdN`, `qddN` or `pN`.
    #[error("unknown atom `{0}`")]
    Atom(String),
    /// Text after a complete expression.
    #[error("unexpected `{0}` after the expression")]
    Trailing(String),
}
