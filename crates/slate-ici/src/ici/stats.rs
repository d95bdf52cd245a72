//! What an ICI counts.

use std::collections::BTreeMap;

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
    /// Class definitions sent on request.
    pub classes_sent: u64,
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
