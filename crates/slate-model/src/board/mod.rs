//! The Board: one module's copy of the world model, and the SBIPs that touch it.

mod batch;
mod builder;
mod chain;
mod dispatch;
mod dump;
mod hook;
mod kept;
mod snapshot;
pub(crate) mod state;
mod txn;
pub(crate) mod watch;

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use crossbeam_channel::Receiver;
use parking_lot::{Mutex, RwLock};

pub use batch::Batch;
pub use builder::BoardBuilder;
pub(crate) use chain::{Chain, Running};
pub(crate) use dispatch::{Access, PendingRead};
pub use hook::{ChangeHook, TouchKind, Touched};
pub(crate) use kept::note_time;
pub use kept::{ReadSet, ReadTrace};
pub use snapshot::Snapshot;
use state::{Origin, State};
use txn::{Inner, Txn};
pub use watch::{BoardEvent, Change, ChangeItem, Cursor, Filter, Gather, RevisedItem, Watch};

use crate::{
    Address, AttrDecl, ClassDef, Clock, Context, CreateError, DefineError, DeleteError, EveryPer,
    Key, LookupError, ObjectId, Packet, ReadError, THING, Trigger, Update, Wake, WakingSender,
    WriteError,
};

/// Default limit on the depth of chains of active functions.
pub const DEFAULT_MAX_DEPTH: usize = 8;

/// The most active functions one thread runs inside one another, whatever the boards and
/// their limits: each nested function takes stack (a Python callable some 10 KiB), and a
/// thread's stack must never overflow. An access that would go deeper is cut as
/// [`ChainError::DepthLimit`] with this limit.
pub const MAX_NESTED_FUNCTIONS: usize = 128;

/// A module's blackboard: the class tree, its objects, and their attribute packets.
///
/// A `Board` is shared by many threads (`Arc<Board>`); every method takes `&self`.
/// Readers never wait behind active functions or notifications: a write holds the lock
/// only to validate and store, and runs its on-write functions after releasing it.
/// A batch is applied under one lock acquisition, so no reader ever sees half of it.
///
/// ```
/// use slate_model::{AttrDecl, Board, ClassDef, ValueType, Update};
/// let board = Board::new();
/// board.define(ClassDef::new("Vehicle").attr(AttrDecl::new("speed", ValueType::Real).default_value(0.0)))?;
/// board.create("Vehicle", "gsr")?;
/// board.write("gsr", "speed", Update::new(2.5).accuracy(0.1).confidence(0.9))?;
/// let p = board.read("gsr", "speed")?;
/// assert_eq!(p.value.as_f64(), Some(2.5));
/// assert_eq!(p.confidence, 0.9);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Board {
    /// Unique in the process: see [`Board::id`].
    id: u64,
    inner: RwLock<Inner>,
    clock: Clock,
    address: Address,
    max_depth: usize,
    /// Those told of the board's events, and the wake each gave, touched after each.
    subscribers: Mutex<Vec<WakingSender<BoardEvent>>>,
    function_failures: AtomicU64,
    chain_cuts: AtomicU64,
    future_stamps: AtomicU64,
    not_owner: AtomicU64,
    unauthorised: AtomicU64,
    /// The refusals' news: at most one event a second per kind and source.
    news: Mutex<EveryPer<NewsKey>>,
    fn_seq: AtomicU64,
}

/// Where a read or write goes: names, or a resolved key.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Target<'a> {
    Names(&'a str, &'a str),
    Key(Key),
}

impl Target<'_> {
    fn resolve(self, st: &State) -> Result<Key, state::Missing> {
        match self {
            Target::Names(o, a) => st.key(o, a),
            // Checked by the read or write that uses it.
            Target::Key(k) => Ok(k),
        }
    }
}

/// How to create an object: class, name, context, owner.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NewObject {
    /// Class name.
    pub class: String,
    /// Object name.
    pub name: String,
    /// Context (default SURROUNDINGS).
    pub context: Context,
    /// Owner (default: the board's address).
    pub owner: Option<Address>,
}

impl NewObject {
    /// An object of `class` named `name`.
    pub fn new(class: &str, name: &str) -> Self {
        NewObject {
            class: class.to_owned(),
            name: name.to_owned(),
            context: Context::default(),
            owner: None,
        }
    }

    /// Sets the context.
    pub fn context(mut self, context: Context) -> Self {
        self.context = context;
        self
    }

    /// Sets the owner.
    pub fn owner(mut self, owner: Address) -> Self {
        self.owner = Some(owner);
        self
    }
}

/// Which objects a query selects: instances of a class and its subclasses, optionally
/// only those in one context or owned by one module.
///
/// ```
/// use slate_model::{Context, Query};
/// let q = Query::class("Vehicle").context(Context::System);
/// # let _ = q;
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Query {
    /// Class name.
    pub class: String,
    /// Only this context.
    pub context: Option<Context>,
    /// Only objects owned by this module.
    pub owner: Option<Address>,
}

impl Query {
    /// Every instance of `class` and its subclasses.
    pub fn class(class: &str) -> Self {
        Query {
            class: class.to_owned(),
            context: None,
            owner: None,
        }
    }

    /// Only objects in `context`.
    pub fn context(mut self, context: Context) -> Self {
        self.context = Some(context);
        self
    }

    /// Only objects owned by `owner`.
    pub fn owner(mut self, owner: Address) -> Self {
        self.owner = Some(owner);
        self
    }
}

/// What a board knows about one object or class.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectInfo {
    /// Handle.
    pub id: ObjectId,
    /// Name.
    pub name: Arc<str>,
    /// Its class (for a class: its parent; `Thing`'s is `Thing`).
    pub class: Arc<str>,
    /// Is it a class?
    pub is_class: bool,
    /// Context (classes: SURROUNDINGS).
    pub context: Context,
    /// Owning module (classes: unknown).
    pub owner: Address,
}

/// What [`Board::merge`] did with a received packet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Merged {
    /// Stored, at this revision.
    Applied(u64),
    /// The board's own packet wins; nothing changed.
    Kept,
    /// The attribute is `owned` and the packet's source is not the object's owner.
    NotOwner,
    /// The rule of this board deciding the write ([`crate::WriteAuthority`]) does not
    /// let the packet's source write it.
    Unauthorised,
    /// The packet is stamped further ahead of this board's clock than it tolerates (a
    /// wrong clock elsewhere): refused, or it would win every merge until then.
    FromTheFuture {
        /// How far ahead of this board's physical time it was.
        ahead: std::time::Duration,
    },
}

/// Rewrites every packet a board writes itself (its source is the board's address)
/// before it is validated again and stored: received packets are left alone.
///
/// The ICI installs one that quantises packets exactly as the wire will carry them, so
/// that the writer holds the very packet every receiver decodes.
pub trait Normaliser: Send + Sync {
    /// Rewrites `packet`, an own write of an attribute declared as `decl`.
    fn normalise(&self, decl: &crate::AttrDecl, packet: &mut Packet);
}

/// Counters a board keeps about itself.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BoardStats {
    /// Current revision.
    pub revision: u64,
    /// Live objects (instances).
    pub objects: usize,
    /// Live classes (including `Thing`).
    pub classes: usize,
    /// Active functions that failed or panicked.
    pub function_failures: u64,
    /// Chains of active functions cut for depth or a cycle.
    pub chain_cuts: u64,
    /// Received packets refused for a stamp beyond the clock's tolerance.
    pub future_stamps: u64,
    /// Received packets for an `owned` attribute refused: their source is not its owner.
    pub not_owner: u64,
    /// Received packets and objects refused: this board's rules ([`crate::WriteAuthority`])
    /// do not let their source write them.
    pub unauthorised: u64,
}

impl Default for Board {
    fn default() -> Self {
        Board::new()
    }
}

impl Board {
    /// A board with the system clock and the default address.
    pub fn new() -> Self {
        BoardBuilder::default().build()
    }

    /// A builder for a board with its own clock, address or limits.
    pub fn builder() -> BoardBuilder {
        BoardBuilder::default()
    }

    /// The board's clock.
    pub fn clock(&self) -> &Clock {
        &self.clock
    }

    /// The board's module address.
    pub fn address(&self) -> &Address {
        &self.address
    }

    /// The current revision: it grows by one with every write, batch, create and delete.
    pub fn revision(&self) -> u64 {
        self.inner.read().state.revision
    }

    // ----- classes -----

    /// Defines a class. Defining an identical class again is a no-op; a different
    /// definition under the same name is a [`DefineError::Conflict`].
    pub fn define(&self, def: ClassDef) -> Result<ObjectId, DefineError> {
        let mut inner = self.inner.write();
        let st = &mut inner.state;
        match st.define(&def)? {
            Some(id) => Ok(id),
            None => st.id(&def.name).ok_or(DefineError::NameTaken(def.name)),
        }
    }

    /// Defines the built-in classes (see [`crate::builtin_classes`]): every board has them
    /// from the start, so that files and plans may name them before the ICI or the plan
    /// engine runs.
    fn define_builtins(&self) {
        let mut inner = self.inner.write();
        for def in crate::builtin_classes() {
            // A fresh board has no class of these names: defining them cannot fail.
            let _ = inner.state.define(&def);
        }
    }

    /// Deletes a class that has no instances and no subclasses.
    pub fn delete_class(&self, name: &str) -> Result<(), DeleteError> {
        self.inner.write().state.delete_class(name).map(|_| ())
    }

    /// The definition of a class.
    pub fn class_def(&self, name: &str) -> Option<ClassDef> {
        let inner = self.inner.read();
        inner
            .state
            .class_id(name)
            .and_then(|id| inner.state.class(id))
            .map(|c| c.def.clone())
    }

    /// Every class definition except `Thing`, parents before children.
    pub fn class_defs(&self) -> Vec<ClassDef> {
        let inner = self.inner.read();
        let st = &inner.state;
        let mut out = Vec::new();
        let mut stack = vec![st.thing];
        while let Some(id) = stack.pop() {
            let Some(c) = st.class(id) else { continue };
            if id != st.thing {
                out.push(c.def.clone());
            }
            stack.extend(c.children.iter().rev());
        }
        out
    }

    /// The class tree now, as a value to walk without asking the board again (lineages,
    /// declarations; see [`ClassTree`](crate::ClassTree) for the rules).
    pub fn class_tree(&self) -> crate::ClassTree {
        crate::ClassTree::new(&self.class_defs())
    }

    /// The declaration of `attr` that `class` and its instances have (declared there or
    /// inherited); `None` if there is no such class or attribute. One lookup in the
    /// board's own flattened declarations, cheaper than building a
    /// [`class_tree`](Board::class_tree) for one answer.
    pub fn attr_decl(&self, class: &str, attr: &str) -> Option<AttrDecl> {
        let inner = self.inner.read();
        let st = &inner.state;
        let c = st.class(st.class_id(class)?)?;
        c.decls.get(&st.attr_id(attr)?).map(|d| d.decl.clone())
    }

    // ----- authority -----

    /// Sets who may write what on this board besides its own module (`[authority]
    /// writes`; docs/security.md, "Authority over writes"). Received packets and objects
    /// are judged by it from then on.
    pub fn set_write_authority(&self, authority: crate::WriteAuthority) {
        self.inner.write().state.authority = Arc::new(authority);
    }

    /// Who may write what on this board besides its own module.
    pub fn write_authority(&self) -> Arc<crate::WriteAuthority> {
        self.inner.read().state.authority.clone()
    }

    /// Would this board take a write of `object.attr` by `writer`? The one rule of who
    /// may write what, which [`merge`](Board::merge) applies to every received packet: an
    /// `owned` attribute only its owner ([`WriteError::NotOwner`]), and otherwise what
    /// the rule deciding it allows another module than this board's
    /// ([`WriteError::Unauthorised`]). Nothing is counted or reported: for a writer that
    /// acts for another (a received plan, which runs with its origin's authority).
    pub fn write_refusal(
        &self,
        object: &str,
        attr: &str,
        writer: &Address,
    ) -> Result<(), WriteError> {
        let inner = self.inner.read();
        let st = &inner.state;
        let key = st.key(object, attr)?;
        match st.write_refusal(key, writer, &self.address)? {
            None => Ok(()),
            Some(refusal) => Err(refusal_error(object, Some(attr), writer, refusal)),
        }
    }

    /// Would this board let `writer` delete `object`? A deletion takes away every value
    /// the object holds, so it is refused when creating an object of its class, or a
    /// write of any of its attributes, would be ([`write_refusal`](Board::write_refusal)).
    /// An object the board does not hold is not refused here: deleting it fails on its
    /// own. Nothing is counted or reported: for a received plan, which deletes with its
    /// origin's authority.
    pub fn delete_refusal(&self, object: &str, writer: &Address) -> Result<(), WriteError> {
        let inner = self.inner.read();
        let st = &inner.state;
        let refused = st
            .id(object)
            .and_then(|id| st.delete_refusal(id, writer, &self.address));
        match refused {
            None => Ok(()),
            Some((attr, refusal)) => Err(refusal_error(object, attr.as_deref(), writer, refusal)),
        }
    }

    /// May `writer` write `attr` of an object `object` of `class` here (with `attr`
    /// `None`: create it)? What the rules deciding it allow another module than this
    /// board's ([`crate::WriteAuthority`]; whole-class rules alone decide a creation),
    /// judged by class, so the object need not be on the board yet: for a receiver that
    /// keeps packets elsewhere (the ICI's `fused` estimates) or creates objects (the
    /// ICI, a received plan). `owned` is judged where the object is
    /// ([`write_refusal`](Board::write_refusal)). A refusal is counted and reported when
    /// `report` (a [`BoardEvent::Unauthorised`], at most once a second per writer), as
    /// for a packet; else only judged.
    pub fn admit_write(
        &self,
        class: &str,
        object: &str,
        attr: Option<&str>,
        writer: &Address,
        report: bool,
    ) -> Result<(), WriteError> {
        let refusal = {
            let inner = self.inner.read();
            let st = &inner.state;
            match st.class_id(class) {
                Some(id) if *writer != self.address => st.unauthorised(id, attr, writer),
                _ => None,
            }
        };
        let Some(refusal) = refusal else {
            return Ok(());
        };
        if report && let state::Refusal::Unauthorised(rule) = &refusal {
            self.report(unauthorised(object, attr, writer, rule));
        }
        Err(refusal_error(object, attr, writer, refusal))
    }

    // ----- objects -----

    /// Creates an object of `class` in the SURROUNDINGS context, owned by this board.
    pub fn create(&self, class: &str, name: &str) -> Result<ObjectId, CreateError> {
        self.create_with(NewObject::new(class, name))
    }

    /// Creates an object as described.
    pub fn create_with(&self, spec: NewObject) -> Result<ObjectId, CreateError> {
        let owner = spec.owner.unwrap_or_else(|| self.address.clone());
        let mut inner = self.inner.write();
        let mut txn = Txn::new(&mut inner, &self.clock, &self.address, 1);
        let id = txn.create(&spec.class, &spec.name, spec.context, owner)?;
        let done = txn.commit();
        drop(inner);
        self.finish(done, &Chain::default());
        Ok(id)
    }

    /// Deletes an object. References to it elsewhere become dangling (see [`crate::Value`]).
    pub fn delete(&self, name: &str) -> Result<u64, DeleteError> {
        let mut inner = self.inner.write();
        let mut txn = Txn::new(&mut inner, &self.clock, &self.address, 1);
        txn.delete(name)?;
        let done = txn.commit();
        drop(inner);
        Ok(self.finish(done, &Chain::default()))
    }

    /// What the board knows about an object or class.
    pub fn info(&self, name: &str) -> Option<ObjectInfo> {
        let inner = self.inner.read();
        let st = &inner.state;
        st.id(name).and_then(|id| object_info(st, id))
    }

    /// Is `name` an object of class `class` itself (not of a subclass)? `None` if the
    /// board has nothing by that name; `Some(false)` for a class or another class's
    /// object. Cheaper than [`info`](Board::info) when that is all one needs.
    pub fn is_instance_of(&self, name: &str, class: &str) -> Option<bool> {
        let inner = self.inner.read();
        let st = &inner.state;
        let e = st.get(st.id(name)?)?;
        Some(
            e.instance()
                .and_then(|i| st.get(i.class))
                .is_some_and(|c| &*c.name == class),
        )
    }

    /// The name of an object or class (`None` if the handle is stale).
    pub fn name_of(&self, id: ObjectId) -> Option<Arc<str>> {
        self.inner.read().state.name(id)
    }

    /// The small integer standing for an attribute name on this board, if any class
    /// declares it.
    pub fn attr_id(&self, name: &str) -> Option<crate::AttrId> {
        self.inner.read().state.attr_id(name)
    }

    /// The name of an attribute id.
    pub fn attr_name(&self, attr: crate::AttrId) -> Arc<str> {
        self.inner.read().state.attr_name(attr)
    }

    /// The classes `id` is: for an object its class and that class's ancestors, for a
    /// class itself and its ancestors, up to `Thing` (empty if the handle is stale).
    pub fn lineage(&self, id: ObjectId) -> Vec<ObjectId> {
        self.inner.read().state.lineage(id).to_vec()
    }

    /// Instances of `class` and of all its subclasses.
    pub fn instances(&self, class: &str) -> Result<Vec<ObjectId>, LookupError> {
        self.query(&Query::class(class))
    }

    /// Instances of a class (and subclasses) filtered by context and owner.
    pub fn query(&self, query: &Query) -> Result<Vec<ObjectId>, LookupError> {
        instances(&self.inner.read().state, query)
    }

    // ----- reads -----

    /// Resolves `object.attr` once, for fast repeated reads and writes.
    pub fn key(&self, object: &str, attr: &str) -> Result<Key, LookupError> {
        Ok(self.inner.read().state.key(object, attr)?)
    }

    /// Reads an attribute: the object's own packet, else its class chain's, else the
    /// declared default; then the on-read active functions may change what is returned.
    pub fn read(&self, object: &str, attr: &str) -> Result<Packet, ReadError> {
        self.read_in(Target::Names(object, attr), &Chain::default())
    }

    /// Reads through a resolved key.
    pub fn read_key(&self, key: Key) -> Result<Packet, ReadError> {
        self.read_in(Target::Key(key), &Chain::default())
    }

    pub(crate) fn read_in(&self, target: Target<'_>, chain: &Chain) -> Result<Packet, ReadError> {
        let pending = {
            let inner = self.inner.read();
            match PendingRead::new(self, &inner.state, target)? {
                Ok(packet) => return Ok(packet),
                Err(pending) => pending,
            }
        };
        pending.finish(self, Access::Live(self), chain)
    }

    /// Is everything `reads` read as it was? No attribute of it stored again since, no
    /// kept packet of it dropped, nothing else of the board changed (objects, classes,
    /// class-level values, functions). `false` for a set of another board.
    pub fn unchanged_since(&self, reads: &ReadSet) -> bool {
        let inner = self.inner.read();
        let st = &inner.state;
        reads.board == self.id
            && st.kept.structure() == reads.structure
            && reads.keys.iter().all(|k| {
                st.get(k.object)
                    .and_then(|e| e.own(k.attr))
                    .is_none_or(|s| s.revision <= reads.revision)
            })
            && reads.derived.iter().all(|(k, s)| st.kept.holds(*k, *s))
    }

    /// A consistent view of the whole board. While it lives, writers wait: keep it short,
    /// and do not write to the board from the thread that holds it.
    pub fn snapshot(&self) -> Snapshot<'_> {
        Snapshot::new(self, self.inner.read())
    }

    // ----- writes -----

    /// Writes an attribute: validates, stamps, stores, notifies watchers, then runs the
    /// on-write active functions. Returns the revision of the write.
    pub fn write(
        &self,
        object: &str,
        attr: &str,
        update: impl Into<Update>,
    ) -> Result<u64, WriteError> {
        self.write_in(
            Target::Names(object, attr),
            update.into(),
            &Chain::default(),
        )
    }

    /// This board's identity, unique in the process (a token names the board it was
    /// taken on; an address in memory could be reused by a later board).
    pub(crate) fn id(&self) -> u64 {
        self.id
    }

    /// Writes through a resolved key.
    pub fn write_key(&self, key: Key, update: impl Into<Update>) -> Result<u64, WriteError> {
        self.write_in(Target::Key(key), update.into(), &Chain::default())
    }

    pub(crate) fn write_in(
        &self,
        target: Target<'_>,
        update: Update,
        chain: &Chain,
    ) -> Result<u64, WriteError> {
        let chain = &*chain.or_running(self.id());
        let done = {
            let mut inner = self.inner.write();
            let key = target.resolve(&inner.state)?;
            let st = &inner.state;
            let names = || {
                (
                    st.name(key.object).unwrap_or_else(|| "?".into()),
                    st.attr_name(key.attr),
                )
            };
            if let Err(cut) = chain.admit(key, Trigger::Write, self.max_depth, names) {
                drop(inner);
                self.report(BoardEvent::ChainCut(cut.clone()));
                return Err(cut.into());
            }
            if !inner.is_observed() && !inner.state.may_have_fns(key) {
                // The common case: nobody to notify, nothing to run.
                let st = &mut inner.state;
                let packet =
                    st.prepare(key, update, &self.clock, &self.address, None, Origin::Own)?;
                st.revision += 1;
                let revision = st.revision;
                st.store(key, packet, revision);
                return Ok(revision);
            }
            let mut txn = Txn::new(&mut inner, &self.clock, &self.address, 1);
            txn.write(key, update)?;
            txn.commit()
        };
        Ok(self.finish(done, chain))
    }

    /// Applies a packet received from another board through the attribute's merge policy,
    /// atomically with respect to local writes. The packet keeps its timestamp and source.
    ///
    /// - `latest` (and `fused`, whose per-source fusion the ICI does before writing): the
    ///   packet wins if its `(timestamp, source)` is greater than the object's own packet's;
    /// - `confident`: the higher confidence wins, ties by `latest`;
    /// - `owned`: only packets from the object's owner are applied (then by `latest`);
    ///   another's is refused ([`Merged::NotOwner`], reported as [`BoardEvent::NotOwner`]);
    /// - any policy: a packet stamped beyond the clock's tolerance is refused
    ///   ([`Merged::FromTheFuture`], reported as [`BoardEvent::FutureStamp`]).
    ///
    /// The same packets merged in any order, any number of times, leave every board with the
    /// same packet: this is what makes copies converge.
    pub fn merge(&self, object: &str, attr: &str, packet: Packet) -> Result<Merged, WriteError> {
        let mut outcome = self.merge_all([(object, attr, packet)]);
        outcome.pop().unwrap_or(Ok(Merged::Kept))
    }

    /// Merges received packets `(object, attribute, packet)` as [`merge`](Board::merge)
    /// does, as one change: one lock, one revision, one notification to each watcher and
    /// hook. Each packet is judged on its own, against what the packets before it left,
    /// so a refused one keeps none of the others out. Returns each packet's outcome, in
    /// order.
    pub fn merge_all<O, A>(
        &self,
        packets: impl IntoIterator<Item = (O, A, Packet)>,
    ) -> Vec<Result<Merged, WriteError>>
    where
        O: AsRef<str>,
        A: AsRef<str>,
    {
        self.merge_all_keyed(packets.into_iter().map(|(o, a, p)| (o, a, None, p)))
    }

    /// As [`merge_all`](Board::merge_all), each packet with the [`Key`] its names
    /// resolved to before on this board, if known: a key to an object that still exists
    /// spares looking the names up; one to a deleted object is ignored (the names are).
    pub fn merge_all_keyed<O, A>(
        &self,
        packets: impl IntoIterator<Item = (O, A, Option<Key>, Packet)>,
    ) -> Vec<Result<Merged, WriteError>>
    where
        O: AsRef<str>,
        A: AsRef<str>,
    {
        let packets = packets.into_iter();
        let mut out = Vec::with_capacity(packets.size_hint().0);
        let mut refused = Vec::new();
        let done = {
            let mut inner = self.inner.write();
            let mut txn = Txn::new(&mut inner, &self.clock, &self.address, 1);
            let mut any = false;
            for (object, attr, key, packet) in packets {
                let one = || -> Result<Merged, WriteError> {
                    // A live object's key names the attribute it was made for: neither
                    // an object's class nor an attribute's id ever changes.
                    let key = match key.filter(|k| txn.state().get(k.object).is_some()) {
                        Some(key) => key,
                        None => txn.state().key(object.as_ref(), attr.as_ref())?,
                    };
                    if let Err(drift) = self.clock.check(packet.timestamp) {
                        refused.push(future_stamp(object.as_ref(), attr.as_ref(), &packet, drift));
                        return Ok(Merged::FromTheFuture { ahead: drift.ahead });
                    }
                    let st = txn.state();
                    let (o, a) = (object.as_ref(), attr.as_ref());
                    match st.write_refusal(key, &packet.source, &self.address)? {
                        Some(state::Refusal::NotOwner(owner)) => {
                            refused.push(not_owner(o, a, &packet, owner));
                            return Ok(Merged::NotOwner);
                        }
                        Some(state::Refusal::Unauthorised(rule)) => {
                            refused.push(unauthorised(o, Some(a), &packet.source, &rule));
                            return Ok(Merged::Unauthorised);
                        }
                        None => {}
                    }
                    let verdict = st.merge_verdict(key, &packet)?;
                    if verdict == Merged::Applied(0) {
                        txn.merge(key, packet)?;
                    }
                    Ok(verdict)
                };
                let result = one();
                any |= matches!(result, Ok(Merged::Applied(_)));
                out.push(result);
            }
            // Nothing stored: the transaction is dropped without a revision.
            any.then(|| txn.commit())
        };
        for event in refused {
            self.report(event);
        }
        if let Some(done) = done {
            let revision = self.finish(done, &Chain::default());
            for r in &mut out {
                if let Ok(Merged::Applied(rev)) = r {
                    *rev = revision;
                }
            }
        }
        out
    }

    /// Is a received packet's stamp within this board's clock tolerance? One beyond it
    /// would win every `latest` merge until the clock caught up (years, for a wrong
    /// clock), so it is refused: reported as a [`BoardEvent::FutureStamp`] and counted.
    /// [`merge`](Board::merge) checks every packet; a receiver that keeps packets
    /// elsewhere (the ICI's `fused` estimates) checks them here first.
    pub fn admit_stamp(
        &self,
        object: &str,
        attr: &str,
        packet: &Packet,
    ) -> Result<(), crate::ClockDriftError> {
        self.clock.check(packet.timestamp).inspect_err(|drift| {
            self.report(future_stamp(object, attr, packet, *drift));
        })
    }

    /// Installs the [`Normaliser`] of this board's own writes (`None` removes it). Only
    /// writes from then on pass through it.
    pub fn set_normaliser(&self, normaliser: Option<Arc<dyn Normaliser>>) {
        self.inner.write().state.normaliser = normaliser;
    }

    /// Starts an atomic batch of writes, creations and deletions.
    pub fn batch(&self) -> Batch<'_> {
        Batch::new(self)
    }

    // ----- watching -----

    /// Subscribes to the changes matching `filter`. Every write notifies once, every
    /// batch once (with all its matching items), in revision order.
    pub fn watch(&self, filter: Filter) -> Result<Watch, LookupError> {
        self.subscribe(filter, None, None)
    }

    /// Like [`watch`](Board::watch), touching `wake` after each change it is handed: a
    /// manual clock's listener that reads it can sleep until there is one
    /// ([`Clock::subscribe_waking`](crate::Clock::subscribe_waking)).
    pub fn watch_waking(&self, filter: Filter, wake: Arc<Wake>) -> Result<Watch, LookupError> {
        self.subscribe(filter, None, Some(wake))
    }

    /// Like [`watch`](Board::watch), but at most `capacity` changes wait for the reader:
    /// when it falls further behind, a writer drops the change and counts it
    /// ([`Watch::dropped`]) instead of queueing without bound. For readers that must
    /// never hold the writers up nor grow memory, like a recorder.
    pub fn watch_bounded(&self, filter: Filter, capacity: usize) -> Result<Watch, LookupError> {
        self.subscribe(filter, Some(capacity.max(1)), None)
    }

    /// Like [`watch_bounded`](Board::watch_bounded), for a reader that takes every
    /// waiting change at once ([`Gather`]): at most `capacity` items wait.
    pub fn watch_gathered(&self, filter: Filter, capacity: usize) -> Result<Gather, LookupError> {
        self.add_watcher(filter, |spec| watch::gather(spec, capacity.max(1)))
    }

    fn subscribe(
        &self,
        filter: Filter,
        capacity: Option<usize>,
        wake: Option<Arc<Wake>>,
    ) -> Result<Watch, LookupError> {
        self.add_watcher(filter, |spec| watch::subscribe(spec, capacity, wake))
    }

    /// Resolves `filter` and adds the watcher `make` builds for it; its reader's end.
    fn add_watcher<R>(
        &self,
        filter: Filter,
        make: impl FnOnce(watch::Spec) -> (watch::Watcher, R),
    ) -> Result<R, LookupError> {
        let mut inner = self.inner.write();
        let spec = resolve_filter(&inner.state, &filter)?;
        let (watcher, reader) = make(spec);
        inner.watchers.push(watcher);
        Ok(reader)
    }

    /// Subscribes to the board's own events (failed active functions, cut chains).
    pub fn events(&self) -> Receiver<BoardEvent> {
        self.events_with(None)
    }

    /// Like [`events`](Board::events), touching `wake` after each event.
    pub fn events_waking(&self, wake: Arc<Wake>) -> Receiver<BoardEvent> {
        self.events_with(Some(wake))
    }

    fn events_with(&self, wake: Option<Arc<Wake>>) -> Receiver<BoardEvent> {
        let (tx, rx) = crossbeam_channel::unbounded();
        self.subscribers.lock().push(WakingSender::new(tx, wake));
        rx
    }

    /// Counters.
    pub fn stats(&self) -> BoardStats {
        let inner = self.inner.read();
        let st = &inner.state;
        let (classes, objects) = st.entities().fold((0, 0), |(c, o), (_, e)| {
            if e.class_data().is_some() {
                (c + 1, o)
            } else {
                (c, o + 1)
            }
        });
        BoardStats {
            revision: st.revision,
            objects,
            classes,
            function_failures: self.function_failures.load(Ordering::Relaxed),
            chain_cuts: self.chain_cuts.load(Ordering::Relaxed),
            future_stamps: self.future_stamps.load(Ordering::Relaxed),
            not_owner: self.not_owner.load(Ordering::Relaxed),
            unauthorised: self.unauthorised.load(Ordering::Relaxed),
        }
    }

    /// Adds a change hook, called in the writer's thread after every committed change.
    pub fn add_hook(&self, hook: Arc<dyn ChangeHook>) {
        let mut inner = self.inner.write();
        let mut hooks = inner.hooks.to_vec();
        hooks.push(hook);
        inner.hooks = hooks.into();
    }

    /// Reports that `peer` defines `class` differently from this board (the ICI, which
    /// finds it, reports it once per peer and class): an event, and a warning in the log.
    pub fn report_class_conflict(&self, class: &str, peer: &Address) {
        self.report(BoardEvent::ClassConflict {
            class: class.to_owned(),
            peer: peer.clone(),
        });
    }

    /// Reports that an object of `owner` was refused past a bound (the ICI holds the
    /// bounds and reports each refusal): an event and a warning, at most once a second
    /// per owner.
    pub fn report_object_limit(&self, owner: &Address, object: &str, limit: usize, total: bool) {
        self.report(BoardEvent::ObjectLimit {
            owner: owner.clone(),
            object: object.to_owned(),
            limit,
            total,
            suppressed: 0,
        });
    }

    /// Reports that a message from `source` was refused: its names would take what the
    /// ICI holds of `source`'s past `limit`. An event and a warning, at most once a
    /// second per source.
    pub fn report_name_limit(&self, source: &Address, limit: usize) {
        self.report(BoardEvent::NameLimit {
            source: source.clone(),
            limit,
            suppressed: 0,
        });
    }

    /// Reports that a module not heard of before was refused past the bound on modules
    /// (the ICI's `max_modules`): an event and a warning, at most once a second for all
    /// addresses together.
    pub fn report_module_limit(&self, address: &Address, limit: usize) {
        self.report(BoardEvent::ModuleLimit {
            address: address.clone(),
            limit,
            suppressed: 0,
        });
    }

    /// How many objects `owner` owns on this board (kept as objects are created and
    /// deleted, not counted on each call).
    pub fn owned_count(&self, owner: &Address) -> usize {
        self.inner.read().state.owned_count(owner)
    }

    /// How many objects (instances) this board holds, and how many of them its own
    /// module owns.
    pub fn object_counts(&self) -> (usize, usize) {
        let inner = self.inner.read();
        let st = &inner.state;
        (st.instance_count(), st.owned_count(&self.address))
    }

    /// Counts `event`, and tells it (the log, the subscribers) unless it is a refusal
    /// whose source has had one told in the last second ([`Board::limit_news`]).
    pub(crate) fn report(&self, event: BoardEvent) {
        self.count(&event);
        if let Some(event) = self.limit_news(event) {
            self.tell(event);
        }
    }

    /// Counts an event: every one, told or not.
    fn count(&self, event: &BoardEvent) {
        match event {
            BoardEvent::FunctionFailed { .. } => &self.function_failures,
            BoardEvent::ChainCut(_) => &self.chain_cuts,
            BoardEvent::FutureStamp { .. } => &self.future_stamps,
            BoardEvent::NotOwner { .. } => &self.not_owner,
            BoardEvent::Unauthorised { .. } => &self.unauthorised,
            _ => return,
        }
        .fetch_add(1, Ordering::Relaxed);
    }

    /// `event` as it is to be told, or `None` if its kind and source had one told in the
    /// last second of the board's clock: a flood from one source is one event a second,
    /// which says how many refusals it stands for (`suppressed`). Refused modules share
    /// one limit, whatever their address (they may be made up).
    fn limit_news(&self, mut event: BoardEvent) -> Option<BoardEvent> {
        use NewsKey::Source;
        let (key, suppressed) = match &mut event {
            BoardEvent::FunctionFailed {
                function,
                suppressed,
                ..
            } => (NewsKey::Function(function.clone()), suppressed),
            BoardEvent::FutureStamp {
                source, suppressed, ..
            } => (Source(NewsKind::FutureStamp, source.clone()), suppressed),
            BoardEvent::NotOwner {
                writer, suppressed, ..
            } => (Source(NewsKind::NotOwner, writer.clone()), suppressed),
            BoardEvent::Unauthorised {
                writer, suppressed, ..
            } => (Source(NewsKind::Unauthorised, writer.clone()), suppressed),
            BoardEvent::ObjectLimit {
                owner, suppressed, ..
            } => (Source(NewsKind::ObjectLimit, owner.clone()), suppressed),
            BoardEvent::NameLimit {
                source, suppressed, ..
            } => (Source(NewsKind::NameLimit, source.clone()), suppressed),
            BoardEvent::ModuleLimit { suppressed, .. } => (
                Source(NewsKind::ModuleLimit, Address::unknown()),
                suppressed,
            ),
            _ => return Some(event),
        };
        let now = self.clock.physical();
        *suppressed = self.news.lock().due(key, now)?;
        Some(event)
    }

    /// Logs `event` and hands it to every subscriber.
    fn tell(&self, event: BoardEvent) {
        match &event {
            BoardEvent::FunctionFailed {
                function,
                object,
                attr,
                error,
                ..
            } => {
                tracing::warn!(%function, %object, %attr, %error, "active function failed");
            }
            BoardEvent::ChainCut(cut) => {
                tracing::warn!(%cut, "active function chain cut");
            }
            BoardEvent::FutureStamp {
                object,
                attr,
                source,
                stamp,
                ahead,
                ..
            } => {
                tracing::warn!(%object, %attr, %source, %stamp, ?ahead, "packet stamped in the future refused");
            }
            BoardEvent::ClassConflict { class, peer } => {
                tracing::warn!(%class, %peer, "class defined differently by another module: its objects are not merged");
            }
            BoardEvent::ObjectLimit {
                owner,
                object,
                limit,
                total,
                ..
            } => {
                tracing::warn!(%owner, %object, limit, total, "objects of another module refused past this board's bound");
            }
            BoardEvent::NotOwner {
                object,
                attr,
                writer,
                owner,
                ..
            } => {
                tracing::warn!(%object, %attr, %writer, %owner, "packet for an owned attribute from another module than its owner refused");
            }
            BoardEvent::Unauthorised {
                object,
                attr,
                writer,
                rule,
                ..
            } => {
                let attr = attr.as_deref().unwrap_or("");
                tracing::warn!(%object, %attr, %writer, %rule, "a write refused: this board's rules do not let its writer write it");
            }
            BoardEvent::NameLimit { source, limit, .. } => {
                tracing::warn!(%source, limit, "a message of another module refused: it would hold more names than one module may");
            }
            BoardEvent::ModuleLimit { address, limit, .. } => {
                tracing::warn!(%address, limit, "a module not heard of before refused: as many are known as may be");
            }
        }
        self.subscribers
            .lock()
            .retain(|tx| tx.send(event.clone()).is_ok());
    }
}

pub(crate) fn instances(st: &State, query: &Query) -> Result<Vec<ObjectId>, LookupError> {
    let id = st
        .class_id(&query.class)
        .ok_or_else(|| LookupError::UnknownClass(query.class.clone()))?;
    let mut out = Vec::new();
    st.instances(id, &mut out);
    if query.context.is_some() || query.owner.is_some() {
        out.retain(|o| {
            st.get(*o).and_then(|e| e.instance()).is_some_and(|i| {
                query.context.is_none_or(|c| c == i.context)
                    && query.owner.as_ref().is_none_or(|w| *w == i.owner)
            })
        });
    }
    Ok(out)
}

pub(crate) fn object_info(st: &State, id: ObjectId) -> Option<ObjectInfo> {
    let e = st.get(id)?;
    let (class, context, owner) = match e.instance() {
        Some(i) => (st.name(i.class)?, i.context, i.owner.clone()),
        None => {
            let parent = st.lineage(id).get(1).copied().unwrap_or(id);
            (st.name(parent)?, Context::default(), Address::unknown())
        }
    };
    Some(ObjectInfo {
        id,
        name: e.name.clone(),
        class,
        is_class: e.instance().is_none(),
        context,
        owner,
    })
}

fn resolve_filter(st: &State, f: &Filter) -> Result<watch::Spec, LookupError> {
    /// `name` looked up with `find`, if there is one; not found, it is `unknown(name)`.
    fn named<T>(
        name: Option<&str>,
        find: impl FnOnce(&str) -> Option<T>,
        unknown: fn(String) -> LookupError,
    ) -> Result<Option<T>, LookupError> {
        name.map(|n| find(n).ok_or_else(|| unknown(n.to_owned())))
            .transpose()
    }
    let object = named(
        f.object.as_deref(),
        |o| st.id(o),
        LookupError::UnknownObject,
    )?;
    let class = named(
        f.class.as_deref(),
        |c| st.class_id(c),
        LookupError::UnknownClass,
    )?;
    let attr = match f.attr.as_deref() {
        None => None,
        Some(a) => Some(st.attr_id(a).ok_or_else(|| {
            LookupError::UnknownAttribute {
                object: f
                    .object
                    .clone()
                    .or_else(|| f.class.clone())
                    .unwrap_or_else(|| THING.to_owned()),
                attr: a.to_owned(),
            }
        })?),
    };
    Ok(watch::Spec {
        object,
        class,
        attr,
        own_writes: f.own_writes,
    })
}

/// The event of a received packet for an `owned` attribute refused for its writer.
fn not_owner(object: &str, attr: &str, packet: &Packet, owner: Address) -> BoardEvent {
    BoardEvent::NotOwner {
        object: object.to_owned(),
        attr: attr.to_owned(),
        writer: packet.source.clone(),
        owner,
        suppressed: 0,
    }
}

/// The event of a write (of an object, with no `attr`) refused by `rule`.
fn unauthorised(
    object: &str,
    attr: Option<&str>,
    writer: &Address,
    rule: &crate::WriteRule,
) -> BoardEvent {
    BoardEvent::Unauthorised {
        object: object.to_owned(),
        attr: attr.map(str::to_owned),
        writer: writer.clone(),
        rule: rule.to_string(),
        suppressed: 0,
    }
}

/// The error of a write `refusal` judged.
fn refusal_error(
    object: &str,
    attr: Option<&str>,
    writer: &Address,
    refusal: state::Refusal,
) -> WriteError {
    match refusal {
        state::Refusal::NotOwner(owner) => WriteError::NotOwner {
            object: object.to_owned(),
            attr: attr.unwrap_or_default().to_owned(),
            owner,
            writer: writer.clone(),
        },
        state::Refusal::Unauthorised(rule) => WriteError::Unauthorised {
            target: match attr {
                Some(attr) => format!("{object}.{attr}"),
                None => object.to_owned(),
            },
            writer: writer.clone(),
            rule: rule.to_string(),
        },
    }
}

/// The event of a received packet refused for its stamp.
fn future_stamp(
    object: &str,
    attr: &str,
    packet: &Packet,
    drift: crate::ClockDriftError,
) -> BoardEvent {
    BoardEvent::FutureStamp {
        object: object.to_owned(),
        attr: attr.to_owned(),
        source: packet.source.clone(),
        stamp: packet.timestamp,
        ahead: drift.ahead,
        suppressed: 0,
    }
}

/// What kind of refusal a piece of news is, for its rate limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum NewsKind {
    FutureStamp,
    NotOwner,
    Unauthorised,
    ObjectLimit,
    NameLimit,
    ModuleLimit,
}

/// What one piece of news is limited by: a refusal's kind and source, or the active
/// function that failed.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
enum NewsKey {
    Source(NewsKind, Address),
    Function(String),
}

/// Sources whose refusals are limited apart (past them, the others share one limit).
const NEWS_SOURCES: usize = 256;

/// The limit on the refusals' news: at most one event a second per kind and source (and
/// per failing function).
fn news_limit() -> EveryPer<NewsKey> {
    EveryPer::new(std::time::Duration::from_secs(1), NEWS_SOURCES)
}
