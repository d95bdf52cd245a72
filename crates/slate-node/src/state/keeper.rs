//! The `slate-state` thread: takes what waits in the board's gathering watch into a pending set and
//! commits it to the store when it is due.

use std::collections::HashSet;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use parking_lot::Mutex;
use slate_ici::{HeldPlan, PlanCircuits};
use slate_model::{Board, ClassDef, Filter, Gather, RevisedItem};

use super::pending::Pending;
use super::store::Store;
use super::{StateConfig, StateError, StateStats};

/// How long the thread waits for a change before it looks at the clock.
const POLL: Duration = Duration::from_millis(10);

/// The keeper: its thread, and the counters it keeps.
pub(crate) struct Keeper {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<Result<(), StateError>>>,
    stats: Arc<Mutex<StateStats>>,
}

impl Keeper {
    /// Subscribes to the board (in the caller's thread, so no change is missed), saves it
    /// whole as the first commit, and starts the thread that keeps the store up to date.
    /// With `circuits`, it also keeps the plans received that the node runs.
    pub fn start(
        board: Arc<Board>,
        store: Store,
        config: &StateConfig,
        circuits: Option<PlanCircuits>,
    ) -> Result<Keeper, StateError> {
        let watch = board.watch_gathered(Filter::all(), config.queue)?;
        let stats = Arc::new(Mutex::new(StateStats::default()));
        let mut work = Work::new(board, store, watch, config, stats.clone());
        work.circuits = circuits;
        work.resync();
        work.commit()?;
        let stop = Arc::new(AtomicBool::new(false));
        let stopped = stop.clone();
        let thread = std::thread::Builder::new()
            .name("slate-state".into())
            .spawn(move || work.run(&stopped))
            .map_err(StateError::Thread)?;
        Ok(Keeper {
            stop,
            thread: Some(thread),
            stats,
        })
    }

    /// The counters, as the keeper updates them (for the dashboard's view).
    pub fn shared_stats(&self) -> Arc<Mutex<StateStats>> {
        self.stats.clone()
    }

    /// Commits what is waiting and stops.
    pub fn stop(&mut self) -> Result<StateStats, StateError> {
        self.stop.store(true, Ordering::Release);
        if let Some(thread) = self.thread.take() {
            match thread.join() {
                Ok(result) => result?,
                Err(_) => tracing::error!("the state keeper thread panicked"),
            }
        }
        Ok(self.stats.lock().clone())
    }
}

impl Drop for Keeper {
    fn drop(&mut self) {
        if let Err(e) = self.stop() {
            tracing::warn!("{e}");
        }
    }
}

/// What the thread holds.
struct Work {
    board: Arc<Board>,
    store: Store,
    watch: Gather,
    /// The items taken from the watch (its block goes back to the writers each time).
    taken: Vec<RevisedItem>,
    commit_every: Duration,
    commit_changes: usize,
    pending: Pending,
    /// Objects left out of the store (`Module`, `Plan`): their packets are too.
    skipped: HashSet<Arc<str>>,
    /// The class definitions the store holds.
    classes: Vec<ClassDef>,
    /// Where the plans received are found (none: they are not kept).
    circuits: Option<PlanCircuits>,
    /// The plans received the store holds (`None`: not written yet in this run).
    held: Option<Vec<HeldPlan>>,
    /// Changes up to this revision are in the pending full save.
    snapshot_revision: u64,
    /// Changes the watch had dropped at the last full save.
    dropped: u64,
    committed: Instant,
    stats: Arc<Mutex<StateStats>>,
}

impl Work {
    fn new(
        board: Arc<Board>,
        store: Store,
        watch: Gather,
        config: &StateConfig,
        stats: Arc<Mutex<StateStats>>,
    ) -> Self {
        Work {
            board,
            store,
            watch,
            taken: Vec::new(),
            commit_every: config.commit_every,
            commit_changes: config.commit_changes.max(1),
            pending: Pending::default(),
            skipped: HashSet::new(),
            classes: Vec::new(),
            circuits: None,
            held: None,
            snapshot_revision: 0,
            dropped: 0,
            committed: Instant::now(),
            stats,
        }
    }

    /// Keeps the store up to date until `stop`, then commits what is waiting. An error
    /// ends the keeping (the node goes on): it is logged and kept in the stats.
    fn run(mut self, stop: &AtomicBool) -> Result<(), StateError> {
        let result = self.keep(stop);
        if let Err(e) = &result {
            tracing::error!("the board is no longer kept: {e}");
            self.stats.lock().failed = Some(e.to_string());
        }
        result
    }

    fn keep(&mut self, stop: &AtomicBool) -> Result<(), StateError> {
        loop {
            let stopping = stop.load(Ordering::Acquire);
            self.drain(stopping);
            if self.watch.dropped() > self.dropped {
                self.resync();
                self.stats.lock().resyncs += 1;
            }
            if stopping || self.due() {
                self.commit()?;
            }
            if stopping {
                return Ok(());
            }
        }
    }

    /// Folds in what waits in the watch, waiting [`POLL`] for it (not when stopping).
    /// The watch holds at most the configured queue's items, so the clock and the stop
    /// flag are looked at between two takes.
    fn drain(&mut self, stopping: bool) {
        if !stopping && !self.watch.wait(POLL) {
            return;
        }
        self.watch.take(&mut self.taken);
        for (revision, item) in self.taken.drain(..) {
            if revision > self.snapshot_revision {
                self.pending
                    .fold(&self.board, revision, item, &mut self.skipped);
            }
        }
    }

    fn due(&self) -> bool {
        self.pending.changes >= self.commit_changes || self.committed.elapsed() >= self.commit_every
    }

    /// Replaces what is pending by the whole board (the watch dropped changes, or the
    /// store is new to this run).
    fn resync(&mut self) {
        self.dropped = self.watch.dropped();
        self.skipped.clear();
        let (pending, revision) = Pending::full(&self.board, &mut self.skipped);
        self.pending = pending;
        self.snapshot_revision = revision;
    }

    /// The plans received that the node runs, if they differ from those stored.
    fn plans_changed(&self) -> Option<Vec<HeldPlan>> {
        let now = self.circuits.as_ref()?.held();
        (self.held.as_ref() != Some(&now)).then_some(now)
    }

    /// Commits what is pending, with the classes and the plans received if they changed.
    fn commit(&mut self) -> Result<(), StateError> {
        self.committed = Instant::now();
        let defs = self.board.class_defs();
        if defs != self.classes {
            self.pending.classes = Some(defs.clone());
        }
        self.pending.plans = self.plans_changed();
        if self.pending.is_empty() {
            return Ok(());
        }
        let pending = std::mem::take(&mut self.pending);
        self.store.commit(&pending)?;
        self.classes = defs;
        if pending.plans.is_some() {
            self.held = pending.plans.clone();
        }
        let mut stats = self.stats.lock();
        stats.revision = stats.revision.max(pending.revision);
        stats.commits += 1;
        stats.packets += pending.packets.len() as u64;
        Ok(())
    }
}
