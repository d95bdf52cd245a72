//! The sender's dictionary: names interned to small ids, and what has been announced.
//!
//! Every change is logged so that a failed encode rolls back completely: an entry is
//! only "announced" once the message announcing it has been produced.

use std::hash::Hash;
use std::sync::Arc;

use rustc_hash::FxHashMap;
use slate_model::memo::NameMemo;
use slate_model::{Address, Timestamp};

use crate::names::Announce;
use crate::schema::AttrSchema;
use crate::text::check_name;
use crate::{EncodeError, MAX_IDS, ObjectEntry, Schema};

/// One table: key → id, with the payload last announced for it.
#[derive(Debug)]
struct Table<K, V> {
    slots: FxHashMap<K, Slot<V>>,
    next: u32,
    /// Previous slots of the keys changed since the last commit.
    undo: Vec<(K, Option<Slot<V>>)>,
    committed_next: u32,
    /// Counts the changes to slots that were there (new payloads, rollbacks, resets):
    /// what was resolved against the table before holds while it stays the same.
    changes: u64,
}

#[derive(Clone, Debug)]
struct Slot<V> {
    id: u32,
    announced: Option<V>,
}

impl<K, V> Default for Table<K, V> {
    fn default() -> Self {
        Table {
            slots: FxHashMap::default(),
            next: 0,
            undo: Vec::new(),
            committed_next: 0,
            changes: 0,
        }
    }
}

impl<K: Hash + Eq + Clone, V: Clone + PartialEq> Table<K, V> {
    /// The id of `key`, and whether `payload` must be announced now: the key is new, was
    /// not announced since the last reset, changed, or `force` asks for it.
    fn intern(
        &mut self,
        what: &'static str,
        key: &K,
        payload: V,
        force: bool,
    ) -> Result<(u32, bool), EncodeError> {
        if let Some(slot) = self.slots.get_mut(key) {
            if !force && slot.announced.as_ref() == Some(&payload) {
                return Ok((slot.id, false));
            }
            self.undo.push((key.clone(), Some(slot.clone())));
            slot.announced = Some(payload);
            self.changes += 1;
            return Ok((slot.id, true));
        }
        crate::error::check_len(what, self.next as usize + 1, MAX_IDS)?;
        let id = self.next;
        self.next += 1;
        self.undo.push((key.clone(), None));
        let announced = Some(payload);
        self.slots.insert(key.clone(), Slot { id, announced });
        Ok((id, true))
    }

    /// The id of `key` if `payload` is what was last announced for it.
    fn known(&self, key: &K, payload: &V) -> Option<u32> {
        let slot = self.slots.get(key)?;
        (slot.announced.as_ref() == Some(payload)).then_some(slot.id)
    }

    fn commit(&mut self) {
        self.undo.clear();
        self.committed_next = self.next;
    }

    fn rollback(&mut self) {
        self.changes += 1;
        while let Some((key, old)) = self.undo.pop() {
            match old {
                Some(slot) => self.slots.insert(key, slot),
                None => self.slots.remove(&key),
            };
        }
        self.next = self.committed_next;
    }

    fn reset(&mut self) {
        self.changes += 1;
        self.slots.values_mut().for_each(|s| s.announced = None);
    }
}

/// An assertion's names resolved: ids announced, the attribute's declaration.
#[derive(Debug)]
pub(crate) struct Resolved {
    pub object: u32,
    pub attr: u32,
    pub schema: Arc<AttrSchema>,
}

/// What an assertion of `(object, attribute)` resolved to, and against what.
#[derive(Debug)]
struct Remembered {
    /// The object's entry then (another entry under the same name is resolved anew).
    entry: ObjectEntry,
    resolved: Resolved,
    /// `Schema::id` and `Dictionary::changes` then.
    schema: u64,
    changes: u64,
}

/// The sender's dictionary and epoch.
#[derive(Debug, Default)]
pub(crate) struct Dictionary {
    addrs: Table<Address, ()>,
    classes: Table<Arc<str>, u32>,
    attrs: Table<Arc<str>, ()>,
    objects: Table<Arc<str>, ObjectEntry>,
    /// Assertions resolved before, by the identity of their names: a sender reports
    /// the same attributes of the same objects over and over, and looking each name up
    /// again (hashing and comparing its text in four tables) was most of the cost.
    remembered: NameMemo<Remembered>,
    /// Timestamp epoch, whole seconds since the Unix epoch; chosen once.
    epoch: Option<u64>,
    epoch_announced: bool,
    /// `(epoch, epoch_announced)` at the last commit.
    committed_epoch: (Option<u64>, bool),
}

impl Dictionary {
    /// Every change to slots that were there, in the tables a resolution reads.
    fn changes(&self) -> u64 {
        self.classes.changes + self.attrs.changes + self.objects.changes
    }

    /// What `(object, attr)` resolved to against `schema`, if nothing it rests on
    /// changed since (the object's entry, the schema, the announced slots).
    pub fn recall(
        &self,
        object: &ObjectEntry,
        attr: &Arc<str>,
        schema: &Schema,
    ) -> Option<&Resolved> {
        let r = self.remembered.get(&object.name, attr)?;
        let valid = r.schema == schema.id() && r.changes == self.changes() && r.entry == *object;
        valid.then_some(&r.resolved)
    }

    /// Remembers what `(object, attr)` resolved to (after [`Dictionary::object`] and
    /// [`Dictionary::attr`] made its ids).
    pub fn remember(
        &mut self,
        object: &ObjectEntry,
        attr: &Arc<str>,
        schema: &Schema,
        resolved: Resolved,
    ) {
        let r = Remembered {
            entry: object.clone(),
            resolved,
            schema: schema.id(),
            changes: self.changes(),
        };
        self.remembered.insert(&object.name, attr, r);
    }

    /// The id of an object; announces it (with its class and owner) if needed.
    pub fn object(
        &mut self,
        entry: &ObjectEntry,
        schema: &Schema,
        force: bool,
        ann: &mut Announce,
    ) -> Result<u32, EncodeError> {
        if let Some(id) = self.known_object(entry, schema).filter(|_| !force) {
            return Ok(id);
        }
        check_name(&entry.name)?;
        check_name(&entry.class)?;
        let fingerprint =
            schema
                .fingerprint(&entry.class)
                .ok_or_else(|| EncodeError::UnknownClass {
                    object: entry.name.to_string(),
                    class: entry.class.to_string(),
                })?;
        let class = self.class(&entry.class, fingerprint, ann)?;
        let owner = self.addr(&entry.owner, ann)?;
        let (id, new) = self
            .objects
            .intern("object ids", &entry.name, entry.clone(), force)?;
        if new && ann.objects.iter().any(|(announced, ..)| *announced == id) {
            return Err(EncodeError::ConflictingEntry(entry.name.to_string()));
        }
        if new {
            ann.objects.push((id, entry.clone(), class, owner));
        }
        Ok(id)
    }

    /// The id of an object announced as it is now, with its class (as the schema
    /// defines it now): the common case, which needs no checks. Its owner needs no
    /// look: it was announced with the object (a reset or a rollback takes both back).
    fn known_object(&self, entry: &ObjectEntry, schema: &Schema) -> Option<u32> {
        let id = self.objects.known(&entry.name, entry)?;
        let fingerprint = schema.fingerprint(&entry.class)?;
        self.classes.known(&entry.class, &fingerprint)?;
        Some(id)
    }

    fn class(
        &mut self,
        name: &Arc<str>,
        fingerprint: u32,
        ann: &mut Announce,
    ) -> Result<u32, EncodeError> {
        let (id, new) = self.classes.intern("class ids", name, fingerprint, false)?;
        if new {
            ann.classes.push((id, name.clone(), fingerprint));
        }
        Ok(id)
    }

    /// The id of an attribute name; announces it if needed.
    pub fn attr(
        &mut self,
        name: &Arc<str>,
        force: bool,
        ann: &mut Announce,
    ) -> Result<u32, EncodeError> {
        if let Some(id) = self.attrs.known(name, &()).filter(|_| !force) {
            return Ok(id);
        }
        check_name(name)?;
        let (id, new) = self.attrs.intern("attribute ids", name, (), force)?;
        if new {
            ann.attrs.push((id, name.clone()));
        }
        Ok(id)
    }

    /// The id of an address; announces it if needed.
    pub fn addr(&mut self, address: &Address, ann: &mut Announce) -> Result<u32, EncodeError> {
        let (id, new) = self.addrs.intern("address ids", address, (), false)?;
        if new {
            ann.addrs.push((id, address.clone()));
        }
        Ok(id)
    }

    /// The epoch in microseconds, choosing it from `first` (rounded down to the second)
    /// if there is none yet; announces it if needed.
    pub fn epoch_for(&mut self, first: Timestamp, ann: &mut Announce) -> u64 {
        let secs = *self.epoch.get_or_insert(first.physical().as_secs());
        self.announce_epoch(ann);
        secs * 1_000_000
    }

    /// Announces the epoch, if there is one and it was not announced since the last reset.
    pub fn announce_epoch(&mut self, ann: &mut Announce) {
        if let (Some(secs), false) = (self.epoch, self.epoch_announced) {
            self.epoch_announced = true;
            ann.epoch = Some(secs);
        }
    }

    /// The epoch, if chosen.
    pub fn epoch(&self) -> Option<Timestamp> {
        self.epoch
            .map(|s| Timestamp::from_duration(std::time::Duration::from_secs(s)))
    }

    /// Keeps every change since the last commit.
    pub fn commit(&mut self) {
        self.addrs.commit();
        self.classes.commit();
        self.attrs.commit();
        self.objects.commit();
        self.committed_epoch = (self.epoch, self.epoch_announced);
    }

    /// Undoes every change since the last commit.
    pub fn rollback(&mut self) {
        self.addrs.rollback();
        self.classes.rollback();
        self.attrs.rollback();
        self.objects.rollback();
        (self.epoch, self.epoch_announced) = self.committed_epoch;
    }

    /// Forgets what was announced (ids and the epoch stay): everything is announced again.
    pub fn reset(&mut self) {
        self.addrs.reset();
        self.classes.reset();
        self.attrs.reset();
        self.objects.reset();
        self.epoch_announced = false;
        self.committed_epoch.1 = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_are_announced_once_until_reset() {
        let mut dict = Dictionary::default();
        let mut ann = Announce::default();
        let speed: Arc<str> = "speed".into();
        assert_eq!(dict.attr(&speed, false, &mut ann), Ok(0));
        assert_eq!(dict.attr(&"x".into(), false, &mut ann), Ok(1));
        assert_eq!(dict.attr(&speed, false, &mut ann), Ok(0));
        assert_eq!(ann.attrs.len(), 2);
        dict.commit();
        dict.reset();
        let mut again = Announce::default();
        assert_eq!(
            dict.attr(&speed, false, &mut again),
            Ok(0),
            "ids survive a reset"
        );
        assert_eq!(again.attrs.len(), 1);
    }

    #[test]
    fn rollback_forgets_ids_and_announcements() {
        let mut dict = Dictionary::default();
        let mut ann = Announce::default();
        dict.attr(&"a".into(), false, &mut ann).unwrap();
        dict.commit();
        dict.attr(&"b".into(), false, &mut ann).unwrap();
        dict.epoch_for(Timestamp::from_raw(1 << 40), &mut ann);
        dict.rollback();
        assert_eq!(dict.epoch(), None);
        let mut again = Announce::default();
        assert_eq!(
            dict.attr(&"c".into(), false, &mut again),
            Ok(1),
            "b's id is free again"
        );
        assert_eq!(dict.attr(&"a".into(), false, &mut again), Ok(0));
        assert_eq!(again.attrs.len(), 1);
    }

    #[test]
    fn a_changed_object_entry_is_announced_again() {
        let schema = Schema::new(&[slate_model::ClassDef::new("Rock")]);
        let mut dict = Dictionary::default();
        let mut ann = Announce::default();
        let rock = ObjectEntry::new("r1", "Rock");
        dict.object(&rock, &schema, false, &mut ann).unwrap();
        dict.object(&rock, &schema, false, &mut ann).unwrap();
        assert_eq!(ann.objects.len(), 1);
        let moved = rock.clone().context(slate_model::Context::System);
        assert_eq!(
            dict.object(&moved, &schema, false, &mut ann),
            Err(EncodeError::ConflictingEntry("r1".into())),
            "one message, two entries"
        );
        dict.rollback();
        let mut first = Announce::default();
        dict.object(&rock, &schema, false, &mut first).unwrap();
        dict.commit();
        let mut next = Announce::default();
        assert_eq!(dict.object(&moved, &schema, false, &mut next), Ok(0));
        assert_eq!(next.objects.len(), 1, "announced again, same id");
        assert!(matches!(
            dict.object(&ObjectEntry::new("x", "Nope"), &schema, false, &mut next),
            Err(EncodeError::UnknownClass { .. })
        ));
    }
}
