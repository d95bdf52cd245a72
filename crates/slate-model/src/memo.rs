//! `NameMemo`: values remembered per `(object, attribute)` name pair by the names'
//! allocations. Not part of the world model's API beside `Board`: it is support for
//! crates that keep per-attribute state about a board's changes (the wire encoder's
//! dictionary, the ICI's streams), which is why it is public, in a module of its own.

use std::sync::Arc;

use rustc_hash::FxHashMap;

/// A name's identity: the address of its `Arc`. It stands for the name only while that
/// `Arc` lives, so only [`NameMemo`], which holds the `Arc`s it is keyed by, uses it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct NameId(usize);

impl NameId {
    /// The identity of `name`.
    fn of(name: &Arc<str>) -> NameId {
        NameId(Arc::as_ptr(name).cast::<u8>() as usize)
    }
}

/// Values remembered per `(object, attribute)` by the identity of the two names, not
/// their text: a board hands out one `Arc<str>` per object and attribute name (in change
/// items, infos and snapshots), and so does a wire decoder per source, so a lookup
/// neither hashes nor compares text. Each entry holds the two `Arc`s it is keyed by, so
/// their addresses cannot be reused while it is there: the same text in another
/// allocation is a miss, never a wrong hit. Past [`NameMemo::MAX`] entries the memo
/// starts afresh.
#[derive(Debug)]
pub struct NameMemo<V> {
    entries: FxHashMap<(NameId, NameId), Pinned<V>>,
}

/// A value with the two names it is remembered for (holding them pins their addresses).
type Pinned<V> = (Arc<str>, Arc<str>, V);

impl<V> Default for NameMemo<V> {
    fn default() -> Self {
        NameMemo {
            entries: FxHashMap::default(),
        }
    }
}

impl<V> NameMemo<V> {
    /// Entries remembered at most.
    pub const MAX: usize = 1 << 16;

    /// What is remembered for these two names (these allocations of them).
    pub fn get(&self, object: &Arc<str>, attr: &Arc<str>) -> Option<&V> {
        let key = (NameId::of(object), NameId::of(attr));
        self.entries.get(&key).map(|(_, _, v)| v)
    }

    /// Remembers `value` for these two names.
    pub fn insert(&mut self, object: &Arc<str>, attr: &Arc<str>, value: V) {
        if self.entries.len() >= Self::MAX {
            self.entries.clear();
        }
        let key = (NameId::of(object), NameId::of(attr));
        self.entries
            .insert(key, (object.clone(), attr.clone(), value));
    }

    /// Forgets everything.
    pub fn clear(&mut self) {
        self.entries.clear();
    }

    /// How many entries there are.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Is nothing remembered?
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
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

    #[test]
    fn a_memo_hits_the_same_allocations_only_and_starts_afresh_when_full() {
        let (gsr, speed): (Arc<str>, Arc<str>) = ("gsr".into(), "speed".into());
        let mut memo = NameMemo::default();
        memo.insert(&gsr, &speed, 1);
        assert_eq!(memo.get(&gsr.clone(), &speed.clone()), Some(&1));
        assert_eq!(
            memo.get(&"gsr".into(), &speed),
            None,
            "same text, other Arc"
        );
        assert_eq!(memo.get(&speed, &gsr), None, "the pair is ordered");
        let names: Vec<Arc<str>> = (0..NameMemo::<u8>::MAX)
            .map(|i| i.to_string().into())
            .collect();
        for n in &names[1..] {
            memo.insert(n, &speed, 2);
        }
        assert_eq!(memo.len(), NameMemo::<u8>::MAX);
        memo.insert(&names[0], &speed, 3);
        assert_eq!(
            (memo.len(), memo.get(&gsr, &speed)),
            (1, None),
            "started afresh"
        );
    }
}
