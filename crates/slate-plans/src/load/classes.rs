//! Classes: a class declaration checked and turned into a `ClassDef`, objects' owners and
//! initial values checked, and the constant expressions those need.

use std::sync::Arc;

use slate_model::{AttrDecl, Board, ClassDef, MergePolicy, ReportPolicy, Value};

use crate::action::Write;
use crate::ast::{AttributeDecl, ClassDecl, Expr, ObjectDecl, PacketExpr};
use crate::check::{Checker, Locals};
use crate::eval::{CompiledExpr, Ctx, Env};

pub(super) fn class_def(
    ck: &mut Checker<'_>,
    class: &ClassDecl,
    board: &Board,
) -> Option<ClassDef> {
    let parent = class
        .parent
        .as_ref()
        .map_or(slate_model::THING, |p| p.name.as_str());
    if !ck.scope.classes.contains_key(parent) {
        let span = class.parent.as_ref().map_or(class.name.span, |p| p.span);
        ck.error(span, format!("unknown parent class {parent}"));
        return None;
    }
    let mut def = ClassDef::new(&class.name.name).parent(parent);
    for a in &class.attributes {
        def = def.attr(attr_decl(ck, a));
    }
    // The same definition again is fine; a new one must not take a built-in's name.
    let accepted = match board.class_def(&def.name) {
        Some(existing) => existing == def,
        None => !slate_model::is_builtin(&def.name),
    };
    if accepted {
        return Some(def);
    }
    let message = if slate_model::is_builtin(&def.name) {
        format!(
            "{} is a built-in class (every board has it, as the language docs list); \
             choose another name",
            def.name
        )
    } else {
        format!(
            "class {} is already defined differently on this board",
            def.name
        )
    };
    ck.error(class.name.span, message);
    None
}

fn attr_decl(ck: &mut Checker<'_>, a: &AttributeDecl) -> AttrDecl {
    let ty = match a.ty.ty {
        crate::ast::Type::Int => slate_model::ValueType::Int,
        crate::ast::Type::Real => slate_model::ValueType::Real,
        crate::ast::Type::Bool => slate_model::ValueType::Bool,
        crate::ast::Type::String => slate_model::ValueType::Str,
        crate::ast::Type::Ref => slate_model::ValueType::Ref,
        crate::ast::Type::Vec(n) => {
            slate_model::ValueType::Vector(u16::try_from(n).unwrap_or(u16::MAX))
        }
    };
    let mut d = AttrDecl::new(&a.name.name, ty);
    d.unit = a.unit.as_ref().map(|u| u.text.clone());
    if let Some(b) = &a.bounds {
        d.bounds = constant(ck, &b.min)
            .zip(constant(ck, &b.max))
            .and_then(|(lo, hi)| lo.as_f64().zip(hi.as_f64()));
    }
    d.resolution = a
        .step
        .as_ref()
        .and_then(|s| constant(ck, s))
        .and_then(|v| v.as_f64());
    if let Some(p) = &a.default {
        let value = constant(ck, &p.value)
            .map(|v| coerce(v, ty))
            .unwrap_or(Value::None);
        let acc = p
            .accuracy
            .as_ref()
            .and_then(|e| constant(ck, e))
            .and_then(|v| v.as_f64())
            .unwrap_or(0.0);
        let conf = p
            .confidence
            .as_ref()
            .and_then(|e| constant(ck, e))
            .and_then(|v| v.as_f64())
            .unwrap_or(1.0);
        if value.value_type() == Some(ty) {
            // `d` has no default yet: the packet is checked against bounds alone.
            check_packet(ck, &d, p, &value, Some(acc), Some(conf));
        } else {
            ck.error(
                p.value.span,
                format!(
                    "the default of {} must be a constant of type {ty}",
                    a.name.name
                ),
            );
        }
        d = d.default_packet(value, acc, conf);
    }
    if let Some(m) = &a.merge {
        match m.name.parse::<MergePolicy>() {
            Ok(policy) => d.merge = policy,
            Err(e) => ck.error(m.span, e),
        }
    }
    d.report = a
        .report
        .as_ref()
        .map(|r| report_policy(ck, r))
        .unwrap_or_default();
    d
}

pub(super) fn report_policy(
    ck: &mut Checker<'_>,
    r: &crate::ast::ReportPolicyDecl,
) -> ReportPolicy {
    let mut secs = |e: &Option<Expr>| {
        e.as_ref()
            .and_then(|e| constant(ck, e))
            .and_then(|v| v.as_f64())
            // At most some 127 years, so a `1e30s` is no `Duration` overflow.
            .map(|s| std::time::Duration::try_from_secs_f64(s.clamp(0.0, 4e9)).unwrap_or_default())
    };
    ReportPolicy {
        min_interval: secs(&r.every),
        heartbeat: secs(&r.heartbeat),
        deadband: r
            .deadband
            .as_ref()
            .and_then(|e| constant(ck, e))
            .and_then(|v| v.as_f64()),
        on_accuracy: r.on_accuracy.is_some(),
    }
}

/// An object's owner must be a valid address.
pub(super) fn check_owner(ck: &mut Checker<'_>, o: &ObjectDecl) {
    if let Some(owner) = &o.owner
        && let Err(e) = owner.value.parse::<slate_model::Address>()
    {
        ck.error(owner.span, e.to_string());
    }
}

/// Checks an object's initial value against its declaration when it is a constant (a
/// value computed from the board is checked when it is written, and a failure there
/// takes the whole load back).
pub(super) fn check_initial(ck: &mut Checker<'_>, class: &str, packet: &PacketExpr, w: &Write) {
    let Some(decl) = ck.scope.attr(class, &w.attr).map(|a| a.decl.clone()) else {
        return;
    };
    let Some(value) = constant_value(&w.value) else {
        return;
    };
    let value = if w.real {
        coerce(value, slate_model::ValueType::Real)
    } else {
        value
    };
    let quality = |n: &Option<CompiledExpr>| n.as_ref().and_then(constant_value)?.as_f64();
    check_packet(
        ck,
        &decl,
        packet,
        &value,
        quality(&w.accuracy),
        quality(&w.confidence),
    );
}

/// Reports a value, accuracy or confidence that `decl` refuses, each at its expression.
fn check_packet(
    ck: &mut Checker<'_>,
    decl: &AttrDecl,
    packet: &PacketExpr,
    value: &Value,
    accuracy: Option<f64>,
    confidence: Option<f64>,
) {
    if let Err(e) = decl.check_value(value) {
        ck.error(packet.value.span, format!("{}: {e}", decl.name));
    }
    for (q, expr, acc) in [
        (accuracy, &packet.accuracy, true),
        (confidence, &packet.confidence, false),
    ] {
        let (Some(q), Some(expr)) = (q, expr) else {
            continue;
        };
        let checked = if acc {
            decl.check_quality(Some(q), None)
        } else {
            decl.check_quality(None, Some(q))
        };
        if let Err(e) = checked {
            ck.error(expr.span, format!("{}: {e}", decl.name));
        }
    }
}

/// The value of a constant expression; `None` if it reads the world or fails.
fn constant_value(node: &CompiledExpr) -> Option<Value> {
    is_constant(node)
        .then(|| node.eval(&mut Ctx::new(&NoWorld, 0, &[])).ok())
        .flatten()
}

pub(super) fn coerce(v: Value, ty: slate_model::ValueType) -> Value {
    match (v, ty) {
        (Value::Int(i), slate_model::ValueType::Real) => Value::Real(i as f64),
        (v, _) => v,
    }
}

/// Evaluates a constant expression (no names, no time); reports one that is not.
pub(super) fn constant(ck: &mut Checker<'_>, e: &Expr) -> Option<Value> {
    let (node, _) = ck.expr(e, &mut Locals::default());
    if !is_constant(&node) {
        ck.error(
            e.span,
            "this must be a constant (no names, attributes or time)",
        );
        return None;
    }
    node.eval(&mut Ctx::new(&NoWorld, 0, &[])).ok()
}

fn is_constant(node: &CompiledExpr) -> bool {
    use crate::eval::Builtin;
    match node {
        CompiledExpr::Attr(_) | CompiledExpr::Token(_) | CompiledExpr::Quant(_) => false,
        CompiledExpr::Call(
            Builtin::Age | Builtin::Now | Builtin::Changed(_) | Builtin::Exists,
            _,
        ) => false,
        n => n.children().iter().all(|c| is_constant(c)),
    }
}

struct NoWorld;

impl Env for NoWorld {
    fn read(&self, _: &str, _: &str) -> Option<slate_model::Packet> {
        None
    }
    fn instances(&self, _: &str) -> Vec<Arc<str>> {
        Vec::new()
    }
    fn exists(&self, _: &str) -> bool {
        false
    }
    fn now(&self) -> std::time::Duration {
        std::time::Duration::ZERO
    }
}
