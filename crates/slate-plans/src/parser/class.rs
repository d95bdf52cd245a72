//! Class declarations: attributes with their options, and `on write` rules.

use super::{BlockKind, PResult, Parser};
use crate::ast::{AttributeDecl, Bounds, ClassDecl, Expr, Ident, PacketExpr, RuleDecl};
use crate::ast::{ReportPolicyDecl, Type, TypeRef, Unit};
use crate::diagnostic::Span;
use crate::lexer::{Keyword, TokenKind};

/// One parsed attribute option, before it is stored in its slot.
enum AttrOption {
    Unit(Unit),
    Bounds(Bounds),
    Step(Expr),
    Default(PacketExpr),
    Derived(PacketExpr),
    Merge(Ident),
    Report(ReportPolicyDecl),
}

const TYPES: &str = "a type (`int`, `real`, `bool`, `string`, `ref` or `vec<N>`)";

impl Parser<'_> {
    /// `class NAME [: PARENT] { (attribute | on write ...)* }`
    pub(super) fn class_decl(&mut self) -> PResult<ClassDecl> {
        let start = self.bump().span;
        let name = self.ident("a class name")?;
        let parent = if self.eat(&TokenKind::Colon) {
            Some(self.ident("a parent class name after `:`")?)
        } else {
            None
        };
        let (mut attributes, mut rules) = (Vec::new(), Vec::new());
        let what = format!("class `{}`", name.name);
        let end = self.block(&what, BlockKind::Class, |p| {
            if p.at_kw(Keyword::On) && !p.names_a_member() {
                rules.push(p.class_rule()?);
            } else {
                attributes.push(p.attribute()?);
            }
            Ok(())
        })?;
        Ok(ClassDecl {
            name,
            parent,
            attributes,
            rules,
            span: start.to(end),
        })
    }

    /// `on write ATTRIBUTE { actions }` inside a class.
    fn class_rule(&mut self) -> PResult<RuleDecl> {
        let start = self.on_write()?;
        let attribute = self.member_name("an attribute name after `on write`")?;
        if self.at(&TokenKind::Dot) {
            let message = format!(
                "inside a class, `on write` names an attribute of the class, as in `on write {}`",
                attribute.name
            );
            return Err(self.error(self.tok.span, message));
        }
        let what = format!("`on write {}`", attribute.name);
        let (actions, end) = self.action_block(&what)?;
        Ok(RuleDecl {
            owner: None,
            attribute,
            actions,
            span: start.to(end),
        })
    }

    /// `NAME : TYPE option* ;`
    fn attribute(&mut self) -> PResult<AttributeDecl> {
        let name = self.member_name("an attribute declaration or `on write`")?;
        if self.at(&TokenKind::Dot) || self.at(&TokenKind::Assign) {
            let message = "a class body declares attributes (`name: type ...;`) and `on write` \
                           rules; write values with an object or a `set` action";
            return Err(self.error(self.tok.span, message));
        }
        self.expect(&TokenKind::Colon, "`:` and a type after the attribute name")?;
        let ty = self.type_ref()?;
        let mut decl = AttributeDecl {
            name,
            ty,
            unit: None,
            bounds: None,
            step: None,
            default: None,
            derived: None,
            merge: None,
            report: None,
            span: Span::default(),
        };
        while self.attribute_option(&mut decl)? {}
        let end = self.expect_semi("`;` after attribute declaration")?;
        decl.span = decl.name.span.to(end);
        self.reject_default_and_derived(&decl);
        Ok(decl)
    }

    /// `int`, `real`, `bool`, `string`, `ref` or `vec<N>`.
    fn type_ref(&mut self) -> PResult<TypeRef> {
        let TokenKind::Ident(word) = &self.tok.kind else {
            return Err(self.expected(TYPES));
        };
        let ty = match word.as_str() {
            "int" => Type::Int,
            "real" => Type::Real,
            "bool" => Type::Bool,
            "string" => Type::String,
            "ref" => Type::Ref,
            "vec" => return self.vec_type(),
            _ => {
                let message = format!("unknown type `{word}`: expected {TYPES}");
                return Err(self.error(self.tok.span, message));
            }
        };
        Ok(TypeRef {
            ty,
            span: self.bump().span,
        })
    }

    /// `vec < N >` with N ≥ 1.
    fn vec_type(&mut self) -> PResult<TypeRef> {
        let start = self.bump().span;
        self.expect(&TokenKind::Lt, "`<` and a length after `vec`")?;
        let length = match self.tok.kind {
            TokenKind::Int(n) => u32::try_from(n).ok().filter(|&n| n >= 1),
            _ => return Err(self.expected("a vector length")),
        };
        let Some(length) = length else {
            let message = format!("vector length must be between 1 and {}", u32::MAX);
            return Err(self.error(self.tok.span, message));
        };
        self.bump();
        let end = self.expect(&TokenKind::Gt, "`>` after the vector length")?;
        Ok(TypeRef {
            ty: Type::Vec(length),
            span: start.to(end),
        })
    }

    /// One option after the type, stored in `decl` (a duplicate is reported and dropped);
    /// false if the current token starts no option.
    fn attribute_option(&mut self, decl: &mut AttributeDecl) -> PResult<bool> {
        let span = self.tok.span;
        let option = match self.tok.kind {
            TokenKind::LBracket => AttrOption::Unit(self.unit()?),
            TokenKind::Keyword(Keyword::In) => AttrOption::Bounds(self.bounds()?),
            TokenKind::Keyword(Keyword::Step) => {
                self.bump();
                AttrOption::Step(self.expr()?)
            }
            TokenKind::Assign => {
                self.bump();
                AttrOption::Default(self.packet()?)
            }
            TokenKind::Keyword(Keyword::Derived) => AttrOption::Derived(self.derived()?),
            TokenKind::Keyword(Keyword::Merge) => AttrOption::Merge(self.merge_policy()?),
            TokenKind::Keyword(Keyword::Report) => {
                AttrOption::Report(self.report_policy(&decl.name.name)?)
            }
            TokenKind::Keyword(keyword @ (Keyword::Accuracy | Keyword::Confidence)) => {
                let message = format!(
                    "`{}` must follow a default value (`= ...`) or `derived = ...`",
                    keyword.as_str()
                );
                return Err(self.error(span, message));
            }
            _ => return Ok(false),
        };
        self.store_option(decl, option, span);
        Ok(true)
    }

    /// Puts `option` (written at `span`) in its slot of `decl`, unless the slot is taken.
    fn store_option(&mut self, decl: &mut AttributeDecl, option: AttrOption, span: Span) {
        let place = format!("in attribute `{}`", decl.name.name);
        let what = |name: &str| format!("{name} {place}");
        match option {
            AttrOption::Unit(unit) => self.set_once(&mut decl.unit, unit, span, &what("unit")),
            AttrOption::Bounds(b) => self.set_once(&mut decl.bounds, b, span, &what("`in` bounds")),
            AttrOption::Step(step) => self.set_once(&mut decl.step, step, span, &what("`step`")),
            AttrOption::Default(d) => self.set_once(&mut decl.default, d, span, &what("default")),
            AttrOption::Derived(d) => self.set_once(&mut decl.derived, d, span, &what("`derived`")),
            AttrOption::Merge(m) => self.set_once(&mut decl.merge, m, span, &what("`merge`")),
            AttrOption::Report(r) => self.set_once(&mut decl.report, r, span, &what("`report`")),
        }
    }

    /// `derived = packet`
    fn derived(&mut self) -> PResult<PacketExpr> {
        self.bump();
        self.expect(&TokenKind::Assign, "`=` and an expression after `derived`")?;
        self.packet()
    }

    /// `merge POLICY`
    fn merge_policy(&mut self) -> PResult<Ident> {
        self.bump();
        self.ident("a merge policy (`latest`, `confident`, `fused` or `owned`)")
    }

    fn reject_default_and_derived(&mut self, decl: &AttributeDecl) {
        if let (Some(_), Some(derived)) = (&decl.default, &decl.derived) {
            let message = format!(
                "attribute `{}` cannot have both a default value and `derived`: a derived value \
                 is computed on every read",
                decl.name.name
            );
            self.error(derived.value.span, message);
        }
    }

    /// `[raw text]`, read raw by the lexer.
    fn unit(&mut self) -> PResult<Unit> {
        let open = self.tok.span;
        let scanned = self.lexer.unit_text();
        self.prev = match &scanned {
            Ok((_, span)) => *span,
            Err(span) => *span,
        };
        self.prev_was_error = scanned.is_err();
        self.tok = self.lexer.next_token();
        match scanned {
            Ok((text, _)) if text.is_empty() => {
                let message = "empty unit: leave out the brackets for a quantity without unit";
                Err(self.error(open.to(self.prev), message))
            }
            Ok((text, _)) => Ok(Unit {
                text,
                span: open.to(self.prev),
            }),
            Err(_) => {
                let message = "unterminated unit: expected `]` on the same line";
                Err(self.error(open.to(self.prev), message))
            }
        }
    }

    /// `in MIN .. MAX`
    fn bounds(&mut self) -> PResult<Bounds> {
        self.bump();
        let min = self.expr()?;
        self.expect(&TokenKind::DotDot, "`..` between the bounds")?;
        let max = self.expr()?;
        Ok(Bounds { min, max })
    }

    /// `report` then one or more of `every EXPR`, `heartbeat EXPR`, `deadband EXPR`,
    /// `on_accuracy`, each once.
    fn report_policy(&mut self, attribute: &str) -> PResult<ReportPolicyDecl> {
        let start = self.bump().span;
        let place = format!("in the `report` options of attribute `{attribute}`");
        self.report_options(start, &place)
    }

    /// One or more report options after `report` (at `start`), each once; `place` says
    /// where they are in messages about duplicates. Class attributes and link blocks share
    /// this grammar.
    pub(super) fn report_options(&mut self, start: Span, place: &str) -> PResult<ReportPolicyDecl> {
        let mut policy = ReportPolicyDecl {
            span: start,
            ..ReportPolicyDecl::default()
        };
        while self.report_option(&mut policy, place)? {}
        if policy.span == start {
            let what = "`every`, `heartbeat`, `deadband` or `on_accuracy` after `report`";
            return Err(self.expected(what));
        }
        Ok(policy)
    }

    /// One report option; false if the current token is none.
    fn report_option(&mut self, policy: &mut ReportPolicyDecl, place: &str) -> PResult<bool> {
        let span = self.tok.span;
        let (slot, name) = match &self.tok.kind {
            TokenKind::Keyword(Keyword::Every) => (&mut policy.every, "every"),
            TokenKind::Keyword(Keyword::Heartbeat) => (&mut policy.heartbeat, "heartbeat"),
            TokenKind::Keyword(Keyword::Deadband) => (&mut policy.deadband, "deadband"),
            TokenKind::Ident(word) if word == "on_accuracy" => {
                self.bump();
                self.set_once(
                    &mut policy.on_accuracy,
                    span,
                    span,
                    &format!("`on_accuracy` {place}"),
                );
                policy.span = policy.span.to(span);
                return Ok(true);
            }
            _ => return Ok(false),
        };
        self.bump();
        let value = self.expr()?;
        let end = value.span;
        self.set_once(slot, value, span, &format!("`{name}` {place}"));
        policy.span = policy.span.to(end);
        Ok(true)
    }
}
