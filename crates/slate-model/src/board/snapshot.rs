//! Consistent reads of a whole board at one revision.

use std::sync::Arc;

use parking_lot::RwLockReadGuard;

use super::txn::Inner;
use super::{Access, Board, Chain, ObjectInfo, PendingRead, Query, Target};
use crate::{Key, LookupError, ObjectId, Packet, ReadError};

/// A consistent view of a board: every read sees the same revision. On-read active
/// functions run, and may read (through the same snapshot) but not write.
///
/// Writers wait while a snapshot lives, so keep it short, and never write to the board
/// from the thread that holds one.
pub struct Snapshot<'b> {
    board: &'b Board,
    inner: RwLockReadGuard<'b, Inner>,
}

impl<'b> Snapshot<'b> {
    pub(crate) fn new(board: &'b Board, inner: RwLockReadGuard<'b, Inner>) -> Self {
        Snapshot { board, inner }
    }

    /// The board it shows.
    pub(crate) fn board(&self) -> &'b Board {
        self.board
    }

    /// The state it holds.
    pub(crate) fn state(&self) -> &super::state::State {
        &self.inner.state
    }

    /// Starts recording what this thread reads of the board through this snapshot, to
    /// ask the board later whether any of it changed
    /// ([`Board::unchanged_since`](crate::Board::unchanged_since)): the attributes read,
    /// and for a derived attribute whose packet is kept (a pure on-read function's), that
    /// packet, which stands for what it read. What does not name all it read (a function
    /// that is not pure, a packet that is not kept) ends the trace with nothing. Traces
    /// are of this thread, and nest: stop (or drop) an inner one before the outer one.
    pub fn trace(&self) -> super::ReadTrace {
        let st = &self.inner.state;
        super::ReadTrace::start(self.board.id(), st.revision, st.kept.structure())
    }

    /// The revision this snapshot shows.
    pub fn revision(&self) -> u64 {
        self.inner.state.revision
    }

    /// Reads an attribute as [`Board::read`] does.
    pub fn read(&self, object: &str, attr: &str) -> Result<Packet, ReadError> {
        self.read_in(Target::Names(object, attr), &Chain::default())
    }

    /// Reads through a resolved key.
    pub fn read_key(&self, key: Key) -> Result<Packet, ReadError> {
        self.read_in(Target::Key(key), &Chain::default())
    }

    pub(crate) fn read_in(&self, target: Target<'_>, chain: &Chain) -> Result<Packet, ReadError> {
        match PendingRead::new(self.board, &self.inner.state, target)? {
            Ok(packet) => Ok(packet),
            Err(pending) => pending.finish(self.board, Access::Frozen(self), chain),
        }
    }

    /// Instances of `class` and its subclasses.
    pub fn instances(&self, class: &str) -> Result<Vec<ObjectId>, LookupError> {
        self.query(&Query::class(class))
    }

    /// Instances selected by a query.
    pub fn query(&self, query: &Query) -> Result<Vec<ObjectId>, LookupError> {
        super::instances(&self.inner.state, query)
    }

    /// Resolves `object.attr` as [`Board::key`] does.
    pub fn key(&self, object: &str, attr: &str) -> Result<Key, LookupError> {
        Ok(self.inner.state.key(object, attr)?)
    }

    /// The handle of an object or class by name.
    pub fn id_of(&self, name: &str) -> Option<ObjectId> {
        self.inner.state.id(name)
    }

    /// Does an object or class of that name exist?
    pub fn exists(&self, name: &str) -> bool {
        self.inner.state.id(name).is_some()
    }

    /// The name of an object or class.
    pub fn name_of(&self, id: ObjectId) -> Option<Arc<str>> {
        self.inner.state.name(id)
    }

    /// What the board knows about an object or class.
    pub fn info(&self, id: ObjectId) -> Option<ObjectInfo> {
        super::object_info(&self.inner.state, id)
    }

    /// The attributes `id` has (declared on its class chain), by name, sorted.
    pub fn attributes(&self, id: ObjectId) -> Vec<Arc<str>> {
        let st = &self.inner.state;
        let mut names: Vec<Arc<str>> = st
            .decl_class(id)
            .map(|(_, c)| c.decls.keys().map(|a| st.attr_name(*a)).collect())
            .unwrap_or_default();
        names.sort();
        names
    }

    /// The packets `id` holds itself (not inherited), with the revision that wrote each,
    /// sorted by attribute name. This is the object's state to send to a late joiner.
    pub fn own_values(&self, id: ObjectId) -> Vec<(Arc<str>, Packet, u64)> {
        let st = &self.inner.state;
        let mut out: Vec<_> = st
            .get(id)
            .map(|e| {
                e.values
                    .iter()
                    .map(|s| (st.attr_name(s.attr), s.packet.clone(), s.revision))
                    .collect()
            })
            .unwrap_or_default();
        out.sort_by(|a, b| a.0.cmp(&b.0));
        out
    }

    /// Every live object and class.
    pub fn objects(&self) -> Vec<ObjectId> {
        self.inner.state.entities().map(|(id, _)| id).collect()
    }
}
