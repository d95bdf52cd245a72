//! The ICI's glue for the team protocol's receive side (docs/team-protocol.md, 2.4):
//! per remote gateway, the robot hello (members, incarnations, liveliness) and the
//! stream tracker (`Outer`); frames are unwrapped and each member's message handed to
//! `State::on_message(member, inner)`, today's per-source machinery. Frames that come
//! before their robot's hello are parked.
//!
//! Gaps found here (`stream_changed`), repairs, NACKs and `Gone` go to `repair.rs`
//! (step 10); state asks and `StateRequest`s to `answer.rs` (step 11). `Want` and
//! addressed parts are decoded and dropped.

use std::collections::VecDeque;

use slate_model::Address;

use super::frame::{
    Forward, MAX_MEMBERS, PartOf, RobotHeartbeat, RobotHello, StreamTag, TeamFrame, TeamMsg,
};
use super::outer::{Change, Fragment, Heard, Outer};
use super::repair::ANY_TAG;
use crate::ici::state::State;
use crate::{LinkKind, MsgKind};

/// Frames parked per gateway while its hello is not known; the oldest go first.
pub(crate) const MAX_PARKED: usize = 64;
/// Remote gateways followed; past it, the one heard least recently is forgotten.
pub(crate) const MAX_SPEAKERS: usize = 256;
/// Messages kept for want of names while their robot's stream has a gap; past it, the
/// oldest one's source is asked for its state instead.
pub(crate) const MAX_UNDECODED: usize = 256;

/// A member's message that did not decode for want of names, kept while its robot's
/// stream has a gap: the frame that announced them is likely among the missing, and
/// its repair makes the message decode (asking for the whole state would cost far
/// more, and every receiver that lost the frame would ask).
#[derive(Debug)]
pub(crate) struct Undecoded {
    pub from: Address,
    pub kind: MsgKind,
    pub bytes: Vec<u8>,
}

/// What a receiver holds of one remote gateway's stream.
#[derive(Debug, Default)]
pub(crate) struct Speaker {
    pub hello: Option<RobotHello>,
    /// The members' addresses, by index (`None`: a name that is no address segment).
    pub members: Vec<Option<Address>>,
    pub outer: Option<Outer>,
    /// The members alive as the last hello or heartbeat said (bit i: member i).
    pub alive: u32,
    /// Frames waiting for the hello (at most `MAX_PARKED`).
    pub parked: VecDeque<TeamFrame>,
    /// The NACK of its hello, while frames are parked and the hello is missing.
    pub hello_ask: Option<super::repair::HelloAsk>,
    /// The state ask for members of this robot, waiting for its back-off.
    pub state_ask: Option<super::answer::StateAskDue>,
    /// When anything was last heard from it (to forget the stalest past the limit).
    pub last_heard: std::time::Duration,
}

/// Is this a team protocol frame (which never travels inside another)?
pub(crate) fn is_team_kind(kind: MsgKind) -> bool {
    use MsgKind::*;
    matches!(
        kind,
        TeamFrame
            | TeamRepair
            | RobotHello
            | RobotHeartbeat
            | Nack
            | Gone
            | Uplink
            | Want
            | StateRequest
            | TeamInterest
            | Fill
            | Forward
    )
}

impl State {
    /// A team protocol frame from `from` (the switch off: refused and counted).
    pub(crate) fn on_team(&mut self, from: &Address, bytes: &[u8]) {
        let decoded = self
            .config
            .team_protocol
            .as_ref()
            .map(|_| TeamMsg::decode(bytes));
        self.count_team_received(from, bytes, decoded.as_ref().and_then(|d| d.as_ref().ok()));
        let msg = match decoded {
            Some(Ok(msg)) => msg,
            None => return self.stats.team.refused += 1,
            Some(Err(e)) => {
                self.stats.team.refused += 1;
                return tracing::debug!(from = %from, error = %e, "team frame refused");
            }
        };
        self.on_team_msg(from, msg, bytes);
    }

    /// A decoded team protocol frame from `from` (`bytes`, as it came).
    fn on_team_msg(&mut self, from: &Address, msg: TeamMsg, bytes: &[u8]) {
        let team_link = LinkKind::between(&self.me, from) == LinkKind::Team;
        if team_link {
            self.forward_to_deaf_mates(from, &msg, bytes);
        }
        match msg {
            TeamMsg::Frame(f) if team_link => self.on_team_frame(from, f),
            TeamMsg::Hello(h) if team_link => self.on_robot_hello(from, h),
            TeamMsg::Heartbeat(hb) if team_link => self.on_robot_heartbeat(from, hb),
            TeamMsg::Uplink(up) if !team_link => self.on_uplink(from, up),
            TeamMsg::Interest(i) if !team_link => self.on_team_interest(from, i),
            TeamMsg::Repair(r) if team_link => self.on_repair(from, r),
            TeamMsg::Nack(n) if team_link => self.on_nack(from, n),
            TeamMsg::StateRequest(r) if !team_link => self.on_state_request(r),
            TeamMsg::Gone(g) if team_link => self.on_gone(from, g),
            TeamMsg::Forward(f) if !team_link => self.on_forward(from, f),
            TeamMsg::Want(w) if !team_link => self.on_want(from, w),
            // Fill: step 13.
            _ => self.stats.team.refused += 1,
        }
    }

    /// A gateway hands what it heard of the other robots' streams (frames, repairs,
    /// hellos, heartbeats, `Gone`) to each live mate whose hello says it does not listen
    /// to the team link, over the robot link: such a member receives the streams as a listener does
    /// (2.1), with the gateway's ears. NACKs are not handed on: a member that does not
    /// listen leaves the repairs to its gateway, which lacks what it lacks.
    fn forward_to_deaf_mates(&mut self, from: &Address, msg: &TeamMsg, bytes: &[u8]) {
        let stream = matches!(
            msg,
            TeamMsg::Frame(_)
                | TeamMsg::Repair(_)
                | TeamMsg::Hello(_)
                | TeamMsg::Heartbeat(_)
                | TeamMsg::Gone(_)
        );
        if !stream || self.team.gateway.is_none() {
            return;
        }
        let deaf: Vec<Address> = self
            .mates()
            .filter(|(_, p)| p.incarnation.is_some() && !p.listener && p.alive == Some(true))
            .map(|(a, _)| a.clone())
            .collect();
        for mate in &deaf {
            self.forward_to(mate, from, bytes);
        }
    }

    /// Hands `mate` what gateway `heard_from` said on the team link.
    pub(super) fn forward_to(&mut self, mate: &Address, heard_from: &Address, bytes: &[u8]) {
        let forward = TeamMsg::Forward(Forward {
            from: heard_from.clone(),
            message: bytes.to_vec(),
        });
        self.stats.team.forwarded += 1;
        self.send_to(mate, MsgKind::Forward, &forward.encode());
    }

    /// What a mate (our gateway) heard on the team link from `f.from`: handled as if
    /// heard there, unless this module listens itself (it heard it then) or `f.from`
    /// is no other robot's.
    fn on_forward(&mut self, from: &Address, f: Forward) {
        let other_robot = LinkKind::between(&self.me, &f.from) == LinkKind::Team;
        if !other_robot || self.team.listening != Some(false) {
            tracing::debug!(from = %from, heard_from = %f.from, "forward dropped");
            return self.stats.team.refused += 1;
        }
        // Not counted as team traffic: it came over the robot link (as a `Forward`).
        // A `Forward` inside is refused there: `f.from` is on the team link.
        match TeamMsg::decode(&f.message) {
            Ok(msg) => self.on_team_msg(&f.from, msg, &f.message),
            Err(e) => {
                self.stats.team.refused += 1;
                tracing::debug!(from = %from, error = %e, "forwarded team frame refused");
            }
        }
    }

    /// The speaker entry of gateway `from`, made on first mention (the stalest one is
    /// forgotten past `MAX_SPEAKERS`).
    fn speaker(&mut self, from: &Address) -> &mut Speaker {
        if !self.team.speakers.contains_key(from) && self.team.speakers.len() >= MAX_SPEAKERS {
            let stalest = self.team.speakers.iter().min_by_key(|(_, s)| s.last_heard);
            if let Some(old) = stalest.map(|(a, _)| a.clone()) {
                self.team.speakers.remove(&old);
            }
        }
        let now = self.now;
        let s = self
            .team
            .speakers
            .get_or_insert_with(from, Speaker::default);
        s.last_heard = now;
        s
    }

    pub(super) fn on_team_frame(&mut self, from: &Address, frame: TeamFrame) {
        let (now, max_nack) = (self.now, self.max_nack_frames());
        let s = self.speaker(from);
        let Some(tag) = s.hello.as_ref().map(|h| h.tag) else {
            return self.park(from, frame);
        };
        if frame.check != tag.check() {
            return self.park_other_epoch(from, frame);
        }
        let outer = s.outer.get_or_insert_with(|| Outer::new(tag.0, max_nack));
        let Heard::Fresh(change) = outer.receive(tag.0, frame.seq, now) else {
            return;
        };
        self.stream_changed(from, change);
        self.team_received(tag, frame.seq);
        self.vouch(from);
        self.unwrap_frame(from, frame);
    }

    fn max_nack_frames(&self) -> u64 {
        self.config
            .team_protocol
            .as_ref()
            .map_or(64, |p| p.max_nack_frames)
    }

    /// A frame of another epoch than the hello's: a new epoch's whose hello has not come
    /// (the gateway restarted, or another module took the role), or a late one of an
    /// earlier epoch. Read against this hello it would be the same position of the old
    /// stream, its parts the old members' messages. It waits for the next hello, which
    /// is asked for: there it is taken if it is that hello's, and dropped if not.
    fn park_other_epoch(&mut self, from: &Address, frame: TeamFrame) {
        self.park(from, frame);
        self.ask_hello(from, Some(ANY_TAG));
    }

    /// Keeps a frame until its robot's hello comes, and NACKs the hello.
    fn park(&mut self, from: &Address, frame: TeamFrame) {
        self.stats.team.parked += 1;
        self.ask_hello(from, None);
        let s = self.speaker(from);
        if s.parked.len() >= MAX_PARKED {
            s.parked.pop_front();
            self.stats.team.parked_dropped += 1;
        }
        self.speaker(from).parked.push_back(frame);
    }

    /// What a frame or heartbeat showed of the stream: newly missing positions are
    /// NACKed (after the grace and a back-off); a jump over a gap too large to repair
    /// asks the members' state (2.6, case b; today's catch-up until step 11).
    pub(super) fn stream_changed(&mut self, from: &Address, change: Change) {
        if let Some((first, n)) = change.revealed {
            tracing::trace!(me = %self.me, at = ?self.now, gateway = %from, first, n, "robot stream gap");
            self.team_gap(from, first, n);
        }
        if change.ask_state {
            tracing::debug!(gateway = %from, "robot stream jumped a gap too large to repair");
            if let (Some(tag), Some(n)) = (self.speaker_tag(from), self.team.nacks.as_mut()) {
                n.forget(tag);
            }
            self.ask_members_state(from);
        }
    }

    /// Hands each part's message on; fragments are reassembled first.
    fn unwrap_frame(&mut self, from: &Address, frame: TeamFrame) {
        for part in frame.parts {
            match part.of {
                PartOf::Member(i) if part.cont || part.more => {
                    let piece = Fragment {
                        member: i,
                        cont: part.cont,
                        more: part.more,
                        bytes: &part.bytes,
                    };
                    let outer = self.speaker(from).outer.as_mut();
                    let whole = outer.and_then(|o| o.fragment(frame.seq, piece));
                    whole
                        .into_iter()
                        .for_each(|r| self.deliver(from, r.member, &r.bytes));
                }
                PartOf::Member(i) => self.deliver(from, i, &part.bytes),
                PartOf::Control => self.on_control_part(from, &part.bytes),
                // Step 12: addressed parts (plans, acks, explicit reports).
                PartOf::Addressed { .. } => {}
            }
        }
    }

    fn on_control_part(&mut self, from: &Address, bytes: &[u8]) {
        match TeamMsg::decode(bytes) {
            Ok(TeamMsg::Heartbeat(hb)) => self.on_robot_heartbeat(from, hb),
            Ok(TeamMsg::Nack(n)) => self.on_nack(from, n),
            _ => self.stats.team.refused += 1,
        }
    }

    /// One member's message, to today's receive path as if the member had sent it.
    fn deliver(&mut self, from: &Address, member: u8, bytes: &[u8]) {
        let s = self.speaker(from);
        let Some(Some(source)) = s.members.get(usize::from(member)).cloned() else {
            self.stats.team.refused += 1;
            return;
        };
        let kind = MsgKind::of(bytes);
        if is_team_kind(kind) {
            // A team frame inside a team frame: refused, so nesting cannot recurse.
            self.stats.team.refused += 1;
            return;
        }
        // Counted with its frame (`count_team_received`), so not again here.
        self.on_inner(&source, kind, bytes);
    }

    /// A robot hello: its members (incarnations, restarts, liveliness), a new epoch if
    /// the tag is new; the frames parked for it are handed on.
    fn on_robot_hello(&mut self, from: &Address, hello: RobotHello) {
        let (max_nack, check) = (self.max_nack_frames(), hello.tag.check());
        let s = self.speaker(from);
        if s.hello
            .as_ref()
            .is_some_and(|h| hello.gw_incarnation < h.gw_incarnation)
        {
            return; // A late hello of an earlier epoch.
        }
        let mut ended = None;
        match &mut s.outer {
            Some(o) if o.tag() != hello.tag.0 => {
                ended = Some(StreamTag(o.tag()));
                o.restart(hello.tag.0);
            }
            Some(_) => {}
            None => s.outer = Some(Outer::new(hello.tag.0, max_nack)),
        }
        s.members = hello
            .members
            .iter()
            .map(|m| member_address(from, &m.name))
            .collect();
        s.alive = hello
            .members
            .iter()
            .enumerate()
            .filter(|(_, m)| m.alive)
            .fold(0, |b, (i, _)| b | 1 << i);
        for (i, m) in hello.members.iter().enumerate() {
            let Some(Some(addr)) = self.speaker(from).members.get(i).cloned() else {
                continue;
            };
            self.member_hello(&addr, m.incarnation);
        }
        let positions: Vec<u64> = hello.members.iter().map(|m| m.inner_seq).collect();
        let s = self.speaker(from);
        (s.hello, s.hello_ask) = (Some(hello), None);
        // The old epoch's missing positions will never be repaired: stop NACKing them.
        if let (Some(tag), Some(n)) = (ended, self.team.nacks.as_mut()) {
            n.forget(tag);
        }
        // Every hello says how far each member has gone: what this module lacks of it
        // (said through another gateway, in an epoch not followed to its end) shows as
        // gaps in the members' own streams, which their catch-up closes.
        self.announce_positions(from, &positions);
        self.team.interest_dirty = true;
        self.apply_alive(from);
        let parked: Vec<TeamFrame> = self.speaker(from).parked.drain(..).collect();
        let (this, other): (Vec<_>, Vec<_>) = parked.into_iter().partition(|f| f.check == check);
        self.stats.rejects.stale += other.len() as u64;
        this.into_iter().for_each(|f| self.on_team_frame(from, f));
    }

    /// A member's incarnation as its robot's hello says it: a new one runs today's
    /// restart rule for that member (its new stream comes from inner position 1), and
    /// asks for its state: only its new incarnation's object list sweeps what the
    /// previous one owned (one broadcast answer for every robot, 2.6).
    fn member_hello(&mut self, member: &Address, incarnation: u64) {
        if self
            .peer(member)
            .incarnation
            .is_some_and(|i| incarnation < i)
        {
            self.stats.rejects.stale += 1;
            return;
        }
        if self.take_incarnation(member, incarnation) {
            self.member_restarted(member);
            self.relay_orphans(member);
            self.request_catch_up(member, false, false);
        }
    }

    /// A robot heartbeat: the stream's position and the members' liveliness.
    fn on_robot_heartbeat(&mut self, from: &Address, hb: RobotHeartbeat) {
        let now = self.now;
        let s = self.speaker(from);
        let Some(hello) = &s.hello else {
            return self.ask_hello_of(from, hb.tag);
        };
        if hello.tag != hb.tag {
            // Another epoch whose hello was not heard.
            return self.ask_hello_of(from, hb.tag);
        }
        let Some(change) = s
            .outer
            .as_mut()
            .and_then(|o| o.announce(hb.tag.0, hb.seq, now))
        else {
            return;
        };
        s.alive = hb.alive & ((1u32 << MAX_MEMBERS) - 1);
        let same_hello = hello.version == hb.hello_version;
        self.stream_changed(from, change);
        self.apply_alive(from);
        if let Some(positions) = hb.positions.filter(|_| same_hello) {
            self.announce_positions(from, &positions);
        }
    }

    /// A full heartbeat's inner positions: a member's lost tail shows as a gap in its
    /// stream (the backstop of 2.3, item 5), which today's catch-up closes until state
    /// requests come (step 11).
    pub(super) fn announce_positions(&mut self, from: &Address, positions: &[u64]) {
        let now = self.now;
        let members = self.speaker(from).members.clone();
        for (member, seq) in members.iter().zip(positions) {
            let Some(m) = member.as_ref() else { continue };
            let Some(p) = self.peers.get_mut(m) else {
                continue;
            };
            p.stream.announce(*seq, now);
            self.catch_up_changed(m);
        }
    }

    /// A heartbeat of a stream whose hello is missing (none heard, or of another
    /// epoch): the hello is NACKed by the tag the heartbeat gives.
    fn ask_hello_of(&mut self, from: &Address, tag: super::frame::StreamTag) {
        self.ask_hello(from, Some(tag));
    }

    /// Members the robot says are alive are heard (vouched for); those it says are
    /// dead are lost.
    fn apply_alive(&mut self, from: &Address) {
        let s = self.speaker(from);
        let bits = s.alive;
        let members: Vec<(usize, Address)> = s
            .members
            .iter()
            .enumerate()
            .filter_map(|(i, a)| Some((i, a.clone()?)))
            .collect();
        for (i, member) in members {
            if bits & (1 << i) != 0 {
                self.vouch_one(&member);
            } else if self
                .peers
                .get(&member)
                .is_some_and(|p| p.alive == Some(true))
            {
                self.lost(&member);
            }
        }
    }

    /// A frame from the robot shows its live members alive (2.4, rule c).
    fn vouch(&mut self, from: &Address) {
        let s = self.speaker(from);
        let bits = s.alive;
        let live: Vec<Address> = s
            .members
            .iter()
            .enumerate()
            .filter(|(i, _)| bits & (1 << i) != 0)
            .filter_map(|(_, a)| a.clone())
            .collect();
        live.iter().for_each(|m| self.vouch_one(m));
    }

    /// A member its robot holds alive is heard, unless the transport said it is down
    /// (rule b stands until the transport says it is up, or a new incarnation shows).
    fn vouch_one(&mut self, member: &Address) {
        if *member == self.me {
            return;
        }
        let p = self.peer(member);
        if !p.up && p.alive == Some(false) {
            return;
        }
        self.heard(member);
    }
}

impl State {
    /// Keeps a member's message that lacked names while its robot's stream has a gap;
    /// `false` if it is not kept (no gap: the names were never sent on the stream).
    pub(crate) fn keep_undecoded(&mut self, from: &Address, kind: MsgKind, bytes: &[u8]) -> bool {
        let team = LinkKind::between(&self.me, from) == LinkKind::Team;
        if !team || self.config.team_protocol.is_none() || !self.team_gapped_robots().holds(from) {
            return false;
        }
        if self.team.undecoded.len() >= MAX_UNDECODED
            && let Some(oldest) = self.team.undecoded.pop_front()
        {
            self.stats.team.undecoded_dropped += 1;
            self.request_catch_up(&oldest.from, true, false);
        }
        self.stats.team.undecoded_kept += 1;
        let bytes = bytes.to_vec();
        let from = from.clone();
        self.team
            .undecoded
            .push_back(Undecoded { from, kind, bytes });
        true
    }

    /// Decodes again the kept messages whose robot's stream has no gap left (repaired,
    /// or closed by `Gone`): those that still lack names ask for them as before.
    pub(crate) fn retry_undecoded(&mut self) {
        if self.team.undecoded.is_empty() {
            return;
        }
        let kept = std::mem::take(&mut self.team.undecoded);
        let gapped = self.team_gapped_robots();
        let (wait, ready): (VecDeque<_>, VecDeque<_>) =
            kept.into_iter().partition(|u| gapped.holds(&u.from));
        self.team.undecoded = wait;
        for u in ready {
            self.on_wire(&u.from, u.kind, &u.bytes);
        }
    }
}

/// `team/<robot of the gateway>/<name>`, if `name` makes an address.
fn member_address(gateway: &Address, name: &str) -> Option<Address> {
    let text = format!("{}/{}/{}", gateway.team(), gateway.robot(), name);
    Address::new(&text).ok()
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use slate_model::{Board, Filter};
    use slate_testing::addr;

    use super::super::frame::{Part, StreamTag};
    use super::super::test_state::{lifecycle, robot_hello};
    use super::*;
    use crate::SimNet;

    use crate::ici::{IciConfig, TeamProtocol};

    /// A state of `t/r0/m0` with the team protocol on, on its own network.
    fn state() -> (SimNet, State) {
        let config = IciConfig::default().team_protocol(Some(TeamProtocol::radio()));
        let (net, state) = super::super::test_state::alone("t/r0/m0", config);
        (net, state)
    }

    /// The hello of `gateway`'s robot: members m1 (index 0) and m2, both alive.
    fn hello(gateway: &Address) -> Vec<u8> {
        TeamMsg::Hello(robot_hello(gateway, 9, &["m1", "m2"])).encode()
    }

    /// A frame at `seq` holding one message of member 0.
    fn frame(seq: u64, message: Vec<u8>) -> Vec<u8> {
        frame_of(0, seq, message)
    }

    /// A frame of `t/r1/g`'s stream in the epoch of [`hello`].
    fn frame_of(member: u8, seq: u64, message: Vec<u8>) -> Vec<u8> {
        frame_in(9, member, seq, message)
    }

    /// A frame of `t/r1/g`'s stream in epoch `epoch`.
    fn frame_in(epoch: u64, member: u8, seq: u64, message: Vec<u8>) -> Vec<u8> {
        TeamMsg::Frame(TeamFrame {
            seq,
            check: StreamTag::of(&addr("t/r1/g"), epoch).check(),
            parts: vec![Part::member(member, message)],
        })
        .encode()
    }

    #[test]
    fn a_frame_of_a_new_epoch_heard_before_its_hello_is_not_read_as_the_old_epochs() {
        let (_net, mut st) = state();
        let gw = addr("t/r1/g");
        st.on_team(&gw, &hello(&gw));
        st.on_team(&gw, &frame(2, lifecycle(2)));
        // The gateway restarts (epoch 10); its first frame comes before its hello, at
        // the position the old stream still misses.
        st.on_team(&gw, &frame_in(10, 0, 1, lifecycle(1)));
        let outer = |st: &State| st.team.speakers[&gw].outer.as_ref().map(Outer::have);
        assert_eq!(
            outer(&st),
            Some(0),
            "position 1 of epoch 9 is still missing"
        );
        assert_eq!(st.team.speakers[&gw].parked.len(), 1);
        let new = TeamMsg::Hello(robot_hello(&gw, 10, &["m1", "m2"])).encode();
        st.on_team(&gw, &new);
        assert_eq!(outer(&st), Some(1), "taken as epoch 10's first frame");
    }

    #[test]
    fn a_late_frame_of_an_earlier_epoch_is_dropped_when_the_next_hello_comes() {
        let (_net, mut st) = state();
        let gw = addr("t/r1/g");
        let new = TeamMsg::Hello(robot_hello(&gw, 10, &["m1", "m2"])).encode();
        st.on_team(&gw, &new);
        st.on_team(&gw, &frame_in(9, 0, 1, lifecycle(1)));
        let stale = st.stats.rejects.stale;
        st.on_team(&gw, &new);
        let s = &st.team.speakers[&gw];
        assert!(s.parked.is_empty());
        assert_eq!(s.outer.as_ref().map(Outer::have), Some(0));
        assert_eq!(st.stats.rejects.stale, stale + 1);
    }

    #[test]
    fn frames_heard_before_the_hello_are_parked_and_handed_on_when_it_comes() {
        let (_net, mut st) = state();
        let gw = addr("t/r1/g");
        st.on_team(&gw, &frame(1, lifecycle(1)));
        assert_eq!(st.stats.team.parked, 1);
        st.on_team(&gw, &hello(&gw));
        let s = &st.team.speakers[&gw];
        assert!(s.parked.is_empty());
        assert_eq!(s.outer.as_ref().map(Outer::have), Some(1));
        let member = addr("t/r1/m1");
        assert_eq!(st.peers[&member].incarnation, Some(5));
    }

    #[test]
    fn at_most_64_frames_are_parked_per_gateway() {
        let (_net, mut st) = state();
        let gw = addr("t/r1/g");
        for seq in 1..=70 {
            st.on_team(&gw, &frame(seq, lifecycle(seq)));
        }
        assert_eq!(st.team.speakers[&gw].parked.len(), MAX_PARKED);
        assert_eq!(st.stats.team.parked_dropped, 6);
    }

    #[test]
    fn messages_kept_for_want_of_names_are_bounded_and_retried_when_the_gap_closes() {
        let (_net, mut st) = state();
        let gw = addr("t/r1/g");
        st.on_team(&gw, &hello(&gw));
        st.on_team(&gw, &frame(1, lifecycle(1)));
        let member = addr("t/r1/m1");
        assert!(
            !st.keep_undecoded(&member, MsgKind::Report, &[1]),
            "no gap yet"
        );
        st.on_team(&gw, &frame(3, lifecycle(3)));
        for _ in 0..MAX_UNDECODED + 5 {
            assert!(st.keep_undecoded(&member, MsgKind::Report, &[1]));
        }
        assert_eq!(st.team.undecoded.len(), MAX_UNDECODED);
        assert_eq!(st.stats.team.undecoded_dropped, 5);
        st.retry_undecoded();
        assert_eq!(
            st.team.undecoded.len(),
            MAX_UNDECODED,
            "the gap is still open"
        );
        st.on_team(&gw, &frame(2, lifecycle(2)));
        st.retry_undecoded();
        assert!(st.team.undecoded.is_empty(), "decoded again (and refused)");
    }

    #[test]
    fn a_team_frame_inside_a_team_frame_is_refused() {
        let (_net, mut st) = state();
        let gw = addr("t/r1/g");
        st.on_team(&gw, &hello(&gw));
        let nested = frame(1, frame(1, lifecycle(1)));
        st.on_team(&gw, &nested);
        assert_eq!(st.stats.team.refused, 1);
    }

    #[test]
    fn the_number_of_gateways_followed_is_bounded() {
        let (_net, mut st) = state();
        for i in 0..MAX_SPEAKERS + 10 {
            let gw = addr(&format!("t/r{i}/g"));
            st.on_team(&gw, &hello(&gw));
        }
        assert_eq!(st.team.speakers.len(), MAX_SPEAKERS);
    }

    #[test]
    fn a_frame_of_a_robot_whose_heartbeat_says_a_member_is_dead_does_not_revive_it() {
        let (_net, mut st) = state();
        let gw = addr("t/r1/g");
        st.on_team(&gw, &hello(&gw));
        let member = addr("t/r1/m1");
        assert_eq!(st.peers[&member].alive, Some(true));
        let dead = RobotHeartbeat {
            tag: StreamTag::of(&gw, 9),
            hello_version: 1,
            seq: 0,
            alive: 0b10,
            positions: None,
        };
        st.on_team(&gw, &TeamMsg::Heartbeat(dead).encode());
        assert_eq!(st.peers[&member].alive, Some(false));
        // A message of m2 vouches for the members alive (m2), not for m1.
        st.on_team(&gw, &frame_of(1, 1, lifecycle(1)));
        assert_eq!(st.peers[&member].alive, Some(false));
        assert_eq!(st.peers[&addr("t/r1/m2")].alive, Some(true));
    }

    #[test]
    fn a_full_heartbeat_shows_a_members_lost_tail_as_a_gap() {
        let (_net, mut st) = state();
        let gw = addr("t/r1/g");
        st.on_team(&gw, &hello(&gw));
        let full = RobotHeartbeat {
            tag: StreamTag::of(&gw, 9),
            hello_version: 1,
            seq: 0,
            alive: 0b11,
            positions: Some(vec![3, 0]),
        };
        st.on_team(&gw, &TeamMsg::Heartbeat(full).encode());
        let now = st.now;
        let gap = |st: &State, m: &str| st.peers[&addr(m)].stream.gap_age(now);
        assert!(
            gap(&st, "t/r1/m1").is_some(),
            "m1 sent 3 messages, none heard"
        );
        assert!(gap(&st, "t/r1/m2").is_none());
    }

    #[test]
    fn team_frames_are_refused_with_the_switch_off() {
        let (net, _) = state();
        let me = addr("t/r0/m1");
        let board = Arc::new(
            Board::builder()
                .clock(net.clock())
                .address(me.clone())
                .build(),
        );
        let watch = board.watch(Filter::all().own_writes_only()).unwrap();
        let mut st = State::new(board, net.join(&me), IciConfig::default(), watch);
        let gw = addr("t/r1/g");
        st.on_team(&gw, &hello(&gw));
        assert!(st.team.speakers.is_empty());
        assert_eq!(st.stats.team.refused, 1);
    }
}
