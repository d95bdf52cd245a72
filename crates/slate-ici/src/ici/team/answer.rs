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

use std::sync::Arc;
use std::time::Duration;

use slate_model::Address;

use super::frame::{MAX_MEMBERS, NackEntry, StateAsk, StateRequest, StreamTag, TeamMsg, Uplink};
use crate::ici::catchup::Audience;
use crate::ici::classes::ClassSet;
use crate::ici::frame::MAX_ITEMS;
use crate::ici::state::State;
use crate::{LinkKind, MsgKind};

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
        let team = LinkKind::between(&self.me, member) == LinkKind::Team;
        if self.config.team_protocol.is_none() || self.config.observer || !team {
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
    fn merge_state_ask(&mut self, gateway: &Address, index: u8, names: bool, classes: bool) {
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
    /// each member named gets a `StateRequest` (this module answers its own at once).
    pub(super) fn gateway_state_asked(&mut self, from: &Address, entry: &NackEntry) {
        let (Some(gw), Some(ask)) = (self.team.gateway.as_ref(), entry.state) else {
            return;
        };
        if entry.tag != gw.tag {
            return;
        }
        let named = (0..MAX_MEMBERS).filter(|i| ask.members & (1 << i) != 0);
        let names: Vec<Arc<str>> = named
            .filter_map(|i| gw.members.get(usize::from(i)).map(|m| m.name.clone()))
            .collect();
        let req = StateRequest {
            names: ask.names,
            classes: ask.classes,
            robots: vec![Arc::from(from.robot())],
        };
        for name in names {
            self.forward_state_request(&name, req.clone());
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
        self.team.counts.state_answers += 1;
        self.answer_state(Audience::Team(&req.robots), req.names, req.classes);
    }

    /// A part of a state answer, into the robot stream (`Uplink` with the state-answer
    /// flag to the gateway, or framed here if this module is gateway).
    pub(crate) fn team_state_out(&mut self, bytes: &[u8]) {
        self.team_elect();
        match self.team.elected.clone() {
            Some(g) if g != self.me => {
                let up = Uplink {
                    to: None,
                    state_answer: true,
                    mark: self.out.get(&LinkKind::Team).map(|o| o.seq),
                    message: bytes.to_vec(),
                };
                self.send_to(&g, MsgKind::Uplink, &TeamMsg::Uplink(up).encode());
            }
            _ => self.team_out(bytes),
        }
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
