//! Loading a `.slate` file into a board: check everything first, then define the classes,
//! attach derived attributes and rules, create the objects and install the plans.

use std::collections::{HashMap, HashSet};
use std::sync::{Arc, Weak};

use slate_model::{
    AttrDecl, Board, ClassDef, MergePolicy, NewObject, ReportPolicy, Trigger, Update, Value,
};

use crate::action::Write;
use crate::active::{Derived, Rule};
use crate::ast::{
    ActionKind, ActiveFn as RuleDecl, AttributeDecl, ClassDecl, Expr, File, Item, ObjectDecl,
    PacketExpr, PlanDecl,
};
use crate::check::{Checker, Locals, model_context};
use crate::diagnostic::{Diagnostic, Diagnostics, Span, Stage};
use crate::engine::{CompiledPlan, Dep, Engine, Shared};
use crate::eval::{Ctx, Env, Node, Obj};
use crate::scope::Scope;

/// What loading a file added to the board.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Loaded {
    /// Classes defined (already identical ones included).
    pub classes: Vec<String>,
    /// Objects created.
    pub objects: Vec<String>,
    /// `on write` rules attached.
    pub rules: usize,
    /// Plans installed.
    pub plans: Vec<String>,
}

/// Why a file did not load. Nothing of it was applied.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{rendered}")]
pub struct LoadError {
    /// Every problem found, with its position.
    pub diagnostics: Diagnostics,
    /// The diagnostics rendered as `FILE:LINE:COL: error: ...` with the source line and a caret.
    pub rendered: String,
}

/// A derived attribute or rule, compiled, waiting to be attached.
struct PendingFn {
    span: Span,
    target: String,
    attr: String,
    trigger: Trigger,
    f: slate_model::FnRef,
}

/// Everything a file compiles to.
#[derive(Default)]
struct Compiled {
    classes: Vec<(ClassDef, Span)>,
    fns: Vec<PendingFn>,
    objects: Vec<(ObjectDecl, Vec<(Span, Write)>)>,
    plans: Vec<CompiledPlan>,
    texts: Vec<(String, String)>,
}

/// Derived attributes known to an engine: (declaring class, attribute) → what they read.
pub(crate) type DerivedDeps = HashMap<(String, String), Vec<Dep>>;

impl Engine {
    /// Loads a `.slate` source into the engine's board. Everything is checked before
    /// anything is applied; on error, every diagnostic is returned, rendered against
    /// `file_name` and `source`.
    pub fn load(&self, file_name: &str, source: &str) -> Result<Loaded, LoadError> {
        let fail = |diagnostics: Diagnostics| LoadError {
            rendered: diagnostics.render(file_name, source),
            diagnostics,
        };
        let file = crate::parse(source).map_err(fail)?;
        let board = self.board().ok_or_else(|| {
            fail(Diagnostics(vec![Diagnostic::error(
                Stage::Check,
                Span::default(),
                "the board is gone",
            )]))
        })?;
        let mut derived = self.shared.derived.lock().clone();
        let weak = Arc::downgrade(&self.shared);
        let compiled = compile(&file, source, &board, &weak, &mut derived).map_err(fail)?;
        let loaded = self.apply(compiled, &board).map_err(fail)?;
        *self.shared.derived.lock() = derived;
        Ok(loaded)
    }

    /// Loads files that together form a module, in whatever order they are given: a file
    /// that fails is tried again once another has loaded (it may name what that one
    /// defines), until a round loads nothing more. A failed load applies nothing, so
    /// trying again is safe. The results are in the order of `files`; a file that never
    /// loads keeps the diagnostics of its last try.
    pub fn load_all(&self, files: &[(String, String)]) -> Vec<Result<Loaded, LoadError>> {
        let mut results: Vec<Option<Result<Loaded, LoadError>>> = vec![None; files.len()];
        loop {
            let mut progress = false;
            for (i, (name, source)) in files.iter().enumerate() {
                if matches!(results[i], Some(Ok(_))) {
                    continue;
                }
                let r = self.load(name, source);
                progress |= r.is_ok();
                results[i] = Some(r);
            }
            if !progress || results.iter().all(|r| matches!(r, Some(Ok(_)))) {
                break;
            }
        }
        results.into_iter().flatten().collect()
    }

    /// Applies a checked file. The check leaves little that can fail here (an initial
    /// value computed from the board, a concurrent change); if anything does, what was
    /// applied is taken back, so that a failed load leaves the board as it was.
    fn apply(&self, c: Compiled, board: &Arc<Board>) -> Result<Loaded, Diagnostics> {
        let mut undo = Undo::default();
        match self.apply_or_stop(c, board, &mut undo) {
            Ok(loaded) => Ok(loaded),
            Err(diags) => {
                undo.roll_back(board);
                Err(diags)
            }
        }
    }

    fn apply_or_stop(
        &self,
        c: Compiled,
        board: &Arc<Board>,
        undo: &mut Undo,
    ) -> Result<Loaded, Diagnostics> {
        let mut loaded = Loaded::default();
        free_plan_names(self, board, &c.plans)?;
        for (def, span) in c.classes {
            let new = board.class_def(&def.name).is_none();
            board
                .define(def.clone())
                .map_err(|e| one(span, e.to_string()))?;
            if new {
                undo.classes.push(def.name.clone());
            }
            loaded.classes.push(def.name);
        }
        // Functions on classes first, so that objects get them from their first write;
        // functions on objects once the objects exist.
        let (on_classes, on_objects): (Vec<_>, Vec<_>) = c
            .fns
            .iter()
            .partition(|f| board.class_def(&f.target).is_some());
        attach(board, &on_classes, undo)?;
        loaded.objects = create_objects(board, c.objects, undo)?;
        attach(board, &on_objects, undo)?;
        loaded.rules = c.fns.iter().filter(|f| f.trigger == Trigger::Write).count();
        for (name, text) in &c.texts {
            self.remember_text(name, text);
        }
        // Plan names were found free above: installing does not fail half-way.
        for plan in c.plans {
            let name = plan.name.to_string();
            self.install(plan, board)
                .map_err(|e| one(Span::default(), e))?;
            loaded.plans.push(name);
        }
        Ok(loaded)
    }
}

/// What a load applied so far, to take back if a later step fails.
#[derive(Default)]
struct Undo {
    /// Classes the load defined (not those it found already defined), in order.
    classes: Vec<String>,
    /// Functions attached: target, attribute, trigger, function.
    fns: Vec<(String, String, Trigger, slate_model::FnRef)>,
    /// Objects created.
    objects: Vec<String>,
}

impl Undo {
    /// Takes everything back, newest first: objects, then functions, then classes.
    fn roll_back(self, board: &Board) {
        if !self.objects.is_empty() {
            let mut batch = board.batch();
            for o in &self.objects {
                batch.delete(o);
            }
            let _ = batch.commit();
        }
        for (target, attr, trigger, f) in self.fns.iter().rev() {
            let _ = board.detach(target, attr, *trigger, f);
        }
        for class in self.classes.iter().rev() {
            let _ = board.delete_class(class);
        }
    }
}

/// Fails if a plan's name is taken on the board or by the engine (a concurrent load may
/// have taken it since the check).
fn free_plan_names(
    engine: &Engine,
    board: &Board,
    plans: &[CompiledPlan],
) -> Result<(), Diagnostics> {
    let taken = plans
        .iter()
        .find(|p| board.info(&p.name).is_some() || engine.status(&p.name).is_some());
    match taken {
        Some(p) => Err(one(
            Span::default(),
            format!(
                "{} already exists on this board; plan names must be unique object names",
                p.name
            ),
        )),
        None => Ok(()),
    }
}

fn attach(board: &Board, fns: &[&PendingFn], undo: &mut Undo) -> Result<(), Diagnostics> {
    for f in fns {
        board
            .attach(&f.target, &f.attr, f.trigger, f.f.clone())
            .map_err(|e| one(f.span, e.to_string()))?;
        undo.fns
            .push((f.target.clone(), f.attr.clone(), f.trigger, f.f.clone()));
    }
    Ok(())
}

fn one(span: Span, msg: String) -> Diagnostics {
    Diagnostics(vec![Diagnostic::error(Stage::Check, span, msg)])
}

/// Checks and compiles a whole file against the board's current classes and objects.
fn compile(
    file: &File,
    source: &str,
    board: &Arc<Board>,
    engine: &Weak<Shared>,
    derived: &mut DerivedDeps,
) -> Result<Compiled, Diagnostics> {
    let mut scope = Scope::from_board(board);
    mark_derived(&mut scope, derived);
    let mut out = Compiled::default();
    let mut diags = Vec::new();
    for class in file.classes() {
        let mut ck = Checker::new(&scope);
        let def = class_def(&mut ck, class, board);
        diags.append(&mut ck.diags);
        if let Some(def) = def {
            let names: Vec<String> = class
                .attributes
                .iter()
                .filter(|a| a.derived.is_some())
                .map(|a| a.name.name.clone())
                .collect();
            scope.add_class(&def, &names);
            out.classes.push((def, class.span));
        }
    }
    declare_objects(file, &mut scope, &mut diags);
    let mut ck = Checker::new(&scope);
    let clock = board.clock().clone();
    for class in file.classes() {
        for a in class.attributes.iter().filter(|a| a.derived.is_some()) {
            if let Some((f, deps)) = derived_fn(&mut ck, class, a, &clock) {
                derived.insert((class.name.name.clone(), a.name.name.clone()), deps);
                out.fns.push(f);
            }
        }
    }
    check_derived_cycles(&mut ck, file, derived);
    for item in &file.items {
        compile_item(&mut ck, item, source, board, engine, derived, &mut out);
    }
    diags.append(&mut ck.diags);
    if diags.is_empty() {
        Ok(out)
    } else {
        Err(Diagnostics(diags))
    }
}

fn mark_derived(scope: &mut Scope, derived: &DerivedDeps) {
    for ((class, attr), _) in derived.iter() {
        scope.mark_derived(class, attr);
    }
}

fn compile_item(
    ck: &mut Checker<'_>,
    item: &Item,
    source: &str,
    board: &Arc<Board>,
    engine: &Weak<Shared>,
    derived: &DerivedDeps,
    out: &mut Compiled,
) {
    match item {
        Item::Class(class) => {
            for rule in &class.active_fns {
                out.fns.extend(rule_fn(
                    ck,
                    rule,
                    Some(&class.name.name),
                    source,
                    board,
                    engine,
                ));
            }
        }
        Item::ActiveFn(rule) => out
            .fns
            .extend(rule_fn(ck, rule, None, source, board, engine)),
        Item::Object(o) => {
            check_owner(ck, o);
            let mut writes = Vec::new();
            for v in &o.values {
                let target = crate::ast::Path {
                    root: o.name.clone(),
                    fields: vec![v.name.clone()],
                    span: v.span,
                };
                if let Some(w) = ck.assignment(&target, &v.packet, &mut Locals::default()) {
                    check_initial(ck, &o.class.name, &v.packet, &w);
                    writes.push((v.packet.value.span, w));
                }
            }
            out.objects.push((o.clone(), writes));
        }
        Item::Plan(p) => {
            if let Some(plan) = compile_plan(ck, p, source, derived) {
                out.texts.push((plan.name.to_string(), plan.text.clone()));
                out.plans.push(plan);
            }
        }
    }
}

/// Object names the file creates (declared objects and `create` actions of its plans).
fn declare_objects(file: &File, scope: &mut Scope, diags: &mut Vec<Diagnostic>) {
    for o in file.objects() {
        if !scope.classes.contains_key(&o.class.name) {
            diags.push(Diagnostic::error(
                Stage::Check,
                o.class.span,
                format!("unknown class {}", o.class.name),
            ));
        } else if scope.objects.contains_key(&o.name.name)
            || scope.classes.contains_key(&o.name.name)
        {
            diags.push(Diagnostic::error(
                Stage::Check,
                o.name.span,
                format!("{} already exists", o.name.name),
            ));
        }
        scope
            .objects
            .insert(o.name.name.clone(), o.class.name.clone());
    }
    let mut plans = HashSet::new();
    for p in file.plans() {
        let name = &p.name.name;
        if scope.objects.contains_key(name)
            || scope.classes.contains_key(name)
            || !plans.insert(name)
        {
            diags.push(Diagnostic::error(
                Stage::Check,
                p.name.span,
                format!("{name} already exists; plan names must be unique object names"),
            ));
        }
    }
    for p in file.plans() {
        for a in &p.action {
            if let ActionKind::Create { class, name, .. } = &a.kind {
                scope
                    .objects
                    .entry(name.name.clone())
                    .or_insert_with(|| class.name.clone());
            }
        }
    }
}

// ----- classes -----

fn class_def(ck: &mut Checker<'_>, class: &ClassDecl, board: &Board) -> Option<ClassDef> {
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
    if slate_model::is_builtin(&def.name)
        && board
            .class_def(&def.name)
            .is_none_or(|existing| existing != def)
    {
        ck.error(
            class.name.span,
            format!(
                "{} is a built-in class (every board has it, as the language docs list); \
                 choose another name",
                def.name
            ),
        );
        return None;
    }
    if let Some(existing) = board.class_def(&def.name)
        && existing != def
    {
        ck.error(
            class.name.span,
            format!(
                "class {} is already defined differently on this board",
                def.name
            ),
        );
        return None;
    }
    Some(def)
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
        if value.value_type() != Some(ty) {
            ck.error(
                p.value.span,
                format!(
                    "the default of {} must be a constant of type {ty}",
                    a.name.name
                ),
            );
        }
        if value.value_type() == Some(ty) {
            let mut probe = d.clone();
            probe.default = None;
            check_packet(ck, &probe, p, &value, Some(acc), Some(conf));
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

fn report_policy(ck: &mut Checker<'_>, r: &crate::ast::ReportPolicy) -> ReportPolicy {
    let mut secs = |e: &Option<Expr>| {
        e.as_ref()
            .and_then(|e| constant(ck, e))
            .and_then(|v| v.as_f64())
            .map(|s| std::time::Duration::from_secs_f64(s.max(0.0)))
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
fn check_owner(ck: &mut Checker<'_>, o: &ObjectDecl) {
    if let Some(owner) = &o.owner
        && let Err(e) = owner.value.parse::<slate_model::Address>()
    {
        ck.error(owner.span, e.to_string());
    }
}

/// Checks an object's initial value against its declaration when it is a constant (a
/// value computed from the board is checked when it is written, and a failure there
/// takes the whole load back).
fn check_initial(ck: &mut Checker<'_>, class: &str, packet: &PacketExpr, w: &Write) {
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
    let quality = |n: &Option<Node>| n.as_ref().and_then(constant_value)?.as_f64();
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
fn constant_value(node: &Node) -> Option<Value> {
    is_constant(node)
        .then(|| node.eval(&mut Ctx::new(&NoWorld, 0, &[])).ok())
        .flatten()
}

fn coerce(v: Value, ty: slate_model::ValueType) -> Value {
    match (v, ty) {
        (Value::Int(i), slate_model::ValueType::Real) => Value::Real(i as f64),
        (v, _) => v,
    }
}

/// Evaluates a constant expression (no names, no time); reports one that is not.
fn constant(ck: &mut Checker<'_>, e: &Expr) -> Option<Value> {
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

fn is_constant(node: &Node) -> bool {
    use crate::eval::Builtin;
    match node {
        Node::Attr(_) | Node::Token(_) | Node::Quant(_) => false,
        Node::Call(Builtin::Age | Builtin::Now | Builtin::Changed(_) | Builtin::Exists, _) => false,
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

// ----- derived attributes and rules -----

fn derived_fn(
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
        .map(|i| i.ty)?;
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
fn template_deps(node: &Node, out: &mut Vec<Dep>) {
    match node {
        Node::Attr(a) => match &a.0 {
            Obj::This => out.push(Dep::Object(SELF.into(), a.1.clone())),
            Obj::Named(o) => out.push(Dep::Object(o.clone(), a.1.clone())),
            Obj::Var(_) => {}
            Obj::Deref(inner) => {
                template_deps(inner, out);
                out.push(Dep::Attr(a.1.clone()));
            }
        },
        Node::Quant(q) => {
            out.push(Dep::Members(q.class.clone()));
            node.children().iter().for_each(|c| template_deps(c, out));
        }
        n => n.children().iter().for_each(|c| template_deps(c, out)),
    }
}

const SELF: &str = "self";

fn check_derived_cycles(ck: &mut Checker<'_>, file: &File, derived: &DerivedDeps) {
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

fn rule_fn(
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

// ----- plans -----

pub(crate) fn compile_plan(
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

/// What a plan's conditions read, with derived attributes expanded into what they read.
fn plan_deps(node: &Node, l: &Locals, scope: &Scope, derived: &DerivedDeps, out: &mut Vec<Dep>) {
    match node {
        Node::Attr(a) => {
            let (obj, attr) = (&a.0, &a.1);
            let (dep, class) = match obj {
                Obj::Named(o) => (
                    Dep::Object(o.clone(), attr.clone()),
                    scope
                        .objects
                        .get(&**o)
                        .cloned()
                        .or_else(|| Some(o.to_string())),
                ),
                Obj::Var(slot) => {
                    let class = l
                        .slot_classes
                        .get(*slot)
                        .cloned()
                        .unwrap_or_else(|| "".into());
                    (
                        Dep::Class(class.clone(), attr.clone()),
                        Some(class.to_string()),
                    )
                }
                Obj::Deref(inner) => {
                    plan_deps(inner, l, scope, derived, out);
                    (Dep::Attr(attr.clone()), None)
                }
                Obj::This => return,
            };
            expand_derived(
                &dep,
                class.as_deref(),
                attr,
                scope,
                derived,
                out,
                &mut HashSet::new(),
            );
            out.push(dep);
        }
        Node::Quant(q) => {
            out.push(Dep::Members(q.class.clone()));
            node.children()
                .iter()
                .for_each(|c| plan_deps(c, l, scope, derived, out));
        }
        n => n
            .children()
            .iter()
            .for_each(|c| plan_deps(c, l, scope, derived, out)),
    }
}

/// If `attr` is derived, adds what its expression reads, seen from `dep`'s object.
fn expand_derived(
    dep: &Dep,
    class: Option<&str>,
    attr: &str,
    scope: &Scope,
    derived: &DerivedDeps,
    out: &mut Vec<Dep>,
    seen: &mut HashSet<Dep>,
) {
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
    for d in declaring {
        for t in derived.get(&(d, attr.to_owned())).into_iter().flatten() {
            let concrete = match (t, dep) {
                (Dep::Object(o, x), Dep::Object(obj, _)) if &**o == SELF => {
                    Dep::Object(obj.clone(), x.clone())
                }
                (Dep::Object(o, x), Dep::Class(c, _)) if &**o == SELF => {
                    Dep::Class(c.clone(), x.clone())
                }
                (Dep::Object(o, x), Dep::Attr(_)) if &**o == SELF => Dep::Attr(x.clone()),
                (other, _) => other.clone(),
            };
            // Each dependency is expanded once: derived attributes that read one another
            // (even the same name through references) stay linear, not exponential.
            if !seen.insert(concrete.clone()) {
                continue;
            }
            if let Dep::Object(_, x) | Dep::Class(_, x) | Dep::Attr(x) = &concrete {
                let x = x.clone();
                expand_derived(&concrete, class, &x, scope, derived, out, seen);
            }
            out.push(concrete);
        }
    }
}

// ----- objects -----

/// Creates the objects in one batch, then writes their initial values in another (they
/// may read the objects just created). Every object created is recorded in `undo`; an
/// initial value the board refuses is reported at its expression.
fn create_objects(
    board: &Board,
    objects: Vec<(ObjectDecl, Vec<(Span, Write)>)>,
    undo: &mut Undo,
) -> Result<Vec<String>, Diagnostics> {
    let mut batch = board.batch();
    let mut names = Vec::new();
    for (o, _) in &objects {
        let mut spec = NewObject::new(&o.class.name, &o.name.name);
        if let Some(c) = o.context {
            spec = spec.context(model_context(c.context));
        }
        if let Some(owner) = &o.owner {
            let addr = owner
                .value
                .parse()
                .map_err(|e: slate_model::AddressError| one(owner.span, e.to_string()))?;
            spec = spec.owner(addr);
        }
        batch.create_with(spec);
        names.push(o.name.name.clone());
    }
    batch.commit().map_err(|e| {
        let span = batch_index(&e)
            .and_then(|i| objects.get(i))
            .map(|o| o.0.name.span);
        one(span.unwrap_or_default(), e.to_string())
    })?;
    undo.objects.extend(names.iter().cloned());
    write_initial(board, objects.iter().flat_map(|(_, w)| w.iter()))?;
    Ok(names)
}

/// Writes the initial values in one batch; a failure names the value's position.
fn write_initial<'w>(
    board: &Board,
    writes: impl Iterator<Item = &'w (Span, Write)>,
) -> Result<(), Diagnostics> {
    let mut batch = board.batch();
    let mut spans = Vec::new();
    let snap_env = BoardEnv(board);
    for (span, w) in writes {
        let Obj::Named(obj) = &w.obj else { continue };
        let mut cx = Ctx::new(&snap_env, 0, &[]);
        let value = w
            .value
            .eval(&mut cx)
            .map_err(|e| one(*span, e.to_string()))?;
        let value = if w.real {
            coerce(value, slate_model::ValueType::Real)
        } else {
            value
        };
        let mut quality =
            |n: &Option<Node>| n.as_ref().and_then(|n| n.eval(&mut cx).ok())?.as_f64();
        // Stamped zero, like a declared default: an initial value claims no time, so it
        // loses to any packet the team wrote (a restarted module never rolls it back).
        let mut u = Update::new(value).timestamp(slate_model::Timestamp::ZERO);
        u.accuracy = quality(&w.accuracy);
        u.confidence = quality(&w.confidence);
        batch.write(obj, &w.attr, u);
        spans.push(*span);
    }
    batch.commit().map_err(|e| {
        let span = batch_index(&e).and_then(|i| spans.get(i).copied());
        one(span.unwrap_or_default(), batch_cause(e))
    })?;
    Ok(())
}

/// The operation of a batch that failed.
fn batch_index(e: &slate_model::BatchError) -> Option<usize> {
    match e {
        slate_model::BatchError::Write { index, .. }
        | slate_model::BatchError::Create { index, .. }
        | slate_model::BatchError::Delete { index, .. } => Some(*index),
        _ => None,
    }
}

/// Why a batch failed, without "batch operation N" (the diagnostic's position says which).
fn batch_cause(e: slate_model::BatchError) -> String {
    match e {
        slate_model::BatchError::Write { source, .. } => source.to_string(),
        other => other.to_string(),
    }
}

struct BoardEnv<'a>(&'a Board);

impl Env for BoardEnv<'_> {
    fn read(&self, object: &str, attr: &str) -> Option<slate_model::Packet> {
        self.0.read(object, attr).ok()
    }
    fn instances(&self, class: &str) -> Vec<Arc<str>> {
        self.0
            .instances(class)
            .unwrap_or_default()
            .into_iter()
            .filter_map(|id| self.0.name_of(id))
            .collect()
    }
    fn exists(&self, object: &str) -> bool {
        self.0.info(object).is_some()
    }
    fn now(&self) -> std::time::Duration {
        self.0.clock().physical()
    }
}
