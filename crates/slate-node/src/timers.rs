//! The timer thread of a node on the system clock: runs the ICI's timers (heartbeats,
//! trailing edges of report filters, liveliness timeouts, catch-up retries) every
//! [`TICK`]. Plan deadlines have their own thread (`Engine::run_timers`). On a manual
//! clock (the simulator) neither is needed: both run whenever the clock moves.

use std::thread::JoinHandle;
use std::time::Duration;

use crossbeam_channel::Sender;
use slate_ici::Ici;

/// How often the ICI's timers run.
pub const TICK: Duration = Duration::from_millis(20);

pub(crate) struct Timers {
    stop: Sender<()>,
    thread: Option<JoinHandle<()>>,
}

impl Timers {
    pub fn start(ici: Ici) -> Timers {
        let (stop, stopped) = crossbeam_channel::bounded::<()>(1);
        let thread = std::thread::Builder::new()
            .name("slate-node-timers".into())
            .spawn(move || {
                while let Err(crossbeam_channel::RecvTimeoutError::Timeout) =
                    stopped.recv_timeout(TICK)
                {
                    ici.tick();
                }
            })
            .ok();
        Timers { stop, thread }
    }

    /// Stops the thread and waits for it.
    pub fn stop(&mut self) {
        let _ = self.stop.try_send(());
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Timers {
    fn drop(&mut self) {
        self.stop();
    }
}
