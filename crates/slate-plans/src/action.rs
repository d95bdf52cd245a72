//! Compiled actions, evaluated into effects before any is applied, so that a failing
//! expression leaves nothing half done and a plan's writes are applied as one batch.

use std::sync::Arc;

use slate_model::{Address, Context, Key, NewObject, Update, Value};

use crate::eval::{CompiledExpr, Ctx, EvalError, KeyCache, Obj, object_name};

/// `set OBJ.ATTR = value [accuracy a] [confidence c]`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Write {
    pub obj: Obj,
    pub attr: Arc<str>,
    pub value: CompiledExpr,
    pub accuracy: Option<CompiledExpr>,
    pub confidence: Option<CompiledExpr>,
    /// The attribute is real: integers are written as reals.
    pub real: bool,
    /// The board handle of a named target.
    pub cache: KeyCache,
}

/// A compiled action.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Act {
    Set(Vec<Write>),
    Report {
        targets: Vec<(Obj, Option<Arc<str>>)>,
        to: Option<Address>,
    },
    /// `text` is `None` for a plan declared elsewhere (looked up by name when sent).
    Send {
        name: String,
        text: Option<String>,
        to: Address,
    },
    Create {
        class: Arc<str>,
        name: Arc<str>,
        context: Option<Context>,
        writes: Vec<Write>,
    },
    Delete(CompiledExpr),
}

/// What running actions will do, in order.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Effect {
    /// Object, attribute, update, and the board handle when known.
    Write(Arc<str>, Arc<str>, Update, Option<Key>),
    Create(NewObject),
    Delete(Arc<str>),
    Report {
        targets: Vec<(Arc<str>, Option<Arc<str>>)>,
        to: Option<Address>,
    },
    Send {
        name: String,
        text: Option<String>,
        to: Address,
    },
}

/// Evaluates actions into effects.
pub(crate) fn effects(acts: &[Act], cx: &mut Ctx<'_>) -> Result<Vec<Effect>, EvalError> {
    let mut out = Vec::new();
    for act in acts {
        match act {
            Act::Set(writes) => {
                for w in writes {
                    out.push(write(w, cx)?);
                }
            }
            Act::Report { targets, to } => {
                let mut resolved = Vec::new();
                for (obj, attr) in targets {
                    if let Some(name) = object_name(cx, obj)? {
                        resolved.push((name, attr.clone()));
                    }
                }
                out.push(Effect::Report {
                    targets: resolved,
                    to: to.clone(),
                });
            }
            Act::Send { name, text, to } => out.push(Effect::Send {
                name: name.clone(),
                text: text.clone(),
                to: to.clone(),
            }),
            Act::Create {
                class,
                name,
                context,
                writes,
            } => {
                let mut spec = NewObject::new(class, name);
                if let Some(c) = context {
                    spec = spec.context(*c);
                }
                out.push(Effect::Create(spec));
                for w in writes {
                    out.push(write(w, cx)?);
                }
            }
            Act::Delete(node) => match node.eval(cx)? {
                Value::Ref(name) => out.push(Effect::Delete(name)),
                _ => return Err(EvalError::Type("delete: the object does not exist".into())),
            },
        }
    }
    Ok(out)
}

fn write(w: &Write, cx: &mut Ctx<'_>) -> Result<Effect, EvalError> {
    let Some(object) = object_name(cx, &w.obj)? else {
        return Err(EvalError::Type(format!(
            "set: no object to write {} to",
            w.attr
        )));
    };
    let value = match w.value.eval(cx)? {
        Value::Int(i) if w.real => Value::Real(i as f64),
        Value::None => {
            return Err(EvalError::Type(format!(
                "set {object}.{}: the value is none (not known yet)",
                w.attr
            )));
        }
        v => v,
    };
    let mut update = Update::new(value);
    update.accuracy = number(&w.accuracy, cx)?;
    update.confidence = number(&w.confidence, cx)?;
    let key = match &w.obj {
        Obj::Named(_) => cx.env.key(&object, &w.attr, &w.cache),
        _ => None,
    };
    Ok(Effect::Write(object, w.attr.clone(), update, key))
}

fn number(n: &Option<CompiledExpr>, cx: &mut Ctx<'_>) -> Result<Option<f64>, EvalError> {
    match n {
        None => Ok(None),
        Some(n) => Ok(n.eval(cx)?.as_f64()),
    }
}
