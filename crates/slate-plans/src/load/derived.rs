//! Derived attributes and `on write` rules: checked, compiled into the language's active
//! functions, and what each reads (for cycles and for the plans that read them).

use std::collections::HashSet;
use std::sync::{Arc, Weak};

use slate_model::{Board, Trigger};

use crate::active::{Derived, Rule};
use crate::ast::{AttributeDecl, ClassDecl, File, RuleDecl};
use crate::check::{Checker, Locals};
use crate::engine::{Dep, Shared};
use crate::eval::{CompiledExpr, Obj};

use super::{DerivedDeps, PendingFn};

pub(super) fn derived_fn(
    ck: &mut Checker<'_>,
    class: &ClassDecl,
    a: &AttributeDecl,
    clock: &slate_model::Clock,
) -> Option<(PendingFn, Vec<Dep>)> {
    let p = a.derived.as_ref()?;
    let mut l = Locals {
        this: Some(class.name.name.clone()),
        ..Locals::default()
    };
    let (value, ty) = ck.expr(&p.value, &mut l);
    let declared = ck
        .scope
        .attr(&class.name.name, &a.name.name)
        .map(|i| i.decl.ty)?;
    if !ty.fits(declared) {
        ck.error(
            p.value.span,
            format!("{} is {declared}, but this computes {ty:?}", a.name.name),
        );
    }
    let accuracy = p.accuracy.as_ref().map(|e| ck.number(e, &mut l));
    let confidence = p.confidence.as_ref().map(|e| ck.number(e, &mut l));
    let mut deps = Vec::new();
    for n in std::iter::once(&value)
        .chain(accuracy.iter())
        .chain(confidence.iter())
    {
        template_deps(n, &mut deps);
    }
    let f = Derived {
        name: format!("{}.{} (derived)", class.name.name, a.name.name),
        value,
        accuracy,
        confidence,
        slots: l.slots,
        real: declared == slate_model::ValueType::Real,
        clock: clock.clone(),
    };
    let pending = PendingFn {
        span: a.name.span,
        target: class.name.name.clone(),
        attr: a.name.name.clone(),
        trigger: Trigger::Read,
        f: Arc::new(f),
    };
    Some((pending, deps))
}

/// What a derived attribute reads: `self.x` becomes `Dep::Object("self", x)`, resolved
/// against the object a plan reads it on.
fn template_deps(node: &CompiledExpr, out: &mut Vec<Dep>) {
    match node {
        CompiledExpr::Attr(a) => match &a.0 {
            Obj::This => out.push(Dep::Object(SELF.into(), a.1.clone())),
            Obj::Named(o) => out.push(Dep::Object(o.clone(), a.1.clone())),
            Obj::Var(_) => {}
            Obj::Deref(inner) => {
                template_deps(inner, out);
                out.push(Dep::Attr(a.1.clone()));
            }
        },
        CompiledExpr::Quant(q) => {
            out.push(Dep::Members(q.class.clone()));
            node.children().iter().for_each(|c| template_deps(c, out));
        }
        n => n.children().iter().for_each(|c| template_deps(c, out)),
    }
}

pub(super) const SELF: &str = "self";

pub(super) fn check_derived_cycles(ck: &mut Checker<'_>, file: &File, derived: &DerivedDeps) {
    for class in file.classes() {
        for a in class.attributes.iter().filter(|a| a.derived.is_some()) {
            let start = (class.name.name.clone(), a.name.name.clone());
            if reaches(&start, &start, derived, &mut HashSet::new()) {
                ck.error(
                    a.name.span,
                    format!("derived attribute {} depends on itself", a.name.name),
                );
            }
        }
    }
}

fn reaches(
    from: &(String, String),
    goal: &(String, String),
    derived: &DerivedDeps,
    seen: &mut HashSet<(String, String)>,
) -> bool {
    let Some(deps) = derived.get(from) else {
        return false;
    };
    deps.iter().any(|d| match d {
        Dep::Object(o, attr) if &**o == SELF => {
            let next = (from.0.clone(), attr.to_string());
            &next == goal || (seen.insert(next.clone()) && reaches(&next, goal, derived, seen))
        }
        _ => false,
    })
}

pub(super) fn rule_fn(
    ck: &mut Checker<'_>,
    rule: &RuleDecl,
    class: Option<&str>,
    source: &str,
    board: &Arc<Board>,
    engine: &Weak<Shared>,
) -> Option<PendingFn> {
    let (target, this) = match (&rule.owner, class) {
        (None, Some(c)) => (c.to_owned(), c.to_owned()),
        (Some(owner), _) => {
            let this = ck.scope.objects.get(&owner.name).cloned().or_else(|| {
                ck.scope
                    .classes
                    .contains_key(&owner.name)
                    .then(|| owner.name.clone())
            });
            let Some(this) = this else {
                ck.error(
                    owner.span,
                    format!("unknown object or class {}", owner.name),
                );
                return None;
            };
            (owner.name.clone(), this)
        }
        (None, None) => return None,
    };
    if ck.scope.attr(&this, &rule.attribute.name).is_none() {
        ck.error(
            rule.attribute.span,
            format!("{target} has no attribute {}", rule.attribute.name),
        );
        return None;
    }
    let mut l = Locals {
        this: Some(this),
        ..Locals::default()
    };
    let acts = ck.actions(&rule.actions, &mut l, source, false);
    let f = Rule {
        name: format!("on write {target}.{}", rule.attribute.name),
        acts,
        slots: l.slots,
        clock: board.clock().clone(),
        engine: engine.clone(),
    };
    Some(PendingFn {
        span: rule.span,
        target,
        attr: rule.attribute.name.clone(),
        trigger: Trigger::Write,
        f: Arc::new(f),
    })
}
