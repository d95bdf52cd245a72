//! Plans (clauses in any order, each once) and the actions of plans and active functions.

use super::{BlockKind, PResult, Parser};
use crate::ast::{Action, ActionKind, Assignment, Expr, Ident, PlanDecl, PlanRef, StrLit};
use crate::diagnostic::Span;
use crate::lexer::{Keyword, TokenKind};

const CLAUSES: &str =
    "a plan clause (`initiation:`, `trigger:`, `termination:`, `every` or `action`)";
const ACTIONS: &str = "an action (`set`, `report`, `send`, `create` or `delete`)";

impl Parser<'_> {
    /// `plan NAME { clauses }`
    pub(super) fn plan_decl(&mut self) -> PResult<PlanDecl> {
        let start = self.bump().span;
        let name = self.ident("a plan name")?;
        self.plan_body(start, name)
    }

    /// `{ clauses }` after a plan name; the action block is required.
    fn plan_body(&mut self, start: Span, name: Ident) -> PResult<PlanDecl> {
        self.nested_plan(|p| {
            let mut plan = PlanDecl {
                name,
                initiation: None,
                trigger: None,
                termination: None,
                every: None,
                action: Vec::new(),
                span: start,
            };
            let mut seen = Vec::new();
            let what = format!("plan `{}`", plan.name.name);
            let end = p.block(&what, BlockKind::Other, |p| {
                p.plan_clause(&mut plan, &mut seen)
            })?;
            plan.span = start.to(end);
            if !seen.contains(&Keyword::Action) {
                let message = format!("plan `{}` has no `action {{ ... }}` block", plan.name.name);
                p.error(plan.name.span, message);
            }
            Ok(plan)
        })
    }

    /// One clause. A duplicate is reported at its keyword (even if the first one was broken),
    /// parsed, and dropped.
    fn plan_clause(&mut self, plan: &mut PlanDecl, seen: &mut Vec<Keyword>) -> PResult<()> {
        let span = self.tok.span;
        let clause = match self.tok.kind {
            TokenKind::Keyword(
                clause @ (Keyword::Initiation
                | Keyword::Trigger
                | Keyword::Termination
                | Keyword::Every
                | Keyword::Action),
            ) => clause,
            _ => return Err(self.expected(CLAUSES)),
        };
        let first = self.first_clause(clause, span, &plan.name.name, seen);
        self.bump();
        if clause == Keyword::Action {
            let (actions, _) = self.action_block("the `action` block")?;
            if first {
                plan.action = actions;
            }
            return Ok(());
        }
        let value = self.clause_expr(clause)?;
        if first {
            *clause_slot(plan, clause) = Some(value);
        }
        Ok(())
    }

    /// Records `clause` (written at `span`) as seen; if it already was, reports a duplicate.
    fn first_clause(
        &mut self,
        clause: Keyword,
        span: Span,
        plan: &str,
        seen: &mut Vec<Keyword>,
    ) -> bool {
        if seen.contains(&clause) {
            let message = format!("duplicate `{}` clause in plan `{plan}`", clause.as_str());
            self.error(span, message);
            return false;
        }
        seen.push(clause);
        true
    }

    /// After the keyword: `: EXPR;` (or ` EXPR;` for `every`).
    fn clause_expr(&mut self, clause: Keyword) -> PResult<Expr> {
        let name = clause.as_str();
        if clause != Keyword::Every {
            self.expect(&TokenKind::Colon, &format!("`:` after `{name}`"))?;
        }
        let value = self.expr()?;
        self.expect_semi(&format!("`;` after the `{name}` clause"))?;
        Ok(value)
    }

    /// `{ action* }`; returns the actions and the closing `}`.
    pub(super) fn action_block(&mut self, what: &str) -> PResult<(Vec<Action>, Span)> {
        let mut actions = Vec::new();
        let end = self.block(what, BlockKind::Other, |p| {
            actions.push(p.action()?);
            Ok(())
        })?;
        Ok((actions, end))
    }

    fn action(&mut self) -> PResult<Action> {
        let start = self.tok.span;
        let kind = match self.tok.kind {
            TokenKind::Keyword(Keyword::Set) => self.set_action()?,
            TokenKind::Keyword(Keyword::Report) => self.report_action()?,
            TokenKind::Keyword(Keyword::Send) => self.send_action()?,
            TokenKind::Keyword(Keyword::Create) => self.create_action()?,
            TokenKind::Keyword(Keyword::Delete) => {
                self.bump();
                let target = self.expr()?;
                self.expect_semi("`;` after `delete`")?;
                ActionKind::Delete(target)
            }
            _ => return Err(self.expected(ACTIONS)),
        };
        Ok(Action {
            kind,
            span: start.to(self.prev),
        })
    }

    /// `set TARGET = packet (, TARGET = packet)* ;`
    fn set_action(&mut self) -> PResult<ActionKind> {
        self.bump();
        let mut assignments = vec![self.assignment()?];
        while self.eat(&TokenKind::Comma) {
            assignments.push(self.assignment()?);
        }
        self.expect_semi("`,` or `;` after the `set` assignment")?;
        Ok(ActionKind::Set(assignments))
    }

    fn assignment(&mut self) -> PResult<Assignment> {
        let target = self.path("an attribute to set, as in `gsr.speed`")?;
        self.expect(&TokenKind::Assign, "`=` after the attribute to set")?;
        let packet = self.packet()?;
        let span = target.span.to(self.prev);
        Ok(Assignment {
            target,
            packet,
            span,
        })
    }

    /// `report TARGET (, TARGET)* [to "addr"] ;`
    fn report_action(&mut self) -> PResult<ActionKind> {
        self.bump();
        let mut targets = vec![self.path("an object or attribute to report")?];
        while self.eat(&TokenKind::Comma) {
            targets.push(self.path("an object or attribute to report")?);
        }
        let to = match self.eat_kw(Keyword::To) {
            Some(_) => Some(self.string("a destination address string after `to`")?),
            None => None,
        };
        self.expect_semi("`,`, `to` or `;` after the reported targets")?;
        Ok(ActionKind::Report { targets, to })
    }

    /// `send plan NAME { ... } to "addr";` or `send NAME to "addr";`
    fn send_action(&mut self) -> PResult<ActionKind> {
        self.bump();
        let plan = match self.eat_kw(Keyword::Plan) {
            Some(start) => {
                let name = self.ident("a plan name")?;
                PlanRef::Inline(Box::new(self.plan_body(start, name)?))
            }
            None => PlanRef::Named(self.ident("`plan` or the name of a plan to send")?),
        };
        let to = self.destination()?;
        self.expect_semi("`;` after the destination")?;
        Ok(ActionKind::Send { plan, to })
    }

    fn destination(&mut self) -> PResult<StrLit> {
        self.expect_kw(Keyword::To, "`to` and a destination address")?;
        self.string("a destination address string after `to`")
    }

    /// `create CLASS NAME [context C] ({ values } [;] | ;)`
    fn create_action(&mut self) -> PResult<ActionKind> {
        self.bump();
        let class = self.ident("a class name after `create`")?;
        let name = self.ident("a name for the new object")?;
        let context = match self.eat_kw(Keyword::Context) {
            Some(_) => Some(self.context_spec()?),
            None => None,
        };
        let mut values = Vec::new();
        if self.at_values_body() {
            let what = format!("the values of `{}`", name.name);
            self.attribute_values(&what, &mut values)?;
            self.eat(&TokenKind::Semi);
        } else {
            self.expect_semi("`context`, `{` or `;`")?;
        }
        Ok(ActionKind::Create {
            class,
            name,
            context,
            values,
        })
    }
}

/// Where the expression of clause `clause` (not `action`) is kept.
fn clause_slot(plan: &mut PlanDecl, clause: Keyword) -> &mut Option<Expr> {
    match clause {
        Keyword::Initiation => &mut plan.initiation,
        Keyword::Trigger => &mut plan.trigger,
        Keyword::Termination => &mut plan.termination,
        _ => &mut plan.every,
    }
}
