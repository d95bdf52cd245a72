//! A transaction: operations applied under the board's write lock, with an undo log so
//! that a failing batch leaves nothing behind, and notifications held back until commit.

use std::sync::Arc;

use super::hook::{ChangeHook, TouchKind, Touched};
use super::state::{Entity, Origin, State, Stored};
use super::watch::{Change, ChangeItem, Watcher};
use smallvec::SmallVec;

use crate::active::FnRef;
use crate::{
    Address, AttrId, Clock, Context, CreateError, DeleteError, Key, ObjectId, Packet, Timestamp,
    Trigger, Update, WriteError,
};

/// What the board keeps under its lock.
pub(crate) struct Inner {
    pub state: State,
    pub watchers: Vec<Watcher>,
    pub hooks: Arc<[Arc<dyn ChangeHook>]>,
}

impl Inner {
    /// Does a change need the full transaction (someone to notify or something to run)?
    pub fn is_observed(&self) -> bool {
        !self.watchers.is_empty() || !self.hooks.is_empty()
    }
}

/// What a committed transaction leaves to do once the lock is released.
pub(crate) struct Committed {
    pub revision: u64,
    pub fired: Vec<Fired>,
    pub touched: SmallVec<[Touched; 4]>,
    pub hooks: Option<Arc<[Arc<dyn ChangeHook>]>>,
}

enum Undo {
    Write(Key, Option<Stored>),
    Create(ObjectId),
    Delete(ObjectId, Entity),
}

/// On-write functions to run once the transaction is committed and the lock released.
pub(crate) struct Fired {
    pub key: Key,
    pub object: Arc<str>,
    pub attr: Arc<str>,
    pub packet: Packet,
    pub previous: Option<Packet>,
    pub fns: Vec<FnRef>,
}

pub(crate) struct Txn<'s> {
    inner: &'s mut Inner,
    clock: &'s Clock,
    me: &'s Address,
    revision: u64,
    stamp: Timestamp,
    undo: Option<Vec<Undo>>,
    /// Per watcher (by index), the items it is to be told.
    notes: SmallVec<[Vec<ChangeItem>; 4]>,
    fired: Vec<Fired>,
    touched: SmallVec<[Touched; 4]>,
}

impl<'s> Txn<'s> {
    /// Starts a transaction. `ops` is how many operations it will hold: more than one
    /// keeps an undo log. Every write it stores is stamped with one timestamp: a batch is
    /// one event.
    pub fn new(inner: &'s mut Inner, clock: &'s Clock, me: &'s Address, ops: usize) -> Self {
        let revision = inner.state.revision + 1;
        Txn {
            inner,
            clock,
            me,
            revision,
            stamp: clock.now(),
            undo: (ops > 1).then(|| Vec::with_capacity(ops)),
            notes: SmallVec::new(),
            fired: Vec::new(),
            touched: SmallVec::new(),
        }
    }

    pub fn state(&self) -> &State {
        &self.inner.state
    }

    /// An own write (see [`Origin::Own`]).
    pub fn write(&mut self, key: Key, update: Update) -> Result<(), WriteError> {
        self.store(key, update, Origin::Own)
    }

    /// An own write that may write guarded attributes (see [`Origin::Machinery`]).
    pub fn write_guarded(&mut self, key: Key, update: Update) -> Result<(), WriteError> {
        self.store(key, update, Origin::Machinery)
    }

    /// Stores a received packet that won its merge.
    pub fn merge(&mut self, key: Key, packet: Packet) -> Result<(), WriteError> {
        self.store(key, Update::from(packet), Origin::Merged)
    }

    fn store(&mut self, key: Key, update: Update, origin: Origin) -> Result<(), WriteError> {
        let packet =
            self.inner
                .state
                .prepare(key, update, self.clock, self.me, Some(self.stamp), origin)?;
        let st = &self.inner.state;
        let fns = if st.may_have_fns(key) {
            st.fns(key, Trigger::Write)
        } else {
            Vec::new()
        };
        let foreign = packet.source != *self.me;
        // Received packets are watched by few (the ICI watches own writes only).
        let noted = self
            .inner
            .watchers
            .iter()
            .any(|w| !(foreign && w.spec.own_writes));
        let names = (!fns.is_empty() || noted).then(|| {
            (
                st.name(key.object).unwrap_or_else(|| "?".into()),
                st.attr_name(key.attr),
            )
        });
        self.touch(key.object, Some(key.attr), TouchKind::Write);
        // The names go to the watchers; the functions to fire need them too (rarely).
        let fired_names = if fns.is_empty() { None } else { names.clone() };
        if let Some((object, attr)) = names.filter(|_| noted) {
            let item = ChangeItem::Write {
                object,
                attr,
                packet: packet.clone(),
            };
            self.note(key.object, Some(key.attr), foreign, item);
        }
        let stored = if fns.is_empty() {
            None
        } else {
            Some(packet.clone())
        };
        let previous = self.inner.state.store(key, packet, self.revision);
        if let (Some(packet), Some((object, attr))) = (stored, fired_names) {
            let prev = previous.as_ref().map(|s| s.packet.clone());
            self.fired.push(Fired {
                key,
                object,
                attr,
                packet,
                previous: prev,
                fns,
            });
        }
        if let Some(undo) = &mut self.undo {
            undo.push(Undo::Write(key, previous));
        }
        Ok(())
    }

    pub fn create(
        &mut self,
        class: &str,
        name: &str,
        context: Context,
        owner: Address,
    ) -> Result<ObjectId, CreateError> {
        let id = self.inner.state.create(class, name, context, owner)?;
        self.touch(id, None, TouchKind::Create);
        let class: Arc<str> = class.into();
        // The board's own allocation of the name, as its writes carry.
        let object = self.inner.state.name(id).unwrap_or_else(|| name.into());
        self.note(id, None, false, ChangeItem::Create { object, class });
        if let Some(undo) = &mut self.undo {
            undo.push(Undo::Create(id));
        }
        Ok(id)
    }

    pub fn delete(&mut self, name: &str) -> Result<ObjectId, DeleteError> {
        let st = &self.inner.state;
        if let Some(id) = st
            .id(name)
            .filter(|id| st.get(*id).is_some_and(|e| e.instance().is_some()))
        {
            let class = st
                .lineage(id)
                .first()
                .and_then(|c| st.name(*c))
                .unwrap_or_else(|| "?".into());
            let object = st.name(id).unwrap_or_else(|| name.into());
            self.touch(id, None, TouchKind::Delete);
            self.note(id, None, false, ChangeItem::Delete { object, class });
        }
        let (id, entity) = self.inner.state.remove(name)?;
        if let Some(undo) = &mut self.undo {
            undo.push(Undo::Delete(id, entity));
        }
        Ok(id)
    }

    /// Records what was touched, for the change hooks.
    fn touch(&mut self, object: ObjectId, attr: Option<AttrId>, kind: TouchKind) {
        if self.inner.hooks.is_empty() {
            return;
        }
        let class = self
            .inner
            .state
            .lineage(object)
            .first()
            .copied()
            .unwrap_or(object);
        self.touched.push(Touched {
            object,
            class,
            attr,
            kind,
        });
    }

    /// Records a change item for every watcher it matches (`foreign`: a write of a
    /// packet another module wrote).
    fn note(&mut self, id: ObjectId, attr: Option<AttrId>, foreign: bool, item: ChangeItem) {
        let Inner {
            state, watchers, ..
        } = &*self.inner;
        // Each matching watcher but the last gets a copy; the last, the item.
        let mut last = None;
        for (i, w) in watchers.iter().enumerate() {
            if !(foreign && w.spec.own_writes) && w.spec.matches(state, id, attr) {
                if self.notes.len() < watchers.len() {
                    self.notes.resize_with(watchers.len(), Vec::new);
                }
                if let Some(before) = last.replace(i) {
                    push_note(&mut self.notes[before], item.clone());
                }
            }
        }
        if let Some(i) = last {
            push_note(&mut self.notes[i], item);
        }
    }

    /// Makes the changes visible: one revision, one notification per matching watcher.
    /// Returns what is left to do outside the lock.
    pub fn commit(self) -> Committed {
        let Txn {
            inner,
            revision,
            notes,
            fired,
            touched,
            ..
        } = self;
        inner.state.revision = revision;
        let mut dead = Vec::new();
        for (i, items) in notes.into_iter().enumerate() {
            if !items.is_empty() && !inner.watchers[i].offer(Change { revision, items }) {
                dead.push(i);
            }
        }
        for i in dead.into_iter().rev() {
            inner.watchers.swap_remove(i);
        }
        let hooks = (!touched.is_empty()).then(|| inner.hooks.clone());
        Committed {
            revision,
            fired,
            touched,
            hooks,
        }
    }

    /// Undoes everything applied so far.
    pub fn rollback(self) {
        let st = &mut self.inner.state;
        for op in self.undo.into_iter().flatten().rev() {
            match op {
                Undo::Write(key, previous) => st.unstore(key, previous),
                Undo::Create(id) => st.uncreate(id),
                Undo::Delete(id, entity) => st.restore(id, entity),
            }
        }
    }
}

/// Appends an item to a watcher's notes, in a list of exactly one for the first: most
/// changes are one write, and the four items a `Vec` holds after its first push are a
/// block of about 400 bytes. A watch's reader frees that block in its own thread; blocks
/// that large are merged and the heap's top handed back to the system, so the writer's
/// next ones fault fresh pages in (a recorder's writer spent a tenth of its time there).
fn push_note(notes: &mut Vec<ChangeItem>, item: ChangeItem) {
    if notes.capacity() == 0 {
        notes.reserve_exact(1);
    }
    notes.push(item);
}
