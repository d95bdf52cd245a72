//! Objects: created in one batch, then their initial values written in another, each
//! failure reported at the declaration it is about.

use std::sync::Arc;

use slate_model::{Board, NewObject, Update};

use crate::action::Write;
use crate::ast::ObjectDecl;
use crate::diagnostic::{Diagnostics, Span};
use crate::eval::{CompiledExpr, Ctx, Env, Obj};

use super::classes::coerce;
use super::{Undo, one};

/// Creates the objects in one batch, then writes their initial values in another (they
/// may read the objects just created). Every object created is recorded in `undo`; an
/// initial value the board refuses is reported at its expression.
pub(super) fn create_objects(
    board: &Board,
    objects: Vec<(ObjectDecl, Vec<(Span, Write)>)>,
    undo: &mut Undo,
) -> Result<Vec<String>, Diagnostics> {
    let mut batch = board.batch();
    let mut names = Vec::new();
    for (o, _) in &objects {
        let mut spec = NewObject::new(&o.class.name, &o.name.name);
        if let Some(c) = o.context {
            spec = spec.context(c.context);
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
            |n: &Option<CompiledExpr>| n.as_ref().and_then(|n| n.eval(&mut cx).ok())?.as_f64();
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
