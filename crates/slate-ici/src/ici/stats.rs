//! What an ICI counts.

use std::collections::BTreeMap;
use std::time::Duration;

use slate_wire::DecodeStats;

use crate::{LinkKind, MsgKind, Traffic};

/// Counters of one ICI. See `docs/ici.md` for when each moves.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct IciStats {
    /// Messages and bytes by link kind and message kind, both ways (a publish counts once).
    pub traffic: BTreeMap<(LinkKind, MsgKind), Traffic>,
    /// What this module reported.
    pub reports: ReportStats,
    /// What received packets did to the board.
    pub merges: MergeStats,
    /// What was refused, by reason.
    pub rejects: RejectStats,
    /// Catch-ups, both as receiver and as source.
    pub catch_up: CatchUpStats,
    /// Liveliness.
    pub liveliness: LivelinessStats,
    /// The team protocol (docs/team-protocol.md): all zero with it off.
    pub team: TeamStats,
    /// How many times the timers ran: each `Ici::tick`, or on a manual clock each move
    /// at which one was due or something had reached the module since they last ran.
    pub timer_runs: u64,
}

impl IciStats {
    /// Traffic of one link kind, all message kinds together.
    pub fn link(&self, link: LinkKind) -> Traffic {
        let mut t = Traffic::default();
        for (_, x) in self.traffic.iter().filter(|((l, _), _)| *l == link) {
            t.add(x);
        }
        t
    }

    /// Traffic of one message kind on one link kind.
    pub fn get(&self, link: LinkKind, kind: MsgKind) -> Traffic {
        self.traffic.get(&(link, kind)).copied().unwrap_or_default()
    }

    pub(crate) fn sent(&mut self, link: LinkKind, kind: MsgKind, bytes: usize) {
        self.traffic.entry((link, kind)).or_default().sent(bytes);
    }

    pub(crate) fn received(&mut self, link: LinkKind, kind: MsgKind, bytes: usize) {
        self.traffic
            .entry((link, kind))
            .or_default()
            .received(bytes);
    }

    /// Counts a sent team protocol message of `kind` and `total` bytes by what it holds:
    /// each inner message under its own kind, the rest (the envelope) under `kind`.
    /// Invariant: the bytes counted add up to `total`.
    pub(crate) fn sent_team(
        &mut self,
        link: LinkKind,
        kind: MsgKind,
        total: usize,
        inner: &[Inner],
    ) {
        inner.iter().for_each(|i| self.sent(link, i.kind, i.bytes));
        let envelope = envelope_of(total, inner);
        self.sent(link, kind, envelope);
        self.team.sent(kind, total, envelope);
    }

    /// Counts a received team protocol message as [`sent_team`](Self::sent_team) does.
    pub(crate) fn received_team(
        &mut self,
        link: LinkKind,
        kind: MsgKind,
        total: usize,
        inner: &[Inner],
    ) {
        inner
            .iter()
            .for_each(|i| self.received(link, i.kind, i.bytes));
        self.received(link, kind, envelope_of(total, inner));
    }
}

/// One inner message of a team frame or repair: its kind and its bytes (without the
/// part's own byte and length, which are the envelope's).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Inner {
    pub kind: MsgKind,
    pub bytes: usize,
}

/// The bytes of a message of `total` bytes that are not its inner messages'. Never
/// negative: inner bytes are slices of the message (a wrong caller counts 0, not a wrap).
fn envelope_of(total: usize, inner: &[Inner]) -> usize {
    total.saturating_sub(inner.iter().map(|i| i.bytes).sum())
}

/// What the team protocol did (docs/ici.md, "Counters"). Sent and received bytes by kind
/// are in [`IciStats::traffic`], where a frame's inner messages count under their own
/// kinds and the frame's envelope under `TeamFrame` (`TeamRepair` for a repair's).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TeamStats {
    /// Robot-stream frames published (as gateway).
    pub frames: u64,
    /// Repairs published (as gateway).
    pub repairs: u64,
    /// Bytes of the repairs published, envelope and replayed messages together (the
    /// replayed messages also count under their kinds in `traffic`).
    pub repair_bytes: u64,
    /// Bytes of frames and repairs published that are no inner message's: headers,
    /// positions, part bytes and lengths.
    pub envelope_bytes: u64,
    /// `Nack`s published.
    pub nacks_sent: u64,
    /// Other robots' NACK entries heard for a stream this module had positions missing
    /// from (its own NACK for them joins that round instead of going out).
    pub nacks_suppressed: u64,
    /// `Gone`s published (as gateway).
    pub gone: u64,
    /// `Gone`s heard for a stream followed.
    pub gone_heard: u64,
    /// State answers this member put into the robot stream.
    pub state_answers: u64,
    /// Times a robot's members were asked for their state (one catch-up each).
    pub state_asked: u64,
    /// Positions received in repairs (held already or not).
    pub repaired: u64,
    /// Pending messages dropped because no gateway came in time.
    pub pending_dropped: u64,
    /// What this gateway heard on the team link and handed to mates that do not listen
    /// there (`Forward`s sent, one per mate).
    pub forwarded: u64,
    /// Uplinks received by a module that is not gateway (dropped).
    pub uplinks_misrouted: u64,
    /// Frames parked because their robot's hello was not heard yet.
    pub parked: u64,
    /// Parked frames dropped past the park's limit.
    pub parked_dropped: u64,
    /// Team protocol frames that did not decode, or came with the switch off.
    pub refused: u64,
    /// Members' messages kept for want of names while their robot's stream had a gap
    /// (decoded again once it has none).
    pub undecoded_kept: u64,
    /// Kept messages dropped past the limit (their source was asked for its state).
    pub undecoded_dropped: u64,
    /// Members' messages the gateway's queue dropped, oldest first, when it was full
    /// (the radio could not keep up; their receivers find the inner gap).
    pub queue_dropped: u64,
    /// The most bytes the gateway's queue held.
    pub queue_max_bytes: u64,
    /// Members asked for their state whose answer was in the gateway's queue already
    /// (it serves the ask: not forwarded).
    pub state_asks_covered: u64,
    /// The longest a member's message waited in the gateway's queue.
    pub queue_max_wait: Duration,
}

impl TeamStats {
    /// Counts one team protocol message sent.
    fn sent(&mut self, kind: MsgKind, total: usize, envelope: usize) {
        match kind {
            MsgKind::TeamFrame => self.frames += 1,
            MsgKind::TeamRepair => {
                self.repairs += 1;
                self.repair_bytes += total as u64;
            }
            MsgKind::Nack => self.nacks_sent += 1,
            MsgKind::Gone => self.gone += 1,
            _ => {}
        }
        if matches!(kind, MsgKind::TeamFrame | MsgKind::TeamRepair) {
            self.envelope_bytes += envelope as u64;
        }
    }
}

/// What this module reported.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReportStats {
    /// Own packets written (candidates for a report).
    pub written: u64,
    /// Packets put in reports (per link kind they went out on, so a packet sent on both
    /// counts twice).
    pub items_sent: u64,
    /// Packets held back by a report filter (minimum interval, dead-band, accuracy).
    pub held: u64,
    /// Held packets sent at the end of their hold (the trailing edge).
    pub trailing: u64,
    /// Packets re-sent by an attribute's heartbeat.
    pub heartbeats: u64,
    /// Packets sent by explicit reports ([`Ici::report`](crate::Ici::report), a plan's
    /// `report` action), per link kind or destination they went to.
    pub explicit: u64,
    /// Packets (and object creations and deletions) not sent on a link kind because no
    /// peer there is interested.
    pub suppressed_interest: u64,
    /// Packets (and object creations and deletions) not sent on the team link because
    /// the export policy keeps them on the robot.
    pub suppressed_export: u64,
    /// Own packets that could not be encoded (dropped, logged).
    pub encode_errors: u64,
    /// Sends the transport refused.
    pub send_errors: u64,
}

/// What received packets did to the board.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MergeStats {
    /// Stored (newer, more confident, or from the owner).
    pub applied: u64,
    /// The board's packet won; nothing changed.
    pub kept: u64,
    /// `owned` attribute written by a module that does not own the object: refused.
    pub not_owner: u64,
    /// Packets and objects refused: this board's rules (`[authority] writes`) do not let
    /// their writer write them (each also a `BoardEvent::Unauthorised`).
    pub unauthorised: u64,
    /// Estimates taken into a `fused` attribute.
    pub fused: u64,
    /// Objects created on receipt.
    pub created: u64,
    /// Objects deleted on receipt (lifecycle or catch-up sweep).
    pub deleted: u64,
}

/// What was refused, by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RejectStats {
    /// slate-wire messages that did not decode, by error.
    pub decode: DecodeStats,
    /// ICI frames that did not decode.
    pub frames: u64,
    /// Packets the board refused (type, bounds, unknown attribute).
    pub invalid: u64,
    /// Packets stamped further ahead of this board's clock than it tolerates (a wrong
    /// clock at their source): refused, each also a `BoardEvent::FutureStamp`.
    pub future: u64,
    /// Packets about objects this board does not model.
    pub uninterested: u64,
    /// Packets about deleted objects (older than the deletion, or not from the owner).
    pub stale: u64,
    /// An object arrived with a class other than the one this board has under its name.
    pub object_conflicts: u64,
    /// A class definition arrived that differs from this board's.
    pub class_conflicts: u64,
    /// Duplicate stream messages (already received).
    pub duplicates: u64,
    /// Objects, or modules, refused past this ICI's bounds (`max_objects_per_source`,
    /// `max_objects`, `max_modules`).
    pub over_limit: u64,
}

/// Catch-ups.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CatchUpStats {
    /// Gaps found in a source's stream (a missing position, or a heartbeat ahead).
    pub gaps: u64,
    /// Requests sent (first tries).
    pub requested: u64,
    /// Requests sent again after the retry interval.
    pub retried: u64,
    /// Answers received in full.
    pub completed: u64,
    /// Requests this module answered.
    pub answered: u64,
    /// Requests that came within the answer interval of the previous answer to the same
    /// module: they wait, merged, for one answer when the interval is over.
    pub deferred: u64,
    /// Of those, requests that waited because their module had had its share of answer
    /// bytes (`max_answer_bytes_per_requester`): a requester asking in a loop costs this
    /// module a bounded number of bytes a second.
    pub over_budget: u64,
    /// Class definitions sent on request.
    pub classes_sent: u64,
    /// Plans (and cancellations) that arrived from a module this board had not caught up
    /// with yet, held until it had (a plan may name the sender's objects).
    pub plans_held: u64,
    /// Of those, plans let through unheld after the wait's limit (the link's timeout),
    /// the catch-up still not complete.
    pub plans_hold_expired: u64,
}

/// Liveliness.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LivelinessStats {
    /// Heartbeats published.
    pub heartbeats_sent: u64,
    /// Modules that went from alive to dead on this board.
    pub lost: u64,
    /// Modules that became alive on this board (first time or back).
    pub found: u64,
    /// Sources seen restarting (a new incarnation).
    pub restarts: u64,
    /// Hellos sent again because the peer had not answered.
    pub hellos_resent: u64,
    /// Modules forgotten after being dead for `forget_dead` (their `Module` object deleted).
    pub forgotten: u64,
}
