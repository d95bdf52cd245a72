//! What plans and rules send out (reports and plans for other modules) and the progress
//! events of plans. The ICI carries both; tests read them here.

use std::sync::Arc;

use crossbeam_channel::{Receiver, Sender};
use parking_lot::Mutex;
use slate_model::{Address, Packet};

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

/// Fan-out of outgoing messages and events to their subscribers.
#[derive(Default)]
pub(crate) struct Outbox {
    outgoing: Mutex<Vec<Sender<Outgoing>>>,
    events: Mutex<Vec<Sender<PlanEvent>>>,
}

impl Outbox {
    pub fn subscribe_outgoing(&self) -> Receiver<Outgoing> {
        let (tx, rx) = crossbeam_channel::unbounded();
        self.outgoing.lock().push(tx);
        rx
    }

    pub fn subscribe_events(&self) -> Receiver<PlanEvent> {
        let (tx, rx) = crossbeam_channel::unbounded();
        self.events.lock().push(tx);
        rx
    }

    pub fn send(&self, msg: Outgoing) {
        self.outgoing
            .lock()
            .retain(|tx| tx.send(msg.clone()).is_ok());
    }

    /// Is anyone listening to events? (Lets the hot path skip building them.)
    pub fn has_event_subscribers(&self) -> bool {
        !self.events.lock().is_empty()
    }

    pub fn event(&self, e: PlanEvent) {
        tracing::debug!(?e, "plan event");
        self.events.lock().retain(|tx| tx.send(e.clone()).is_ok());
    }
}
