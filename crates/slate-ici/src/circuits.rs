//! Plan circuits (docs/ici.md): a plan sent to another module travels on a virtual
//! circuit, and its origin hears every step of its progression — received, accepted or
//! rejected with the reason, initiated, each trigger with success or failure,
//! terminated, cancelled, destination lost.
//!
//! [`PlanCircuits`] joins a plan [`Engine`] to an [`Ici`] in both roles:
//!
//! * **destination** ([`destination`]): a `Plan` message is acknowledged `Received`,
//!   loaded into the engine, `Accepted` or `Rejected` (the rendered diagnostics); then
//!   the engine's progress events for that plan become acks. A `PlanCancel` cancels it.
//!   Steps are numbered per circuit and kept, so they can be sent again.
//! * **origin** ([`origin`]): acks are put in order and deduplicated by their number,
//!   and delivered once each on the circuit's [`PlanHandle`]; a destination that dies
//!   while the circuit is open becomes a local `DestinationLost` step.
//!
//! The engine's `send` actions open circuits of their own (plans decompose into
//! sub-plans, like the paper's welding cell), and its `report` actions go out through
//! [`Ici::report`]. The protocol is described in `docs/ici.md` ("Plan circuits").

mod authority;
mod destination;
mod origin;

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Weak};
use std::time::Duration;

use crossbeam_channel::{Receiver, Select, Sender, TrySendError};
use parking_lot::Mutex;
use slate_model::{Address, Board, ChangeHook, ClockListener, Touched};
use slate_plans::{Diagnostic, Diagnostics, Engine, Item, Outgoing, PlanEvent, Span, Stage};
use slate_wire::{Message, PlanStep};

use crate::{Ici, PlanHandler, SendRawError};
pub use authority::PlanAuthority;
use destination::Destination;
use origin::Origin;
use slate_model::Wake;
pub use slate_model::{AddressPattern, PatternError};

/// How long a gap in a circuit's acknowledgements may stay open (later steps arrived,
/// an earlier one did not) before the origin asks the destination for its steps again.
pub const ACK_GAP_GRACE: Duration = Duration::from_secs(1);

/// The longest plan text, in bytes, a module sends or accepts: ten times the longest plan
/// of the demo, half what a message carries. A longer text is refused before it is parsed
/// (the origin's [`SendPlanError::TooLarge`], the destination's `Rejected` step).
pub const MAX_PLAN_TEXT_BYTES: usize = 32 * 1024;

/// Plan messages (`Plan`, `PlanCancel`) waiting for the circuits' thread, at most: past it a
/// `Plan` is rejected at once (the module is busy), without being parsed.
pub const MAX_QUEUED_PLANS: usize = 64;

/// What a module's circuits did: with the plans it received (destination) and those it
/// sent (origin).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CircuitStats {
    /// `Plan` messages that opened a circuit (a plan sent again on its circuit is not
    /// counted again).
    pub received: u64,
    /// Plans loaded and acknowledged `Accepted`.
    pub accepted: u64,
    /// Plans refused with a reason on their circuit (`Rejected`): too large, not one plan,
    /// nested too deep, wrong names or types, a name taken, or the module busy.
    pub rejected: u64,
    /// Of those, plans rejected because [`MAX_QUEUED_PLANS`] were already waiting.
    pub busy: u64,
    /// Of those, plans rejected because their sender or their origin has no authority
    /// to send this module plans ([`PlanAuthority`]).
    pub unauthorised: u64,
    /// Copies of a plan this module already had (same origin, circuit and text), answered
    /// with the circuit's steps again, never loaded twice.
    pub answered_again: u64,
    /// Last steps (`Terminated`, `Cancelled`, `Rejected`) sent again, unasked, in case the
    /// first copy was lost: nothing follows them to reveal the loss.
    pub repeated: u64,
    /// Plans (and cancellations) this module sent again on its circuits: unanswered, to
    /// ask for missing steps, or to a destination that came back.
    pub resent: u64,
}

/// The counters behind [`CircuitStats`].
#[derive(Default)]
struct Counters {
    received: AtomicU64,
    accepted: AtomicU64,
    rejected: AtomicU64,
    busy: AtomicU64,
    unauthorised: AtomicU64,
    answered_again: AtomicU64,
    repeated: AtomicU64,
    resent: AtomicU64,
}

impl Counters {
    fn snapshot(&self) -> CircuitStats {
        CircuitStats {
            received: self.received.load(Ordering::Relaxed),
            accepted: self.accepted.load(Ordering::Relaxed),
            rejected: self.rejected.load(Ordering::Relaxed),
            busy: self.busy.load(Ordering::Relaxed),
            unauthorised: self.unauthorised.load(Ordering::Relaxed),
            answered_again: self.answered_again.load(Ordering::Relaxed),
            repeated: self.repeated.load(Ordering::Relaxed),
            resent: self.resent.load(Ordering::Relaxed),
        }
    }
}

/// How long a follower of a circuit (`slate plan send` without `--timeout`, a Python
/// handle's iteration) waits, after [`PlanStep::DestinationLost`], for the destination
/// to come back: longer than Zenoh's 10 s lease and a module's restart, so a destination
/// that only dropped off the network is heard again.
pub const LOST_WAIT: Duration = Duration::from_secs(30);

/// The plan circuits of one module: plans it sends (with their acknowledgements) and
/// plans it runs for others. Cloning gives another handle to the same circuits;
/// dropping the last one stops them (keep one for as long as the module runs).
///
/// ```
/// use std::sync::Arc;
/// use std::time::Duration;
/// use slate_ici::{AddressPattern, Ici, IciConfig, PlanAuthority, PlanCircuits, SimNet};
/// use slate_model::{Address, Board};
/// use slate_plans::Engine;
/// use slate_wire::PlanStep;
///
/// let net = SimNet::new(7);
/// let start = |text: &str| -> Result<(Engine, PlanCircuits), slate_ici::Error> {
///     let address = Address::new(text)?;
///     let board = Arc::new(Board::builder().clock(net.clock()).address(address.clone()).build());
///     let engine = Engine::new(&board);
///     engine.load("world.slate", "class Cell { t: real = 0.0; } object cell : Cell;")?;
///     let ici = Ici::new(board, net.join(&address), IciConfig::default())?;
///     Ok((engine.clone(), PlanCircuits::attach(&ici, &engine)))
/// };
/// let (_, planner) = start("team/r1/planner")?;
/// let (cell_engine, cell) = start("team/r2/cell")?;
/// net.run_for(Duration::from_millis(200)); // they meet
///
/// // By default only the modules of its own robot may send the cell plans.
/// let to = Address::new("team/r2/cell")?;
/// cell.set_authority(PlanAuthority::own_robot(&to).allow(AddressPattern::new("team/r1/planner")?));
/// let handle = planner.send(&to, "plan hot { trigger: cell.t > 50.0; action { set cell.t = 50.0; } }")?;
/// net.run_for(Duration::from_millis(200));
/// let steps: Vec<PlanStep> = handle.acks().try_iter().collect();
/// assert_eq!(steps, [PlanStep::Received, PlanStep::Accepted, PlanStep::Initiated]);
/// assert_eq!(cell_engine.status("hot").map(|s| s.fired), Some(0));
/// # Ok::<(), slate_ici::Error>(())
/// ```
#[derive(Clone)]
pub struct PlanCircuits {
    inner: Arc<Inner>,
}

/// A plan this module sent: its circuit, and the acknowledgements as they arrive.
#[derive(Debug)]
pub struct PlanHandle {
    /// The circuit's number (unique among the circuits this module opened).
    pub circuit: u64,
    /// The plan's name.
    pub name: String,
    /// The module running it.
    pub to: Address,
    acks: Receiver<PlanStep>,
}

impl PlanHandle {
    /// The acknowledgements, in order, deduplicated (a crossbeam Receiver). A local
    /// [`PlanStep::DestinationLost`] appears where the destination died.
    pub fn acks(&self) -> &Receiver<PlanStep> {
        &self.acks
    }
}

/// One circuit as this module sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct CircuitStatus {
    /// The circuit's number (chosen by its origin).
    pub circuit: u64,
    /// The plan's name.
    pub name: String,
    /// The other end: the destination of a plan sent, the origin of a plan received.
    pub peer: Address,
    /// Every step heard (origin) or sent (destination) so far, in order.
    pub steps: Vec<PlanStep>,
}

/// Why a plan could not be sent or cancelled.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum SendPlanError {
    /// The text is not exactly one `plan NAME { ... }`: it does not parse, or it holds
    /// something else or more. `rendered` shows every problem with its line and column.
    #[error("not one plan:\n{rendered}")]
    NotOnePlan {
        /// The diagnostics, rendered under the source lines.
        rendered: String,
    },
    /// The text is longer than [`MAX_PLAN_TEXT_BYTES`]: split the plan (a plan can send
    /// sub-plans, each on its own circuit).
    #[error(
        "the plan text is {bytes} bytes; at most {MAX_PLAN_TEXT_BYTES} are sent: split it into sub-plans"
    )]
    TooLarge {
        /// The text's length.
        bytes: usize,
    },
    /// The ICI refused the message.
    #[error("cannot send: {0}")]
    Send(#[from] SendRawError),
    /// This module opened no circuit of that number.
    #[error("no circuit {0} was opened by this module")]
    UnknownCircuit(u64),
    /// The circuit is closed: its plan terminated, was cancelled or was rejected.
    #[error("circuit {0} is closed (its plan terminated, was cancelled or was rejected)")]
    Closed(u64),
}

/// The name of the one plan `text` holds, or every reason it is not one plan.
pub(crate) fn one_plan(file_name: &str, text: &str) -> Result<String, String> {
    let file = slate_plans::parse(text).map_err(|d| d.render(file_name, text))?;
    let shape = |span: Span, message: &str| {
        Diagnostics(vec![Diagnostic::error(Stage::Parse, span, message)]).render(file_name, text)
    };
    match file.items.as_slice() {
        [Item::Plan(plan)] => Ok(plan.name.name.clone()),
        [] => Err(shape(
            Span::new(0, 0, 1, 1),
            "expected one `plan NAME { ... }`, found nothing",
        )),
        [Item::Plan(_), second, ..] => Err(shape(
            second.span(),
            "expected one plan and nothing else after it",
        )),
        [first, ..] => Err(shape(
            first.span(),
            "expected `plan NAME { ... }`: a circuit carries one plan, not classes, objects or rules",
        )),
    }
}

/// Steps that close a circuit: the final ones ([`PlanStep::is_final`]) but a lost
/// destination, which may come back (the origin then sends the plan again).
pub(crate) fn closes(step: &PlanStep) -> bool {
    step.closes_circuit()
}

pub(crate) struct Inner {
    ici: Ici,
    engine: Engine,
    me: Address,
    next_circuit: AtomicU64,
    /// Taken through [`Inner::origin`] (but by the timers).
    origin: Mutex<Origin>,
    /// Taken through [`Inner::destination`] (but by the timers).
    destination: Mutex<Destination>,
    /// On a manual clock, when the timers next have something to do; touched by
    /// anything else that takes the origin or the destination, and by the engine after
    /// each event and send (`events`, `outgoing`). The clock skips the `Hook` on a move
    /// before it.
    wake: Arc<Wake>,
    outgoing: Receiver<Outgoing>,
    events: Receiver<PlanEvent>,
    /// Held by the one thread draining the engine's channels.
    draining: Mutex<()>,
    /// The manual clock's listener (the clock holds it weakly).
    listener: Mutex<Option<Arc<dyn ClockListener>>>,
    /// Plans received, accepted, rejected.
    counters: Counters,
    /// Who may send this module plans.
    authority: Mutex<PlanAuthority>,
    /// The origin each plan received runs for (plan name → origin), named as the origin of
    /// the plans it sends on; a plan not in it is this module's own. One entry per plan
    /// the engine holds for another module.
    runs_for: Mutex<HashMap<String, Address>>,
    /// Those told of each plan refused for want of authority (see
    /// [`PlanCircuits::refusals`]).
    refusals: Mutex<Vec<slate_model::WakingSender<RefusedPlan>>>,
    /// The transport loses sends without retransmitting them ([`Transport::retransmits`]):
    /// unanswered plans go again and last steps are repeated.
    ///
    /// [`Transport::retransmits`]: crate::Transport::retransmits
    lossy: bool,
    /// On the system clock, where `Plan` and `PlanCancel` messages go to be handled on the
    /// circuits' thread, not on the transport's; `None` on a manual clock.
    queue: Option<Sender<(Address, Message)>>,
}

impl PlanCircuits {
    /// Connects the plan engine to the ICI: plans received are loaded into `engine` and
    /// acknowledged step by step; the engine's `send` actions go out as plans on new
    /// circuits; its `report` actions go out as reports.
    ///
    /// It replaces the ICI's plan handler. On a manual clock (the simulator) everything
    /// runs in the threads that move the clock, write the board or deliver messages; on
    /// the system clock a small thread also takes the engine's timer-driven events, and
    /// parses, checks and loads the plans received (at most [`MAX_QUEUED_PLANS`] waiting),
    /// so the transport's receive thread never does.
    pub fn attach(ici: &Ici, engine: &slate_plans::Engine) -> PlanCircuits {
        let manual = ici.board().clock().is_manual();
        let (queue, queued) = crossbeam_channel::bounded(MAX_QUEUED_PLANS);
        let wake = Arc::new(Wake::default());
        let inner = Arc::new(Inner {
            ici: ici.clone(),
            engine: engine.clone(),
            me: ici.address().clone(),
            next_circuit: AtomicU64::new(1),
            origin: Mutex::new(Origin::default()),
            destination: Mutex::new(Destination::default()),
            wake: wake.clone(),
            outgoing: engine.outgoing_waking(wake.clone()),
            events: engine.events_waking(wake.clone()),
            draining: Mutex::new(()),
            listener: Mutex::new(None),
            counters: Counters::default(),
            authority: Mutex::new(PlanAuthority::own_robot(ici.address())),
            runs_for: Mutex::new(HashMap::new()),
            refusals: Mutex::new(Vec::new()),
            lossy: !ici.transport_retransmits(),
            queue: (!manual).then_some(queue),
        });
        let weak = Arc::downgrade(&inner);
        ici.set_plan_handler(Arc::new(Handler(weak.clone())));
        let board = ici.board();
        board.add_hook(Arc::new(Hook(weak.clone())));
        if manual {
            let listener: Arc<dyn ClockListener> = Arc::new(Hook(weak.clone()));
            board
                .clock()
                .subscribe_waking(Arc::downgrade(&listener), wake);
            *inner.listener.lock() = Some(listener);
        } else {
            spawn_pump(weak, inner.outgoing.clone(), inner.events.clone(), queued);
        }
        PlanCircuits { inner }
    }

    /// Sends a plan (slate source text of ONE `plan NAME { ... }`) to a module;
    /// acknowledgements arrive on the handle.
    ///
    /// The text is parsed here (a syntax error never travels); names and types are
    /// checked by the destination, against its board. A plan sent to a module that is
    /// not up yet is delivered when it comes up.
    pub fn send(&self, to: &Address, text: &str) -> Result<PlanHandle, SendPlanError> {
        self.inner.send(to, text)
    }

    /// Cancels a plan this module sent.
    pub fn cancel(&self, circuit: u64) -> Result<(), SendPlanError> {
        self.inner.cancel(circuit)
    }

    /// Circuits this module opened (plans it sent), with every step heard so far.
    pub fn sent(&self) -> Vec<CircuitStatus> {
        self.inner.origin().status()
    }

    /// Circuits others opened to this module (plans it runs for them).
    pub fn received(&self) -> Vec<CircuitStatus> {
        self.inner.destination().status()
    }

    /// How many plans this module received, accepted and rejected.
    pub fn stats(&self) -> CircuitStats {
        self.inner.counters.snapshot()
    }

    /// Sets who may send this module plans (by default the modules of its own robot):
    /// plans received from then on are judged by it.
    pub fn set_authority(&self, authority: PlanAuthority) {
        *self.inner.authority.lock() = authority;
    }

    /// Who may send this module plans.
    pub fn authority(&self) -> PlanAuthority {
        self.inner.authority.lock().clone()
    }

    /// Every plan refused from now on for want of authority, as it is refused; a receiver
    /// that lets [`MAX_QUEUED_REFUSALS`] wait misses the newer ones (nothing waits for it).
    pub fn refusals(&self) -> Receiver<RefusedPlan> {
        self.refusals_with(None)
    }

    /// [`PlanCircuits::refusals`], touching `wake` after each refusal: a manual clock's
    /// listener that reads them can sleep until there is one.
    pub fn refusals_waking(&self, wake: Arc<Wake>) -> Receiver<RefusedPlan> {
        self.refusals_with(Some(wake))
    }

    fn refusals_with(&self, wake: Option<Arc<Wake>>) -> Receiver<RefusedPlan> {
        let (tx, rx) = crossbeam_channel::bounded(MAX_QUEUED_REFUSALS);
        let tx = slate_model::WakingSender::new(tx, wake);
        self.inner.refusals.lock().push(tx);
        rx
    }
}

impl PlanCircuits {
    /// The plans other modules sent that this one accepted and still runs (neither
    /// ended nor cancelled): what a node keeps to install them again after a restart.
    pub fn held(&self) -> Vec<HeldPlan> {
        self.inner.held()
    }

    /// Installs again a plan [`held`](PlanCircuits::held) before a restart, on its
    /// circuit: the steps it takes from now on go to the module that sent it, numbered
    /// from [`HeldPlan::next_step`]. The plan takes up at [`HeldPlan::progress`]: active
    /// if it had initiated, with its `fired` count, firing on the trigger's next rising
    /// edge if the trigger held when it was kept. Refused, with the reason, if the module that sent it or its
    /// origin may no longer send plans here, or the plan no longer loads.
    pub fn reinstate(&self, plan: HeldPlan) -> Result<(), String> {
        self.inner.reinstate(plan)
    }
}

/// A plan another module sent and this one accepted and still runs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HeldPlan {
    /// The module that sent it: the circuit's other end, to which its steps go.
    pub from: Address,
    /// The circuit's number, chosen by `from`.
    pub circuit: u64,
    /// The module whose plan it is (named as the origin of the plans it sends on).
    pub origin: Address,
    /// The plan's name.
    pub name: String,
    /// Its source text.
    pub text: String,
    /// The number the circuit's next step takes.
    pub next_step: u64,
    /// Where the plan was (its latches, `fired` count and trigger's edge): it takes up
    /// there when installed again, so a trigger that held does not fire it once more.
    pub progress: slate_plans::PlanProgress,
}

/// Refusals a receiver of [`PlanCircuits::refusals`] may have waiting.
pub const MAX_QUEUED_REFUSALS: usize = 256;

/// A plan refused because its sender or its origin may not send this module plans.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RefusedPlan {
    /// The module that sent it.
    pub from: Address,
    /// The origin it named (the module whose plan it is).
    pub origin: Address,
    /// The plan's name.
    pub name: String,
    /// The reason acknowledged on its circuit.
    pub reason: String,
}

impl Inner {
    fn send(self: &Arc<Self>, to: &Address, text: &str) -> Result<PlanHandle, SendPlanError> {
        let me = self.me.clone();
        self.send_for(to, text, &me)
    }

    /// Sends a plan of `origin`: this module's own, or the origin of the received plan
    /// that sends it on (so it carries no more authority than its origin has).
    fn send_for(
        self: &Arc<Self>,
        to: &Address,
        text: &str,
        origin: &Address,
    ) -> Result<PlanHandle, SendPlanError> {
        if text.len() > MAX_PLAN_TEXT_BYTES {
            return Err(SendPlanError::TooLarge { bytes: text.len() });
        }
        let name = one_plan("plan.slate", text)
            .map_err(|rendered| SendPlanError::NotOnePlan { rendered })?;
        let circuit = self.next_circuit.fetch_add(1, Ordering::Relaxed);
        let now = self.now();
        let (acks, msg) = self
            .origin()
            .open(circuit, (&name, text), to, origin, now, self.lossy);
        if let Err(e) = self.transmit(to, msg) {
            self.origin().forget(circuit);
            return Err(e.into());
        }
        tracing::debug!(me = %self.me, %to, circuit, plan = %name, "plan sent");
        Ok(PlanHandle {
            circuit,
            name,
            to: to.clone(),
            acks,
        })
    }

    fn cancel(self: &Arc<Self>, circuit: u64) -> Result<(), SendPlanError> {
        let now = self.now();
        let to = self.origin().request_cancel(circuit, now, self.lossy)?;
        self.transmit(&to, Message::PlanCancel { circuit })?;
        Ok(())
    }

    /// Sends a plan message; one addressed to this module is handled here at once.
    fn transmit(self: &Arc<Self>, to: &Address, msg: Message) -> Result<(), SendRawError> {
        if *to == self.me {
            self.on_message(to, msg);
            return Ok(());
        }
        self.ici.send_raw(to, &msg)
    }

    /// Sends, logging a refusal (acks and re-sends are retried by the protocol).
    fn transmit_logged(self: &Arc<Self>, to: &Address, msg: Message) {
        if let Err(e) = self.transmit(to, msg) {
            tracing::debug!(to = %to, error = %e, "plan message not sent");
        }
    }

    fn now(&self) -> Duration {
        self.ici.board().clock().physical()
    }

    /// A plan message from the transport (or from this module to itself): on the system
    /// clock, `Plan` and `PlanCancel` are queued for the circuits' thread (in order, so a
    /// cancel follows its plan); the rest is handled at once.
    fn on_message(self: &Arc<Self>, from: &Address, msg: Message) {
        match (&self.queue, msg) {
            (Some(queue), msg @ (Message::Plan(_) | Message::PlanCancel { .. })) => {
                self.enqueue(queue, from, msg);
            }
            (_, msg) => self.handle(from, msg),
        }
    }

    /// Queues a plan message; when the queue is full, a `Plan` is rejected as busy and a
    /// `PlanCancel` (cheap) is handled here.
    fn enqueue(self: &Arc<Self>, queue: &Sender<(Address, Message)>, from: &Address, msg: Message) {
        match queue.try_send((from.clone(), msg)) {
            Ok(()) => {}
            Err(TrySendError::Full((from, Message::Plan(plan)))) => self.refuse_busy(&from, plan),
            Err(TrySendError::Full((from, msg)) | TrySendError::Disconnected((from, msg))) => {
                self.handle(&from, msg);
            }
        }
    }

    /// Handles the plan messages queued so far (on the circuits' thread).
    fn handle_queued(self: &Arc<Self>, queued: &Receiver<(Address, Message)>) {
        for (from, msg) in queued.try_iter().take(MAX_QUEUED_PLANS) {
            self.handle(&from, msg);
        }
    }

    fn handle(self: &Arc<Self>, from: &Address, msg: Message) {
        match msg {
            Message::Plan(plan) => self.on_plan(from, plan),
            Message::PlanAck(ack) => {
                let now = self.now();
                self.origin().ack(from, ack, now);
            }
            Message::PlanCancel { circuit } => self.on_cancel(from, circuit),
            other => tracing::debug!(from = %from, ?other, "not a plan message"),
        }
    }

    /// A module came up (re-send the plans of open circuits: the destination answers
    /// with their steps) or died (open circuits to it lose their destination).
    fn on_peer(self: &Arc<Self>, peer: &Address, alive: bool) {
        if !alive {
            self.origin().lost(peer);
            return;
        }
        let now = self.now();
        let resend = self.origin().resume(peer, now, self.lossy);
        self.count_resent(resend.len());
        for msg in resend {
            self.transmit_logged(peer, msg);
        }
    }

    /// The circuits this module opened, for anything but their timers.
    fn origin(&self) -> parking_lot::MutexGuard<'_, Origin> {
        self.wake.touched();
        self.origin.lock()
    }

    /// The circuits opened to this module, for anything but their timers.
    pub(crate) fn destination(&self) -> parking_lot::MutexGuard<'_, Destination> {
        self.wake.touched();
        self.destination.lock()
    }

    /// Runs the timers, unless none is due before the manual clock's next move (every
    /// module of a simulated team hears every move: the console's circuits, one per
    /// plan it sent, were walked at each).
    fn tick_if_due(self: &Arc<Self>, now: Duration) {
        if self.wake.asleep_at(now) {
            return;
        }
        // Anything that takes the origin or the destination meanwhile (a plan sent to
        // this module itself) is a touch: the next move runs the timers again.
        self.wake.running();
        self.tick();
        let next = {
            let origin = self.origin.lock().next_due();
            let destination = self.destination.lock().next_repeat();
            origin.into_iter().chain(destination).min()
        };
        self.wake.ran(next.unwrap_or(Duration::MAX));
    }

    /// Timers: unanswered plans go again, circuits whose acks have a gap ask for them
    /// again, and last steps are repeated.
    fn tick(self: &Arc<Self>) {
        let now = self.now();
        let due = self.origin.lock().due(now);
        self.count_resent(due.len());
        for (to, msg) in due {
            self.transmit_logged(&to, msg);
        }
        self.repeat_last_steps(now);
    }

    fn count_resent(&self, n: usize) {
        self.counters.resent.fetch_add(n as u64, Ordering::Relaxed);
    }

    /// Takes what the engine produced (progress events, reports and plans to send),
    /// unless another thread is at it: that thread takes it before it lets go.
    fn drain(self: &Arc<Self>) -> bool {
        loop {
            let Some(guard) = self.draining.try_lock() else {
                return false;
            };
            while let Some(work) = self.next_work() {
                match work {
                    Work::Event(e) => self.on_event(e),
                    Work::Out(o) => self.on_outgoing(o),
                }
            }
            drop(guard);
            if self.events.is_empty() && self.outgoing.is_empty() {
                return true;
            }
        }
    }

    fn next_work(&self) -> Option<Work> {
        if let Ok(e) = self.events.try_recv() {
            return Some(Work::Event(e));
        }
        self.outgoing.try_recv().ok().map(Work::Out)
    }

    fn on_outgoing(self: &Arc<Self>, out: Outgoing) {
        match out {
            Outgoing::Plan(p) => match self.send_for(&p.to, &p.text, &self.runs_for(&p.origin)) {
                Ok(h) => {
                    tracing::debug!(plan = %p.origin, sub = %h.name, to = %h.to, circuit = h.circuit, "sub-plan sent");
                }
                Err(e) => {
                    tracing::warn!(plan = %p.origin, sub = %p.name, to = %p.to, error = %e, "sub-plan not sent")
                }
            },
            Outgoing::Report(r) => {
                let packets = r
                    .items
                    .into_iter()
                    .map(|i| (i.object, i.attr, i.packet))
                    .collect();
                let sent = self.ici.report(r.to.as_ref(), packets);
                tracing::trace!(plan = %r.origin, sent, "explicit report");
            }
        }
    }
}

impl Inner {
    /// The origin a plan of the engine runs for: the one it was received from, or this
    /// module for its own plans (and its rules).
    fn runs_for(&self, plan: &str) -> Address {
        let runs_for = self.runs_for.lock();
        runs_for
            .get(plan)
            .cloned()
            .unwrap_or_else(|| self.me.clone())
    }
}

enum Work {
    Event(PlanEvent),
    Out(Outgoing),
}

/// The ICI's plan handler.
struct Handler(Weak<Inner>);

impl PlanHandler for Handler {
    fn message(&self, from: &Address, msg: Message) {
        if let Some(inner) = self.0.upgrade() {
            inner.on_message(from, msg);
        }
    }

    fn peer(&self, peer: &Address, alive: bool) {
        if let Some(inner) = self.0.upgrade() {
            inner.on_peer(peer, alive);
        }
    }
}

/// Runs after the engine's own hook and clock listener (registered later): takes the
/// events and messages the engine produced in this thread.
struct Hook(Weak<Inner>);

impl ChangeHook for Hook {
    fn changed(&self, _: &Board, _: u64, _: &[Touched]) {
        if let Some(inner) = self.0.upgrade() {
            inner.drain();
        }
    }
}

impl ClockListener for Hook {
    /// Takes what the engine produced and runs the timers. The clock calls it only on a
    /// move at or past `Inner::wake`, which the engine touches with every event and
    /// send: every board of a simulated team hears every move of the shared clock.
    fn advanced(&self, now: Duration) {
        if let Some(inner) = self.0.upgrade() {
            inner.drain();
            inner.tick_if_due(now);
            if !(inner.events.is_empty() && inner.outgoing.is_empty()) {
                // Produced by another thread while the timers ran, their touch undone.
                inner.wake.touched();
            }
        }
    }
}

/// The stack of the circuits' thread, set rather than left to `RUST_MIN_STACK`: it parses,
/// checks and loads the plans received, whose nesting the language caps so that the
/// deepest needs under 1 MiB even unoptimized (docs/language.md, "Limits").
const PLAN_THREAD_STACK: usize = 2 * 1024 * 1024;

/// On the system clock, the engine's timer thread produces events with nobody of ours
/// in its call stack: this thread takes them (and runs the gap timers). It also handles
/// the plan messages received (`queued`), off the transport's receive thread.
fn spawn_pump(
    weak: Weak<Inner>,
    outgoing: Receiver<Outgoing>,
    events: Receiver<PlanEvent>,
    queued: Receiver<(Address, Message)>,
) {
    let pump = move || {
        loop {
            let mut select = Select::new();
            select.recv(&outgoing);
            select.recv(&events);
            select.recv(&queued);
            let ready = select.ready_timeout(Duration::from_millis(100)).is_ok();
            let Some(inner) = weak.upgrade() else { return };
            inner.handle_queued(&queued);
            if ready && !inner.drain() {
                std::thread::sleep(Duration::from_millis(1));
            }
            inner.tick();
        }
    };
    if let Err(e) = std::thread::Builder::new()
        .name("slate-plan-circuits".into())
        .stack_size(PLAN_THREAD_STACK)
        .spawn(pump)
    {
        tracing::error!(error = %e, "cannot start the plan circuits thread");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{IciConfig, SimNet};
    use slate_wire::Plan;

    #[test]
    fn a_plan_that_finds_the_queue_full_is_rejected_as_busy_unparsed() {
        let net = SimNet::new(3);
        let me = Address::new("t/r2/cell").unwrap_or_else(|e| panic!("{e}"));
        let board = Arc::new(Board::builder().address(me.clone()).build());
        let engine = Engine::new(&board);
        let ici =
            Ici::new(board, net.join(&me), IciConfig::default()).unwrap_or_else(|e| panic!("{e}"));
        let circuits = PlanCircuits::attach(&ici, &engine);
        let (full, _nobody_takes) = crossbeam_channel::bounded(0);
        let plan = Plan {
            circuit: 7,
            name: "p".into(),
            source_text: "not even parsed".into(),
            to: me.clone(),
            origin: me.clone(),
        };
        let from = Address::new("t/r9/nobody").unwrap_or_else(|e| panic!("{e}"));
        circuits.inner.enqueue(&full, &from, Message::Plan(plan));
        let received = circuits.received();
        let [circuit] = received.as_slice() else {
            panic!("{received:?}")
        };
        let [PlanStep::Received, PlanStep::Rejected { reason }] = circuit.steps.as_slice() else {
            panic!("{circuit:?}")
        };
        assert!(reason.contains("busy"), "{reason}");
        let stats = circuits.stats();
        assert_eq!(
            (stats.received, stats.rejected, stats.busy),
            (1, 1, 1),
            "{stats:?}"
        );
    }

    #[test]
    fn one_plan_names_the_plan_and_refuses_anything_else() {
        let ok = one_plan("p.slate", "plan go { action { } }");
        assert_eq!(ok.as_deref(), Ok("go"));
        let two = one_plan("p.slate", "plan a { action { } }\nplan b { action { } }").unwrap_err();
        assert!(two.contains("p.slate:2:1"), "{two}");
        let class = one_plan("p.slate", "class C { x: real; }").unwrap_err();
        assert!(
            class.contains("p.slate:1:1") && class.contains("one plan"),
            "{class}"
        );
        let empty = one_plan("p.slate", "").unwrap_err();
        assert!(empty.contains("found nothing"), "{empty}");
        let syntax = one_plan("p.slate", "plan go {\n  trigger: x >;\n action { } }").unwrap_err();
        assert!(syntax.contains("p.slate:2:"), "{syntax}");
    }
}
