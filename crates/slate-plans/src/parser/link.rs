//! Link policies: `link NAME { export ...; report ...; heartbeat ...; }`.
//!
//! `export`, `never` and `timeout` are words with a meaning only here, not keywords, so they
//! still name objects and plans elsewhere. The report options are the attributes' own
//! grammar ([`Parser::report_options`]).

use super::{BlockKind, PResult, Parser};
use crate::ast::{ExportDecl, LinkDecl, LinkEntry, LinkEntryKind, LinkFilterDecl};
use crate::lexer::{Keyword, TokenKind};

impl Parser<'_> {
    /// `link NAME { entry* }`
    pub(super) fn link_decl(&mut self) -> PResult<LinkDecl> {
        let start = self.bump().span;
        let link = self.ident("a link name (`team` or `robot`)")?;
        let what = format!("link `{}`", link.name);
        let mut entries = Vec::new();
        let end = self.block(&what, BlockKind::Other, |p| {
            entries.push(p.link_entry()?);
            Ok(())
        })?;
        Ok(LinkDecl {
            link,
            entries,
            span: start.to(end),
        })
    }

    /// `export ...;`, `report ...;` or `heartbeat ...;`
    fn link_entry(&mut self) -> PResult<LinkEntry> {
        let start = self.tok.span;
        let kind = match &self.tok.kind {
            TokenKind::Ident(word) if word == "export" => self.export_entry()?,
            TokenKind::Keyword(Keyword::Report) => self.link_report()?,
            TokenKind::Keyword(Keyword::Heartbeat) => self.link_heartbeat()?,
            _ => return Err(self.expected("`export`, `report` or `heartbeat` in a link block")),
        };
        let span = start.to(self.prev);
        self.expect_semi("`;` after the link entry")?;
        Ok(LinkEntry { kind, span })
    }

    /// `export CLASS [(CONTEXT, ...)] {, CLASS [(CONTEXT, ...)]}`
    fn export_entry(&mut self) -> PResult<LinkEntryKind> {
        self.bump();
        let mut classes = vec![self.export_class()?];
        while self.eat(&TokenKind::Comma) {
            classes.push(self.export_class()?);
        }
        Ok(LinkEntryKind::Export(classes))
    }

    /// `CLASS` or `CLASS (CONTEXT, ...)`
    fn export_class(&mut self) -> PResult<ExportDecl> {
        let class = self.ident("a class name to export")?;
        let mut contexts = Vec::new();
        if self.eat(&TokenKind::LParen) {
            contexts.push(self.context_spec()?);
            while self.eat(&TokenKind::Comma) {
                contexts.push(self.context_spec()?);
            }
            self.expect(&TokenKind::RParen, "`)` after the contexts")?;
        }
        Ok(ExportDecl { class, contexts })
    }

    /// `report CLASS.ATTRIBUTE never` or `report CLASS.ATTRIBUTE option+`
    fn link_report(&mut self) -> PResult<LinkEntryKind> {
        let start = self.bump().span;
        let attribute = self.path("a class attribute (`Class.attribute`) after `report`")?;
        let filter = match &self.tok.kind {
            TokenKind::Ident(word) if word == "never" => LinkFilterDecl::Never(self.bump().span),
            _ => {
                let place = format!("in the link report of `{}`", path_text(&attribute));
                let policy = self.report_options(start, &place);
                if policy.is_err()
                    && let Some(last) = self.diagnostics.last_mut()
                {
                    never_hint(last);
                }
                LinkFilterDecl::Policy(policy?)
            }
        };
        Ok(LinkEntryKind::Report { attribute, filter })
    }

    /// `heartbeat DURATION [timeout DURATION]`
    fn link_heartbeat(&mut self) -> PResult<LinkEntryKind> {
        self.bump();
        let heartbeat = self.expr()?;
        let timeout = match &self.tok.kind {
            TokenKind::Ident(word) if word == "timeout" => {
                self.bump();
                Some(self.expr()?)
            }
            _ => None,
        };
        Ok(LinkEntryKind::Heartbeat { heartbeat, timeout })
    }
}

/// `Robot.position` as written.
fn path_text(path: &crate::ast::Path) -> String {
    let fields = path.fields.iter().map(|f| format!(".{}", f.name));
    std::iter::once(path.root.name.clone())
        .chain(fields)
        .collect()
}

/// In a link block, `never` is a report option too: say so when none was found.
fn never_hint(d: &mut crate::diagnostic::Diagnostic) {
    if d.message.starts_with("expected `every`") {
        d.message = d.message.replacen(
            "`every`, `heartbeat`, `deadband` or `on_accuracy`",
            "`never`, `every`, `heartbeat`, `deadband` or `on_accuracy`",
            1,
        );
    }
}
