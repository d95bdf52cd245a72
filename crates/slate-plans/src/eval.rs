//! Compiled expressions: a tree of evaluator nodes with every name resolved by the
//! checker, evaluated against the world through the narrow [`Env`] trait.
//!
//! Missing data is not an error: reading an attribute that was never written, or through a
//! reference to an object that does not exist, gives `none`; arithmetic and comparisons
//! with `none` give `none`; a condition that is `none` is false. Errors are kept for real
//! faults (a type that only shows at run time, division by zero, the operation cap).

use std::sync::Arc;
use std::time::Duration;

use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};

use slate_model::{AttrId, Key, ObjectId, Packet, Value};

/// Most evaluation steps one evaluation may take (a quantifier over 10 000 objects with a
/// small filter takes about 100 000).
pub const MAX_OPS: u64 = 5_000_000;

/// What an expression reads the world through.
pub trait Env {
    /// The packet `object.attr` reads, or `None` if the object or attribute is unknown.
    fn read(&self, object: &str, attr: &str) -> Option<Packet>;
    /// The same, using and refreshing a cached handle (an environment without handles
    /// just reads by name).
    fn read_cached(&self, object: &str, attr: &str, cache: &KeyCache) -> Option<Packet> {
        let _ = cache;
        self.read(object, attr)
    }
    /// The board handle of `object.attr`, if this environment has handles.
    fn key(&self, object: &str, attr: &str, cache: &KeyCache) -> Option<Key> {
        let _ = (object, attr, cache);
        None
    }
    /// Names of the instances of `class` and its subclasses.
    fn instances(&self, class: &str) -> Vec<Arc<str>>;
    /// Does an object or class of that name exist?
    fn exists(&self, object: &str) -> bool;
    /// Physical time now, since the Unix epoch.
    fn now(&self) -> Duration;
}

/// A fault while evaluating.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    /// A value of an unexpected type (only possible through references).
    #[error("{0}")]
    Type(String),
    /// Division or remainder by zero.
    #[error("division by zero")]
    DivisionByZero,
    /// The evaluation took more than [`MAX_OPS`] steps.
    #[error("evaluation stopped after {MAX_OPS} steps")]
    Limit,
}

/// The board handle a named attribute last resolved to, so that evaluations skip the name
/// lookups. A stale handle (the object was deleted) fails its lookup and is resolved again.
#[derive(Debug, Default)]
pub struct KeyCache {
    object: AtomicU64,
    /// Attribute id + 1; 0 means empty.
    attr: AtomicU32,
}

impl KeyCache {
    /// The cached handle, if any.
    pub fn get(&self) -> Option<Key> {
        let attr = self.attr.load(Ordering::Relaxed).checked_sub(1)?;
        let object = ObjectId::from_bits(self.object.load(Ordering::Relaxed));
        Some(Key {
            object,
            attr: AttrId::from_bits(attr),
        })
    }

    /// Remembers a handle.
    pub fn set(&self, key: Key) {
        self.object.store(key.object.to_bits(), Ordering::Relaxed);
        self.attr
            .store(key.attr.to_bits().saturating_add(1), Ordering::Relaxed);
    }
}

impl Clone for KeyCache {
    fn clone(&self) -> Self {
        KeyCache::default()
    }
}

impl PartialEq for KeyCache {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// Packet fields an expression can read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Field {
    Value,
    Accuracy,
    Confidence,
    /// Seconds since the Unix epoch.
    Timestamp,
    Source,
}

/// Whose attribute.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Obj {
    /// An object or class by name.
    Named(Arc<str>),
    /// A quantifier variable (slot in the frame).
    Var(usize),
    /// `self`: the object an active function runs for.
    This,
    /// The object a reference-valued expression names.
    Deref(Box<CompiledExpr>),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Arith {
    Add,
    Sub,
    Mul,
    Div,
    Rem,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Cmp {
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
}

/// Built-in functions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Builtin {
    Age,
    Now,
    Abs,
    Min,
    Max,
    Sqrt,
    Sin,
    Cos,
    Atan2,
    Distance,
    Norm,
    Polar,
    At,
    Exists,
    /// `changed(x, deadband)`; the payload is the call site's index in the plan.
    Changed(usize),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum QuantKind {
    Any,
    All,
    Count,
}

#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Quant {
    pub kind: QuantKind,
    pub slot: usize,
    pub class: Arc<str>,
    pub filter: Option<CompiledExpr>,
    pub order: Option<(CompiledExpr, bool)>,
}

/// An attribute read: whose, which, which packet field, and the cached handle.
pub(crate) type AttrRead = (Obj, Arc<str>, Field, KeyCache);

/// A compiled expression.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum CompiledExpr {
    Const(Value),
    Attr(Box<(Obj, Arc<str>, Field, KeyCache)>),
    /// The object itself, as a reference value.
    Token(Obj),
    Vector(Vec<CompiledExpr>),
    Not(Box<CompiledExpr>),
    Neg(Box<CompiledExpr>),
    And(Box<(CompiledExpr, CompiledExpr)>),
    Or(Box<(CompiledExpr, CompiledExpr)>),
    Arith(Arith, Box<(CompiledExpr, CompiledExpr)>),
    Cmp(Cmp, Box<(CompiledExpr, CompiledExpr)>),
    Call(Builtin, Vec<CompiledExpr>),
    Quant(Box<Quant>),
}

impl CompiledExpr {
    /// The nodes directly below this one.
    pub fn children(&self) -> Vec<&CompiledExpr> {
        match self {
            CompiledExpr::Const(_) => Vec::new(),
            CompiledExpr::Attr(a) => obj_children(&a.0),
            CompiledExpr::Token(o) => obj_children(o),
            CompiledExpr::Vector(items) | CompiledExpr::Call(_, items) => items.iter().collect(),
            CompiledExpr::Not(n) | CompiledExpr::Neg(n) => vec![n],
            CompiledExpr::And(ab)
            | CompiledExpr::Or(ab)
            | CompiledExpr::Arith(_, ab)
            | CompiledExpr::Cmp(_, ab) => {
                vec![&ab.0, &ab.1]
            }
            CompiledExpr::Quant(q) => q
                .filter
                .iter()
                .chain(q.order.as_ref().map(|o| &o.0))
                .collect(),
        }
    }
}

fn obj_children(o: &Obj) -> Vec<&CompiledExpr> {
    match o {
        Obj::Deref(n) => vec![n],
        _ => Vec::new(),
    }
}

/// Per-evaluation state: variable frame, `changed` baselines, deadlines, step count.
pub(crate) struct Ctx<'a> {
    pub env: &'a dyn Env,
    /// Quantifier variables (and, after `any`, its binding).
    pub frame: Vec<Option<Arc<str>>>,
    /// `self`, in active functions and derived attributes.
    pub this: Option<Arc<str>>,
    /// Values `changed` sites had when the plan last acted.
    pub baseline: &'a [Option<Value>],
    /// Values `changed` sites have now (to become the baseline if the plan acts).
    pub seen: Vec<Option<Value>>,
    /// Earliest future moment (seconds since the epoch) a time condition flips.
    pub deadline: Option<f64>,
    /// Time was read in a way no deadline describes (the engine re-evaluates periodically).
    pub unanchored_time: bool,
    /// Newest timestamp (seconds) of the packets read, for derived attributes.
    pub newest: f64,
    now: Option<f64>,
    ops: u64,
}

impl<'a> Ctx<'a> {
    pub fn new(env: &'a dyn Env, slots: usize, baseline: &'a [Option<Value>]) -> Self {
        Ctx {
            env,
            frame: if slots == 0 {
                Vec::new()
            } else {
                vec![None; slots]
            },
            this: None,
            baseline,
            seen: if baseline.is_empty() {
                Vec::new()
            } else {
                vec![None; baseline.len()]
            },
            deadline: None,
            unanchored_time: false,
            newest: 0.0,
            now: None,
            ops: 0,
        }
    }

    fn now(&mut self) -> f64 {
        *self.now.get_or_insert_with(|| self.env.now().as_secs_f64())
    }

    fn step(&mut self) -> Result<(), EvalError> {
        self.ops += 1;
        if self.ops > MAX_OPS {
            Err(EvalError::Limit)
        } else {
            Ok(())
        }
    }

    /// Notes the moment a time condition flips. A moment equal to now (the clock stopped
    /// exactly on it) means the condition flips just after: look again a microsecond on.
    fn note_deadline(&mut self, at: f64) {
        let now = self.now();
        if at >= now {
            let at = at.max(now + 1e-6);
            self.deadline = Some(self.deadline.map_or(at, |d| d.min(at)));
        }
    }
}

/// Is this value true as a condition? (`none` is false.)
pub(crate) fn truthy(v: &Value) -> bool {
    matches!(v, Value::Bool(true))
}

impl CompiledExpr {
    /// Evaluates the node.
    pub fn eval(&self, cx: &mut Ctx<'_>) -> Result<Value, EvalError> {
        cx.step()?;
        match self {
            CompiledExpr::Const(v) => Ok(v.clone()),
            CompiledExpr::Attr(a) => Ok(read_field(cx, a)?.unwrap_or(Value::None)),
            CompiledExpr::Token(obj) => Ok(object_name(cx, obj)?.map_or(Value::None, Value::Ref)),
            CompiledExpr::Vector(items) => vector(cx, items),
            CompiledExpr::Not(n) => Ok(match n.eval(cx)? {
                Value::Bool(b) => Value::Bool(!b),
                _ => Value::None,
            }),
            CompiledExpr::Neg(n) => Ok(negate(n.eval(cx)?)),
            CompiledExpr::And(ab) => Ok(Value::Bool(
                truthy(&ab.0.eval(cx)?) && truthy(&ab.1.eval(cx)?),
            )),
            CompiledExpr::Or(ab) => Ok(Value::Bool(
                truthy(&ab.0.eval(cx)?) || truthy(&ab.1.eval(cx)?),
            )),
            CompiledExpr::Arith(op, ab) => arith(*op, ab.0.eval(cx)?, ab.1.eval(cx)?),
            CompiledExpr::Cmp(op, ab) => compare(cx, *op, &ab.0, &ab.1),
            CompiledExpr::Call(f, args) => call(cx, *f, args),
            CompiledExpr::Quant(q) => quantify(cx, q),
        }
    }
}

/// The name of the object `obj` designates now (`None`: unbound or dangling).
pub(crate) fn object_name(cx: &mut Ctx<'_>, obj: &Obj) -> Result<Option<Arc<str>>, EvalError> {
    Ok(match obj {
        Obj::Named(n) => Some(n.clone()),
        Obj::Var(slot) => cx.frame.get(*slot).cloned().flatten(),
        Obj::This => cx.this.clone(),
        Obj::Deref(node) => match node.eval(cx)? {
            Value::Ref(r) => Some(r),
            Value::None => None,
            other => {
                return Err(EvalError::Type(format!(
                    "{other} is not a reference to an object"
                )));
            }
        },
    })
}

/// Reads an attribute's packet (`None` if unknown or unbound).
pub(crate) fn read_packet(cx: &mut Ctx<'_>, a: &AttrRead) -> Result<Option<Packet>, EvalError> {
    let (obj, attr, _, cache) = a;
    let packet = match obj {
        Obj::Named(name) => cx.env.read_cached(name, attr, cache),
        _ => match object_name(cx, obj)? {
            Some(name) => cx.env.read(&name, attr),
            None => return Ok(None),
        },
    };
    if let Some(p) = &packet {
        cx.newest = cx.newest.max(p.timestamp.as_secs_f64());
    }
    Ok(packet)
}

fn read_field(cx: &mut Ctx<'_>, a: &AttrRead) -> Result<Option<Value>, EvalError> {
    let field = a.2;
    Ok(read_packet(cx, a)?.map(|p| match field {
        Field::Value => p.value,
        Field::Accuracy => Value::Real(p.accuracy),
        Field::Confidence => Value::Real(p.confidence),
        Field::Timestamp => Value::Real(p.timestamp.as_secs_f64()),
        Field::Source => Value::Str(p.source.as_str().into()),
    }))
}

fn vector(cx: &mut Ctx<'_>, items: &[CompiledExpr]) -> Result<Value, EvalError> {
    let mut out = Vec::with_capacity(items.len());
    for item in items {
        match item.eval(cx)?.as_f64() {
            Some(x) => out.push(x),
            None => return Ok(Value::None),
        }
    }
    Ok(Value::from(out))
}

fn negate(v: Value) -> Value {
    match v {
        Value::Int(i) => Value::Int(i.wrapping_neg()),
        Value::Real(x) => Value::Real(-x),
        Value::Vector(v) => Value::from(v.iter().map(|x| -x).collect::<Vec<_>>()),
        _ => Value::None,
    }
}

fn arith(op: Arith, a: Value, b: Value) -> Result<Value, EvalError> {
    use Value::{Int, Real, Vector};
    Ok(match (a, b) {
        (Int(x), Int(y)) => int_arith(op, x, y)?,
        (Vector(x), Vector(y)) if x.len() == y.len() => {
            let r: Result<Vec<f64>, _> = x
                .iter()
                .zip(y.iter())
                .map(|(p, q)| real_arith(op, *p, *q))
                .collect();
            Value::from(r?)
        }
        (Vector(x), k) if k.as_f64().is_some() => scale(op, &x, k.as_f64().unwrap_or(0.0), false)?,
        (k, Vector(x)) if k.as_f64().is_some() => scale(op, &x, k.as_f64().unwrap_or(0.0), true)?,
        (a, b) => match (a.as_f64(), b.as_f64()) {
            (Some(x), Some(y)) => Real(real_arith(op, x, y)?),
            _ => Value::None,
        },
    })
}

fn scale(op: Arith, v: &[f64], k: f64, k_first: bool) -> Result<Value, EvalError> {
    let r: Result<Vec<f64>, _> = v
        .iter()
        .map(|x| {
            if k_first {
                real_arith(op, k, *x)
            } else {
                real_arith(op, *x, k)
            }
        })
        .collect();
    Ok(Value::from(r?))
}

fn int_arith(op: Arith, x: i64, y: i64) -> Result<Value, EvalError> {
    Ok(Value::Int(match op {
        Arith::Add => x.wrapping_add(y),
        Arith::Sub => x.wrapping_sub(y),
        Arith::Mul => x.wrapping_mul(y),
        Arith::Div => x.checked_div(y).ok_or(EvalError::DivisionByZero)?,
        Arith::Rem => x.checked_rem(y).ok_or(EvalError::DivisionByZero)?,
    }))
}

fn real_arith(op: Arith, x: f64, y: f64) -> Result<f64, EvalError> {
    let r = match op {
        Arith::Add => x + y,
        Arith::Sub => x - y,
        Arith::Mul => x * y,
        Arith::Div | Arith::Rem if y == 0.0 => return Err(EvalError::DivisionByZero),
        Arith::Div => x / y,
        Arith::Rem => x % y,
    };
    Ok(r)
}

/// Compares; also notes when a time condition (`age(x) > 2s`, `now() >= t`) will flip.
fn compare(
    cx: &mut Ctx<'_>,
    op: Cmp,
    a: &CompiledExpr,
    b: &CompiledExpr,
) -> Result<Value, EvalError> {
    let outer = std::mem::replace(&mut cx.unanchored_time, false);
    let va = a.eval(cx)?;
    let time_in_a = std::mem::replace(&mut cx.unanchored_time, false);
    let vb = b.eval(cx)?;
    let time_in_b = std::mem::replace(&mut cx.unanchored_time, false);
    // `age(x) OP k` and `now() OP k` with a timeless k flip at a moment we can name.
    let anchored_a = !time_in_b && anchor(cx, a, &vb)?;
    let anchored_b = !time_in_a && anchor(cx, b, &va)?;
    cx.unanchored_time = outer || (time_in_a && !anchored_a) || (time_in_b && !anchored_b);
    Ok(match (op, &va, &vb) {
        (Cmp::Eq, x, y) => Value::Bool(x == y),
        (Cmp::Ne, x, y) => Value::Bool(x != y),
        (_, x, y) => match ordering(x, y) {
            Some(o) => Value::Bool(match op {
                Cmp::Lt => o.is_lt(),
                Cmp::Le => o.is_le(),
                Cmp::Gt => o.is_gt(),
                _ => o.is_ge(),
            }),
            None => Value::None,
        },
    })
}

/// If `timed` is `age(x)` or `now()` and `other` a number k, notes the moment the
/// comparison flips (when the time expression equals k) and returns true.
fn anchor(cx: &mut Ctx<'_>, timed: &CompiledExpr, other: &Value) -> Result<bool, EvalError> {
    match (time_base(cx, timed)?, other.as_f64()) {
        (Some(base), Some(k)) => {
            cx.note_deadline(base + k);
            Ok(true)
        }
        _ => Ok(false),
    }
}

/// For `age(x)` the timestamp of x (it equals k at base + k); for `now()` zero.
fn time_base(cx: &mut Ctx<'_>, node: &CompiledExpr) -> Result<Option<f64>, EvalError> {
    Ok(match node {
        CompiledExpr::Call(Builtin::Now, _) => Some(0.0),
        CompiledExpr::Call(Builtin::Age, args) => match args.first() {
            Some(CompiledExpr::Attr(a)) => read_packet(cx, a)?.map(|p| p.timestamp.as_secs_f64()),
            _ => None,
        },
        _ => None,
    })
}

fn ordering(x: &Value, y: &Value) -> Option<std::cmp::Ordering> {
    match (x, y) {
        (Value::Int(a), Value::Int(b)) => Some(a.cmp(b)),
        (Value::Str(a), Value::Str(b)) => Some(a.cmp(b)),
        _ => x.as_f64()?.partial_cmp(&y.as_f64()?),
    }
}

fn call(cx: &mut Ctx<'_>, f: Builtin, args: &[CompiledExpr]) -> Result<Value, EvalError> {
    match f {
        Builtin::Age => age(cx, args),
        Builtin::Now => {
            cx.unanchored_time = true;
            Ok(Value::Real(cx.now()))
        }
        Builtin::Changed(site) => changed(cx, site, args),
        Builtin::Exists => Ok(match args.first().map(|a| a.eval(cx)).transpose()? {
            Some(Value::Ref(r)) => Value::Bool(cx.env.exists(&r)),
            _ => Value::Bool(false),
        }),
        _ => {
            let mut vals = Vec::with_capacity(args.len());
            for a in args {
                vals.push(a.eval(cx)?);
            }
            Ok(math(f, &vals))
        }
    }
}

fn age(cx: &mut Ctx<'_>, args: &[CompiledExpr]) -> Result<Value, EvalError> {
    cx.unanchored_time = true;
    let Some(CompiledExpr::Attr(a)) = args.first() else {
        return Ok(Value::None);
    };
    let Some(p) = read_packet(cx, a)? else {
        return Ok(Value::None);
    };
    if p.timestamp == slate_model::Timestamp::ZERO {
        return Ok(Value::None);
    }
    Ok(Value::Real(cx.now() - p.timestamp.as_secs_f64()))
}

fn changed(cx: &mut Ctx<'_>, site: usize, args: &[CompiledExpr]) -> Result<Value, EvalError> {
    let current = match args.first() {
        Some(n) => n.eval(cx)?,
        None => Value::None,
    };
    let deadband = match args.get(1) {
        Some(n) => n.eval(cx)?.as_f64().unwrap_or(0.0),
        None => 0.0,
    };
    let moved = match cx.baseline.get(site).cloned().flatten() {
        None => !current.is_none(),
        Some(before) => difference(&before, &current).is_none_or(|d| d > deadband),
    };
    if let Some(slot) = cx.seen.get_mut(site) {
        *slot = Some(current);
    }
    Ok(Value::Bool(moved))
}

/// How far apart two values are: absolute difference, Euclidean distance, or `None`
/// when they cannot be measured (then any inequality counts as a change).
fn difference(a: &Value, b: &Value) -> Option<f64> {
    match (a, b) {
        (Value::Vector(x), Value::Vector(y)) if x.len() == y.len() => Some(euclid(x, y)),
        _ => match (a.as_f64(), b.as_f64()) {
            (Some(x), Some(y)) => Some((x - y).abs()),
            _ => (a == b).then_some(0.0),
        },
    }
}

fn euclid(x: &[f64], y: &[f64]) -> f64 {
    x.iter()
        .zip(y)
        .map(|(p, q)| (p - q) * (p - q))
        .sum::<f64>()
        .sqrt()
}

fn math(f: Builtin, v: &[Value]) -> Value {
    let real = |i: usize| v.get(i).and_then(Value::as_f64);
    let r = |x: Option<f64>| x.map_or(Value::None, Value::Real);
    match f {
        Builtin::Abs => match v.first() {
            Some(Value::Int(i)) => Value::Int(i.wrapping_abs()),
            _ => r(real(0).map(f64::abs)),
        },
        Builtin::Min | Builtin::Max => extreme(f == Builtin::Max, v),
        Builtin::Sqrt => r(real(0).map(f64::sqrt)),
        Builtin::Sin => r(real(0).map(f64::sin)),
        Builtin::Cos => r(real(0).map(f64::cos)),
        Builtin::Atan2 => r(real(0).zip(real(1)).map(|(y, x)| y.atan2(x))),
        Builtin::Norm => r(v
            .first()
            .and_then(Value::as_vector)
            .map(|x| euclid(x, &vec![0.0; x.len()]))),
        Builtin::Distance => match (
            v.first().and_then(Value::as_vector),
            v.get(1).and_then(Value::as_vector),
        ) {
            (Some(a), Some(b)) if a.len() == b.len() => Value::Real(euclid(a, b)),
            _ => Value::None,
        },
        Builtin::Polar => match (real(0), real(1)) {
            (Some(rho), Some(th)) => Value::from([rho * th.cos(), rho * th.sin()]),
            _ => Value::None,
        },
        Builtin::At => match (v.first().and_then(Value::as_vector), v.get(1)) {
            (Some(x), Some(Value::Int(i))) => usize::try_from(*i)
                .ok()
                .and_then(|i| x.get(i))
                .map_or(Value::None, |e| Value::Real(*e)),
            _ => Value::None,
        },
        _ => Value::None,
    }
}

fn extreme(max: bool, v: &[Value]) -> Value {
    if v.iter().all(|x| matches!(x, Value::Int(_))) {
        let ints = v.iter().filter_map(|x| {
            if let Value::Int(i) = x {
                Some(*i)
            } else {
                None
            }
        });
        return (if max { ints.max() } else { ints.min() }).map_or(Value::None, Value::Int);
    }
    let reals: Option<Vec<f64>> = v.iter().map(Value::as_f64).collect();
    reals
        .and_then(|r| r.into_iter().reduce(if max { f64::max } else { f64::min }))
        .map_or(Value::None, Value::Real)
}

fn quantify(cx: &mut Ctx<'_>, q: &Quant) -> Result<Value, EvalError> {
    let mut count = 0i64;
    let mut best: Option<(Value, Arc<str>)> = None;
    for name in cx.env.instances(&q.class) {
        cx.step()?;
        cx.frame[q.slot] = Some(name.clone());
        let matches = match &q.filter {
            Some(f) => truthy(&f.eval(cx)?),
            None => true,
        };
        if !matches {
            if q.kind == QuantKind::All {
                cx.frame[q.slot] = None;
                return Ok(Value::Bool(false));
            }
            continue;
        }
        count += 1;
        if q.kind == QuantKind::Any {
            let Some((key, desc)) = &q.order else {
                return Ok(Value::Bool(true)); // bound to the first match
            };
            let k = key.eval(cx)?;
            if better(
                &k,
                best.as_ref().map(|b| &b.0),
                &name,
                best.as_ref().map(|b| &b.1),
                *desc,
            ) {
                best = Some((k, name));
            }
        }
    }
    Ok(match q.kind {
        QuantKind::All => {
            cx.frame[q.slot] = None;
            Value::Bool(true)
        }
        QuantKind::Count => {
            cx.frame[q.slot] = None;
            Value::Int(count)
        }
        QuantKind::Any => {
            cx.frame[q.slot] = best.as_ref().map(|b| b.1.clone());
            Value::Bool(best.is_some())
        }
    })
}

/// Is `key` (of object `name`) a better `by` match than the best so far? Objects without
/// a key never win; ties go to the smaller name, so every board picks the same one.
fn better(
    key: &Value,
    best: Option<&Value>,
    name: &str,
    best_name: Option<&Arc<str>>,
    desc: bool,
) -> bool {
    if key.is_none() {
        return false;
    }
    let Some(b) = best else { return true };
    match ordering(key, b) {
        Some(std::cmp::Ordering::Equal) | None => best_name.is_none_or(|bn| name < &**bn),
        Some(o) => {
            if desc {
                o.is_gt()
            } else {
                o.is_lt()
            }
        }
    }
}
