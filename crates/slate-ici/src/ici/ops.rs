//! Board changes the ICI decided on, applied outside its state lock: a board's hooks
//! run in the writing thread, and may call back into the ICI (or a plan engine may).

use std::sync::Arc;
use std::time::Duration;

use parking_lot::Mutex;
use slate_model::{
    Address, Board, Context, CreateError, Merged, NewObject, Packet, ReadError, Update, Value,
    WriteError,
};

use super::filter::Key;
use super::module::{MODULE_CLASS, module_object_name};
use super::state::State;
use crate::LinkKind;

/// One board change.
#[derive(Debug)]
pub(crate) enum BoardOp {
    /// Create the object unless it exists.
    Ensure(NewObject),
    /// Merge a received packet through the attribute's policy.
    Merge {
        object: Arc<str>,
        attr: Arc<str>,
        /// The board's key of `object.attr`, if known (a stale one is ignored).
        key: Option<slate_model::Key>,
        packet: Packet,
    },
    /// Write the current fusion of a `fused` attribute.
    Fuse(Key),
    /// Delete the object if `owner` owns it.
    Delete { object: Arc<str>, owner: Address },
    /// Update a peer's `Module` object.
    Module {
        peer: Address,
        alive: bool,
        last_seen: Duration,
    },
    /// Delete a forgotten peer's `Module` object.
    ForgetModule(Address),
}

/// Outcomes of merges, counted outside the state lock and added to its stats once.
#[derive(Default)]
pub(crate) struct Tally {
    applied: u64,
    kept: u64,
    not_owner: u64,
    unauthorised: u64,
    invalid: u64,
    /// Packets stamped beyond the board clock's tolerance (the board reported each).
    future: u64,
    /// A packet merged by a remembered key found its object gone (deleted here since,
    /// and the ICI has not heard yet): the receiver's memo is out of date.
    stale_key: bool,
}

impl Tally {
    fn count(&mut self, outcome: Result<Merged, WriteError>) {
        match outcome {
            Ok(Merged::Applied(_)) => self.applied += 1,
            Ok(Merged::Kept) => self.kept += 1,
            Ok(Merged::NotOwner) => self.not_owner += 1,
            Ok(Merged::Unauthorised) => self.unauthorised += 1,
            Ok(Merged::FromTheFuture { .. }) => self.future += 1,
            Err(e) => {
                self.invalid += 1;
                tracing::debug!(error = %e, "packet refused");
            }
        }
    }

    /// Adds the counts to the state's stats (one lock for a whole queue of merges).
    pub fn flush(self, state: &Mutex<State>) {
        let any = self.applied + self.kept + self.not_owner + self.unauthorised;
        if any + self.invalid + self.future == 0 {
            return;
        }
        let mut st = state.lock();
        if self.stale_key {
            st.known.clear();
        }
        let m = &mut st.stats.merges;
        m.applied += self.applied;
        m.kept += self.kept;
        m.not_owner += self.not_owner;
        m.unauthorised += self.unauthorised;
        st.stats.rejects.invalid += self.invalid;
        st.stats.rejects.future += self.future;
    }
}

/// Applies one change, counting the outcome in `state`'s stats (merges in `tally`).
pub(crate) fn apply(board: &Board, state: &Mutex<State>, op: BoardOp, tally: &mut Tally) {
    match op {
        BoardOp::Ensure(spec) => ensure(board, state, spec),
        BoardOp::Merge {
            object,
            attr,
            key,
            packet,
        } => merge_all(board, tally, [(object, attr, key, packet)]),
        BoardOp::Fuse(key) => fuse(board, state, &key),
        BoardOp::Delete { object, owner } => delete(board, state, &object, &owner),
        BoardOp::Module {
            peer,
            alive,
            last_seen,
        } => module(board, &peer, alive, last_seen),
        BoardOp::ForgetModule(peer) => forget_module(board, &peer),
    }
}

fn ensure(board: &Board, state: &Mutex<State>, spec: NewObject) {
    if board.info(&spec.name).is_some() || super::limits::refuses_object(board, state, &spec) {
        return;
    }
    let owner = spec.owner.clone().unwrap_or_else(Address::unknown);
    if board
        .admit_write(&spec.class, &spec.name, None, &owner, true)
        .is_err()
    {
        state.lock().stats.merges.unauthorised += 1;
        return;
    }
    let name = spec.name.clone();
    match board.create_with(spec) {
        Ok(_) => state.lock().stats.merges.created += 1,
        Err(CreateError::Exists(_)) => {}
        Err(e) => {
            state.lock().stats.rejects.invalid += 1;
            tracing::debug!(object = %name, error = %e, "object not created");
        }
    }
}

/// Received packets to merge as one board change (a report's, mostly few).
pub(crate) type Merges = smallvec::SmallVec<[Merge; 4]>;

/// A received packet to merge: object, attribute, the board's key if known.
pub(crate) type Merge = (Arc<str>, Arc<str>, Option<slate_model::Key>, Packet);

/// Merges received packets as one board change.
pub(crate) fn merge_all(
    board: &Board,
    tally: &mut Tally,
    packets: impl IntoIterator<Item = Merge>,
) {
    let mut keyed = false;
    let outcomes = board.merge_all_keyed(packets.into_iter().inspect(|m| keyed |= m.2.is_some()));
    for outcome in outcomes {
        // An object gone under a remembered key: forget them all (rare).
        tally.stale_key |= keyed && matches!(outcome, Err(WriteError::UnknownObject(_)));
        tally.count(outcome);
    }
}

/// Writes the fusion as it is now (not as it was when the op was queued), so the last
/// fusion written is always the latest, whatever the order threads apply ops in.
fn fuse(board: &Board, state: &Mutex<State>, key: &Key) {
    let fused = {
        let st = state.lock();
        let class = board
            .info(&key.0)
            .map(|i| if i.is_class { i.name } else { i.class });
        let bounds = class.and_then(|c| st.catalog.decl(&c, &key.1).and_then(|d| d.bounds));
        st.fusion.result(key, bounds)
    };
    let Some(packet) = fused else { return };
    if own_packet(board, key).as_ref() == Some(&packet) {
        return;
    }
    if let Err(e) = board.write(&key.0, &key.1, Update::from(packet)) {
        refused(state, &key.0, &key.1, &e);
    }
}

/// The packet an object holds itself for an attribute (not inherited).
pub(crate) fn own_packet(board: &Board, key: &Key) -> Option<Packet> {
    let snap = board.snapshot();
    let id = snap.id_of(&key.0)?;
    snap.own_values(id)
        .into_iter()
        .find(|(a, _, _)| *a == key.1)
        .map(|(_, p, _)| p)
}

fn refused(state: &Mutex<State>, object: &str, attr: &str, e: &WriteError) {
    state.lock().stats.rejects.invalid += 1;
    tracing::debug!(%object, %attr, error = %e, "write refused");
}

fn delete(board: &Board, state: &Mutex<State>, object: &str, owner: &Address) {
    if board
        .info(object)
        .is_none_or(|i| i.is_class || i.owner != *owner)
    {
        return;
    }
    if board.delete(object).is_ok() {
        state.lock().stats.merges.deleted += 1;
    }
}

/// Deletes a forgotten peer's `Module` object (if it is one: a name is not proof).
fn forget_module(board: &Board, peer: &Address) {
    let name = module_object_name(peer);
    if board.info(&name).is_some_and(|i| &*i.class == MODULE_CLASS) {
        let _ = board.delete(&name);
    }
}

/// Creates (if need be) and writes a peer's `Module` object in one batch. `alive` is
/// written only when it changes: plans that read it (a robot's liveliness is derived from
/// its modules') are evaluated again on every write of it, and a refresh while the peer
/// lives changes only `last_seen`.
fn module(board: &Board, peer: &Address, alive: bool, last_seen: Duration) {
    let name = module_object_name(peer);
    let context = match LinkKind::between(board.address(), peer) {
        LinkKind::Robot => Context::Self_,
        LinkKind::Team => Context::System,
    };
    // One read says both whether the object is there and what it holds (a lookup of
    // the object's info too cost as much again, for every peer heard).
    let held = board.read(&name, "alive");
    let mut batch = board.batch();
    if matches!(held, Err(ReadError::UnknownObject(_))) {
        batch.create_with(NewObject::new(MODULE_CLASS, &name).context(context));
        batch.write(&name, "address", peer.as_str());
    }
    let unchanged = held.is_ok_and(|p| p.value == Value::Bool(alive));
    if !unchanged {
        batch.write(&name, "alive", alive);
    }
    batch.write(&name, "last_seen", last_seen.as_secs_f64());
    if let Err(e) = batch.commit() {
        tracing::warn!(module = %peer, error = %e, "module object not written");
    }
}
