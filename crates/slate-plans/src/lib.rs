//! The slate language front end: lexer, parser and diagnostics for `.slate` files, which declare
//! classes, objects, active functions and plans (the production rules of the 1986 NOSC paper).
//!
//! [`parse`] turns a source into a [`File`] syntax tree, or into [`Diagnostics`] listing every
//! error found, each with a [`Span`] that [`Diagnostic::render`] shows under the source line.
//! Names and types are not resolved here: that is the checker's job.
//!
//! ```
//! use slate_plans::{parse, ActionKind, Item};
//!
//! # fn main() -> Result<(), slate_plans::Diagnostics> {
//! let file = parse(
//!     r#"
//!     class Vehicle { speed: real [m/s] in 0 .. 50 = 0.0 accuracy 0.1; }
//!     object gsr : Vehicle context self owner "team/r1/nav";
//!     plan slow_down {
//!         trigger: gsr.speed > 10.0;
//!         action { set gsr.speed = 10.0 confidence 1.0; }
//!     }
//!     "#,
//! )?;
//! let Item::Plan(plan) = &file.items[2] else { unreachable!() };
//! assert_eq!(plan.trigger.as_ref().map(ToString::to_string).as_deref(), Some("(gsr.speed > 10.0)"));
//! assert!(matches!(plan.action[0].kind, ActionKind::Set(_)));
//!
//! let errors = parse("class Vehicle {\n    speed: real [m/s]\n}").unwrap_err();
//! assert_eq!(
//!     errors.render("world.slate", "class Vehicle {\n    speed: real [m/s]\n}"),
//!     "world.slate:2:22: error: expected `;` after attribute declaration, found `}`\n  \
//!      2 |     speed: real [m/s]\n    |                      ^"
//! );
//! # Ok(())
//! # }
//! ```
//!
//! The language is described in `docs/language.md` at the repository root.
#![warn(missing_docs)]

mod action;
mod ast;
mod compile;
mod diagnostic;
mod display;
mod engine;
mod env;
mod eval;
mod fns;
mod index;
mod lexer;
mod load;
mod outbox;
mod parser;
mod scope;

pub use ast::{
    Action, ActionKind, ActiveFn, Assignment, AttributeDecl, AttributeValue, BinaryOp, Bounds,
    ClassDecl, Context, ContextSpec, Expr, ExprKind, File, Ident, Item, Literal, ObjectDecl, Order,
    PacketExpr, Path, PlanDecl, PlanRef, Quantifier, QuantifierKind, ReportPolicy, StrLit, Type,
    TypeRef, UnaryOp, Unit,
};
pub use diagnostic::{Diagnostic, Diagnostics, Severity, Span, Stage};
pub use engine::{
    Engine, MAX_EVALUATIONS_PER_CHANGE, PLAN_CLASS, PlanState, PlanStatus, TIME_FALLBACK,
};
pub use eval::{EvalError, MAX_OPS};
pub use load::{LoadError, Loaded};
pub use outbox::{Outgoing, PlanEvent, PlanMessage, Report, ReportItem};
pub use parser::{MAX_NESTING, parse};
