//! Small handles for objects and attribute names.

use std::fmt;
use std::sync::Arc;

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

/// A name's identity: the address of the `Arc` a board hands out for it (one per object
/// and attribute name, in change items, infos and snapshots), to key a cache without
/// hashing or comparing the text. It stands for the name only while that `Arc` lives: a
/// cache keyed by it keeps the `Arc` in the entry, so that the address cannot be reused.
/// The same text in another allocation has another `NameId`: a miss, never a wrong hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct NameId(usize);

impl NameId {
    /// The identity of `name`.
    pub fn of(name: &Arc<str>) -> NameId {
        NameId(Arc::as_ptr(name).cast::<u8>() as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn name_ids_are_the_allocation_not_the_text() {
        let name: Arc<str> = "gsr".into();
        let again: Arc<str> = "gsr".into();
        assert_eq!(NameId::of(&name), NameId::of(&name.clone()));
        assert_ne!(NameId::of(&name), NameId::of(&again));
        let set: HashSet<NameId> = [&name, &name, &again].map(NameId::of).into();
        assert_eq!(set.len(), 2);
    }
}
