//! Small handles for objects and attribute names.

use std::fmt;

/// A handle to an object or class on one board.
///
/// Classes are objects too: they hold class-level attribute values. A handle to a
/// deleted object is stale and fails every lookup, even if the name is reused; handles are
/// local to one board (other boards know objects by name).
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ObjectId {
    pub(crate) index: u32,
    pub(crate) generation: u32,
}

impl fmt::Debug for ObjectId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "ObjectId({}v{})", self.index, self.generation)
    }
}

/// A board-local small integer standing for an attribute name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct AttrId(pub(crate) u32);

/// A resolved `object.attribute`: the fastest way to read and write one attribute
/// repeatedly. Get one with [`Board::key`](crate::Board::key).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Key {
    /// The object (or class).
    pub object: ObjectId,
    /// The attribute.
    pub attr: AttrId,
}
