//! Loading a `.slate` file into a board: check everything first, then define the classes,
//! attach derived attributes and rules, create the objects and install the plans.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::sync::{Arc, Weak};

use slate_model::{Board, ClassDef, Trigger};

use crate::action::Write;
use crate::ast::{ActionKind, File, Item, ObjectDecl};
use crate::check::{Checker, Locals};
use crate::diagnostic::{Diagnostic, Diagnostics, Span, Stage};
use crate::engine::{CompiledPlan, Dep, Engine, Shared};
use crate::scope::Scope;

mod classes;
mod derived;
mod links;
mod objects;
mod plans;
mod substitute;

use classes::{check_initial, check_owner, class_def};
use derived::{check_derived_cycles, derived_fn, rule_fn};
pub use links::{LinkExport, LinkName, LinkPolicy, LinkReport};
use objects::create_objects;
use plans::compile_plan;
pub use substitute::{ROBOT_PLACEHOLDER, Substitution, SubstitutionError};

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
    /// Links whose policy the file's `link` blocks changed (the merged policies are
    /// [`Engine::link_policies`]).
    pub links: Vec<LinkName>,
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
    links: BTreeMap<LinkName, LinkPolicy>,
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
        loaded.links = c.links.keys().copied().collect();
        self.merge_links(c.links);
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
    match plans.iter().find_map(|p| engine.name_taken(board, &p.name)) {
        Some(taken) => Err(one(Span::default(), taken)),
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
    for class in file.classes() {
        for a in class.attributes.iter().filter(|a| a.derived.is_some()) {
            if let Some((f, deps)) = derived_fn(&mut ck, class, a) {
                derived.insert((class.name.name.clone(), a.name.name.clone()), deps);
                out.fns.push(f);
            }
        }
    }
    check_derived_cycles(&mut ck, file, derived);
    for item in &file.items {
        compile_item(&mut ck, item, source, engine, derived, &mut out);
    }
    out.links = links::compile_links(&mut ck, file.links());
    diags.append(&mut ck.diags);
    if diags.is_empty() {
        Ok(out)
    } else {
        Err(Diagnostics::at_most_max(diags))
    }
}

fn mark_derived(scope: &mut Scope, derived: &DerivedDeps) {
    scope.mark_derived(
        derived
            .iter()
            .map(|((class, attr), _)| (class.as_ref(), attr.as_ref())),
    );
}

fn compile_item(
    ck: &mut Checker<'_>,
    item: &Item,
    source: &str,
    engine: &Weak<Shared>,
    derived: &DerivedDeps,
    out: &mut Compiled,
) {
    match item {
        Item::Class(class) => {
            for rule in &class.rules {
                out.fns
                    .extend(rule_fn(ck, rule, Some(&class.name.name), source, engine));
            }
        }
        Item::Rule(rule) => out.fns.extend(rule_fn(ck, rule, None, source, engine)),
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
        // Checked together, after every item: blocks of one file merge in source order.
        Item::Link(_) => {}
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
