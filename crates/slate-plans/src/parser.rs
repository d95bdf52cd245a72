//! The parser: tokens to a syntax tree, by recursive descent (items and statements) and precedence
//! climbing (expressions, in `parser/expr.rs`).
//!
//! Error handling: a parsing function that finds a problem pushes one diagnostic and returns
//! `Err(Reported)`; the nearest enclosing loop (block member or top-level item) then skips to a
//! synchronisation point — past the next `;`, up to a `}`, or up to a keyword that starts an item
//! — and carries on. So every independent mistake is reported once, and one mistake is not
//! reported twice. Exceeding [`MAX_NESTING`] or [`MAX_PLAN_NESTING`], and too many errors, are
//! fatal: parsing stops there.

mod class;
mod expr;
mod link;
mod object;
mod plan;

use crate::ast::{AttributeValue, ContextSpec, File, Ident, Item, PacketExpr, Path, StrLit};
use crate::diagnostic::{Diagnostic, Diagnostics, MAX_ERRORS, Span, Stage};
use crate::lexer::{Keyword, Lexer, Token, TokenKind};
use slate_model::Context;

/// How deeply an expression may nest: each operator, `.`, call, bracket and quantifier is a
/// level of the tree ([`Expr::depth`](crate::Expr::depth)), and so is each parenthesis for
/// the parser.
///
/// Parsing, checking, evaluating, printing and dropping recurse on these levels, so this
/// bounds the stack they take (docs/language.md, "Limits"): deeper input is one error at the
/// place it goes too deep, never a crash, and nothing deeper is built.
pub const MAX_NESTING: usize = 64;

/// How many plans may be sent inside one another (`send plan a { ... send plan b { ... } }`
/// is 2 levels, the plan declaring them included). Lower than [`MAX_NESTING`]: checking a
/// plan level takes several times the stack of an expression level, and the demo's plans
/// nest 3 deep.
pub const MAX_PLAN_NESTING: usize = 16;

/// The error for an expression deeper than [`MAX_NESTING`]: what counts, and what to do.
fn too_deep_expression() -> String {
    format!(
        "expression nested too deep: at most {MAX_NESTING} levels of operators, `.`, calls, \
         brackets, parentheses and quantifiers are allowed; split it into smaller expressions \
         (a derived attribute can name a part)"
    )
}

/// The error for plans sent inside plans deeper than [`MAX_PLAN_NESTING`].
fn too_deep_plans() -> String {
    format!(
        "plans nested too deep: at most {MAX_PLAN_NESTING} levels of plans sent inside plans are \
         allowed"
    )
}

/// Parses a whole `.slate` source.
///
/// On failure, returns every error found (lexical and syntactic), in source order.
pub fn parse(source: &str) -> Result<File, Diagnostics> {
    let mut parser = Parser::new(source);
    let file = parser.file();
    parser.finish(file)
}

/// Marks a problem that has already been pushed as a diagnostic.
#[derive(Debug)]
struct Reported;

type PResult<T> = Result<T, Reported>;

/// Which kind of `{ ... }` block is being parsed; only class bodies may contain `on`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum BlockKind {
    Class,
    Other,
}

struct Parser<'s> {
    source: &'s str,
    lexer: Lexer<'s>,
    /// The current (next unconsumed) token.
    tok: Token,
    /// The last consumed token; line 0 before the first.
    prev: Span,
    /// Whether the last consumed token was a lexical error (which may have swallowed a `}`).
    prev_was_error: bool,
    diagnostics: Vec<Diagnostic>,
    /// Current expression nesting level (see [`MAX_NESTING`]).
    depth: usize,
    /// Current plan nesting level (see [`MAX_PLAN_NESTING`]).
    plan_depth: usize,
    /// Set when nesting went too deep: every loop stops.
    fatal: bool,
    /// Where a missing `}` was last reported, so that enclosing blocks don't report it again.
    unclosed_at: Option<usize>,
    /// `any o: Obstacle`-style text of the quantifier whose `where`/`by` is being parsed.
    quantifier: Option<String>,
}

impl<'s> Parser<'s> {
    fn new(source: &'s str) -> Self {
        let mut lexer = Lexer::new(source);
        let tok = lexer.next_token();
        Self {
            source,
            lexer,
            tok,
            prev: Span::default(),
            prev_was_error: false,
            diagnostics: Vec::new(),
            depth: 0,
            plan_depth: 0,
            fatal: false,
            unclosed_at: None,
            quantifier: None,
        }
    }

    fn finish(self, file: File) -> Result<File, Diagnostics> {
        let mut all = self.lexer.into_diagnostics();
        all.extend(self.diagnostics);
        all.sort_by_key(|d| d.span.start);
        if all.iter().any(Diagnostic::is_error) {
            Err(Diagnostics(all))
        } else {
            Ok(file)
        }
    }

    fn file(&mut self) -> File {
        let mut items = Vec::new();
        while self.tok.kind != TokenKind::Eof && !self.fatal {
            if self.eat(&TokenKind::Semi) {
                continue;
            }
            let start = self.tok.span.start;
            match self.item() {
                Ok(item) => items.push(item),
                Err(Reported) => {
                    self.recover_item();
                    self.ensure_progress(start, Self::recover_item);
                }
            }
        }
        File { items }
    }

    fn item(&mut self) -> PResult<Item> {
        match self.tok.kind {
            TokenKind::Keyword(Keyword::Class) => self.class_decl().map(Item::Class),
            TokenKind::Keyword(Keyword::Object) => self.object_decl().map(Item::Object),
            TokenKind::Keyword(Keyword::Plan) => self.plan_decl().map(Item::Plan),
            TokenKind::Keyword(Keyword::On) => self.top_rule().map(Item::Rule),
            TokenKind::Keyword(Keyword::Link) => self.link_decl().map(Item::Link),
            _ => Err(self.expected("`class`, `object`, `plan`, `on` or `link`")),
        }
    }

    // ---- tokens ----

    /// Consumes the current token and returns it.
    fn bump(&mut self) -> Token {
        let next = self.lexer.next_token();
        let token = std::mem::replace(&mut self.tok, next);
        self.prev = token.span;
        self.prev_was_error = token.kind == TokenKind::Error;
        token
    }

    fn at(&self, kind: &TokenKind) -> bool {
        self.tok.kind == *kind
    }

    fn at_kw(&self, keyword: Keyword) -> bool {
        self.tok.kind == TokenKind::Keyword(keyword)
    }

    fn eat(&mut self, kind: &TokenKind) -> bool {
        let found = self.at(kind);
        if found {
            self.bump();
        }
        found
    }

    /// Consumes `keyword` if it is next, returning its span.
    fn eat_kw(&mut self, keyword: Keyword) -> Option<Span> {
        self.at_kw(keyword).then(|| self.bump().span)
    }

    /// Consumes `kind` or reports "expected {what}".
    fn expect(&mut self, kind: &TokenKind, what: &str) -> PResult<Span> {
        if self.at(kind) {
            Ok(self.bump().span)
        } else {
            Err(self.expected(what))
        }
    }

    /// Consumes the `;` that ends a statement (see [`Self::expect_at_line_end`]).
    fn expect_semi(&mut self, what: &str) -> PResult<Span> {
        self.expect_at_line_end(&TokenKind::Semi, what)
    }

    /// Consumes `kind`. When it is missing at the end of a line (the next token is on a later
    /// line), reports it and carries on as if it were there, so that the next line still parses
    /// as intended: a forgotten `;` or `{` costs one error, not one per following line.
    fn expect_at_line_end(&mut self, kind: &TokenKind, what: &str) -> PResult<Span> {
        if self.at(kind) {
            return Ok(self.bump().span);
        }
        let at_line_end = self.prev.line > 0 && self.tok.span.line > self.prev.line;
        let reported = self.expected(what);
        if at_line_end {
            Ok(self.prev.after(self.source))
        } else {
            Err(reported)
        }
    }

    /// Whether a `{ NAME = ...` body starts here, its `{` possibly forgotten.
    fn at_values_body(&self) -> bool {
        let word = matches!(self.tok.kind, TokenKind::Ident(_) | TokenKind::Keyword(_));
        self.at(&TokenKind::LBrace) || word && self.names_a_member()
    }

    fn expect_kw(&mut self, keyword: Keyword, what: &str) -> PResult<Span> {
        self.eat_kw(keyword).ok_or_else(|| self.expected(what))
    }

    /// An identifier (not a keyword): a class, object, plan or variable name.
    fn ident(&mut self, what: &str) -> PResult<Ident> {
        match &self.tok.kind {
            TokenKind::Ident(name) => {
                let name = name.clone();
                Ok(Ident {
                    name,
                    span: self.bump().span,
                })
            }
            TokenKind::Keyword(keyword) => {
                let message = format!("expected {what}, found keyword `{}`", keyword.as_str());
                Err(self.error(self.tok.span, message))
            }
            _ => Err(self.expected(what)),
        }
    }

    /// An attribute or field name: any word, keywords included (`x.speed.accuracy`, `count`).
    fn member_name(&mut self, what: &str) -> PResult<Ident> {
        let name = match &self.tok.kind {
            TokenKind::Ident(name) => name.clone(),
            TokenKind::Keyword(keyword) => keyword.as_str().to_owned(),
            _ => return Err(self.expected(what)),
        };
        Ok(Ident {
            name,
            span: self.bump().span,
        })
    }

    fn string(&mut self, what: &str) -> PResult<StrLit> {
        let TokenKind::Str(value) = &self.tok.kind else {
            return Err(self.expected(what));
        };
        let value = value.clone();
        Ok(StrLit {
            value,
            span: self.bump().span,
        })
    }

    // ---- errors ----

    fn error(&mut self, span: Span, message: impl Into<String>) -> Reported {
        if self.fatal {
            return Reported;
        }
        self.diagnostics
            .push(Diagnostic::error(Stage::Parse, span, message));
        if self.diagnostics.len() >= MAX_ERRORS {
            self.fatal = true;
            let message = format!("too many errors ({MAX_ERRORS}); stopping here");
            self.diagnostics
                .push(Diagnostic::error(Stage::Parse, span, message));
        }
        Reported
    }

    /// Reports "expected {what}, found {current token}", unless the lexer already reported it.
    fn expected(&mut self, what: &str) -> Reported {
        if self.tok.kind == TokenKind::Error {
            return Reported;
        }
        let message = format!("expected {what}, found {}", self.describe(&self.tok));
        self.error(self.expected_span(), message)
    }

    /// Where a missing token goes: the current token, or just after the previous one when the
    /// current token is on a later line (a missing `;` belongs at the end of its line).
    fn expected_span(&self) -> Span {
        if self.prev.line > 0 && self.tok.span.line > self.prev.line {
            self.prev.after(self.source)
        } else {
            self.tok.span
        }
    }

    fn describe(&self, token: &Token) -> String {
        if token.kind == TokenKind::Eof {
            return "end of file".to_owned();
        }
        let text = self
            .source
            .get(token.span.start..token.span.end)
            .unwrap_or("?");
        match text.char_indices().nth(24) {
            Some((cut, _)) => format!("`{}...`", &text[..cut]),
            None => format!("`{text}`"),
        }
    }

    /// Reports `what` as a duplicate at `span` if `slot` is taken; otherwise fills it.
    fn set_once<T>(&mut self, slot: &mut Option<T>, value: T, span: Span, what: &str) {
        if slot.is_some() {
            self.error(span, format!("duplicate {what}"));
        } else {
            *slot = Some(value);
        }
    }

    /// Runs `parse` one expression nesting level deeper; past [`MAX_NESTING`] is fatal.
    fn nested<T>(&mut self, parse: impl FnOnce(&mut Self) -> PResult<T>) -> PResult<T> {
        self.enter(|p| &mut p.depth, MAX_NESTING, too_deep_expression)?;
        let result = parse(self);
        self.depth -= 1;
        result
    }

    /// Runs `parse` one plan nesting level deeper; past [`MAX_PLAN_NESTING`] is fatal.
    fn nested_plan<T>(&mut self, parse: impl FnOnce(&mut Self) -> PResult<T>) -> PResult<T> {
        self.enter(|p| &mut p.plan_depth, MAX_PLAN_NESTING, too_deep_plans)?;
        let result = parse(self);
        self.plan_depth -= 1;
        result
    }

    /// Increments the counter that `level` selects, unless it is at `max`; then reports
    /// `too_deep`.
    fn enter(
        &mut self,
        level: impl Fn(&mut Self) -> &mut usize,
        max: usize,
        too_deep: fn() -> String,
    ) -> PResult<()> {
        if *level(self) >= max {
            return Err(self.too_deep(self.tok.span, too_deep()));
        }
        *level(self) += 1;
        Ok(())
    }

    /// Reports that nesting went too deep at `span`, and stops the parse.
    fn too_deep(&mut self, span: Span, message: String) -> Reported {
        self.error(span, message);
        self.fatal = true;
        Reported
    }

    // ---- recovery ----

    /// Whether `keyword` (found while skipping at brace `depth`) surely starts a new item.
    fn syncs_at(&self, keyword: Keyword, depth: usize) -> bool {
        match keyword {
            Keyword::Class | Keyword::Object | Keyword::Link => true,
            Keyword::Plan => self.prev_text() != "send",
            Keyword::On => depth == 0,
            _ => false,
        }
    }

    fn prev_text(&self) -> &str {
        self.source
            .get(self.prev.start..self.prev.end)
            .unwrap_or("")
    }

    /// Skips the rest of a broken statement: past the next `;` or balanced `{ ... }`, or up to
    /// a `}` that closes the enclosing block or a keyword that starts an item.
    fn recover_statement(&mut self) {
        let mut depth = 0usize;
        while !self.fatal {
            match &self.tok.kind {
                TokenKind::Eof => return,
                TokenKind::Semi if depth == 0 => {
                    self.bump();
                    return;
                }
                TokenKind::RBrace if depth == 0 => return,
                TokenKind::RBrace if depth == 1 => {
                    self.bump();
                    return;
                }
                TokenKind::RBrace => depth -= 1,
                TokenKind::LBrace => depth += 1,
                TokenKind::Keyword(keyword) if self.syncs_at(*keyword, depth) => return,
                _ => {}
            }
            self.bump();
        }
    }

    /// Skips to the next keyword that starts an item.
    fn recover_item(&mut self) {
        let mut depth = 0usize;
        while !self.fatal {
            match &self.tok.kind {
                TokenKind::Eof => return,
                TokenKind::LBrace => depth += 1,
                TokenKind::RBrace => depth = depth.saturating_sub(1),
                TokenKind::Keyword(keyword) if self.syncs_at(*keyword, depth) => return,
                _ => {}
            }
            self.bump();
        }
    }

    // ---- blocks ----

    /// Parses `{ member* }`, calling `member` at each member start and recovering from its
    /// errors; returns the span of the closing `}`. Stray `;` are allowed and ignored.
    fn block(
        &mut self,
        what: &str,
        kind: BlockKind,
        mut member: impl FnMut(&mut Self) -> PResult<()>,
    ) -> PResult<Span> {
        self.expect_at_line_end(&TokenKind::LBrace, &format!("`{{` to open {what}"))?;
        while !self.fatal {
            match &self.tok.kind {
                TokenKind::RBrace => return Ok(self.bump().span),
                TokenKind::Semi => {
                    self.bump();
                }
                TokenKind::Eof => return Err(self.unclosed(what)),
                TokenKind::Keyword(keyword)
                    if self.ends_block(*keyword, kind) && !self.names_a_member() =>
                {
                    return Err(self.unclosed(what));
                }
                _ => {
                    let start = self.tok.span.start;
                    if member(self).is_err() {
                        self.recover_statement();
                        self.ensure_progress(start, Self::recover_statement);
                    }
                }
            }
        }
        Err(Reported)
    }

    /// If nothing was consumed since `start`, skips the current token and recovers again, so
    /// that every turn of a recovering loop moves on: recovery stops *before* an item keyword,
    /// which may be the very token a member failed on (`on = 1;` in an action block).
    fn ensure_progress(&mut self, start: usize, recover: fn(&mut Self)) {
        if self.tok.span.start == start && self.tok.kind != TokenKind::Eof {
            self.bump();
            recover(self);
        }
    }

    fn ends_block(&self, keyword: Keyword, kind: BlockKind) -> bool {
        match keyword {
            Keyword::Class | Keyword::Object | Keyword::Plan | Keyword::Link => true,
            Keyword::On => kind != BlockKind::Class,
            _ => false,
        }
    }

    /// Whether the current word is an attribute name (`plan: string;`, `on = 1;`) rather than
    /// the keyword that starts an item or a rule: it is one if `:` or `=` follows.
    fn names_a_member(&self) -> bool {
        matches!(
            self.lexer.peek_token().kind,
            TokenKind::Colon | TokenKind::Assign
        )
    }

    /// Reports a missing `}`, once for all the blocks it leaves open, and not at all right after
    /// a lexical error (an unterminated string swallows the rest of its line, braces included).
    fn unclosed(&mut self, what: &str) -> Reported {
        if self.unclosed_at == Some(self.tok.span.start) || self.prev_was_error {
            return Reported;
        }
        self.unclosed_at = Some(self.tok.span.start);
        self.expected(&format!("`}}` to close {what}"))
    }

    // ---- pieces shared by items and actions ----

    /// `NAME(.FIELD)*`, where NAME may be `self`.
    fn path(&mut self, what: &str) -> PResult<Path> {
        let root = match self.eat_kw(Keyword::SelfKw) {
            Some(span) => Ident {
                name: "self".to_owned(),
                span,
            },
            None => self.ident(what)?,
        };
        let mut fields = Vec::new();
        while self.eat(&TokenKind::Dot) {
            fields.push(self.member_name("an attribute name after `.`")?);
        }
        let span = root.span.to(self.prev);
        Ok(Path { root, fields, span })
    }

    /// `EXPR [accuracy EXPR] [confidence EXPR]`, qualifiers in either order, each once.
    fn packet(&mut self) -> PResult<PacketExpr> {
        let value = self.expr()?;
        let mut packet = PacketExpr {
            value,
            accuracy: None,
            confidence: None,
        };
        loop {
            let span = self.tok.span;
            if self.eat_kw(Keyword::Accuracy).is_some() {
                let accuracy = self.expr()?;
                self.set_once(&mut packet.accuracy, accuracy, span, "`accuracy`");
            } else if self.eat_kw(Keyword::Confidence).is_some() {
                let confidence = self.expr()?;
                self.set_once(&mut packet.confidence, confidence, span, "`confidence`");
            } else {
                return Ok(packet);
            }
        }
    }

    /// After `context`: `self`, `surroundings` or `system`.
    fn context_spec(&mut self) -> PResult<ContextSpec> {
        let context = match &self.tok.kind {
            TokenKind::Keyword(Keyword::SelfKw) => Context::Self_,
            TokenKind::Ident(name) if name == "surroundings" => Context::Surroundings,
            TokenKind::Ident(name) if name == "system" => Context::System,
            _ => return Err(self.expected("a context (`self`, `surroundings` or `system`)")),
        };
        Ok(ContextSpec {
            context,
            span: self.bump().span,
        })
    }

    /// `{ NAME = packet; ... }` of an object or a `create`; returns the closing `}`.
    fn attribute_values(&mut self, what: &str, values: &mut Vec<AttributeValue>) -> PResult<Span> {
        self.block(what, BlockKind::Other, |p| {
            let name = p.member_name("an attribute name")?;
            p.expect(&TokenKind::Assign, "`=` after the attribute name")?;
            let packet = p.packet()?;
            let span = name.span.to(p.prev);
            p.expect_semi("`;` after the attribute value")?;
            values.push(AttributeValue { name, packet, span });
            Ok(())
        })
    }
}

#[cfg(test)]
mod tests;
