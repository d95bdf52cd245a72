//! Derived attributes and `on write` rules: checked, compiled into the language's active
//! functions, and what each reads (for cycles and for the plans that read them).

use std::collections::HashSet;
use std::sync::{Arc, Weak};

use slate_model::Trigger;

use crate::active::{Derived, Rule};
use crate::ast::{AttributeDecl, ClassDecl, File, RuleDecl};
use crate::check::{Checker, Locals};
use crate::engine::{Dep, Shared};
use crate::eval::{CompiledExpr, Obj};
use crate::parser::MAX_NESTING;

use super::{DerivedDeps, PendingFn};

pub(super) fn derived_fn(
    ck: &mut Checker<'_>,
    class: &ClassDecl,
    a: &AttributeDecl,
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
        reads(n, &l.slot_classes, &mut deps);
    }
    let f = Derived {
        name: format!("{}.{} (derived)", class.name.name, a.name.name),
        value,
        accuracy,
        confidence,
        slots: l.slots,
        real: declared == slate_model::ValueType::Real,
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

/// What an expression reads, as dependencies; the one rule for plans' conditions and
/// derived attributes. `self.x` becomes `Dep::Object("self", x)` (a derived attribute's
/// own object, resolved against the object a plan reads it on), `o.x` `Dep::Object(o, x)`,
/// a quantifier variable's `v.x` `Dep::Class(v's class, x)` (any instance: `slot_classes`
/// gives each slot's class), `e.x` through a reference what `e` reads and `Dep::Attr(x)`
/// (on any object), and a quantifier `Dep::Members` of its class.
pub(super) fn reads(node: &CompiledExpr, slot_classes: &[Arc<str>], out: &mut Vec<Dep>) {
    match node {
        CompiledExpr::Attr(a) => match &a.0 {
            Obj::This => out.push(Dep::Object(SELF.into(), a.1.clone())),
            Obj::Named(o) => out.push(Dep::Object(o.clone(), a.1.clone())),
            Obj::Var(slot) => {
                let class = slot_classes
                    .get(*slot)
                    .cloned()
                    .unwrap_or_else(|| "".into());
                out.push(Dep::Class(class, a.1.clone()));
            }
            Obj::Deref(inner) => {
                reads(inner, slot_classes, out);
                out.push(Dep::Attr(a.1.clone()));
            }
        },
        CompiledExpr::Quant(q) => {
            out.push(Dep::Members(q.class.clone()));
            node.children()
                .iter()
                .for_each(|c| reads(c, slot_classes, out));
        }
        n => n
            .children()
            .iter()
            .for_each(|c| reads(c, slot_classes, out)),
    }
}

pub(super) const SELF: &str = "self";

/// Reports every derived attribute that reads itself through `self.x` reads of derived
/// attributes, and the first of each class whose chain of such reads is more than
/// [`MAX_NESTING`] deep (a long chain is one error, not one per attribute).
pub(super) fn check_derived_cycles(ck: &mut Checker<'_>, file: &File, derived: &DerivedDeps) {
    for class in file.classes() {
        let mut too_deep_reported = false;
        for a in class.attributes.iter().filter(|a| a.derived.is_some()) {
            let start = (class.name.name.clone(), a.name.name.clone());
            match self_reach(&start, derived) {
                Reach::Itself => ck.error(
                    a.name.span,
                    format!("derived attribute {} depends on itself", a.name.name),
                ),
                Reach::TooDeep if !too_deep_reported => {
                    too_deep_reported = true;
                    ck.error(a.name.span, too_deep(&a.name.name));
                }
                Reach::TooDeep | Reach::Fine => {}
            }
        }
    }
}

fn too_deep(attribute: &str) -> String {
    format!(
        "derived attribute {attribute} reads derived attributes of its object more than \
         {MAX_NESTING} deep; make the chain shorter (read the values it needs directly)"
    )
}

/// What following a derived attribute's `self.x` reads through other derived attributes
/// finds.
enum Reach {
    /// The attribute itself: a cycle.
    Itself,
    /// A chain more than [`MAX_NESTING`] attributes deep.
    TooDeep,
    /// Neither.
    Fine,
}

/// Follows the `self.x` reads of derived attribute `start` through the derived attributes
/// of its class, without recursion (the chain comes from the source, of any length) and at
/// most [`MAX_NESTING`] deep, visiting each attribute once.
fn self_reach(start: &(String, String), derived: &DerivedDeps) -> Reach {
    let mut seen = HashSet::new();
    let mut stack = vec![(start.clone(), 1usize)];
    while let Some((from, depth)) = stack.pop() {
        for next in self_reads(&from, derived) {
            if next == *start {
                return Reach::Itself;
            }
            if !derived.contains_key(&next) || !seen.insert(next.clone()) {
                continue;
            }
            if depth >= MAX_NESTING {
                return Reach::TooDeep;
            }
            stack.push((next, depth + 1));
        }
    }
    Reach::Fine
}

/// The attributes of its own object that derived attribute `from` reads (`self.x`).
fn self_reads(from: &(String, String), derived: &DerivedDeps) -> Vec<(String, String)> {
    let deps = derived.get(from).into_iter().flatten();
    deps.filter_map(|d| match d {
        Dep::Object(o, attr) if &**o == SELF => Some((from.0.clone(), attr.to_string())),
        _ => None,
    })
    .collect()
}

pub(super) fn rule_fn(
    ck: &mut Checker<'_>,
    rule: &RuleDecl,
    class: Option<&str>,
    source: &str,
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
