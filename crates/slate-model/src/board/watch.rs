//! Watching a board: change notifications, revision cursors and board events.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, RecvTimeoutError, TryRecvError, TrySendError};
use parking_lot::{Condvar, Mutex};

use super::state::State;
use crate::{Address, AttrId, ChainError, ObjectId, Packet, Trigger, Wake, WakingSender};

/// What to watch: changes that match every part given (an empty filter matches all).
///
/// ```
/// use slate_model::Filter;
/// let f = Filter::class("Vehicle").attr("speed");
/// # let _ = f;
/// ```
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Filter {
    pub(crate) object: Option<String>,
    pub(crate) class: Option<String>,
    pub(crate) attr: Option<String>,
    pub(crate) own_writes: bool,
}

impl Filter {
    /// Every change on the board.
    pub fn all() -> Self {
        Filter::default()
    }

    /// Changes of one object, including class-level writes to its class chain (they
    /// change what the object reads where it has no value of its own).
    pub fn object(name: &str) -> Self {
        Filter::default().and_object(name)
    }

    /// Changes of a class, its subclasses, and their instances.
    pub fn class(name: &str) -> Self {
        Filter::default().and_class(name)
    }

    /// Writes of one attribute (on any object), plus creations and deletions.
    pub fn attribute(name: &str) -> Self {
        Filter::default().attr(name)
    }

    /// Also require the object.
    pub fn and_object(mut self, name: &str) -> Self {
        self.object = Some(name.to_owned());
        self
    }

    /// Also require the class.
    pub fn and_class(mut self, name: &str) -> Self {
        self.class = Some(name.to_owned());
        self
    }

    /// Also require the attribute.
    pub fn attr(mut self, name: &str) -> Self {
        self.attr = Some(name.to_owned());
        self
    }

    /// Only the writes of packets the board wrote itself (its address is their source):
    /// not the packets it merged from others. Creations and deletions still all match.
    pub fn own_writes_only(mut self) -> Self {
        self.own_writes = true;
        self
    }
}

/// One change a revision made.
#[derive(Clone, Debug, PartialEq)]
pub enum ChangeItem {
    /// An attribute was written (on an object, or class-level on a class).
    Write {
        /// Object or class name.
        object: Arc<str>,
        /// Attribute name.
        attr: Arc<str>,
        /// The packet stored.
        packet: Packet,
    },
    /// An object was created.
    Create {
        /// Object name.
        object: Arc<str>,
        /// Its class.
        class: Arc<str>,
    },
    /// An object was deleted.
    Delete {
        /// Object name.
        object: Arc<str>,
        /// Its class.
        class: Arc<str>,
    },
}

/// The changes one revision (a write, or a whole batch) made that match a watch.
#[derive(Clone, Debug, PartialEq)]
pub struct Change {
    /// Board revision of the change.
    pub revision: u64,
    /// The matching items, in the order they were applied.
    pub items: Vec<ChangeItem>,
}

/// Something a board reports about itself (not a change of the world model).
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq)]
pub enum BoardEvent {
    /// An active function returned an error or panicked. The board is unchanged by it,
    /// and the other functions still ran. Reported at most once a second per function
    /// (a peer's writes can make one fail at will); each failure is counted
    /// ([`BoardStats::function_failures`](crate::BoardStats)).
    FunctionFailed {
        /// The function's name.
        function: String,
        /// Object accessed.
        object: String,
        /// Attribute accessed.
        attr: String,
        /// Read or write.
        trigger: Trigger,
        /// What went wrong.
        error: String,
        /// Failures of the same function since the last event of them, not reported one
        /// by one: at most one such event a second.
        suppressed: u64,
    },
    /// A chain of active functions was cut (too deep, or a cycle); the access that would
    /// have continued it was refused.
    ChainCut(ChainError),
    /// A received packet was refused: it is stamped further ahead of this board's clock
    /// than the clock tolerates (its source's clock is wrong, or this one's is). Reported
    /// at most once a second per source; each refusal is counted
    /// ([`BoardStats::future_stamps`](crate::BoardStats)).
    FutureStamp {
        /// Object the packet was for.
        object: String,
        /// Attribute the packet was for.
        attr: String,
        /// The packet's source.
        source: crate::Address,
        /// The packet's timestamp.
        stamp: crate::Timestamp,
        /// How far ahead of this board's physical time it was.
        ahead: std::time::Duration,
        /// Refusals like this one (of the same kind, from the same source) since the
        /// last event of them, not reported one by one: at most one such event a second.
        suppressed: u64,
    },
    /// Another module defines a class of this board's differently: objects of that class
    /// are not merged between the two boards (each keeps its own), until one of them
    /// changes its definition. Reported once per (module, class).
    ClassConflict {
        /// The class both define.
        class: String,
        /// The module whose definition differs.
        peer: Address,
    },
    /// Objects of another module were refused: it owns as many on this board as one
    /// module may, or all other modules together do (`total`). Reported at most once a
    /// second per owner while refusals go on.
    ObjectLimit {
        /// The module whose object was refused.
        owner: Address,
        /// The object refused.
        object: String,
        /// The bound reached.
        limit: usize,
        /// Whether the bound is the total for all other modules (else per module).
        total: bool,
        /// Refusals like this one (of the same kind, from the same source) since the
        /// last event of them, not reported one by one: at most one such event a second.
        suppressed: u64,
    },
    /// A received packet for an `owned` attribute was refused: its writer is not the
    /// object's owner (on a secured team, a member that writes what it does not own).
    /// Reported at most once a second per writer; each refusal is counted
    /// ([`BoardStats::not_owner`](crate::BoardStats)).
    NotOwner {
        /// The object.
        object: String,
        /// The attribute.
        attr: String,
        /// The packet's source.
        writer: Address,
        /// The object's owner on this board.
        owner: Address,
        /// Refusals like this one (of the same kind, from the same source) since the
        /// last event of them, not reported one by one: at most one such event a second.
        suppressed: u64,
    },
    /// A write from another module was refused: the rule of this board that decides it
    /// (`[authority] writes`, [`WriteAuthority`](crate::WriteAuthority)) does not let
    /// that module write it. A received packet (`attr` named), or an object created
    /// (`attr` is `None`). Reported at most once a second per writer; each refusal is
    /// counted ([`BoardStats::unauthorised`](crate::BoardStats)).
    Unauthorised {
        /// The object (or class) written.
        object: String,
        /// The attribute written, or `None` for the object's creation.
        attr: Option<String>,
        /// The module that wrote it.
        writer: Address,
        /// The rule that refused it, as `Class.attr may be written by PATTERNS`.
        rule: String,
        /// Refusals like this one (of the same kind, from the same source) since the
        /// last event of them, not reported one by one: at most one such event a second.
        suppressed: u64,
    },
    /// A message from `source` was refused: the names it announces would take what this
    /// board's ICI holds of that source's past the bound (`ici.max_names_per_source`).
    /// Reported at most once a second per source while refusals go on.
    NameLimit {
        /// The module whose message was refused.
        source: Address,
        /// The bound reached.
        limit: usize,
        /// Refusals like this one (of the same kind, from the same source) since the
        /// last event of them, not reported one by one: at most one such event a second.
        suppressed: u64,
    },
    /// A module this board's ICI had not heard of was refused: it keeps track of as
    /// many modules as it may. Reported at most once a second (for all addresses together:
    /// they may be made up) while refusals go on.
    ModuleLimit {
        /// The address refused.
        address: Address,
        /// The bound reached.
        limit: usize,
        /// Refusals like this one (of the same kind, from the same source) since the
        /// last event of them, not reported one by one: at most one such event a second.
        suppressed: u64,
    },
}

/// The last revision a reader has taken from a [`Watch`]; writers wait on it.
#[derive(Clone, Debug, Default)]
pub struct Cursor {
    inner: Arc<(Mutex<u64>, Condvar)>,
}

impl Cursor {
    /// The last revision seen.
    pub fn seen(&self) -> u64 {
        *self.inner.0.lock()
    }

    fn advance(&self, revision: u64) {
        let mut seen = self.inner.0.lock();
        if revision > *seen {
            *seen = revision;
            self.inner.1.notify_all();
        }
    }

    /// Waits until the reader has seen `revision` (or later); false on timeout.
    pub fn wait_for(&self, revision: u64, timeout: Duration) -> bool {
        let deadline = Instant::now() + timeout;
        let mut seen = self.inner.0.lock();
        while *seen < revision {
            if self.inner.1.wait_until(&mut seen, deadline).timed_out() {
                return *seen >= revision;
            }
        }
        true
    }
}

/// A subscription to a board's changes. Iterating blocks for the next change; dropping
/// the watch unsubscribes.
#[derive(Debug)]
pub struct Watch {
    rx: Receiver<Change>,
    cursor: Cursor,
    /// Changes a bounded watch had no room for (always 0 for an unbounded one).
    dropped: Arc<AtomicU64>,
}

impl Watch {
    /// The next change, waiting as long as it takes (`None` once the board is gone).
    pub fn recv(&self) -> Option<Change> {
        self.rx
            .recv()
            .ok()
            .inspect(|c| self.cursor.advance(c.revision))
    }

    /// The next change, waiting at most `timeout`.
    pub fn recv_timeout(&self, timeout: Duration) -> Option<Change> {
        match self.rx.recv_timeout(timeout) {
            Ok(c) => {
                self.cursor.advance(c.revision);
                Some(c)
            }
            Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => None,
        }
    }

    /// The next change if one is waiting.
    pub fn try_recv(&self) -> Option<Change> {
        match self.rx.try_recv() {
            Ok(c) => {
                self.cursor.advance(c.revision);
                Some(c)
            }
            Err(TryRecvError::Empty | TryRecvError::Disconnected) => None,
        }
    }

    /// A cursor a writer can wait on until this watch's reader has seen its write.
    pub fn cursor(&self) -> Cursor {
        self.cursor.clone()
    }

    /// Changes waiting to be received.
    pub fn pending(&self) -> usize {
        self.rx.len()
    }

    /// Changes not delivered because a bounded watch was full (see
    /// [`Board::watch_bounded`](crate::Board::watch_bounded)).
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }
}

impl Iterator for Watch {
    type Item = Change;
    fn next(&mut self) -> Option<Change> {
        self.recv()
    }
}

/// A filter with its names resolved.
#[derive(Debug)]
pub(crate) struct Spec {
    pub object: Option<ObjectId>,
    pub class: Option<ObjectId>,
    pub attr: Option<AttrId>,
    pub own_writes: bool,
}

impl Spec {
    /// Does a change of `id` (and `attr`, for writes) match?
    pub fn matches(&self, st: &State, id: ObjectId, attr: Option<AttrId>) -> bool {
        if let (Some(want), Some(got)) = (self.attr, attr)
            && want != got
        {
            return false;
        }
        if let Some(c) = self.class
            && !st.lineage(id).contains(&c)
        {
            return false;
        }
        match self.object {
            None => true,
            Some(o) if o == id => true,
            // A class-level write to a class in the object's chain changes what it reads.
            Some(o) => {
                st.get(id).is_some_and(|e| e.class_data().is_some()) && st.lineage(o).contains(&id)
            }
        }
    }
}

pub(crate) struct Watcher {
    pub spec: Spec,
    sink: Sink,
    dropped: Arc<AtomicU64>,
}

/// Where a watcher's changes go.
enum Sink {
    /// One message a change, to a [`Watch`] (`bounded` by its channel or not), with
    /// the reader's wake if it gave one ([`Board::watch_waking`](crate::Board::watch_waking)).
    Channel(WakingSender<Change>),
    /// Every item appended to the one buffer a [`Gather`] takes whole.
    Buffer(Arc<Gathered>),
}

impl Watcher {
    /// A watcher for `spec` handing changes to `sink`, and its count of changes dropped
    /// (the reader's end shares it).
    fn new(spec: Spec, sink: Sink) -> (Watcher, Arc<AtomicU64>) {
        let dropped = Arc::new(AtomicU64::new(0));
        let watcher = Watcher {
            spec,
            sink,
            dropped: dropped.clone(),
        };
        (watcher, dropped)
    }

    /// Hands a change to the reader without ever waiting: a full bounded watch drops it
    /// and counts it. False once the reader is gone (the watcher is then removed).
    pub fn offer(&self, change: Change) -> bool {
        match &self.sink {
            Sink::Channel(tx) => match tx.try_send(change) {
                Ok(()) => true,
                Err(TrySendError::Full(_)) => {
                    self.dropped.fetch_add(1, Ordering::Relaxed);
                    true
                }
                Err(TrySendError::Disconnected(_)) => false,
            },
            Sink::Buffer(shared) => shared.offer(change, &self.dropped),
        }
    }
}

/// Creates a watcher and the watch its reader holds; `capacity` bounds the changes
/// waiting (`None`: unbounded).
pub(crate) fn subscribe(
    spec: Spec,
    capacity: Option<usize>,
    wake: Option<Arc<Wake>>,
) -> (Watcher, Watch) {
    let (tx, rx) = match capacity {
        Some(n) => crossbeam_channel::bounded(n),
        None => crossbeam_channel::unbounded(),
    };
    let (watcher, dropped) = Watcher::new(spec, Sink::Channel(WakingSender::new(tx, wake)));
    let cursor = Cursor::default();
    (
        watcher,
        Watch {
            rx,
            cursor,
            dropped,
        },
    )
}

/// Creates a watcher whose items gather in one buffer of at most `capacity` items, and
/// the [`Gather`] its reader holds.
pub(crate) fn gather(spec: Spec, capacity: usize) -> (Watcher, Gather) {
    let shared = Arc::new(Gathered {
        items: Mutex::new(Vec::new()),
        ready: Condvar::new(),
        capacity,
    });
    let (watcher, dropped) = Watcher::new(spec, Sink::Buffer(shared.clone()));
    (watcher, Gather { shared, dropped })
}

/// One change item with the revision of the change it belongs to.
pub type RevisedItem = (u64, ChangeItem);

/// What a gathering watcher and its reader share.
struct Gathered {
    items: Mutex<Vec<RevisedItem>>,
    /// Signalled when an item comes to an empty buffer (the reader waits only then).
    ready: Condvar,
    capacity: usize,
}

impl Gathered {
    /// Appends a change's items to the buffer, or drops the change if they do not fit.
    /// False once the reader is gone.
    fn offer(self: &Arc<Self>, change: Change, dropped: &AtomicU64) -> bool {
        if Arc::strong_count(self) == 1 {
            return false;
        }
        let mut items = self.items.lock();
        if items.len() + change.items.len() > self.capacity {
            drop(items);
            dropped.fetch_add(1, Ordering::Relaxed);
            return true;
        }
        let was_empty = items.is_empty();
        let revision = change.revision;
        items.extend(change.items.into_iter().map(|item| (revision, item)));
        drop(items);
        if was_empty {
            self.ready.notify_one();
        }
        true
    }
}

/// A subscription to a board's changes whose reader takes everything waiting at once,
/// item by item with each item's revision, for readers that take changes in bulk and
/// must never hold the writers up (a recorder, a store). A writer appends a change's
/// items to one buffer, and the reader swaps it for an empty one of its own: the buffer's
/// blocks go back and forth, a change's own list is freed in its writer's thread, and
/// nothing a writer allocated is freed in the reader's. At most `capacity` items wait: a change that would go past it is
/// dropped and counted ([`Gather::dropped`]). Dropping it unsubscribes.
pub struct Gather {
    shared: Arc<Gathered>,
    dropped: Arc<AtomicU64>,
}

impl Gather {
    /// Waits up to `timeout` for an item; is one waiting?
    pub fn wait(&self, timeout: Duration) -> bool {
        let mut items = self.shared.items.lock();
        if items.is_empty() {
            self.shared.ready.wait_for(&mut items, timeout);
        }
        !items.is_empty()
    }

    /// Appends every waiting item to `into`, in revision order; how many. Pass the same
    /// vector, emptied, each time: its block becomes the writers' next buffer.
    pub fn take(&self, into: &mut Vec<RevisedItem>) -> usize {
        let mut items = self.shared.items.lock();
        let n = items.len();
        if into.is_empty() {
            std::mem::swap(&mut *items, into);
        } else {
            into.append(&mut items);
        }
        n
    }

    /// Items waiting to be taken.
    pub fn pending(&self) -> usize {
        self.shared.items.lock().len()
    }

    /// Changes not taken because the buffer was full.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }
}

impl std::fmt::Debug for Gather {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Gather")
            .field("pending", &self.pending())
            .field("dropped", &self.dropped())
            .finish()
    }
}
