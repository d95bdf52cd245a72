//! The built-in classes: defined on every board from the start, so that files, plans and
//! `slate check` can name them before any machinery (the ICI, the plan engine) runs.
//!
//! | class | defined for | written by |
//! |---|---|---|
//! | `Thing` | the root of every class tree | nobody (it declares nothing) |
//! | `Module` | the modules a board has heard of | the board's ICI |
//! | `Plan` | the plans a board runs | the board's plan engine |

use crate::{AttrDecl, ClassDef, ValueType};

/// The class of the objects that stand for modules (liveliness as a world-model fact).
pub const MODULE_CLASS: &str = "Module";

/// The class of the objects that show a board's plans.
pub const PLAN_CLASS: &str = "Plan";

/// The `Module` class:
///
/// | attribute | type | meaning |
/// |---|---|---|
/// | `address` | string | the module's address, `team/robot/module` |
/// | `alive` | bool | heard from within its liveliness timeout (default false) |
/// | `last_seen` | real, s | when it was last heard from, seconds since the Unix epoch |
///
/// Each board's ICI writes these objects from what it hears (they are local facts, never
/// reported): SELF context for the modules of its own robot, SYSTEM for other robots'.
pub fn module_class() -> ClassDef {
    ClassDef::new(MODULE_CLASS)
        .attr(AttrDecl::new("address", ValueType::Str))
        .attr(AttrDecl::new("alive", ValueType::Bool).default_value(false))
        .attr(AttrDecl::new("last_seen", ValueType::Real).unit("s"))
}

/// The `Plan` class: one object per plan a board runs, in the SELF context. Every field is
/// guarded: only the plan engine writes them (a plan is cancelled through the engine).
///
/// | attribute | type | meaning |
/// |---|---|---|
/// | `state` | string | `pending`, `active`, `terminated` or `cancelled` |
/// | `fired` | int | how many times its action committed |
/// | `last_error` | string | why its last evaluation or action failed (empty if none) |
/// | `origin` | string | the module that sent it (empty if loaded locally) |
/// | `text` | string | its source text |
pub fn plan_class() -> ClassDef {
    let field = |name: &str, ty: ValueType, default: crate::Value| {
        AttrDecl::new(name, ty).default_value(default).guarded()
    };
    ClassDef::new(PLAN_CLASS)
        .attr(field("state", ValueType::Str, "pending".into()))
        .attr(field("fired", ValueType::Int, 0.into()))
        .attr(field("last_error", ValueType::Str, "".into()))
        .attr(field("origin", ValueType::Str, "".into()))
        .attr(field("text", ValueType::Str, "".into()))
}

/// The built-in classes below `Thing`, parents before children.
pub fn builtin_classes() -> [ClassDef; 2] {
    [module_class(), plan_class()]
}

/// Is `name` a built-in class (`Thing` included)?
pub fn is_builtin(name: &str) -> bool {
    name == crate::THING || name == MODULE_CLASS || name == PLAN_CLASS
}
