//! The team protocol (docs/team-protocol.md): one speaker per robot on the team link, a
//! numbered robot stream relaying its modules' messages, repairs by NACK with
//! suppression. It runs only with `IciConfig::team_protocol` set; `TeamState` is what
//! an ICI holds of it: its gateway role if elected, the messages waiting for a gateway,
//! the remote robots' union interest, and the streams of the other robots' gateways.
#![allow(dead_code)]

mod answer;
mod count;
mod frame;
mod gateway;
mod history;
mod nack;
mod outer;
mod pace;
mod receive;
mod repair;
mod send;
#[cfg(test)]
pub(crate) mod test_state;

use std::collections::VecDeque;

use slate_model::Address;

use super::addr_map::AddrMap;

pub(crate) use answer::catch_up_retry;
pub(crate) use receive::{Speaker, Undecoded, is_team_kind};

/// Bytes of messages a member holds while it knows no gateway; past it, the oldest go
/// first. A console loading a mission for many robots writes a few hundred messages
/// before its first election (a count of 64 lost some at 8 robots).
pub(crate) const MAX_PENDING_BYTES: usize = 64 * 1024;

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
    /// Team messages waiting for a gateway, this module's and its mates' (at most `MAX_PENDING_BYTES` in all,
    /// unless one alone is larger).
    pub pending: pace::ByteQueue<pace::Held>,
    /// The remote robots' union interest, from the gateway (`None`: not known yet, so
    /// everything exported goes).
    pub remote: Option<frame::TeamInterest>,
    /// Something exported was kept home because no other robot modelled it (as the
    /// gateway last said): when their interest widens, this module's state must follow.
    pub kept_home: bool,
    /// The remote interest must be recomputed and told to the members (gateway).
    pub interest_dirty: bool,
    /// The streams of other robots' gateways, by gateway address.
    pub speakers: AddrMap<Speaker>,
    /// The receiver's NACK scheduler (made on first use, seeded per ICI).
    pub nacks: Option<nack::NackScheduler>,
    /// This member's state answers to the team (2.6).
    pub answering: answer::Answering,
    /// Members' messages that named what a lost frame announced, kept until their
    /// robot's stream has no gap left (at most `receive::MAX_UNDECODED`).
    pub undecoded: VecDeque<Undecoded>,
}

impl TeamState {
    /// A module's team state before it hears anything: no gateway, nothing held.
    pub fn new() -> TeamState {
        TeamState {
            pending: pace::ByteQueue::new(MAX_PENDING_BYTES),
            ..TeamState::default()
        }
    }
}
