//! What a node tells its operator: peers coming up and going down, plan progress, failed
//! active functions, classes other modules define differently. Each is logged through `tracing` and kept in a short event log (the
//! dashboard's `events`).

use std::collections::{HashMap, VecDeque};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender};
use parking_lot::Mutex;
use slate_ici::{ClassSet, Ici, MODULE_CLASS, PlanCircuits, RefusedPlan};
use slate_model::{
    Address, Board, BoardEvent, ChangeItem, ClockListener, Every, EveryPer, Filter, Query, Value,
    Wake, Watch,
};
use slate_plans::{Engine, PLAN_CLASS, PlanEvent, PlanState};

use crate::observer::OBSERVER_PREFIX;

/// Events kept (the dashboard shows at most 300).
const KEEP: usize = 300;

/// A peer that came up is greeted again this long after: the first messages to a module
/// that has just appeared can be lost while the network's routes to it settle (then its
/// interest stays unknown, and nothing is sent to it live).
const REGREET: Duration = Duration::from_secs(1);

/// News a flood repeats (undecodable messages, refused plans from one sender) is told of
/// at most this often: a flood is one event a second.
const NEWS_EVERY: Duration = Duration::from_secs(1);

/// Senders whose refused plans are told of apart, at most once a second each (past them,
/// the others share one limit).
const REFUSED_SENDERS: usize = 256;

/// How often the monitor looks at the board's events and the engine's.
const POLL: Duration = Duration::from_millis(50);

/// How much an event matters: the dashboard's level, so the log shows as it is.
pub use slate_dashboard::Level;

/// One entry of a node's event log.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeEvent {
    /// Seconds since the Unix epoch, on the board's clock.
    pub time: f64,
    /// How much it matters.
    pub level: Level,
    /// What happened, in a sentence.
    pub text: String,
}

/// The last [`KEEP`] events, and the channels of those who follow them as they come.
#[derive(Default)]
pub(crate) struct EventLog(Mutex<VecDeque<NodeEvent>>, Mutex<Vec<Sender<NodeEvent>>>);

/// Events a follower may have waiting before newer ones are dropped for it.
const FOLLOW_QUEUE: usize = 1024;

impl EventLog {
    pub fn push(&self, board: &Board, level: Level, text: String) {
        match level {
            Level::Info => tracing::info!("{text}"),
            Level::Warn => tracing::warn!("{text}"),
            Level::Error => tracing::error!("{text}"),
        }
        let time = board.clock().physical().as_secs_f64();
        let mut log = self.0.lock();
        if log.len() == KEEP {
            log.pop_front();
        }
        let event = NodeEvent { time, level, text };
        log.push_back(event.clone());
        drop(log);
        self.tell_followers(&event);
    }

    /// Every event from now on, as it is logged; a follower that lets [`FOLLOW_QUEUE`]
    /// wait misses the newer ones (nothing waits for it, nothing grows).
    pub fn follow(&self) -> Receiver<NodeEvent> {
        let (tx, rx) = crossbeam_channel::bounded(FOLLOW_QUEUE);
        self.1.lock().push(tx);
        rx
    }

    /// Hands `event` to each follower; forgets those that hung up.
    fn tell_followers(&self, event: &NodeEvent) {
        use crossbeam_channel::TrySendError;
        self.1.lock().retain(|tx| {
            !matches!(
                tx.try_send(event.clone()),
                Err(TrySendError::Disconnected(_))
            )
        });
    }

    pub fn events(&self) -> Vec<NodeEvent> {
        self.0.lock().iter().cloned().collect()
    }
}

/// What turns board changes and events into log entries: a thread polling every
/// [`POLL`] on the system clock; on a manual clock (the simulator) the clock's own moves,
/// so that a simulated run stays the same run (no wall-clock timing enters it).
pub(crate) struct Monitor {
    stop: Sender<()>,
    thread: Option<JoinHandle<()>>,
    /// On a manual clock: the listener the clock holds weakly (dropped, it stops).
    ticked: Option<Arc<Ticked>>,
}

impl Monitor {
    pub fn start(
        board: &Arc<Board>,
        engine: &Engine,
        ici: (&Ici, ClassSet, &PlanCircuits),
        log: Arc<EventLog>,
    ) -> Monitor {
        let (stop, stopped) = crossbeam_channel::bounded(1);
        let wake = Arc::new(Wake::default());
        let watch = |filter: Filter| board.watch_waking(filter, wake.clone()).ok();
        let sources = Sources {
            ici: ici.0.clone(),
            interest: ici.1,
            regreet: Mutex::new(None),
            modules: watch(Filter::class(MODULE_CLASS).attr("alive")),
            plans: watch(Filter::class(PLAN_CLASS).attr("state")),
            engine: engine.clone(),
            alive: Mutex::new(HashMap::new()),
            board_events: board.events_waking(wake.clone()),
            plan_events: engine.events_waking(wake.clone()),
            refused_plans: ici.2.refusals_waking(wake.clone()),
            refusals_told: Mutex::new(EveryPer::new(NEWS_EVERY, REFUSED_SENDERS)),
            undecodable: Mutex::new((0, Every::new(NEWS_EVERY))),
            board: Arc::downgrade(board),
            wake,
        };
        sources.peers_met_already(board, &log);
        if board.clock().is_manual() {
            let ticked = Arc::new(Ticked { sources, log });
            let listener: Arc<dyn ClockListener> = ticked.clone();
            let wake = ticked.sources.wake.clone();
            board
                .clock()
                .subscribe_waking(Arc::downgrade(&listener), wake);
            return Monitor {
                stop,
                thread: None,
                ticked: Some(ticked),
            };
        }
        let thread = std::thread::Builder::new()
            .name("slate-node-monitor".into())
            .spawn(move || sources.run(&stopped, &log))
            .ok();
        Monitor {
            stop,
            thread,
            ticked: None,
        }
    }

    /// Stops the thread (or the clock's calls), after it has logged what is waiting.
    pub fn stop(&mut self) {
        let _ = self.stop.try_send(());
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        if let Some(t) = self.ticked.take() {
            t.drain();
        }
    }
}

impl Drop for Monitor {
    fn drop(&mut self) {
        self.stop();
    }
}

/// The monitor of a node on a manual clock: it drains whenever the clock moves. It never
/// greets peers again ([`REGREET`] is for networks whose routes settle in wall-clock time;
/// the simulator delivers to a peer as soon as it is up).
struct Ticked {
    sources: Sources,
    log: Arc<EventLog>,
}

impl Ticked {
    fn drain(&self) {
        if let Some(board) = self.sources.board.upgrade() {
            self.sources.drain(&board, &self.log);
        }
    }
}

impl ClockListener for Ticked {
    /// Drains. The clock calls it only on a move at or past `Sources::wake`: when
    /// something came in, or the undecodable count is due to be looked at. Every board
    /// of a simulated team hears every move of the shared clock, and draining every
    /// board's monitor at each was a sixth of the simulator's time at 24 robots.
    fn advanced(&self, _now: Duration) {
        let wake = &self.sources.wake;
        wake.running();
        self.drain();
        wake.ran(self.sources.undecodable.lock().1.next());
    }
}

struct Sources {
    ici: Ici,
    /// The ICI's interest (said again in each hello).
    interest: ClassSet,
    /// When to greet every peer again (see [`REGREET`]).
    regreet: Mutex<Option<Instant>>,
    modules: Option<Watch>,
    /// Plan states, for cancellations written by other modules.
    plans: Option<Watch>,
    engine: Engine,
    /// The last `alive` of each Module object (the ICI rewrites it with `last_seen`).
    alive: Mutex<HashMap<String, Value>>,
    board_events: Receiver<BoardEvent>,
    plan_events: Receiver<PlanEvent>,
    /// Plans the circuits refused for want of authority.
    refused_plans: Receiver<RefusedPlan>,
    /// Refused plans are told of at most once a second per sender: each is acknowledged
    /// and counted, but a flood from one sender would push every other event out.
    refusals_told: Mutex<EveryPer<Address>>,
    /// Received messages that did not decode: how many the log has told of, and how
    /// often the count is looked at (board time).
    undecodable: Mutex<(u64, Every)>,
    board: std::sync::Weak<Board>,
    /// On a manual clock, when the next drain has something to do: touched by every
    /// source above after each change, event or refusal it is handed; else when the
    /// undecodable count is next looked at.
    wake: Arc<Wake>,
}

impl Sources {
    fn run(self, stopped: &Receiver<()>, log: &EventLog) {
        loop {
            let stop = stopped.recv_timeout(POLL).is_ok();
            let Some(board) = self.board.upgrade() else {
                return;
            };
            self.drain(&board, log);
            if stop {
                return;
            }
            let due = self.regreet.lock().is_some_and(|t| Instant::now() >= t);
            if due {
                *self.regreet.lock() = None;
                // Says hello (with the interest, unchanged) and asks for a catch-up again.
                self.ici.set_interest(self.interest.clone());
            }
        }
    }

    /// The peers the ICI met before this monitor watched their `Module` objects (it
    /// starts with the node, and hears its first peers at once): told of as the others.
    fn peers_met_already(&self, board: &Board, log: &EventLog) {
        let ids = board.query(&Query::class(MODULE_CLASS)).unwrap_or_default();
        for object in ids.into_iter().filter_map(|id| board.name_of(id)) {
            if let Ok(alive) = board.read(&object, "alive") {
                self.module_alive(board, log, &object, alive.value);
            }
        }
    }

    /// A `Module` object's `alive` written: `peer X up` or `down` when it changed.
    fn module_alive(&self, board: &Board, log: &EventLog, object: &str, alive: Value) {
        let changed =
            self.alive.lock().insert(object.to_owned(), alive.clone()) != Some(alive.clone());
        if !changed {
            return;
        }
        let peer = match board.read(object, "address").map(|p| p.value) {
            Ok(Value::Str(s)) => s.to_string(),
            _ => object.to_owned(),
        };
        let up = alive == Value::Bool(true);
        if up {
            self.regreet
                .lock()
                .get_or_insert_with(|| Instant::now() + REGREET);
        }
        let state = if up { "up" } else { "down" };
        if peer.contains(&format!("/{OBSERVER_PREFIX}")) {
            // Short-lived observers (`slate get`, `slate put`...) are not news.
            tracing::debug!("observer {peer} {state}");
        } else {
            let level = if up { Level::Info } else { Level::Warn };
            log.push(board, level, format!("peer {peer} {state}"));
        }
    }

    fn drain(&self, board: &Board, log: &EventLog) {
        while let Some(change) = self.modules.as_ref().and_then(Watch::try_recv) {
            for item in change.items {
                if let ChangeItem::Delete { object, .. } = &item {
                    // A forgotten module (dead for the ICI's `forget_dead`).
                    self.alive.lock().remove(&**object);
                }
                if let ChangeItem::Write {
                    object,
                    attr,
                    packet,
                } = item
                    && &*attr == "alive"
                {
                    self.module_alive(board, log, &object, packet.value);
                }
            }
        }
        self.cancellations(board, log);
        for e in self.board_events.try_iter() {
            log.push(board, Level::Warn, board_event(&e));
        }
        for e in self.plan_events.try_iter() {
            let (level, text) = plan_event(&e);
            log.push(board, level, text);
        }
        for r in self.refused_plans.try_iter() {
            let now = board.clock().physical();
            if let Some(held) = self.refusals_told.lock().due(r.from.clone(), now) {
                log.push(board, Level::Warn, refused_plan(&r, held));
            }
        }
        self.undecodable_news(board, log);
    }

    /// Received messages that did not decode since the last time told, as one event at
    /// most every [`NEWS_EVERY`] of board time, whatever their number. The count
    /// is looked at that often too, not on every tick of the clock: it is read from a
    /// copy of all the ICI's statistics.
    fn undecodable_news(&self, board: &Board, log: &EventLog) {
        let now = board.clock().physical();
        let mut undecodable = self.undecodable.lock();
        if !undecodable.1.due(now) {
            return;
        }
        let told = undecodable.0;
        let count = crate::stats::Drops::of(&self.ici.stats()).undecodable;
        undecodable.0 = count.max(told);
        drop(undecodable);
        if count > told {
            let text = format!(
                "{} received messages did not decode and were refused (slate stats: drops.undecodable, {count} in all)",
                count - told
            );
            log.push(board, Level::Warn, text);
        }
    }
}

impl Sources {
    /// Another module wrote `cancelled` to the state of a plan running here (`slate plan
    /// cancel`): the engine cancels it, which acks `Cancelled` to its origin.
    fn cancellations(&self, board: &Board, log: &EventLog) {
        while let Some(change) = self.plans.as_ref().and_then(Watch::try_recv) {
            for item in change.items {
                let ChangeItem::Write { object, packet, .. } = item else {
                    continue;
                };
                let remote = packet.source != *board.address();
                let cancel = matches!(&packet.value, Value::Str(s) if &**s == "cancelled");
                let Some(status) = self.engine.status(&object) else {
                    continue;
                };
                if !remote {
                    continue;
                }
                let over = matches!(status.state, PlanState::Terminated | PlanState::Cancelled);
                if cancel && !over {
                    let by = &packet.source;
                    log.push(
                        board,
                        Level::Warn,
                        format!("plan {object} cancelled by {by}"),
                    );
                    self.engine.cancel(&object);
                } else if let Err(e) = self.engine.restore_state(&object) {
                    // Only the engine says what state a plan is in: put it back.
                    tracing::debug!(plan = %object, error = %e, "plan state not restored");
                }
            }
        }
    }
}

/// A plan refused for want of authority, as a sentence (its reason says who may send),
/// with how many more from the same sender were not told one by one.
fn refused_plan(r: &RefusedPlan, held: u64) -> String {
    let text = format!("plan {} from {} refused: {}", r.name, r.from, r.reason);
    match held {
        0 => text,
        n => {
            format!("{text}; and {n} more like it since the last such event (at most one a second)")
        }
    }
}

/// A board event as a sentence (the event log's, and a recording's `text`); a refusal
/// that stands for others not told one by one says how many.
pub(crate) fn board_event(e: &BoardEvent) -> String {
    let text = board_event_alone(e);
    match suppressed(e) {
        0 => text,
        n => {
            format!("{text}; and {n} more like it since the last such event (at most one a second)")
        }
    }
}

/// How many refusals like `e` it stands for besides itself.
fn suppressed(e: &BoardEvent) -> u64 {
    match e {
        BoardEvent::FutureStamp { suppressed, .. }
        | BoardEvent::FunctionFailed { suppressed, .. }
        | BoardEvent::ObjectLimit { suppressed, .. }
        | BoardEvent::NotOwner { suppressed, .. }
        | BoardEvent::Unauthorised { suppressed, .. }
        | BoardEvent::NameLimit { suppressed, .. }
        | BoardEvent::ModuleLimit { suppressed, .. } => *suppressed,
        _ => 0,
    }
}

/// A board event as a sentence, on its own.
fn board_event_alone(e: &BoardEvent) -> String {
    match e {
        BoardEvent::FunctionFailed {
            function,
            object,
            attr,
            error,
            ..
        } => format!("active function {function} failed on {object}.{attr}: {error}"),
        BoardEvent::ChainCut(c) => format!("chain of active functions cut: {c}"),
        BoardEvent::ClassConflict { class, peer } => format!(
            "class {class} is defined differently by {peer}: objects of {class} are not merged with it"
        ),
        BoardEvent::FutureStamp {
            object,
            attr,
            source,
            ahead,
            ..
        } => format!(
            "packet for {object}.{attr} from {source} refused: stamped {:.1} s ahead of this board's clock, beyond its tolerance (its clock or this one's is wrong)",
            ahead.as_secs_f64()
        ),
        BoardEvent::ObjectLimit {
            owner,
            object,
            limit,
            total,
            ..
        } => {
            let whose = if *total {
                "other modules together"
            } else {
                "one module"
            };
            format!(
                "object {object} of {owner} refused: {whose} may own at most {limit} objects on this board (ici.max_objects_per_source, ici.max_objects)"
            )
        }
        BoardEvent::NotOwner {
            object,
            attr,
            writer,
            owner,
            ..
        } => format!(
            "packet for {object}.{attr} from {writer} refused: the attribute is owned, and only its owner {owner} may write it"
        ),
        BoardEvent::Unauthorised {
            object,
            attr: Some(attr),
            writer,
            rule,
            ..
        } => format!(
            "packet for {object}.{attr} from {writer} refused: {rule} on this board ([authority] writes)"
        ),
        BoardEvent::Unauthorised {
            object,
            attr: None,
            writer,
            rule,
            ..
        } => format!(
            "object {object} of {writer} refused: {rule} on this board ([authority] writes)"
        ),
        BoardEvent::NameLimit { source, limit, .. } => format!(
            "a message from {source} refused: it would make this node hold more than {limit} names of that module (ici.max_names_per_source)"
        ),
        BoardEvent::ModuleLimit { address, limit, .. } => format!(
            "module {address} refused: this node keeps track of at most {limit} modules (ici.max_modules)"
        ),
        other => format!("{other:?}"),
    }
}

fn plan_event(e: &PlanEvent) -> (Level, String) {
    match e {
        PlanEvent::Installed { plan } => (Level::Info, format!("plan {plan} installed")),
        PlanEvent::Initiated { plan } => (Level::Info, format!("plan {plan} initiated")),
        PlanEvent::Triggered {
            plan,
            fired,
            error: None,
        } => (Level::Info, format!("plan {plan} fired ({fired})")),
        PlanEvent::Triggered {
            plan,
            fired,
            error: Some(err),
        } => (
            Level::Warn,
            format!("plan {plan} fired ({fired}) and failed: {err}"),
        ),
        PlanEvent::Terminated { plan } => (Level::Info, format!("plan {plan} terminated")),
        PlanEvent::Cancelled { plan } => (Level::Warn, format!("plan {plan} cancelled")),
        PlanEvent::Failed { plan, error } => (
            Level::Warn,
            format!("plan {plan}: condition failed: {error}"),
        ),
    }
}
