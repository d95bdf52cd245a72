//! Packets of pure on-read functions (the language's derived attributes), kept until what
//! they read changes.
//!
//! A pure function ([`ActiveFn::pure`](crate::ActiveFn::pure)) returns what the attributes
//! it reads through its `Call` and the clock say, and does nothing else. While one runs,
//! this thread records what it reads ([`Recording`]): every attribute (by key), and the
//! time, if it reads the clock ([`Call::now`](crate::Call::now)). Its packet is kept, and
//! served to later reads, until:
//! * one of those attributes is stored again or taken back ([`Kept::changed`]), by any
//!   path (a write, a batch, a merge, a rollback);
//! * anything else of the board changes ([`Kept::clear`]): an object or class created or
//!   deleted (what quantifiers see, what names resolve to), a class-level value (what
//!   instances inherit), an active function attached or detached;
//! * the clock shows another time, if the function read it.
//!
//! What is not kept: a packet computed while the board changed (another thread wrote
//! between the function's reads), one whose function failed, and one whose function read
//! an attribute that has on-read functions of its own (its chain of functions would no
//! longer be checked for cycles and depth if it were served from here), or read another
//! board, or read the clock at two different times. Those are computed again at every
//! read, as every on-read function was before.
//!
//! The same recording traces an evaluation outside any function ([`ReadTrace`], the plan
//! engine's conditions): the attributes it read, and for each derived attribute the
//! serial of the kept packet it was served, which stands for everything that packet read
//! (the packet is dropped when any of it changes). [`Board::unchanged_since`] then says
//! whether any of it changed. An evaluation that read the clock, or an attribute whose
//! packet is not kept, cannot be traced.
//!
//! [`Board::unchanged_since`]: crate::Board::unchanged_since

use std::cell::{Cell, RefCell};
use std::marker::PhantomData;
use std::time::Duration;

use parking_lot::Mutex;
use rustc_hash::FxHashMap;
use smallvec::SmallVec;

use crate::{Clock, Key, Packet};

/// The kept packets of one board. It lives in the board's state, so that every change of
/// the state says what it changed under the same write lock ([`Kept::changed`] and
/// [`Kept::clear`] take `&mut self`: no lock of their own); reads, which hold the state
/// only for reading, look up and keep under the mutex.
#[derive(Default)]
pub(crate) struct Kept {
    table: Mutex<Table>,
}

#[derive(Default)]
struct Table {
    /// Per attribute with pure on-read functions, its last packet.
    entries: FxHashMap<Key, Entry>,
    /// Per attribute read, the kept packets that read it (some may be gone already:
    /// dropping one more than needed is only a computation again).
    readers: FxHashMap<Key, SmallVec<[Key; 2]>>,
    /// Counts the changes of the state: a packet computed across one is not kept.
    epoch: u64,
    /// Counts the changes that drop every kept packet ([`Kept::clear`]).
    structure: u64,
    /// Numbers the packets kept: a packet kept again after a change is another one.
    serial: u64,
}

struct Entry {
    packet: Packet,
    /// The clock's physical time when it was computed, if the function read the clock.
    at: Option<Duration>,
    serial: u64,
}

/// What a pure function, or a traced evaluation ([`ReadTrace`]), read.
pub(crate) struct Reads {
    /// Which recording this is ([`Recording`]), unique on its thread.
    id: u64,
    board: u64,
    kind: Kind,
    keys: Vec<Key>,
    /// Attributes with pure functions served or computed, and the serial of their kept
    /// packet (a trace only: while the packet is kept, nothing it read changed).
    derived: Vec<(Key, u64)>,
    at: Option<Duration>,
    /// It read what cannot be followed.
    spoiled: bool,
}

/// Who records.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// A pure function: it runs in a chain of functions, and its packet is kept only if
    /// it ran no other function (see the module's documentation).
    Function,
    /// An evaluation outside any function (a plan's conditions): no chain to check, so
    /// the kept packets it is served stand for what they read.
    Trace,
}

thread_local! {
    /// The recordings of the pure functions and traces running in this thread, innermost
    /// last.
    static RECORDING: RefCell<Vec<Reads>> = const { RefCell::new(Vec::new()) };
    /// The id of the next recording started on this thread.
    static NEXT_RECORDING: Cell<u64> = const { Cell::new(0) };
}

impl Kept {
    /// `key`'s stored packet changed: the packets that read it are no longer kept. A
    /// class's packet (a class-level value) is what instances inherit: nothing is kept.
    pub fn changed(&mut self, key: Key, of_class: bool) {
        if of_class {
            return self.clear();
        }
        let t = self.table.get_mut();
        t.epoch += 1;
        if t.entries.is_empty() {
            t.readers.clear();
            return;
        }
        if let Some(readers) = t.readers.remove(&key) {
            for r in readers {
                t.entries.remove(&r);
            }
        }
    }

    /// Something other than a stored packet changed: nothing is kept.
    pub fn clear(&mut self) {
        let t = self.table.get_mut();
        t.epoch += 1;
        t.structure += 1;
        t.entries.clear();
        t.readers.clear();
    }

    /// The number of the state's changes so far, to give back to [`Kept::keep`].
    pub fn epoch(&self) -> u64 {
        self.table.lock().epoch
    }

    /// The number of changes other than stored packets so far.
    pub fn structure(&self) -> u64 {
        self.table.lock().structure
    }

    /// The packet kept for `key`, if it still holds at the clock's time, and its serial
    /// if it holds whatever the time.
    pub fn get(&self, key: Key, clock: &Clock) -> Option<(Packet, Option<u64>)> {
        let t = self.table.lock();
        let e = t.entries.get(&key)?;
        e.at.is_none_or(|at| clock.physical() == at)
            .then(|| (e.packet.clone(), e.at.is_none().then_some(e.serial)))
    }

    /// Is the packet kept for `key` still the one numbered `serial`?
    pub fn holds(&self, key: Key, serial: u64) -> bool {
        self.table
            .lock()
            .entries
            .get(&key)
            .is_some_and(|e| e.serial == serial && e.at.is_none())
    }

    /// Keeps the packet computed for `key` from `reads`, unless the state changed since
    /// `epoch` (taken before the computation) or the reads cannot be followed. Returns
    /// the serial of the packet kept, if it holds whatever the time.
    pub fn keep(&self, key: Key, packet: Packet, reads: Reads, epoch: u64) -> Option<u64> {
        let mut t = self.table.lock();
        if reads.spoiled || t.epoch != epoch {
            return None;
        }
        let Reads { mut keys, at, .. } = reads;
        // What the functions started from: the attribute's own (or inherited) packet.
        keys.push(key);
        keys.sort_unstable_by_key(|k| (k.object.to_bits(), k.attr.to_bits()));
        keys.dedup();
        for k in keys {
            let readers = t.readers.entry(k).or_default();
            if !readers.contains(&key) {
                readers.push(key);
            }
        }
        t.serial += 1;
        let serial = t.serial;
        t.entries.insert(key, Entry { packet, at, serial });
        at.is_none().then_some(serial)
    }
}

/// While it lives, this thread records what is read for one pure computation on one board.
/// It ends on the thread that started it (it is not `Send`), and ending it takes its own
/// reads off the thread's stack, with any recording started after it and not ended (a
/// [`ReadTrace`] dropped out of order, whose reads then cannot be followed): an ended
/// recording never gives another's reads, and nothing is left to collect reads for ever.
pub(crate) struct Recording {
    id: u64,
    _thread: PhantomData<*const ()>,
}

impl Recording {
    pub fn start(board: u64) -> Recording {
        Self::push(board, Kind::Function)
    }

    fn push(board: u64, kind: Kind) -> Recording {
        let id = NEXT_RECORDING.replace(NEXT_RECORDING.get() + 1);
        RECORDING.with_borrow_mut(|r| {
            r.push(Reads {
                id,
                board,
                kind,
                keys: Vec::new(),
                derived: Vec::new(),
                at: None,
                spoiled: false,
            });
        });
        Recording {
            id,
            _thread: PhantomData,
        }
    }

    /// Ends the recording and gives what was read.
    pub fn stop(self) -> Option<Reads> {
        let reads = self.take();
        std::mem::forget(self);
        reads
    }

    /// Takes this recording's reads off the stack, with whatever is above them (then
    /// spoiled: what was read meanwhile went to those); `None` if they are gone already.
    fn take(&self) -> Option<Reads> {
        RECORDING.with_borrow_mut(|r| {
            let at = r.iter().rposition(|reads| reads.id == self.id)?;
            let above = r.len() > at + 1;
            r.truncate(at + 1);
            let mut reads = r.pop()?;
            reads.spoiled |= above;
            Some(reads)
        })
    }
}

impl Drop for Recording {
    fn drop(&mut self) {
        self.take();
    }
}

/// Applies `f` to the innermost recording of this thread, if any.
fn innermost(f: impl FnOnce(&mut Reads)) {
    RECORDING.with_borrow_mut(|r| {
        if let Some(top) = r.last_mut() {
            f(top);
        }
    });
}

/// `board` read `key` (a packet without on-read functions, or the start of a read that
/// has some).
pub(crate) fn note_read(board: u64, key: Key) {
    innermost(|r| {
        if r.board == board {
            r.keys.push(key);
        } else {
            r.spoiled = true;
        }
    });
}

/// `board`'s clock was read and showed `at`. A trace does not follow time.
pub(crate) fn note_time(board: u64, at: Duration) {
    innermost(|r| {
        if r.kind == Kind::Trace || r.board != board || r.at.is_some_and(|t| t != at) {
            r.spoiled = true;
        }
        r.at = Some(at);
    });
}

/// A read of `key` on `board` is to run its on-read functions, or be served their kept
/// packet (`kept`: its serial), or was computed and kept (`kept`) or not (`None`). A
/// function reading it is not kept (its chain would not be checked); a trace follows the
/// kept packet, and cannot follow one that is not.
pub(crate) fn note_functions(board: u64, key: Key, kept: Option<u64>) {
    innermost(|r| match (r.kind, kept) {
        (Kind::Trace, Some(serial)) if r.board == board => r.derived.push((key, serial)),
        _ => r.spoiled = true,
    });
}

/// Records what this thread reads of one board while it lives: see [`Snapshot::trace`].
///
/// [`Snapshot::trace`]: crate::Snapshot::trace
pub struct ReadTrace {
    recording: Recording,
    revision: u64,
    structure: u64,
}

/// What a traced evaluation read ([`ReadTrace::stop`]), to ask the board later whether
/// any of it changed ([`Board::unchanged_since`](crate::Board::unchanged_since)).
#[derive(Clone, Debug)]
pub struct ReadSet {
    pub(crate) board: u64,
    pub(crate) revision: u64,
    pub(crate) structure: u64,
    pub(crate) keys: Vec<Key>,
    pub(crate) derived: Vec<(Key, u64)>,
}

impl ReadTrace {
    pub(crate) fn start(board: u64, revision: u64, structure: u64) -> ReadTrace {
        ReadTrace {
            recording: Recording::push(board, Kind::Trace),
            revision,
            structure,
        }
    }

    /// Ends the trace: what was read, or `None` if something read cannot be followed (an
    /// attribute whose on-read functions are not pure, or whose packet was not kept or
    /// read the clock; a read of another board).
    pub fn stop(self) -> Option<ReadSet> {
        let reads = self.recording.stop()?;
        if reads.spoiled {
            return None;
        }
        let Reads {
            board,
            mut keys,
            mut derived,
            ..
        } = reads;
        keys.sort_unstable_by_key(|k| (k.object.to_bits(), k.attr.to_bits()));
        keys.dedup();
        derived.sort_unstable_by_key(|(k, s)| (k.object.to_bits(), k.attr.to_bits(), *s));
        derived.dedup();
        Some(ReadSet {
            board,
            revision: self.revision,
            structure: self.structure,
            keys,
            derived,
        })
    }
}
