//! The plan engine: runs plans on a board, data-driven. A write re-evaluates only the plans
//! whose conditions read what changed (a dependency index); a condition that depends on
//! time is re-evaluated when its truth can change (deadlines on the board's clock).
//!
//! Semantics (docs/language.md, "What a plan does"): initiation is latched; the trigger fires
//! the action when it becomes true (its edge is counted from activation, so a trigger
//! already true when the plan initiates fires at once) or, with `every`, repeatedly while it
//! holds; termination is latched and checked first, so a termination true before or
//! together with initiation means the action never runs.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap, HashMap};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Weak};
use std::time::Duration;

use crossbeam_channel::Receiver;
use parking_lot::{Condvar, Mutex};
use slate_model::{
    Board, ChangeHook, ClockListener, Context, Key, NewObject, ObjectId, ReadSet, Touched, Value,
};
use smallvec::SmallVec;

use crate::action::{Act, Effect, effects};
use crate::env::SnapEnv;
use crate::eval::{CompiledExpr, Ctx, truthy};
use crate::index::DepIndex;
use crate::load::{LinkName, LinkPolicy};
use crate::outbox::{Outbox, Outgoing, PlanEvent, PlanMessage, ReportItem, ReportRequest};

/// Class of the objects that show plans on the board (built in on every board).
pub use slate_model::PLAN_CLASS;

/// Most plan evaluations one change may cause (a guard against plans that trigger each
/// other for ever); past it the rest is dropped and reported.
pub const MAX_EVALUATIONS_PER_CHANGE: usize = 100_000;

/// How often a condition that reads time in a way no deadline describes (`age(x) * 2 > 5`
/// rather than `age(x) > 2.5s`) is re-evaluated while its plan is active.
pub const TIME_FALLBACK: Duration = Duration::from_millis(100);

/// What a condition reads: the engine re-evaluates a plan when one of these changes.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Dep {
    /// `gsr.speed`: one object's attribute.
    Object(Arc<str>, Arc<str>),
    /// `o.range` for a quantifier over `Obstacle`: that attribute on any instance.
    Class(Arc<str>, Arc<str>),
    /// An attribute read through a reference: on any object.
    Attr(Arc<str>),
    /// Instances of the class appearing or disappearing.
    Members(Arc<str>),
}

/// A plan, checked and compiled.
#[derive(Clone, Debug)]
pub(crate) struct CompiledPlan {
    pub name: Arc<str>,
    pub initiation: Option<CompiledExpr>,
    pub trigger: Option<CompiledExpr>,
    pub termination: Option<CompiledExpr>,
    pub every: Option<f64>,
    pub actions: Vec<Act>,
    pub slots: usize,
    pub changed_sites: usize,
    pub deps: Vec<Dep>,
    pub text: String,
}

/// Where a plan is in its life.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlanState {
    /// Installed; initiation not yet true.
    Pending,
    /// Initiated; the trigger is watched.
    Active,
    /// Termination became true; it will never act again.
    Terminated,
    /// Cancelled.
    Cancelled,
}

impl PlanState {
    /// The lower-case name stored on the plan object.
    pub fn name(self) -> &'static str {
        match self {
            PlanState::Pending => "pending",
            PlanState::Active => "active",
            PlanState::Terminated => "terminated",
            PlanState::Cancelled => "cancelled",
        }
    }

    fn is_over(self) -> bool {
        matches!(self, PlanState::Terminated | PlanState::Cancelled)
    }
}

/// A plan's progress, as its plan object shows it.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanStatus {
    /// Name.
    pub name: String,
    /// State.
    pub state: PlanState,
    /// Times the action ran.
    pub fired: u64,
    /// Error of the last action or evaluation, if it failed.
    pub last_error: Option<String>,
}

/// Where a plan was when its node stopped, to take it up there after a restart
/// ([`Engine::resume`]): the latches and the trigger's edge, which the plan object alone
/// does not say.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlanProgress {
    /// Its state: a plan that had initiated resumes active (initiation is latched).
    pub state: PlanState,
    /// Times its action had run.
    pub fired: u64,
    /// Did the trigger hold at its last evaluation? A plan resumed with it fires on the
    /// trigger's next rising edge, not again for the state it already fired for.
    pub trigger_held: bool,
}

struct PlanRt {
    plan: Arc<CompiledPlan>,
    state: PlanState,
    last_trigger: bool,
    /// Resumed after a restart, having acted: its first evaluation takes the `changed`
    /// references from the values it reads, as after an action (they are not kept).
    prime: bool,
    fired: u64,
    last_error: Option<String>,
    baseline: Vec<Option<Value>>,
    next_every: Option<f64>,
    timer_gen: u64,
    /// The plan object's `fired` attribute.
    fired_key: Option<Key>,
    /// What its last evaluation read, if that evaluation did nothing and read no time:
    /// while none of it changes, evaluating again would do nothing again.
    quiet: Option<ReadSet>,
}

#[derive(Default)]
struct State {
    plans: Vec<PlanRt>,
    by_name: HashMap<Arc<str>, usize>,
    index: DepIndex,
    timers: BinaryHeap<Reverse<(u64, usize, u64)>>,
}

enum Work {
    Touched(SmallVec<[Touched; 4]>),
    Due,
    Plan(usize),
}

pub(crate) struct Shared {
    board: Weak<Board>,
    state: Mutex<State>,
    queue: Mutex<Vec<Work>>,
    pub outbox: Outbox,
    /// Wakes the system clock's timer thread when a timer sooner than the one it waits
    /// for is set ([`timer_loop`]).
    wake: (Mutex<()>, Condvar),
    /// The earliest plan timer (microseconds of the board's clock; `u64::MAX`: none),
    /// set after each run of the engine: a manual clock's move before it has nothing
    /// for the engine to do, and the system clock's timer thread sleeps until it.
    next_timer: AtomicU64,
    /// On a manual clock: `next_timer` while nothing is queued, the clock's move before
    /// which the engine is not called.
    due: Arc<slate_model::Wake>,
    /// Plans declared in loaded files, for `send NAME` (its own lock: rules read it while
    /// the engine runs).
    texts: Mutex<HashMap<String, String>>,
    /// Derived attributes of loaded files and what they read.
    pub(crate) derived: Mutex<crate::load::DerivedDeps>,
    evaluations: AtomicU64,
    /// Times the system clock's timer thread found a deadline passed and ran the plans.
    timer_wakes: AtomicU64,
    /// Plans installed (the hook does nothing while there are none).
    installed: AtomicUsize,
    /// The `link` blocks of every file loaded, merged per link.
    links: Mutex<BTreeMap<LinkName, LinkPolicy>>,
    /// The modules received plans run as (`crate::authority`).
    origins: crate::authority::Origins,
    /// Where plans not yet installed take up from ([`Engine::resume`]).
    resumes: Mutex<HashMap<String, PlanProgress>>,
}

/// Runs plans on one board. Cloning gives another handle to the same engine.
///
/// ```
/// use std::sync::Arc;
/// use slate_model::{Board, Clock};
/// use slate_plans::Engine;
/// let board = Arc::new(Board::builder().clock(Clock::manual()).build());
/// let engine = Engine::new(&board);
/// engine.load("demo.slate", r#"
///     class Vehicle { speed: real = 0.0; mode: string = "auto"; }
///     object gsr : Vehicle;
///     plan slow_down {
///         trigger: gsr.speed > 10.0;
///         action { set gsr.mode = "slow"; }
///     }
/// "#)?;
/// board.write("gsr", "speed", 12.0)?;
/// assert_eq!(board.read("gsr", "mode")?.value.to_string(), "\"slow\"");
/// assert_eq!(engine.status("slow_down").unwrap().fired, 1);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone)]
pub struct Engine {
    pub(crate) shared: Arc<Shared>,
}

impl Engine {
    /// An engine for `board` (which has the built-in `Plan` class from the start): starts
    /// listening to the board's changes and, for a manual clock, to the clock.
    pub fn new(board: &Arc<Board>) -> Engine {
        let shared = Arc::new(Shared {
            board: Arc::downgrade(board),
            state: Mutex::new(State::default()),
            queue: Mutex::new(Vec::new()),
            outbox: Outbox::default(),
            wake: (Mutex::new(()), Condvar::new()),
            next_timer: AtomicU64::new(u64::MAX),
            due: Arc::default(),
            texts: Mutex::new(HashMap::new()),
            derived: Mutex::new(HashMap::new()),
            evaluations: AtomicU64::new(0),
            timer_wakes: AtomicU64::new(0),
            installed: AtomicUsize::new(0),
            links: Mutex::new(BTreeMap::new()),
            origins: crate::authority::Origins::default(),
            resumes: Mutex::new(HashMap::new()),
        });
        // Nothing queued, no timer: no move has anything for the engine until a push
        // touches `due` or a timer lowers it. Left at zero, an engine with no plan (most
        // modules': nothing drains, so nothing sets it) was called at every move.
        shared.due.set(Duration::MAX);
        board.add_hook(Arc::new(Hook(Arc::downgrade(&shared))));
        let listener: Arc<dyn ClockListener> = shared.clone();
        let due = shared.due.clone();
        board
            .clock()
            .subscribe_waking(Arc::downgrade(&listener), due);
        Engine { shared }
    }

    /// The link policies of every file loaded so far (`link team { ... }`), merged per
    /// link: what the module's ICI is to apply (`Ici::set_link_policy`).
    pub fn link_policies(&self) -> BTreeMap<LinkName, LinkPolicy> {
        self.shared.links.lock().clone()
    }

    /// Merges the link policies of a file just loaded into those of the files before it.
    pub(crate) fn merge_links(&self, links: BTreeMap<LinkName, LinkPolicy>) {
        let mut all = self.shared.links.lock();
        for (name, policy) in links {
            all.entry(name).or_default().merge(policy);
        }
    }

    /// The board, if it still exists.
    pub fn board(&self) -> Option<Arc<Board>> {
        self.shared.board.upgrade()
    }

    /// Reports and plans the engine's actions produce, for the ICI.
    pub fn outgoing(&self) -> Receiver<Outgoing> {
        self.shared.outbox.subscribe_outgoing(None)
    }

    /// [`Engine::outgoing`], touching `wake` after each send: a manual clock's listener
    /// that takes them can sleep until there is something ([`slate_model::Clock::subscribe_waking`]).
    pub fn outgoing_waking(&self, wake: Arc<slate_model::Wake>) -> Receiver<Outgoing> {
        self.shared.outbox.subscribe_outgoing(Some(wake))
    }

    /// Progress events of every plan.
    pub fn events(&self) -> Receiver<PlanEvent> {
        self.shared.outbox.subscribe_events(None)
    }

    /// [`Engine::events`], touching `wake` after each event.
    pub fn events_waking(&self, wake: Arc<slate_model::Wake>) -> Receiver<PlanEvent> {
        self.shared.outbox.subscribe_events(Some(wake))
    }

    /// The status of a plan.
    pub fn status(&self, name: &str) -> Option<PlanStatus> {
        let st = self.shared.state.lock();
        let rt = &st.plans[*st.by_name.get(name)?];
        Some(PlanStatus {
            name: name.to_owned(),
            state: rt.state,
            fired: rt.fired,
            last_error: rt.last_error.clone(),
        })
    }

    /// Every plan's status, in installation order.
    pub fn plans(&self) -> Vec<PlanStatus> {
        let st = self.shared.state.lock();
        st.plans
            .iter()
            .map(|rt| PlanStatus {
                name: rt.plan.name.to_string(),
                state: rt.state,
                fired: rt.fired,
                last_error: rt.last_error.clone(),
            })
            .collect()
    }

    /// How many plan evaluations the engine has run (data-driven evaluation keeps this
    /// small: a write evaluates only the plans that read what it changed).
    pub fn evaluations(&self) -> u64 {
        self.shared.evaluations.load(Ordering::Relaxed)
    }

    /// How many times the timer thread ([`Engine::run_timers`]) found a deadline passed
    /// and ran the plans due.
    pub fn timer_wakes(&self) -> u64 {
        self.shared.timer_wakes.load(Ordering::Relaxed)
    }

    /// Cancels a plan; it never acts again. Returns false if there is no such plan.
    pub fn cancel(&self, name: &str) -> bool {
        let Some(board) = self.board() else {
            return false;
        };
        {
            let mut st = self.shared.state.lock();
            let Some(&idx) = st.by_name.get(name) else {
                return false;
            };
            if st.plans[idx].state.is_over() {
                return true;
            }
            st.plans[idx].state = PlanState::Cancelled;
        }
        let _ = write_plan(&board, name, "state", PlanState::Cancelled.name());
        self.shared.outbox.event(PlanEvent::Cancelled {
            plan: name.to_owned(),
        });
        true
    }

    /// The plan named `plan`, once loaded, runs with the authority of `origin` (a plan
    /// received from another module): its actions may write only what the board would
    /// take from `origin` ([`Board::write_refusal`](slate_model::Board::write_refusal):
    /// not an `owned` attribute of an object `origin` does not own, nor what the board's
    /// write rules do not let `origin` write). Set before the plan is loaded; `None`
    /// clears it.
    pub fn run_as(&self, plan: &str, origin: Option<&slate_model::Address>) {
        match origin {
            Some(origin) => self.shared.origins.set(plan, origin.clone()),
            None => self.shared.origins.clear(plan),
        }
    }

    /// Where the plan named `plan` is: what [`Engine::resume`] takes after a restart.
    pub fn progress(&self, plan: &str) -> Option<PlanProgress> {
        let st = self.shared.state.lock();
        let rt = &st.plans[*st.by_name.get(plan)?];
        Some(PlanProgress {
            state: rt.state,
            fired: rt.fired,
            trigger_held: rt.last_trigger,
        })
    }

    /// The plan named `plan`, once loaded, takes up where `progress` says (kept before a
    /// restart) instead of starting afresh: latched initiation and termination, its
    /// `fired` count, and the trigger's edge. Set before the plan is loaded.
    pub fn resume(&self, plan: &str, progress: PlanProgress) {
        self.shared.resumes.lock().insert(plan.to_owned(), progress);
    }

    /// Records who sent a plan in its object's `origin` (a guarded field: the ICI that
    /// received the plan tells the engine, which writes it).
    pub fn set_origin(&self, plan: &str, origin: &str) -> Result<(), slate_model::BatchError> {
        let board = self.board().ok_or_else(|| unknown_plan(plan))?;
        write_plan(&board, plan, "origin", origin)
    }

    /// Writes a plan's state back on its object from the engine's own (after a copy of it
    /// was written by another module: only the engine says what state a plan is in).
    pub fn restore_state(&self, plan: &str) -> Result<(), slate_model::BatchError> {
        let state = self.status(plan).ok_or_else(|| unknown_plan(plan))?.state;
        let board = self.board().ok_or_else(|| unknown_plan(plan))?;
        write_plan(&board, plan, "state", state.name())
    }

    /// Runs the plans whose deadlines have passed (a manual clock does this by itself when
    /// it moves; see [`Engine::run_timers`] for the system clock).
    pub fn tick(&self) {
        if let Some(board) = self.board() {
            self.shared.push(Work::Due, &board);
        }
    }

    /// Runs a thread that wakes for every plan deadline on the system clock. It stops
    /// when the engine is dropped.
    pub fn run_timers(&self) -> std::thread::JoinHandle<()> {
        let weak = Arc::downgrade(&self.shared);
        std::thread::Builder::new()
            .name("slate-plan-timers".into())
            .spawn(move || timer_loop(&weak))
            .unwrap_or_else(|_| std::thread::spawn(|| ()))
    }

    /// Why `name` cannot name a new plan: an object or class of the board, or a plan of
    /// this engine, has it already. `None` when it is free.
    pub(crate) fn name_taken(&self, board: &Board, name: &str) -> Option<String> {
        let exists = self.shared.state.lock().by_name.contains_key(name);
        (exists || board.info(name).is_some()).then(|| {
            format!("{name} already exists on this board; plan names must be unique object names")
        })
    }

    pub(crate) fn install(&self, plan: CompiledPlan, board: &Board) -> Result<(), String> {
        let name = plan.name.clone();
        if let Some(taken) = self.name_taken(board, &name) {
            return Err(taken);
        }
        let resume = self.shared.resumes.lock().remove(&*name);
        let from = resume.unwrap_or(PlanProgress {
            state: PlanState::Pending,
            fired: 0,
            trigger_held: false,
        });
        let mut batch = board.batch();
        batch
            .create_with(NewObject::new(PLAN_CLASS, &name).context(Context::Self_))
            .write_guarded(&name, "state", from.state.name())
            .write_guarded(&name, "text", plan.text.as_str());
        if from.fired > 0 {
            batch.write_guarded(&name, "fired", from.fired as i64);
        }
        batch.commit().map_err(|e| e.to_string())?;
        let idx = {
            let mut st = self.shared.state.lock();
            let idx = st.plans.len();
            for dep in &plan.deps {
                st.index.add(idx, dep, board);
            }
            st.by_name.insert(name.clone(), idx);
            self.shared.installed.fetch_add(1, Ordering::Relaxed);
            let sites = plan.changed_sites;
            let prime = from.fired > 0 && sites > 0;
            let next_every = plan.every.filter(|_| from.trigger_held);
            let now = board.clock().physical().as_secs_f64();
            st.plans.push(PlanRt {
                plan: Arc::new(plan),
                state: from.state,
                last_trigger: from.trigger_held,
                prime,
                fired: from.fired,
                last_error: None,
                baseline: vec![None; sites],
                // A resumed trigger that held repeats one period after the restart.
                next_every: next_every.map(|period| now + period),
                timer_gen: 0,
                fired_key: board.key(&name, "fired").ok(),
                quiet: None,
            });
            idx
        };
        self.shared.outbox.event(PlanEvent::Installed {
            plan: name.to_string(),
        });
        self.shared.push(Work::Plan(idx), board);
        Ok(())
    }

    pub(crate) fn remember_text(&self, name: &str, text: &str) {
        self.shared
            .texts
            .lock()
            .insert(name.to_owned(), text.to_owned());
    }
}

/// Writes one of a plan object's fields: they are guarded, the engine's alone.
fn write_plan(
    board: &Board,
    plan: &str,
    attr: &str,
    value: &str,
) -> Result<(), slate_model::BatchError> {
    let mut batch = board.batch();
    batch.write_guarded(plan, attr, value);
    batch.commit().map(|_| ())
}

/// The error of a plan the engine does not hold (or whose board is gone).
fn unknown_plan(plan: &str) -> slate_model::BatchError {
    slate_model::BatchError::Write {
        index: 0,
        source: slate_model::WriteError::UnknownObject(plan.to_owned()),
    }
}

struct Hook(Weak<Shared>);

impl ChangeHook for Hook {
    fn changed(&self, board: &Board, _revision: u64, touched: &[Touched]) {
        let Some(shared) = self.0.upgrade() else {
            return;
        };
        if shared.installed.load(Ordering::Relaxed) == 0 {
            return;
        }
        // The common case, nobody else running the engine: no queueing, no copy.
        if let Some(mut st) = shared.state.try_lock() {
            let mut plans = SmallVec::new();
            for t in touched {
                st.touched(t, board, &mut |p| add_once(&mut plans, p));
            }
            shared.evaluate_all(&mut st, plans, board, MAX_EVALUATIONS_PER_CHANGE);
            drop(st);
            shared.push_nothing(board);
        } else {
            shared.push(Work::Touched(SmallVec::from_slice(touched)), board);
        }
    }
}

fn add_once(plans: &mut SmallVec<[usize; 8]>, p: usize) {
    if !plans.contains(&p) {
        plans.push(p);
    }
}

impl ClockListener for Shared {
    /// Runs the plans whose timers are due, and what was left queued. Every board of a
    /// simulated team hears every move of the shared clock (one per event): a move
    /// before the earliest timer, with nothing queued, is skipped.
    fn advanced(&self, now: Duration) {
        let idle = micros(now) < self.next_timer.load(Ordering::SeqCst);
        if idle && self.queue.lock().is_empty() {
            return;
        }
        if let Some(board) = self.board.upgrade() {
            self.push(Work::Due, &board);
        }
    }
}

fn timer_loop(weak: &Weak<Shared>) {
    loop {
        let Some(shared) = weak.upgrade() else { return };
        let Some(board) = shared.board.upgrade() else {
            return;
        };
        let now = micros(board.clock().physical());
        // Read under the lock a sooner timer notifies under, so none is missed.
        let mut guard = shared.wake.0.lock();
        let next = shared.next_timer.load(Ordering::SeqCst);
        if next <= now {
            drop(guard);
            shared.timer_wakes.fetch_add(1, Ordering::Relaxed);
            shared.push(Work::Due, &board);
            if shared.next_timer.load(Ordering::SeqCst) <= now {
                // Another thread runs the engine and will run the plans due: wait for
                // it rather than queue more.
                std::thread::sleep(Duration::from_millis(1));
            }
            continue;
        }
        let wait = Duration::from_micros(next - now).min(Duration::from_millis(200));
        shared.wake.1.wait_for(&mut guard, wait);
    }
}

fn micros(d: Duration) -> u64 {
    u64::try_from(d.as_micros()).unwrap_or(u64::MAX)
}

impl Shared {
    pub(crate) fn board(&self) -> Option<Arc<Board>> {
        self.board.upgrade()
    }

    pub(crate) fn plan_text(&self, name: &str) -> Option<String> {
        self.texts.lock().get(name).cloned()
    }

    /// Queues work and runs it, unless another thread (or an outer call on this one) is
    /// already running the engine: then that one runs it before it lets go.
    fn push(&self, work: Work, board: &Board) {
        self.queue.lock().push(work);
        self.due.touched();
        self.push_nothing(board);
    }

    /// Runs whatever is queued, unless someone else is running the engine.
    fn push_nothing(&self, board: &Board) {
        loop {
            if self.queue.lock().is_empty() {
                return;
            }
            let Some(mut st) = self.state.try_lock() else {
                return;
            };
            self.drain(&mut st, board);
        }
    }

    fn drain(&self, st: &mut State, board: &Board) {
        let mut budget = MAX_EVALUATIONS_PER_CHANGE;
        loop {
            let work = std::mem::take(&mut *self.queue.lock());
            if work.is_empty() {
                break;
            }
            let mut plans = SmallVec::new();
            for w in work {
                st.affected(w, board, &mut |p| add_once(&mut plans, p));
            }
            budget = self.evaluate_all(st, plans, board, budget);
            if budget == 0 {
                break;
            }
        }
        let next = st
            .timers
            .peek()
            .map_or(u64::MAX, |Reverse((due, _, _))| *due);
        self.next_timer.store(next, Ordering::SeqCst);
        self.due.set(Duration::from_micros(next));
        // Work queued since the loop looked (by a thread that found the engine taken)
        // waits for the next move, as it did before `due` was set.
        if !self.queue.lock().is_empty() {
            self.due.touched();
        }
    }

    /// Evaluates plans within a budget of evaluations; returns what is left of it.
    fn evaluate_all(
        &self,
        st: &mut State,
        plans: SmallVec<[usize; 8]>,
        board: &Board,
        mut budget: usize,
    ) -> usize {
        for p in plans {
            if budget == 0 {
                tracing::error!(
                    "plan evaluations exceeded {MAX_EVALUATIONS_PER_CHANGE} for one change; dropping the rest"
                );
                self.queue.lock().clear();
                return 0;
            }
            budget -= 1;
            self.evaluate(st, p, board);
        }
        budget
    }

    fn evaluate(&self, st: &mut State, idx: usize, board: &Board) {
        let rt = &mut st.plans[idx];
        if rt
            .quiet
            .as_ref()
            .is_some_and(|reads| board.unchanged_since(reads))
        {
            return;
        }
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let primed = rt.prime;
        let outcome = {
            let snap = board.snapshot();
            let trace = snap.trace();
            let env = SnapEnv::new(&snap, board.clock());
            let outcome = step(rt, &env);
            let reads = trace.stop();
            // A condition that read the clock has a timer (`wake_at`) unless its moment
            // has passed (`age(x) > 2s` stays true): not reading it at all is simpler to
            // trust.
            rt.quiet = reads.filter(|_| !(primed || env.timed.get()) && outcome.did_nothing());
            outcome
        };
        self.schedule(st, idx, &outcome);
        let name = st.plans[idx].plan.name.clone();
        for e in &outcome.events {
            self.outbox.event(e.clone());
        }
        if let Some(state) = outcome.new_state {
            let _ = write_plan(board, &name, "state", state.name());
        }
        if let Some(error) = &outcome.eval_error {
            st.plans[idx].last_error = Some(error.clone());
            let _ = write_plan(board, &name, "last_error", error.as_str());
        }
        if let Some(effects) = outcome.effects {
            self.act(st, idx, effects, board);
        }
    }

    fn schedule(&self, st: &mut State, idx: usize, outcome: &Outcome) {
        let Some(at) = outcome.wake_at else { return };
        let rt = &mut st.plans[idx];
        rt.timer_gen += 1;
        let due = micros(Duration::try_from_secs_f64(at.max(0.0)).unwrap_or(Duration::MAX));
        st.timers.push(Reverse((due, idx, rt.timer_gen)));
        // The change hook evaluates without `drain`: the clock must call the engine by then.
        self.due.lower(Duration::from_micros(due));
        if due < self.next_timer.fetch_min(due, Ordering::SeqCst) {
            let _guard = self.wake.0.lock();
            self.wake.1.notify_all();
        }
    }

    fn act(&self, st: &mut State, idx: usize, effects: Result<Vec<Effect>, String>, board: &Board) {
        // `fired` counts the actions that committed: it is written in the action's own
        // batch, and a failed action leaves it as it was.
        let rt = &mut st.plans[idx];
        let name = rt.plan.name.clone();
        let progress = Progress {
            name: &name,
            fired: rt.fired + 1,
            fired_key: rt.fired_key,
            clear_error: rt.last_error.is_some(),
        };
        let result = effects.and_then(|effects| apply(board, &progress, effects, self));
        let rt = &mut st.plans[idx];
        rt.last_error = result.as_ref().err().cloned();
        match &result {
            Ok(()) => rt.fired = progress.fired,
            Err(e) => {
                let _ = write_plan(board, &name, "last_error", e.as_str());
            }
        }
        let fired = rt.fired;
        if self.outbox.has_event_subscribers() {
            let error = result.err();
            self.outbox.event(PlanEvent::Triggered {
                plan: name.to_string(),
                fired,
                error,
            });
        }
    }
}

/// What one evaluation of a plan decided.
#[derive(Default)]
struct Outcome {
    new_state: Option<PlanState>,
    events: Vec<PlanEvent>,
    effects: Option<Result<Vec<Effect>, String>>,
    wake_at: Option<f64>,
    eval_error: Option<String>,
}

impl Outcome {
    /// Did the evaluation change nothing and set no timer? Then, with no time read, an
    /// evaluation on the same values does the same: its trigger holds as it held (so it
    /// does not fire; with `every` and the trigger holding there would be a timer).
    fn did_nothing(&self) -> bool {
        self.new_state.is_none()
            && self.events.is_empty()
            && self.effects.is_none()
            && self.wake_at.is_none()
            && self.eval_error.is_none()
    }
}

/// Evaluates a plan's conditions once, by the plan semantics (docs/language.md).
fn step(rt: &mut PlanRt, env: &SnapEnv<'_>) -> Outcome {
    let mut out = Outcome::default();
    if rt.state.is_over() {
        return out;
    }
    if rt.prime && rt.state == PlanState::Active {
        prime(rt, env);
    }
    let plan = rt.plan.clone();
    let name = &plan.name;
    let baseline = rt.baseline.clone();
    let mut cx = Ctx::new(env, plan.slots, &baseline);
    let check =
        |node: &Option<CompiledExpr>, absent: bool, cx: &mut Ctx<'_>, out: &mut Outcome| match node
        {
            None => absent,
            Some(n) => n.eval(cx).map(|v| truthy(&v)).unwrap_or_else(|e| {
                out.eval_error = Some(e.to_string());
                false
            }),
        };
    if check(&plan.termination, false, &mut cx, &mut out) {
        rt.state = PlanState::Terminated;
        out.new_state = Some(PlanState::Terminated);
        out.events.push(PlanEvent::Terminated {
            plan: name.to_string(),
        });
        return out;
    }
    if rt.state == PlanState::Pending {
        if !check(&plan.initiation, true, &mut cx, &mut out) {
            out.wake_at = wake(&cx, None);
            return out;
        }
        rt.state = PlanState::Active;
        rt.last_trigger = false;
        out.new_state = Some(PlanState::Active);
        out.events.push(PlanEvent::Initiated {
            plan: name.to_string(),
        });
    }
    let trig = check(&plan.trigger, true, &mut cx, &mut out);
    let now = env.clock.physical().as_secs_f64();
    let due = rt.next_every.is_some_and(|t| now >= t - 1e-9);
    let fire = trig && (!rt.last_trigger || (plan.every.is_some() && due));
    rt.last_trigger = trig;
    if fire {
        out.effects = Some(effects(&plan.actions, &mut cx).map_err(|e| e.to_string()));
        rt.baseline = cx.seen.clone();
        rt.next_every = plan.every.map(|p| now + p);
        if plan.changed_sites > 0 {
            // Acting moves the `changed` baselines to the values just seen, against
            // which nothing has changed: the edge is taken from the trigger as it reads
            // now, so the next move by more than the deadband fires again even when no
            // evaluation saw the trigger false in between.
            let mut again = Ctx::new(env, plan.slots, &rt.baseline);
            rt.last_trigger = check(&plan.trigger, true, &mut again, &mut out);
        }
    }
    let every_due = if trig { rt.next_every } else { None };
    out.wake_at = wake(&cx, every_due);
    out
}

/// Takes a resumed plan's `changed` references from the values its trigger reads now.
fn prime(rt: &mut PlanRt, env: &SnapEnv<'_>) {
    rt.prime = false;
    let plan = rt.plan.clone();
    let unset = vec![None; plan.changed_sites];
    let mut cx = Ctx::new(env, plan.slots, &unset);
    if let Some(trigger) = &plan.trigger {
        drop(trigger.eval(&mut cx));
    }
    rt.baseline = cx.seen;
}

/// The next moment the plan must be looked at again without any write.
fn wake(cx: &Ctx<'_>, every: Option<f64>) -> Option<f64> {
    let fallback = cx
        .unanchored_time
        .then(|| cx.env.now().as_secs_f64() + TIME_FALLBACK.as_secs_f64());
    [cx.deadline, every, fallback]
        .into_iter()
        .flatten()
        .reduce(f64::min)
}

impl State {
    /// Calls `f` with every plan that `work` may concern.
    fn affected(&mut self, work: Work, board: &Board, f: &mut dyn FnMut(usize)) {
        match work {
            Work::Plan(p) => f(p),
            Work::Due => self.due(board, f),
            Work::Touched(touched) => {
                for t in touched {
                    self.touched(&t, board, f);
                }
            }
        }
    }

    fn due(&mut self, board: &Board, f: &mut dyn FnMut(usize)) {
        let now = micros(board.clock().physical());
        while let Some(Reverse((due, idx, generation))) = self.timers.peek().copied() {
            if due > now {
                break;
            }
            self.timers.pop();
            if self
                .plans
                .get(idx)
                .is_some_and(|rt| rt.timer_gen == generation)
            {
                f(idx);
            }
        }
    }

    fn touched(&mut self, t: &Touched, board: &Board, f: &mut dyn FnMut(usize)) {
        self.index.touched(t, board, f);
    }
}

/// Applies a plan's effects: writes, creations and deletions as one batch together with
/// the plan object's progress, then the reports and plans it sends.
/// A firing's update of its plan object.
struct Progress<'a> {
    name: &'a str,
    fired: u64,
    fired_key: Option<Key>,
    clear_error: bool,
}

fn apply(
    board: &Board,
    progress: &Progress<'_>,
    effects: Vec<Effect>,
    engine: &Shared,
) -> Result<(), String> {
    let outbox = &engine.outbox;
    let plan = progress.name;
    if let Some(origin) = engine.origins.of(plan)
        && let Some(refusal) = crate::authority::refusal(board, plan, &origin, &effects)
    {
        return Err(refusal);
    }
    let mut batch = board.batch();
    let mut messages = Vec::new();
    for e in effects {
        match e {
            Effect::Write(_, _, u, Some(key)) => drop(batch.write_key(key, u)),
            Effect::Write(o, a, u, None) => drop(batch.write_shared(o, a, u)),
            Effect::Create(spec) => drop(batch.create_with(spec)),
            Effect::Delete(o) => drop(batch.delete(&o)),
            other => messages.push(other),
        }
    }
    let fired = progress.fired as i64;
    match progress.fired_key {
        Some(key) => drop(batch.write_key_guarded(key, fired)),
        None => drop(batch.write_guarded(plan, "fired", fired)),
    }
    if progress.clear_error {
        batch.write_guarded(plan, "last_error", "");
    }
    batch.commit().map_err(|e| e.to_string())?;
    for e in messages {
        match e {
            Effect::Report { targets, to } => {
                let items = report_items(board, &targets);
                outbox.send(Outgoing::Report(ReportRequest {
                    origin: plan.to_owned(),
                    to,
                    items,
                }));
            }
            Effect::Send { name, text, to } => {
                let Some(text) = text.or_else(|| engine.plan_text(&name)) else {
                    return Err(format!("send {name}: no plan of that name was loaded"));
                };
                outbox.send(Outgoing::Plan(PlanMessage {
                    origin: plan.to_owned(),
                    name,
                    text,
                    to,
                }));
            }
            _ => {}
        }
    }
    Ok(())
}

/// The packets a report carries: one attribute, or everything an object holds itself.
pub(crate) fn report_items(
    board: &Board,
    targets: &[(Arc<str>, Option<Arc<str>>)],
) -> Vec<ReportItem> {
    let mut items = Vec::new();
    for (object, attr) in targets {
        match attr {
            Some(a) => {
                if let Ok(packet) = board.read(object, a) {
                    items.push(ReportItem {
                        object: object.clone(),
                        attr: a.clone(),
                        packet,
                    });
                }
            }
            None => {
                let snap = board.snapshot();
                let Some(id) = board_id(&snap, object) else {
                    continue;
                };
                for (attr, packet, _) in snap.own_values(id) {
                    items.push(ReportItem {
                        object: object.clone(),
                        attr,
                        packet,
                    });
                }
            }
        }
    }
    items
}

fn board_id(snap: &slate_model::Snapshot<'_>, name: &str) -> Option<ObjectId> {
    snap.id_of(name)
}
