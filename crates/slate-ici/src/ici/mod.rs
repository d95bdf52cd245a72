//! The ICI: one board, one transport, and the protocol between them.

mod addr_map;
mod catchup;
mod classes;
mod config;
mod explicit;
mod filter;
mod frame;
mod fuse;
mod limits;
mod linger;
mod link;
mod module;
mod ops;
mod outgoing;
mod quantise;
mod recv;
mod send;
mod state;
mod stats;
mod stream;
mod team;
mod tick;
mod window;

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Weak};
use std::time::Duration;

use parking_lot::{Mutex, RwLock};
use slate_model::{Address, Board, ClockListener, DefineError, Filter, LookupError, Touched};
use slate_wire::{EncodeError, Encoder, Message, Schema};

pub use classes::ClassSet;
pub use config::{IciConfig, Listen, Liveliness, TeamProtocol};
pub use link::{LinkPolicy, LinkReport, link_kind};
pub use module::{MODULE_CLASS, module_class, module_object_name};
use ops::BoardOp;
use state::State;
pub use stats::{
    CatchUpStats, IciStats, LivelinessStats, MergeStats, RejectStats, ReportStats, TeamStats,
};

use crate::{LinkKind, MsgKind, SendError, Transport};
use slate_model::Wake;

/// Where plans meet the ICI: the plan engine installs one with
/// [`Ici::set_plan_handler`] to receive the `Plan`, `PlanAck` and `PlanCancel` messages
/// that reach this module, and to hear modules die (so it can ack `DestinationLost`).
/// It sends with [`Ici::send_raw`]. Calls come from the ICI's callers' threads (the
/// transport's, or the simulator's step loop), with no ICI lock held.
pub trait PlanHandler: Send + Sync {
    /// A plan message arrived.
    fn message(&self, from: &Address, msg: Message);

    /// A module became alive (again) or died, as this ICI judges it.
    fn peer(&self, peer: &Address, alive: bool) {
        let _ = (peer, alive);
    }
}

/// A channel is a plan handler: it receives the plan messages (peer news is dropped).
impl PlanHandler for crossbeam_channel::Sender<(Address, Message)> {
    fn message(&self, from: &Address, msg: Message) {
        let _ = self.send((from.clone(), msg));
    }
}

/// What the plan handler is told.
pub(crate) enum PlanEvent {
    Message(Address, Message),
    Peer(Address, bool),
}

/// Why an ICI could not start.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum IciStartError {
    /// The board and the transport must be the same module.
    #[error("the board is {board} but the transport is {transport}")]
    AddressMismatch {
        /// The board's address.
        board: Address,
        /// The transport's address.
        transport: Address,
    },
    /// The board has a `Module` class that differs from the ICI's.
    #[error("cannot define the Module class: {0}")]
    Define(#[from] DefineError),
    /// The board refused a watch.
    #[error("cannot watch the board: {0}")]
    Watch(#[from] LookupError),
}

/// Why [`Ici::send_raw`] failed.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum SendRawError {
    /// Only plans, acks and cancels go raw; reports go through the board.
    #[error("send_raw carries plans, acks and cancels, not {0} messages")]
    NotAPlanMessage(MsgKind),
    /// The message did not encode.
    #[error("cannot encode: {0}")]
    Encode(#[from] EncodeError),
    /// The transport refused it.
    #[error("cannot send: {0}")]
    Send(#[from] SendError),
}

/// The Intelligent Communications Interface of one module: keeps its board consistent
/// with the boards of the other modules it hears, over one [`Transport`].
///
/// It reports the packets its board writes (through each attribute's report policy,
/// to the peers interested, within the export policy), merges what it receives through
/// each attribute's merge policy, creates and deletes objects as their owners do,
/// catches up with sources it lost track of, and turns liveliness into `Module`
/// objects. The protocol is in `docs/ici.md`.
///
/// On a manual clock (the simulator) it runs its timers whenever the clock moves; on
/// the system clock, call [`tick`](Ici::tick) every few tens of milliseconds.
/// Dropping the last handle stops it.
#[derive(Clone)]
pub struct Ici {
    shared: Arc<Shared>,
}

struct Shared {
    board: Arc<Board>,
    transport: Arc<dyn Transport>,
    state: Mutex<State>,
    /// The board committed changes not drained yet.
    changes: AtomicBool,
    /// Held while board ops are applied (one applier at a time, in queue order).
    apply: Mutex<()>,
    queue: Mutex<VecDeque<BoardOp>>,
    plan_handler: RwLock<Option<Arc<dyn PlanHandler>>>,
    ticker: Arc<Ticker>,
    /// On a manual clock, when the timers next have something to do
    /// ([`State::next_tick`]); touched by anything else that changes the state (a
    /// message, a peer's up or down, a board change, a call). The clock skips the
    /// ticker on a move before it.
    wake: Arc<Wake>,
    /// The link policies set (`set_link_policy`), taken after the state lock.
    links: Mutex<link::Links>,
    /// Publications made once the state lock is released (the state's own).
    outgoing: Arc<outgoing::Outgoing>,
    /// The thread that sends lingering reports (`IciConfig::linger`; none on a manual
    /// clock).
    linger: Option<Arc<linger::Linger>>,
}

impl Ici {
    /// Connects `board` to `transport` (both at the same address) and starts: defines
    /// the `Module` class on the board, watches it, and greets the peers already up.
    pub fn new(
        board: Arc<Board>,
        transport: Arc<dyn Transport>,
        config: IciConfig,
    ) -> Result<Ici, IciStartError> {
        if board.address() != transport.address() {
            return Err(IciStartError::AddressMismatch {
                board: board.address().clone(),
                transport: transport.address().clone(),
            });
        }
        board.define(module_class())?;
        board.set_normaliser(Some(Arc::new(quantise::Quantiser)));
        quantise::settle(&board);
        let watch = board.watch(Filter::all().own_writes_only())?;
        let links = Mutex::new(link::Links::new(&config));
        let state = State::new(board.clone(), transport.clone(), config, watch);
        let outgoing = state.outgoing.clone();
        let lingers = !state.linger.is_zero();
        let shared = Arc::new_cyclic(|me: &Weak<Shared>| Shared {
            board: board.clone(),
            transport: transport.clone(),
            state: Mutex::new(state),
            changes: AtomicBool::new(false),
            apply: Mutex::new(()),
            queue: Mutex::new(VecDeque::new()),
            plan_handler: RwLock::new(None),
            ticker: Arc::new(Ticker(me.clone())),
            wake: Arc::default(),
            links,
            outgoing,
            linger: lingers
                .then(|| linger::Linger::start(me.clone()))
                .transpose()
                .unwrap_or_else(|e| {
                    tracing::warn!("no linger thread ({e}): every report goes at once");
                    None
                }),
        });
        shared.with_state(State::adopt_own_objects);
        shared.connect();
        for peer in transport.peers() {
            shared.with_state(|st| st.on_peer(&peer, true));
        }
        Ok(Ici { shared })
    }

    /// The module's address.
    pub fn address(&self) -> &Address {
        self.shared.transport.address()
    }

    /// The board.
    pub fn board(&self) -> &Arc<Board> {
        &self.shared.board
    }

    /// Runs the timers due now (heartbeats, trailing edges, timeouts, retries).
    pub fn tick(&self) {
        self.shared.with_state(tick_all);
    }

    /// The gateway of this module's robot as this module sees it (team protocol on).
    pub fn gateway(&self) -> Option<Address> {
        self.shared.state.lock().gateway()
    }

    /// Counters so far.
    pub fn stats(&self) -> IciStats {
        let st = self.shared.state.lock();
        let mut stats = st.stats.clone();
        stats.rejects.decode = st.decoder.stats();
        stats
    }

    /// The modules this ICI currently holds alive.
    pub fn alive_peers(&self) -> Vec<Address> {
        let st = self.shared.state.lock();
        st.peers
            .iter()
            .filter(|(_, p)| p.alive == Some(true))
            .map(|(a, _)| a.clone())
            .collect()
    }

    /// Does this board hold `peer`'s current state: a catch-up with it completed (since
    /// it last restarted), and none is outstanding? For an observer, also: `peer` has
    /// answered its hello, so it knows to forget the observer as soon as it leaves (a
    /// hello can be lost, and an observer may be done before it says hello again).
    pub fn is_caught_up_with(&self, peer: &Address) -> bool {
        let st = self.shared.state.lock();
        let observer = st.config.observer;
        st.peers.get(peer).is_some_and(|p| {
            let heard = !observer || p.hello_unanswered.is_none();
            p.caught_up && p.catch_up.is_none() && !p.failed && heard
        })
    }

    /// The classes other modules define differently from this board, with the module:
    /// `(class, peer)`, sorted. Objects of such a class are not merged with that module.
    pub fn class_conflicts(&self) -> Vec<(String, Address)> {
        let st = self.shared.state.lock();
        st.conflicts
            .iter()
            .map(|(class, peer)| (class.to_string(), peer.clone()))
            .collect()
    }

    /// Changes what this board models: tells every peer, and catches up with each.
    pub fn set_interest(&self, interest: ClassSet) {
        self.shared.with_state(|st| {
            st.config.interest = interest;
            st.forget_resolved();
            for link in LinkKind::ALL {
                for peer in st.up_peers(link) {
                    st.send_hello(&peer);
                    st.request_catch_up(&peer, false, false);
                }
            }
        });
    }

    /// Changes what may leave the robot on the team link, from now on.
    pub fn set_export(&self, export: ClassSet) {
        self.shared.with_state(|st| st.config.export = export);
    }

    /// Sets the policy of one kind of link (a module's merged `link` blocks, from now
    /// on): its export (team link) is united with the export this ICI was started with,
    /// its heartbeat and timeout replace the link's, and its report overrides become the
    /// link's own filters, applied on top of the classes' (docs/team-protocol.md, 3).
    pub fn set_link_policy(&self, link: LinkKind, policy: LinkPolicy) {
        self.shared
            .with_state(|st| self.shared.links.lock().set(st, link, policy));
    }

    /// The team link's rate changed (a robot on deck, on a fast link, goes to sea on its
    /// acoustic modem): with the team protocol on, its gateway paces its radio to
    /// `rate_bps` from now on (`TeamProtocol::rate_bps`), its token bucket full. What it
    /// sent on the link before is not owed at the new rate: a few kilobytes of plans on
    /// deck would otherwise hold back every frame for minutes at a few bytes a second.
    pub fn set_team_rate(&self, rate_bps: u32) {
        self.shared.with_state(|st| st.set_team_rate(rate_bps));
    }

    /// The policy last set for one kind of link.
    pub fn link_policy(&self, link: LinkKind) -> Option<LinkPolicy> {
        self.shared.links.lock().get(link).cloned()
    }

    /// Asks `source` for its current state now.
    pub fn catch_up(&self, source: &Address) {
        self.shared
            .with_state(|st| st.request_catch_up(source, false, false));
    }

    /// Installs the handler of inbound plan messages (replacing any other).
    pub fn set_plan_handler(&self, handler: Arc<dyn PlanHandler>) {
        *self.shared.plan_handler.write() = Some(handler);
    }

    /// Delivers packets now, whoever wrote them: to one module (`Some(to)`, reliably,
    /// off the report stream) or to every peer interested (`None`, on the report stream
    /// of each link kind, like any report). This is a plan's `report` action: it skips
    /// the report filters and the export policy, but not the receivers' interest. Only
    /// packets the object (or class) holds itself go: `(object, attribute, packet)`
    /// triples whose value is inherited, a default or `none` are left out. Returns how
    /// many packets went out (a packet sent on both link kinds counts twice).
    pub fn report(
        &self,
        to: Option<&Address>,
        packets: Vec<(
            std::sync::Arc<str>,
            std::sync::Arc<str>,
            slate_model::Packet,
        )>,
    ) -> usize {
        self.shared.with_state(|st| st.report_explicit(to, packets))
    }

    /// Whether the transport retransmits what the network lost ([`Transport::retransmits`]).
    pub fn transport_retransmits(&self) -> bool {
        self.shared.transport.retransmits()
    }

    /// Sends a `Plan`, `PlanAck` or `PlanCancel` to one module, reliably. This is the
    /// plan engine's way out; everything else goes through the board.
    pub fn send_raw(&self, to: &Address, msg: &Message) -> Result<(), SendRawError> {
        let kind = MsgKind::of_message(msg);
        if !matches!(kind, MsgKind::Plan | MsgKind::PlanAck | MsgKind::PlanCancel) {
            return Err(SendRawError::NotAPlanMessage(kind));
        }
        let bytes = Encoder::new(self.address().clone()).encode(msg, &Schema::default())?;
        self.shared.transport.send(to, kind, &bytes)?;
        let link = LinkKind::between(self.address(), to);
        let mut st = self.shared.state.lock();
        self.shared.touched();
        st.team_aired(link, bytes.len());
        st.said(link);
        st.stats.sent(link, kind, bytes.len());
        Ok(())
    }
}

impl Shared {
    /// Hooks the ICI to the board (changes), the clock (ticks) and the transport.
    fn connect(self: &Arc<Self>) {
        let me = Arc::downgrade(self);
        self.board.add_hook(Arc::new(Doorbell(me.clone())));
        if self.board.clock().is_manual() {
            let listener: Arc<dyn ClockListener> = self.ticker.clone();
            let clock = self.board.clock();
            clock.subscribe_waking(Arc::downgrade(&listener), self.wake.clone());
        }
        self.transport.set_handler(Arc::new(Inbound(me)));
    }

    /// Runs `f` on the state, then applies the board ops it queued and hands out the
    /// plan events, with the state lock released.
    fn with_state<R>(&self, f: impl FnOnce(&mut State) -> R) -> R {
        self.with_state_until(f, |_| Duration::ZERO)
    }

    /// [`with_state`](Self::with_state), then the clock's time before which the timers
    /// have nothing to do is `wake(state)` (after `f`, with the lock held).
    fn with_state_until<R>(
        &self,
        f: impl FnOnce(&mut State) -> R,
        wake: impl FnOnce(&State) -> Duration,
    ) -> R {
        let (result, queued, plans, every) = {
            let mut st = self.state.lock();
            st.now = self.board.clock().physical();
            let result = f(&mut st);
            self.wake.set(wake(&st));
            let queued = self.enqueue(&mut st);
            let every = std::mem::take(&mut st.queued_every);
            (result, queued, std::mem::take(&mut st.plans), every)
        };
        self.outgoing.flush(&*self.transport, every);
        if queued {
            self.run_queue();
        }
        self.deliver(plans);
        self.pump();
        result
    }

    /// Tells the linger thread, once a linger, when the reports waiting must go. Without
    /// the thread (it could not start), they go now.
    fn ask_linger(&self, st: &mut State) {
        let Some(until) = st.linger_end().filter(|_| !st.linger_asked) else {
            return;
        };
        st.linger_asked = true;
        match &self.linger {
            Some(linger) => linger.ask(until.saturating_sub(st.now)),
            None => st.flush_lingering(),
        }
    }

    /// Moves the board ops the state holds to the queue, in the order the state lock
    /// was taken (the state's buffer keeps its capacity). Were any?
    fn enqueue(&self, st: &mut State) -> bool {
        if st.ops.is_empty() {
            return false;
        }
        self.queue.lock().extend(st.ops.drain(..));
        true
    }

    /// The board committed something. While board ops are being applied (received
    /// packets, mostly), the applier drains the changes once it is done (`with_state`
    /// pumps after `run_queue`), not once per op.
    fn changed(&self) {
        self.changes.store(true, Ordering::SeqCst);
        if self.apply.is_locked() {
            return;
        }
        self.pump();
    }

    /// Drains the board's changes, unless another caller holds the state: that caller
    /// drains them when it lets go (it checks the flag after releasing the lock).
    fn pump(&self) {
        while self.changes.load(Ordering::SeqCst) {
            let Some(mut st) = self.state.try_lock() else {
                return;
            };
            self.changes.store(false, Ordering::SeqCst);
            self.touched();
            st.now = self.board.clock().physical();
            st.drain_changes();
            self.ask_linger(&mut st);
            let queued = self.enqueue(&mut st);
            let plans = std::mem::take(&mut st.plans);
            let every = std::mem::take(&mut st.queued_every);
            drop(st);
            self.outgoing.flush(&*self.transport, every);
            if queued {
                self.run_queue();
            }
            self.deliver(plans);
        }
    }

    /// Applies queued board ops, unless another caller is applying: that caller takes
    /// what is queued before it lets go.
    fn run_queue(&self) {
        loop {
            let Some(guard) = self.apply.try_lock() else {
                return;
            };
            let mut tally = ops::Tally::default();
            let mut merges = ops::Merges::new();
            loop {
                // Consecutive merges (a report's packets) are one board change.
                let op = {
                    let mut queue = self.queue.lock();
                    while let Some(BoardOp::Merge { .. }) = queue.front() {
                        if let Some(BoardOp::Merge {
                            object,
                            attr,
                            key,
                            packet,
                        }) = queue.pop_front()
                        {
                            merges.push((object, attr, key, packet));
                        }
                    }
                    if merges.is_empty() {
                        queue.pop_front()
                    } else {
                        None
                    }
                };
                if !merges.is_empty() {
                    ops::merge_all(&self.board, &mut tally, merges.drain(..));
                    continue;
                }
                let Some(op) = op else { break };
                ops::apply(&self.board, &self.state, op, &mut tally);
            }
            tally.flush(&self.state);
            self.touched();
            drop(guard);
            if self.queue.lock().is_empty() {
                return;
            }
        }
    }

    /// Something other than a tick changed the state: the timers run at the clock's
    /// next move.
    fn touched(&self) {
        self.wake.touched();
    }

    fn deliver(&self, events: Vec<PlanEvent>) {
        if events.is_empty() {
            return;
        }
        let Some(handler) = self.plan_handler.read().clone() else {
            return;
        };
        for event in events {
            match event {
                PlanEvent::Message(from, msg) => handler.message(&from, msg),
                PlanEvent::Peer(peer, alive) => handler.peer(&peer, alive),
            }
        }
    }
}

impl Drop for Shared {
    /// Reports still lingering go; the board outlives its ICI: its writes are its own
    /// again.
    fn drop(&mut self) {
        let every = {
            let mut st = self.state.lock();
            st.flush_lingering();
            std::mem::take(&mut st.queued_every)
        };
        self.outgoing.flush(&*self.transport, every);
        self.board.set_normaliser(None);
    }
}

/// Runs the ICI's timers, then the link filters' (`link.rs`).
fn tick_all(st: &mut State) {
    st.stats.timer_runs += 1;
    st.tick();
    st.link_filter_timers();
}

/// The board's change hook: rings the ICI.
struct Doorbell(Weak<Shared>);

impl slate_model::ChangeHook for Doorbell {
    fn changed(&self, _: &Board, _: u64, _: &[Touched]) {
        if let Some(shared) = self.0.upgrade() {
            shared.changed();
        }
    }
}

/// The manual clock's listener: runs the timers.
struct Ticker(Weak<Shared>);

impl ClockListener for Ticker {
    /// Runs the timers. The clock calls it only on a move at or past `Shared::wake`:
    /// every module of a simulated team hears every move of the shared clock (one per
    /// event), and running all of their timers at each was the simulator's largest
    /// cost, growing with the cube of the team (docs/team-protocol.md, 7.1).
    fn advanced(&self, _now: Duration) {
        if let Some(shared) = self.0.upgrade() {
            shared.with_state_until(tick_all, State::next_tick);
        }
    }
}

/// The transport's handler.
struct Inbound(Weak<Shared>);

impl crate::Handler for Inbound {
    fn message(&self, from: &Address, payload: &[u8]) {
        if let Some(shared) = self.0.upgrade() {
            shared.with_state(|st| st.on_message(from, payload));
        }
    }

    fn peer(&self, peer: &Address, up: bool) {
        if let Some(shared) = self.0.upgrade() {
            shared.with_state(|st| st.on_peer(peer, up));
        }
    }
}
