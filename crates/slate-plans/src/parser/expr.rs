//! Expressions, by precedence climbing. Loosest first: `or`, `and`, prefix `not`, comparisons
//! (non-associative), `+ -`, `* / %`, prefix `-`, then postfix `.field`.

use super::{MAX_NESTING, PResult, Parser, Reported, too_deep_expression};
use crate::ast::{
    BinaryOp, Expr, ExprKind, Ident, Literal, Order, Quantifier, QuantifierKind, UnaryOp,
};
use crate::diagnostic::Span;
use crate::lexer::{Keyword, TokenKind};

const PREC_OR: u8 = 1;
const PREC_AND: u8 = 2;
/// Prefix `not`: looser than comparisons, tighter than `and`.
const PREC_NOT: u8 = 3;
const PREC_CMP: u8 = 4;
const PREC_ADD: u8 = 5;
const PREC_MUL: u8 = 6;

/// The binary operator `kind` stands for, with its precedence.
fn binary_op(kind: &TokenKind) -> Option<(BinaryOp, u8)> {
    Some(match kind {
        TokenKind::Keyword(Keyword::Or) => (BinaryOp::Or, PREC_OR),
        TokenKind::Keyword(Keyword::And) => (BinaryOp::And, PREC_AND),
        TokenKind::EqEq => (BinaryOp::Eq, PREC_CMP),
        TokenKind::NotEq => (BinaryOp::Ne, PREC_CMP),
        TokenKind::Lt => (BinaryOp::Lt, PREC_CMP),
        TokenKind::Le => (BinaryOp::Le, PREC_CMP),
        TokenKind::Gt => (BinaryOp::Gt, PREC_CMP),
        TokenKind::Ge => (BinaryOp::Ge, PREC_CMP),
        TokenKind::Plus => (BinaryOp::Add, PREC_ADD),
        TokenKind::Minus => (BinaryOp::Sub, PREC_ADD),
        TokenKind::Star => (BinaryOp::Mul, PREC_MUL),
        TokenKind::Slash => (BinaryOp::Div, PREC_MUL),
        TokenKind::Percent => (BinaryOp::Rem, PREC_MUL),
        _ => return None,
    })
}

fn quantifier_kind(kind: &TokenKind) -> Option<QuantifierKind> {
    match kind {
        TokenKind::Keyword(Keyword::Any) => Some(QuantifierKind::Any),
        TokenKind::Keyword(Keyword::All) => Some(QuantifierKind::All),
        TokenKind::Keyword(Keyword::Count) => Some(QuantifierKind::Count),
        _ => None,
    }
}

impl Parser<'_> {
    /// `kind` as a node of the tree, unless that makes it deeper than [`MAX_NESTING`]: then
    /// the error is reported at `at` (the operator, `.`, name or bracket that went too deep)
    /// and the parse stops. Every expression node is made here, so no tree is deeper.
    fn node(&mut self, kind: ExprKind, span: Span, at: Span) -> PResult<Expr> {
        let expr = Expr::node(kind, span);
        if expr.depth() > MAX_NESTING {
            return Err(self.too_deep(at, too_deep_expression()));
        }
        Ok(expr)
    }

    /// A whole expression.
    pub(super) fn expr(&mut self) -> PResult<Expr> {
        self.binary(PREC_OR)
    }

    /// Operators of precedence `min` and above, left-associative except comparisons.
    fn binary(&mut self, min: u8) -> PResult<Expr> {
        let mut lhs = if min <= PREC_NOT && self.at_kw(Keyword::Not) {
            self.not()?
        } else {
            self.unary()?
        };
        while let Some((op, prec)) = binary_op(&self.tok.kind) {
            if prec < min {
                break;
            }
            let at = self.bump().span;
            let rhs = self.binary(prec + 1)?;
            let span = lhs.span.to(rhs.span);
            lhs = self.node(ExprKind::Binary(op, Box::new(lhs), Box::new(rhs)), span, at)?;
            if op.is_comparison() {
                self.reject_chained_comparison(op)?;
            }
        }
        Ok(lhs)
    }

    /// `not EXPR`, where EXPR stops before `and` and `or`.
    fn not(&mut self) -> PResult<Expr> {
        let start = self.bump().span;
        let operand = self.nested(|p| p.binary(PREC_NOT))?;
        self.unary_expr(UnaryOp::Not, start, operand)
    }

    fn unary_expr(&mut self, op: UnaryOp, start: Span, operand: Expr) -> PResult<Expr> {
        let span = start.to(operand.span);
        self.node(ExprKind::Unary(op, Box::new(operand)), span, start)
    }

    /// `a < b < c` is an error: comparisons don't chain.
    fn reject_chained_comparison(&mut self, first: BinaryOp) -> PResult<()> {
        match binary_op(&self.tok.kind) {
            Some((second, _)) if second.is_comparison() => {
                let message = match &self.quantifier {
                    Some(head) => format!(
                        "comparison operators cannot be chained: a quantifier's condition \
                         extends as far right as it can, so parenthesize the quantifier to \
                         compare its result, as in `({head} where ...) {} ...`",
                        second.as_str()
                    ),
                    None => format!(
                        "comparison operators cannot be chained: combine them with `and`, as \
                         in `a {} b and b {} c`",
                        first.as_str(),
                        second.as_str()
                    ),
                };
                Err(self.error(self.tok.span, message))
            }
            _ => Ok(()),
        }
    }

    /// Prefix `-`, then postfix.
    fn unary(&mut self) -> PResult<Expr> {
        if self.at(&TokenKind::Minus) {
            let start = self.bump().span;
            let operand = self.nested(|p| p.unary())?;
            return self.unary_expr(UnaryOp::Neg, start, operand);
        }
        self.postfix()
    }

    /// A primary followed by `.field`s.
    fn postfix(&mut self) -> PResult<Expr> {
        let mut expr = self.primary()?;
        while self.eat(&TokenKind::Dot) {
            let field = self.member_name("an attribute or field name after `.`")?;
            if self.at(&TokenKind::LParen) {
                let message = format!(
                    "`.{}(...)`: there are no methods; call functions by name, as in `{}(x)`",
                    field.name, field.name
                );
                return Err(self.error(self.tok.span, message));
            }
            let (span, at) = (expr.span.to(field.span), field.span);
            expr = self.node(ExprKind::Field(Box::new(expr), field), span, at)?;
        }
        Ok(expr)
    }

    fn primary(&mut self) -> PResult<Expr> {
        if let Some(literal) = self.literal() {
            let span = self.bump().span;
            return Ok(Expr::leaf(ExprKind::Literal(literal), span));
        }
        match &self.tok.kind {
            TokenKind::Ident(_) => self.name_or_call(),
            TokenKind::Keyword(Keyword::SelfKw) => {
                let span = self.bump().span;
                let name = Ident {
                    name: "self".to_owned(),
                    span,
                };
                Ok(Expr::leaf(ExprKind::Name(name), span))
            }
            TokenKind::LParen => self.nested(Self::parenthesized),
            TokenKind::LBracket => self.nested(Self::vector),
            TokenKind::Keyword(Keyword::Not) => {
                let message = "`not` applies to a whole comparison; parenthesize it to use it \
                               here, as in `(not ...)`";
                Err(self.error(self.tok.span, message))
            }
            kind if quantifier_kind(kind).is_some() => self.nested(Self::quantifier),
            _ => Err(self.expected("an expression")),
        }
    }

    /// The literal the current token is, if it is one.
    fn literal(&self) -> Option<Literal> {
        Some(match &self.tok.kind {
            TokenKind::Int(value) => Literal::Int(*value),
            TokenKind::Real(value) => Literal::Real(*value),
            TokenKind::Duration(seconds) => Literal::Duration(*seconds),
            TokenKind::Str(text) => Literal::Str(text.clone()),
            TokenKind::Keyword(Keyword::True) => Literal::Bool(true),
            TokenKind::Keyword(Keyword::False) => Literal::Bool(false),
            TokenKind::Keyword(Keyword::None) => Literal::None,
            _ => return None,
        })
    }

    fn name_or_call(&mut self) -> PResult<Expr> {
        let name = self.ident("a name")?;
        if !self.at(&TokenKind::LParen) {
            let span = name.span;
            return Ok(Expr::leaf(ExprKind::Name(name), span));
        }
        let (args, end) = self.nested(|p| p.list(&TokenKind::LParen, &TokenKind::RParen, "`)`"))?;
        let span = name.span.to(end);
        self.node(ExprKind::Call(name, args), span, span)
    }

    /// `( EXPR )`; the result keeps the span of the inner expression.
    fn parenthesized(&mut self) -> PResult<Expr> {
        self.bump();
        let outer = self.quantifier.take();
        let inner = self.expr();
        self.quantifier = outer;
        let inner = inner?;
        self.expect(&TokenKind::RParen, "`)`")?;
        Ok(inner)
    }

    /// `[ EXPR, ... ]`
    fn vector(&mut self) -> PResult<Expr> {
        let start = self.tok.span;
        let (items, end) = self.list(&TokenKind::LBracket, &TokenKind::RBracket, "`]`")?;
        self.node(ExprKind::Vector(items), start.to(end), start)
    }

    /// `OPEN [EXPR (, EXPR)* [,]] CLOSE`; returns the items and the span of CLOSE.
    fn list(
        &mut self,
        open: &TokenKind,
        close: &TokenKind,
        close_text: &str,
    ) -> PResult<(Vec<Expr>, Span)> {
        self.expect(open, "a list")?;
        let outer = self.quantifier.take();
        let items = self.list_items(close, close_text);
        self.quantifier = outer;
        let items = items?;
        Ok((items, self.bump().span))
    }

    /// Items up to (not including) `close`.
    fn list_items(&mut self, close: &TokenKind, close_text: &str) -> PResult<Vec<Expr>> {
        let mut items = Vec::new();
        while !self.at(close) {
            items.push(self.expr()?);
            if !self.eat(&TokenKind::Comma) && !self.at(close) {
                return Err(self.expected(&format!("`,` or {close_text}")));
            }
        }
        Ok(items)
    }

    /// `any|all|count VAR : CLASS [where EXPR] [by EXPR [desc]]`
    fn quantifier(&mut self) -> PResult<Expr> {
        let start = self.tok.span;
        let kind = quantifier_kind(&self.bump().kind).ok_or(Reported)?;
        let keyword = self.prev_text().to_owned();
        let var = self.ident(&format!("a variable name after `{keyword}`"))?;
        self.expect(
            &TokenKind::Colon,
            "`:` and a class name after the quantifier variable",
        )?;
        let class = self.ident("a class name")?;
        let head = format!("{keyword} {}: {}", var.name, class.name);
        let filter = self.quantifier_filter(kind, &head)?;
        let order = self.quantifier_order(kind, &head)?;
        self.reject_operator_after_quantifier(&head)?;
        let span = start.to(self.prev);
        let quantifier = Quantifier {
            kind,
            var,
            class,
            filter,
            order,
        };
        self.node(ExprKind::Quantifier(Box::new(quantifier)), span, start)
    }

    /// `where EXPR`, required for `all`.
    fn quantifier_filter(&mut self, kind: QuantifierKind, head: &str) -> PResult<Option<Expr>> {
        if self.eat_kw(Keyword::Where).is_none() {
            if kind == QuantifierKind::All {
                return Err(self.expected(&format!("`where` and a condition after `{head}`")));
            }
            return Ok(None);
        }
        self.quantifier_operand(head).map(Some)
    }

    /// `by EXPR [desc]`, only for `any`.
    fn quantifier_order(&mut self, kind: QuantifierKind, head: &str) -> PResult<Option<Order>> {
        if !self.at_kw(Keyword::By) {
            return Ok(None);
        }
        if kind != QuantifierKind::Any {
            let message = format!("`by` orders the matches of `any` only, not of `{head}`");
            return Err(self.error(self.tok.span, message));
        }
        self.bump();
        let key = self.quantifier_operand(head)?;
        let descending = self.eat_kw(Keyword::Desc).is_some();
        Ok(Some(Order { key, descending }))
    }

    /// An expression inside a quantifier, remembering the quantifier for error messages.
    fn quantifier_operand(&mut self, head: &str) -> PResult<Expr> {
        let outer = self.quantifier.replace(head.to_owned());
        let result = self.expr();
        self.quantifier = outer;
        result
    }

    /// An unparenthesized quantifier cannot be the left operand of an operator.
    fn reject_operator_after_quantifier(&mut self, head: &str) -> PResult<()> {
        let rest = match binary_op(&self.tok.kind) {
            Some((op, _)) => format!(" {} ...", op.as_str()),
            None if self.at(&TokenKind::Dot) => ".field".to_owned(),
            None => return Ok(()),
        };
        let message = format!(
            "a quantifier must be parenthesized to be used as an operand, as in `({head} ...){rest}`"
        );
        Err(self.error(self.tok.span, message))
    }
}
