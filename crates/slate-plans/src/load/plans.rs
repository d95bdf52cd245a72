//! Plans: a plan declaration compiled for the engine, and what its conditions read (derived
//! attributes expanded into what they read).

use std::collections::HashSet;

use crate::ast::PlanDecl;
use crate::check::{Checker, Locals};
use crate::engine::{CompiledPlan, Dep};
use crate::eval::CompiledExpr;
use crate::scope::Scope;

use super::DerivedDeps;
use super::classes::constant;
use super::derived::{SELF, reads};

pub(super) fn compile_plan(
    ck: &mut Checker<'_>,
    p: &PlanDecl,
    source: &str,
    derived: &DerivedDeps,
) -> Option<CompiledPlan> {
    let before = ck.diags.len();
    let mut l = Locals::default();
    let initiation = p.initiation.as_ref().map(|e| ck.condition(e, &mut l));
    let termination = p.termination.as_ref().map(|e| ck.condition(e, &mut l));
    l.bound.clear();
    let trigger = p.trigger.as_ref().map(|e| ck.condition(e, &mut l));
    let every = p
        .every
        .as_ref()
        .and_then(|e| constant(ck, e))
        .and_then(|v| v.as_f64());
    if every.is_some_and(|s| s <= 0.0) {
        ck.error(
            p.every.as_ref().map_or(p.span, |e| e.span),
            "`every` needs a positive duration, like every 500ms",
        );
    }
    let actions = ck.actions(&p.action, &mut l, source, true);
    if ck.diags.len() > before {
        return None;
    }
    let mut deps = Vec::new();
    for n in [&initiation, &trigger, &termination].into_iter().flatten() {
        plan_deps(n, &l, ck.scope, derived, &mut deps);
    }
    deps.sort_by(|a, b| format!("{a:?}").cmp(&format!("{b:?}")));
    deps.dedup();
    let text = source
        .get(p.span.start..p.span.end)
        .unwrap_or_default()
        .to_owned();
    Some(CompiledPlan {
        name: p.name.name.as_str().into(),
        initiation,
        trigger,
        termination,
        every,
        actions,
        slots: l.slots,
        changed_sites: l.changed_sites,
        deps,
        text,
    })
}

/// What a plan's conditions read ([`reads`]), with derived attributes expanded into what
/// they read.
fn plan_deps(
    node: &CompiledExpr,
    l: &Locals,
    scope: &Scope,
    derived: &DerivedDeps,
    out: &mut Vec<Dep>,
) {
    let mut direct = Vec::new();
    reads(node, &l.slot_classes, &mut direct);
    let mut seen = HashSet::new();
    for dep in direct {
        expand_derived(&dep, scope, derived, out, &mut seen);
        out.push(dep);
    }
}

/// The class whose attribute `dep` reads, if known: a named object's (or the class's own,
/// for a class-level read), a quantifier's class; none through a reference.
fn dep_class(dep: &Dep, scope: &Scope) -> Option<String> {
    match dep {
        Dep::Object(o, _) => Some(scope.objects.get(&**o).cloned().unwrap_or(o.to_string())),
        Dep::Class(c, _) => Some(c.to_string()),
        Dep::Attr(_) | Dep::Members(_) => None,
    }
}

/// If `dep` reads a derived attribute, adds what its expression reads, seen from `dep`'s
/// object, and so on through the derived attributes it reads (each seen from its own
/// object or class): without recursion (a chain of derived attributes comes from the
/// source, of any length), each dependency once.
fn expand_derived(
    dep: &Dep,
    scope: &Scope,
    derived: &DerivedDeps,
    out: &mut Vec<Dep>,
    seen: &mut HashSet<Dep>,
) {
    let mut work = vec![dep.clone()];
    while let Some(dep) = work.pop() {
        let (Dep::Object(_, attr) | Dep::Class(_, attr) | Dep::Attr(attr)) = &dep else {
            continue;
        };
        let class = dep_class(&dep, scope);
        for concrete in derived_reads(&dep, class.as_deref(), attr, scope, derived) {
            // Each dependency is expanded once: derived attributes that read one another
            // (even the same name through references) stay linear, not exponential.
            if !seen.insert(concrete.clone()) {
                continue;
            }
            work.push(concrete.clone());
            out.push(concrete);
        }
    }
}

/// What derived attribute `attr` reads, seen from `dep`'s object (nothing if `attr` is not
/// derived).
fn derived_reads(
    dep: &Dep,
    class: Option<&str>,
    attr: &str,
    scope: &Scope,
    derived: &DerivedDeps,
) -> Vec<Dep> {
    let declaring: Vec<String> = match class {
        Some(c) => scope
            .attr(c, attr)
            .filter(|a| a.derived)
            .map(|a| vec![a.class.clone()])
            .unwrap_or_default(),
        None => derived
            .keys()
            .filter(|(_, a)| a == attr)
            .map(|(c, _)| c.clone())
            .collect(),
    };
    let reads = declaring
        .into_iter()
        .flat_map(|d| derived.get(&(d, attr.to_owned())).into_iter().flatten());
    reads.map(|t| seen_from(t, dep)).collect()
}

/// Dependency `t` of a derived attribute (written from `self`) made concrete for the
/// object or class that `dep` reads it on.
fn seen_from(t: &Dep, dep: &Dep) -> Dep {
    match (t, dep) {
        (Dep::Object(o, x), Dep::Object(obj, _)) if &**o == SELF => {
            Dep::Object(obj.clone(), x.clone())
        }
        (Dep::Object(o, x), Dep::Class(c, _)) if &**o == SELF => Dep::Class(c.clone(), x.clone()),
        (Dep::Object(o, x), Dep::Attr(_)) if &**o == SELF => Dep::Attr(x.clone()),
        (other, _) => other.clone(),
    }
}
