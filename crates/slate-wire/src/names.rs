//! The names section (dictionary entries, inline in a report or alone in a `Names`
//! message) and the receiver's per-source dictionaries.

use std::sync::Arc;

use rustc_hash::{FxHashMap, FxHashSet};
use slate_model::{Address, Context};

use crate::bits::{BitReader, BitWriter};
use crate::text::{read_address, read_name, write_address};
use crate::{DecodeError, MAX_IDS, MAX_ITEMS, ObjectEntry};

/// Entries a message announces, in the order they are written.
#[derive(Debug, Default)]
pub(crate) struct Announce {
    /// The epoch in whole seconds.
    pub epoch: Option<u64>,
    pub addrs: Vec<(u32, Address)>,
    /// `(id, name, fingerprint)`.
    pub classes: Vec<(u32, Arc<str>, u32)>,
    pub attrs: Vec<(u32, Arc<str>)>,
    /// `(id, entry, class id, owner address id)`.
    pub objects: Vec<(u32, ObjectEntry, u32, u32)>,
}

impl Announce {
    /// Is there nothing to announce?
    pub fn is_empty(&self) -> bool {
        self.epoch.is_none()
            && self.addrs.is_empty()
            && self.classes.is_empty()
            && self.attrs.is_empty()
            && self.objects.is_empty()
    }

    /// The largest table, for the item limit.
    pub fn max_len(&self) -> usize {
        let lens = [self.addrs.len(), self.classes.len(), self.attrs.len()];
        lens.into_iter()
            .chain([self.objects.len()])
            .max()
            .unwrap_or(0)
    }
}

/// Writes a names section: 5 presence bits (epoch, addresses, classes, attributes,
/// objects), then each present part.
pub(crate) fn write_section(w: &mut BitWriter, ann: &Announce) {
    w.bit(ann.epoch.is_some());
    w.bit(!ann.addrs.is_empty());
    w.bit(!ann.classes.is_empty());
    w.bit(!ann.attrs.is_empty());
    w.bit(!ann.objects.is_empty());
    ann.epoch.iter().for_each(|secs| w.uvar(*secs));
    write_list(w, &ann.addrs, |w, (_, a)| write_address(w, a));
    write_list(w, &ann.classes, |w, (_, name, fingerprint)| {
        w.str(name);
        w.bits((*fingerprint).into(), 32);
    });
    write_list(w, &ann.attrs, |w, (_, name)| w.str(name));
    write_list(w, &ann.objects, |w, (_, entry, class, owner)| {
        w.str(&entry.name);
        w.uvar((*class).into());
        w.bits(context_number(entry.context), 2);
        w.uvar((*owner).into());
    });
}

/// Writes a non-empty list as a count, then `id, fields` per entry.
fn write_list<T: HasId>(w: &mut BitWriter, items: &[T], each: impl Fn(&mut BitWriter, &T)) {
    if items.is_empty() {
        return;
    }
    w.uvar(items.len() as u64);
    for item in items {
        w.uvar(item.id().into());
        each(w, item);
    }
}

trait HasId {
    fn id(&self) -> u32;
}
impl<A, B> HasId for (u32, A, B) {
    fn id(&self) -> u32 {
        self.0
    }
}
impl<A> HasId for (u32, A) {
    fn id(&self) -> u32 {
        self.0
    }
}
impl<A, B, C> HasId for (u32, A, B, C) {
    fn id(&self) -> u32 {
        self.0
    }
}

fn context_number(c: Context) -> u64 {
    match c {
        Context::Self_ => 0,
        Context::Surroundings => 1,
        Context::System => 2,
    }
}

fn context_of(n: u64) -> Result<Context, DecodeError> {
    Context::ALL
        .get(n as usize)
        .copied()
        .ok_or(DecodeError::BadValue("reserved context"))
}

/// What a receiver knows of one source's dictionary.
#[derive(Clone, Debug, Default)]
pub(crate) struct SourceDict {
    /// Epoch in whole seconds.
    epoch: Option<u64>,
    addrs: FxHashMap<u32, Address>,
    /// `id → (name, fingerprint)`.
    classes: FxHashMap<u32, (Arc<str>, u32)>,
    attrs: FxHashMap<u32, Arc<str>>,
    /// `id → (entry, class id)`.
    objects: FxHashMap<u32, (ObjectEntry, u32)>,
}

/// A decoded names section, not yet applied.
#[derive(Debug, Default)]
pub(crate) struct Section {
    /// The epoch differs from the one we knew: the source restarted, forget the old names.
    fresh: bool,
    delta: SourceDict,
    /// Object ids and attribute ids in the order announced.
    pub objects: Vec<u32>,
    pub attrs: Vec<u32>,
}

impl SourceDict {
    /// The names it holds, all tables together.
    pub fn len(&self) -> usize {
        self.addrs.len() + self.classes.len() + self.attrs.len() + self.objects.len()
    }

    /// The names a dictionary `base` (none: a source not heard yet) would hold with
    /// `section` applied.
    pub fn len_with(base: Option<&SourceDict>, section: &Section) -> usize {
        let d = &section.delta;
        let Some(base) = base.filter(|_| !section.fresh) else {
            return d.len();
        };
        base.len()
            + unheld(&d.addrs, &base.addrs)
            + unheld(&d.classes, &base.classes)
            + unheld(&d.attrs, &base.attrs)
            + unheld(&d.objects, &base.objects)
    }

    /// Applies a section (after the whole message decoded).
    pub fn apply(&mut self, section: Section) {
        if section.fresh {
            *self = SourceDict::default();
        }
        let d = section.delta;
        self.epoch = d.epoch.or(self.epoch);
        self.addrs.extend(d.addrs);
        self.classes.extend(d.classes);
        self.attrs.extend(d.attrs);
        self.objects.extend(d.objects);
    }
}

/// The ids of `delta` that `held` does not hold yet.
fn unheld<V>(delta: &FxHashMap<u32, V>, held: &FxHashMap<u32, V>) -> usize {
    delta.keys().filter(|k| !held.contains_key(k)).count()
}

/// Lookups through a pending section, then the source's dictionary.
#[derive(Clone, Copy, Debug)]
pub(crate) struct View<'a> {
    base: Option<&'a SourceDict>,
    section: Option<&'a Section>,
}

/// An object as a report needs it: its entry and its class's announced fingerprint.
pub(crate) struct Known<'a> {
    pub entry: &'a ObjectEntry,
    pub fingerprint: u32,
}

impl<'a> View<'a> {
    /// A view of `base` (if the source is known) updated by `section` (if any).
    pub fn new(base: Option<&'a SourceDict>, section: Option<&'a Section>) -> Self {
        let base = base.filter(|_| !section.is_some_and(|s| s.fresh));
        View { base, section }
    }

    fn find<T>(&self, table: impl Fn(&'a SourceDict) -> Option<&'a T>) -> Option<&'a T> {
        let pending = self.section.and_then(|s| table(&s.delta));
        pending.or_else(|| self.base.and_then(table))
    }

    /// The epoch in microseconds.
    pub fn epoch_us(&self) -> Result<u64, DecodeError> {
        let secs = self.find(|d| d.epoch.as_ref()).ok_or(unknown("epoch", 0))?;
        Ok(secs.saturating_mul(1_000_000))
    }

    pub fn addr(&self, id: u64) -> Result<&'a Address, DecodeError> {
        self.find(|d| d.addrs.get(&(id as u32)))
            .filter(|_| id < MAX_IDS as u64)
            .ok_or(unknown("address", id))
    }

    pub fn attr(&self, id: u64) -> Result<&'a Arc<str>, DecodeError> {
        self.find(|d| d.attrs.get(&(id as u32)))
            .filter(|_| id < MAX_IDS as u64)
            .ok_or(unknown("attribute", id))
    }

    fn class(&self, id: u64) -> Result<&'a (Arc<str>, u32), DecodeError> {
        self.find(|d| d.classes.get(&(id as u32)))
            .filter(|_| id < MAX_IDS as u64)
            .ok_or(unknown("class", id))
    }

    pub fn object(&self, id: u64) -> Result<Known<'a>, DecodeError> {
        let (entry, class) = self
            .find(|d| d.objects.get(&(id as u32)))
            .filter(|_| id < MAX_IDS as u64)
            .ok_or(unknown("object", id))?;
        let fingerprint = self.class((*class).into())?.1;
        Ok(Known { entry, fingerprint })
    }
}

fn unknown(table: &'static str, id: u64) -> DecodeError {
    DecodeError::UnknownName { table, id }
}

/// Reads a names section written by [`write_section`], resolving references through
/// `base` (the source's dictionary, if known).
pub(crate) fn read_section(
    r: &mut BitReader,
    base: Option<&SourceDict>,
) -> Result<Section, DecodeError> {
    let present = r.bits(5)?;
    let has = |bit: u32| present & (1 << (4 - bit)) != 0;
    let count = |r: &mut BitReader, bit: u32| {
        if has(bit) {
            r.count("names in a message", MAX_ITEMS)
        } else {
            Ok(0)
        }
    };
    let mut s = Section::default();
    if has(0) {
        let secs = r.uvar()?;
        s.fresh = base.is_some_and(|b| b.epoch.is_some_and(|e| e != secs));
        s.delta.epoch = Some(secs);
    }
    let n = count(r, 1)?;
    s.read_addrs(r, n)?;
    let n = count(r, 2)?;
    s.read_classes(r, n)?;
    let n = count(r, 3)?;
    s.read_attrs(r, n)?;
    let n = count(r, 4)?;
    s.read_objects(r, n, base)?;
    Ok(s)
}

impl Section {
    fn read_addrs(&mut self, r: &mut BitReader, n: usize) -> Result<(), DecodeError> {
        for _ in 0..n {
            let id = read_id(r)?;
            once(self.delta.addrs.insert(id, read_address(r)?))?;
        }
        Ok(())
    }

    fn read_classes(&mut self, r: &mut BitReader, n: usize) -> Result<(), DecodeError> {
        for _ in 0..n {
            let id = read_id(r)?;
            let name: Arc<str> = read_name(r)?.into();
            let fingerprint = r.bits(32)? as u32;
            once(self.delta.classes.insert(id, (name, fingerprint)))?;
        }
        Ok(())
    }

    fn read_attrs(&mut self, r: &mut BitReader, n: usize) -> Result<(), DecodeError> {
        let mut names = FxHashSet::default();
        for _ in 0..n {
            let id = read_id(r)?;
            let name: Arc<str> = read_name(r)?.into();
            unique(&mut names, &name)?;
            once(self.delta.attrs.insert(id, name))?;
            self.attrs.push(id);
        }
        Ok(())
    }

    fn read_objects(
        &mut self,
        r: &mut BitReader,
        n: usize,
        base: Option<&SourceDict>,
    ) -> Result<(), DecodeError> {
        let mut names = FxHashSet::default();
        for _ in 0..n {
            let (id, object) = read_object(r, View::new(base, Some(self)))?;
            unique(&mut names, &object.0.name)?;
            once(self.delta.objects.insert(id, object))?;
            self.objects.push(id);
        }
        Ok(())
    }
}

/// An id may be announced once per section.
fn once<T>(previous: Option<T>) -> Result<(), DecodeError> {
    match previous {
        Some(_) => Err(DecodeError::BadValue("id announced twice in one message")),
        None => Ok(()),
    }
}

/// A name may be announced once per section.
fn unique(seen: &mut FxHashSet<Arc<str>>, name: &Arc<str>) -> Result<(), DecodeError> {
    if !seen.insert(name.clone()) {
        return Err(DecodeError::BadValue("name announced twice in one message"));
    }
    Ok(())
}

fn read_object(r: &mut BitReader, view: View) -> Result<(u32, (ObjectEntry, u32)), DecodeError> {
    let id = read_id(r)?;
    let name = read_name(r)?;
    let class_id = r.uvar()?;
    let class = view.class(class_id)?.0.clone();
    let context = context_of(r.bits(2)?)?;
    let owner = view.addr(r.uvar()?)?.clone();
    let entry = ObjectEntry {
        name: name.into(),
        class,
        context,
        owner,
    };
    Ok((id, (entry, class_id as u32)))
}

/// Reads an id, which must be below [`MAX_IDS`].
fn read_id(r: &mut BitReader) -> Result<u32, DecodeError> {
    Ok(r.count("dictionary id", MAX_IDS - 1)? as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn section(ann: &Announce, base: Option<&SourceDict>) -> Result<Section, DecodeError> {
        let mut w = BitWriter::new();
        write_section(&mut w, ann);
        let bytes = w.finish();
        read_section(&mut BitReader::new(&bytes), base)
    }

    fn announce_rock() -> Announce {
        let owner = Address::new("team/r1/prox").unwrap();
        Announce {
            epoch: Some(1_767_225_600),
            addrs: vec![(0, owner.clone())],
            classes: vec![(0, "Rock".into(), 0xdead_beef)],
            attrs: vec![(0, "range".into())],
            objects: vec![(3, ObjectEntry::new("r1", "Rock").owner(owner), 0, 0)],
        }
    }

    #[test]
    fn a_section_resolves_its_own_references() {
        let s = section(&announce_rock(), None).unwrap();
        let view = View::new(None, Some(&s));
        let rock = view.object(3).unwrap();
        assert_eq!(&*rock.entry.name, "r1");
        assert_eq!(rock.entry.owner.as_str(), "team/r1/prox");
        assert_eq!(rock.fingerprint, 0xdead_beef);
        assert_eq!(view.epoch_us(), Ok(1_767_225_600_000_000));
        assert_eq!(s.objects, vec![3]);
    }

    #[test]
    fn later_sections_resolve_through_the_dictionary() {
        let mut dict = SourceDict::default();
        dict.apply(section(&announce_rock(), None).unwrap());
        let later = Announce {
            objects: vec![(4, ObjectEntry::new("r2", "Rock"), 0, 0)],
            ..Announce::default()
        };
        let s = section(&later, Some(&dict)).unwrap();
        assert_eq!(
            View::new(Some(&dict), Some(&s))
                .object(4)
                .unwrap()
                .entry
                .class
                .as_ref(),
            "Rock"
        );
        assert_eq!(
            View::new(Some(&dict), None).object(4).err(),
            Some(unknown("object", 4))
        );
    }

    #[test]
    fn a_new_epoch_starts_a_new_dictionary() {
        let mut dict = SourceDict::default();
        dict.apply(section(&announce_rock(), None).unwrap());
        let restarted = Announce {
            epoch: Some(1_767_225_700),
            ..Announce::default()
        };
        let s = section(&restarted, Some(&dict)).unwrap();
        assert!(View::new(Some(&dict), Some(&s)).object(3).is_err());
        dict.apply(s);
        assert!(View::new(Some(&dict), None).attr(0).is_err());
    }

    #[test]
    fn references_to_unannounced_entries_are_unknown_names() {
        let ann = Announce {
            objects: vec![(0, ObjectEntry::new("r1", "Rock"), 7, 0)],
            ..Announce::default()
        };
        assert_eq!(section(&ann, None).err(), Some(unknown("class", 7)));
    }
}
