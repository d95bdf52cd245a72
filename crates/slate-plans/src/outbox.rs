//! What plans and rules send out (reports and plans for other modules) and the progress
//! events of plans. The ICI carries both; tests read them here.

use std::collections::VecDeque;
use std::sync::Arc;

use crossbeam_channel::Receiver;
use parking_lot::Mutex;
use slate_model::{Address, Packet, Wake, WakingSender};

/// One reported assertion.
#[derive(Clone, Debug, PartialEq)]
pub struct ReportItem {
    /// Object (or class) name.
    pub object: Arc<str>,
    /// Attribute name.
    pub attr: Arc<str>,
    /// The packet as the board reads it when the report is made.
    pub packet: Packet,
}

/// What a `report` action asks the ICI to send: the assertions to put in a report (the
/// paper's `Report`, which the ICI builds from this, is `slate_wire::Report`).
#[derive(Clone, Debug, PartialEq)]
pub struct ReportRequest {
    /// The plan or rule that made it.
    pub origin: String,
    /// Destination; `None` means every interested board.
    pub to: Option<Address>,
    /// The assertions.
    pub items: Vec<ReportItem>,
}

/// A plan to send to another module, produced by a `send` action.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanMessage {
    /// The plan that sent it.
    pub origin: String,
    /// The plan's name.
    pub name: String,
    /// Its slate source text (`plan NAME { ... }`).
    pub text: String,
    /// Destination module.
    pub to: Address,
}

/// Something for the ICI to send.
#[derive(Clone, Debug, PartialEq)]
pub enum Outgoing {
    /// A report to make.
    Report(ReportRequest),
    /// A plan.
    Plan(PlanMessage),
}

/// A step of a plan's progress (docs/language.md); the ICI turns them into acknowledgements
/// for the module that sent the plan.
#[derive(Clone, Debug, PartialEq)]
pub enum PlanEvent {
    /// The plan was installed.
    Installed {
        /// Plan name.
        plan: String,
    },
    /// Its initiation condition became true.
    Initiated {
        /// Plan name.
        plan: String,
    },
    /// Its action ran; `error` says why it failed, if it did.
    Triggered {
        /// Plan name.
        plan: String,
        /// How many of its actions have committed, this one included if it did (a
        /// failed action does not count).
        fired: u64,
        /// `None` on success.
        error: Option<String>,
    },
    /// Its termination condition became true: it will never act again.
    Terminated {
        /// Plan name.
        plan: String,
    },
    /// It was cancelled.
    Cancelled {
        /// Plan name.
        plan: String,
    },
    /// Evaluating a condition failed (the condition counted as false).
    Failed {
        /// Plan name.
        plan: String,
        /// What went wrong.
        error: String,
    },
}

/// Sends kept, at most, while nothing subscribes to them (`Outbox::send`).
pub(crate) const MAX_UNCLAIMED: usize = 256;

/// Fan-out of outgoing messages and events to their subscribers.
#[derive(Default)]
pub(crate) struct Outbox {
    outgoing: Mutex<Subscribers>,
    events: Mutex<Vec<WakingSender<PlanEvent>>>,
}

/// Who takes the sends, and the sends made before anyone did.
#[derive(Default)]
struct Subscribers {
    senders: Vec<WakingSender<Outgoing>>,
    unclaimed: VecDeque<Outgoing>,
    /// Unclaimed sends dropped to keep [`MAX_UNCLAIMED`].
    dropped: u64,
}

impl Outbox {
    /// A new subscriber of the sends; the first takes those made before it came.
    /// `wake`, if given, is touched after each send.
    pub fn subscribe_outgoing(&self, wake: Option<Arc<Wake>>) -> Receiver<Outgoing> {
        let (tx, rx) = crossbeam_channel::unbounded();
        let sub = WakingSender::new(tx, wake);
        let mut subs = self.outgoing.lock();
        for msg in subs.unclaimed.drain(..) {
            let _ = sub.send(msg);
        }
        subs.senders.push(sub);
        rx
    }

    /// A new subscriber of the events; `wake`, if given, is touched after each.
    pub fn subscribe_events(&self, wake: Option<Arc<Wake>>) -> Receiver<PlanEvent> {
        let (tx, rx) = crossbeam_channel::unbounded();
        self.events.lock().push(WakingSender::new(tx, wake));
        rx
    }

    /// Hands `msg` to every subscriber. With none, it waits for the first: plans whose
    /// trigger holds as their node starts act before the ICI subscribes (they are loaded
    /// first, and the first catch-up can make them true), and a `send` made then was
    /// lost for good. At most [`MAX_UNCLAIMED`] wait (an engine no ICI ever carries
    /// keeps its newest sends); the oldest go first, counted and logged.
    pub fn send(&self, msg: Outgoing) {
        let mut subs = self.outgoing.lock();
        subs.senders.retain(|sub| sub.send(msg.clone()).is_ok());
        if !subs.senders.is_empty() {
            return;
        }
        if subs.unclaimed.len() >= MAX_UNCLAIMED {
            subs.unclaimed.pop_front();
            subs.dropped += 1;
            if subs.dropped == 1 {
                tracing::warn!(
                    kept = MAX_UNCLAIMED,
                    "plan sends with nothing to carry them (no ICI attached): the oldest are dropped"
                );
            }
        }
        subs.unclaimed.push_back(msg);
    }

    /// Sends dropped while nothing subscribed (beyond [`MAX_UNCLAIMED`]).
    #[cfg(test)]
    pub fn unclaimed_dropped(&self) -> u64 {
        self.outgoing.lock().dropped
    }

    /// Is anyone listening to events? (Lets the hot path skip building them.)
    pub fn has_event_subscribers(&self) -> bool {
        !self.events.lock().is_empty()
    }

    pub fn event(&self, e: PlanEvent) {
        tracing::debug!(?e, "plan event");
        self.events.lock().retain(|sub| sub.send(e.clone()).is_ok());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(n: usize) -> Outgoing {
        Outgoing::Plan(PlanMessage {
            origin: "push".into(),
            name: format!("p{n}"),
            text: format!("plan p{n} {{ }}"),
            to: Address::new("t/r1/loco").unwrap(),
        })
    }

    #[test]
    fn sends_made_before_anyone_subscribed_go_to_the_first_subscriber_in_order() {
        let outbox = Outbox::default();
        outbox.send(plan(1));
        outbox.send(plan(2));
        let first = outbox.subscribe_outgoing(None);
        let second = outbox.subscribe_outgoing(None);
        outbox.send(plan(3));
        assert_eq!(
            first.try_iter().collect::<Vec<_>>(),
            [plan(1), plan(2), plan(3)]
        );
        assert_eq!(second.try_iter().collect::<Vec<_>>(), [plan(3)]);
    }

    #[test]
    fn unclaimed_sends_are_bounded_keeping_the_newest() {
        let outbox = Outbox::default();
        for n in 0..MAX_UNCLAIMED + 10 {
            outbox.send(plan(n));
        }
        assert_eq!(outbox.unclaimed_dropped(), 10);
        let got: Vec<_> = outbox.subscribe_outgoing(None).try_iter().collect();
        assert_eq!(got.len(), MAX_UNCLAIMED);
        assert_eq!(got[0], plan(10));
    }

    #[test]
    fn sends_wait_again_once_every_subscriber_is_gone() {
        let outbox = Outbox::default();
        drop(outbox.subscribe_outgoing(None));
        outbox.send(plan(1));
        assert_eq!(
            outbox
                .subscribe_outgoing(None)
                .try_iter()
                .collect::<Vec<_>>(),
            [plan(1)]
        );
    }
}
