//! The ICI's glue for the team protocol's send side (docs/team-protocol.md, 2.3): a
//! member's team messages go to its gateway (`Uplink`, robot link, reliable) or wait
//! for one; the gateway frames its own and its members' messages, keeps the history,
//! publishes, and says the robot hello, the idle heartbeat and the remote robots'
//! interest (`TeamInterest`) to its members.
//!
//! Left for later steps: the token bucket and priority queue (frames go out as they
//! close), `Mark`s after a takeover, the members' exports in the hello (the gateway's
//! own export policy stands for the robot's) and their inner positions (only the
//! gateway's own are known).

use std::sync::Arc;

use slate_model::{Address, Context};

use super::MAX_PENDING;
use super::frame::{
    RobotHeartbeat, RobotHello, StreamTag, TeamFrame, TeamInterest, TeamMsg, Uplink,
};
use super::gateway::{Framer, Gateway, Seen};
use super::history::HistoryLimits;
use super::nack::RepairScheduler;
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
        self.route(bytes.to_vec());
    }

    fn route(&mut self, message: Vec<u8>) {
        match self.team.elected.clone() {
            Some(g) if g == self.me => {
                let index = self
                    .team
                    .gateway
                    .as_ref()
                    .and_then(|gw| gw.index_of(self.me.module()));
                self.gateway_push(index, message);
            }
            Some(g) => self.uplink(&g, message, false),
            None => self.hold(message),
        }
    }

    /// Keeps a message for the gateway to come, the oldest dropped past `MAX_PENDING`.
    fn hold(&mut self, message: Vec<u8>) {
        if self.team.pending.len() >= MAX_PENDING {
            self.team.pending.pop_front();
            self.stats.team.pending_dropped += 1;
        }
        self.team.pending.push_back(message);
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

    /// A mate's message for the stream: this module must be gateway (an uplink that
    /// reached a module that no longer is, or not yet, is dropped and counted: its
    /// inner position shows as a gap at receivers).
    pub(super) fn on_uplink(&mut self, from: &Address, up: Uplink) {
        if self.team.gateway.is_none() {
            self.stats.team.uplinks_misrouted += 1;
            return;
        }
        if self.gateway_index(from).is_none() {
            self.team_review();
        }
        let index = self.gateway_index(from);
        if let (Some(gw), Some(i)) = (self.team.gateway.as_mut(), index) {
            gw.sent_inner(i, up.mark);
        }
        if !up.message.is_empty() {
            self.gateway_push(index, up.message);
        }
    }

    fn gateway_index(&self, member: &Address) -> Option<u8> {
        self.team.gateway.as_ref()?.index_of(member.module())
    }

    /// Frames a member's message; publishes the frames it closed.
    fn gateway_push(&mut self, index: Option<u8>, message: Vec<u8>) {
        let now = self.now;
        let Some(gw) = self.team.gateway.as_mut() else {
            return self.hold(message);
        };
        let Some(index) = index else {
            gw.unindexed += 1;
            return;
        };
        let frames = gw.framer.push(index, message, now);
        frames.into_iter().for_each(|f| self.publish_frame(f));
    }

    /// Publishes a closed frame and keeps it in the history.
    fn publish_frame(&mut self, frame: TeamFrame) {
        let (now, seq) = (self.now, frame.seq);
        let msg = TeamMsg::Frame(frame);
        let bytes: Arc<[u8]> = msg.encode().into();
        if let Some(gw) = self.team.gateway.as_mut() {
            gw.last_sent = now;
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
        let mine = chosen.as_ref() == Some(&self.me);
        if self.team.gateway.is_some() && !mine {
            self.resign();
        }
        self.team.elected = chosen;
        if mine {
            self.take_gateway_role();
        }
        if self.team.elected.is_some() {
            let held: Vec<Vec<u8>> = self.team.pending.drain(..).collect();
            held.into_iter().for_each(|m| self.route(m));
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
        // The hello opens the stream; the idle heartbeat counts from it.
        (gateway.last_sent, gateway.last_full) = (self.now, self.now);
        self.team.gateway = Some(gateway);
        self.team.interest_dirty = true;
        self.team_review();
    }

    /// Leaves the role: the open frame goes out first.
    fn resign(&mut self) {
        let open = self.team.gateway.as_mut().and_then(|gw| gw.framer.flush());
        open.into_iter().for_each(|f| self.publish_frame(f));
        self.team.gateway = None;
    }

    /// The gateway's view of its members: itself and the mates whose hello it heard.
    fn team_review(&mut self) {
        let mut seen = vec![self.seen_self()];
        let mates = self
            .peers
            .iter()
            .filter(|(_, p)| p.link == LinkKind::Robot && !p.observer);
        seen.extend(mates.filter_map(|(a, p)| {
            Some(Seen {
                name: a.module().into(),
                incarnation: p.incarnation?,
                alive: p.alive == Some(true),
                listener: p.listener,
            })
        }));
        let own = self.out.get(&LinkKind::Team).map(|o| o.seq);
        let Some(gw) = self.team.gateway.as_mut() else {
            return;
        };
        if gw.review(&seen).hello {
            self.team.interest_dirty = true;
        }
        let index = gw.index_of(self.me.module());
        gw.sent_inner(index.unwrap_or(u8::MAX), own);
    }

    /// Tells the transport whether to hand this module team publications: a gateway
    /// always listens, a member unless its setting is `Never`. `Auto` listens until the
    /// robot hellos carry every member's exports (the rule of 2.1 needs them).
    fn team_listen(&mut self) {
        let never = self.config.team_protocol.as_ref().map(|p| p.listen) == Some(Listen::Never);
        let on = self.team.gateway.is_some() || !never;
        if self.team.listening != Some(on) {
            self.team.listening = Some(on);
            self.transport.listen(LinkKind::Team, on);
        }
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
        let now = self.now;
        let due = self.team.gateway.as_mut().and_then(|gw| gw.framer.due(now));
        due.into_iter().for_each(|f| self.publish_frame(f));
        self.robot_hello_if_due();
        self.robot_heartbeat_if_due();
        self.team_interest_if_changed();
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
        let interest = self.robot_interest();
        let Some(gw) = self.team.gateway.as_mut() else {
            return;
        };
        if !gw.hello_is_due(now, min) {
            return;
        }
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
        self.publish_now(
            LinkKind::Team,
            MsgKind::RobotHello,
            &TeamMsg::Hello(hello).encode(),
        );
    }

    /// The union of the members' interests without SELF: an object of another robot
    /// never arrives in SELF. Classes left with no context are dropped.
    fn robot_interest(&self) -> ClassSet {
        let mates = self
            .peers
            .values()
            .filter(|p| p.link == LinkKind::Robot && p.alive == Some(true));
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
        self.publish_now(
            LinkKind::Team,
            MsgKind::RobotHeartbeat,
            &TeamMsg::Heartbeat(hb).encode(),
        );
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

    /// What the other robots model, for this module's own sends. When it widens, this
    /// module's state goes to them: what it wrote that nobody modelled then was kept
    /// home, and no receiver knows to ask for it.
    fn take_remote_interest(&mut self, remote: TeamInterest) {
        let before = self.team.remote.replace(remote);
        let widened = match (&before, &self.team.remote) {
            (Some(b), Some(now)) => !b.interest.covers(&now.interest),
            _ => false,
        };
        if widened {
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
    use crate::ici::{IciConfig, TeamProtocol};

    /// `t/r0/m0` alone on its robot, with this election priority.
    fn state(priority: Option<u8>) -> (SimNet, State) {
        let protocol = TeamProtocol::radio().priority(priority);
        let config = IciConfig::default().team_protocol(Some(protocol));
        let (net, state) = super::super::test_state::alone("t/r0/m0", config);
        (net, state)
    }

    #[test]
    fn a_member_with_no_gateway_holds_at_most_64_messages() {
        let (_net, mut st) = state(None);
        st.now = Duration::from_secs(1);
        for i in 0..70u8 {
            st.publish(LinkKind::Team, MsgKind::Report, &[0x11, i]);
        }
        assert_eq!(st.team.pending.len(), MAX_PENDING);
        assert_eq!(st.stats.team.pending_dropped, 6);
        assert_eq!(
            st.team.pending.front().map(|m| m[1]),
            Some(6),
            "the oldest went"
        );
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
