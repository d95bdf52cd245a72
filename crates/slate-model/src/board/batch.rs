//! Atomic batches: all operations apply, under one lock and one revision, or none do.

use std::sync::Arc;

use super::txn::Txn;
use super::{Board, Chain, NewObject, Target};
use crate::{BatchError, Key, Update};

enum Op {
    Write(Arc<str>, Arc<str>, Update),
    WriteKey(Key, Update),
    /// A write that may touch a guarded attribute.
    Guarded(Arc<str>, Arc<str>, Update),
    /// The same through a resolved key.
    GuardedKey(Key, Update),
    Create(NewObject),
    Delete(String),
}

/// An atomic batch of writes, creations and deletions, applied in order by
/// [`Batch::commit`]. Readers see all of it or none of it; watchers get one
/// notification; on-write functions run after the whole batch is stored.
///
/// ```
/// use slate_model::{AttrDecl, Board, ClassDef, ValueType};
/// let board = Board::new();
/// board.define(ClassDef::new("Obstacle").attr(AttrDecl::new("range", ValueType::Real)))?;
/// let mut batch = board.batch();
/// batch.create("Obstacle", "rock").write("rock", "range", 3.5);
/// let revision = batch.commit()?;
/// assert_eq!(board.read("rock", "range")?.value.as_f64(), Some(3.5));
/// # let _ = revision;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[must_use = "a batch does nothing until it is committed"]
pub struct Batch<'b> {
    board: &'b Board,
    ops: Vec<Op>,
}

impl<'b> Batch<'b> {
    pub(crate) fn new(board: &'b Board) -> Self {
        Batch {
            board,
            ops: Vec::new(),
        }
    }

    /// Adds a write.
    pub fn write(&mut self, object: &str, attr: &str, update: impl Into<Update>) -> &mut Self {
        self.ops
            .push(Op::Write(object.into(), attr.into(), update.into()));
        self
    }

    /// Adds a write with names the caller already shares (no copy of the names).
    pub fn write_shared(&mut self, object: Arc<str>, attr: Arc<str>, update: Update) -> &mut Self {
        self.ops.push(Op::Write(object, attr, update));
        self
    }

    /// Adds a write through a resolved key.
    pub fn write_key(&mut self, key: Key, update: impl Into<Update>) -> &mut Self {
        self.ops.push(Op::WriteKey(key, update.into()));
        self
    }

    /// Adds a write that may also write a guarded attribute ([`AttrDecl::guarded`]): the
    /// door of the machinery that declared it (the plan engine for `Plan`'s fields).
    /// Bindings, tools and plans never use it, so what they write cannot contradict what
    /// that machinery does.
    ///
    /// [`AttrDecl::guarded`]: crate::AttrDecl::guarded
    pub fn write_guarded(
        &mut self,
        object: &str,
        attr: &str,
        update: impl Into<Update>,
    ) -> &mut Self {
        self.ops
            .push(Op::Guarded(object.into(), attr.into(), update.into()));
        self
    }

    /// [`Batch::write_guarded`] through a resolved key.
    pub fn write_key_guarded(&mut self, key: Key, update: impl Into<Update>) -> &mut Self {
        self.ops.push(Op::GuardedKey(key, update.into()));
        self
    }

    /// Adds the creation of an object in the SURROUNDINGS context.
    pub fn create(&mut self, class: &str, name: &str) -> &mut Self {
        self.create_with(NewObject::new(class, name))
    }

    /// Adds the creation of an object as described.
    pub fn create_with(&mut self, spec: NewObject) -> &mut Self {
        self.ops.push(Op::Create(spec));
        self
    }

    /// Adds the deletion of an object.
    pub fn delete(&mut self, name: &str) -> &mut Self {
        self.ops.push(Op::Delete(name.to_owned()));
        self
    }

    /// Number of operations.
    pub fn len(&self) -> usize {
        self.ops.len()
    }

    /// Has nothing been added?
    pub fn is_empty(&self) -> bool {
        self.ops.is_empty()
    }

    /// Applies every operation, or none; returns the batch's revision (an empty batch
    /// changes nothing and returns the current revision).
    pub fn commit(self) -> Result<u64, BatchError> {
        let board = self.board;
        if self.ops.is_empty() {
            return Ok(board.revision());
        }
        let done = {
            let mut inner = board.inner.write();
            let mut txn = Txn::new(&mut inner, &board.clock, &board.address, self.ops.len());
            for (index, op) in self.ops.into_iter().enumerate() {
                if let Err(e) = apply(&mut txn, board, index, op) {
                    txn.rollback();
                    return Err(e);
                }
            }
            txn.commit()
        };
        Ok(board.finish(done, &Chain::default()))
    }
}

fn apply(txn: &mut Txn<'_>, board: &Board, index: usize, op: Op) -> Result<(), BatchError> {
    let write = |txn: &mut Txn<'_>, target: Target<'_>, update, machinery: bool| {
        let failed = |source| BatchError::Write { index, source };
        let key = target.resolve(txn.state()).map_err(|m| failed(m.into()))?;
        if machinery {
            txn.write_guarded(key, update).map_err(failed)
        } else {
            txn.write(key, update).map_err(failed)
        }
    };
    match op {
        Op::Write(o, a, u) => write(txn, Target::Names(&o, &a), u, false),
        Op::WriteKey(k, u) => write(txn, Target::Key(k), u, false),
        Op::Guarded(o, a, u) => write(txn, Target::Names(&o, &a), u, true),
        Op::GuardedKey(k, u) => write(txn, Target::Key(k), u, true),
        Op::Create(spec) => {
            let owner = spec.owner.unwrap_or_else(|| board.address.clone());
            txn.create(&spec.class, &spec.name, spec.context, owner)
                .map(|_| ())
                .map_err(|source| BatchError::Create { index, source })
        }
        Op::Delete(name) => txn
            .delete(&name)
            .map(|_| ())
            .map_err(|source| BatchError::Delete { index, source }),
    }
}
