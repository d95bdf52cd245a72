//! The destination's side of plan circuits: plans received are acknowledged, loaded
//! into the engine, and followed; every step is numbered and kept so that the origin
//! can have them again.

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use slate_model::Address;
use slate_plans::PlanEvent;
use slate_wire::{Message, Plan, PlanAck, PlanStep};

use crossbeam_channel::TrySendError;

use super::{
    ACK_GAP_GRACE, CircuitStatus, HeldPlan, Inner, MAX_PLAN_TEXT_BYTES, RefusedPlan, closes,
    one_plan,
};

/// Closed circuits remembered (to answer an origin that missed their last steps).
const MAX_CLOSED: usize = 1024;

/// Steps kept per circuit (the oldest are forgotten past it; an origin that missed
/// them skips them).
const MAX_KEPT_STEPS: usize = 4096;

/// The longest reason a `Rejected` step carries, in bytes: the diagnostics past it are cut
/// (each quotes at most a window of its line, but a text may have many), so the step always
/// fits in an acknowledgement.
const MAX_REASON_BYTES: usize = 8 * 1024;

/// Times a last step (`Terminated`, `Cancelled`, `Rejected`) is sent again unasked:
/// [`ACK_GAP_GRACE`] after it, then after twice the wait each time (1, 3, 7, 15 s).
/// An origin hears of a lost step when a later one arrives; nothing follows a last step,
/// so on a link that loses datagrams (a UDP team link) it is repeated. At 30 % loss all
/// five copies are lost once in about 400 circuits.
const LAST_STEP_REPEATS: u32 = 4;

/// A last step to send again.
struct Repeat {
    /// The origin.
    to: Address,
    ack: PlanAck,
    /// When it goes next.
    due: Duration,
    /// The wait after that.
    wait: Duration,
    /// Copies still to send.
    left: u32,
}

/// A circuit is named by its origin and the number the origin gave it.
type Key = (Address, u64);

/// An open circuit whose plan still runs: its key, the plan's name and text, and the
/// number its next step takes.
type Running = (Key, String, String, u64);

/// The circuits other modules opened to this one.
#[derive(Default)]
pub(crate) struct Destination {
    circuits: BTreeMap<Key, Circuit>,
    /// Plan name → circuit, while the plan may still make progress.
    by_name: HashMap<String, Key>,
    closed: VecDeque<Key>,
    /// Last steps to send again, oldest first (at most [`MAX_CLOSED`]).
    repeats: VecDeque<Repeat>,
}

struct Circuit {
    name: String,
    text: String,
    /// Kept steps; the first is number `first`.
    steps: VecDeque<PlanStep>,
    first: u64,
    phase: Phase,
    /// Progress events heard while the plan was being loaded (sent after `Accepted`).
    pending: Vec<PlanStep>,
    /// A cancellation arrived while the plan was being loaded.
    cancel: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Loading,
    Open,
    Closed,
}

impl Circuit {
    /// Appends a step; returns its ack.
    fn push(&mut self, circuit: u64, step: PlanStep) -> PlanAck {
        if closes(&step) {
            self.phase = Phase::Closed;
        }
        self.steps.push_back(step.clone());
        if self.steps.len() > MAX_KEPT_STEPS {
            self.steps.pop_front();
            self.first += 1;
        }
        PlanAck {
            circuit,
            seq: self.first + self.steps.len() as u64 - 1,
            step,
        }
    }

    fn acks(&self, circuit: u64) -> Vec<PlanAck> {
        (self.first..)
            .zip(&self.steps)
            .map(|(seq, step)| PlanAck {
                circuit,
                seq,
                step: step.clone(),
            })
            .collect()
    }
}

impl Destination {
    /// The acks of a circuit already known under the same plan: an origin sending it
    /// again asks for them. `None` for a new circuit (a known number with another plan
    /// is an origin that restarted: the old record goes).
    fn resend(&mut self, key: &Key, plan: &Plan) -> Option<Vec<PlanAck>> {
        let c = self.circuits.get(key)?;
        if c.name == plan.name && c.text == plan.source_text {
            return Some(c.acks(key.1));
        }
        let old = self.circuits.remove(key)?;
        if self.by_name.get(&old.name) == Some(key) {
            self.by_name.remove(&old.name);
        }
        None
    }

    /// Opens a circuit: its first step is `Received`. The text is kept (to know the plan
    /// when it is sent again) unless it is over [`MAX_PLAN_TEXT_BYTES`]: such a plan is
    /// rejected, and each time it is sent again, so closed circuits keep at most that much.
    fn begin(&mut self, key: &Key, plan: &Plan) -> PlanAck {
        let fits = plan.source_text.len() <= MAX_PLAN_TEXT_BYTES;
        let mut c = Circuit {
            name: plan.name.clone(),
            text: if fits {
                plan.source_text.clone()
            } else {
                String::new()
            },
            steps: VecDeque::new(),
            first: 1,
            phase: Phase::Loading,
            pending: Vec::new(),
            cancel: false,
        };
        let ack = c.push(key.1, PlanStep::Received);
        self.circuits.insert(key.clone(), c);
        ack
    }

    /// Reserves the plan's name for this circuit, unless another circuit has it.
    fn claim(&mut self, key: &Key, name: &str) -> Result<(), String> {
        match self.by_name.get(name) {
            Some(other) if other != key => Err(format!(
                "a plan named {name} is being loaded for {} (circuit {}); plan names are unique on a board",
                other.0, other.1
            )),
            _ => {
                self.by_name.insert(name.to_owned(), key.clone());
                Ok(())
            }
        }
    }

    fn reject(&mut self, key: &Key, reason: String) -> Option<PlanAck> {
        let c = self.circuits.get_mut(key)?;
        let reason = bounded(reason);
        let ack = c.push(key.1, PlanStep::Rejected { reason });
        if self.by_name.get(&c.name) == Some(key) {
            self.by_name.remove(&c.name);
        }
        self.retire(key);
        Some(ack)
    }

    /// The plan loaded: `Accepted`, then what happened meanwhile. Also says whether a
    /// cancellation is waiting.
    fn accept(&mut self, key: &Key) -> (Vec<PlanAck>, bool) {
        let Some(c) = self.circuits.get_mut(key) else {
            return (Vec::new(), false);
        };
        c.phase = Phase::Open;
        let mut acks = vec![c.push(key.1, PlanStep::Accepted)];
        for step in std::mem::take(&mut c.pending) {
            if c.phase != Phase::Closed {
                acks.push(c.push(key.1, step));
            }
        }
        let cancel = c.cancel;
        if c.phase == Phase::Closed {
            self.retire(key);
        }
        (acks, cancel)
    }

    /// A progress event of a plan: the ack to send, to whom.
    fn event(&mut self, name: &str, step: PlanStep) -> Option<(Address, PlanAck)> {
        let key = self.by_name.get(name)?.clone();
        let c = self.circuits.get_mut(&key)?;
        match c.phase {
            Phase::Loading => {
                c.pending.push(step);
                None
            }
            Phase::Open => {
                let ack = c.push(key.1, step);
                if c.phase == Phase::Closed {
                    self.retire(&key);
                }
                Some((key.0, ack))
            }
            Phase::Closed => None,
        }
    }

    /// The plan to cancel for a `PlanCancel`, if it is running (one being loaded is
    /// cancelled once loaded).
    fn cancel_target(&mut self, key: &Key) -> Option<String> {
        let c = self.circuits.get_mut(key)?;
        match c.phase {
            Phase::Open => Some(c.name.clone()),
            Phase::Loading => {
                c.cancel = true;
                None
            }
            Phase::Closed => None,
        }
    }

    /// A closed circuit no longer maps its plan's events; the oldest closed are
    /// forgotten past [`MAX_CLOSED`].
    fn retire(&mut self, key: &Key) {
        if let Some(c) = self.circuits.get(key)
            && self.by_name.get(&c.name) == Some(key)
        {
            self.by_name.remove(&c.name);
        }
        self.closed.push_back(key.clone());
        while self.closed.len() > MAX_CLOSED {
            if let Some(old) = self.closed.pop_front() {
                self.circuits.remove(&old);
            }
        }
    }

    /// The open circuits whose plan still runs.
    fn running(&self) -> Vec<Running> {
        let open = |(key, c): (&Key, &Circuit)| {
            let running = c.phase == Phase::Open && self.by_name.get(&c.name) == Some(key);
            let next = c.first + c.steps.len() as u64;
            running.then(|| (key.clone(), c.name.clone(), c.text.clone(), next))
        };
        self.circuits.iter().filter_map(open).collect()
    }

    /// Opens a circuit for a plan reinstated after a restart: open, its name claimed,
    /// its next step numbered `next_step`.
    fn reopen(&mut self, key: &Key, plan: &HeldPlan) -> Result<(), String> {
        self.claim(key, &plan.name)?;
        let c = Circuit {
            name: plan.name.clone(),
            text: plan.text.clone(),
            steps: VecDeque::new(),
            first: plan.next_step.max(1),
            phase: Phase::Open,
            pending: Vec::new(),
            cancel: false,
        };
        self.circuits.insert(key.clone(), c);
        Ok(())
    }

    /// Forgets a circuit whose plan did not load again.
    fn forget(&mut self, key: &Key) {
        if let Some(c) = self.circuits.remove(key)
            && self.by_name.get(&c.name) == Some(key)
        {
            self.by_name.remove(&c.name);
        }
    }

    /// Sends `ack` to `to` again later if it is a circuit's last step.
    fn repeat_if_last(&mut self, to: &Address, ack: &PlanAck, now: Duration) {
        if !closes(&ack.step) {
            return;
        }
        self.repeats.push_back(Repeat {
            to: to.clone(),
            ack: ack.clone(),
            due: now + ACK_GAP_GRACE,
            wait: ACK_GAP_GRACE * 2,
            left: LAST_STEP_REPEATS,
        });
        if self.repeats.len() > MAX_CLOSED {
            self.repeats.pop_front();
        }
    }

    /// When the next last step is repeated, if one is to be.
    pub(super) fn next_repeat(&self) -> Option<Duration> {
        self.repeats.iter().map(|r| r.due).min()
    }

    /// The last steps due again at `now`, to whom.
    fn repeats_due(&mut self, now: Duration) -> Vec<(Address, PlanAck)> {
        let mut out = Vec::new();
        for r in self.repeats.iter_mut().filter(|r| r.due <= now) {
            out.push((r.to.clone(), r.ack.clone()));
            r.left -= 1;
            r.due = now + r.wait;
            r.wait *= 2;
        }
        self.repeats.retain(|r| r.left > 0);
        out
    }

    /// Every circuit, by origin and number.
    pub fn status(&self) -> Vec<CircuitStatus> {
        self.circuits
            .iter()
            .map(|((origin, circuit), c)| CircuitStatus {
                circuit: *circuit,
                name: c.name.clone(),
                peer: origin.clone(),
                steps: c.steps.iter().cloned().collect(),
            })
            .collect()
    }
}

/// `reason`, cut to at most [`MAX_REASON_BYTES`] (at a character boundary) with a note
/// saying how much was left out.
fn bounded(mut reason: String) -> String {
    if reason.len() <= MAX_REASON_BYTES {
        return reason;
    }
    let mut cut = MAX_REASON_BYTES - 64;
    while !reason.is_char_boundary(cut) {
        cut -= 1;
    }
    let left_out = reason.len() - cut;
    reason.truncate(cut);
    reason.push_str(&format!("\n... ({left_out} more bytes of diagnostics)"));
    reason
}

/// The ack step of an engine event, with the plan's name. `Installed` is acked as
/// `Accepted` once the load returns; `Failed` (a condition that did not evaluate) is
/// not a step of the circuit: it shows on the plan object's `last_error`.
fn step_of(event: PlanEvent) -> Option<(String, PlanStep)> {
    let (plan, step) = match event {
        PlanEvent::Initiated { plan } => (plan, PlanStep::Initiated),
        PlanEvent::Triggered {
            plan,
            fired,
            error: None,
        } => (
            plan,
            PlanStep::Triggered {
                ok: true,
                detail: format!("fired {fired}"),
            },
        ),
        PlanEvent::Triggered {
            plan,
            error: Some(detail),
            ..
        } => (plan, PlanStep::Triggered { ok: false, detail }),
        PlanEvent::Terminated { plan } => (plan, PlanStep::Terminated),
        PlanEvent::Cancelled { plan } => (plan, PlanStep::Cancelled),
        PlanEvent::Installed { .. } | PlanEvent::Failed { .. } => return None,
    };
    Some((plan, step))
}

impl Inner {
    /// A plan arrived: a known circuit gets its steps again; a new one is received,
    /// checked, loaded, and accepted or rejected.
    pub(super) fn on_plan(self: &Arc<Self>, from: &Address, plan: Plan) {
        let Some(key) = self.open(from, &plan) else {
            return;
        };
        if let Some(reason) = self.unauthorised(from, &plan) {
            self.rejected(&key, &plan.name, reason);
            return;
        }
        let checked = self
            .check(&plan)
            .and_then(|()| self.destination().claim(&key, &plan.name));
        let outcome = checked.and_then(|()| {
            let file = format!("{from}/{}.slate", plan.name);
            self.engine.run_as(&plan.name, Some(&plan.origin));
            let loaded = self.engine.load(&file, &plan.source_text);
            loaded.map(|_| ()).map_err(|e| {
                self.engine.run_as(&plan.name, None);
                e.rendered
            })
        });
        match outcome {
            Ok(()) => {
                self.runs_for.lock().insert(plan.name.clone(), plan.origin);
                self.accepted(&key, &plan.name);
            }
            Err(reason) => self.rejected(&key, &plan.name, reason),
        }
        self.drain();
    }

    /// Why `from` or the origin `plan` names may not send this module plans (judged
    /// before the text is parsed), counted and told to those following refusals.
    fn unauthorised(&self, from: &Address, plan: &Plan) -> Option<String> {
        let reason = self
            .authority
            .lock()
            .refusal(&self.me, from, &plan.origin)?;
        self.counters.unauthorised.fetch_add(1, Ordering::Relaxed);
        tracing::warn!(%from, origin = %plan.origin, plan = %plan.name, "plan refused: no authority");
        let refused = RefusedPlan {
            from: from.clone(),
            origin: plan.origin.clone(),
            name: plan.name.clone(),
            reason: reason.clone(),
        };
        self.refusals.lock().retain(|tx| {
            !matches!(
                tx.try_send(refused.clone()),
                Err(TrySendError::Disconnected(_))
            )
        });
        Some(reason)
    }

    /// A plan arrived while [`MAX_QUEUED_PLANS`](super::MAX_QUEUED_PLANS) were waiting:
    /// it is received and rejected at once, unparsed; the origin may send it again later.
    pub(super) fn refuse_busy(self: &Arc<Self>, from: &Address, plan: Plan) {
        let Some(key) = self.open(from, &plan) else {
            return;
        };
        self.counters.busy.fetch_add(1, Ordering::Relaxed);
        let reason = format!(
            "{} is busy: {} plans are waiting to be loaded; send it again later",
            self.me,
            super::MAX_QUEUED_PLANS
        );
        self.rejected(&key, &plan.name, reason);
    }

    /// A known circuit gets its steps again (`None`); a new one is opened and
    /// acknowledged `Received`.
    fn open(self: &Arc<Self>, from: &Address, plan: &Plan) -> Option<Key> {
        let key = (from.clone(), plan.circuit);
        let again = self.destination().resend(&key, plan);
        if let Some(acks) = again {
            self.counters.answered_again.fetch_add(1, Ordering::Relaxed);
            for ack in acks {
                self.transmit_logged(from, Message::PlanAck(ack));
            }
            return None;
        }
        let received = self.destination().begin(&key, plan);
        self.counters.received.fetch_add(1, Ordering::Relaxed);
        self.transmit_logged(from, Message::PlanAck(received));
        Some(key)
    }

    fn rejected(self: &Arc<Self>, key: &Key, name: &str, reason: String) {
        self.counters.rejected.fetch_add(1, Ordering::Relaxed);
        tracing::debug!(from = %key.0, plan = %name, %reason, "plan rejected");
        let ack = self.destination().reject(key, reason);
        if let Some(ack) = ack {
            self.send_ack(&key.0, ack);
        }
    }

    fn accepted(self: &Arc<Self>, key: &Key, name: &str) {
        self.counters.accepted.fetch_add(1, Ordering::Relaxed);
        if let Err(e) = self.engine.set_origin(name, key.0.as_str()) {
            tracing::debug!(plan = %name, error = %e, "plan origin not written");
        }
        let (acks, cancel) = self.destination().accept(key);
        for ack in acks {
            self.send_ack(&key.0, ack);
        }
        if cancel {
            self.engine.cancel(name);
        }
    }

    /// Why a plan cannot be loaded here, before the engine is asked: the address, the
    /// text's size (before it is parsed), the shape of the text, and its name (plan names are unique on a board: a plan whose
    /// name is taken is rejected, never renamed, so the origin's name stays the one
    /// every board shows).
    fn check(&self, plan: &Plan) -> Result<(), String> {
        if plan.to != self.me {
            return Err(format!(
                "the plan is addressed to {}, not {}",
                plan.to, self.me
            ));
        }
        if plan.source_text.len() > MAX_PLAN_TEXT_BYTES {
            return Err(format!(
                "the plan text is {} bytes; at most {MAX_PLAN_TEXT_BYTES} bytes are accepted: split it into sub-plans",
                plan.source_text.len()
            ));
        }
        let file = format!("{}/{}.slate", plan.origin, plan.name);
        let name = one_plan(&file, &plan.source_text)?;
        if name != plan.name {
            return Err(format!(
                "the circuit says plan {} but the text holds plan {name}",
                plan.name
            ));
        }
        if let Some(status) = self.engine.status(&name) {
            return Err(format!(
                "a plan named {name} already exists on {} ({}); plan names are unique on a board: send it under another name",
                self.me,
                status.state.name()
            ));
        }
        if self.ici.board().info(&name).is_some() {
            return Err(format!(
                "{name} already names an object or class on {}; plan names must be unique object names",
                self.me
            ));
        }
        Ok(())
    }

    /// The plans received that still run, each with the origin it runs for and where it
    /// is (the engine is asked before the origins are locked: one lock at a time).
    pub(super) fn held(&self) -> Vec<HeldPlan> {
        let running = self.destination().running();
        let running: Vec<_> = running
            .into_iter()
            .filter_map(|r| Some((self.engine.progress(&r.1)?, r)))
            .collect();
        let runs_for = self.runs_for.lock();
        let held = |(progress, ((from, circuit), name, text, next_step)): (_, Running)| {
            let origin = runs_for.get(&name).cloned().unwrap_or_else(|| from.clone());
            HeldPlan {
                from,
                circuit,
                origin,
                name,
                text,
                next_step,
                progress,
            }
        };
        running.into_iter().map(held).collect()
    }

    /// Installs a plan held before a restart (see [`PlanCircuits::reinstate`](super::PlanCircuits::reinstate)).
    pub(super) fn reinstate(self: &Arc<Self>, plan: HeldPlan) -> Result<(), String> {
        let wire = Plan {
            circuit: plan.circuit,
            name: plan.name.clone(),
            source_text: plan.text.clone(),
            to: self.me.clone(),
            origin: plan.origin.clone(),
        };
        let authority = self
            .authority
            .lock()
            .refusal(&self.me, &plan.from, &plan.origin);
        authority.map_or(Ok(()), Err)?;
        self.check(&wire)?;
        let key = (plan.from.clone(), plan.circuit);
        self.destination().reopen(&key, &plan)?;
        let file = format!("{}/{}.slate", plan.from, plan.name);
        self.engine.resume(&plan.name, plan.progress);
        if let Err(e) = self.engine.load(&file, &plan.text) {
            self.destination().forget(&key);
            return Err(e.rendered);
        }
        self.runs_for.lock().insert(plan.name.clone(), plan.origin);
        if let Err(e) = self.engine.set_origin(&plan.name, plan.from.as_str()) {
            tracing::debug!(plan = %plan.name, error = %e, "plan origin not written");
        }
        self.drain();
        Ok(())
    }

    /// The origin cancels the plan of a circuit.
    pub(super) fn on_cancel(self: &Arc<Self>, from: &Address, circuit: u64) {
        let name = self.destination().cancel_target(&(from.clone(), circuit));
        if let Some(name) = name {
            self.engine.cancel(&name);
            self.drain();
        }
    }

    /// A progress event from the engine: an ack for the circuit of that plan, if any.
    pub(super) fn on_event(self: &Arc<Self>, event: PlanEvent) {
        let Some((name, step)) = step_of(event) else {
            return;
        };
        let ack = self.destination().event(&name, step);
        if let Some((origin, ack)) = ack {
            self.send_ack(&origin, ack);
        }
    }

    /// Sends a step of a circuit to its origin; a last step is sent again later.
    fn send_ack(self: &Arc<Self>, to: &Address, ack: PlanAck) {
        if *to != self.me && self.lossy {
            let now = self.now();
            self.destination().repeat_if_last(to, &ack, now);
        }
        self.transmit_logged(to, Message::PlanAck(ack));
    }

    /// Sends again the last steps due (see [`LAST_STEP_REPEATS`]).
    pub(super) fn repeat_last_steps(self: &Arc<Self>, now: Duration) {
        let due = self.destination.lock().repeats_due(now);
        let repeated = due.len() as u64;
        self.counters
            .repeated
            .fetch_add(repeated, Ordering::Relaxed);
        for (to, ack) in due {
            self.transmit_logged(&to, Message::PlanAck(ack));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(circuit: u64, name: &str) -> Plan {
        Plan {
            circuit,
            name: name.into(),
            source_text: format!("plan {name} {{ action {{ }} }}"),
            to: Address::new("t/r2/d").unwrap(),
            origin: Address::new("t/r1/o").unwrap(),
        }
    }

    #[test]
    fn steps_are_numbered_kept_and_sent_again_for_the_same_plan() {
        let mut d = Destination::default();
        let key = (Address::new("t/r1/o").unwrap(), 5);
        assert!(d.resend(&key, &plan(5, "p")).is_none());
        assert_eq!(d.begin(&key, &plan(5, "p")).seq, 1);
        d.claim(&key, "p").unwrap();
        assert!(
            d.event("p", PlanStep::Initiated).is_none(),
            "held while loading"
        );
        let (acks, cancel) = d.accept(&key);
        let seqs: Vec<(u64, PlanStep)> = acks.into_iter().map(|a| (a.seq, a.step)).collect();
        assert_eq!(seqs, [(2, PlanStep::Accepted), (3, PlanStep::Initiated)]);
        assert!(!cancel);
        let (_, ack) = d.event("p", PlanStep::Terminated).unwrap();
        assert_eq!(ack.seq, 4);
        assert!(d.event("p", PlanStep::Cancelled).is_none(), "closed");
        assert_eq!(d.resend(&key, &plan(5, "p")).map(|a| a.len()), Some(4));
        assert!(
            d.resend(&key, &plan(5, "q")).is_none(),
            "a restarted origin's new plan"
        );
    }

    #[test]
    fn a_long_reason_is_cut_at_a_character_boundary_and_says_so() {
        assert_eq!(bounded("short".into()), "short");
        let long = "é".repeat(MAX_REASON_BYTES);
        let cut = bounded(long.clone());
        assert!(cut.len() <= MAX_REASON_BYTES, "{}", cut.len());
        let kept = cut.split('\n').next().unwrap_or_default();
        assert!(long.starts_with(kept));
        let left_out = long.len() - kept.len();
        assert!(
            cut.ends_with(&format!("({left_out} more bytes of diagnostics)")),
            "{cut}"
        );
    }

    #[test]
    fn a_text_over_the_limit_is_not_kept() {
        let mut d = Destination::default();
        let key = (Address::new("t/r1/o").unwrap(), 9);
        let mut big = plan(9, "p");
        big.source_text.push_str(&" ".repeat(MAX_PLAN_TEXT_BYTES));
        d.begin(&key, &big);
        d.reject(&key, "too large".into());
        let kept: usize = d.circuits.values().map(|c| c.text.len()).sum();
        assert_eq!(kept, 0);
        let again = d.resend(&key, &big);
        assert!(
            again.is_none(),
            "sent again, it is refused again: {again:?}"
        );
    }

    #[test]
    fn a_name_is_claimed_by_one_circuit_at_a_time() {
        let mut d = Destination::default();
        let (a, b) = (
            (Address::new("t/r1/o").unwrap(), 1),
            (Address::new("t/r3/o").unwrap(), 1),
        );
        d.begin(&a, &plan(1, "p"));
        d.begin(&b, &plan(1, "p"));
        d.claim(&a, "p").unwrap();
        let err = d.claim(&b, "p").unwrap_err();
        assert!(err.contains("t/r1/o"), "{err}");
        d.reject(&a, "no".into());
        d.claim(&b, "p").unwrap();
    }

    #[test]
    fn a_last_step_is_repeated_four_times_with_back_off_and_no_other_step_is() {
        let mut d = Destination::default();
        let to = Address::new("t/r1/o").unwrap();
        let ack = |step| PlanAck {
            circuit: 1,
            seq: 1,
            step,
        };
        d.repeat_if_last(&to, &ack(PlanStep::Initiated), Duration::ZERO);
        d.repeat_if_last(&to, &ack(PlanStep::Terminated), Duration::ZERO);
        let mut sent_at = Vec::new();
        for tenth in 0..300 {
            let now = Duration::from_millis(100 * tenth);
            for (_, a) in d.repeats_due(now) {
                assert_eq!(a.step, PlanStep::Terminated);
                sent_at.push(now.as_secs());
            }
        }
        assert_eq!(sent_at, [1, 3, 7, 15]);
    }
}
