//! State requests through the robot stream (docs/team-protocol.md, 2.6, step 11):
//! * a receiver that must catch up with a remote member asks for its state in a `Nack`
//!   entry `what = state` (member bitmap, names/classes flags), after `gap_grace` and a
//!   back-off drawn from its NACK scheduler; another robot's ask heard meanwhile for the
//!   same members suppresses ours (the one broadcast answer serves both);
//! * the source gateway forwards a `StateRequest` to each member named, over the robot
//!   link, with the robot of the asker;
//! * the member answers at most once per `answer_interval` (requests meanwhile are
//!   merged, whatever robots asked) with its current state filtered by its export policy
//!   and the remote robots' union interest, through the robot stream: once, by
//!   broadcast, numbered and so repairable. Every listener applies it.
//!
//! Observers (`IciConfig::observer`) keep today's unicast catch-up request, answered
//! by a reliable send to them alone.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

use slate_model::Address;

use super::frame::{MAX_MEMBERS, NackEntry, StateAsk, StateRequest, StreamTag, TeamMsg};
use super::gateway::Gateway;
use crate::ici::catchup::Audience;
use crate::ici::classes::ClassSet;
use crate::ici::frame::MAX_ITEMS;
use crate::ici::state::State;
use crate::{IciConfig, LinkKind, MsgKind, TeamProtocol};

/// A state ask for some members of one robot, waiting for its back-off. One per
/// followed gateway (`Speaker`), so bounded by the speakers' limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct StateAskDue {
    pub ask: StateAsk,
    pub due: Duration,
}

/// A member's state answers: when it last answered, and the requests merged since.
#[derive(Clone, Debug, Default)]
pub(crate) struct Answering {
    pub answered: Option<Duration>,
    pub deferred: Option<StateRequest>,
}

// ----- the receiver -----

impl State {
    /// Asks for team member `member`'s state through its robot stream. `false`: the
    /// caller sends today's catch-up request (switch off, robot link, an observer).
    /// A member whose robot hello is not known yet is not asked: the hello is NACKed
    /// first, and the caller's retry asks again.
    pub(crate) fn team_state_ask(&mut self, member: &Address, names: bool, classes: bool) -> bool {
        if asked_through_stream(&self.config, &self.me, member).is_none() {
            return false;
        }
        if let Some((gateway, index)) = self.gateway_of(member) {
            self.merge_state_ask(&gateway, index, names, classes);
        }
        true
    }

    /// The gateway heard most lately whose hello lists `member`, and its index (the
    /// hello being handled may not be stored yet: its tag is read when the ask is due).
    fn gateway_of(&self, member: &Address) -> Option<(Address, u8)> {
        let found = self.team.speakers.iter().filter_map(|(g, s)| {
            let index = s.members.iter().position(|m| m.as_ref() == Some(member))?;
            Some((s.last_heard, g, u8::try_from(index).ok()?))
        });
        let (_, gateway, index) = found.max_by_key(|(heard, _, _)| *heard)?;
        Some((gateway.clone(), index))
    }

    /// Adds member `index` to gateway `gateway`'s pending ask, which keeps its due time
    /// (or gets `gap_grace` plus a back-off, as a frame NACK does).
    pub(super) fn merge_state_ask(
        &mut self,
        gateway: &Address,
        index: u8,
        names: bool,
        classes: bool,
    ) {
        let Some(p) = self.config.team_protocol.clone() else {
            return;
        };
        let pending = self.team.speakers.get(gateway).and_then(|s| s.state_ask);
        let due = match pending {
            Some(a) => a.due,
            None => self.now + p.gap_grace + self.nack_draw(p.nack_backoff),
        };
        let mut ask = pending.map_or(StateAsk::default(), |a| a.ask);
        ask.members |= 1 << index;
        ask.names |= names;
        ask.classes |= classes;
        if let Some(s) = self.team.speakers.get_mut(gateway) {
            s.state_ask = Some(StateAskDue { ask, due });
        }
    }

    /// Another robot asked for the state of members of stream `tag`: the members its
    /// ask covers (with the names and classes we need) leave ours, as its answer is
    /// broadcast.
    pub(super) fn state_ask_heard(&mut self, tag: StreamTag, heard: StateAsk) {
        for s in self.team.speakers.values_mut() {
            let ours = s.hello.as_ref().is_some_and(|h| h.tag == tag);
            let Some(pending) = s.state_ask.as_mut().filter(|_| ours) else {
                continue;
            };
            let covers =
                (heard.names || !pending.ask.names) && (heard.classes || !pending.ask.classes);
            if covers {
                pending.ask.members &= !heard.members;
            }
            if pending.ask.members == 0 {
                s.state_ask = None;
            }
        }
    }

    /// The state ask entries due now (each sent once; the caller's catch-up retry asks
    /// again if no answer comes).
    pub(super) fn state_asks_due(&mut self) -> Vec<NackEntry> {
        let now = self.now;
        let mut entries = Vec::new();
        for s in self.team.speakers.values_mut() {
            let Some(tag) = s.hello.as_ref().map(|h| h.tag) else {
                continue;
            };
            if let Some(due) = s.state_ask.take_if(|a| a.due <= now) {
                entries.push(state_entry(tag, due.ask));
            }
        }
        entries
    }
}

/// The team protocol through which the module at `me` asks `member` for its state, if
/// it does: `member` is on another robot and the module is not an observer (which keeps
/// the unicast catch-up request).
pub(crate) fn asked_through_stream<'c>(
    config: &'c IciConfig,
    me: &Address,
    member: &Address,
) -> Option<&'c TeamProtocol> {
    let team = LinkKind::between(me, member) == LinkKind::Team;
    config
        .team_protocol
        .as_ref()
        .filter(|_| team && !config.observer)
}

/// How long an unanswered catch-up of `member` waits before the module at `me` asks
/// again. Through a robot stream the member answers at most once per
/// `answer_interval`, and its answer may need a repair (`repair_wait`): asking sooner
/// only adds asks to the team link (on the acoustic channel, an ask every 3 s per
/// member made most of its traffic and the boards never agreed).
pub(crate) fn catch_up_retry(config: &IciConfig, me: &Address, member: &Address) -> Duration {
    let answered =
        asked_through_stream(config, me, member).map(|p| p.answer_interval + p.repair_wait);
    config.catch_up_retry.max(answered.unwrap_or_default())
}

fn state_entry(tag: StreamTag, ask: StateAsk) -> NackEntry {
    NackEntry {
        tag,
        frames: None,
        hello: false,
        state: Some(ask),
    }
}

// ----- the source gateway -----

impl State {
    /// A state ask for this gateway's stream, from a module of robot `from.robot()`:
    /// each member named gets a `StateRequest` (this module answers its own at once),
    /// or, while the gateway's queue waits for the radio, once it is empty (2.3): an
    /// answer queued behind a backlog adds to it and is stale when it goes out, and
    /// held, the asks of every robot merge into one answer.
    pub(super) fn gateway_state_asked(&mut self, from: &Address, entry: &NackEntry) {
        let (Some(gw), Some(ask)) = (self.team.gateway.as_ref(), entry.state) else {
            return;
        };
        if entry.tag != gw.tag {
            return;
        }
        let named = (0..MAX_MEMBERS).filter(|i| ask.members & (1 << i) != 0);
        // A member whose answer waits in the queue is served by it: that answer is
        // newer than every frame the asker can have missed (the queue keeps order).
        // Not an ask for names or classes: the queued answer may lack them.
        let plain = !ask.names && !ask.classes;
        let (queued, named): (Vec<u8>, Vec<u8>) =
            named.partition(|i| plain && gw.queue.holds_answer_of(*i));
        let names: Vec<Arc<str>> = named
            .into_iter()
            .filter_map(|i| gw.members.get(usize::from(i)).map(|m| m.name.clone()))
            .collect();
        self.stats.team.state_asks_covered += queued.len() as u64;
        let req = StateRequest {
            names: ask.names,
            classes: ask.classes,
            robots: vec![Arc::from(from.robot())],
        };
        let now = self.now;
        let Some(gw) = self.team.gateway.as_mut() else {
            return;
        };
        if !gw.queue.is_empty() {
            for name in names {
                gw.held_since.get_or_insert(now);
                let held = gw.held_asks.remove(&name);
                gw.held_asks.insert(name, merge_requests(held, req.clone()));
            }
            return;
        }
        for name in names {
            self.forward_state_request(&name, req.clone());
        }
    }

    /// Forwards the state asks held while the queue was not empty, once it is, or once
    /// the oldest has waited `answer_interval`: on a channel slower than what the robot
    /// says (the acoustic console's) the queue never empties, and an ask held for that
    /// would never be answered. An ask for a member whose state answer still waits in
    /// the queue waits for it to leave: a second whole state behind the first tells
    /// nobody more than the first will, and at 24 robots the console queued one every
    /// `answer_interval` behind a queue 74 s long (docs/team-protocol.md, 9.1).
    pub(super) fn forward_held_state_asks(&mut self) {
        let now = self.now;
        let interval = self
            .config
            .team_protocol
            .as_ref()
            .map(|p| p.answer_interval);
        let Some(gw) = self.team.gateway.as_mut() else {
            return;
        };
        let waited = gw
            .held_since
            .zip(interval)
            .is_some_and(|(since, interval)| now >= since + interval);
        if !gw.queue.is_empty() && !waited {
            return;
        }
        let answer_queued = |gw: &Gateway, name: &str| {
            (gw.index_of(name)).is_some_and(|i| gw.queue.holds_answer_of(i))
        };
        let (wait, go): (BTreeMap<_, _>, BTreeMap<_, _>) = std::mem::take(&mut gw.held_asks)
            .into_iter()
            .partition(|(name, _)| answer_queued(gw, name));
        gw.held_since = (!wait.is_empty()).then_some(now);
        gw.held_asks = wait;
        for (name, req) in go {
            self.forward_state_request(&name, req);
        }
    }

    fn forward_state_request(&mut self, name: &str, req: StateRequest) {
        let Ok(member) = Address::new(&format!("{}/{}", self.me.robot_path(), name)) else {
            return;
        };
        if member == self.me {
            return self.on_state_request(req);
        }
        let bytes = TeamMsg::StateRequest(req).encode();
        self.send_to(&member, MsgKind::StateRequest, &bytes);
    }
}

// ----- the member -----

impl State {
    /// A request for this member's state: answered now, or merged with the others
    /// until `answer_interval` has passed since the last answer.
    pub(super) fn on_state_request(&mut self, req: StateRequest) {
        let Some(interval) = self
            .config
            .team_protocol
            .as_ref()
            .map(|p| p.answer_interval)
        else {
            return;
        };
        let now = self.now;
        let a = &mut self.team.answering;
        let lately = a.answered.is_some_and(|t| now.saturating_sub(t) < interval);
        let merged = merge_requests(a.deferred.take(), req);
        if lately {
            self.stats.catch_up.deferred += 1;
            self.team.answering.deferred = Some(merged);
            return;
        }
        self.team_answer(merged);
    }

    /// This member's state for every robot, as an answer no one asked for (merged with
    /// any request pending). Without the class definitions: every robot loads its own,
    /// and a receiver that lacks one asks for them when a report fails to decode.
    pub(crate) fn team_answer_unasked(&mut self) {
        let everyone = StateRequest {
            names: false,
            classes: false,
            robots: Vec::new(),
        };
        self.on_state_request(everyone);
    }

    /// Answers the merged requests once `answer_interval` has passed.
    pub(super) fn deferred_state_answer(&mut self) {
        let Some(interval) = self
            .config
            .team_protocol
            .as_ref()
            .map(|p| p.answer_interval)
        else {
            return;
        };
        let a = &self.team.answering;
        let due = a
            .answered
            .is_none_or(|t| self.now.saturating_sub(t) >= interval);
        if let Some(req) = self.team.answering.deferred.take_if(|_| due) {
            self.team_answer(req);
        }
    }

    fn team_answer(&mut self, req: StateRequest) {
        self.team.answering.answered = Some(self.now);
        self.stats.team.state_answers += 1;
        tracing::debug!(me = %self.me, at = ?self.now, robots = ?req.robots, "state answer");
        self.answer_state(Audience::Team(&req.robots), req.names, req.classes);
    }

    /// A part of a state answer, into the robot stream (`Uplink` with the state-answer
    /// flag to the gateway, or framed here if this module is gateway).
    pub(crate) fn team_state_out(&mut self, bytes: &[u8]) {
        self.team_elect();
        self.route(bytes.to_vec(), true);
    }

    /// The remote robots' union interest (what a team answer is filtered by), if known.
    pub(crate) fn team_remote_interest(&self) -> Option<ClassSet> {
        self.team.remote.as_ref().map(|r| r.interest.clone())
    }
}

/// One request covering both: names or classes if either asks, and both's robots
/// (at most `MAX_ITEMS`, the frame's limit; past it, the newest are left out).
fn merge_requests(old: Option<StateRequest>, new: StateRequest) -> StateRequest {
    let Some(mut merged) = old else { return new };
    merged.names |= new.names;
    merged.classes |= new.classes;
    for robot in new.robots {
        if !merged.robots.contains(&robot) && merged.robots.len() < MAX_ITEMS as usize {
            merged.robots.push(robot);
        }
    }
    merged
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use slate_testing::addr;

    use super::super::frame::{Member, Nack, RobotHello};
    use super::super::gateway::{Framer, Gateway};
    use super::super::history::HistoryLimits;
    use super::super::pace::{Queued, TokenBucket};
    use super::super::test_state::{START, ms, robot_hello, sent, tick_at};
    use super::*;
    use crate::SimNet;
    use crate::ici::{IciConfig, TeamProtocol};

    /// A state of `me` with `config` and the team protocol on (radio).
    fn state_with(me: &str, config: IciConfig) -> (SimNet, State) {
        let config = config.team_protocol(Some(TeamProtocol::radio()));
        let (net, mut state) = super::super::test_state::alone(me, config);
        state.now = START;
        (net, state)
    }

    fn state() -> (SimNet, State) {
        state_with("t/r0/m0", IciConfig::default())
    }

    fn member(name: &str) -> Member {
        Member {
            name: name.into(),
            incarnation: 5,
            inner_seq: 0,
            alive: true,
            listener: true,
        }
    }

    /// `st` hears the hello of gateway `t/r1/g`, whose robot has m1 and m2.
    fn hear_robot_1(st: &mut State) -> StreamTag {
        let gw = addr("t/r1/g");
        let tag = StreamTag::of(&gw, 9);
        let hello = RobotHello {
            exports: ClassSet::all(),
            ..robot_hello(&gw, 9, &["m1", "m2"])
        };
        st.on_team(&gw, &TeamMsg::Hello(hello).encode());
        tag
    }

    /// Another robot's state ask (names re-announced if `names`).
    fn state_nack(tag: StreamTag, members: u32, names: bool) -> Vec<u8> {
        let ask = StateAsk {
            members,
            names,
            classes: false,
        };
        TeamMsg::Nack(Nack {
            entries: vec![state_entry(tag, ask)],
        })
        .encode()
    }

    /// Messages of `kind` this state sent on `link`.
    #[test]
    fn catching_up_with_two_members_of_a_robot_is_one_state_entry_after_the_back_off() {
        let (_net, mut st) = state();
        hear_robot_1(&mut st);
        st.request_catch_up(&addr("t/r1/m1"), false, false);
        st.request_catch_up(&addr("t/r1/m2"), true, false);
        let ask = st.team.speakers[&addr("t/r1/g")].state_ask.unwrap().ask;
        assert_eq!((ask.members, ask.names, ask.classes), (0b11, true, false));
        tick_at(&mut st, ms(99));
        assert_eq!(
            sent(&st, LinkKind::Team, MsgKind::Nack),
            0,
            "within gap_grace"
        );
        tick_at(&mut st, ms(400));
        assert_eq!(sent(&st, LinkKind::Team, MsgKind::Nack), 1);
        assert_eq!(sent(&st, LinkKind::Team, MsgKind::CatchUpRequest), 0);
    }

    #[test]
    fn an_unanswered_state_ask_goes_again_only_once_an_answer_could_have_come() {
        // Acoustic: the member answers at most once per 30 s and its answer may need a
        // repair (10 s). Asking again every `catch_up_retry` (3 s) made most of the
        // channel's traffic, and the boards never agreed.
        let config = IciConfig::default().team_protocol(Some(TeamProtocol::acoustic()));
        let (_net, mut st) = super::super::test_state::alone("t/r0/m0", config);
        st.now = START;
        hear_robot_1(&mut st);
        st.request_catch_up(&addr("t/r1/m1"), false, false);
        let run_to = |st: &mut State, until: u64| {
            while st.now < START + ms(until) {
                st.now += ms(250);
                st.tick();
            }
            sent(st, LinkKind::Team, MsgKind::Nack)
        };
        assert_eq!(run_to(&mut st, 39_000), 1, "asked once in the first 39 s");
        assert_eq!(run_to(&mut st, 46_000), 2, "asked again after 40 s");
    }

    #[test]
    fn another_robots_state_ask_for_the_same_members_suppresses_ours() {
        let (_net, mut st) = state();
        let tag = hear_robot_1(&mut st);
        st.request_catch_up(&addr("t/r1/m1"), false, false);
        st.request_catch_up(&addr("t/r1/m2"), false, false);
        // A member never heard from is asked with its names: so is the ask heard.
        st.on_team(&addr("t/r2/g"), &state_nack(tag, 0b01, true));
        let left = st.team.speakers[&addr("t/r1/g")]
            .state_ask
            .map(|a| a.ask.members);
        assert_eq!(left, Some(0b10), "m2 is still to ask for");
        st.on_team(&addr("t/r2/g"), &state_nack(tag, 0b10, true));
        tick_at(&mut st, ms(5000));
        assert_eq!(sent(&st, LinkKind::Team, MsgKind::Nack), 0);
    }

    #[test]
    fn an_ask_heard_that_lacks_the_names_we_need_does_not_suppress_ours() {
        let (_net, mut st) = state();
        let tag = hear_robot_1(&mut st);
        st.request_catch_up(&addr("t/r1/m1"), true, false);
        st.on_team(&addr("t/r2/g"), &state_nack(tag, 0b01, false));
        tick_at(&mut st, ms(400));
        assert_eq!(sent(&st, LinkKind::Team, MsgKind::Nack), 1);
    }

    #[test]
    fn an_observer_keeps_the_unicast_catch_up_request() {
        let (_net, mut st) = state_with("t/cli/get", IciConfig::default().observer(true));
        hear_robot_1(&mut st);
        st.request_catch_up(&addr("t/r1/m1"), false, false);
        assert_eq!(sent(&st, LinkKind::Team, MsgKind::CatchUpRequest), 1);
        assert!(st.team.speakers[&addr("t/r1/g")].state_ask.is_none());
    }

    /// A gateway of m0, m1 and m2 (stream tag 77); with a `backlog` of `(member,
    /// answer)`, its radio 900 B in debt at 1 000 B/s and one lifecycle message of that
    /// member queued (`answer`: a part of its state answer).
    fn gateway_of_three(backlog: Option<(u8, bool)>) -> Gateway {
        let limits = HistoryLimits {
            bytes: 4096,
            age: Duration::from_secs(60),
        };
        let mut gw = Gateway::new(StreamTag(77), 1, Framer::new(1024, ms(250)), limits);
        gw.members = vec![member("m0"), member("m1"), member("m2")];
        if let Some((member, answer)) = backlog {
            gw.bucket = TokenBucket::new(8_000, 100, START);
            gw.bucket.spend(1_000, START);
            let message = super::super::test_state::lifecycle(1);
            let (mark, since) = (None, START);
            gw.queue.push(Queued {
                member,
                message,
                mark,
                since,
                answer,
            });
        }
        gw
    }

    #[test]
    fn the_gateway_forwards_a_state_ask_to_each_member_named() {
        let (_net, mut st) = state();
        st.team.gateway = Some(gateway_of_three(None));
        st.on_team(&addr("t/r3/g"), &state_nack(StreamTag(77), 0b110, false));
        assert_eq!(sent(&st, LinkKind::Robot, MsgKind::StateRequest), 2);
        st.on_team(&addr("t/r3/g"), &state_nack(StreamTag(78), 0b110, false));
        assert_eq!(
            sent(&st, LinkKind::Robot, MsgKind::StateRequest),
            2,
            "another stream's ask"
        );
    }

    #[test]
    fn a_gateway_holds_state_asks_while_its_queue_waits_for_the_radio() {
        let (_net, mut st) = state();
        st.team.gateway = Some(gateway_of_three(Some((0, false))));
        st.on_team(&addr("t/r3/g"), &state_nack(StreamTag(77), 0b110, false));
        st.on_team(&addr("t/r4/g"), &state_nack(StreamTag(77), 0b010, true));
        st.forward_held_state_asks();
        assert_eq!(sent(&st, LinkKind::Robot, MsgKind::StateRequest), 0);
        st.now = START + ms(2000);
        st.pump();
        st.forward_held_state_asks();
        assert_eq!(
            sent(&st, LinkKind::Robot, MsgKind::StateRequest),
            2,
            "one merged request per member once the queue is empty"
        );
    }

    #[test]
    fn a_held_state_ask_goes_after_answer_interval_though_the_queue_never_empties() {
        // The acoustic console's queue never emptied: the asks it held were never
        // answered, and a robot that missed the launch report never got it.
        let (_net, mut st) = state();
        st.team.gateway = Some(gateway_of_three(Some((0, false))));
        st.on_team(&addr("t/r3/g"), &state_nack(StreamTag(77), 0b110, true));
        let interval = TeamProtocol::radio().answer_interval;
        st.now = START + interval - ms(1);
        st.forward_held_state_asks();
        assert_eq!(sent(&st, LinkKind::Robot, MsgKind::StateRequest), 0);
        st.now = START + interval;
        st.forward_held_state_asks();
        assert!(!st.team.gateway.as_ref().unwrap().queue.is_empty());
        assert_eq!(sent(&st, LinkKind::Robot, MsgKind::StateRequest), 2);
    }

    #[test]
    fn an_ask_for_a_member_whose_answer_is_queued_is_served_by_it() {
        let (_net, mut st) = state();
        st.team.gateway = Some(gateway_of_three(Some((1, true))));
        st.on_team(&addr("t/r3/g"), &state_nack(StreamTag(77), 0b110, false));
        st.now = START + ms(2000);
        st.pump();
        st.forward_held_state_asks();
        assert_eq!(
            sent(&st, LinkKind::Robot, MsgKind::StateRequest),
            1,
            "m2 only: m1's answer was on its way"
        );
        assert_eq!(st.stats.team.state_asks_covered, 1);
    }

    #[test]
    fn a_held_ask_for_a_member_whose_answer_still_waits_in_the_queue_waits_for_it() {
        // 24 robots: the console released its held asks every `answer_interval` while
        // its own answer still waited in its queue, so it queued a whole state every
        // 2 s or so (135 in a run) behind a queue 74 s long.
        let (_net, mut st) = state();
        st.team.gateway = Some(gateway_of_three(Some((1, true))));
        // Asks with names are not served by the queued answer (it may lack them).
        st.on_team(&addr("t/r3/g"), &state_nack(StreamTag(77), 0b110, true));
        let interval = TeamProtocol::radio().answer_interval;
        st.now = START + interval;
        st.forward_held_state_asks();
        assert_eq!(
            sent(&st, LinkKind::Robot, MsgKind::StateRequest),
            1,
            "m2 only: m1's answer still waits in the queue"
        );
        st.now = START + ms(2000);
        st.pump();
        st.forward_held_state_asks();
        assert!(st.team.gateway.as_ref().unwrap().queue.is_empty());
        assert_eq!(
            sent(&st, LinkKind::Robot, MsgKind::StateRequest),
            2,
            "m1's ask goes once its answer left"
        );
    }

    fn request(robot: &str) -> StateRequest {
        StateRequest {
            names: false,
            classes: false,
            robots: vec![Arc::from(robot)],
        }
    }

    #[test]
    fn requests_within_the_answer_interval_are_merged_into_one_answer() {
        let (_net, mut st) = state();
        st.on_state_request(request("r1"));
        st.now = START + ms(500);
        st.on_state_request(request("r2"));
        st.on_state_request(request("r3"));
        assert_eq!(st.stats.catch_up.answered, 1);
        let deferred = st.team.answering.deferred.clone().unwrap();
        assert_eq!(deferred.robots, vec![Arc::from("r2"), Arc::from("r3")]);
        st.now = START + ms(1999);
        st.deferred_state_answer();
        assert_eq!(st.stats.catch_up.answered, 1, "within answer_interval");
        st.now = START + ms(2000);
        st.deferred_state_answer();
        assert_eq!(st.stats.catch_up.answered, 2);
        assert!(st.team.answering.deferred.is_none());
    }

    #[test]
    fn a_merged_request_names_at_most_max_items_robots() {
        let mut merged = request("r0");
        for i in 1..=(MAX_ITEMS + 10) {
            merged = merge_requests(Some(merged), request(&format!("r{i}")));
        }
        assert_eq!(merged.robots.len(), MAX_ITEMS as usize);
        let again = merge_requests(Some(merged.clone()), request("r0"));
        assert_eq!(again.robots.len(), merged.robots.len(), "no robot twice");
    }
}
