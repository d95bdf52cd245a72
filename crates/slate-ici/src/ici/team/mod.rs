//! The team protocol (docs/team-protocol.md): one speaker per robot on the team link, a
//! numbered robot stream relaying its modules' messages, repairs by NACK with
//! suppression. It runs only with `IciConfig::team_protocol` set; `TeamState` is what
//! an ICI holds of it: its gateway role if elected, the messages waiting for a gateway,
//! the remote robots' union interest, and the streams of the other robots' gateways.
#![allow(dead_code)]

mod answer;
mod frame;
mod gateway;
mod history;
mod nack;
mod outer;
mod receive;
mod repair;
mod send;
#[cfg(test)]
mod test_state;

use std::collections::{BTreeMap, VecDeque};

use slate_model::Address;

pub(crate) use receive::{Speaker, is_team_kind};

/// Messages a member holds while it knows no gateway; past it, the oldest go first.
pub(crate) const MAX_PENDING: usize = 64;

/// What one ICI holds of the team protocol.
#[derive(Debug, Default)]
pub(crate) struct TeamState {
    /// The gateway role, while this module has it.
    pub gateway: Option<gateway::Gateway>,
    /// When the team protocol first ran here (the election waits a little after it).
    pub started: Option<std::time::Duration>,
    /// Whether this module last told its transport to listen to the team link
    /// (`None`: not told yet, so it listens, as every endpoint starts).
    pub listening: Option<bool>,
    /// The gateway this module last acted on (to see the election change).
    pub elected: Option<Address>,
    /// Team messages waiting for a gateway (at most `MAX_PENDING`).
    pub pending: VecDeque<Vec<u8>>,
    /// The remote robots' union interest, from the gateway (`None`: not known yet, so
    /// everything exported goes).
    pub remote: Option<frame::TeamInterest>,
    /// The remote interest must be recomputed and told to the members (gateway).
    pub interest_dirty: bool,
    /// The streams of other robots' gateways, by gateway address.
    pub speakers: BTreeMap<Address, Speaker>,
    /// The receiver's NACK scheduler (made on first use, seeded per ICI).
    pub nacks: Option<nack::NackScheduler>,
    /// This member's state answers to the team (2.6).
    pub answering: answer::Answering,
    /// Counters until step 16 puts them in `IciStats`.
    pub counts: TeamCounts,
}

/// What the team protocol counted (step 16 moves these to `IciStats.team`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct TeamCounts {
    /// Pending messages dropped because no gateway came in time.
    pub pending_dropped: u64,
    /// Uplinks received by a module that is not gateway (dropped).
    pub uplinks_misrouted: u64,
    /// Frames parked because their robot's hello was not heard yet, and dropped from
    /// the park past its limit.
    pub parked: u64,
    pub parked_dropped: u64,
    /// Positions received in repairs (held already or not).
    pub repaired: u64,
    /// `Gone`s heard for a stream followed.
    pub gone_heard: u64,
    /// Times a robot's members were asked for their state (one catch-up each).
    pub state_asked: u64,
    /// State answers this member put into the robot stream.
    pub state_answers: u64,
    /// Team protocol frames that did not decode, or came with the switch off.
    pub refused: u64,
}
