//! Objects and top-level active functions.

use super::{PResult, Parser};
use crate::ast::{ObjectDecl, RuleDecl};
use crate::diagnostic::Span;
use crate::lexer::{Keyword, TokenKind};

impl Parser<'_> {
    /// `object NAME : CLASS [context C] [owner "addr"] ({ values } | ;)`
    pub(super) fn object_decl(&mut self) -> PResult<ObjectDecl> {
        let start = self.bump().span;
        let name = self.ident("an object name")?;
        self.expect(
            &TokenKind::Colon,
            "`:` and a class name after the object name",
        )?;
        let class = self.ident("a class name")?;
        let mut object = ObjectDecl {
            name,
            class,
            context: None,
            owner: None,
            values: Vec::new(),
            span: start,
        };
        self.object_options(&mut object)?;
        let end = if self.at_values_body() {
            let what = format!("object `{}`", object.name.name);
            self.attribute_values(&what, &mut object.values)?
        } else {
            self.expect_semi("`context`, `owner`, `{` or `;`")?
        };
        object.span = start.to(end);
        Ok(object)
    }

    /// `context C` and `owner "addr"`, in either order, each once.
    fn object_options(&mut self, object: &mut ObjectDecl) -> PResult<()> {
        loop {
            let span = self.tok.span;
            if self.eat_kw(Keyword::Context).is_some() {
                let context = self.context_spec()?;
                self.set_once(&mut object.context, context, span, "`context`");
            } else if self.eat_kw(Keyword::Owner).is_some() {
                let owner = self.string("an owner address string after `owner`")?;
                self.set_once(&mut object.owner, owner, span, "`owner`");
            } else {
                return Ok(());
            }
        }
    }

    /// `on write`, with a hint for `on read`.
    pub(super) fn on_write(&mut self) -> PResult<Span> {
        let start = self.bump().span;
        if self.at_kw(Keyword::Read) {
            let message = "`on read` is not supported: declare a `derived` attribute to compute \
                           a value when it is read";
            return Err(self.error(self.tok.span, message));
        }
        self.expect_kw(Keyword::Write, "`write` after `on`")?;
        Ok(start)
    }

    /// `on write OWNER.ATTRIBUTE { actions }` at top level.
    pub(super) fn top_rule(&mut self) -> PResult<RuleDecl> {
        let start = self.on_write()?;
        let owner = self.ident("a class or object name after `on write`")?;
        if !self.at(&TokenKind::Dot) {
            let message = format!(
                "expected `.` and an attribute name after `{}`: at top level, `on write` names \
                 a class or object attribute, as in `on write Vehicle.speed`",
                owner.name
            );
            return Err(self.error(self.expected_span(), message));
        }
        self.bump();
        let attribute = self.member_name("an attribute name")?;
        let what = format!("`on write {}.{}`", owner.name, attribute.name);
        let (actions, end) = self.action_block(&what)?;
        Ok(RuleDecl {
            owner: Some(owner),
            attribute,
            actions,
            span: start.to(end),
        })
    }
}
