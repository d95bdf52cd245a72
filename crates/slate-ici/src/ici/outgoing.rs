//! Publications that may wait: those of a lossless class ([`Flow::Every`]) are made
//! after the state lock is released, so that a writer held back by a slow receiver
//! holds only itself, not the module's receiving, timers and liveliness.
//!
//! While one waits (or is queued), every later publication and send of the module
//! queues behind it, so that a stream's messages keep their order, and a catch-up
//! answer does not overtake the reports its position covers. The thread that queued a
//! [`Flow::Every`] publication makes it (waiting its turn, then waiting for room: that
//! is the back-pressure on the writer); a thread that queued only best-effort ones
//! makes those at the front that are best effort and leaves the next lossless one to
//! its own writer, so a timer or a receive thread never waits for a slow receiver.

use std::collections::VecDeque;

use parking_lot::Mutex;

use slate_model::Address;

use crate::{Flow, LinkKind, MsgKind, Transport};

/// One publication (or, with `to`, send) to make.
struct Pending {
    to: Option<Address>,
    link: LinkKind,
    kind: MsgKind,
    bytes: Vec<u8>,
    flow: Flow,
}

#[derive(Default)]
struct Queue {
    pending: VecDeque<Pending>,
    /// A publication taken from the queue is being made.
    in_flight: bool,
}

/// The queue of publications made outside the state lock, shared by the state (which
/// queues) and the ICI's entry points (which make them once the lock is released).
#[derive(Default)]
pub(crate) struct Outgoing {
    queue: Mutex<Queue>,
    /// Held by the thread making queued publications, one at a time.
    sending: Mutex<()>,
}

impl Outgoing {
    /// Must a publication of `flow` be queued: is it lossless, or is one being made or
    /// waiting (a publication made now would overtake it)?
    pub fn must_queue(&self, flow: Flow) -> bool {
        if flow == Flow::Every {
            return true;
        }
        let q = self.queue.lock();
        q.in_flight || !q.pending.is_empty()
    }

    /// Queues a publication (the caller holds the state lock, so the queue's order is
    /// the order the state decided them in).
    pub fn push(&self, link: LinkKind, kind: MsgKind, bytes: &[u8], flow: Flow) {
        self.queue.lock().pending.push_back(Pending {
            to: None,
            link,
            kind,
            bytes: bytes.to_vec(),
            flow,
        });
    }

    /// Queues a send to `to` (it never waits: the transport queues sends per peer).
    pub fn push_send(&self, to: &Address, kind: MsgKind, bytes: &[u8]) {
        self.queue.lock().pending.push_back(Pending {
            to: Some(to.clone()),
            link: LinkKind::Robot,
            kind,
            bytes: bytes.to_vec(),
            flow: Flow::Latest,
        });
    }

    /// Makes the queued publications, in order (the state lock released). `wait`: this
    /// thread queued a lossless one, and waits for its turn and for room to make it;
    /// otherwise it makes only best-effort ones, and only if no other thread is making
    /// publications.
    pub fn flush(&self, transport: &dyn Transport, mut wait: bool) {
        loop {
            let guard = if wait {
                self.sending.lock()
            } else {
                let Some(guard) = self.sending.try_lock() else {
                    return;
                };
                guard
            };
            while let Some(p) = self.next(wait) {
                let made = match &p.to {
                    Some(to) => transport.send(to, p.kind, &p.bytes),
                    None => transport.publish_with(p.link, p.kind, &p.bytes, p.flow),
                };
                if let Err(e) = made {
                    tracing::debug!(kind = %p.kind, error = %e, "queued message refused");
                }
                self.queue.lock().in_flight = false;
            }
            drop(guard);
            wait = false;
            // A best-effort publication queued while this thread let go is made now
            // (its own thread found the lock taken and left it); a lossless one's own
            // thread is waiting for the lock and makes it.
            let q = self.queue.lock();
            if !q.pending.front().is_some_and(|p| p.flow != Flow::Every) {
                return;
            }
        }
    }

    /// The next publication to make, marked in flight: any if `wait`, else only a
    /// best-effort one.
    fn next(&self, wait: bool) -> Option<Pending> {
        let mut q = self.queue.lock();
        if !wait && q.pending.front()?.flow == Flow::Every {
            return None;
        }
        let p = q.pending.pop_front()?;
        q.in_flight = true;
        Some(p)
    }
}
