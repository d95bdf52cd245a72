//! Active-function dispatch: attaching functions to attributes, running the on-write ones
//! after a commit and the on-read ones after a read (both outside the board's lock, each
//! isolated so that its error or panic becomes an event), reading and writing as a function
//! through its token, and the access a function is given (the live board or a snapshot).

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;
use std::sync::atomic::Ordering;

use super::kept::{self, Recording};
use super::state::{Decl, State};
use super::txn::Committed;
use super::{Board, BoardEvent, Chain, Query, Running, Snapshot, Target};
use crate::active::{FnRef, NativeFn};
use crate::packet::check_value;
use crate::{
    ActiveFn, Call, ChainError, FnError, Key, LookupError, ObjectId, Packet, ReadError, Trigger,
    Update, WriteError,
};

impl Board {
    /// Attaches a native function run when `target.attr` is read. On a class it applies
    /// to every instance and subclass, including ones created later.
    pub fn on_read<F>(&self, target: &str, attr: &str, f: F) -> Result<(), LookupError>
    where
        F: Fn(&mut Call<'_>) -> Result<(), FnError> + Send + Sync + 'static,
    {
        self.attach_native(target, attr, Trigger::Read, f)
    }

    /// Attaches a native function run after `target.attr` is written.
    pub fn on_write<F>(&self, target: &str, attr: &str, f: F) -> Result<(), LookupError>
    where
        F: Fn(&mut Call<'_>) -> Result<(), FnError> + Send + Sync + 'static,
    {
        self.attach_native(target, attr, Trigger::Write, f)
    }

    /// Attaches `f` as a native function, named after where it runs and its number.
    fn attach_native<F>(
        &self,
        target: &str,
        attr: &str,
        trigger: Trigger,
        f: F,
    ) -> Result<(), LookupError>
    where
        F: Fn(&mut Call<'_>) -> Result<(), FnError> + Send + Sync + 'static,
    {
        let n = self.fn_seq.fetch_add(1, Ordering::Relaxed);
        let native: FnRef = Arc::new(NativeFn {
            name: format!("{target}.{attr} on {trigger} #{n}"),
            f,
        });
        self.attach(target, attr, trigger, native)
    }

    /// Attaches any active function (native or declarative) to `target.attr`. Functions
    /// run in order: inherited ones ancestor-first, then the object's own, each in the
    /// order attached.
    pub fn attach(
        &self,
        target: &str,
        attr: &str,
        trigger: Trigger,
        f: Arc<dyn ActiveFn>,
    ) -> Result<(), LookupError> {
        let mut inner = self.inner.write();
        let key = inner.state.key(target, attr)?;
        inner.state.attach(key, trigger, f);
        Ok(())
    }

    /// Detaches a function attached with [`Board::attach`] (the same `Arc`), as a load
    /// that fails half-way takes back what it attached. Returns whether it was attached.
    pub fn detach(
        &self,
        target: &str,
        attr: &str,
        trigger: Trigger,
        f: &Arc<dyn ActiveFn>,
    ) -> Result<bool, LookupError> {
        let mut inner = self.inner.write();
        let key = inner.state.key(target, attr)?;
        Ok(inner.state.detach(key, trigger, f))
    }

    /// After a commit, outside the lock: runs the on-write functions, then the change
    /// hooks. Returns the committed revision.
    pub(crate) fn finish(&self, done: Committed, chain: &Chain) -> u64 {
        let Committed {
            revision,
            fired,
            touched,
            hooks,
        } = done;
        let chain = &*chain.or_running(self.id());
        for f in fired {
            // A write admitted its key already; a batch's writes are admitted here.
            let names = || (f.object.clone(), f.attr.clone());
            if let Err(cut) = chain.admit(f.key, Trigger::Write, self.max_depth, names) {
                self.report(BoardEvent::ChainCut(cut));
                continue;
            }
            let chain = chain.with(f.key, Trigger::Write, &f.object, &f.attr);
            let mut call = Call {
                access: Access::Live(self),
                chain: &chain,
                trigger: Trigger::Write,
                key: f.key,
                object: f.object,
                attr: f.attr,
                packet: f.packet,
                previous: f.previous,
                revision,
            };
            for func in &f.fns {
                self.run_isolated(func.as_ref(), &mut call);
            }
        }
        // A hook is no active function: what it does starts chains of its own.
        let _outside = Running::enter(self.id(), &Chain::default());
        for hook in hooks.iter().flat_map(|h| h.iter()) {
            hook.changed(self, revision, &touched);
        }
        revision
    }

    /// Runs one function; an error or a panic becomes an event, never a failure of the
    /// access that triggered it.
    fn run_isolated(&self, func: &dyn ActiveFn, call: &mut Call<'_>) -> bool {
        let running = Running::enter(self.id(), call.chain);
        let outcome = catch_unwind(AssertUnwindSafe(|| func.call(call)));
        drop(running);
        let error = match outcome {
            Ok(Ok(())) => return true,
            Ok(Err(e)) => e.to_string(),
            Err(panic) => format!("panicked: {}", panic_message(panic.as_ref())),
        };
        self.report(BoardEvent::FunctionFailed {
            function: func.name().to_owned(),
            object: call.object.to_string(),
            attr: call.attr.to_string(),
            trigger: call.trigger,
            error,
            suppressed: 0,
        });
        false
    }

    /// Reads as an active function of this board would through its `Call`: inside the
    /// chain the token was taken in ([`Call::token`](crate::Call::token)).
    pub fn read_as(
        &self,
        token: &crate::CallToken,
        object: &str,
        attr: &str,
    ) -> Result<Packet, ReadError> {
        self.read_in(Target::Names(object, attr), self.chain_of(token)?)
    }

    /// Writes as an active function of this board would through its `Call`: inside the
    /// chain the token was taken in ([`Call::token`](crate::Call::token)).
    pub fn write_as(
        &self,
        token: &crate::CallToken,
        object: &str,
        attr: &str,
        update: impl Into<Update>,
    ) -> Result<u64, WriteError> {
        self.write_in(
            Target::Names(object, attr),
            update.into(),
            self.chain_of(token)?,
        )
    }

    /// The token's chain (borrowed: a binding reads and writes through tokens often).
    /// A token of another board is refused: its chain says nothing of this board's
    /// accesses, and an empty chain in its place would let a cycle through two boards
    /// run without limit.
    fn chain_of<'t>(&self, token: &'t crate::CallToken) -> Result<&'t Chain, ChainError> {
        if token.board == self.id {
            Ok(&token.chain)
        } else {
            Err(ChainError::ForeignToken)
        }
    }
}

/// A read whose on-read functions still have to run, outside the lock.
pub(crate) struct PendingRead {
    key: Key,
    packet: Packet,
    decl: Arc<Decl>,
    fns: Vec<FnRef>,
    object: Arc<str>,
    attr: Arc<str>,
    keep: Keep,
}

/// Whether a read's result may be kept ([`Kept`](super::kept::Kept)).
enum Keep {
    /// A function is not pure: run them all, keep nothing.
    No,
    /// Every function is pure, and their packet is kept: serve it (the serial of a
    /// packet that holds whatever the time).
    Kept(Packet, Option<u64>),
    /// Every function is pure: run them, and keep their packet unless the state changed
    /// since this epoch.
    Compute(u64),
}

impl PendingRead {
    /// `Ok(Ok(packet))` when no function applies (the common case), else the pending read.
    pub(super) fn new(
        board: &Board,
        st: &State,
        target: Target<'_>,
    ) -> Result<Result<Packet, PendingRead>, ReadError> {
        let key = target.resolve(st)?;
        kept::note_read(board.id(), key);
        if let Some(packet) = st.read_own(key) {
            return Ok(Ok(packet.clone()));
        }
        let r = st.resolve(key)?;
        let fns = if r.read_fns {
            st.fns(key, Trigger::Read)
        } else {
            Vec::new()
        };
        if fns.is_empty() {
            return Ok(Ok(r.packet.clone()));
        }
        let keep = if fns.iter().all(|f| f.pure()) {
            match st.kept.get(key, board.clock()) {
                Some((packet, serial)) => Keep::Kept(packet, serial),
                None => Keep::Compute(st.kept.epoch()),
            }
        } else {
            Keep::No
        };
        let (packet, decl) = (r.packet, r.decl);
        let object = st.name(key.object).unwrap_or_else(|| "?".into());
        Ok(Err(PendingRead {
            key,
            packet: packet.clone(),
            decl: decl.clone(),
            fns,
            object,
            attr: st.attr_name(key.attr),
            keep,
        }))
    }

    pub(super) fn finish(
        self,
        board: &Board,
        access: Access<'_>,
        chain: &Chain,
    ) -> Result<Packet, ReadError> {
        let chain = &*chain.or_running(board.id());
        let names = || (self.object.clone(), self.attr.clone());
        if let Err(cut) = chain.admit(self.key, Trigger::Read, board.max_depth, names) {
            kept::note_functions(board.id(), self.key, None);
            board.report(BoardEvent::ChainCut(cut.clone()));
            return Err(cut.into());
        }
        let epoch = match self.keep {
            // The functions ran nothing else and read no attribute with functions of its
            // own: once this read is admitted, running them again changes nothing.
            Keep::Kept(packet, serial) => {
                kept::note_functions(board.id(), self.key, serial);
                return Ok(packet);
            }
            Keep::Compute(epoch) => Some(epoch),
            Keep::No => {
                kept::note_functions(board.id(), self.key, None);
                None
            }
        };
        let recording = epoch.map(|_| Recording::start(board.id()));
        let mut all_ran = true;
        let chain = chain.with(self.key, Trigger::Read, &self.object, &self.attr);
        let mut call = Call {
            access,
            chain: &chain,
            trigger: Trigger::Read,
            key: self.key,
            object: self.object,
            attr: self.attr,
            packet: self.packet,
            previous: None,
            revision: 0,
        };
        for func in &self.fns {
            let before = call.packet.clone();
            let ran = board.run_isolated(func.as_ref(), &mut call);
            all_ran &= ran;
            if ran && !call.packet.value.is_none() {
                let d = &self.decl.decl;
                if let Err(e) = check_value(&call.packet.value, d.ty, d.bounds) {
                    all_ran = false;
                    board.report(BoardEvent::FunctionFailed {
                        function: func.name().to_owned(),
                        object: call.object.to_string(),
                        attr: call.attr.to_string(),
                        trigger: Trigger::Read,
                        error: format!("returned an invalid packet: {e}"),
                        suppressed: 0,
                    });
                    call.packet = before;
                }
            }
        }
        let reads = recording.and_then(Recording::stop);
        let mut serial = None;
        if let (Some(reads), Some(epoch), true) = (reads, epoch, all_ran) {
            let packet = call.packet.clone();
            call.access
                .with_state(|st| serial = st.kept.keep(self.key, packet, reads, epoch));
        }
        kept::note_functions(board.id(), self.key, serial);
        Ok(call.packet)
    }
}

/// Where an active function reads and writes: the live board, or a held snapshot.
pub(crate) enum Access<'a> {
    Live(&'a Board),
    Frozen(&'a Snapshot<'a>),
}

impl Access<'_> {
    /// The board read or written.
    pub fn board(&self) -> &Board {
        match self {
            Access::Live(b) => b,
            Access::Frozen(s) => s.board(),
        }
    }

    /// Runs `f` on the board's state (a snapshot holds it already).
    fn with_state(&self, f: impl FnOnce(&State)) {
        match self {
            Access::Live(b) => f(&b.inner.read().state),
            Access::Frozen(s) => f(s.state()),
        }
    }

    pub fn read(&self, object: &str, attr: &str, chain: &Chain) -> Result<Packet, ReadError> {
        match self {
            Access::Live(b) => b.read_in(Target::Names(object, attr), chain),
            Access::Frozen(s) => s.read_in(Target::Names(object, attr), chain),
        }
    }

    pub fn write(
        &self,
        object: &str,
        attr: &str,
        update: Update,
        chain: &Chain,
    ) -> Result<u64, WriteError> {
        match self {
            Access::Live(b) => b.write_in(Target::Names(object, attr), update, chain),
            Access::Frozen(_) => Err(WriteError::ReadOnly),
        }
    }

    pub fn instances(&self, class: &str) -> Result<Vec<ObjectId>, LookupError> {
        match self {
            Access::Live(b) => b.instances(class),
            Access::Frozen(s) => s.query(&Query::class(class)),
        }
    }

    pub fn name_of(&self, id: ObjectId) -> Option<Arc<str>> {
        match self {
            Access::Live(b) => b.name_of(id),
            Access::Frozen(s) => s.name_of(id),
        }
    }

    pub fn exists(&self, name: &str) -> bool {
        match self {
            Access::Live(b) => b.info(name).is_some(),
            Access::Frozen(s) => s.exists(name),
        }
    }
}

fn panic_message(panic: &(dyn std::any::Any + Send)) -> String {
    panic
        .downcast_ref::<&str>()
        .map(|s| (*s).to_owned())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".to_owned())
}

impl From<ChainError> for FnError {
    fn from(e: ChainError) -> Self {
        FnError::Write(WriteError::Chain(e))
    }
}
