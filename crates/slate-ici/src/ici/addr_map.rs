//! A map keyed by address: walked in the addresses' order, like a `BTreeMap`, and looked
//! up by hash. Every message a module receives looks up its source (and more: `heard`,
//! the stream, the timeouts), and a `BTreeMap`'s search compares the address's text with
//! several others of the team (they share their team and robot prefixes): at 24 robots
//! those comparisons were a tenth of the simulator's time. Entries come and go rarely (a
//! module heard first, a dead one forgotten), so they sit in a vector sorted by address,
//! and an index from address to position is rebuilt when one does.

use std::borrow::Borrow;
use std::hash::Hash;
use std::ops::Range;

use rustc_hash::FxHashMap;
use slate_model::Address;

/// Values by address, in address order, with hashed lookups. `home`: the entries whose
/// address starts with a prefix set once (a module's mates), kept as a range.
pub(crate) struct AddrMap<V> {
    /// Sorted by address, each address once.
    entries: Vec<(Address, V)>,
    /// Address to its position in `entries`.
    index: FxHashMap<Address, usize>,
    /// The prefix of the home range, and the range of `entries` that starts with it.
    home_prefix: String,
    home: Range<usize>,
}

impl<V> Default for AddrMap<V> {
    fn default() -> Self {
        AddrMap {
            entries: Vec::new(),
            index: FxHashMap::default(),
            home_prefix: String::new(),
            home: 0..0,
        }
    }
}

impl<V: std::fmt::Debug> std::fmt::Debug for AddrMap<V> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_map().entries(self.iter()).finish()
    }
}

impl<V> AddrMap<V> {
    /// An empty map whose [`home`](Self::home) entries are those whose address starts
    /// with `prefix`.
    pub fn with_home(prefix: String) -> Self {
        AddrMap {
            home_prefix: prefix,
            ..AddrMap::default()
        }
    }

    pub fn len(&self) -> usize {
        self.entries.len()
    }

    #[cfg(test)]
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    fn position<Q>(&self, key: &Q) -> Option<usize>
    where
        Address: Borrow<Q>,
        Q: Hash + Eq + ?Sized,
    {
        self.index.get(key).copied()
    }

    pub fn contains_key<Q>(&self, key: &Q) -> bool
    where
        Address: Borrow<Q>,
        Q: Hash + Eq + ?Sized,
    {
        self.index.contains_key(key)
    }

    pub fn get<Q>(&self, key: &Q) -> Option<&V>
    where
        Address: Borrow<Q>,
        Q: Hash + Eq + ?Sized,
    {
        self.position(key).map(|i| &self.entries[i].1)
    }

    pub fn get_mut<Q>(&mut self, key: &Q) -> Option<&mut V>
    where
        Address: Borrow<Q>,
        Q: Hash + Eq + ?Sized,
    {
        self.position(key).map(|i| &mut self.entries[i].1)
    }

    pub fn get_key_value<Q>(&self, key: &Q) -> Option<(&Address, &V)>
    where
        Address: Borrow<Q>,
        Q: Hash + Eq + ?Sized,
    {
        self.position(key).map(|i| {
            let (a, v) = &self.entries[i];
            (a, v)
        })
    }

    /// The value of `key`, made by `make` if there is none.
    pub fn get_or_insert_with(&mut self, key: &Address, make: impl FnOnce() -> V) -> &mut V {
        let i = match self.position(key) {
            Some(i) => i,
            None => {
                let i = self.entries.partition_point(|(a, _)| a < key);
                self.entries.insert(i, (key.clone(), make()));
                self.reindex(i);
                i
            }
        };
        &mut self.entries[i].1
    }

    pub fn remove<Q>(&mut self, key: &Q) -> Option<V>
    where
        Address: Borrow<Q>,
        Q: Hash + Eq + ?Sized,
    {
        let i = self.index.remove(key)?;
        let (_, v) = self.entries.remove(i);
        self.reindex(i);
        Some(v)
    }

    /// The positions from `from` on moved: their index entries and the home range follow.
    fn reindex(&mut self, from: usize) {
        for (i, (a, _)) in self.entries.iter().enumerate().skip(from) {
            self.index.insert(a.clone(), i);
        }
        let prefix = self.home_prefix.as_str();
        if prefix.is_empty() {
            return;
        }
        let start = self.entries.partition_point(|(a, _)| a.as_str() < prefix);
        let len = self.entries[start..].partition_point(|(a, _)| a.as_str().starts_with(prefix));
        self.home = start..start + len;
    }

    /// The entries in address order.
    pub fn iter(&self) -> impl Iterator<Item = (&Address, &V)> + Clone {
        self.entries.iter().map(|(a, v)| (a, v))
    }

    /// The entries in address order, values mutable.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = (&Address, &mut V)> {
        self.entries.iter_mut().map(|(a, v)| (&*a, v))
    }

    pub fn values(&self) -> impl Iterator<Item = &V> + Clone {
        self.entries.iter().map(|(_, v)| v)
    }

    pub fn values_mut(&mut self) -> impl Iterator<Item = &mut V> {
        self.entries.iter_mut().map(|(_, v)| v)
    }

    /// The entries whose address starts with the prefix given to
    /// [`with_home`](Self::with_home), in address order (none without one).
    pub fn home(&self) -> impl Iterator<Item = (&Address, &V)> + Clone {
        self.entries[self.home.clone()].iter().map(|(a, v)| (a, v))
    }
}

impl<Q, V> std::ops::Index<&Q> for AddrMap<V>
where
    Address: Borrow<Q>,
    Q: Hash + Eq + ?Sized,
{
    type Output = V;

    fn index(&self, key: &Q) -> &V {
        self.get(key).expect("no entry for this address")
    }
}

impl<'a, V> IntoIterator for &'a AddrMap<V> {
    type Item = (&'a Address, &'a V);
    type IntoIter = std::iter::Map<
        std::slice::Iter<'a, (Address, V)>,
        fn(&'a (Address, V)) -> (&'a Address, &'a V),
    >;

    fn into_iter(self) -> Self::IntoIter {
        self.entries.iter().map(|(a, v)| (a, v))
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;

    fn addr(s: &str) -> Address {
        Address::new(s).unwrap()
    }

    /// Inserts and removals in any order leave the same entries, order and lookups as a
    /// `BTreeMap`, and the home range is the entries with its prefix.
    #[test]
    fn it_walks_and_finds_as_a_btree_map_does() {
        let names = [
            "t/r2/exec",
            "t/r10/exec",
            "t/r1/vision",
            "t/r1/exec",
            "t/base/console",
            "t/r1/prox",
            "t/r1b/exec",
            "t/r0/exec",
            "t/r1/gps",
        ];
        let mut map = AddrMap::with_home("t/r1/".to_owned());
        let mut model = BTreeMap::new();
        for (i, n) in names.iter().enumerate() {
            *map.get_or_insert_with(&addr(n), || 0) += i;
            *model.entry(addr(n)).or_insert(0) += i;
            if i % 3 == 2 {
                let gone = names[i / 2];
                assert_eq!(map.remove(gone), model.remove(gone));
            }
            let walked: Vec<_> = map.iter().map(|(a, v)| (a.clone(), *v)).collect();
            let expected: Vec<_> = model.iter().map(|(a, v)| (a.clone(), *v)).collect();
            assert_eq!(walked, expected);
            for n in names {
                assert_eq!(map.get(n), model.get(n), "{n}");
            }
            let home: Vec<_> = map.home().map(|(a, _)| a.to_string()).collect();
            let expected: Vec<_> = model
                .keys()
                .filter(|a| a.as_str().starts_with("t/r1/"))
                .map(|a| a.to_string())
                .collect();
            assert_eq!(home, expected);
        }
    }
}
