//! The origin's side of plan circuits: the plans this module sent, their acks put in
//! order and deduplicated by step number, and the local `DestinationLost` step.

use std::collections::BTreeMap;
use std::time::Duration;

use crossbeam_channel::{Receiver, Sender};
use slate_model::Address;
use slate_wire::{Message, Plan, PlanAck, PlanStep};

use super::{ACK_GAP_GRACE, CircuitStatus, SendPlanError, closes};

/// Acks held ahead of a gap, at most, per circuit (later ones are dropped and asked
/// for again once the gap is filled).
const MAX_EARLY: u64 = 4096;

/// Times a gap is asked for without progress before the origin gives up on it and
/// delivers what follows (the destination no longer holds the missing steps). On a link
/// that loses 30 % of its messages an ask and its answer both arrive half the time, so
/// eight asks fill a gap but once in about 200 gaps (three left one in eight skipped).
const MAX_GAP_ASKS: u32 = 8;

/// Times a plan (or its cancellation) is sent again without an answer before the origin
/// stops sending it: the first copy goes after [`ACK_GAP_GRACE`], each next one after
/// twice the wait (at most [`MAX_RESEND_WAIT`]), so the copies span about 40 s, longer
/// than Zenoh's 10 s lease and a module's restart. On a link that loses datagrams (a UDP
/// team link) this is what makes a plan arrive; a plan is a few hundred bytes.
const MAX_RESENDS: u32 = 8;

/// The longest wait between two copies of an unanswered plan.
const MAX_RESEND_WAIT: Duration = Duration::from_secs(8);

/// Copies of a plan sent (or sent to a destination back), over a link that retransmits:
/// one, after [`MAX_RESEND_WAIT`], for a first message lost on its way in (a destination
/// restarting, or Zenoh without a route to its inbox yet). More would only race an answer
/// queued behind a slow link: on the demo's 9600 bit/s radio a run's plans went from
/// 5.8 kB to 43 kB so, each copy also answered with every step again.
const RETRANSMITTED_COPIES: u32 = 1;

/// The circuits this module opened.
#[derive(Default)]
pub(crate) struct Origin {
    circuits: BTreeMap<u64, Sent>,
}

/// One plan sent.
struct Sent {
    name: String,
    text: String,
    to: Address,
    /// The origin the plan names: this module, or the origin of the plan that sent it on.
    origin: Address,
    /// Every step delivered, in order (remote steps and local `DestinationLost`).
    steps: Vec<PlanStep>,
    /// The destination's next step number to deliver (from 1).
    next: u64,
    /// Steps that arrived ahead of a gap.
    early: BTreeMap<u64, PlanStep>,
    /// Since when a gap has been open (or since it was last asked for): the plan goes
    /// again after [`ACK_GAP_GRACE`] to ask for the missing steps.
    gap_since: Option<Duration>,
    /// Times the open gap was asked for.
    asks: u32,
    /// Since when the origin has waited for an answer (the plan, or its cancellation, was
    /// sent and nothing came back from the destination since); `None` once it answered,
    /// while it is down, or after [`MAX_RESENDS`] copies in vain.
    waiting_since: Option<Duration>,
    /// How long to wait for that answer before sending again: [`ACK_GAP_GRACE`], doubled
    /// by each copy up to [`MAX_RESEND_WAIT`].
    wait: Duration,
    /// Copies sent since the destination last answered.
    unanswered: u32,
    /// Copies sent at most while waiting: [`MAX_RESENDS`], or [`RETRANSMITTED_COPIES`]
    /// over a link that retransmits.
    max_copies: u32,
    tx: Sender<PlanStep>,
    closed: bool,
    /// The origin asked for the plan to be cancelled.
    cancel: bool,
    /// The destination died and has not been heard since.
    lost: bool,
}

impl Sent {
    fn deliver(&mut self, step: PlanStep) {
        tracing::debug!(to = %self.to, plan = %self.name, ?step, "plan step");
        self.closed |= closes(&step);
        let _ = self.tx.send(step.clone());
        self.steps.push(step);
    }

    /// Delivers the steps that are in order now.
    fn advance(&mut self) {
        while let Some(step) = self.early.remove(&self.next) {
            self.next += 1;
            self.lost = false;
            self.deliver(step);
        }
    }

    fn plan(&self, circuit: u64) -> Message {
        Message::Plan(Plan {
            circuit,
            name: self.name.clone(),
            source_text: self.text.clone(),
            to: self.to.clone(),
            origin: self.origin.clone(),
        })
    }

    fn is_open(&self) -> bool {
        !self.closed
    }

    /// Waits for an answer from `now`: over a link that loses sends, the first copy after
    /// [`ACK_GAP_GRACE`] and at most [`MAX_RESENDS`]; over one that retransmits, at most
    /// [`RETRANSMITTED_COPIES`], after [`MAX_RESEND_WAIT`].
    fn await_answer(&mut self, now: Duration, lossy: bool) {
        self.waiting_since = Some(now);
        (self.wait, self.max_copies) = match lossy {
            true => (ACK_GAP_GRACE, MAX_RESENDS),
            false => (MAX_RESEND_WAIT, RETRANSMITTED_COPIES),
        };
        self.unanswered = 0;
    }

    /// The destination answered: nothing is waited for, but a cancellation's own answer
    /// (the circuit closing).
    fn answered(&mut self) {
        self.unanswered = 0;
        if !self.cancel {
            self.waiting_since = None;
        }
    }

    /// When [`overdue`](Self::overdue) or [`gap_due`](Self::gap_due) next has
    /// something to do, if anything.
    fn next_due(&self) -> Option<Duration> {
        let resend = (self.waiting_since)
            .filter(|_| self.is_open())
            .map(|since| since.saturating_add(self.wait));
        let ask = self
            .gap_since
            .map(|since| since.saturating_add(ACK_GAP_GRACE));
        resend.into_iter().chain(ask).min()
    }

    /// The messages to send again if the answer is overdue: the plan (a destination that
    /// has it answers with its steps, one that has not loads it), then the cancellation
    /// asked for. Each copy doubles the wait; after [`MAX_RESENDS`] the origin stops.
    fn overdue(&mut self, circuit: u64, now: Duration) -> Vec<Message> {
        let Some(since) = self.waiting_since.filter(|_| self.is_open()) else {
            return Vec::new();
        };
        if now.saturating_sub(since) < self.wait {
            return Vec::new();
        }
        if self.unanswered >= self.max_copies {
            let copies = self.max_copies;
            tracing::warn!(to = %self.to, plan = %self.name, "no answer to {copies} copies of the plan; no more are sent until the destination is heard again");
            self.waiting_since = None;
            return Vec::new();
        }
        self.unanswered += 1;
        self.waiting_since = Some(now);
        self.wait = (self.wait * 2).min(MAX_RESEND_WAIT);
        self.copies(circuit)
    }

    /// The plan, and its cancellation if one was asked for.
    fn copies(&self, circuit: u64) -> Vec<Message> {
        let cancel = self.cancel.then_some(Message::PlanCancel { circuit });
        std::iter::once(self.plan(circuit)).chain(cancel).collect()
    }

    /// The plan, to ask for the steps of a gap open past the grace; after
    /// [`MAX_GAP_ASKS`] in vain, the missing steps are skipped.
    fn gap_due(&mut self, circuit: u64, now: Duration) -> Option<Message> {
        let since = self.gap_since?;
        if now.saturating_sub(since) < ACK_GAP_GRACE {
            return None;
        }
        if self.asks >= MAX_GAP_ASKS {
            tracing::warn!(
                circuit,
                from = self.next,
                "plan acks lost for good; skipping them"
            );
            self.next = self.early.keys().next().copied().unwrap_or(self.next);
            self.asks = 0;
            self.advance();
            self.gap_since = (!self.early.is_empty()).then_some(now);
            return None;
        }
        self.asks += 1;
        self.gap_since = Some(now);
        Some(self.plan(circuit))
    }
}

impl Origin {
    /// Opens a circuit for a plan of `origin` (this module's own, or the origin of the
    /// plan that sends it on); returns its acks' receiver and the plan message to send.
    /// Until the destination answers, the plan is sent again from `now` (the time it is
    /// sent) as [`Sent::await_answer`] says for the link (`lossy`): over one that
    /// retransmits too, since a message can still be lost on its way in (Zenoh drops a
    /// send it has no route for yet, and a destination may not read it).
    pub fn open(
        &mut self,
        circuit: u64,
        (name, text): (&str, &str),
        to: &Address,
        origin: &Address,
        now: Duration,
        lossy: bool,
    ) -> (Receiver<PlanStep>, Message) {
        let (tx, rx) = crossbeam_channel::unbounded();
        let mut sent = Sent {
            name: name.to_owned(),
            text: text.to_owned(),
            to: to.clone(),
            origin: origin.clone(),
            steps: Vec::new(),
            next: 1,
            early: BTreeMap::new(),
            gap_since: None,
            asks: 0,
            waiting_since: None,
            wait: ACK_GAP_GRACE,
            unanswered: 0,
            max_copies: MAX_RESENDS,
            tx,
            closed: false,
            cancel: false,
            lost: false,
        };
        sent.await_answer(now, lossy);
        let msg = sent.plan(circuit);
        self.circuits.insert(circuit, sent);
        (rx, msg)
    }

    /// Forgets a circuit whose plan could not be sent.
    pub fn forget(&mut self, circuit: u64) {
        self.circuits.remove(&circuit);
    }

    /// Marks an open circuit to be cancelled; returns its destination. The cancellation
    /// is sent again until the circuit closes, from `now` (the time it is sent), as
    /// [`Origin::open`] sends a plan.
    pub fn request_cancel(
        &mut self,
        circuit: u64,
        now: Duration,
        lossy: bool,
    ) -> Result<Address, SendPlanError> {
        let c = self
            .circuits
            .get_mut(&circuit)
            .ok_or(SendPlanError::UnknownCircuit(circuit))?;
        if c.closed {
            return Err(SendPlanError::Closed(circuit));
        }
        c.cancel = true;
        c.await_answer(now, lossy);
        Ok(c.to.clone())
    }

    /// An ack from `from`: delivered with every step it puts in order. Duplicates,
    /// acks of unknown circuits and acks from another module than the destination are
    /// dropped. Returns how many steps were delivered.
    pub fn ack(&mut self, from: &Address, ack: PlanAck, now: Duration) -> usize {
        let Some(c) = self.circuits.get_mut(&ack.circuit) else {
            tracing::debug!(from = %from, circuit = ack.circuit, "ack of an unknown circuit");
            return 0;
        };
        if c.to == *from {
            // The destination answers (even with steps delivered already).
            c.answered();
        }
        if c.to == *from && c.early.is_empty() {
            // Nor is a gap waited for.
            c.gap_since = None;
            c.asks = 0;
        }
        let fresh = c.to == *from
            && ack.seq >= c.next
            && ack.seq < c.next + MAX_EARLY
            && !c.early.contains_key(&ack.seq);
        if !fresh {
            return 0;
        }
        let before = c.steps.len();
        c.early.insert(ack.seq, ack.step);
        c.advance();
        let delivered = c.steps.len() - before;
        if delivered > 0 {
            c.asks = 0;
        }
        c.gap_since = match c.early.is_empty() {
            true => None,
            false if delivered > 0 => Some(now),
            false => c.gap_since.or(Some(now)),
        };
        delivered
    }

    /// `peer` died: each open circuit to it gets a `DestinationLost` step (once, until
    /// the destination is heard again).
    pub fn lost(&mut self, peer: &Address) {
        for c in self.circuits.values_mut() {
            if c.to == *peer && c.is_open() && !c.lost {
                c.lost = true;
                c.waiting_since = None;
                c.deliver(PlanStep::DestinationLost);
            }
        }
    }

    /// `peer` is up: the plans of the open circuits to it, sent again (the destination
    /// loads one it never got, and answers one it knows with all its steps), and the
    /// cancellations asked for. Until the destination answers, [`due`](Self::due) sends
    /// them again: at most [`MAX_RESENDS`] times over a link that loses sends (`lossy`),
    /// [`RETRANSMITTED_COPIES`] over one that retransmits.
    pub fn resume(&mut self, peer: &Address, now: Duration, lossy: bool) -> Vec<Message> {
        let mut out = Vec::new();
        for (&circuit, c) in &mut self.circuits {
            if c.to != *peer || !c.is_open() {
                continue;
            }
            c.await_answer(now, lossy);
            out.extend(c.copies(circuit));
        }
        out
    }

    /// What is due at `now`: the plans (and cancellations) unanswered past their wait,
    /// sent again with back-off; and for a gap open past the grace, the plan, to ask for
    /// the missing steps.
    pub fn due(&mut self, now: Duration) -> Vec<(Address, Message)> {
        let mut out = Vec::new();
        for (&circuit, c) in &mut self.circuits {
            let to = c.to.clone();
            let asks = c.gap_due(circuit, now).into_iter();
            let copies = c.overdue(circuit, now).into_iter().chain(asks);
            out.extend(copies.map(|msg| (to.clone(), msg)));
        }
        out
    }

    /// The earliest time [`due`](Self::due) has something to do, if any.
    pub fn next_due(&self) -> Option<Duration> {
        self.circuits.values().filter_map(Sent::next_due).min()
    }

    /// Every circuit, oldest first.
    pub fn status(&self) -> Vec<CircuitStatus> {
        self.circuits
            .iter()
            .map(|(&circuit, c)| CircuitStatus {
                circuit,
                name: c.name.clone(),
                peer: c.to.clone(),
                steps: c.steps.clone(),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn addr(s: &str) -> Address {
        Address::new(s).unwrap()
    }

    fn ack(seq: u64, step: PlanStep) -> PlanAck {
        PlanAck {
            circuit: 1,
            seq,
            step,
        }
    }

    fn opened() -> (Origin, Receiver<PlanStep>, Address) {
        let mut o = Origin::default();
        let dest = addr("t/r2/d");
        let (rx, msg) = o.open(
            1,
            ("p", "plan p { action { } }"),
            &dest,
            &addr("t/r1/o"),
            Duration::ZERO,
            true,
        );
        assert!(matches!(msg, Message::Plan(Plan { circuit: 1, .. })));
        (o, rx, dest)
    }

    #[test]
    fn acks_are_delivered_in_order_and_once() {
        let (mut o, rx, d) = opened();
        let t = Duration::ZERO;
        assert_eq!(
            o.ack(&d, ack(2, PlanStep::Accepted), t),
            0,
            "held: 1 is missing"
        );
        assert_eq!(o.ack(&d, ack(2, PlanStep::Accepted), t), 0, "a duplicate");
        assert_eq!(o.ack(&d, ack(1, PlanStep::Received), t), 2);
        assert_eq!(
            o.ack(&d, ack(1, PlanStep::Received), t),
            0,
            "a late duplicate"
        );
        assert_eq!(
            o.ack(&addr("t/r3/x"), ack(3, PlanStep::Initiated), t),
            0,
            "not the destination"
        );
        let got: Vec<PlanStep> = rx.try_iter().collect();
        assert_eq!(got, [PlanStep::Received, PlanStep::Accepted]);
    }

    #[test]
    fn a_dead_destination_is_one_local_step_and_acks_resume_after_it() {
        let (mut o, rx, d) = opened();
        o.ack(&d, ack(1, PlanStep::Received), Duration::ZERO);
        o.lost(&d);
        o.lost(&d);
        let resend = o.resume(&d, Duration::ZERO, true);
        assert_eq!(resend.len(), 1, "the plan goes again");
        o.ack(&d, ack(1, PlanStep::Received), Duration::ZERO);
        o.ack(&d, ack(2, PlanStep::Accepted), Duration::ZERO);
        let got: Vec<PlanStep> = rx.try_iter().collect();
        assert_eq!(
            got,
            [
                PlanStep::Received,
                PlanStep::DestinationLost,
                PlanStep::Accepted
            ]
        );
    }

    #[test]
    fn a_plan_sent_again_to_a_destination_back_is_sent_again_until_it_answers() {
        let (mut o, _rx, d) = opened();
        o.ack(&d, ack(1, PlanStep::Received), Duration::ZERO);
        o.lost(&d);
        let at = Duration::from_secs(10);
        assert_eq!(o.resume(&d, at, true).len(), 1);
        // That plan message was lost (sent before the restarted module could read it).
        let again = o.due(at + ACK_GAP_GRACE);
        assert_eq!(again.len(), 1, "no answer: the plan goes again");
        assert!(matches!(again[0].1, Message::Plan(_)));
        // A restarted destination answers with its own steps from 1: duplicates here,
        // but an answer.
        o.ack(&d, ack(1, PlanStep::Received), at + ACK_GAP_GRACE);
        assert!(o.due(at + 3 * ACK_GAP_GRACE).is_empty(), "answered");
    }

    #[test]
    fn over_a_link_that_retransmits_a_plan_sent_to_a_destination_back_goes_once_more_at_most() {
        let (mut o, _rx, d) = opened();
        o.ack(&d, ack(1, PlanStep::Received), Duration::ZERO);
        o.lost(&d);
        let at = Duration::from_secs(10);
        assert_eq!(o.resume(&d, at, false).len(), 1);
        // Its answer waits behind a slow radio's queue: no copy races it.
        let mut copies = Vec::new();
        for tenth in 1..=600 {
            let now = at + Duration::from_millis(100 * tenth);
            copies.extend(o.due(now).into_iter().map(|_| now - at));
        }
        // One copy, for a destination that could not read the first yet (restarting).
        assert_eq!(copies, [MAX_RESEND_WAIT], "copies at {copies:?}");
    }

    #[test]
    fn over_a_link_that_retransmits_an_unanswered_plan_goes_once_more_at_most() {
        let mut o = Origin::default();
        let d = addr("t/r2/d");
        let _ = o.open(
            1,
            ("p", "plan p { action { } }"),
            &d,
            &addr("t/r1/o"),
            Duration::ZERO,
            false,
        );
        // The first message was lost on its way in (Zenoh had no route to the
        // destination's inbox yet, or the destination could not read it): one copy.
        let mut copies = Vec::new();
        for tenth in 1..=600 {
            let now = Duration::from_millis(100 * tenth);
            copies.extend(o.due(now).into_iter().map(|_| now));
        }
        assert_eq!(copies, [MAX_RESEND_WAIT], "copies at {copies:?}");
    }

    #[test]
    fn a_closed_circuit_cannot_be_cancelled_and_loses_nothing() {
        let (mut o, _rx, d) = opened();
        o.ack(
            &d,
            ack(
                1,
                PlanStep::Rejected {
                    reason: "no".into(),
                },
            ),
            Duration::ZERO,
        );
        assert!(matches!(
            o.request_cancel(1, Duration::ZERO, true),
            Err(SendPlanError::Closed(1))
        ));
        assert!(matches!(
            o.request_cancel(9, Duration::ZERO, true),
            Err(SendPlanError::UnknownCircuit(9))
        ));
        o.lost(&d);
        assert_eq!(o.status()[0].steps.len(), 1);
    }

    #[test]
    fn a_gap_is_asked_for_then_skipped() {
        let (mut o, rx, d) = opened();
        o.ack(&d, ack(3, PlanStep::Initiated), Duration::ZERO);
        assert!(o.due(Duration::from_millis(500)).is_empty(), "grace");
        let mut asked = 0;
        for s in 1..=(MAX_GAP_ASKS + 1) {
            asked += o.due(Duration::from_secs(u64::from(s))).len();
        }
        assert_eq!(asked, MAX_GAP_ASKS as usize);
        assert_eq!(rx.try_iter().collect::<Vec<_>>(), [PlanStep::Initiated]);
        assert!(o.due(Duration::from_secs(60)).is_empty(), "no gap left");
    }

    #[test]
    fn an_unanswered_plan_is_sent_again_with_back_off_then_no_more() {
        let (mut o, _rx, _d) = opened();
        let mut sent_at = Vec::new();
        for tenth in 0..1200 {
            let now = Duration::from_millis(100 * tenth);
            if !o.due(now).is_empty() {
                sent_at.push(now.as_secs());
            }
        }
        assert_eq!(
            sent_at,
            [1, 3, 7, 15, 23, 31, 39, 47],
            "1 s, doubling to 8 s, 8 copies"
        );
    }

    #[test]
    fn a_cancellation_is_sent_again_until_the_circuit_closes() {
        let (mut o, _rx, d) = opened();
        o.ack(&d, ack(1, PlanStep::Received), Duration::ZERO);
        assert!(o.due(Duration::from_secs(5)).is_empty(), "answered");
        o.request_cancel(1, Duration::from_secs(5), true).unwrap();
        o.ack(&d, ack(2, PlanStep::Accepted), Duration::from_secs(5));
        let again = o.due(Duration::from_secs(6));
        assert!(
            matches!(
                again.as_slice(),
                [
                    (_, Message::Plan(_)),
                    (_, Message::PlanCancel { circuit: 1 })
                ]
            ),
            "{again:?}"
        );
        o.ack(&d, ack(3, PlanStep::Cancelled), Duration::from_secs(6));
        assert!(o.due(Duration::from_secs(60)).is_empty(), "closed");
    }
}
