//! Reliable sends to one peer: a bounded queue and a thread that hands them to Zenoh.
//!
//! Zenoh blocks a reliable put while the link to its peer is congested (up to its
//! `wait_before_close`, 5 s, then it closes the link). Putting from the caller's thread
//! would stall the ICI, and with it every other peer's messages and liveliness, behind
//! one peer that does not read. Each peer's sends go through its own queue instead; a
//! peer whose queue overflows is reported down (it cannot keep up: what is sent to it
//! meanwhile is refused) and up again once its queue has drained, which makes the ICI
//! greet it and catch it up.

use std::sync::{Arc, Weak, mpsc};
use std::time::{Duration, Instant};

use parking_lot::Mutex;
use slate_model::Address;
use zenoh::Wait;
use zenoh::pubsub::Publisher;

use crate::transport::Inner;

/// Most bytes queued for one peer: a full catch-up answer of a large board fits.
pub(crate) const MAX_QUEUED_BYTES: usize = 16 << 20;

/// Most messages queued for one peer.
pub(crate) const MAX_QUEUED: usize = 4096;

/// Longest wait for the route to a peer's inbox before the first send to it.
const ROUTE_WAIT: Duration = Duration::from_secs(3);

/// How often a wait here (for the route, for an empty queue) looks again.
const POLL: Duration = Duration::from_millis(5);

/// What is queued for one peer, and whether it was found unable to keep up.
#[derive(Debug, Default)]
struct Queue {
    bytes: usize,
    len: usize,
    /// The queue overflowed and has not drained since: the peer is reported down.
    congested: bool,
    /// The outbox was dropped (the peer left, the transport closed): send nothing more.
    gone: bool,
}

/// One peer's queue of reliable sends, and the thread that empties it.
pub(crate) struct Outbox {
    tx: mpsc::Sender<Vec<u8>>,
    queue: Arc<Mutex<Queue>>,
}

/// Why a payload was not queued.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Refused {
    /// This payload overflowed the queue: the peer has just been found unable to keep up.
    Overflowed,
    /// The peer is still catching up with an earlier overflow.
    Congested,
}

impl Outbox {
    /// An outbox to `peer` through `publisher`; its thread holds only a weak reference
    /// to the transport, to report the peer down and up again.
    pub fn open(
        peer: Address,
        publisher: Arc<Publisher<'static>>,
        inner: Weak<Inner>,
    ) -> std::io::Result<Outbox> {
        let (tx, rx) = mpsc::channel::<Vec<u8>>();
        let queue = Arc::new(Mutex::new(Queue::default()));
        let worker = Worker {
            peer,
            publisher,
            inner,
            queue: queue.clone(),
        };
        std::thread::Builder::new()
            .name("slate-zenoh-send".into())
            .spawn(move || worker.run(rx))?;
        Ok(Outbox { tx, queue })
    }

    /// Queues `payload`, unless the peer cannot keep up; `overflowed` runs (under the
    /// queue's lock, so that the peer's down and up events keep their order) when this
    /// payload is the one that overflows the queue.
    pub fn offer(&self, payload: Vec<u8>, overflowed: impl FnOnce()) -> Result<(), Refused> {
        let mut q = self.queue.lock();
        if q.congested {
            return Err(Refused::Congested);
        }
        if q.len >= MAX_QUEUED || q.bytes + payload.len() > MAX_QUEUED_BYTES {
            q.congested = true;
            overflowed();
            return Err(Refused::Overflowed);
        }
        q.len += 1;
        q.bytes += payload.len();
        if self.tx.send(payload).is_err() {
            q.len -= 1;
        }
        Ok(())
    }

    /// Waits until the thread has handed Zenoh everything queued, or `deadline`.
    pub fn wait_empty(&self, deadline: Instant) {
        while self.queue.lock().len > 0 && Instant::now() < deadline {
            std::thread::sleep(POLL);
        }
    }

    /// Is the peer reported down for not keeping up?
    pub fn congested(&self) -> bool {
        self.queue.lock().congested
    }
}

impl Drop for Outbox {
    fn drop(&mut self) {
        self.queue.lock().gone = true;
    }
}

/// The thread's side of an outbox.
struct Worker {
    peer: Address,
    publisher: Arc<Publisher<'static>>,
    inner: Weak<Inner>,
    queue: Arc<Mutex<Queue>>,
}

impl Worker {
    /// Puts each queued payload in turn (blocking while Zenoh's link is congested), until
    /// the outbox is dropped. The first waits for the peer's inbox to be routed.
    fn run(self, rx: mpsc::Receiver<Vec<u8>>) {
        let Ok(first) = rx.recv() else { return };
        self.await_route();
        for payload in std::iter::once(first).chain(rx) {
            if self.queue.lock().gone {
                return;
            }
            let len = payload.len();
            if let Err(e) = self.publisher.put(payload).wait() {
                tracing::debug!(to = %self.peer, error = %e, "send failed");
            }
            self.taken(len);
        }
    }

    /// Waits, at most [`ROUTE_WAIT`], until Zenoh routes the publisher to a subscriber:
    /// the peer's inbox. Zenoh drops a put that matches no subscriber, and a peer's
    /// inbox is declared to this session some time after the peer is seen: its liveliness
    /// token can arrive first, and so can its publications, on a link just opened or
    /// opened again (a direct send made then, a plan or a greeting, was lost for good).
    /// Without a route by then, the put goes anyway (and later ones do not wait).
    fn await_route(&self) {
        let deadline = Instant::now() + ROUTE_WAIT;
        loop {
            let matched = self.publisher.matching_status().wait();
            if matched.map_or(true, |m| m.matching()) {
                return;
            }
            if Instant::now() >= deadline || self.queue.lock().gone {
                tracing::debug!(to = %self.peer, "no route to the peer's inbox: sent anyway");
                return;
            }
            std::thread::sleep(POLL);
        }
    }

    /// One payload left the queue; a congested peer whose queue is now empty is up again.
    fn taken(&self, len: usize) {
        let mut q = self.queue.lock();
        q.len = q.len.saturating_sub(1);
        q.bytes = q.bytes.saturating_sub(len);
        if q.congested && q.len == 0 && !q.gone {
            q.congested = false;
            if let Some(inner) = self.inner.upgrade() {
                inner.congestion(&self.peer, false);
            }
        }
    }
}
