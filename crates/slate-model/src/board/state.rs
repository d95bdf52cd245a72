//! The board's data: a slab of entities (classes and objects), name tables, and the
//! pure operations on them. Nothing here runs active functions or takes locks.

use std::sync::Arc;

use rustc_hash::FxHashMap;

use super::kept::Kept;
use crate::active::FnRef;
use crate::class::valid_name;
use crate::packet::{check_quality, check_value};
use crate::{
    Address, AttrDecl, AttrId, ClassDef, Clock, Context, CreateError, DefineError, DeleteError,
    Key, LookupError, ObjectId, Packet, ReadError, THING, Timestamp, Trigger, Update, WriteError,
};

/// An attribute declaration as the board uses it.
#[derive(Debug)]
pub(crate) struct Decl {
    pub decl: AttrDecl,
    /// The class that declares it.
    pub declared_in: ObjectId,
    /// The declared default packet, or [`Packet::none`].
    pub default: Packet,
}

/// What a read resolved to.
pub(crate) struct Resolved<'s> {
    pub packet: &'s Packet,
    pub decl: &'s Arc<Decl>,
    /// Might on-read functions apply? (If not, the packet is the answer.)
    pub read_fns: bool,
}

/// A stored packet and the revision that stored it.
#[derive(Clone, Debug)]
pub(crate) struct Stored {
    pub attr: AttrId,
    pub packet: Packet,
    pub revision: u64,
}

pub(crate) type FnTable = FxHashMap<(AttrId, Trigger), Vec<FnRef>>;

pub(crate) struct ClassData {
    pub def: ClassDef,
    /// This class first, then its parent, up to `Thing`: the chain
    /// [`ClassTree::lineage`](crate::ClassTree::lineage) gives by name, kept here by id for
    /// reads. A class is defined only below an existing parent, so the chain is its
    /// parent's with the class in front, and has no cycle.
    pub ancestors: Vec<ObjectId>,
    /// Every attribute this class has, declared here or inherited.
    pub decls: FxHashMap<AttrId, Arc<Decl>>,
    pub children: Vec<ObjectId>,
    pub instances: Vec<ObjectId>,
    /// Functions of this class and its ancestors, ancestor-first.
    pub effective: FnTable,
    /// Does `effective` hold any on-read function? (Lets reads skip looking.)
    pub read_fns: bool,
}

pub(crate) struct InstanceData {
    pub class: ObjectId,
    pub context: Context,
    pub owner: Address,
    /// Position in the class's `instances`.
    pub slot_in_class: usize,
}

pub(crate) enum Kind {
    Class(Box<ClassData>),
    Instance(InstanceData),
}

pub(crate) struct Entity {
    pub name: Arc<str>,
    pub kind: Kind,
    /// Values this entity has written itself (an instance's own, a class's class-level).
    pub values: Vec<Stored>,
    /// Functions attached to this entity directly.
    pub fns: FnTable,
}

impl Entity {
    #[inline]
    pub fn own(&self, attr: AttrId) -> Option<&Stored> {
        self.values.iter().find(|s| s.attr == attr)
    }

    pub fn class_data(&self) -> Option<&ClassData> {
        match &self.kind {
            Kind::Class(c) => Some(c),
            Kind::Instance(_) => None,
        }
    }

    pub fn instance(&self) -> Option<&InstanceData> {
        match &self.kind {
            Kind::Instance(i) => Some(i),
            Kind::Class(_) => None,
        }
    }
}

struct Slot {
    generation: u32,
    entity: Option<Entity>,
}

/// Where a write's packet comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Origin {
    /// A write made on this board (`write`, a batch, an active function).
    Own,
    /// A write of the machinery that keeps guarded attributes ([`AttrDecl::guarded`]),
    /// such as the plan engine's: an own write that may also write them.
    ///
    /// [`AttrDecl::guarded`]: crate::AttrDecl::guarded
    Machinery,
    /// A received packet that won its merge.
    Merged,
}

/// A name that did not resolve.
#[derive(Debug)]
pub(crate) enum Missing {
    Object(String),
    Attr { object: String, attr: String },
}

impl From<Missing> for ReadError {
    fn from(m: Missing) -> Self {
        match m {
            Missing::Object(o) => ReadError::UnknownObject(o),
            Missing::Attr { object, attr } => ReadError::UnknownAttribute { object, attr },
        }
    }
}

impl From<Missing> for WriteError {
    fn from(m: Missing) -> Self {
        match m {
            Missing::Object(o) => WriteError::UnknownObject(o),
            Missing::Attr { object, attr } => WriteError::UnknownAttribute { object, attr },
        }
    }
}

impl From<Missing> for LookupError {
    fn from(m: Missing) -> Self {
        match m {
            Missing::Object(o) => LookupError::UnknownObject(o),
            Missing::Attr { object, attr } => LookupError::UnknownAttribute { object, attr },
        }
    }
}

pub(crate) struct State {
    slots: Vec<Slot>,
    free: Vec<u32>,
    names: FxHashMap<Arc<str>, ObjectId>,
    attr_ids: FxHashMap<Arc<str>, AttrId>,
    attr_names: Vec<Arc<str>>,
    pub revision: u64,
    pub thing: ObjectId,
    /// Instances per owner, kept where entities enter and leave the slots.
    owned: FxHashMap<Address, usize>,
    /// Instances in all.
    instances: usize,
    /// Rewrites the packets this board writes itself, before they are stored.
    pub normaliser: Option<Arc<dyn crate::Normaliser>>,
    /// Who may write what here besides this board's module (`[authority] writes`).
    pub authority: Arc<crate::WriteAuthority>,
    /// Packets of pure on-read functions, kept until what they read changes: every
    /// method below that changes the state says what it changed.
    pub kept: Kept,
}

/// Why a write from another module is not taken: the one rule of who may write what on
/// a board ([`State::write_refusal`]).
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Refusal {
    /// The attribute is `owned`, and the object is this module's.
    NotOwner(Address),
    /// The rule that decides the write does not let the writer write.
    Unauthorised(crate::WriteRule),
}

impl State {
    pub fn new() -> Self {
        let mut st = State {
            slots: Vec::new(),
            free: Vec::new(),
            names: FxHashMap::default(),
            attr_ids: FxHashMap::default(),
            attr_names: Vec::new(),
            revision: 0,
            thing: ObjectId {
                index: 0,
                generation: 0,
            },
            owned: FxHashMap::default(),
            instances: 0,
            normaliser: None,
            authority: Arc::default(),
            kept: Kept::default(),
        };
        let root = ClassData {
            def: ClassDef {
                name: THING.into(),
                parent: String::new(),
                attrs: Vec::new(),
            },
            ancestors: Vec::new(),
            decls: FxHashMap::default(),
            children: Vec::new(),
            instances: Vec::new(),
            effective: FnTable::default(),
            read_fns: false,
        };
        let thing = st.insert(entity(THING.into(), Kind::Class(Box::new(root))));
        st.thing = thing;
        if let Some(Kind::Class(c)) = st.get_mut(thing).map(|e| &mut e.kind) {
            c.ancestors.push(thing);
        }
        st
    }

    // ----- lookups -----

    #[inline]
    pub fn get(&self, id: ObjectId) -> Option<&Entity> {
        let slot = self.slots.get(id.index as usize)?;
        if slot.generation != id.generation {
            return None;
        }
        slot.entity.as_ref()
    }

    #[inline]
    pub fn get_mut(&mut self, id: ObjectId) -> Option<&mut Entity> {
        let slot = self.slots.get_mut(id.index as usize)?;
        if slot.generation != id.generation {
            return None;
        }
        slot.entity.as_mut()
    }

    pub fn id(&self, name: &str) -> Option<ObjectId> {
        self.names.get(name).copied()
    }

    /// Instances `owner` owns.
    pub fn owned_count(&self, owner: &Address) -> usize {
        self.owned.get(owner).copied().unwrap_or(0)
    }

    /// Instances in all.
    pub fn instance_count(&self) -> usize {
        self.instances
    }

    /// Counts an instance in (`arrived`) or out; an owner with none left is dropped,
    /// so the map holds only owners of objects on the board.
    fn count_instance(&mut self, e: &Entity, arrived: bool) {
        let Some(inst) = e.instance() else { return };
        if arrived {
            self.instances += 1;
            *self.owned.entry(inst.owner.clone()).or_insert(0) += 1;
            return;
        }
        self.instances = self.instances.saturating_sub(1);
        if let Some(n) = self.owned.get_mut(&inst.owner) {
            *n = n.saturating_sub(1);
            if *n == 0 {
                self.owned.remove(&inst.owner);
            }
        }
    }

    #[inline]
    pub fn class(&self, id: ObjectId) -> Option<&ClassData> {
        self.get(id)?.class_data()
    }

    pub fn class_id(&self, name: &str) -> Option<ObjectId> {
        self.id(name).filter(|id| self.class(*id).is_some())
    }

    pub fn attr_id(&self, name: &str) -> Option<AttrId> {
        self.attr_ids.get(name).copied()
    }

    pub fn attr_name(&self, attr: AttrId) -> Arc<str> {
        self.attr_names
            .get(attr.0 as usize)
            .cloned()
            .unwrap_or_else(|| "?".into())
    }

    pub fn name(&self, id: ObjectId) -> Option<Arc<str>> {
        self.get(id).map(|e| e.name.clone())
    }

    pub fn name_or_stale(&self, id: ObjectId) -> String {
        self.get(id)
            .map_or_else(|| format!("{id:?} (deleted)"), |e| e.name.to_string())
    }

    /// The class whose declarations apply to `id`: its class, or itself for a class.
    #[inline]
    pub fn decl_class(&self, id: ObjectId) -> Option<(&Entity, &ClassData)> {
        let e = self.get(id)?;
        let class = match &e.kind {
            Kind::Class(c) => c,
            Kind::Instance(i) => self.class(i.class)?,
        };
        Some((e, class))
    }

    /// Classes `id` is, or is an instance of: for an instance its class chain, for a
    /// class itself and its ancestors.
    pub fn lineage(&self, id: ObjectId) -> &[ObjectId] {
        self.decl_class(id).map_or(&[], |(_, c)| &c.ancestors)
    }

    pub fn key(&self, object: &str, attr: &str) -> Result<Key, Missing> {
        let id = self
            .id(object)
            .ok_or_else(|| Missing::Object(object.to_owned()))?;
        self.key_of(id, attr)
    }

    pub fn key_of(&self, id: ObjectId, attr: &str) -> Result<Key, Missing> {
        let (e, class) = self
            .decl_class(id)
            .ok_or_else(|| Missing::Object(format!("{id:?}")))?;
        let missing = || Missing::Attr {
            object: e.name.to_string(),
            attr: attr.to_owned(),
        };
        let attr = self.attr_id(attr).ok_or_else(missing)?;
        class.decls.get(&attr).ok_or_else(missing)?;
        Ok(Key { object: id, attr })
    }

    /// The entity, its class (itself for a class) and the declaration `key` names.
    #[inline]
    pub fn decl(&self, key: Key) -> Result<(&Entity, &ClassData, &Arc<Decl>), Missing> {
        let (e, class) = self
            .decl_class(key.object)
            .ok_or_else(|| Missing::Object(self.name_or_stale(key.object)))?;
        match class.decls.get(&key.attr) {
            Some(d) => Ok((e, class, d)),
            None => Err(Missing::Attr {
                object: e.name.to_string(),
                attr: self.attr_name(key.attr).to_string(),
            }),
        }
    }

    // ----- reads -----

    /// The fast path of reads: the object's own packet, when no on-read function can
    /// apply. `None` means: take the slow path ([`State::resolve`] and [`State::fns`]).
    #[inline]
    pub fn read_own(&self, key: Key) -> Option<&Packet> {
        let e = self.get(key.object)?;
        let stored = e.own(key.attr)?;
        let class = match &e.kind {
            Kind::Instance(i) => self.class(i.class)?,
            Kind::Class(c) => c,
        };
        (!class.read_fns && e.fns.is_empty()).then_some(&stored.packet)
    }

    /// The packet `key` reads (own value, else the nearest class-level value up the
    /// class chain, else the declared default), and its declaration.
    pub fn resolve(&self, key: Key) -> Result<Resolved<'_>, Missing> {
        let (e, class, decl) = self.decl(key)?;
        let read_fns = class.read_fns || !e.fns.is_empty();
        let found = |packet| {
            Ok(Resolved {
                packet,
                decl,
                read_fns,
            })
        };
        if let Some(s) = e.own(key.attr) {
            return found(&s.packet);
        }
        // A class's own values were checked above; an instance starts at its class.
        let skip = usize::from(e.class_data().is_some());
        for &c in &class.ancestors[skip..] {
            if let Some(s) = self.get(c).and_then(|ce| ce.own(key.attr)) {
                return found(&s.packet);
            }
            if c == decl.declared_in {
                break;
            }
        }
        found(&decl.default)
    }

    /// Could `key` have active functions? (Cheap; `false` lets writes skip [`State::fns`].)
    #[inline]
    pub fn may_have_fns(&self, key: Key) -> bool {
        self.decl_class(key.object)
            .is_some_and(|(e, c)| !(c.effective.is_empty() && e.fns.is_empty()))
    }

    /// Active functions of `key` for `trigger`: inherited ones ancestor-first, then the
    /// object's own, each in the order attached.
    pub fn fns(&self, key: Key, trigger: Trigger) -> Vec<FnRef> {
        let Some((e, class)) = self.decl_class(key.object) else {
            return Vec::new();
        };
        let k = (key.attr, trigger);
        let mut out = Vec::new();
        if e.class_data().is_some() {
            out.extend(class.effective.get(&k).into_iter().flatten().cloned());
        } else {
            out.extend(class.effective.get(&k).into_iter().flatten().cloned());
            out.extend(e.fns.get(&k).into_iter().flatten().cloned());
        }
        out
    }

    /// Instances of `class` and of its subclasses, depth first.
    pub fn instances(&self, class: ObjectId, out: &mut Vec<ObjectId>) {
        if let Some(c) = self.class(class) {
            out.extend_from_slice(&c.instances);
            for &child in &c.children {
                self.instances(child, out);
            }
        }
    }

    /// All live entities, in slot order.
    pub fn entities(&self) -> impl Iterator<Item = (ObjectId, &Entity)> {
        self.slots.iter().enumerate().filter_map(|(i, s)| {
            let id = ObjectId {
                index: i as u32,
                generation: s.generation,
            };
            s.entity.as_ref().map(|e| (id, e))
        })
    }

    // ----- writes -----

    /// Validates an update for `key` and fills in the fields the writer left out; an
    /// unstamped write gets `stamp`, or a fresh timestamp. A given timestamp is kept and
    /// merged into the clock. An [`Origin::Own`] write must also be one every receiver
    /// would store (see [`State::admit_own`]); a [`Origin::Merged`] one was judged by
    /// [`State::write_refusal`] and [`State::merge_verdict`] already.
    pub fn prepare(
        &self,
        key: Key,
        update: Update,
        clock: &Clock,
        me: &Address,
        stamp: Option<Timestamp>,
        origin: Origin,
    ) -> Result<Packet, WriteError> {
        let (e, _, decl) = self.decl(key)?;
        let d = &decl.decl;
        if origin == Origin::Own {
            refuse_guarded(e, d, me, || self.name_or_stale(key.object))?;
        }
        let invalid = |source| WriteError::Invalid {
            object: self.name_or_stale(key.object),
            attr: d.name.clone(),
            source,
        };
        check_value(&update.value, d.ty, d.bounds).map_err(invalid)?;
        let (acc, conf) = d.default_quality();
        let accuracy = update.accuracy.unwrap_or(acc);
        let confidence = update.confidence.unwrap_or(conf);
        check_quality(accuracy, confidence).map_err(invalid)?;
        let stamped = update.timestamp.is_some();
        let mut packet = Packet {
            value: update.value,
            accuracy,
            confidence,
            timestamp: update
                .timestamp
                .unwrap_or_else(|| stamp.unwrap_or_else(|| clock.now())),
            source: update.source.unwrap_or_else(|| me.clone()),
        };
        if origin != Origin::Merged {
            self.admit_own(e, d, key, &packet, stamped, clock)?;
        }
        if stamped {
            // A merged packet too far ahead was refused by its merge; one taken before
            // this clock fell behind must not drag it forward.
            let _ = clock.observe(packet.timestamp);
        }
        if let Some(n) = self.normaliser.as_ref().filter(|_| packet.source == *me) {
            n.normalise(d, &mut packet);
            check_value(&packet.value, d.ty, d.bounds).map_err(invalid)?;
            check_quality(packet.accuracy, packet.confidence).map_err(invalid)?;
        }
        Ok(packet)
    }

    /// Would every receiver store this own write as the writer does? An `owned`
    /// attribute of an instance takes packets from its owner only (the rule
    /// [`State::merge_verdict`] applies to received ones). An explicit stamp must be
    /// within the clock's tolerance (receivers refuse the rest), and, except under
    /// `fused` (whose board value is a fusion the ICI rewrites), not older by
    /// `(timestamp, source)` than the packet the object holds (receivers keep that one).
    fn admit_own(
        &self,
        e: &Entity,
        decl: &AttrDecl,
        key: Key,
        packet: &Packet,
        stamped: bool,
        clock: &Clock,
    ) -> Result<(), WriteError> {
        use crate::MergePolicy;
        let names = || (self.name_or_stale(key.object), decl.name.clone());
        if let Some(owner) = not_owner(e, decl, &packet.source) {
            let (object, attr) = names();
            return Err(WriteError::NotOwner {
                object,
                attr,
                owner: owner.clone(),
                writer: packet.source.clone(),
            });
        }
        if !stamped {
            return Ok(());
        }
        if let Err(drift) = clock.check(packet.timestamp) {
            let (object, attr) = names();
            return Err(WriteError::FromTheFuture {
                object,
                attr,
                stamp: packet.timestamp,
                ahead: drift.ahead,
                max: drift.max,
            });
        }
        match e.own(key.attr).map(|s| &s.packet) {
            Some(held)
                if decl.merge != MergePolicy::Fused
                    && (packet.timestamp, &packet.source) < (held.timestamp, &held.source) =>
            {
                let (object, attr) = names();
                Err(WriteError::Superseded {
                    object,
                    attr,
                    stamp: packet.timestamp,
                    held: held.timestamp,
                    held_source: held.source.clone(),
                })
            }
            _ => Ok(()),
        }
    }

    /// Would a received packet win against the object's own packet under the attribute's
    /// merge policy? `Applied(0)` means yes (the revision is not known yet).
    /// The writer must be allowed to write it first ([`State::write_refusal`]).
    pub fn merge_verdict(&self, key: Key, packet: &Packet) -> Result<crate::Merged, Missing> {
        use crate::{MergePolicy, Merged};
        let (e, _, decl) = self.decl(key)?;
        let own = e.own(key.attr).map(|s| &s.packet);
        let newer =
            |p: &Packet| match (packet.timestamp, &packet.source).cmp(&(p.timestamp, &p.source)) {
                std::cmp::Ordering::Equal => tie_break(packet) > tie_break(p),
                o => o.is_gt(),
            };
        let wins = match decl.decl.merge {
            MergePolicy::Latest | MergePolicy::Fused => own.is_none_or(newer),
            MergePolicy::Confident => own.is_none_or(|p| {
                packet.confidence > p.confidence || (packet.confidence == p.confidence && newer(p))
            }),
            MergePolicy::Owned => own.is_none_or(newer),
        };
        Ok(if wins {
            Merged::Applied(0)
        } else {
            Merged::Kept
        })
    }

    /// May `writer` write `key` on the board of `me`? The one rule of who may write what:
    /// an `owned` attribute of an instance only its owner; else, for another module
    /// than `me`, what the declared rule deciding it ([`crate::WriteAuthority`]) allows.
    pub fn write_refusal(
        &self,
        key: Key,
        writer: &Address,
        me: &Address,
    ) -> Result<Option<Refusal>, Missing> {
        let (e, _, decl) = self.decl(key)?;
        if let Some(owner) = not_owner(e, &decl.decl, writer) {
            return Ok(Some(Refusal::NotOwner(owner.clone())));
        }
        if writer == me || self.authority.is_empty() {
            return Ok(None);
        }
        let attr = self.attr_name(key.attr);
        Ok(self.unauthorised(key.object, Some(&attr), writer))
    }

    /// May `writer` delete `id` on the board of `me`? A deletion takes away every value
    /// the object holds, so it is judged as creating one of its class and writing each of
    /// its attributes ([`State::write_refusal`]); the refused attribute (the first by
    /// name) comes with the refusal, `None` when the class itself decided.
    pub fn delete_refusal(
        &self,
        id: ObjectId,
        writer: &Address,
        me: &Address,
    ) -> Option<(Option<Arc<str>>, Refusal)> {
        let (_, class) = self.decl_class(id)?;
        if writer != me
            && let Some(refusal) = self.unauthorised(id, None, writer)
        {
            return Some((None, refusal));
        }
        class
            .decls
            .keys()
            .filter_map(|&attr| {
                let key = Key { object: id, attr };
                let refusal = self.write_refusal(key, writer, me).ok()??;
                Some((self.attr_name(attr), refusal))
            })
            .min_by(|a, b| a.0.cmp(&b.0))
            .map(|(attr, refusal)| (Some(attr), refusal))
    }

    /// The declared rule deciding `writer`'s write of `attr` of `id` (of the object
    /// itself with `None`), if it refuses it.
    pub fn unauthorised(
        &self,
        id: ObjectId,
        attr: Option<&str>,
        writer: &Address,
    ) -> Option<Refusal> {
        let lineage = self.lineage(id).iter().filter_map(|c| self.name(*c));
        self.authority
            .deciding(lineage, attr)
            .filter(|rule| !rule.permits(writer))
            .map(|rule| Refusal::Unauthorised(rule.clone()))
    }

    /// Stores a packet; returns the entity's previous own value of that attribute.
    #[inline]
    pub fn store(&mut self, key: Key, packet: Packet, revision: u64) -> Option<Stored> {
        let of_class = self.class(key.object).is_some();
        self.kept.changed(key, of_class);
        let e = self.get_mut(key.object)?;
        let new = Stored {
            attr: key.attr,
            packet,
            revision,
        };
        match e.values.iter_mut().find(|s| s.attr == key.attr) {
            Some(slot) => Some(std::mem::replace(slot, new)),
            None => {
                e.values.push(new);
                None
            }
        }
    }

    /// Puts back what [`State::store`] replaced.
    pub fn unstore(&mut self, key: Key, previous: Option<Stored>) {
        let of_class = self.class(key.object).is_some();
        self.kept.changed(key, of_class);
        let Some(e) = self.get_mut(key.object) else {
            return;
        };
        match previous {
            Some(p) => {
                if let Some(slot) = e.values.iter_mut().find(|s| s.attr == key.attr) {
                    *slot = p;
                }
            }
            None => e.values.retain(|s| s.attr != key.attr),
        }
    }

    // ----- objects -----

    pub fn create(
        &mut self,
        class: &str,
        name: &str,
        context: Context,
        owner: Address,
    ) -> Result<ObjectId, CreateError> {
        if !valid_name(name) {
            return Err(CreateError::BadName(name.to_owned()));
        }
        let class_id = self
            .class_id(class)
            .ok_or_else(|| CreateError::UnknownClass(class.to_owned()))?;
        if self.names.contains_key(name) {
            return Err(CreateError::Exists(name.to_owned()));
        }
        let slot_in_class = self.class(class_id).map_or(0, |c| c.instances.len());
        let data = InstanceData {
            class: class_id,
            context,
            owner,
            slot_in_class,
        };
        let id = self.insert(entity(name.into(), Kind::Instance(data)));
        if let Some(Kind::Class(c)) = self.get_mut(class_id).map(|e| &mut e.kind) {
            c.instances.push(id);
        }
        Ok(id)
    }

    /// Removes an instance; returns it so that [`State::restore`] can put it back.
    pub fn remove(&mut self, name: &str) -> Result<(ObjectId, Entity), DeleteError> {
        let id = self
            .id(name)
            .ok_or_else(|| DeleteError::UnknownObject(name.to_owned()))?;
        let Some(inst) = self.get(id).and_then(Entity::instance) else {
            return Err(DeleteError::WrongKind {
                name: name.to_owned(),
                what: "a class",
                use_instead: "delete_class",
            });
        };
        let (class, pos) = (inst.class, inst.slot_in_class);
        if let Some(Kind::Class(c)) = self.get_mut(class).map(|e| &mut e.kind) {
            c.instances.swap_remove(pos);
            let moved = c.instances.get(pos).copied();
            if let Some(Kind::Instance(m)) =
                moved.and_then(|m| self.get_mut(m)).map(|e| &mut e.kind)
            {
                m.slot_in_class = pos;
            }
        }
        Ok((id, self.take(id)))
    }

    /// Undoes [`State::remove`] (the id stays valid: the slot gets its old generation).
    pub fn restore(&mut self, id: ObjectId, mut e: Entity) {
        self.kept.clear();
        if let Some(pos) = self.free.iter().rposition(|&i| i == id.index) {
            self.free.remove(pos);
        }
        if let Kind::Instance(inst) = &mut e.kind
            && let Some(Kind::Class(c)) = self
                .slots
                .get_mut(inst.class.index as usize)
                .and_then(|s| s.entity.as_mut())
                .map(|e| &mut e.kind)
        {
            inst.slot_in_class = c.instances.len();
            c.instances.push(id);
        }
        self.names.insert(e.name.clone(), id);
        self.count_instance(&e, true);
        let slot = &mut self.slots[id.index as usize];
        slot.generation = id.generation;
        slot.entity = Some(e);
    }

    /// Undoes [`State::create`].
    pub fn uncreate(&mut self, id: ObjectId) {
        if let Some(e) = self.get(id) {
            let name = e.name.clone();
            let _ = self.remove(&name);
        }
    }

    // ----- classes -----

    /// Defines a class; `Ok(None)` if an identical definition already exists.
    pub fn define(&mut self, def: &ClassDef) -> Result<Option<ObjectId>, DefineError> {
        if !valid_name(&def.name) {
            return Err(DefineError::BadName(def.name.clone()));
        }
        if let Some(existing) = self.id(&def.name) {
            return self.same_definition(existing, def).map(|()| None);
        }
        let parent = self
            .class_id(&def.parent)
            .ok_or_else(|| DefineError::UnknownParent {
                class: def.name.clone(),
                parent: def.parent.clone(),
            })?;
        self.check_decls(parent, def)?;
        Ok(Some(self.insert_class(parent, def)))
    }

    fn same_definition(&self, existing: ObjectId, def: &ClassDef) -> Result<(), DefineError> {
        let Some(c) = self.class(existing) else {
            return Err(DefineError::NameTaken(def.name.clone()));
        };
        match describe_difference(&c.def, def) {
            None => Ok(()),
            Some(difference) => Err(DefineError::Conflict {
                name: def.name.clone(),
                difference,
            }),
        }
    }

    fn check_decls(&self, parent: ObjectId, def: &ClassDef) -> Result<(), DefineError> {
        let inherited = self.class(parent).map(|c| &c.decls);
        for (i, a) in def.attrs.iter().enumerate() {
            let bad = |why: &str| DefineError::BadDecl {
                class: def.name.clone(),
                attr: a.name.clone(),
                why: why.to_owned(),
            };
            if !valid_name(&a.name) {
                return Err(DefineError::BadAttrName {
                    class: def.name.clone(),
                    attr: a.name.clone(),
                });
            }
            let from = self.attr_id(&a.name).and_then(|id| inherited?.get(&id));
            if from.is_some() || def.attrs[..i].iter().any(|b| b.name == a.name) {
                let inherited_from = from.map(|d| self.name_or_stale(d.declared_in));
                return Err(DefineError::DuplicateAttr {
                    class: def.name.clone(),
                    attr: a.name.clone(),
                    inherited_from,
                });
            }
            if let Some((lo, hi)) = a.bounds
                && !(lo.is_finite() && hi.is_finite() && lo <= hi)
            {
                return Err(bad("bounds must be finite with min <= max"));
            }
            if a.resolution.is_some_and(|r| !(r.is_finite() && r > 0.0)) {
                return Err(bad("resolution must be finite and > 0"));
            }
            if let Some(p) = &a.default {
                check_value(&p.value, a.ty, a.bounds)
                    .and_then(|()| check_quality(p.accuracy, p.confidence))
                    .map_err(|source| DefineError::BadDefault {
                        class: def.name.clone(),
                        attr: a.name.clone(),
                        source,
                    })?;
            }
        }
        Ok(())
    }

    fn insert_class(&mut self, parent: ObjectId, def: &ClassDef) -> ObjectId {
        let (mut ancestors, mut decls, effective) = match self.class(parent) {
            Some(p) => (p.ancestors.clone(), p.decls.clone(), p.effective.clone()),
            None => Default::default(),
        };
        let id = self.insert(entity(
            def.name.as_str().into(),
            Kind::Class(Box::new(ClassData {
                def: def.clone(),
                ancestors: Vec::new(),
                decls: FxHashMap::default(),
                children: Vec::new(),
                instances: Vec::new(),
                read_fns: has_read_fns(&effective),
                effective,
            })),
        ));
        ancestors.insert(0, id);
        for a in &def.attrs {
            let attr = self.intern(&a.name);
            let default = a.default.as_ref().map_or_else(Packet::none, |p| Packet {
                value: p.value.clone(),
                accuracy: p.accuracy,
                confidence: p.confidence,
                ..Packet::none()
            });
            decls.insert(
                attr,
                Arc::new(Decl {
                    decl: a.clone(),
                    declared_in: id,
                    default,
                }),
            );
        }
        if let Some(Kind::Class(c)) = self.get_mut(id).map(|e| &mut e.kind) {
            c.ancestors = ancestors;
            c.decls = decls;
        }
        if let Some(Kind::Class(p)) = self.get_mut(parent).map(|e| &mut e.kind) {
            p.children.push(id);
        }
        id
    }

    pub fn delete_class(&mut self, name: &str) -> Result<ObjectId, DeleteError> {
        let id = self
            .id(name)
            .ok_or_else(|| DeleteError::UnknownObject(name.to_owned()))?;
        let Some(c) = self.class(id) else {
            return Err(DeleteError::WrongKind {
                name: name.to_owned(),
                what: "an object",
                use_instead: "delete",
            });
        };
        if id == self.thing {
            return Err(DeleteError::Root);
        }
        if !c.instances.is_empty() || !c.children.is_empty() {
            return Err(DeleteError::ClassInUse {
                class: name.to_owned(),
                instances: c.instances.len(),
                subclasses: c.children.len(),
            });
        }
        let parent = c.ancestors.get(1).copied();
        if let Some(Kind::Class(p)) = parent.and_then(|p| self.get_mut(p)).map(|e| &mut e.kind) {
            p.children.retain(|&ch| ch != id);
        }
        self.take(id);
        Ok(id)
    }

    // ----- active functions -----

    /// Attaches a function to an object's or a class's attribute. A class's function
    /// reaches every instance and every subclass, existing or created later.
    pub fn attach(&mut self, key: Key, trigger: Trigger, f: FnRef) {
        self.kept.clear();
        let Some(e) = self.get_mut(key.object) else {
            return;
        };
        e.fns.entry((key.attr, trigger)).or_default().push(f);
        if e.class_data().is_some() {
            self.recompute_effective(key.object);
        }
    }

    /// Removes one attached function (the same `Arc`); returns whether it was attached.
    pub fn detach(&mut self, key: Key, trigger: Trigger, f: &FnRef) -> bool {
        self.kept.clear();
        let Some(e) = self.get_mut(key.object) else {
            return false;
        };
        let Some(fns) = e.fns.get_mut(&(key.attr, trigger)) else {
            return false;
        };
        let before = fns.len();
        fns.retain(|g| !Arc::ptr_eq(g, f));
        let removed = fns.len() < before;
        if removed && e.class_data().is_some() {
            self.recompute_effective(key.object);
        }
        removed
    }

    fn recompute_effective(&mut self, class: ObjectId) {
        let parent = self.class(class).and_then(|c| c.ancestors.get(1).copied());
        let mut table = parent
            .and_then(|p| self.class(p))
            .map(|p| p.effective.clone())
            .unwrap_or_default();
        let Some(e) = self.get_mut(class) else { return };
        for (k, fns) in &e.fns {
            table.entry(*k).or_default().extend(fns.iter().cloned());
        }
        let children = match &mut e.kind {
            Kind::Class(c) => {
                c.read_fns = has_read_fns(&table);
                c.effective = table;
                c.children.clone()
            }
            Kind::Instance(_) => return,
        };
        for child in children {
            self.recompute_effective(child);
        }
    }

    // ----- slab -----

    fn insert(&mut self, e: Entity) -> ObjectId {
        self.kept.clear();
        self.count_instance(&e, true);
        let name = e.name.clone();
        let id = match self.free.pop() {
            Some(index) => {
                let slot = &mut self.slots[index as usize];
                slot.entity = Some(e);
                ObjectId {
                    index,
                    generation: slot.generation,
                }
            }
            None => {
                self.slots.push(Slot {
                    generation: 0,
                    entity: Some(e),
                });
                ObjectId {
                    index: (self.slots.len() - 1) as u32,
                    generation: 0,
                }
            }
        };
        self.names.insert(name, id);
        id
    }

    fn take(&mut self, id: ObjectId) -> Entity {
        self.kept.clear();
        let slot = &mut self.slots[id.index as usize];
        let e = slot.entity.take().expect("take of a live entity");
        slot.generation = slot.generation.wrapping_add(1);
        self.free.push(id.index);
        self.names.remove(&e.name);
        self.count_instance(&e, false);
        e
    }

    fn intern(&mut self, name: &str) -> AttrId {
        if let Some(id) = self.attr_ids.get(name) {
            return *id;
        }
        let id = AttrId(self.attr_names.len() as u32);
        let name: Arc<str> = name.into();
        self.attr_names.push(name.clone());
        self.attr_ids.insert(name, id);
        id
    }
}

/// A total order on packets with the same timestamp and source (which a correct source
/// never sends twice), so that even then every board keeps the same one.
fn tie_break(p: &Packet) -> (u64, u64, String) {
    (
        p.confidence.to_bits(),
        p.accuracy.to_bits(),
        format!("{:?}", p.value),
    )
}

fn has_read_fns(table: &FnTable) -> bool {
    table
        .iter()
        .any(|((_, t), fns)| *t == Trigger::Read && !fns.is_empty())
}

fn entity(name: Arc<str>, kind: Kind) -> Entity {
    Entity {
        name,
        kind,
        values: Vec::new(),
        fns: FnTable::default(),
    }
}

/// Says how two definitions of one class differ, or `None` if they are the same.
fn describe_difference(old: &ClassDef, new: &ClassDef) -> Option<String> {
    if old.parent != new.parent {
        // The root class has no parent: say so rather than print an empty name.
        let here = if old.parent.is_empty() {
            "it is the root class here (no parent)".to_owned()
        } else {
            format!("parent {} here", old.parent)
        };
        return Some(format!(
            "{here}, parent {} in the new definition",
            new.parent
        ));
    }
    for a in &old.attrs {
        match new.attrs.iter().find(|b| b.name == a.name) {
            None => {
                return Some(format!(
                    "attribute {} is missing from the new definition",
                    a.name
                ));
            }
            Some(b) if b != a => {
                return Some(format!(
                    "attribute {} differs: {a:?} here, {b:?} in the new definition",
                    a.name
                ));
            }
            Some(_) => {}
        }
    }
    new.attrs
        .iter()
        .find(|b| !old.attrs.iter().any(|a| a.name == b.name))
        .map(|b| format!("the new definition adds attribute {}", b.name))
}

/// Refuses a plain local write to a guarded attribute ([`AttrDecl::guarded`]) of an
/// object this board keeps (`me` owns it, or it is a class). On another module's object the
/// write is a request to that module's machinery, which answers it (a node's engine cancels
/// a plan whose copy was written `cancelled`, and restores any other state).
fn refuse_guarded(
    e: &Entity,
    decl: &AttrDecl,
    me: &Address,
    object: impl FnOnce() -> String,
) -> Result<(), WriteError> {
    let kept_here = e.instance().is_none_or(|i| i.owner == *me);
    if !(decl.guarded && kept_here) {
        return Ok(());
    }
    Err(WriteError::Guarded {
        object: object(),
        attr: decl.name.clone(),
    })
}

/// The owner of `e`, if `decl` is `owned` there and `writer` is not that owner.
fn not_owner<'e>(e: &'e Entity, decl: &AttrDecl, writer: &Address) -> Option<&'e Address> {
    e.instance()
        .map(|i| &i.owner)
        .filter(|owner| decl.merge == crate::MergePolicy::Owned && *owner != writer)
}
