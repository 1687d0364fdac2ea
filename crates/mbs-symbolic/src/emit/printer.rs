//! A small deterministic printer for the straight-line bodies of the generated functions:
//! expressions are written as text directly, in the layout prettyplease (and rustfmt) give
//! them — one statement per line, a binary expression that does not fit in [`MAX_WIDTH`]
//! columns broken before its operator with the right operand indented by four more spaces:
//!
//! ```text
//! f[0] = ((0.5 * (self.L1 * (x1 * self.m1)))
//!     + (x10
//!         + (self.L1 * x3)));
//! ```
//!
//! Every operation is fully parenthesised, exactly as the expression DAG nests, so the text
//! evaluates the same floating-point operations in the same order as the DAG (no precedence
//! or associativity is left to the Rust parser).

/// Maximum line width (rustfmt's default `max_width`).
pub(super) const MAX_WIDTH: usize = 100;

/// An expression to print, with the length of its one-line form.
pub(super) struct E {
    len: usize,
    kind: Kind,
}

enum Kind {
    /// A name, literal or field access.
    Atom(String),
    /// `(a op b)`
    Bin(Box<E>, &'static str, Box<E>),
    /// `(-a)`
    Neg(Box<E>),
    /// `f(a, b)`
    Call(String, Vec<E>),
    /// `[a, b]`
    Array(Vec<E>),
}

impl E {
    /// A name, literal or field access, printed as is.
    pub fn atom(s: String) -> E {
        E {
            len: s.len(),
            kind: Kind::Atom(s),
        }
    }

    /// `(a op b)`
    pub fn bin(a: E, op: &'static str, b: E) -> E {
        E {
            len: a.len + b.len + op.len() + 4,
            kind: Kind::Bin(Box::new(a), op, Box::new(b)),
        }
    }

    /// `(-a)`
    pub fn neg(a: E) -> E {
        E {
            len: a.len + 3,
            kind: Kind::Neg(Box::new(a)),
        }
    }

    /// `f(args)`
    pub fn call(f: &str, args: Vec<E>) -> E {
        let len = f.len()
            + 2
            + args.iter().map(|a| a.len).sum::<usize>()
            + 2 * args.len().saturating_sub(1);
        E {
            len,
            kind: Kind::Call(f.to_string(), args),
        }
    }

    /// `[items]`
    pub fn array(items: Vec<E>) -> E {
        let len =
            2 + items.iter().map(|a| a.len).sum::<usize>() + 2 * items.len().saturating_sub(1);
        E {
            len,
            kind: Kind::Array(items),
        }
    }

    /// The one-line form.
    fn flat(&self, out: &mut String) {
        match &self.kind {
            Kind::Atom(s) => out.push_str(s),
            Kind::Bin(a, op, b) => {
                out.push('(');
                a.flat(out);
                out.push(' ');
                out.push_str(op);
                out.push(' ');
                b.flat(out);
                out.push(')');
            }
            Kind::Neg(a) => {
                out.push_str("(-");
                a.flat(out);
                out.push(')');
            }
            Kind::Call(f, args) => {
                out.push_str(f);
                out.push('(');
                for (k, a) in args.iter().enumerate() {
                    if k > 0 {
                        out.push_str(", ");
                    }
                    a.flat(out);
                }
                out.push(')');
            }
            Kind::Array(items) => {
                out.push('[');
                for (k, a) in items.iter().enumerate() {
                    if k > 0 {
                        out.push_str(", ");
                    }
                    a.flat(out);
                }
                out.push(']');
            }
        }
    }

    /// Writes the expression starting at column `col` of a line indented by `indent`,
    /// `tail` more characters following it on its last line; returns the column after it.
    fn write(&self, out: &mut String, col: usize, indent: usize, tail: usize) -> usize {
        if col + self.len + tail <= MAX_WIDTH {
            self.flat(out);
            return col + self.len;
        }
        match &self.kind {
            Kind::Atom(s) => {
                out.push_str(s);
                col + s.len()
            }
            Kind::Bin(a, op, b) => {
                out.push('(');
                a.write(out, col + 1, indent, 0);
                let inner = indent + 4;
                out.push('\n');
                push_spaces(out, inner);
                out.push_str(op);
                out.push(' ');
                let end = b.write(out, inner + op.len() + 1, inner, tail + 1);
                out.push(')');
                end + 1
            }
            Kind::Neg(a) => {
                out.push_str("(-");
                let end = a.write(out, col + 2, indent, tail + 1);
                out.push(')');
                end + 1
            }
            Kind::Call(f, args) => {
                // `f(\n    a,\n    b,\n)`
                out.push_str(f);
                if let [one] = args.as_slice()
                    && let Kind::Array(_) = one.kind
                {
                    // `f([\n    a,\n    b,\n])`: rustfmt's overflow of a last array argument.
                    out.push('(');
                    let end = one.write(out, col + f.len() + 1, indent, tail + 1);
                    out.push(')');
                    return end + 1;
                }
                write_block(out, args, indent, '(', ')')
            }
            Kind::Array(items) => {
                // `[\n    a,\n    b,\n]`
                write_block(out, items, indent, '[', ']')
            }
        }
    }
}

/// `open`, one item per line indented by `indent + 4` with a trailing comma, `close` on a
/// line indented by `indent` (rustfmt's vertical list); returns the column after `close`.
fn write_block(out: &mut String, items: &[E], indent: usize, open: char, close: char) -> usize {
    out.push(open);
    let inner = indent + 4;
    for a in items {
        out.push('\n');
        push_spaces(out, inner);
        a.write(out, inner, inner, 1);
        out.push(',');
    }
    out.push('\n');
    push_spaces(out, indent);
    out.push(close);
    indent + 1
}

fn push_spaces(out: &mut String, n: usize) {
    out.extend(std::iter::repeat_n(' ', n));
}

/// Appends the statement `{head}{e};` at indentation `indent`, with its newline.
pub(super) fn write_statement(out: &mut String, indent: usize, head: &str, e: &E) {
    push_spaces(out, indent);
    out.push_str(head);
    e.write(out, indent + head.len(), indent, 1);
    out.push_str(";\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    fn a(s: &str) -> E {
        E::atom(s.into())
    }

    #[test]
    fn short_statements_stay_on_one_line() {
        let mut out = String::new();
        let e = E::bin(a("x1"), "*", E::neg(E::call("f64::sin", vec![a("q[0]")])));
        write_statement(&mut out, 8, "let x2 = ", &e);
        assert_eq!(out, "        let x2 = (x1 * (-f64::sin(q[0])));\n");
    }

    #[test]
    fn long_sums_break_before_the_operator() {
        let long = |k: usize| a(&format!("self.a_rather_long_parameter_name_{k}"));
        let e = E::bin(
            E::bin(long(1), "*", long(2)),
            "+",
            E::bin(long(3), "-", long(4)),
        );
        let mut out = String::new();
        write_statement(&mut out, 8, "f[0] = ", &e);
        let want = "        f[0] = ((self.a_rather_long_parameter_name_1 * self.a_rather_long_parameter_name_2)
            + (self.a_rather_long_parameter_name_3 - self.a_rather_long_parameter_name_4));
";
        assert_eq!(out, want);
        assert!(out.lines().all(|l| l.len() <= MAX_WIDTH), "{out}");
    }
}
