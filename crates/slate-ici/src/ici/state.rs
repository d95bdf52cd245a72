//! The ICI's protocol state, behind one lock: streams, peers, filters, fusion,
//! tombstones and counters. Board changes it decides on are queued as [`BoardOp`]s and
//! applied after the lock is released (board hooks may call back into the ICI).

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::Arc;
use std::time::Duration;

use rustc_hash::FxHashMap;

use slate_model::memo::NameMemo;
use slate_model::{Address, Board, Change, Context, MergePolicy, Packet, Timestamp, Watch};
use slate_wire::{Decoder, Encoder, Message, ObjectEntry};

use super::addr_map::AddrMap;
use super::classes::{Catalog, ClassSet, Lineage};
use super::config::IciConfig;
use super::filter::{Filters, Key};
use super::fuse::Fusion;
use super::module::MODULE_CLASS;
use super::ops::BoardOp;
use super::stats::IciStats;
use super::stream::Inbound;
use crate::{Flow, LinkKind, MsgKind, Transport};

/// What merging a received packet of an object's attribute needs, found on its first
/// packet (this board models the object, holds it in the same class, and has the
/// attribute's merge policy and key) instead of on every one: until the catalog is
/// rebuilt, the interest changes or an object is deleted.
pub(crate) struct Known {
    /// The object's entry as received (another entry under the same name is looked at
    /// anew).
    pub entry: ObjectEntry,
    pub merge: MergePolicy,
    pub key: slate_model::Key,
}

/// One of this module's outgoing streams (one per link kind): its position and the
/// encoder whose dictionary its receivers share.
pub(crate) struct Outbound {
    pub seq: u64,
    pub encoder: Encoder,
    /// When something other than a heartbeat was last published on this link: a link
    /// silent but for heartbeats for a while is idle (`tick.rs`, `heartbeat_gap`).
    pub said: Duration,
}

/// An outstanding catch-up request.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Request {
    pub since: Duration,
    pub names: bool,
    pub classes: bool,
}

/// What this module knows of another.
pub(crate) struct Peer {
    pub link: LinkKind,
    /// Reachable, as far as the transport (or its traffic) says.
    pub up: bool,
    pub interest: Option<ClassSet>,
    pub incarnation: Option<u64>,
    pub last_heard: Duration,
    /// When something other than a heartbeat was last heard from it (`ZERO`: never): a
    /// peer heard only by heartbeats for a while may be sending them further apart
    /// (`tick.rs`, `expected_gap`).
    pub said: Duration,
    /// When the transport last said it went down, until it says up: the down is believed
    /// if nothing is heard from the module after it for [`down_believed_after`] its
    /// link's heartbeat (see `tick.rs`, `on_peer`).
    ///
    /// [`down_believed_after`]: super::tick::down_believed_after
    pub down_at: Option<Duration>,
    /// `alive` as last written to its `Module` object.
    pub alive: Option<bool>,
    pub seen_written: Duration,
    pub stream: Inbound,
    /// The highest position taken from its current incarnation's stream (or announced
    /// by its heartbeats): where the fence goes if it restarts.
    pub top: u64,
    /// Up for a while after it restarted: a message of its previous incarnation may
    /// still arrive (queued on a slow radio when it restarted) and be decoded against
    /// the new incarnation's names and epoch, which misreads it with stamps after the
    /// restart (docs/ici.md, "Limits and known gaps"); see [`Peer::fenced`].
    pub fence: Option<Fence>,
    pub catch_up: Option<Request>,
    /// A part of the answer being received was refused: do not count it as complete.
    pub failed: bool,
    /// A catch-up with it has completed since it (re)started.
    pub caught_up: bool,
    /// Its plan messages (plans, cancellations) that arrived before that catch-up did,
    /// in order, and until when they may wait for it (`recv.rs`, `hold_plan`).
    pub held_plans: Vec<Message>,
    pub hold_plans_until: Option<Duration>,
    /// When this module last sent it a hello (not a reply) that it has not answered
    /// yet, and how many times it said it again; `None` once answered.
    pub hello_unanswered: Option<(Duration, u32)>,
    /// The newest stamp of its own on its stream (packets it wrote, objects it created
    /// or deleted): older than its incarnation means a previous incarnation's stream.
    pub newest: Option<Timestamp>,
    /// Its hello said it is a short-lived observer: forgotten as soon as it is dead.
    pub observer: bool,
    /// When this module last answered a catch-up request of its, and the request that
    /// waits for the answer interval to pass (see `State::on_request`).
    pub answered: Option<Duration>,
    pub deferred: Option<slate_wire::CatchUpRequest>,
    /// The catch-up answer bytes sent it and not yet paid off (`limits.rs`).
    pub answer_bytes: super::limits::AnswerBytes,
    /// A mate's election priority, from its robot-link hello (`None`: not eligible, or
    /// no hello with the team protocol heard).
    pub priority: Option<u8>,
    /// A mate's hello says it listens to the team link.
    pub listener: bool,
}

impl Peer {
    fn new(me: &Address, them: &Address) -> Self {
        Peer {
            link: LinkKind::between(me, them),
            up: false,
            interest: None,
            incarnation: None,
            last_heard: Duration::ZERO,
            said: Duration::ZERO,
            down_at: None,
            alive: None,
            seen_written: Duration::ZERO,
            stream: Inbound::default(),
            top: 0,
            fence: None,
            catch_up: None,
            failed: false,
            caught_up: false,
            held_plans: Vec::new(),
            hold_plans_until: None,
            hello_unanswered: None,
            newest: None,
            observer: false,
            answered: None,
            deferred: None,
            answer_bytes: Default::default(),
            priority: None,
            listener: false,
        }
    }

    /// The source restarted: until `until` at the latest, fence its new stream at the
    /// highest position heard of the incarnation that ended (taken, announced, or given
    /// by a catch-up), or of a fence still up; no fence if nothing of its stream was
    /// heard. Call it before the stream is reset.
    pub fn put_up_fence(&mut self, until: Duration) {
        let heard = self.top.max(self.stream.have());
        let top = heard.max(self.fence.map_or(0, |f| f.top));
        self.fence = (top > 0).then_some(Fence { top, until });
        self.top = 0;
    }

    /// Is position `seq` of a restarted source to be refused as possibly its previous
    /// incarnation's? Reports carry no incarnation, and one of the previous incarnation
    /// decodes against the new one's names and epoch as other packets stamped after the
    /// restart, so neither its stamps nor its names tell it apart. Its position does,
    /// mostly: the new stream starts from 1 (or the catch-up answer's position) and
    /// comes in order, while the previous one's late messages are ahead of it. So while
    /// the fence is up, only the next position in order is taken; one ahead of a gap is
    /// refused without being recorded and raises the fence, and a real one is found
    /// again from the source's heartbeats (a gap, then a catch-up). The fence comes
    /// down once `have` passes it (every later message of the previous incarnation is
    /// then a duplicate), or at `until` (the link's timeout after the restart was
    /// found): a message held longer than that is not waited for, and the refusals'
    /// catch-ups stop.
    pub fn fenced(&mut self, seq: u64, now: Duration) -> bool {
        let Some(fence) = self.fence else {
            return false;
        };
        let have = self.stream.have();
        if have > fence.top || now >= fence.until {
            self.fence = None;
            return false;
        }
        if seq <= have + 1 {
            return false;
        }
        self.fence = Some(Fence {
            top: fence.top.max(seq),
            ..fence
        });
        true
    }
}

/// The fence on a restarted source's stream: the highest position heard of its previous
/// incarnation's stream (raised by every position refused since), and when the fence
/// comes down at the latest.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fence {
    pub top: u64,
    pub until: Duration,
}

/// Where an object created on receipt came from, to decide whether a catch-up's object
/// list may sweep it: created from the owner's stream at `seq`, or from a packet stamped
/// `stamp` (another module's report).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Origin {
    pub seq: Option<u64>,
    pub stamp: Timestamp,
}

/// Deleted objects: name, owner, when. The oldest are forgotten past the limit.
#[derive(Default)]
pub(crate) struct Tombstones {
    by_name: BTreeMap<Arc<str>, (Address, Timestamp)>,
    order: VecDeque<Arc<str>>,
}

impl Tombstones {
    pub fn bury(&mut self, name: Arc<str>, owner: Address, stamp: Timestamp, max: usize) {
        if self.by_name.insert(name.clone(), (owner, stamp)).is_none() {
            self.order.push_back(name);
        }
        while self.order.len() > max {
            if let Some(old) = self.order.pop_front() {
                self.by_name.remove(&old);
            }
        }
    }

    pub fn get(&self, name: &str) -> Option<&(Address, Timestamp)> {
        self.by_name.get(name)
    }
}

pub(crate) struct State {
    pub me: Address,
    pub board: Arc<Board>,
    pub transport: Arc<dyn Transport>,
    pub config: IciConfig,
    pub incarnation: u64,
    pub catalog: Catalog,
    pub out: BTreeMap<LinkKind, Outbound>,
    pub decoder: Decoder,
    /// The other modules heard of, by address; its home range is this module's robot's
    /// (every address of a module of this robot starts with `me`'s robot path and a
    /// slash).
    pub peers: AddrMap<Peer>,
    pub filters: Filters,
    pub fusion: Fusion,
    /// The best packet heard of, per `confident` attribute.
    pub best: BTreeMap<Key, Packet>,
    /// Objects this board owns: name → (class, context).
    pub own_objects: FxHashMap<Arc<str>, (Arc<str>, Context)>,
    /// Own objects' attributes written so far, resolved: (object, attribute) → policies.
    pub own_attrs: NameMemo<super::send::OwnAttr>,
    /// Attributes of objects received before, resolved: (object, attribute) → what
    /// merging a packet needs.
    pub known: NameMemo<Known>,
    pub tombstones: Tombstones,
    pub origins: BTreeMap<Arc<str>, Origin>,
    /// Classes another module defines differently, with that module: (class, peer).
    pub conflicts: BTreeSet<(Arc<str>, Address)>,
    pub next_heartbeat: BTreeMap<LinkKind, Duration>,
    /// No live peer times out before this instant (`State::timeouts`); never later than
    /// the earliest deadline of a live peer.
    pub timeouts_from: Duration,
    /// Nothing of `State::catch_up_timers` is due before this instant; never later than
    /// the earliest [`State::catch_up_due`] of any peer.
    pub catch_up_from: Duration,
    /// No peer's held plans are due to go unheld before this instant
    /// (`State::held_plan_timers`).
    pub plans_held_from: Duration,
    /// As `catch_up_from`, without the peers whose gap waits for their robot's stream to
    /// be repaired (`State::catch_up_timers` looks at them again when a message has
    /// changed that stream). Never later than `catch_up_from` for the others.
    pub catch_up_unheld_from: Duration,
    /// The peers whose `alive` was last written false: those `forget_dead` looks at.
    pub dead: BTreeSet<Address>,
    /// No dead peer is due to be forgotten before this instant (`State::forget_dead`);
    /// never later than the earliest `forget_due` (`tick.rs`) of the dead. Zero once
    /// anything that can bring one earlier happened (a peer died, the transport's word
    /// on a peer, a hello, a link policy, listening to the team link or not).
    pub forget_from: Duration,
    /// The peers that may have a hello unanswered or a catch-up answer deferred: those
    /// `hello_timers`, `deferred_answers` and `next_tick` look at, rather than every peer
    /// of the team at every tick. Added to wherever either is set; a tick drops those
    /// with neither (`State::prune_peer_timers`).
    pub peer_timers: BTreeSet<Address>,
    /// A timer run by the tick in progress acted, after timers that read what it
    /// changed had run: the next tick comes at the clock's next move
    /// (`State::next_tick`).
    pub tick_again: bool,
    pub watch: Watch,
    /// A change taken from `watch` past the revision a drain stopped at
    /// (`drain_changes_to`): the next drain starts with it.
    pub next_change: Option<Change>,
    pub stats: IciStats,
    /// Physical time of the operation in progress.
    pub now: Duration,
    /// Decided board changes, applied after the lock is released.
    pub ops: Vec<BoardOp>,
    /// Plan messages received, handed to the plan handler after the lock is released.
    pub plans: Vec<super::PlanEvent>,
    /// Buffers kept between drains (a single update is the common case: no allocation).
    pub spare_items: Vec<super::send::Item>,
    /// Items of own writes waiting for the end of the linger (`IciConfig::linger`) to go
    /// in one report with those that follow.
    pub lingering: Vec<super::send::Item>,
    /// How long reports linger: the config's, zero on a manual clock.
    pub linger: Duration,
    /// When the last report of own writes was flushed (physical time).
    pub reported_at: Option<Duration>,
    /// The linger thread was told when the items waiting now must go (once a linger).
    pub linger_asked: bool,
    /// The team protocol's state (empty while `config.team_protocol` is `None`).
    pub team: super::team::TeamState,
    /// Publications made once the lock is released (`outgoing.rs`).
    pub outgoing: Arc<super::outgoing::Outgoing>,
    /// A lossless publication was queued: the thread holding the lock makes it, and
    /// waits for it, once it lets go.
    pub queued_every: bool,
}

impl State {
    /// Does this module's robot speak for it on `link` (the team link with the team
    /// protocol on: one gateway per robot, its numbered stream, robot hellos and
    /// heartbeats, no hello or catch-up per pair of modules)?
    pub(crate) fn robot_speaks_on(&self, link: LinkKind) -> bool {
        link == LinkKind::Team && self.config.team_protocol.is_some()
    }

    pub fn new(
        board: Arc<Board>,
        transport: Arc<dyn Transport>,
        config: IciConfig,
        watch: Watch,
    ) -> Self {
        let me = transport.address().clone();
        let linger = if board.clock().is_manual() {
            Duration::ZERO
        } else {
            config.linger
        };
        let out = LinkKind::ALL
            .into_iter()
            .map(|l| {
                (
                    l,
                    Outbound {
                        seq: 0,
                        encoder: Encoder::new(me.clone()),
                        said: Duration::ZERO,
                    },
                )
            })
            .collect();
        let now = board.clock().physical();
        State {
            incarnation: board.clock().now().raw(),
            catalog: Catalog::new(&board),
            peers: AddrMap::with_home(format!("{}/", me.robot_path())),
            me,
            board,
            transport,
            decoder: Decoder::with_max_sources(config.max_sources)
                .with_max_names(config.max_names_per_source)
                .with_max_total_names(config.max_names),
            config,
            out,
            filters: Filters::default(),
            fusion: Fusion::default(),
            best: BTreeMap::new(),
            own_objects: FxHashMap::default(),
            own_attrs: NameMemo::default(),
            known: NameMemo::default(),
            tombstones: Tombstones::default(),
            origins: BTreeMap::new(),
            conflicts: BTreeSet::new(),
            next_heartbeat: LinkKind::ALL.into_iter().map(|l| (l, now)).collect(),
            timeouts_from: Duration::ZERO,
            catch_up_from: Duration::ZERO,
            plans_held_from: Duration::MAX,
            catch_up_unheld_from: Duration::ZERO,
            dead: BTreeSet::new(),
            forget_from: Duration::ZERO,
            peer_timers: BTreeSet::new(),
            tick_again: false,
            watch,
            next_change: None,
            stats: IciStats::default(),
            now,
            ops: Vec::new(),
            plans: Vec::new(),
            spare_items: Vec::new(),
            lingering: Vec::new(),
            linger,
            reported_at: None,
            linger_asked: false,
            team: super::team::TeamState::new(),
            outgoing: Arc::default(),
            queued_every: false,
        }
    }

    /// Takes note of the objects this board owns already.
    pub fn adopt_own_objects(&mut self) {
        let snap = self.board.snapshot();
        let owned: Vec<_> = snap
            .objects()
            .into_iter()
            .filter_map(|id| snap.info(id))
            .filter(|i| !i.is_class && i.owner == self.me && &*i.class != MODULE_CLASS)
            .map(|i| (i.name, (i.class, i.context)))
            .collect();
        drop(snap);
        self.own_objects.extend(owned);
    }

    /// Does `peer` define `class` differently from this board (as found so far)?
    pub fn conflicts_with(&self, peer: &Address, class: &str) -> bool {
        self.conflicts.contains(&(Arc::from(class), peer.clone()))
    }

    /// The other modules of this module's robot: the peers' home range (addresses order
    /// as their text, and a robot's are those that start with `team/robot/`), not a walk
    /// over the whole team.
    pub fn mates(&self) -> impl Iterator<Item = (&Address, &Peer)> {
        self.peers.home()
    }

    /// The peer entry of `address`, made on first mention.
    pub fn peer(&mut self, address: &Address) -> &mut Peer {
        let me = &self.me;
        self.peers
            .get_or_insert_with(address, || Peer::new(me, address))
    }

    /// Rebuilds the catalog from the board (a class was missing).
    pub fn refresh_catalog(&mut self) {
        self.catalog = Catalog::new(&self.board);
        self.forget_resolved();
    }

    /// Forgets what was resolved for own and received attributes (the catalog, the
    /// interest or the objects changed).
    pub fn forget_resolved(&mut self) {
        self.own_attrs.clear();
        self.known.clear();
    }

    /// The class chain of `class`, refreshing the catalog once if it is unknown.
    pub fn lineage(&mut self, class: &str) -> Option<Lineage> {
        if let Some(lineage) = self.catalog.lineage(class) {
            return Some(lineage);
        }
        self.refresh_catalog();
        self.catalog.lineage(class)
    }

    /// The context an object has on `board_of`'s board: SELF on the owner's robot is
    /// SYSTEM on every other robot; everything else keeps its context.
    pub fn context_on(context: Context, owner: &Address, board_of: &Address) -> Context {
        if context == Context::Self_ && LinkKind::between(owner, board_of) == LinkKind::Team {
            Context::System
        } else {
            context
        }
    }

    /// Is any peer up on one link kind?
    pub fn has_up_peer(&self, link: LinkKind) -> bool {
        self.up_on(link).next().is_some()
    }

    /// The peers up on one link kind.
    pub fn up_peers(&self, link: LinkKind) -> Vec<Address> {
        self.up_on(link).cloned().collect()
    }

    /// The addresses of the peers up on one link kind, in address order.
    fn up_on(&self, link: LinkKind) -> impl Iterator<Item = &Address> {
        self.peers
            .iter()
            .filter(move |(_, p)| p.up && p.link == link)
            .map(|(a, _)| a)
    }

    /// The gateway of this module's robot (docs/team-protocol.md, 2.1): the live,
    /// eligible member with the smallest `(priority, address)`, this module included,
    /// as this module's robot-link view has it. `None` with the team protocol off, or
    /// when no member is eligible. No messages of its own: mates that heard the same
    /// hellos agree.
    pub fn gateway(&self) -> Option<Address> {
        let protocol = self.config.team_protocol.as_ref()?;
        let me = protocol.priority.map(|p| (p, &self.me));
        let mates = self
            .mates()
            .filter(|(_, p)| p.alive == Some(true))
            .filter_map(|(a, p)| Some((p.priority?, a)));
        me.into_iter().chain(mates).min().map(|(_, a)| a.clone())
    }

    /// Sends one message reliably to `to`, counting it. While a lossless publication
    /// waits, the send queues behind it (`outgoing.rs`): a catch-up answer must not
    /// overtake the reports its position covers.
    pub fn send_to(&mut self, to: &Address, kind: MsgKind, bytes: &[u8]) {
        let link = LinkKind::between(&self.me, to);
        self.team_aired(link, bytes.len());
        self.said(link);
        if self.outgoing.must_queue(Flow::Latest) {
            self.outgoing.push_send(to, kind, bytes);
            self.stats.sent(link, kind, bytes.len());
            return;
        }
        match self.transport.send(to, kind, bytes) {
            Ok(()) => self.stats.sent(link, kind, bytes.len()),
            Err(e) => {
                self.stats.reports.send_errors += 1;
                tracing::debug!(to = %to, %kind, error = %e, "send refused");
            }
        }
    }

    /// Publishes one message on `link`, counting it. With the team protocol on, a team
    /// message goes to the robot's gateway instead (`team_out`).
    pub fn publish(&mut self, link: LinkKind, kind: MsgKind, bytes: &[u8]) {
        self.publish_with(link, kind, bytes, Flow::Latest);
    }

    /// [`State::publish`] with a [`Flow`]. A team message handed to the gateway goes
    /// in the robot's numbered stream, which the gateway repairs but does not hold its
    /// writers back for: `flow` does not travel there (docs/ici.md, *A class that needs
    /// every update*).
    pub fn publish_with(&mut self, link: LinkKind, kind: MsgKind, bytes: &[u8], flow: Flow) {
        if self.robot_speaks_on(link) {
            return self.team_out(bytes);
        }
        self.publish_now_with(link, kind, bytes, flow);
    }

    /// Publishes one message on `link` as it is, counting it.
    pub fn publish_now(&mut self, link: LinkKind, kind: MsgKind, bytes: &[u8]) {
        self.publish_now_with(link, kind, bytes, Flow::Latest);
    }

    /// A lossless publication, and any made while one waits, is queued and made once the
    /// lock is released (`outgoing.rs`); it is counted as sent when queued.
    fn publish_now_with(&mut self, link: LinkKind, kind: MsgKind, bytes: &[u8], flow: Flow) {
        self.team_aired(link, bytes.len());
        if kind != MsgKind::Heartbeat {
            self.said(link);
        }
        if self.outgoing.must_queue(flow) {
            self.outgoing.push(link, kind, bytes, flow);
            self.queued_every |= flow == Flow::Every;
            self.stats.sent(link, kind, bytes.len());
            return;
        }
        match self.transport.publish(link, kind, bytes) {
            Ok(()) => self.stats.sent(link, kind, bytes.len()),
            Err(e) => {
                self.stats.reports.send_errors += 1;
                tracing::debug!(%link, %kind, error = %e, "publish refused");
            }
        }
    }
}

/// Was something stamped `stamp` made before the incarnation that began at `incarnation`?
/// Never `Timestamp::ZERO`, the stamp of initial values from files, which every
/// incarnation writes alike.
pub(crate) fn predates(stamp: Timestamp, incarnation: u64) -> bool {
    stamp != Timestamp::ZERO && stamp.raw() < incarnation
}

#[cfg(test)]
mod tests {
    use super::*;

    const UNTIL: Duration = Duration::from_secs(5);

    /// A peer on the team link that had taken positions up to `top` when it restarted.
    /// A team peer, never heard.
    fn peer() -> Peer {
        let me = Address::new("t/r0/m0").unwrap();
        Peer::new(&me, &Address::new("t/r1/m0").unwrap())
    }

    fn restarted_at(top: u64) -> Peer {
        let mut p = peer();
        for seq in 1..=top {
            p.stream.receive(seq, Duration::ZERO);
        }
        p.top = top;
        p.put_up_fence(UNTIL);
        p.stream = Inbound::default();
        p
    }

    fn take(p: &mut Peer, seq: u64, now: Duration) -> bool {
        !p.fenced(seq, now) && p.stream.receive(seq, now)
    }

    #[test]
    fn a_position_ahead_of_the_new_stream_is_refused_after_a_restart() {
        let mut p = restarted_at(10);
        assert!(p.fenced(10, Duration::ZERO));
        assert_eq!(p.stream.have(), 0, "a refused position is not recorded");
    }

    #[test]
    fn the_new_stream_is_taken_in_order_behind_the_fence() {
        let mut p = restarted_at(10);
        assert!(take(&mut p, 1, Duration::ZERO));
        assert!(take(&mut p, 2, Duration::ZERO));
        assert!(!take(&mut p, 4, Duration::ZERO), "ahead of a gap");
        assert_eq!(p.stream.have(), 2);
    }

    #[test]
    fn a_refused_position_raises_the_fence() {
        let mut p = restarted_at(3);
        assert!(p.fenced(8, Duration::ZERO));
        for seq in 1..=4 {
            assert!(take(&mut p, seq, Duration::ZERO));
        }
        assert!(p.fenced(7, Duration::ZERO), "the fence is at 8 now");
    }

    #[test]
    fn the_fence_comes_down_once_the_new_stream_passes_it() {
        let mut p = restarted_at(2);
        for seq in 1..=3 {
            assert!(take(&mut p, seq, Duration::ZERO));
        }
        assert!(!p.fenced(9, Duration::ZERO));
        assert!(p.fence.is_none());
    }

    #[test]
    fn the_fence_comes_down_after_the_links_timeout() {
        let mut p = restarted_at(10);
        assert!(p.fenced(9, UNTIL - Duration::from_millis(1)));
        assert!(!p.fenced(9, UNTIL));
        assert!(p.fence.is_none());
    }

    #[test]
    fn a_restart_of_a_source_whose_stream_was_never_heard_puts_up_no_fence() {
        let mut p = restarted_at(0);
        assert!(p.fence.is_none());
        assert!(!p.fenced(5, Duration::ZERO));
    }

    #[test]
    fn a_restart_fences_at_the_position_a_catch_up_gave() {
        let mut p = peer();
        p.stream.caught_up(6, Duration::ZERO);
        p.put_up_fence(UNTIL);
        assert_eq!(p.fence.map(|f| f.top), Some(6));
    }

    #[test]
    fn a_second_restart_keeps_the_higher_fence() {
        let mut p = restarted_at(10);
        assert!(take(&mut p, 1, Duration::ZERO));
        p.top = 1;
        p.put_up_fence(UNTIL);
        assert_eq!(p.fence.map(|f| f.top), Some(10));
    }
}
