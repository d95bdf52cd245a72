//! Watching a board: change notifications, revision cursors and board events.

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use parking_lot::{Condvar, Mutex};

use super::state::State;
use crate::{Address, AttrId, ChainError, ObjectId, Packet, Trigger};

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
///
/// Writers hand changes over in batches: a commit appends its items to the watch's queue
/// (no allocation once the queue has grown, and a wake-up only when the reader sleeps),
/// and the reader takes everything waiting at once, then hands it out change by change.
/// A reader that finds nothing looks again for a microsecond or so before it sleeps, so
/// a busy board's writers seldom pay a wake-up; a sleeping reader is woken by the very
/// write that gives it something (no timer, no added latency).
#[derive(Debug)]
pub struct Watch {
    shared: Arc<Shared>,
    /// The batch the reader took last, handed out change by change.
    taken: Mutex<Batch>,
    cursor: Cursor,
}

impl Watch {
    /// The next change, waiting as long as it takes (`None` once the board is gone).
    pub fn recv(&self) -> Option<Change> {
        self.take(Wait::Forever)
    }

    /// The next change, waiting at most `timeout`.
    pub fn recv_timeout(&self, timeout: Duration) -> Option<Change> {
        self.take(Wait::Until(Instant::now() + timeout))
    }

    /// The next change if one is waiting.
    pub fn try_recv(&self) -> Option<Change> {
        self.take(Wait::No)
    }

    /// Hands out the next change of the batch taken, else takes the next batch.
    fn take(&self, wait: Wait) -> Option<Change> {
        let mut taken = self.taken.lock();
        if taken.changes.is_empty() {
            let shared = &*self.shared;
            let mut queue = shared.queue.lock();
            let mut looked = false;
            while queue.waiting.changes.is_empty() {
                if queue.closed {
                    return None;
                }
                let deadline = match wait {
                    Wait::No => return None,
                    Wait::Forever => None,
                    Wait::Until(deadline) => Some(deadline),
                };
                // Awake, the reader costs a writer no system call: it looks again a few
                // times before it sleeps (the next change of a busy board is usually a
                // microsecond away), then sleeps until a writer wakes it.
                if !looked {
                    looked = true;
                    drop(queue);
                    let posted = shared.look_again(deadline);
                    queue = shared.queue.lock();
                    if posted {
                        continue;
                    }
                }
                queue.sleeping = true;
                let timed_out = match deadline {
                    None => {
                        shared.ready.wait(&mut queue);
                        false
                    }
                    Some(deadline) => shared.ready.wait_until(&mut queue, deadline).timed_out(),
                };
                queue.sleeping = false;
                if timed_out && queue.waiting.changes.is_empty() {
                    return None;
                }
            }
            // The emptied buffers go back to the writers, who fill them again without
            // allocating.
            std::mem::swap(&mut queue.waiting, &mut *taken);
            shared.posted.store(false, Ordering::Relaxed);
        }
        let (revision, n) = taken.changes.pop_front()?;
        let items = taken.items.drain(..n).collect();
        self.cursor.advance(revision);
        Some(Change { revision, items })
    }

    /// A cursor a writer can wait on until this watch's reader has seen its write.
    pub fn cursor(&self) -> Cursor {
        self.cursor.clone()
    }

    /// Changes waiting to be received.
    pub fn pending(&self) -> usize {
        let taken = self.taken.lock().changes.len();
        taken + self.shared.queue.lock().waiting.changes.len()
    }

    /// Changes not delivered because a bounded watch was full (see
    /// [`Board::watch_bounded`](crate::Board::watch_bounded)).
    pub fn dropped(&self) -> u64 {
        self.shared.dropped.load(Ordering::Relaxed)
    }
}

impl Drop for Watch {
    fn drop(&mut self) {
        // The writers see it at their next change and forget the watcher.
        let mut queue = self.shared.queue.lock();
        queue.closed = true;
        queue.waiting = Batch::default();
    }
}

impl Iterator for Watch {
    type Item = Change;
    fn next(&mut self) -> Option<Change> {
        self.recv()
    }
}

/// How long [`Watch::take`] waits for a batch.
#[derive(Clone, Copy)]
enum Wait {
    No,
    Forever,
    Until(Instant),
}

/// Changes, as their items in order and, per change, its revision and how many items it
/// holds: one buffer for all, not one allocation per change.
#[derive(Debug, Default)]
struct Batch {
    items: VecDeque<ChangeItem>,
    changes: VecDeque<(u64, usize)>,
}

/// What waits for the reader.
#[derive(Debug, Default)]
struct Queue {
    waiting: Batch,
    /// The reader waits on [`Shared::ready`]: the next change wakes it.
    sleeping: bool,
    /// The reader or the board is gone.
    closed: bool,
}

/// What a watch's writers (the board) and its reader share.
#[derive(Debug)]
struct Shared {
    queue: Mutex<Queue>,
    ready: Condvar,
    /// Something waits in `queue`: what the reader looks at before it sleeps, without
    /// taking the lock (set by the writers, cleared by the reader when it takes a batch).
    posted: AtomicBool,
    /// At most this many changes wait in `queue` (the reader's batch taken aside).
    capacity: Option<usize>,
    /// Changes a bounded watch had no room for (always 0 for an unbounded one).
    dropped: AtomicU64,
}

impl Shared {
    /// Looks for a change posted, spinning a little (255 pause instructions in all: a
    /// microsecond to a few, depending on the processor, about what a writer's wake-up
    /// of a sleeping reader costs), until `deadline` at the latest: true if one was.
    fn look_again(&self, deadline: Option<Instant>) -> bool {
        for step in 0..SPINS {
            if self.posted.load(Ordering::Acquire) {
                return true;
            }
            if deadline.is_some_and(|d| Instant::now() >= d) {
                return false;
            }
            for _ in 0..1u32 << step {
                std::hint::spin_loop();
            }
        }
        self.posted.load(Ordering::Acquire)
    }
}

/// Looks of [`Shared::look_again`], each spinning twice as long as the one before.
const SPINS: u32 = 8;

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
    shared: Arc<Shared>,
}

impl Watcher {
    /// Hands a change (the `items` of `revision`) to the reader without ever waiting: a
    /// full bounded watch drops it and counts it. False once the reader is gone (the
    /// watcher is then removed).
    pub fn offer(&self, revision: u64, items: impl IntoIterator<Item = ChangeItem>) -> bool {
        let shared = &*self.shared;
        let mut queue = shared.queue.lock();
        if queue.closed {
            return false;
        }
        let waiting = &mut queue.waiting;
        if shared.capacity.is_some_and(|n| waiting.changes.len() >= n) {
            shared.dropped.fetch_add(1, Ordering::Relaxed);
            return true;
        }
        let before = waiting.items.len();
        waiting.items.extend(items);
        let n = waiting.items.len() - before;
        waiting.changes.push_back((revision, n));
        // Written once per batch, not per change: the reader reads it while it looks.
        if !shared.posted.load(Ordering::Relaxed) {
            shared.posted.store(true, Ordering::Release);
        }
        if std::mem::take(&mut queue.sleeping) {
            drop(queue);
            shared.ready.notify_one();
        }
        true
    }
}

impl Drop for Watcher {
    /// The board is gone: a waiting reader gets what is left, then `None`.
    fn drop(&mut self) {
        self.shared.queue.lock().closed = true;
        self.shared.ready.notify_all();
    }
}

/// Creates a watcher and the watch its reader holds; `capacity` bounds the changes
/// waiting (`None`: unbounded).
pub(crate) fn subscribe(spec: Spec, capacity: Option<usize>) -> (Watcher, Watch) {
    let shared = Arc::new(Shared {
        queue: Mutex::new(Queue::default()),
        ready: Condvar::new(),
        posted: AtomicBool::new(false),
        capacity,
        dropped: AtomicU64::new(0),
    });
    let watch = Watch {
        shared: shared.clone(),
        taken: Mutex::new(Batch::default()),
        cursor: Cursor::default(),
    };
    (Watcher { spec, shared }, watch)
}
