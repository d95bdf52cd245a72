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

impl ObjectId {
    /// The handle as one number (for caches; a stale or forged one fails every lookup).
    pub fn to_bits(self) -> u64 {
        u64::from(self.index) << 32 | u64::from(self.generation)
    }

    /// A handle from [`ObjectId::to_bits`].
    pub fn from_bits(bits: u64) -> Self {
        ObjectId {
            index: (bits >> 32) as u32,
            generation: bits as u32,
        }
    }
}

/// A board-local small integer standing for an attribute name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct AttrId(pub(crate) u32);

impl AttrId {
    /// The id as a number (for caches).
    pub fn to_bits(self) -> u32 {
        self.0
    }

    /// An id from [`AttrId::to_bits`] (an unknown one fails every lookup).
    pub fn from_bits(bits: u32) -> Self {
        AttrId(bits)
    }
}

/// A resolved `object.attribute`: the fastest way to read and write one attribute
/// repeatedly. Get one with [`Board::key`](crate::Board::key).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Key {
    /// The object (or class).
    pub object: ObjectId,
    /// The attribute.
    pub attr: AttrId,
}
