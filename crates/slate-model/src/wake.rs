//! When a manual clock's listener next has something to do.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use crossbeam_channel::{SendError, Sender, TrySendError};

/// The manual clock's time (nanoseconds since the Unix epoch) before which a listener
/// has nothing to do, as its last run left it; 0 once anything else touched what it
/// reads, so the next move runs it. Given to [`Clock::subscribe_waking`], the clock
/// itself skips the listener on a move before it, without calling it: every board of a
/// simulated team hears every move of the shared clock (one per event), and calling
/// every listener of every board at each was the simulator's largest cost, growing with
/// the cube of the team (docs/team-protocol.md, 7.1). The time may be earlier than the
/// listener's real next work (a move that finds nothing to do costs a call), never
/// later.
///
/// [`Clock::subscribe_waking`]: crate::Clock::subscribe_waking
#[derive(Debug, Default)]
pub struct Wake(AtomicU64);

impl Wake {
    /// Something other than the listener changed what it reads: it runs at the next
    /// move.
    pub fn touched(&self) {
        self.0.store(0, Ordering::SeqCst);
    }

    /// Does a move of the clock to `now` come before anything is due?
    pub fn asleep_at(&self, now: Duration) -> bool {
        nanos(now) < self.0.load(Ordering::SeqCst)
    }

    /// Nothing is due before `at`. For a caller that holds the lock every touch is made
    /// under, or that looks again for work touched meanwhile after setting it.
    pub fn set(&self, at: Duration) {
        self.0.store(nanos(at), Ordering::SeqCst);
    }

    /// Something is due at `at`, if that is sooner than the time held.
    pub fn lower(&self, at: Duration) {
        self.0.fetch_min(nanos(at), Ordering::SeqCst);
    }

    /// The listener starts a run: a touch from now on outlasts it ([`Wake::ran`]).
    pub fn running(&self) {
        self.0.store(u64::MAX, Ordering::SeqCst);
    }

    /// The listener ran and nothing is due before `at`, unless something touched what
    /// it reads since [`Wake::running`] (then it runs at the next move).
    pub fn ran(&self, at: Duration) {
        let _ = self
            .0
            .compare_exchange(u64::MAX, nanos(at), Ordering::SeqCst, Ordering::SeqCst);
    }
}

/// A channel's sender, and the wake of its reader if it gave one, touched after each
/// send: a reader run by a manual clock's moves sleeps until there is something.
#[derive(Debug)]
pub struct WakingSender<T> {
    tx: Sender<T>,
    wake: Option<Arc<Wake>>,
}

impl<T> WakingSender<T> {
    /// `tx`, touching `wake` (if any) after each send.
    pub fn new(tx: Sender<T>, wake: Option<Arc<Wake>>) -> Self {
        WakingSender { tx, wake }
    }

    /// Sends, waiting for room in a bounded channel.
    pub fn send(&self, msg: T) -> Result<(), SendError<T>> {
        let sent = self.tx.send(msg);
        self.touch();
        sent
    }

    /// Sends if there is room.
    pub fn try_send(&self, msg: T) -> Result<(), TrySendError<T>> {
        let sent = self.tx.try_send(msg);
        self.touch();
        sent
    }

    fn touch(&self) {
        if let Some(wake) = &self.wake {
            wake.touched();
        }
    }
}

fn nanos(t: Duration) -> u64 {
    u64::try_from(t.as_nanos()).unwrap_or(u64::MAX)
}
