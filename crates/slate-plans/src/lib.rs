//! The slate language and what runs it: the lexer and parser, the checker, the evaluator, the
//! plan engine and the loader. A `.slate` file declares classes, objects, active functions and
//! plans (the production rules of the 1986 NOSC paper); [`Engine::load`] checks a whole file
//! against a [`Board`](slate_model::Board), applies it (or nothing of it, with every error
//! found) and installs its plans, which the [`Engine`] then runs as the board changes.
//!
//! ```
//! use std::sync::Arc;
//!
//! use slate_model::{Board, Value};
//! use slate_plans::{Engine, PlanState};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let board = Arc::new(Board::new());
//! let engine = Engine::new(&board);
//! let loaded = engine.load(
//!     "gsr.slate",
//!     r#"
//!     class Vehicle { speed: real [m/s] in 0 .. 50 = 0.0 accuracy 0.1; }
//!     object gsr : Vehicle;
//!     plan slow_down {
//!         trigger: gsr.speed > 10.0;
//!         action { set gsr.speed = 10.0 confidence 1.0; }
//!     }
//!     "#,
//! )?;
//! assert_eq!(loaded.plans, ["slow_down"]);
//!
//! board.write("gsr", "speed", 12.0)?; // the trigger rises: the plan fires
//! assert_eq!(board.read("gsr", "speed")?.value, Value::Real(10.0));
//! let status = engine.status("slow_down").expect("installed");
//! assert_eq!((status.fired, status.state), (1, PlanState::Active));
//!
//! let error = engine.load("bad.slate", "object x : Nowhere;").unwrap_err();
//! assert!(error.rendered.starts_with("bad.slate:1:12: error:"), "{error}");
//! # Ok(())
//! # }
//! ```
//!
//! Underneath, [`parse`] turns a source into a [`File`] syntax tree, or into [`Diagnostics`]
//! listing every error found, each with a [`Span`] that [`Diagnostic::render`] shows under the
//! source line. Names and types are resolved by the checker, when a file is loaded.
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
//! The language is described in `docs/language.md` at the repository root; how the crate is laid
//! out is in `src/README.md`.
#![warn(missing_docs)]

mod action;
mod active;
mod ast;
mod authority;
mod check;
mod diagnostic;
mod display;
mod engine;
mod env;
mod eval;
mod index;
mod lexer;
mod load;
mod outbox;
mod parser;
mod scope;

pub use ast::{
    Action, ActionKind, Assignment, AttributeDecl, AttributeValue, BinaryOp, Bounds, ClassDecl,
    ContextSpec, ExportDecl, Expr, ExprKind, File, Ident, Item, LinkDecl, LinkEntry, LinkEntryKind,
    LinkFilterDecl, Literal, ObjectDecl, Order, PacketExpr, Path, PlanDecl, PlanRef, Quantifier,
    QuantifierKind, ReportPolicyDecl, RuleDecl, StrLit, Type, TypeRef, UnaryOp, Unit,
};
pub use diagnostic::{Diagnostic, Diagnostics, MAX_QUOTED_CHARS, Severity, Span, Stage};
pub use engine::{
    Engine, MAX_EVALUATIONS_PER_CHANGE, PLAN_CLASS, PlanProgress, PlanState, PlanStatus,
    TIME_FALLBACK,
};
pub use eval::{EvalError, MAX_OPS};
pub use load::{
    LinkExport, LinkName, LinkPolicy, LinkReport, LoadError, Loaded, ROBOT_PLACEHOLDER,
    Substitution, SubstitutionError,
};
pub use outbox::{Outgoing, PlanEvent, PlanMessage, ReportItem, ReportRequest};
pub use parser::{MAX_NESTING, MAX_PLAN_NESTING, parse};
