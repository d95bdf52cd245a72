//! The checker: resolves names, checks types, arities and quantifiers, and compiles
//! expressions and actions into evaluator nodes. Every error becomes a diagnostic with the
//! span it is about; checking goes on after an error so that all of them are reported.

use std::sync::Arc;

use slate_model::{Address, Value, ValueType};

use crate::action::{Act, Write};
use crate::ast::{
    Action, ActionKind, BinaryOp, Expr, ExprKind, Ident, Literal, Path, PlanRef, Quantifier,
    QuantifierKind, UnaryOp,
};
use crate::diagnostic::{Diagnostic, Span, Stage};
use crate::eval::{Arith, Builtin, Cmp, CompiledExpr, Field, KeyCache, Obj, Quant, QuantKind};
use crate::scope::Scope;

/// The static type of an expression. `Unknown` follows an error (and checks nothing more).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Ty {
    Int,
    Real,
    Bool,
    Str,
    Ref,
    Vec(u16),
    None,
    Unknown,
}

impl Ty {
    pub fn of(t: ValueType) -> Ty {
        match t {
            ValueType::Int => Ty::Int,
            ValueType::Real => Ty::Real,
            ValueType::Bool => Ty::Bool,
            ValueType::Str => Ty::Str,
            ValueType::Ref => Ty::Ref,
            ValueType::Vector(n) => Ty::Vec(n),
        }
    }

    fn is_num(self) -> bool {
        matches!(self, Ty::Int | Ty::Real | Ty::Unknown)
    }

    fn name(self) -> String {
        match self {
            Ty::Int => "int".into(),
            Ty::Real => "real".into(),
            Ty::Bool => "bool".into(),
            Ty::Str => "string".into(),
            Ty::Ref => "ref".into(),
            Ty::Vec(n) => format!("vec<{n}>"),
            Ty::None => "none".into(),
            Ty::Unknown => "unknown".into(),
        }
    }

    /// Can a value of this type be written to an attribute of type `to`?
    /// (Integers are written to real attributes as reals.)
    pub fn fits(self, to: ValueType) -> bool {
        let t = Ty::of(to);
        self == t || matches!(self, Ty::Unknown | Ty::None) || (self == Ty::Int && t == Ty::Real)
    }
}

/// Names visible inside one expression or plan.
#[derive(Clone, Debug, Default)]
pub(crate) struct Locals {
    /// Quantifier variables in scope: name, slot, class.
    pub vars: Vec<(String, usize, Arc<str>)>,
    /// `self`'s class, inside class rules and derived attributes.
    pub this: Option<String>,
    /// Slots used (each quantifier gets its own).
    pub slots: usize,
    /// The class of each slot.
    pub slot_classes: Vec<Arc<str>>,
    /// `changed()` call sites.
    pub changed_sites: usize,
    /// Variables `any` binds for the action: name, slot, class.
    pub bound: Vec<(String, usize, Arc<str>)>,
}

pub(crate) struct Checker<'s> {
    pub scope: &'s Scope,
    pub diags: Vec<Diagnostic>,
}

/// The object a path starts from, and its class if known.
struct Base {
    obj: Obj,
    class: Option<String>,
}

impl<'s> Checker<'s> {
    pub fn new(scope: &'s Scope) -> Self {
        Checker {
            scope,
            diags: Vec::new(),
        }
    }

    pub fn error(&mut self, span: Span, msg: impl Into<String>) {
        self.diags.push(Diagnostic::error(Stage::Check, span, msg));
    }

    /// Compiles a condition: it must be a boolean.
    pub fn condition(&mut self, e: &Expr, l: &mut Locals) -> CompiledExpr {
        let (node, ty) = self.expr(e, l);
        if !matches!(ty, Ty::Bool | Ty::Unknown) {
            self.error(
                e.span,
                format!(
                    "a condition must be true or false, but this is {}",
                    ty.name()
                ),
            );
        }
        node
    }

    /// Compiles an expression that must be a number (durations are seconds).
    pub fn number(&mut self, e: &Expr, l: &mut Locals) -> CompiledExpr {
        let (node, ty) = self.expr(e, l);
        if !ty.is_num() {
            self.error(e.span, format!("expected a number, found {}", ty.name()));
        }
        node
    }

    pub fn expr(&mut self, e: &Expr, l: &mut Locals) -> (CompiledExpr, Ty) {
        match &e.kind {
            ExprKind::Literal(lit) => literal(lit),
            ExprKind::Vector(items) => self.vector(items, l),
            ExprKind::Name(_) | ExprKind::Field(..) => self.path_expr(e, l),
            ExprKind::Call(f, args) => self.call(f, args, e.span, l),
            ExprKind::Unary(op, inner) => self.unary(*op, inner, l),
            ExprKind::Binary(op, a, b) => self.binary(*op, a, b, e.span, l),
            ExprKind::Quantifier(q) => self.quantifier(q, l),
        }
    }

    fn vector(&mut self, items: &[Expr], l: &mut Locals) -> (CompiledExpr, Ty) {
        let nodes = items.iter().map(|i| self.number(i, l)).collect::<Vec<_>>();
        let n = u16::try_from(nodes.len()).unwrap_or(u16::MAX);
        (CompiledExpr::Vector(nodes), Ty::Vec(n))
    }

    fn unary(&mut self, op: UnaryOp, inner: &Expr, l: &mut Locals) -> (CompiledExpr, Ty) {
        let (node, ty) = self.expr(inner, l);
        match op {
            UnaryOp::Not => {
                if !matches!(ty, Ty::Bool | Ty::Unknown) {
                    self.error(
                        inner.span,
                        format!("`not` needs true or false, found {}", ty.name()),
                    );
                }
                (CompiledExpr::Not(Box::new(node)), Ty::Bool)
            }
            UnaryOp::Neg => {
                if !(ty.is_num() || matches!(ty, Ty::Vec(_))) {
                    self.error(inner.span, format!("cannot negate {}", ty.name()));
                }
                (CompiledExpr::Neg(Box::new(node)), ty)
            }
        }
    }

    fn binary(
        &mut self,
        op: BinaryOp,
        a: &Expr,
        b: &Expr,
        span: Span,
        l: &mut Locals,
    ) -> (CompiledExpr, Ty) {
        let (na, ta) = self.expr(a, l);
        let (nb, tb) = self.expr(b, l);
        let pair = Box::new((na, nb));
        match op {
            BinaryOp::And | BinaryOp::Or => {
                for (t, e) in [(ta, a), (tb, b)] {
                    if !matches!(t, Ty::Bool | Ty::Unknown) {
                        self.error(
                            e.span,
                            format!("`{}` needs true or false, found {}", op.as_str(), t.name()),
                        );
                    }
                }
                (
                    if op == BinaryOp::And {
                        CompiledExpr::And(pair)
                    } else {
                        CompiledExpr::Or(pair)
                    },
                    Ty::Bool,
                )
            }
            BinaryOp::Eq | BinaryOp::Ne => {
                if !comparable(ta, tb) {
                    self.error(
                        span,
                        format!("cannot compare {} with {}", ta.name(), tb.name()),
                    );
                }
                (
                    CompiledExpr::Cmp(if op == BinaryOp::Eq { Cmp::Eq } else { Cmp::Ne }, pair),
                    Ty::Bool,
                )
            }
            BinaryOp::Lt | BinaryOp::Le | BinaryOp::Gt | BinaryOp::Ge => {
                let ordered = (ta.is_num() && tb.is_num()) || (ta == Ty::Str && tb == Ty::Str);
                if !ordered {
                    self.error(
                        span,
                        format!(
                            "`{}` needs two numbers (or two strings), found {} and {}",
                            op.as_str(),
                            ta.name(),
                            tb.name()
                        ),
                    );
                }
                (CompiledExpr::Cmp(cmp_op(op), pair), Ty::Bool)
            }
            _ => {
                let ty = arith_type(op, ta, tb);
                if ty.is_none() {
                    self.error(
                        span,
                        format!(
                            "cannot apply `{}` to {} and {}",
                            op.as_str(),
                            ta.name(),
                            tb.name()
                        ),
                    );
                }
                (
                    CompiledExpr::Arith(arith_op(op), pair),
                    ty.unwrap_or(Ty::Unknown),
                )
            }
        }
    }

    fn quantifier(&mut self, q: &Quantifier, l: &mut Locals) -> (CompiledExpr, Ty) {
        if !self.scope.classes.contains_key(&q.class.name) {
            self.error(q.class.span, format!("unknown class {}", q.class.name));
        }
        if self.is_name_taken(&q.var.name, l) {
            self.error(
                q.var.span,
                format!(
                    "{} is already a name here; choose another variable name",
                    q.var.name
                ),
            );
        }
        let slot = l.slots;
        l.slots += 1;
        let class: Arc<str> = q.class.name.as_str().into();
        l.slot_classes.push(class.clone());
        l.vars.push((q.var.name.clone(), slot, class.clone()));
        let filter = q.filter.as_ref().map(|f| self.condition(f, l));
        let order = q.order.as_ref().map(|o| {
            let (key, ty) = self.expr(&o.key, l);
            if !(ty.is_num() || ty == Ty::Str) {
                self.error(
                    o.key.span,
                    format!(
                        "`by` needs a number or a string to sort on, found {}",
                        ty.name()
                    ),
                );
            }
            (key, o.descending)
        });
        l.vars.pop();
        let (kind, ty) = match q.kind {
            QuantifierKind::Any => (QuantKind::Any, Ty::Bool),
            QuantifierKind::All => (QuantKind::All, Ty::Bool),
            QuantifierKind::Count => (QuantKind::Count, Ty::Int),
        };
        if kind == QuantKind::Any {
            l.bound.push((q.var.name.clone(), slot, class.clone()));
        } else if order.is_some() {
            self.error(
                q.var.span,
                "`by` only makes sense with `any`, which binds one object",
            );
        }
        (
            CompiledExpr::Quant(Box::new(Quant {
                kind,
                slot,
                class,
                filter,
                order,
            })),
            ty,
        )
    }

    fn is_name_taken(&self, name: &str, l: &Locals) -> bool {
        l.vars.iter().any(|v| v.0 == name)
            || self.scope.objects.contains_key(name)
            || self.scope.classes.contains_key(name)
    }

    fn call(&mut self, f: &Ident, args: &[Expr], span: Span, l: &mut Locals) -> (CompiledExpr, Ty) {
        let Some((builtin, arity)) = builtin(&f.name) else {
            self.error(
                f.span,
                format!("unknown function {}(); known: {}", f.name, BUILTIN_NAMES),
            );
            return (CompiledExpr::Const(Value::None), Ty::Unknown);
        };
        if !arity.contains(&args.len()) {
            let want = if arity.start() == arity.end() {
                arity.start().to_string()
            } else {
                format!("{} or more", arity.start())
            };
            self.error(
                span,
                format!("{}() takes {want} argument(s), got {}", f.name, args.len()),
            );
            return (CompiledExpr::Const(Value::None), Ty::Unknown);
        }
        match builtin {
            Builtin::Age => self.age(args, l),
            Builtin::Changed(_) => self.changed(args, l),
            _ => self.math_call(builtin, &f.name, args, l),
        }
    }

    fn age(&mut self, args: &[Expr], l: &mut Locals) -> (CompiledExpr, Ty) {
        let (node, _) = self.expr(&args[0], l);
        if !matches!(&node, CompiledExpr::Attr(a) if a.2 == Field::Value) {
            self.error(
                args[0].span,
                "age() takes an attribute, like age(gsr.position)",
            );
        }
        (CompiledExpr::Call(Builtin::Age, vec![node]), Ty::Real)
    }

    fn changed(&mut self, args: &[Expr], l: &mut Locals) -> (CompiledExpr, Ty) {
        let (node, _) = self.expr(&args[0], l);
        if !matches!(&node, CompiledExpr::Attr(_)) {
            self.error(
                args[0].span,
                "changed() takes an attribute, like changed(gsr.position, 0.5)",
            );
        }
        let deadband = args
            .get(1)
            .map(|d| self.number(d, l))
            .unwrap_or(CompiledExpr::Const(Value::Real(0.0)));
        let site = l.changed_sites;
        l.changed_sites += 1;
        (
            CompiledExpr::Call(Builtin::Changed(site), vec![node, deadband]),
            Ty::Bool,
        )
    }

    fn math_call(
        &mut self,
        f: Builtin,
        name: &str,
        args: &[Expr],
        l: &mut Locals,
    ) -> (CompiledExpr, Ty) {
        let compiled: Vec<(CompiledExpr, Ty)> = args.iter().map(|a| self.expr(a, l)).collect();
        let tys: Vec<Ty> = compiled.iter().map(|c| c.1).collect();
        let result = call_type(f, &tys);
        if result.is_none() {
            let found = tys.iter().map(|t| t.name()).collect::<Vec<_>>().join(", ");
            self.error(
                args.first().map_or(Span::default(), |a| a.span),
                format!("{name}() cannot take ({found})"),
            );
        }
        (
            CompiledExpr::Call(f, compiled.into_iter().map(|c| c.0).collect()),
            result.unwrap_or(Ty::Unknown),
        )
    }

    // ----- paths -----

    fn path_expr(&mut self, e: &Expr, l: &mut Locals) -> (CompiledExpr, Ty) {
        match flatten(e) {
            Some((root, fields)) => self.resolve(root, &fields, l),
            None => {
                self.error(e.span, "expected a name or an attribute path");
                (CompiledExpr::Const(Value::None), Ty::Unknown)
            }
        }
    }

    /// Compiles a path given as root name and fields.
    pub fn path(&mut self, p: &Path, l: &mut Locals) -> (CompiledExpr, Ty) {
        let fields: Vec<&Ident> = p.fields.iter().collect();
        self.resolve(&p.root, &fields, l)
    }

    fn base(&mut self, root: &Ident, l: &Locals) -> Option<Base> {
        if root.name == "self" {
            let Some(class) = l.this.clone() else {
                self.error(
                    root.span,
                    "`self` only exists in a class's rules and derived attributes",
                );
                return None;
            };
            return Some(Base {
                obj: Obj::This,
                class: Some(class),
            });
        }
        if let Some((_, slot, class)) = l
            .vars
            .iter()
            .rev()
            .chain(l.bound.iter().rev())
            .find(|v| v.0 == root.name)
        {
            return Some(Base {
                obj: Obj::Var(*slot),
                class: Some(class.to_string()),
            });
        }
        let class = self.scope.objects.get(&root.name).cloned().or_else(|| {
            self.scope
                .classes
                .contains_key(&root.name)
                .then(|| root.name.clone())
        });
        match class {
            Some(class) => Some(Base {
                obj: Obj::Named(root.name.as_str().into()),
                class: Some(class),
            }),
            None => {
                self.error(
                    root.span,
                    format!(
                        "unknown name {}: not an object, a class or a variable here",
                        root.name
                    ),
                );
                None
            }
        }
    }

    fn resolve(&mut self, root: &Ident, fields: &[&Ident], l: &mut Locals) -> (CompiledExpr, Ty) {
        let unknown = (CompiledExpr::Const(Value::None), Ty::Unknown);
        let Some(mut base) = self.base(root, l) else {
            return unknown;
        };
        let mut i = 0;
        loop {
            let Some(f) = fields.get(i) else {
                return (CompiledExpr::Token(base.obj), Ty::Ref);
            };
            let Some(ty) = self.attr_type(&base, f) else {
                return unknown;
            };
            let attr = CompiledExpr::Attr(Box::new((
                base.obj,
                f.name.as_str().into(),
                Field::Value,
                KeyCache::default(),
            )));
            let Some(next) = fields.get(i + 1) else {
                return (attr, ty);
            };
            if let Some((field, fty)) = packet_field(&next.name) {
                if let Some(extra) = fields.get(i + 2) {
                    self.error(extra.span, format!("nothing follows .{}", next.name));
                }
                let CompiledExpr::Attr(mut a) = attr else {
                    return unknown;
                };
                a.2 = field;
                return (CompiledExpr::Attr(a), fty);
            }
            if ty != Ty::Ref {
                self.error(
                    next.span,
                    format!(
                        "{} is a {}, not a reference to an object",
                        f.name,
                        ty.name()
                    ),
                );
                return unknown;
            }
            base = Base {
                obj: Obj::Deref(Box::new(attr)),
                class: None,
            };
            i += 1;
        }
    }

    fn attr_type(&mut self, base: &Base, f: &Ident) -> Option<Ty> {
        match &base.class {
            Some(class) => match self.scope.attr(class, &f.name) {
                Some(a) => Some(Ty::of(a.decl.ty)),
                None => {
                    self.error(f.span, format!("class {class} has no attribute {}", f.name));
                    None
                }
            },
            None => match self.scope.attr_anywhere(&f.name) {
                Ok(t) => Some(Ty::of(t)),
                Err(msg) => {
                    self.error(f.span, msg);
                    None
                }
            },
        }
    }

    // ----- actions -----

    /// Compiles actions; `in_plan` allows create and delete (rules may only set, report
    /// and send, so that their writes stay inside the active-function chain limits).
    pub fn actions(
        &mut self,
        actions: &[Action],
        l: &mut Locals,
        source: &str,
        in_plan: bool,
    ) -> Vec<Act> {
        actions
            .iter()
            .filter_map(|a| self.action(a, l, source, in_plan))
            .collect()
    }

    fn action(&mut self, a: &Action, l: &mut Locals, source: &str, in_plan: bool) -> Option<Act> {
        match &a.kind {
            ActionKind::Set(assignments) => {
                let writes = assignments
                    .iter()
                    .filter_map(|s| self.assignment(&s.target, &s.packet, l))
                    .collect();
                Some(Act::Set(writes))
            }
            ActionKind::Report { targets, to } => {
                let to = to.as_ref().and_then(|t| self.address(&t.value, t.span));
                let targets = targets
                    .iter()
                    .filter_map(|t| self.report_target(t, l))
                    .collect();
                Some(Act::Report { targets, to })
            }
            ActionKind::Send { plan, to } => self.send(plan, to.value.as_str(), to.span, source),
            ActionKind::Create {
                class,
                name,
                context,
                values,
            } if in_plan => self.create(class, name, context.map(|c| c.context), values, l),
            ActionKind::Delete(e) if in_plan => {
                let (node, ty) = self.expr(e, l);
                if !matches!(ty, Ty::Ref | Ty::Unknown) {
                    self.error(
                        e.span,
                        format!("delete needs an object, found {}", ty.name()),
                    );
                }
                Some(Act::Delete(node))
            }
            _ => {
                self.error(
                    a.span,
                    "create and delete are allowed in plans, not in `on write` rules",
                );
                None
            }
        }
    }

    pub fn assignment(
        &mut self,
        target: &Path,
        packet: &crate::ast::PacketExpr,
        l: &mut Locals,
    ) -> Option<Write> {
        let Some((last, prefix)) = target.fields.split_last() else {
            self.error(target.span, "set needs an attribute, like gsr.speed");
            return None;
        };
        let before = self.diags.len();
        let obj = match self.resolve(&target.root, &prefix.iter().collect::<Vec<_>>(), l) {
            (CompiledExpr::Token(obj), _) => obj,
            (node @ CompiledExpr::Attr(_), Ty::Ref) => Obj::Deref(Box::new(node)),
            _ => {
                if self.diags.len() == before {
                    self.error(
                        target.span,
                        "set needs an object's attribute, like gsr.speed",
                    );
                }
                return None;
            }
        };
        let base = Base {
            class: self.class_of(&obj, l),
            obj,
        };
        let ty = self.attr_type(&base, last)?;
        self.refuse_guarded(base.class.as_deref(), &last.name, target.span);
        let (value, vty) = self.expr(&packet.value, l);
        let target_ty = value_type(ty);
        if let Some(t) = target_ty
            && !vty.fits(t)
        {
            self.error(
                packet.value.span,
                format!(
                    "{}.{} is {}, but this value is {}",
                    target.root.name,
                    last.name,
                    ty.name(),
                    vty.name()
                ),
            );
        }
        let accuracy = packet.accuracy.as_ref().map(|e| self.number(e, l));
        let confidence = packet.confidence.as_ref().map(|e| self.number(e, l));
        Some(Write {
            obj: base.obj,
            attr: last.name.as_str().into(),
            value,
            accuracy,
            confidence,
            real: ty == Ty::Real,
            cache: KeyCache::default(),
        })
    }

    /// A guarded attribute (a `Plan`'s fields) is written by its machinery only: a write
    /// to one in a file is an error here rather than a failure at run time.
    fn refuse_guarded(&mut self, class: Option<&str>, attr: &str, span: Span) {
        let guarded = class
            .and_then(|c| self.scope.attr(c, attr))
            .is_some_and(|a| a.decl.guarded);
        if guarded {
            let class = class.unwrap_or_default();
            self.error(
                span,
                format!(
                    "{class}.{attr} is written only by the plan engine; a plan is cancelled \
                     through the engine (`slate plan cancel`), never by a write"
                ),
            );
        }
    }

    fn class_of(&self, obj: &Obj, l: &Locals) -> Option<String> {
        match obj {
            Obj::Named(n) => self
                .scope
                .objects
                .get(&**n)
                .cloned()
                .or_else(|| self.scope.classes.contains_key(&**n).then(|| n.to_string())),
            Obj::Var(slot) => l.slot_classes.get(*slot).map(|c| c.to_string()),
            Obj::This => l.this.clone(),
            Obj::Deref(_) => None,
        }
    }

    fn report_target(&mut self, t: &Path, l: &mut Locals) -> Option<(Obj, Option<Arc<str>>)> {
        match self.path(t, l) {
            (CompiledExpr::Token(obj), _) => Some((obj, None)),
            (CompiledExpr::Attr(a), _) if a.2 == Field::Value => Some((a.0, Some(a.1))),
            (CompiledExpr::Const(_), Ty::Unknown) => None,
            _ => {
                self.error(t.span, "report needs an object or an object's attribute");
                None
            }
        }
    }

    fn send(&mut self, plan: &PlanRef, to: &str, to_span: Span, source: &str) -> Option<Act> {
        let to = self.address(to, to_span)?;
        match plan {
            PlanRef::Inline(decl) => {
                let text = source
                    .get(decl.span.start..decl.span.end)
                    .unwrap_or_default()
                    .to_owned();
                Some(Act::Send {
                    name: decl.name.name.clone(),
                    text: Some(text),
                    to,
                })
            }
            PlanRef::Named(name) => Some(Act::Send {
                name: name.name.clone(),
                text: None,
                to,
            }),
        }
    }

    fn create(
        &mut self,
        class: &Ident,
        name: &Ident,
        context: Option<slate_model::Context>,
        values: &[crate::ast::AttributeValue],
        l: &mut Locals,
    ) -> Option<Act> {
        if !self.scope.classes.contains_key(&class.name) {
            self.error(class.span, format!("unknown class {}", class.name));
            return None;
        }
        let obj = Obj::Named(name.name.as_str().into());
        let mut writes = Vec::new();
        for v in values {
            let base = Base {
                obj: obj.clone(),
                class: Some(class.name.clone()),
            };
            let Some(ty) = self.attr_type(&base, &v.name) else {
                continue;
            };
            self.refuse_guarded(Some(&class.name), &v.name.name, v.name.span);
            let (value, vty) = self.expr(&v.packet.value, l);
            if let Some(t) = value_type(ty)
                && !vty.fits(t)
            {
                self.error(
                    v.packet.value.span,
                    format!(
                        "{} is {}, but this value is {}",
                        v.name.name,
                        ty.name(),
                        vty.name()
                    ),
                );
            }
            let accuracy = v.packet.accuracy.as_ref().map(|e| self.number(e, l));
            let confidence = v.packet.confidence.as_ref().map(|e| self.number(e, l));
            writes.push(Write {
                obj: obj.clone(),
                attr: v.name.name.as_str().into(),
                value,
                accuracy,
                confidence,
                real: ty == Ty::Real,
                cache: KeyCache::default(),
            });
        }
        Some(Act::Create {
            class: class.name.as_str().into(),
            name: name.name.as_str().into(),
            context,
            writes,
        })
    }

    pub fn address(&mut self, text: &str, span: Span) -> Option<Address> {
        match Address::new(text) {
            Ok(a) => Some(a),
            Err(e) => {
                self.error(span, e.to_string());
                None
            }
        }
    }
}

fn value_type(t: Ty) -> Option<ValueType> {
    Some(match t {
        Ty::Int => ValueType::Int,
        Ty::Real => ValueType::Real,
        Ty::Bool => ValueType::Bool,
        Ty::Str => ValueType::Str,
        Ty::Ref => ValueType::Ref,
        Ty::Vec(n) => ValueType::Vector(n),
        Ty::None | Ty::Unknown => return None,
    })
}

/// `a.b.c` as the root name and the fields, or `None` if it is not a plain path.
fn flatten(e: &Expr) -> Option<(&Ident, Vec<&Ident>)> {
    match &e.kind {
        ExprKind::Name(id) => Some((id, Vec::new())),
        ExprKind::Field(base, f) => {
            let (root, mut fields) = flatten(base)?;
            fields.push(f);
            Some((root, fields))
        }
        _ => None,
    }
}

fn packet_field(name: &str) -> Option<(Field, Ty)> {
    Some(match name {
        "value" => (Field::Value, Ty::Unknown),
        "accuracy" => (Field::Accuracy, Ty::Real),
        "confidence" => (Field::Confidence, Ty::Real),
        "timestamp" => (Field::Timestamp, Ty::Real),
        "source" => (Field::Source, Ty::Str),
        _ => return None,
    })
}

fn literal(lit: &Literal) -> (CompiledExpr, Ty) {
    let (v, t) = match lit {
        Literal::Int(i) => (Value::Int(*i), Ty::Int),
        Literal::Real(x) | Literal::Duration(x) => (Value::Real(*x), Ty::Real),
        Literal::Str(s) => (Value::from(s.as_str()), Ty::Str),
        Literal::Bool(b) => (Value::Bool(*b), Ty::Bool),
        Literal::None => (Value::None, Ty::None),
    };
    (CompiledExpr::Const(v), t)
}

fn comparable(a: Ty, b: Ty) -> bool {
    a == b
        || (a.is_num() && b.is_num())
        || matches!(a, Ty::None | Ty::Unknown)
        || matches!(b, Ty::None | Ty::Unknown)
        || matches!((a, b), (Ty::Ref, Ty::Str) | (Ty::Str, Ty::Ref))
}

fn cmp_op(op: BinaryOp) -> Cmp {
    match op {
        BinaryOp::Lt => Cmp::Lt,
        BinaryOp::Le => Cmp::Le,
        BinaryOp::Gt => Cmp::Gt,
        _ => Cmp::Ge,
    }
}

fn arith_op(op: BinaryOp) -> Arith {
    match op {
        BinaryOp::Add => Arith::Add,
        BinaryOp::Sub => Arith::Sub,
        BinaryOp::Mul => Arith::Mul,
        BinaryOp::Div => Arith::Div,
        _ => Arith::Rem,
    }
}

fn arith_type(op: BinaryOp, a: Ty, b: Ty) -> Option<Ty> {
    use Ty::{Int, Real, Unknown, Vec};
    match (a, b) {
        (Unknown, _) | (_, Unknown) => Some(Unknown),
        (Int, Int) => Some(Int),
        (x, y) if x.is_num() && y.is_num() => Some(Real),
        (Vec(n), Vec(m)) if n == m && matches!(op, BinaryOp::Add | BinaryOp::Sub) => Some(Vec(n)),
        (Vec(n), k) if k.is_num() && matches!(op, BinaryOp::Mul | BinaryOp::Div) => Some(Vec(n)),
        (k, Vec(n)) if k.is_num() && op == BinaryOp::Mul => Some(Vec(n)),
        _ => None,
    }
}

const BUILTIN_NAMES: &str =
    "age, now, abs, min, max, sqrt, sin, cos, atan2, distance, norm, polar, at, exists, changed";

fn builtin(name: &str) -> Option<(Builtin, std::ops::RangeInclusive<usize>)> {
    Some(match name {
        "age" => (Builtin::Age, 1..=1),
        "now" => (Builtin::Now, 0..=0),
        "abs" => (Builtin::Abs, 1..=1),
        "min" => (Builtin::Min, 1..=64),
        "max" => (Builtin::Max, 1..=64),
        "sqrt" => (Builtin::Sqrt, 1..=1),
        "sin" => (Builtin::Sin, 1..=1),
        "cos" => (Builtin::Cos, 1..=1),
        "atan2" => (Builtin::Atan2, 2..=2),
        "distance" => (Builtin::Distance, 2..=2),
        "norm" => (Builtin::Norm, 1..=1),
        "polar" => (Builtin::Polar, 2..=2),
        "at" => (Builtin::At, 2..=2),
        "exists" => (Builtin::Exists, 1..=1),
        "changed" => (Builtin::Changed(0), 1..=2),
        _ => return None,
    })
}

/// The result type of a math builtin, or `None` if the arguments do not fit.
fn call_type(f: Builtin, t: &[Ty]) -> Option<Ty> {
    let num = |i: usize| t.get(i).is_some_and(|x| x.is_num());
    let vec = |i: usize| matches!(t.get(i), Some(Ty::Vec(_) | Ty::Unknown));
    match f {
        Builtin::Now => Some(Ty::Real),
        Builtin::Abs if num(0) => Some(t[0]),
        Builtin::Min | Builtin::Max if t.iter().all(|x| x.is_num()) => {
            Some(if t.iter().all(|x| *x == Ty::Int) {
                Ty::Int
            } else {
                Ty::Real
            })
        }
        Builtin::Sqrt | Builtin::Sin | Builtin::Cos if num(0) => Some(Ty::Real),
        Builtin::Atan2 | Builtin::Polar if num(0) && num(1) => Some(if f == Builtin::Polar {
            Ty::Vec(2)
        } else {
            Ty::Real
        }),
        Builtin::Distance if vec(0) && vec(1) => match (t[0], t[1]) {
            (Ty::Vec(a), Ty::Vec(b)) if a != b => None,
            _ => Some(Ty::Real),
        },
        Builtin::Norm if vec(0) => Some(Ty::Real),
        Builtin::At if vec(0) && matches!(t.get(1), Some(Ty::Int | Ty::Unknown)) => Some(Ty::Real),
        Builtin::Exists if matches!(t.first(), Some(Ty::Ref | Ty::Unknown)) => Some(Ty::Bool),
        _ => None,
    }
}
