//! Change hooks: code that reacts to every committed change synchronously, in the
//! writer's thread, after the lock is released. This is how a plan engine evaluates the
//! plans that depend on what changed without a polling loop or a channel hop.

use super::Board;
use crate::{AttrId, ObjectId};

/// What kind of change touched an object.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TouchKind {
    /// An attribute was written.
    Write,
    /// The object was created.
    Create,
    /// The object was deleted (its handle is already stale).
    Delete,
}

/// One object (or class) a committed revision touched.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Touched {
    /// The object or class.
    pub object: ObjectId,
    /// Its class (for a class: itself).
    pub class: ObjectId,
    /// The attribute written, for writes.
    pub attr: Option<AttrId>,
    /// What happened.
    pub kind: TouchKind,
}

/// Reacts to committed changes. Called once per revision with everything it touched,
/// after on-write active functions ran. A hook may read and write the board (its writes
/// are later revisions and call the hooks again: a hook must bound its own recursion).
pub trait ChangeHook: Send + Sync {
    /// A revision was committed.
    fn changed(&self, board: &Board, revision: u64, touched: &[Touched]);
}
