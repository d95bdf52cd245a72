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
/// delivers what follows (the destination no longer holds the missing steps).
const MAX_GAP_ASKS: u32 = 3;

/// Times the plan is sent again to a destination that came back and does not answer,
/// one [`ACK_GAP_GRACE`] apart: a module that restarts can be up for its peers' Zenoh
/// liveliness a few seconds before messages reach it, so this outlasts Zenoh's 10 s
/// lease. A plan is a few hundred bytes: at most one a second per silent circuit.
const MAX_RESENDS: u32 = 12;

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
    /// Since when a gap has been open (or since it was last asked for), or since the
    /// plan was sent again to a destination that came back and has not answered: the
    /// plan goes again after [`ACK_GAP_GRACE`] (that message can be lost too, e.g. sent
    /// before a restarted module reads its inbox).
    gap_since: Option<Duration>,
    /// Times the open gap was asked for.
    asks: u32,
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
}

impl Origin {
    /// Opens a circuit for a plan of `origin` (this module's own, or the origin of the
    /// plan that sends it on); returns its acks' receiver and the plan message to send.
    pub fn open(
        &mut self,
        circuit: u64,
        name: &str,
        text: &str,
        to: &Address,
        origin: &Address,
    ) -> (Receiver<PlanStep>, Message) {
        let (tx, rx) = crossbeam_channel::unbounded();
        let sent = Sent {
            name: name.to_owned(),
            text: text.to_owned(),
            to: to.clone(),
            origin: origin.clone(),
            steps: Vec::new(),
            next: 1,
            early: BTreeMap::new(),
            gap_since: None,
            asks: 0,
            tx,
            closed: false,
            cancel: false,
            lost: false,
        };
        let msg = sent.plan(circuit);
        self.circuits.insert(circuit, sent);
        (rx, msg)
    }

    /// Forgets a circuit whose plan could not be sent.
    pub fn forget(&mut self, circuit: u64) {
        self.circuits.remove(&circuit);
    }

    /// Marks an open circuit to be cancelled; returns its destination.
    pub fn request_cancel(&mut self, circuit: u64) -> Result<Address, SendPlanError> {
        let c = self
            .circuits
            .get_mut(&circuit)
            .ok_or(SendPlanError::UnknownCircuit(circuit))?;
        if c.closed {
            return Err(SendPlanError::Closed(circuit));
        }
        c.cancel = true;
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
        if c.to == *from && c.early.is_empty() {
            // The destination answers (even with steps delivered already): nothing is
            // waited for.
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
                c.deliver(PlanStep::DestinationLost);
            }
        }
    }

    /// `peer` is up: the plans of the open circuits to it, sent again (the destination
    /// loads one it never got, and answers one it knows with all its steps), and the
    /// cancellations asked for. Until the destination answers, [`gaps_due`](Self::gaps_due)
    /// sends the plan again (at most [`MAX_GAP_ASKS`] times).
    pub fn resume(&mut self, peer: &Address, now: Duration) -> Vec<Message> {
        let mut out = Vec::new();
        for (&circuit, c) in &mut self.circuits {
            if c.to != *peer || !c.is_open() {
                continue;
            }
            c.gap_since = c.gap_since.or(Some(now));
            out.push(c.plan(circuit));
            if c.cancel {
                out.push(Message::PlanCancel { circuit });
            }
        }
        out
    }

    /// Circuits whose gap stayed open past the grace: the plan to send again, to ask
    /// for the steps. A gap asked for in vain [`MAX_GAP_ASKS`] times is skipped; a plan
    /// sent again to a destination back is sent at most [`MAX_RESENDS`] times unanswered.
    pub fn gaps_due(&mut self, now: Duration) -> Vec<(Address, Message)> {
        let mut out = Vec::new();
        for (&circuit, c) in &mut self.circuits {
            let Some(since) = c.gap_since else { continue };
            if now.saturating_sub(since) < ACK_GAP_GRACE {
                continue;
            }
            let bound = if c.early.is_empty() {
                MAX_RESENDS
            } else {
                MAX_GAP_ASKS
            };
            if c.asks >= bound {
                tracing::warn!(
                    circuit,
                    from = c.next,
                    "plan acks lost for good; skipping them"
                );
                c.next = c.early.keys().next().copied().unwrap_or(c.next);
                c.asks = 0;
                c.advance();
                c.gap_since = (!c.early.is_empty()).then_some(now);
                continue;
            }
            c.asks += 1;
            c.gap_since = Some(now);
            out.push((c.to.clone(), c.plan(circuit)));
        }
        out
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
        let (rx, msg) = o.open(1, "p", "plan p { action { } }", &dest, &addr("t/r1/o"));
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
        let resend = o.resume(&d, Duration::ZERO);
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
        assert_eq!(o.resume(&d, at).len(), 1);
        // That plan message was lost (sent before the restarted module could read it).
        let again = o.gaps_due(at + ACK_GAP_GRACE);
        assert_eq!(again.len(), 1, "no answer: the plan goes again");
        assert!(matches!(again[0].1, Message::Plan(_)));
        // A restarted destination answers with its own steps from 1: duplicates here,
        // but an answer.
        o.ack(&d, ack(1, PlanStep::Received), at + ACK_GAP_GRACE);
        assert!(o.gaps_due(at + 3 * ACK_GAP_GRACE).is_empty(), "answered");
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
        assert!(matches!(o.request_cancel(1), Err(SendPlanError::Closed(1))));
        assert!(matches!(
            o.request_cancel(9),
            Err(SendPlanError::UnknownCircuit(9))
        ));
        o.lost(&d);
        assert_eq!(o.status()[0].steps.len(), 1);
    }

    #[test]
    fn a_gap_is_asked_for_then_skipped() {
        let (mut o, rx, d) = opened();
        o.ack(&d, ack(3, PlanStep::Initiated), Duration::ZERO);
        assert!(o.gaps_due(Duration::from_millis(500)).is_empty(), "grace");
        let mut asked = 0;
        for s in 1..=4 {
            asked += o.gaps_due(Duration::from_secs(s)).len();
        }
        assert_eq!(asked, 3);
        assert_eq!(rx.try_iter().collect::<Vec<_>>(), [PlanStep::Initiated]);
        assert!(o.gaps_due(Duration::from_secs(9)).is_empty(), "no gap left");
    }
}
