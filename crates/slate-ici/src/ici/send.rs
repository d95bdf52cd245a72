//! Outgoing: the board's committed changes become items (own packets through their
//! report filters, creations and deletions of owned objects), and items become
//! messages on each link kind for the peers there that want them.

use std::sync::Arc;

use smallvec::SmallVec;

use slate_model::{Address, ChangeItem, Context, MergePolicy, Packet, ReportPolicy, Timestamp};
use slate_wire::{AssertionParts, EncodeError, ObjectEntry};

use super::classes::{ClassSet, Lineage};
use super::filter::{Key, is_unfiltered};
use super::frame::{Frame, Lifecycle, Listed};
use super::module::MODULE_CLASS;
use super::ops::BoardOp;
use super::state::State;
use crate::{Flow, LinkKind, MsgKind};

/// Whether an item goes on a link kind.
enum Wanted {
    Yes,
    /// The export policy keeps it on the robot.
    NotExported,
    /// No peer up there models it.
    NoPeer,
}

/// Something to put on the streams, with what deciding its destinations needs.
pub(crate) enum Item {
    /// A packet of an attribute.
    Value(Arc<Subject>, Packet),
    /// An own object made.
    Created {
        listed: Listed,
        stamp: Timestamp,
        lineage: Lineage,
    },
    /// An own object deleted.
    Deleted {
        name: Arc<str>,
        stamp: Timestamp,
        lineage: Lineage,
        context: Context,
    },
}

/// An object's attribute as reports name it, with the class chain its destinations
/// are decided by: made once, shared by the items of all its packets.
pub(crate) struct Subject {
    pub object: ObjectEntry,
    pub attr: Arc<str>,
    pub lineage: Lineage,
    pub is_class: bool,
}

impl Item {
    /// Class chain, context, owner (`me` for a creation or deletion: only own
    /// objects' are sent), and whether it is a class's.
    pub(crate) fn dest<'a>(&'a self, me: &'a Address) -> (&'a Lineage, Context, &'a Address, bool) {
        match self {
            Item::Value(s, _) => (&s.lineage, s.object.context, &s.object.owner, s.is_class),
            Item::Created {
                listed, lineage, ..
            } => (lineage, listed.context, me, false),
            Item::Deleted {
                lineage, context, ..
            } => (lineage, *context, me, false),
        }
    }
}

/// A packet of a subject, as the encoder reads it.
struct Reported<'a>(&'a Subject, &'a Packet);

impl AssertionParts for Reported<'_> {
    fn object(&self) -> &ObjectEntry {
        &self.0.object
    }

    fn attr(&self) -> &Arc<str> {
        &self.0.attr
    }

    fn packet(&self) -> &Packet {
        self.1
    }
}

/// What reporting an attribute of an own object needs from the catalog, resolved on
/// its first write instead of on every one (where the names were hashed and compared
/// in four tables); forgotten when the catalog is rebuilt or an object deleted.
#[derive(Clone)]
pub(crate) struct OwnAttr {
    subject: Arc<Subject>,
    merge: MergePolicy,
    report: ReportPolicy,
}

/// A report's assertions, by reference (an occasional one holds a few: inline).
type Values<'a> = SmallVec<[Reported<'a>; 8]>;

impl State {
    /// Takes every change committed since the last call and sends what is due.
    pub fn drain_changes(&mut self) {
        self.drain_changes_to(u64::MAX);
    }

    /// Takes the changes committed since the last call up to board revision `revision`
    /// and sends what is due; a later change waits for the next call (`next_change`).
    /// A catch-up answer drains up to the revision its state was read at, so that the
    /// reports of every write it holds go before it, and none of a write after it.
    /// Reports that linger (`IciConfig::linger`) wait, unless a catch-up answer is to
    /// follow them or one is of a lossless class (its writer waits for room, in its own
    /// thread: docs/ici.md).
    pub fn drain_changes_to(&mut self, revision: u64) {
        let mut items = std::mem::take(&mut self.spare_items);
        while let Some(change) = self.next_change.take().or_else(|| self.watch.try_recv()) {
            if change.revision > revision {
                self.next_change = Some(change);
                break;
            }
            for item in change.items {
                self.collect(item, &mut items);
            }
        }
        self.lingering.append(&mut items);
        let wait = revision == u64::MAX && !self.any_lossless(&self.lingering) && self.lingers();
        if !wait {
            self.flush_lingering();
        }
        items.clear();
        self.spare_items = items;
    }

    /// Must what waits now wait on, for the end of the linger the last report began?
    fn lingers(&self) -> bool {
        self.linger_end().is_some_and(|end| self.now < end)
    }

    /// When the linger of the reports waiting ends: the last report's time plus the
    /// linger; `None` if nothing waits, or reports do not linger, or the last report was
    /// made "after" now (the system clock stepped back: that begins no linger).
    pub fn linger_end(&self) -> Option<std::time::Duration> {
        let at = self.reported_at?;
        let lingers = !self.linger.is_zero() && at <= self.now && !self.lingering.is_empty();
        lingers.then(|| at.saturating_add(self.linger))
    }

    /// Sends the reports that linger, if any.
    pub fn flush_lingering(&mut self) {
        if self.lingering.is_empty() {
            return;
        }
        let items = std::mem::take(&mut self.lingering);
        self.report(&items);
        self.lingering = items;
        self.lingering.clear();
    }

    /// Is one of `items` an update of a lossless class?
    fn any_lossless(&self, items: &[Item]) -> bool {
        !self.config.lossless.is_empty()
            && items.iter().any(|i| match i {
                Item::Value(subject, _) => self.flow_of(std::iter::once(&**subject)) == Flow::Every,
                _ => false,
            })
    }

    /// Sends reports of own writes now; the linger starts again from here.
    fn report(&mut self, items: &[Item]) {
        self.flush(items);
        self.reported_at = Some(self.now);
        self.linger_asked = false;
    }

    fn collect(&mut self, item: ChangeItem, out: &mut Vec<Item>) {
        match item {
            // A packet of this module's previous incarnation, handed back by a peer, is
            // not a new write (an initial value, stamped zero, is this one's).
            ChangeItem::Write {
                object,
                attr,
                packet,
            } if packet.source == self.me && self.of_this_incarnation(packet.timestamp) => {
                out.extend(self.own_write(object, attr, packet));
            }
            ChangeItem::Write { .. } => {}
            ChangeItem::Create { object, .. } => out.extend(self.own_create(object)),
            ChangeItem::Delete { object, .. } => out.extend(self.deleted(object)),
        }
    }

    /// Was an own packet stamped `stamp` written by this incarnation? Initial values
    /// from files are stamped `Timestamp::ZERO` (they claim no time, so that they lose
    /// to whatever the team wrote since): they are.
    fn of_this_incarnation(&self, stamp: Timestamp) -> bool {
        !super::state::predates(stamp, self.incarnation)
    }

    /// A packet this module wrote: the item to send now, if any.
    fn own_write(&mut self, object: Arc<str>, attr: Arc<str>, packet: Packet) -> Option<Item> {
        let own = match self.own_attrs.get(&object, &attr) {
            Some(own) => own.clone(),
            // Another module's object, or a class: the board says what it is.
            None if !self.own_objects.contains_key(&object) => {
                let item = self.value_item(&object, &attr, packet)?;
                let Item::Value(subject, _) = &item else {
                    return None;
                };
                let (merge, report) = self.policies(&subject.lineage[0], &attr)?;
                return self.own_value(item, merge, &report);
            }
            None => {
                let own = self.resolve_own(&object, &attr)?;
                self.own_attrs.insert(&object, &attr, own.clone());
                own
            }
        };
        self.own_value(Item::Value(own.subject, packet), own.merge, &own.report)
    }

    /// What an own object's attribute needs, from the catalog (`None` if the catalog
    /// does not know its class or attribute, even once rebuilt).
    fn resolve_own(&mut self, object: &Arc<str>, attr: &Arc<str>) -> Option<OwnAttr> {
        let (class, context) = self.own_objects.get(object)?.clone();
        let lineage = self.lineage(&class)?;
        let (merge, report) = self.policies(&class, attr)?;
        let subject = Subject {
            object: ObjectEntry {
                name: object.clone(),
                class,
                context,
                owner: self.me.clone(),
            },
            attr: attr.clone(),
            lineage,
            is_class: false,
        };
        Some(OwnAttr {
            subject: Arc::new(subject),
            merge,
            report,
        })
    }

    /// The merge and report policies of `class.attr`, refreshing the catalog once if
    /// it does not know them.
    fn policies(&mut self, class: &str, attr: &str) -> Option<(MergePolicy, ReportPolicy)> {
        let found = |st: &State| {
            let decl = st.catalog.decl(class, attr)?;
            Some((decl.merge, decl.report.clone()))
        };
        match found(self) {
            Some(found) => Some(found),
            None => {
                self.refresh_catalog();
                found(self)
            }
        }
    }

    /// An own packet (the board stored it quantised, as receivers decode it): fused,
    /// kept as the best heard of, and offered to its report filter (the item, if it is
    /// to go now).
    fn own_value(&mut self, item: Item, merge: MergePolicy, report: &ReportPolicy) -> Option<Item> {
        let Item::Value(subject, packet) = &item else {
            return Some(item);
        };
        self.stats.reports.written += 1;
        if merge == MergePolicy::Latest && is_unfiltered(report) {
            return Some(item); // the common case: nothing to keep
        }
        let key = (subject.object.name.clone(), subject.attr.clone());
        if merge == MergePolicy::Fused {
            self.fusion.update(key.clone(), packet.clone());
            self.ops.push(BoardOp::Fuse(key.clone()));
        }
        if merge == MergePolicy::Confident {
            self.keep_best(&key, packet);
        }
        let (now, quiet) = (self.now, self.config.quiet);
        match self.filters.offer(key, packet.clone(), report, now, quiet) {
            Some(_) => Some(item),
            None => {
                self.stats.reports.held += 1;
                None
            }
        }
    }

    /// A local write replaces whatever the board held; under `confident`, a better
    /// packet this module heard of before must win again (as it does on every other
    /// board), so it is merged back.
    fn keep_best(&mut self, key: &Key, own: &Packet) {
        match self.best.get(key) {
            Some(best) if better(best, own) => {
                let (object, attr, packet) = (key.0.clone(), key.1.clone(), best.clone());
                self.ops.push(BoardOp::Merge {
                    object,
                    attr,
                    key: None,
                    packet,
                });
            }
            _ => {
                self.best.insert(key.clone(), own.clone());
            }
        }
    }

    /// An item reporting `packet` of `object.attr`, if the object still exists (an own
    /// object is known without asking the board, whose lock the writer wants).
    pub fn value_item(
        &mut self,
        object: &Arc<str>,
        attr: &Arc<str>,
        packet: Packet,
    ) -> Option<Item> {
        let (entry, is_class) = match self.own_objects.get(object) {
            Some((class, context)) => {
                let entry = ObjectEntry {
                    name: object.clone(),
                    class: class.clone(),
                    context: *context,
                    owner: self.me.clone(),
                };
                (entry, false)
            }
            None => {
                let info = self.board.info(object)?;
                (ObjectEntry::from(&info), info.is_class)
            }
        };
        if &*entry.class == MODULE_CLASS {
            return None;
        }
        let lineage = self.lineage(&entry.class)?;
        let subject = Subject {
            object: entry,
            attr: attr.clone(),
            lineage,
            is_class,
        };
        Some(Item::Value(Arc::new(subject), packet))
    }

    fn own_create(&mut self, object: Arc<str>) -> Option<Item> {
        let info = self.board.info(&object)?;
        if info.is_class || info.owner != self.me || &*info.class == MODULE_CLASS {
            return None;
        }
        let lineage = self.lineage(&info.class)?;
        self.own_objects
            .insert(object.clone(), (info.class.clone(), info.context));
        let fingerprint = self.catalog.schema.fingerprint(&info.class).unwrap_or(0);
        let listed = Listed {
            name: object,
            class: info.class,
            fingerprint,
            context: info.context,
        };
        let stamp = self.board.clock().now();
        Some(Item::Created {
            listed,
            stamp,
            lineage,
        })
    }

    fn deleted(&mut self, object: Arc<str>) -> Option<Item> {
        self.forget_resolved();
        self.filters.forget(&object);
        self.best.retain(|(o, _), _| *o != object);
        self.fusion.forget(&object);
        self.origins.remove(&object);
        let (class, context) = self.own_objects.remove(&object)?;
        let stamp = self.board.clock().now();
        let max = self.config.max_tombstones;
        self.tombstones
            .bury(object.clone(), self.me.clone(), stamp, max);
        let lineage = self
            .lineage(&class)
            .unwrap_or_else(|| Arc::from(vec![class]));
        Some(Item::Deleted {
            name: object,
            stamp,
            lineage,
            context,
        })
    }

    // ----- destinations -----

    /// Sends items on each link kind to the peers there that want them.
    pub fn flush(&mut self, items: &[Item]) {
        if items.is_empty() {
            return;
        }
        let mut chosen: SmallVec<[&Item; 8]> = SmallVec::with_capacity(items.len());
        for link in LinkKind::ALL {
            chosen.clear();
            let (mut not_exported, mut not_wanted) = (0, 0);
            for item in items {
                match self.wanted(link, item) {
                    Wanted::Yes => chosen.push(item),
                    Wanted::NotExported => not_exported += 1,
                    Wanted::NoPeer => not_wanted += 1,
                }
            }
            self.stats.reports.suppressed_export += not_exported;
            self.stats.reports.suppressed_interest += not_wanted;
            if link == LinkKind::Team && not_wanted > 0 {
                self.team.kept_home = true;
            }
            self.link_filter(link, &mut chosen); // the link policy's filters (link.rs)
            self.emit(link, &chosen);
        }
    }

    /// Does anyone on `link` want this item, and may it go there?
    fn wanted(&self, link: LinkKind, item: &Item) -> Wanted {
        let export = &self.config.export;
        let (lineage, context, _, is_class) = item.dest(&self.me);
        let exported = link == LinkKind::Robot
            || if is_class {
                export.relates_to_class(lineage, &self.catalog)
            } else {
                export.contains(lineage, context)
            };
        if !exported {
            return Wanted::NotExported;
        }
        if self.robot_speaks_on(link) {
            return if self.team_wants(item) {
                Wanted::Yes
            } else {
                Wanted::NoPeer
            };
        }
        let wanted = self
            .peers
            .iter()
            .filter(|(_, p)| p.up && p.link == link)
            .any(|(a, p)| self.interest_wants(a, p.interest.as_ref(), item));
        if wanted { Wanted::Yes } else { Wanted::NoPeer }
    }

    /// Does a peer with this interest (`None`: not heard yet) want the item?
    fn interest_wants(&self, p: &Address, interest: Option<&ClassSet>, item: &Item) -> bool {
        let Some(interest) = interest else {
            return false;
        };
        let (lineage, context, owner, is_class) = item.dest(&self.me);
        if is_class {
            interest.relates_to_class(lineage, &self.catalog)
        } else {
            interest.contains(lineage, State::context_on(context, owner, p))
        }
    }

    pub(super) fn peer_wants_item(&self, p: &Address, item: &Item) -> bool {
        let interest = self.peers.get(p).and_then(|p| p.interest.as_ref());
        self.interest_wants(p, interest, item)
    }

    /// Groups consecutive items into messages: lifecycle frames (creations, then
    /// deletions) and reports, keeping the order of the board's changes.
    pub(super) fn emit(&mut self, link: LinkKind, items: &[&Item]) {
        // What lingers was written before: it takes its stream positions first (an
        // explicit report or a filter's held value must not overtake it).
        self.flush_lingering();
        let mut life = Lifecycle::default();
        // The assertions are encoded where they are (not copied into a `Report`).
        let mut values: Values = SmallVec::with_capacity(items.len());
        // A report holds one flow: an update of a lossless class does not make the
        // others' lossless (back-pressure for what a slow receiver may drop), and they
        // do not make it droppable.
        let mut flow = Flow::Latest;
        for item in items {
            match item {
                Item::Value(subject, packet) => {
                    self.emit_lifecycle(link, &mut life);
                    let this = self.flow_of(std::iter::once(&**subject));
                    if this != flow {
                        self.emit_values(link, &mut values, flow);
                        flow = this;
                    }
                    values.push(Reported(subject, packet));
                }
                Item::Created { listed, stamp, .. } => {
                    self.emit_values(link, &mut values, flow);
                    if !life.deleted.is_empty() {
                        self.emit_lifecycle(link, &mut life);
                    }
                    life.created.push((listed.clone(), *stamp));
                }
                Item::Deleted { name, stamp, .. } => {
                    self.emit_values(link, &mut values, flow);
                    life.deleted.push((name.clone(), *stamp));
                }
            }
        }
        self.emit_values(link, &mut values, flow);
        self.emit_lifecycle(link, &mut life);
    }

    fn emit_lifecycle(&mut self, link: LinkKind, life: &mut Lifecycle) {
        if life.created.is_empty() && life.deleted.is_empty() {
            return;
        }
        let Some(out) = self.out.get_mut(&link) else {
            return;
        };
        out.seq += 1;
        life.seq = out.seq;
        let bytes = Frame::Lifecycle(std::mem::take(life)).encode();
        self.publish(link, MsgKind::Lifecycle, &bytes);
    }

    /// Reports `values` (at most `max_report_items` a report) and empties it.
    /// Emits `values`, all of `flow`, in reports of at most `max_report_items`.
    fn emit_values(&mut self, link: LinkKind, values: &mut Values, flow: Flow) {
        let max = self.config.max_report_items.max(1);
        for chunk in values.chunks(max) {
            self.emit_report(link, chunk, flow);
        }
        values.clear();
    }

    /// Encodes and publishes one report; a batch that does not encode is split until
    /// the faulty packet is isolated and dropped.
    fn emit_report(&mut self, link: LinkKind, items: &[Reported], flow: Flow) {
        let Some(out) = self.out.get_mut(&link) else {
            return;
        };
        let result = out
            .encoder
            .encode_report(out.seq + 1, items, &self.catalog.schema);
        match result {
            Ok(bytes) => {
                out.seq += 1;
                self.stats.reports.items_sent += items.len() as u64;
                // Names a report announces are not announced again: lost, they would
                // leave the lossless reports that use them undecodable until a
                // catch-up (and their updates lost).
                let announced = out.encoder.announced() && !self.config.lossless.is_empty();
                let flow = if announced { Flow::Every } else { flow };
                self.publish_with(link, MsgKind::Report, &bytes, flow);
            }
            Err(e) if items.len() > 1 => {
                let (a, b) = items.split_at(items.len() / 2);
                tracing::trace!(error = %e, "splitting a report");
                self.emit_report(link, a, flow);
                self.emit_report(link, b, flow);
            }
            Err(e) => self.encode_failed(&items[0], &e),
        }
    }

    /// [`Flow::Every`] if one of the subjects is of a class whose every update is sent
    /// ([`IciConfig::lossless`](crate::IciConfig::lossless)), else [`Flow::Latest`].
    pub(super) fn flow_of<'a>(&self, mut subjects: impl Iterator<Item = &'a Subject>) -> Flow {
        let lossless = &self.config.lossless;
        if !lossless.is_empty() && subjects.any(|s| lossless.contains(&s.lineage, s.object.context))
        {
            Flow::Every
        } else {
            Flow::Latest
        }
    }

    fn encode_failed(&mut self, a: &impl AssertionParts, e: &EncodeError) {
        self.stats.reports.encode_errors += 1;
        if matches!(
            e,
            EncodeError::UnknownClass { .. } | EncodeError::UnknownAttr { .. }
        ) {
            self.refresh_catalog();
        }
        tracing::warn!(object = %a.object().name, attr = %a.attr(), error = %e, "packet not reported");
    }
}

/// Does `a` win over `b` under `confident` (as `Board::merge` decides)?
pub(crate) fn better(a: &Packet, b: &Packet) -> bool {
    a.confidence > b.confidence
        || (a.confidence == b.confidence && (a.timestamp, &a.source) > (b.timestamp, &b.source))
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use slate_model::{AttrDecl, ClassDef, ValueType};
    use slate_testing::addr;

    use super::super::classes::ClassSet;
    use super::super::state::State;
    use super::super::team::test_state::{START, alone, sent};
    use crate::{IciConfig, LinkKind, MsgKind, SimNet};

    const LINGER: Duration = Duration::from_micros(50);

    /// A state whose reports linger (the simulator's clock turns it off: set here), a
    /// peer of its robot up and interested in everything, objects `g` (a `Gauge`) and
    /// `e` (an `Event`, lossless in `config` if the test says so).
    fn lingering(config: IciConfig) -> (SimNet, State) {
        let (net, mut st) = alone("t/r1/nav", config);
        st.linger = LINGER;
        for class in ["Gauge", "Event"] {
            let def = ClassDef::new(class).attr(AttrDecl::new("x", ValueType::Real));
            st.board.define(def).unwrap();
        }
        st.refresh_catalog();
        st.board.create("Gauge", "g").unwrap();
        st.board.create("Event", "e").unwrap();
        let p = st.peer(&addr("t/r1/cam"));
        p.up = true;
        p.interest = Some(ClassSet::all());
        st.now = START;
        st.drain_changes();
        (net, st)
    }

    /// Writes `object.x = x` at `at` after [`START`] and drains: how many reports went?
    fn write(st: &mut State, object: &str, x: f64, at: Duration) -> u64 {
        let before = sent(st, LinkKind::Robot, MsgKind::Report);
        st.now = START + at;
        st.board.write(object, "x", x).unwrap();
        st.drain_changes();
        sent(st, LinkKind::Robot, MsgKind::Report) - before
    }

    #[test]
    fn writes_within_the_linger_wait_and_go_together_then_a_write_after_it_goes_at_once() {
        let (_net, mut st) = lingering(IciConfig::default());
        let us = Duration::from_micros;
        assert_eq!(
            write(&mut st, "g", 1.0, us(100)),
            1,
            "after a quiet spell: at once"
        );
        assert_eq!(
            write(&mut st, "g", 2.0, us(110)),
            0,
            "within the linger: waits"
        );
        assert_eq!(write(&mut st, "g", 3.0, us(120)), 0);
        assert_eq!(st.lingering.len(), 2);
        assert_eq!(
            st.linger_end(),
            Some(START + us(150)),
            "it ends a linger after the last report"
        );
        assert_eq!(
            write(&mut st, "g", 4.0, us(151)),
            1,
            "past it: all in one report"
        );
        assert!(st.lingering.is_empty());
    }

    #[test]
    fn an_explicit_report_sends_what_lingers_before_it() {
        let (_net, mut st) = lingering(IciConfig::default());
        let us = Duration::from_micros;
        write(&mut st, "g", 1.0, us(100));
        assert_eq!(write(&mut st, "g", 2.0, us(110)), 0);
        let before = sent(&st, LinkKind::Robot, MsgKind::Report);
        let packet = st.board.read("g", "x").unwrap();
        st.report_explicit(None, vec![("g".into(), "x".into(), packet)]);
        assert!(
            st.lingering.is_empty(),
            "flushed first, so it keeps its place"
        );
        assert_eq!(sent(&st, LinkKind::Robot, MsgKind::Report) - before, 2);
    }

    #[test]
    fn a_write_of_a_lossless_class_or_after_the_clock_stepped_back_does_not_linger() {
        let config = IciConfig::default().lossless(ClassSet::none().class("Event"));
        let (_net, mut st) = lingering(config);
        let us = Duration::from_micros;
        write(&mut st, "e", 1.0, us(100));
        assert_eq!(
            write(&mut st, "e", 2.0, us(110)),
            1,
            "its writer waits for room itself"
        );
        assert_eq!(
            write(&mut st, "g", 1.0, us(120)),
            0,
            "another class lingers"
        );
        assert_eq!(
            write(&mut st, "e", 3.0, us(130)),
            2,
            "and goes with it (a report a flow)"
        );
        assert!(st.lingering.is_empty());
        // The system clock stepped back a second: the last report is "in the future".
        assert_eq!(write(&mut st, "g", 2.0, us(130)), 0, "within the linger");
        st.flush_lingering();
        st.now = START;
        st.board.write("g", "x", 3.0).unwrap();
        st.drain_changes();
        assert!(
            st.lingering.is_empty(),
            "no linger from a report made after now"
        );
    }
}
