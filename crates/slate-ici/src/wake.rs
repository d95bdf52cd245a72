//! When a module's timers next have something to do, on a manual clock.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// The manual clock's time (nanoseconds) before which a module's timers have nothing to
/// do, as their last run left them; 0 once anything else touched what they read, so the
/// next move runs them. Every module of a simulated team hears every move of the shared
/// clock (one per event), and running every module's timers at each was the simulator's
/// largest cost (docs/team-protocol.md, 7.1): a move before this skips them. Kept by
/// the ICI and by the plan circuits, each for its own timers.
#[derive(Debug, Default)]
pub(crate) struct Wake(AtomicU64);

impl Wake {
    /// Something other than the timers changed what they read: they run at the next move.
    pub fn touched(&self) {
        self.0.store(0, Ordering::SeqCst);
    }

    /// Does a move of the clock to `now` come before anything is due?
    pub fn asleep_at(&self, now: Duration) -> bool {
        nanos(now) < self.0.load(Ordering::SeqCst)
    }

    /// Nothing is due before `at`. For a caller that holds the lock every touch is made
    /// under (the ICI's state lock).
    pub fn set(&self, at: Duration) {
        self.0.store(nanos(at), Ordering::SeqCst);
    }

    /// The timers start a run: a touch from now on outlasts it ([`Wake::ran`]).
    pub fn running(&self) {
        self.0.store(u64::MAX, Ordering::SeqCst);
    }

    /// The timers ran and nothing is due before `at`, unless something touched what they
    /// read since [`Wake::running`] (then they run at the next move).
    pub fn ran(&self, at: Duration) {
        let _ = self
            .0
            .compare_exchange(u64::MAX, nanos(at), Ordering::SeqCst, Ordering::SeqCst);
    }
}

fn nanos(t: Duration) -> u64 {
    u64::try_from(t.as_nanos()).unwrap_or(u64::MAX)
}
