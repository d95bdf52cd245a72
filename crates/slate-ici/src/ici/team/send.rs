//! The ICI's glue for the team protocol's send side (docs/team-protocol.md, 2.3): a
//! member's team messages go to its gateway (`Uplink`, robot link, reliable) or wait
//! for one; the gateway frames its own and its members' messages, keeps the history,
//! publishes, and says the robot hello, the idle heartbeat and the remote robots'
//! interest (`TeamInterest`) to its members.
//!
//! Members' messages wait in the gateway's queue and are framed as fast as its token
//! bucket allows (`team/pace.rs`).
//!
//! Left for later steps: the members' exports in the hello (the gateway's own export
//! policy stands for the robot's).

use std::sync::Arc;
use std::time::Duration;

use slate_model::{Address, Context};

use super::frame::{
    RobotHeartbeat, RobotHello, StreamTag, TeamFrame, TeamInterest, TeamMsg, Uplink,
};
use super::gateway::{Framer, Gateway, Seen};
use super::history::HistoryLimits;
use super::nack::RepairScheduler;
use super::pace::{Held, Queued, TxQueue};
use crate::ici::Listen;
use crate::ici::classes::{ClassSet, context_bit};
use crate::ici::state::State;
use crate::{LinkKind, MsgKind};

impl State {
    /// A team message of this module (`State::publish(Team, ..)` with the protocol on):
    /// into the stream if this module is gateway, to the gateway otherwise, or held
    /// until there is one.
    pub fn team_out(&mut self, bytes: &[u8]) {
        self.team_elect();
        self.route(bytes.to_vec(), false);
    }

    /// Into the stream, to the gateway, or held; `answer` flags a part of a state answer.
    pub(super) fn route(&mut self, message: Vec<u8>, answer: bool) {
        match self.team.elected.clone() {
            Some(g) if g == self.me => {
                let me = self.me.clone();
                let mark = self.out.get(&LinkKind::Team).map(|o| o.seq);
                self.gateway_queue(&me, message, mark, answer);
            }
            Some(g) => self.uplink(&g, message, answer),
            None => {
                let from = self.me.clone();
                self.hold(Held {
                    from,
                    message,
                    mark: None,
                    answer,
                });
            }
        }
    }

    /// Keeps a message for the gateway to come, the oldest dropped past
    /// `MAX_PENDING_BYTES`.
    fn hold(&mut self, held: Held) {
        self.stats.team.pending_dropped += self.team.pending.push(held);
    }

    /// Hands a held message on once the election is acted on: this module's own is
    /// routed; a mate's is queued if this module is gateway, and dropped and counted
    /// otherwise (its inner position shows as a gap at receivers).
    fn release(&mut self, held: Held) {
        if held.from == self.me {
            return self.route(held.message, held.answer);
        }
        if self.team.gateway.is_none() {
            self.stats.team.uplinks_misrouted += 1;
            return;
        }
        self.gateway_queue(&held.from, held.message, held.mark, held.answer);
    }

    /// Hands a message to the gateway with this module's inner team position as its
    /// mark, so the gateway can list every member's position in its hello and full
    /// heartbeats (reports' `seq` is bit-packed: the gateway cannot read it).
    /// A message-less uplink is a `Mark`; `state_answer` flags a part of a state answer.
    pub(super) fn uplink(&mut self, gateway: &Address, message: Vec<u8>, state_answer: bool) {
        let up = Uplink {
            to: None,
            state_answer,
            mark: self.out.get(&LinkKind::Team).map(|o| o.seq),
            message,
        };
        self.send_to(gateway, MsgKind::Uplink, &TeamMsg::Uplink(up).encode());
    }

    /// A mate's message for the stream: this module must be gateway. One that came
    /// before this module acted on an election that may make it gateway is held until
    /// it does ([`Self::team_elect`]); one that reached a module that no longer is, or is
    /// not to be, is dropped and counted: its inner position shows as a gap at receivers.
    pub(super) fn on_uplink(&mut self, from: &Address, up: Uplink) {
        if self.team.gateway.is_none() {
            let undecided = self.team.elected.as_ref().is_none_or(|g| *g == self.me);
            if undecided {
                return self.hold(Held {
                    from: from.clone(),
                    message: up.message,
                    mark: up.mark,
                    answer: up.state_answer,
                });
            }
            self.stats.team.uplinks_misrouted += 1;
            return;
        }
        if self.gateway_index(from).is_none() {
            self.team_review();
        }
        self.gateway_queue(from, up.message, up.mark, up.state_answer);
    }

    /// Paces the team link at `rate_bps` from now on ([`crate::Ici::set_team_rate`]).
    pub(crate) fn set_team_rate(&mut self, rate_bps: u32) {
        let Some(protocol) = self.config.team_protocol.as_mut() else {
            return;
        };
        protocol.rate_bps = rate_bps;
        if let Some(gw) = self.team.gateway.as_mut() {
            gw.pace(protocol, self.now);
        }
    }

    /// Charges `bytes` this module put on `link` to its bucket while it is gateway:
    /// whatever goes on the robot's radio, stream or not (plans, acks), leaves that
    /// much less for the queue (2.3).
    pub(crate) fn team_aired(&mut self, link: LinkKind, bytes: usize) {
        if let (LinkKind::Team, Some(gw)) = (link, self.team.gateway.as_mut()) {
            gw.bucket.spend(bytes, self.now);
        }
    }

    fn gateway_index(&self, member: &Address) -> Option<u8> {
        self.team.gateway.as_ref()?.index_of(member.module())
    }

    /// Queues a member's message (empty: a `Mark`, its position alone; `answer`: a part
    /// of its state answer) for the radio, and frames what the bucket allows.
    fn gateway_queue(
        &mut self,
        member: &Address,
        message: Vec<u8>,
        mark: Option<u64>,
        answer: bool,
    ) {
        let index = self.gateway_index(member);
        let since = self.now;
        let Some(gw) = self.team.gateway.as_mut() else {
            let from = member.clone();
            return self.hold(Held {
                from,
                message,
                mark,
                answer,
            });
        };
        let Some(member) = index else {
            tracing::debug!(me = %self.me, %member, "a member's message dropped: not indexed");
            gw.unindexed += 1;
            return;
        };
        let dropped = gw.queue.push(Queued {
            member,
            message,
            mark,
            since,
            answer,
        });
        let t = &mut self.stats.team;
        t.queue_dropped += dropped;
        t.queue_max_bytes = t.queue_max_bytes.max(gw.queue.bytes() as u64);
        self.pump();
    }

    /// Frames queued messages while the bucket allows, and publishes the frames they
    /// close; with the queue empty, the open frame once its batch is up. A member's
    /// position is taken for the hello and full heartbeats once its message went out.
    pub(super) fn pump(&mut self) {
        let now = self.now;
        loop {
            let Some(gw) = self.team.gateway.as_mut() else {
                return;
            };
            if !gw.bucket.ready(now) {
                return;
            }
            let Some(q) = gw.queue.pop() else {
                let due = gw.framer.due(now);
                return due.into_iter().for_each(|f| self.publish_frame(f));
            };
            let t = &mut self.stats.team;
            t.queue_max_wait = t.queue_max_wait.max(now.saturating_sub(q.since));
            let (member, mark) = (q.member, q.mark);
            let frames = match q.message.is_empty() {
                true => Vec::new(),
                false => gw.framer.push(member, q.message, now),
            };
            frames.into_iter().for_each(|f| self.publish_frame(f));
            if let Some(gw) = self.team.gateway.as_mut() {
                gw.framed(member, mark);
            }
        }
    }

    /// Publishes a closed frame and keeps it in the history.
    fn publish_frame(&mut self, frame: TeamFrame) {
        let (now, seq) = (self.now, frame.seq);
        let msg = TeamMsg::Frame(frame);
        let bytes: Arc<[u8]> = msg.encode().into();
        if let Some(gw) = self.team.gateway.as_mut() {
            gw.last_sent = now;
            gw.frame_out();
            if let Err(e) = gw.history.push(seq, bytes.clone(), now, &[]) {
                tracing::debug!(error = %e, "frame not kept in the history");
            }
        }
        self.publish_team(MsgKind::TeamFrame, &bytes, &super::count::inner_of(&msg));
    }

    /// Acts on the election: takes or leaves the gateway role, and hands the messages
    /// held to the gateway now known.
    /// The election is not acted on during the first robot heartbeat interval after
    /// start, while the mates' hellos arrive: otherwise every module that starts
    /// first would speak for its robot for a moment (start-up split brain, 2.1). Team
    /// messages wait in `pending` meanwhile.
    pub(crate) fn team_elect(&mut self) {
        let started = *self.team.started.get_or_insert(self.now);
        if self.now.saturating_sub(started) < self.config.robot.heartbeat {
            return;
        }
        let chosen = self.gateway();
        if chosen == self.team.elected {
            return;
        }
        self.tick_again = true;
        let mine = chosen.as_ref() == Some(&self.me);
        let resigned = self.team.gateway.is_some() && !mine;
        if resigned {
            self.resign();
        }
        self.team.elected = chosen;
        if mine {
            self.take_gateway_role();
        } else if let Some(gateway) = self.team.elected.clone().filter(|_| resigned) {
            // What this module said as gateway went out in its own stream, which nobody
            // speaks for any more (a split brain that ended): the gateway now learns where
            // its messages got to, and its full heartbeats tell the team, so that a lost
            // tail of that stream shows as this module's gap at every receiver.
            self.uplink(&gateway, Vec::new(), false);
        }
        if self.team.elected.is_some() {
            let held = self.team.pending.drain();
            held.into_iter().for_each(|h| self.release(h));
        }
    }

    /// Starts a new epoch of the robot stream: a new tag, positions from 1.
    fn take_gateway_role(&mut self) {
        let Some(protocol) = &self.config.team_protocol else {
            return;
        };
        let epoch = self.board.clock().now().raw();
        let framer = Framer::new(protocol.mtu, protocol.batch);
        let limits = HistoryLimits {
            bytes: protocol.history_bytes,
            age: protocol.history_age,
        };
        let tag = StreamTag::of(&self.me, epoch);
        let mut gateway = Gateway::new(tag, epoch, framer, limits);
        gateway.repairs = RepairScheduler::new(super::repair::repair_timing(protocol));
        gateway.queue = TxQueue::new(protocol.history_bytes);
        gateway.pace(protocol, self.now);
        // The hello opens the stream; the idle heartbeat counts from it.
        (gateway.last_sent, gateway.last_full) = (self.now, self.now);
        self.team.gateway = Some(gateway);
        self.team.interest_dirty = true;
        self.team_review();
        // What this module sent through the previous gateway counts as said.
        let own = self.out.get(&LinkKind::Team).map(|o| o.seq);
        if let Some(gw) = self.team.gateway.as_mut() {
            let index = gw.index_of(self.me.module());
            gw.sent_inner(index.unwrap_or(u8::MAX), own);
        }
    }

    /// Leaves the role: the queued messages and the open frame go out first, unpaced
    /// (they would otherwise be lost with the role).
    fn resign(&mut self) {
        let mut frames = Vec::new();
        if let Some(gw) = self.team.gateway.as_mut() {
            for q in gw.queue.drain() {
                if !q.message.is_empty() {
                    frames.extend(gw.framer.push(q.member, q.message, self.now));
                }
            }
            frames.extend(gw.framer.flush());
        }
        frames.into_iter().for_each(|f| self.publish_frame(f));
        self.team.gateway = None;
    }

    /// The gateway's view of its members: itself and the mates whose hello it heard.
    fn team_review(&mut self) {
        let mut seen = vec![self.seen_self()];
        let mates = self.mates().filter(|(_, p)| !p.observer);
        seen.extend(mates.filter_map(|(a, p)| {
            Some(Seen {
                name: a.module().into(),
                incarnation: p.incarnation?,
                alive: p.alive == Some(true),
                listener: p.listener,
            })
        }));
        let Some(gw) = self.team.gateway.as_mut() else {
            return;
        };
        if gw.review(&seen).hello {
            self.team.interest_dirty = true;
        }
    }

    /// Tells the transport whether to hand this module team publications: a gateway
    /// always listens, a member unless its setting is `Never`. `Auto` listens until the
    /// robot hellos carry every member's exports (the rule of 2.1 needs them).
    fn team_listen(&mut self) {
        let never = self.config.team_protocol.as_ref().map(|p| p.listen) == Some(Listen::Never);
        let on = self.team.gateway.is_some() || !never;
        if self.team.listening != Some(on) {
            self.team.listening = Some(on);
            // What this module hears decides when the dead are gone (`deaf_to`).
            self.forget_from = Duration::ZERO;
            self.transport.listen(LinkKind::Team, on);
            if on {
                self.hear_from_now();
            }
        }
    }

    /// A member that starts listening begins to time the other robots' modules by their
    /// silence from now: before, it could not hear them (`State::deaf_to`).
    fn hear_from_now(&mut self) {
        let now = self.now;
        let team = self.peers.values_mut().filter(|p| p.link == LinkKind::Team);
        team.for_each(|p| p.last_heard = p.last_heard.max(now));
        self.timeouts_from = self.timeouts_from.min(now);
    }

    fn seen_self(&self) -> Seen {
        let listen = self.config.team_protocol.as_ref().map(|p| p.listen);
        Seen {
            name: self.me.module().into(),
            incarnation: self.incarnation,
            alive: true,
            listener: listen != Some(Listen::Never),
        }
    }

    /// The team protocol's timers: the election, and for the gateway the batch, the
    /// robot hello, the idle heartbeat and the members' `TeamInterest`.
    pub(crate) fn team_tick(&mut self) {
        if self.config.team_protocol.is_none() {
            return;
        }
        self.team_elect();
        self.team_listen();
        self.retry_undecoded();
        self.nack_tick();
        self.deferred_state_answer();
        if self.team.gateway.is_none() {
            return;
        }
        self.team_review();
        self.repair_tick();
        self.pump();
        self.forward_held_state_asks();
        self.robot_hello_if_due();
        self.robot_heartbeat_if_due();
        self.team_interest_if_changed();
    }

    /// The earliest instant at which [`team_tick`](Self::team_tick) may have something
    /// to do, if nothing reaches this module before (see `State::next_tick`). What
    /// depends on the state alone (the election, the gateway's view of its members,
    /// whether to listen) settles in the tick that sees it change, and what changes it
    /// between ticks reaches the module from outside or is a timer that asks for the
    /// next tick itself (`State::tick_again`).
    pub(crate) fn team_next_tick(&self) -> Duration {
        let Some(protocol) = &self.config.team_protocol else {
            return Duration::MAX;
        };
        let Some(started) = self.team.started else {
            return Duration::ZERO;
        };
        let mut next = Duration::MAX;
        let election = started.saturating_add(self.config.robot.heartbeat);
        if self.now < election {
            next = election;
        }
        if !self.team.undecoded.is_empty() {
            // Retried once their robot's stream has no gap left: a message that repairs
            // it ticks the module, but a timer of this tick may have closed a gap too.
            let gapped = self.team_gapped_robots();
            if self.team.undecoded.iter().any(|u| !gapped.holds(&u.from)) {
                return Duration::ZERO;
            }
        }
        let team_timeout = self.config.team.timeout;
        for s in self.team.speakers.values() {
            if let Some(ask) = &s.hello_ask {
                // The ask fires at its due time, or is dropped once the robot is silent
                // past the timeout.
                let silent = s.last_heard.saturating_add(team_timeout);
                next = next
                    .min(ask.due)
                    .min(silent.saturating_add(Duration::from_nanos(1)));
            }
            if let Some(ask) = s.state_ask.as_ref().filter(|_| s.hello.is_some()) {
                next = next.min(ask.due);
            }
        }
        if let Some(nacks) = &self.team.nacks {
            if nacks.has_output() {
                return Duration::ZERO;
            }
            next = next.min(nacks.next_due().unwrap_or(Duration::MAX));
        }
        let answering = &self.team.answering;
        if answering.deferred.is_some() {
            let interval = protocol.answer_interval;
            next = next.min(answering.answered.map_or(Duration::ZERO, |t| t + interval));
        }
        let Some(gw) = &self.team.gateway else {
            return next;
        };
        if let Some(closes) = gw.repairs.next_due() {
            next = next.min(closes.max(gw.repair_bucket.ready_at()));
        }
        let data = gw.bucket.ready_at();
        let framed = match gw.queue.is_empty() {
            true => gw.framer.next_due(),
            false => Some(Duration::ZERO),
        };
        if let Some(at) = framed {
            next = next.min(at.max(data));
        }
        if !gw.held_asks.is_empty() {
            let waited = gw
                .held_since
                .map_or(Duration::MAX, |t| t + protocol.answer_interval);
            let emptied = match gw.queue.is_empty() {
                true => Duration::ZERO,
                false => data,
            };
            next = next.min(waited).min(emptied);
        }
        if gw.hello_due {
            let spaced = gw
                .hello_sent
                .map_or(Duration::ZERO, |t| t + protocol.hello_min_interval);
            next = next.min(spaced);
        }
        let idle = self.config.team.heartbeat;
        next = next.min(match gw.heartbeat_due {
            true => Duration::ZERO,
            false => gw.last_sent.saturating_add(idle),
        });
        if protocol.full_every > 0 {
            next = next.min(gw.last_full.saturating_add(idle * protocol.full_every));
        }
        if self.team.interest_dirty {
            return Duration::ZERO;
        }
        next
    }

    fn robot_hello_if_due(&mut self) {
        let now = self.now;
        let Some(min) = self
            .config
            .team_protocol
            .as_ref()
            .map(|p| p.hello_min_interval)
        else {
            return;
        };
        let due = self.team.gateway.as_ref();
        if !due.is_some_and(|gw| gw.hello_is_due(now, min)) {
            return;
        }
        // The members' union walks every peer: taken only when a hello goes.
        let interest = self.robot_interest();
        let Some(gw) = self.team.gateway.as_mut() else {
            return;
        };
        (gw.hello_due, gw.hello_sent, gw.last_sent) = (false, Some(now), now);
        let hello = RobotHello {
            version: gw.version,
            tag: gw.tag,
            gw_incarnation: gw.epoch,
            observer: self.config.observer,
            interest,
            exports: self.config.export.clone(),
            members: gw.members.clone(),
        };
        self.publish_team_msg(MsgKind::RobotHello, &TeamMsg::Hello(hello));
    }

    /// The union of the members' interests without SELF: an object of another robot
    /// never arrives in SELF. Classes left with no context are dropped.
    fn robot_interest(&self) -> ClassSet {
        let mates = self
            .mates()
            .map(|(_, p)| p)
            .filter(|p| p.alive == Some(true));
        let sets =
            std::iter::once(&self.config.interest).chain(mates.filter_map(|p| p.interest.as_ref()));
        union_without(sets, context_bit(Context::Self_))
    }

    fn robot_heartbeat_if_due(&mut self) {
        let now = self.now;
        let idle = self.config.team.heartbeat;
        let full_every = self
            .config
            .team_protocol
            .as_ref()
            .map_or(0, |p| p.full_every);
        let Some(gw) = self.team.gateway.as_mut() else {
            return;
        };
        let full = gw.full_is_due(now, idle * full_every);
        if !(full || gw.heartbeat_is_due(now, idle)) {
            return;
        }
        gw.heartbeats += 1;
        (gw.heartbeat_due, gw.last_sent) = (false, now);
        if full {
            gw.last_full = now;
        }
        let hb = RobotHeartbeat {
            tag: gw.tag,
            hello_version: gw.version,
            seq: gw.framer.position(),
            alive: gw.alive_bits(),
            positions: full.then(|| gw.members.iter().map(|m| m.inner_seq).collect()),
        };
        self.stats.liveliness.heartbeats_sent += 1;
        self.publish_team_msg(MsgKind::RobotHeartbeat, &TeamMsg::Heartbeat(hb));
    }

    /// Tells the members the remote robots' union interest when it changed (a remote
    /// hello, a new member, a takeover), and takes it for this module's own sends. Not
    /// before a robot hello is heard: until then members send everything they export
    /// (an empty interest would keep their writes home, to be sent again as state).
    fn team_interest_if_changed(&mut self) {
        if !std::mem::take(&mut self.team.interest_dirty) {
            return;
        }
        let hellos = self.team.speakers.values().filter_map(|s| s.hello.as_ref());
        if hellos.clone().next().is_none() {
            // No robot heard yet: members send everything they export until one is.
            return;
        }
        let interest = union_without(hellos.clone().map(|h| &h.interest), 0);
        let exports = union_without(hellos.map(|h| &h.exports), 0);
        let version = self.team.remote.as_ref().map_or(1, |r| r.version + 1);
        let remote = TeamInterest {
            version,
            interest,
            exports,
        };
        let bytes = TeamMsg::Interest(remote.clone()).encode();
        self.take_remote_interest(remote);
        self.publish_now(LinkKind::Robot, MsgKind::TeamInterest, &bytes);
    }

    /// A member takes its gateway's word for what the other robots model, and answers
    /// with a `Mark` (its inner team position, no message). A gateway says its interest
    /// when it takes over and when its members change, so the mark reaches a gateway
    /// that acts: its hello and full heartbeats then list this member's position, and
    /// receivers find a tail lost with uplinks that reached no gateway (one that died,
    /// or that had not yet taken the role).
    pub(super) fn on_team_interest(&mut self, from: &Address, remote: TeamInterest) {
        self.take_remote_interest(remote);
        self.uplink(from, Vec::new(), false);
    }

    /// What the other robots model, for this module's own sends. When it widens after
    /// this module kept something home (nobody modelled it), its state goes to them:
    /// no receiver knows to ask for what it never heard of.
    fn take_remote_interest(&mut self, remote: TeamInterest) {
        let before = self.team.remote.replace(remote);
        let widened = match (&before, &self.team.remote) {
            (Some(b), Some(now)) => !b.interest.covers(&now.interest),
            _ => false,
        };
        if widened && std::mem::take(&mut self.team.kept_home) {
            self.team_answer_unasked();
        }
    }

    /// Does any other robot model this item (as the gateway last said)? Before it has
    /// said, everything exported goes: receivers drop what they do not model.
    pub(crate) fn team_wants(&self, item: &crate::ici::send::Item) -> bool {
        let Some(remote) = &self.team.remote else {
            return true;
        };
        let (lineage, context, _, is_class) = item.dest(&self.me);
        if is_class {
            return remote.interest.relates_to_class(lineage, &self.catalog);
        }
        // SELF on this robot is SYSTEM on the others.
        let there = if context == Context::Self_ {
            Context::System
        } else {
            context
        };
        remote.interest.contains(lineage, there)
    }

    /// What the robot hello says changed (a member's interest): the gateway moves its
    /// version on and says it again (at most once per `hello_min_interval`).
    pub(crate) fn team_hello_changed(&mut self) {
        if let Some(gw) = self.team.gateway.as_mut() {
            gw.version = gw.version.wrapping_add(1);
            gw.hello_due = true;
        }
    }
}

/// The union of class sets, one rule per class, without the context bits `drop`.
fn union_without<'a>(sets: impl Iterator<Item = &'a ClassSet>, drop: u8) -> ClassSet {
    let mut masks: std::collections::BTreeMap<Arc<str>, u8> = Default::default();
    for (class, mask) in sets.flat_map(|s| s.rules()) {
        *masks.entry(class.clone()).or_default() |= mask & !drop;
    }
    masks
        .into_iter()
        .fold(ClassSet::none(), |set, (c, m)| set.with(&c, m))
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use slate_testing::addr;

    use super::*;
    use crate::SimNet;
    use crate::ici::team::MAX_PENDING_BYTES;
    use crate::ici::{IciConfig, TeamProtocol};

    /// `t/r0/m0` alone on its robot, with this election priority.
    fn state(priority: Option<u8>) -> (SimNet, State) {
        let protocol = TeamProtocol::radio().priority(priority);
        let config = IciConfig::default().team_protocol(Some(protocol));
        let (net, state) = super::super::test_state::alone("t/r0/m0", config);
        (net, state)
    }

    #[test]
    fn a_member_with_no_gateway_holds_its_messages_up_to_a_byte_limit() {
        let (_net, mut st) = state(None);
        st.now = Duration::from_secs(1);
        for i in 0..200u8 {
            st.publish(LinkKind::Team, MsgKind::Report, &[0x11, i]);
        }
        assert_eq!(st.team.pending.len(), 200, "400 bytes are few");
        let large = MAX_PENDING_BYTES / 10 + 1;
        for i in 0..10u8 {
            let mut report = vec![0x11; large];
            report[1] = i;
            st.publish(LinkKind::Team, MsgKind::Report, &report);
        }
        assert_eq!(st.stats.team.pending_dropped, 201, "the oldest went");
        let first = st.team.pending.iter().next();
        assert_eq!(first.map(|h| h.message[1]), Some(1));
        let held: usize = st.team.pending.iter().map(|h| h.message.len()).sum();
        assert!(held <= MAX_PENDING_BYTES);
    }

    #[test]
    fn the_election_waits_one_robot_heartbeat_after_start() {
        let (_net, mut st) = state(Some(0));
        st.team_tick();
        st.publish(LinkKind::Team, MsgKind::Report, &[0x11, 1]);
        assert_eq!((st.team.elected.clone(), st.team.pending.len()), (None, 1));
        st.now += st.config.robot.heartbeat;
        st.team_tick();
        assert_eq!(st.team.elected, Some(addr("t/r0/m0")));
        assert!(st.team.pending.is_empty(), "handed to the stream");
    }

    /// `st` elected gateway of its robot (alone, priority 0), at its start plus one
    /// robot heartbeat.
    fn elected(st: &mut State) {
        st.team_tick();
        st.now += st.config.robot.heartbeat;
        st.team_tick();
        assert!(st.team.gateway.is_some());
    }

    /// Messages of `kind` this state published on the team link.
    fn sent(st: &State, kind: MsgKind) -> u64 {
        super::super::test_state::sent(st, LinkKind::Team, kind)
    }

    /// Bytes this state published on the team link, every kind.
    fn team_bytes(st: &State) -> u64 {
        let team = st
            .stats
            .traffic
            .iter()
            .filter(|((l, _), _)| *l == LinkKind::Team);
        team.map(|(_, t)| t.sent_bytes).sum()
    }

    /// Publishes `n` own reports of `len` bytes at once, the k-th at inner position k.
    fn burst(st: &mut State, n: u64, len: usize) {
        for k in 1..=n {
            st.out.get_mut(&LinkKind::Team).expect("team outbound").seq = k;
            let mut report = vec![0x11; len];
            report[1] = k as u8;
            st.publish(LinkKind::Team, MsgKind::Report, &report);
        }
    }

    #[test]
    fn a_gateway_never_offers_the_radio_more_than_its_rate() {
        let (_net, mut st) = state(Some(0));
        elected(&mut st);
        let protocol = st.config.team_protocol.clone().expect("protocol");
        let (start, before) = (st.now, team_bytes(&st));
        burst(&mut st, 60, 200);
        for step in 1..=400u64 {
            st.now = start + Duration::from_millis(50 * step);
            st.team_tick();
            let elapsed = st.now - start;
            let earned = elapsed.as_secs_f64() * f64::from(protocol.rate_bps) / 8.0;
            // A bucket one frame deep, and the frame that took the last of it.
            let allowed = earned as u64 + 2 * protocol.mtu as u64;
            let aired = team_bytes(&st) - before;
            assert!(
                aired <= allowed,
                "{aired} B on the air after {elapsed:?}: more than {allowed} B"
            );
        }
        assert_eq!(
            sent(&st, MsgKind::Report),
            60,
            "every report went out in the end"
        );
    }

    #[test]
    fn a_gateway_moved_to_a_slower_link_owes_nothing_it_sent_before() {
        // On deck (a fast link) the console's gateway sends kilobytes of plans, charged
        // to its bucket; at sea the acoustic share is a few bytes a second. Owed at that
        // rate, they would hold back every frame for minutes.
        let (_net, mut st) = state(Some(0));
        elected(&mut st);
        st.team_aired(LinkKind::Team, 6_000);
        st.set_team_rate(70);
        assert_eq!(
            st.config.team_protocol.as_ref().map(|p| p.rate_bps),
            Some(70)
        );
        burst(&mut st, 1, 20);
        st.now += Duration::from_secs(1);
        st.team_tick();
        assert_eq!(sent(&st, MsgKind::Report), 1, "the report went at once");
    }

    #[test]
    fn a_members_position_is_told_only_once_its_message_went_out() {
        let (_net, mut st) = state(Some(0));
        elected(&mut st);
        burst(&mut st, 60, 200);
        st.now += Duration::from_millis(300);
        st.team_tick();
        let told = |st: &State| st.team.gateway.as_ref().expect("gateway").members[0].inner_seq;
        let aired = sent(&st, MsgKind::Report);
        assert!(aired < 60, "the radio cannot carry 12 kB at once");
        assert!(
            told(&st) <= aired,
            "position {} told with {aired} reports on the air",
            told(&st)
        );
        for _ in 0..200 {
            st.now += Duration::from_millis(100);
            st.team_tick();
        }
        assert_eq!(told(&st), 60);
    }

    fn interest(version: u64, interest: ClassSet) -> TeamInterest {
        TeamInterest {
            version,
            interest,
            exports: ClassSet::none(),
        }
    }

    #[test]
    fn a_widened_interest_is_not_answered_when_nothing_was_kept_home() {
        let (_net, mut st) = state(Some(0));
        st.take_remote_interest(interest(1, ClassSet::none().class("Rock")));
        st.take_remote_interest(interest(2, ClassSet::all()));
        assert_eq!(st.stats.team.state_answers, 0, "nothing was withheld");
    }

    #[test]
    fn a_gateway_frames_its_own_messages_keeps_them_and_says_its_hello() {
        let (_net, mut st) = state(Some(0));
        st.team_tick();
        st.now += Duration::from_millis(300);
        st.publish(LinkKind::Team, MsgKind::Report, &[0x11, 1]);
        st.publish(LinkKind::Team, MsgKind::Report, &[0x11, 2]);
        st.now += Duration::from_millis(250);
        st.team_tick();
        let gw = st.team.gateway.as_ref().expect("gateway");
        assert_eq!((gw.framer.position(), gw.history.len()), (1, 1));
        assert!(gw.hello_sent.is_some());
        let sent = |kind| {
            st.stats
                .traffic
                .get(&(LinkKind::Team, kind))
                .map_or(0, |t| t.sent_msgs)
        };
        assert_eq!(
            (sent(MsgKind::TeamFrame), sent(MsgKind::RobotHello)),
            (1, 1)
        );
        assert_eq!(
            (sent(MsgKind::Report), sent(MsgKind::TeamFrame)),
            (2, 1),
            "members' messages count by kind inside their one frame"
        );
    }
}
