//! The linger thread: sends the reports of own writes that wait for the end of their
//! linger (`IciConfig::linger`) when no later write has sent them first. Only on the
//! system clock: on a manual clock reports do not linger.

use std::sync::{Arc, Weak};
use std::time::{Duration, Instant};

use parking_lot::{Condvar, Mutex};

use super::Shared;
use super::state::State;

/// How long the thread sleeps with nothing to do before it looks whether its ICI is
/// gone.
const IDLE: Duration = Duration::from_secs(1);

/// When the reports waiting must go, shared with the thread.
#[derive(Default)]
pub(super) struct Linger {
    due: Mutex<Option<Instant>>,
    ready: Condvar,
}

impl Linger {
    /// Starts the thread for `shared`; it ends soon after the ICI is dropped.
    pub fn start(shared: Weak<Shared>) -> std::io::Result<Arc<Linger>> {
        let linger = Arc::new(Linger::default());
        let mine = linger.clone();
        std::thread::Builder::new()
            .name("slate-linger".into())
            .spawn(move || mine.run(&shared))?;
        Ok(linger)
    }

    /// The reports waiting now must go `after` from now.
    pub fn ask(&self, after: Duration) {
        // A linger too long for the clock (a config's mistake) sends them now.
        let now = Instant::now();
        let at = now.checked_add(after).unwrap_or(now);
        let mut due = self.due.lock();
        if due.is_none_or(|d| at < d) {
            *due = Some(at);
            self.ready.notify_one();
        }
    }

    fn run(&self, shared: &Weak<Shared>) {
        loop {
            let mut due = self.due.lock();
            match *due {
                None => {
                    self.ready.wait_for(&mut due, IDLE);
                }
                Some(at) if Instant::now() < at => {
                    self.ready.wait_until(&mut due, at);
                }
                Some(_) => {
                    *due = None;
                    drop(due);
                    let Some(shared) = shared.upgrade() else {
                        return;
                    };
                    shared.with_state(State::flush_lingering);
                    continue;
                }
            }
            drop(due);
            if shared.strong_count() == 0 {
                return;
            }
        }
    }
}
