//! Active functions: code attached to an attribute that runs when it is read or written.

use std::fmt;
use std::sync::Arc;
use std::time::Duration;

use crate::board::{Access, Chain};
use crate::{Key, LookupError, ObjectId, Packet, ReadError, Update, Value, WriteError};

/// When an active function runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Trigger {
    /// When the attribute is read; the function may change the packet returned.
    Read,
    /// After a new packet was stored (and watchers were notified).
    Write,
}

impl fmt::Display for Trigger {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Trigger::Read => "read",
            Trigger::Write => "write",
        })
    }
}

/// Why an active function failed. Failures are reported as
/// [`BoardEvent::FunctionFailed`](crate::BoardEvent::FunctionFailed); they never undo
/// the write that triggered the function nor stop the functions after it.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FnError {
    /// A read inside the function failed.
    #[error(transparent)]
    Read(#[from] ReadError),
    /// A write inside the function failed.
    #[error(transparent)]
    Write(#[from] WriteError),
    /// A lookup inside the function failed.
    #[error(transparent)]
    Lookup(#[from] LookupError),
    /// The function's own error.
    #[error("{0}")]
    Message(String),
}

impl From<&str> for FnError {
    fn from(m: &str) -> Self {
        FnError::Message(m.to_owned())
    }
}

impl From<String> for FnError {
    fn from(m: String) -> Self {
        FnError::Message(m)
    }
}

/// An active function. Native closures get one through
/// [`Board::on_read`](crate::Board::on_read) / [`Board::on_write`](crate::Board::on_write);
/// declarative functions of the slate language implement this trait themselves.
pub trait ActiveFn: Send + Sync {
    /// A name for reports and events.
    fn name(&self) -> &str;
    /// Runs the function.
    fn call(&self, call: &mut Call<'_>) -> Result<(), FnError>;
    /// Is this an on-read function whose packet follows from the packet it is given and
    /// what it reads through its `Call` alone ([`Call::read`], [`Call::instances`],
    /// [`Call::name_of`], [`Call::exists`], and the clock through [`Call::now`]), with no
    /// other effect? Then the board keeps the packet it returns and serves later reads
    /// from it, until one of the attributes it read is stored again, an object, class or
    /// function is added or removed, or (if it read the clock) the clock moves. The
    /// language's derived attributes are. Default: `false`, run at every read.
    fn pure(&self) -> bool {
        false
    }
}

/// A closure with a name.
pub(crate) struct NativeFn<F> {
    pub(crate) name: String,
    pub(crate) f: F,
}

impl<F> ActiveFn for NativeFn<F>
where
    F: Fn(&mut Call<'_>) -> Result<(), FnError> + Send + Sync,
{
    fn name(&self) -> &str {
        &self.name
    }
    fn call(&self, call: &mut Call<'_>) -> Result<(), FnError> {
        (self.f)(call)
    }
}

/// A shared active function.
pub type FnRef = Arc<dyn ActiveFn>;

/// What an active function sees and may do while it runs.
pub struct Call<'a> {
    pub(crate) access: Access<'a>,
    pub(crate) chain: &'a Chain,
    pub(crate) trigger: Trigger,
    pub(crate) key: Key,
    pub(crate) object: Arc<str>,
    pub(crate) attr: Arc<str>,
    pub(crate) packet: Packet,
    pub(crate) previous: Option<Packet>,
    pub(crate) revision: u64,
}

impl Call<'_> {
    /// Why the function runs.
    pub fn trigger(&self) -> Trigger {
        self.trigger
    }

    /// Name of the object whose attribute was accessed.
    pub fn object(&self) -> &str {
        &self.object
    }

    /// Handle of that object.
    pub fn object_id(&self) -> ObjectId {
        self.key.object
    }

    /// Name of the attribute.
    pub fn attr(&self) -> &str {
        &self.attr
    }

    /// On write: the packet stored. On read: the packet to be returned so far.
    pub fn packet(&self) -> &Packet {
        &self.packet
    }

    /// On write: the object's own packet before the write (`None` if it had none and
    /// read through its class). On read: `None`.
    pub fn previous(&self) -> Option<&Packet> {
        self.previous.as_ref()
    }

    /// On write: the board revision of the write.
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// On read: replaces the packet returned (checked against the declaration).
    /// On write this changes nothing stored; write the attribute instead.
    pub fn set_packet(&mut self, packet: Packet) {
        self.packet = packet;
    }

    /// On read: replaces the value returned, keeping the other fields.
    pub fn set_value(&mut self, value: impl Into<Value>) {
        self.packet.value = value.into();
    }

    /// The board's physical time now (since the Unix epoch). A pure function
    /// ([`ActiveFn::pure`]) reads the clock through this: what it returns is then kept
    /// only while the clock shows this time.
    pub fn now(&self) -> Duration {
        let board = self.access.board();
        let at = board.clock().physical();
        crate::board::note_time(board.id(), at);
        at
    }

    /// Reads another attribute (running its on-read functions, within the chain limits).
    pub fn read(&self, object: &str, attr: &str) -> Result<Packet, ReadError> {
        self.access.read(object, attr, self.chain)
    }

    /// Writes an attribute (running its on-write functions, within the chain limits).
    /// Not allowed inside a snapshot.
    pub fn write(
        &self,
        object: &str,
        attr: &str,
        update: impl Into<Update>,
    ) -> Result<u64, WriteError> {
        self.access.write(object, attr, update.into(), self.chain)
    }

    /// The instances of a class (including subclasses).
    pub fn instances(&self, class: &str) -> Result<Vec<ObjectId>, LookupError> {
        self.access.instances(class)
    }

    /// The name of an object.
    pub fn name_of(&self, id: ObjectId) -> Option<Arc<str>> {
        self.access.name_of(id)
    }

    /// Does an object or class of that name exist?
    pub fn exists(&self, name: &str) -> bool {
        self.access.exists(name)
    }

    /// An owned token of this function's place in its chain, for code that cannot hold
    /// the `Call` (another language's runtime): [`Board::read_as`](crate::Board::read_as)
    /// and [`Board::write_as`](crate::Board::write_as) with it run inside the chain, as
    /// [`read`](Call::read) and [`write`](Call::write) do. `None` inside a snapshot,
    /// where every access must go through the `Call` (the snapshot holds the board).
    pub fn token(&self) -> Option<CallToken> {
        match self.access {
            Access::Live(board) => Some(CallToken {
                chain: self.chain.clone(),
                board: board.id(),
            }),
            Access::Frozen(_) => None,
        }
    }
}

/// An active function's place in its chain of active functions, owned: see
/// [`Call::token`]. Use it only while the function runs (afterwards its chain no longer
/// exists, and accesses with it may be cut as cycles that are not), and only on the board
/// that ran the function (on another it is no chain at all).
#[derive(Clone, Debug)]
pub struct CallToken {
    pub(crate) chain: Chain,
    /// The [`Board::id`](crate::Board) of the board that took it.
    pub(crate) board: u64,
}
