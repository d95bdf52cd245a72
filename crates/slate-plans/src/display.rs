//! Source-like printing of syntax-tree pieces, for messages and tests.
//!
//! Expressions print fully parenthesized (`(a + (b * c))`), so the printed text shows how the
//! parser grouped them, and parses back to the same tree.

use std::fmt::{self, Display, Formatter};

use crate::ast::{BinaryOp, UnaryOp};
use crate::ast::{Expr, ExprKind, Literal, Path, Quantifier, QuantifierKind, Type};

impl Display for Expr {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match &self.kind {
            ExprKind::Literal(literal) => write!(f, "{literal}"),
            ExprKind::Vector(items) => write!(f, "[{}]", Joined(items)),
            ExprKind::Name(name) => f.write_str(&name.name),
            ExprKind::Field(base, field) => write!(f, "{base}.{}", field.name),
            ExprKind::Call(name, args) => write!(f, "{}({})", name.name, Joined(args)),
            ExprKind::Unary(UnaryOp::Not, operand) => write!(f, "(not {operand})"),
            ExprKind::Unary(UnaryOp::Neg, operand) => write!(f, "(-{operand})"),
            ExprKind::Binary(op, lhs, rhs) => write!(f, "({lhs} {op} {rhs})"),
            ExprKind::Quantifier(quantifier) => write!(f, "({quantifier})"),
        }
    }
}

/// Items separated by `, `.
struct Joined<'a>(&'a [Expr]);

impl Display for Joined<'_> {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        for (i, item) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "{item}")?;
        }
        Ok(())
    }
}

impl Display for Literal {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Literal::Int(value) => write!(f, "{value}"),
            Literal::Real(value) => write!(f, "{value:?}"),
            Literal::Duration(seconds) => write!(f, "{seconds:?}s"),
            Literal::Str(text) => write_string(f, text),
            Literal::Bool(value) => write!(f, "{value}"),
            Literal::None => f.write_str("none"),
        }
    }
}

/// A string literal with the language's escapes.
fn write_string(f: &mut Formatter<'_>, text: &str) -> fmt::Result {
    f.write_str("\"")?;
    for c in text.chars() {
        match c {
            '"' => f.write_str("\\\"")?,
            '\\' => f.write_str("\\\\")?,
            '\n' => f.write_str("\\n")?,
            c => write!(f, "{c}")?,
        }
    }
    f.write_str("\"")
}

impl Display for Quantifier {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}: {}", self.kind, self.var.name, self.class.name)?;
        if let Some(filter) = &self.filter {
            write!(f, " where {filter}")?;
        }
        if let Some(order) = &self.order {
            write!(f, " by {}", order.key)?;
            if order.descending {
                f.write_str(" desc")?;
            }
        }
        Ok(())
    }
}

impl Display for QuantifierKind {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            QuantifierKind::Any => "any",
            QuantifierKind::All => "all",
            QuantifierKind::Count => "count",
        })
    }
}

impl Display for BinaryOp {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Display for Path {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(&self.root.name)?;
        for field in &self.fields {
            write!(f, ".{}", field.name)?;
        }
        Ok(())
    }
}

impl Display for Type {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Type::Int => f.write_str("int"),
            Type::Real => f.write_str("real"),
            Type::Bool => f.write_str("bool"),
            Type::String => f.write_str("string"),
            Type::Ref => f.write_str("ref"),
            Type::Vec(length) => write!(f, "vec<{length}>"),
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::ast::{Item, Literal};

    /// The expression of `trigger:` in a one-plan file.
    fn trigger(source: &str) -> crate::ast::Expr {
        let file = crate::parse(&format!("plan p {{ trigger: {source}; action {{}} }}"));
        match file.map(|f| f.items.into_iter().next()) {
            Ok(Some(Item::Plan(plan))) => plan.trigger.unwrap_or_else(|| unreachable!()),
            other => panic!("{source}: {other:?}"),
        }
    }

    #[test]
    fn printed_expressions_parse_back_to_the_same_text() {
        for source in [
            "a + b * c - -d % 2",
            "not x.speed.accuracy > 1e-7 or y and \"q\\\"\\\\\\n\" != none",
            "[1, 2.5, 250ms, true] == polar(self.range, now())",
            "(any o: Obstacle where o.r < 5 by distance(o.p, g.p) desc) and (count t: T) > 2",
            "all v: Vehicle where v.alive",
        ] {
            let printed = trigger(source).to_string();
            assert_eq!(trigger(&printed).to_string(), printed, "{source}");
        }
    }

    #[test]
    fn literals_print_in_source_syntax() {
        let cases = [
            (Literal::Real(2.0), "2.0"),
            (Literal::Duration(0.25), "0.25s"),
            (Literal::Str("a\"b".into()), "\"a\\\"b\""),
            (Literal::None, "none"),
        ];
        for (literal, text) in cases {
            assert_eq!(literal.to_string(), text);
        }
    }
}
