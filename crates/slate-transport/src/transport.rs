//! The transport trait: how an ICI reaches other modules, whatever carries the bytes.
//!
//! A transport speaks module addresses (`team/robot/module`), link kinds and message
//! kinds; it never sees topics. An implementation over a pub/sub network (Zenoh) derives
//! every key expression from `(address, link kind, message kind)` in one function of its
//! own; nothing else formats keys.

use std::collections::BTreeMap;
use std::fmt;
use std::sync::Arc;

use slate_model::Address;
use slate_wire::Message;

/// The two kinds of links: between modules of one robot, and between robots.
///
/// Two modules are on one robot when their addresses share `team/robot`. A publish names
/// the kind of link it goes out on: [`LinkKind::Robot`] reaches the other modules of the
/// sender's robot, [`LinkKind::Team`] the modules of every other robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum LinkKind {
    /// Inside one robot: fast, clean, cheap.
    Robot,
    /// Between robots: slow, lossy, expensive (radio, acoustic modem).
    Team,
}

impl LinkKind {
    /// Both kinds.
    pub const ALL: [LinkKind; 2] = [LinkKind::Robot, LinkKind::Team];

    /// The kind of the link between two modules.
    pub fn between(a: &Address, b: &Address) -> LinkKind {
        if a.same_robot(b) {
            LinkKind::Robot
        } else {
            LinkKind::Team
        }
    }

    /// Lower-case name (`robot`, `team`).
    pub fn name(self) -> &'static str {
        match self {
            LinkKind::Robot => "robot",
            LinkKind::Team => "team",
        }
    }
}

impl fmt::Display for LinkKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What a message is, for routing (a transport may give kinds their own keys,
/// priorities or reliability) and for statistics.
///
/// The first nine are slate-wire messages (header version 1); the next three are the
/// ICI's own frames (header version 0, see `docs/ici.md`); the twelve after them are the
/// team protocol's frames (header version 0 kinds 4-13, and versions 2 and 3 for team data
/// and repair frames, see `docs/team-protocol.md` section 2.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[non_exhaustive]
pub enum MsgKind {
    /// A report of attribute packets.
    Report,
    /// Dictionary entries.
    Names,
    /// Class definitions.
    Classes,
    /// A plan.
    Plan,
    /// A plan acknowledgement.
    PlanAck,
    /// A plan cancellation.
    PlanCancel,
    /// A catch-up request.
    CatchUpRequest,
    /// A catch-up answer (the source's current packets).
    CatchUpAnswer,
    /// A heartbeat.
    Heartbeat,
    /// The ICI's hello: incarnation and declared interest.
    Hello,
    /// The ICI's object creations and deletions.
    Lifecycle,
    /// The ICI's list of the objects a source owns (ends a catch-up answer).
    ObjectList,
    /// A numbered frame of a robot stream, single part (`0x20..=0x2E`, the low nibble
    /// is the member index) or multi part (`0x2F`).
    TeamFrame,
    /// A repair of a range of robot-stream positions (`0x3F`).
    TeamRepair,
    /// A robot's hello: its members, their incarnations, its union interest (`0x04`).
    RobotHello,
    /// A robot's heartbeat: stream position and members' liveliness (`0x05`).
    RobotHeartbeat,
    /// A request to repair robot-stream positions or to send state (`0x06`).
    Nack,
    /// Positions a gateway can no longer repair (`0x07`).
    Gone,
    /// A member's message handed to its robot's gateway (`0x08`).
    Uplink,
    /// What a member lacks, told to its gateway (`0x09`).
    Want,
    /// A gateway's request for a member's current state (`0x0A`).
    StateRequest,
    /// The remote robots' union interest and exports, from a gateway to its members
    /// (`0x0B`).
    TeamInterest,
    /// Inner positions covered by a repair by difference (`0x0C`).
    Fill,
    /// What a gateway heard on the team link, handed to a member that does not listen
    /// there (`0x0D`).
    Forward,
    /// Bytes that are none of the above.
    Unknown,
}

impl MsgKind {
    /// Every kind.
    pub const ALL: [MsgKind; 25] = [
        MsgKind::Report,
        MsgKind::Names,
        MsgKind::Classes,
        MsgKind::Plan,
        MsgKind::PlanAck,
        MsgKind::PlanCancel,
        MsgKind::CatchUpRequest,
        MsgKind::CatchUpAnswer,
        MsgKind::Heartbeat,
        MsgKind::Hello,
        MsgKind::Lifecycle,
        MsgKind::ObjectList,
        MsgKind::TeamFrame,
        MsgKind::TeamRepair,
        MsgKind::RobotHello,
        MsgKind::RobotHeartbeat,
        MsgKind::Nack,
        MsgKind::Gone,
        MsgKind::Uplink,
        MsgKind::Want,
        MsgKind::StateRequest,
        MsgKind::TeamInterest,
        MsgKind::Fill,
        MsgKind::Forward,
        MsgKind::Unknown,
    ];

    /// The kind of a message, read from its first byte: the high nibble is the header
    /// version (0 ICI frames, 1 slate-wire, 2 team data frames, 3 team repairs), the low
    /// nibble the kind (or, in a single-part team frame, the member index).
    pub fn of(payload: &[u8]) -> MsgKind {
        let Some(&first) = payload.first() else {
            return MsgKind::Unknown;
        };
        let index = match (first >> 4, first & 0xf) {
            (1, k @ 1..=9) => k - 1,
            (0, k @ 1..=3) => k + 8,
            (0, k @ 4..=13) => k + 10,
            (2, _) => 12,
            (3, 0xf) => 13,
            _ => return MsgKind::Unknown,
        };
        MsgKind::ALL[usize::from(index)]
    }

    /// The kind of a slate-wire message.
    pub fn of_message(msg: &Message) -> MsgKind {
        match msg {
            Message::Report(_) => MsgKind::Report,
            Message::Names(_) => MsgKind::Names,
            Message::Classes(_) => MsgKind::Classes,
            Message::Plan(_) => MsgKind::Plan,
            Message::PlanAck(_) => MsgKind::PlanAck,
            Message::PlanCancel { .. } => MsgKind::PlanCancel,
            Message::CatchUpRequest(_) => MsgKind::CatchUpRequest,
            Message::CatchUpAnswer(_) => MsgKind::CatchUpAnswer,
            Message::Heartbeat(_) => MsgKind::Heartbeat,
        }
    }

    /// Lower-case name, usable as the last segment of a key.
    pub fn name(self) -> &'static str {
        match self {
            MsgKind::Report => "report",
            MsgKind::Names => "names",
            MsgKind::Classes => "classes",
            MsgKind::Plan => "plan",
            MsgKind::PlanAck => "plan_ack",
            MsgKind::PlanCancel => "plan_cancel",
            MsgKind::CatchUpRequest => "catch_up_request",
            MsgKind::CatchUpAnswer => "catch_up_answer",
            MsgKind::Heartbeat => "heartbeat",
            MsgKind::Hello => "hello",
            MsgKind::Lifecycle => "lifecycle",
            MsgKind::ObjectList => "object_list",
            MsgKind::TeamFrame => "team_frame",
            MsgKind::TeamRepair => "team_repair",
            MsgKind::RobotHello => "robot_hello",
            MsgKind::RobotHeartbeat => "robot_heartbeat",
            MsgKind::Nack => "nack",
            MsgKind::Gone => "gone",
            MsgKind::Uplink => "uplink",
            MsgKind::Want => "want",
            MsgKind::StateRequest => "state_request",
            MsgKind::TeamInterest => "team_interest",
            MsgKind::Fill => "fill",
            MsgKind::Forward => "forward",
            MsgKind::Unknown => "unknown",
        }
    }
}

impl fmt::Display for MsgKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Messages and bytes one way and the other.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Traffic {
    /// Messages sent.
    pub sent_msgs: u64,
    /// Bytes sent.
    pub sent_bytes: u64,
    /// Messages received.
    pub recv_msgs: u64,
    /// Bytes received.
    pub recv_bytes: u64,
}

impl Traffic {
    /// Counts one message sent.
    pub fn sent(&mut self, bytes: usize) {
        self.sent_msgs += 1;
        self.sent_bytes += bytes as u64;
    }

    /// Counts one message received.
    pub fn received(&mut self, bytes: usize) {
        self.recv_msgs += 1;
        self.recv_bytes += bytes as u64;
    }

    /// Adds another count to this one.
    pub fn add(&mut self, other: &Traffic) {
        self.sent_msgs += other.sent_msgs;
        self.sent_bytes += other.sent_bytes;
        self.recv_msgs += other.recv_msgs;
        self.recv_bytes += other.recv_bytes;
    }
}

/// What an endpoint sent and received, by link kind and message kind, and what it
/// could not send. A publish counts once, however many peers it reaches.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Traffic per link kind and message kind.
    pub traffic: BTreeMap<(LinkKind, MsgKind), Traffic>,
    /// Sends refused (closed endpoint, unknown peer, too large).
    pub refused: u64,
    /// Publications received and dropped because the module's handler was too far behind
    /// to take them (the transport's receive queue was full); the ICI catches up on what
    /// they carried. Zero for a transport without such a queue.
    pub behind_dropped: u64,
}

impl LinkStats {
    /// The traffic of one link kind, all message kinds together.
    pub fn link(&self, link: LinkKind) -> Traffic {
        let mut total = Traffic::default();
        for (_, t) in self.traffic.iter().filter(|((l, _), _)| *l == link) {
            total.add(t);
        }
        total
    }

    /// The traffic of one message kind on one link kind.
    pub fn get(&self, link: LinkKind, kind: MsgKind) -> Traffic {
        self.traffic.get(&(link, kind)).copied().unwrap_or_default()
    }

    /// Counts a message sent.
    pub fn sent(&mut self, link: LinkKind, kind: MsgKind, bytes: usize) {
        self.traffic.entry((link, kind)).or_default().sent(bytes);
    }

    /// Counts a message received.
    pub fn received(&mut self, link: LinkKind, kind: MsgKind, bytes: usize) {
        self.traffic
            .entry((link, kind))
            .or_default()
            .received(bytes);
    }
}

/// Why a transport refused to send.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SendError {
    /// The endpoint is closed (or its node was killed).
    #[error("the endpoint is closed")]
    Closed,
    /// The payload is over the transport's limit.
    #[error("payload of {len} bytes is over the limit of {max}")]
    TooLarge {
        /// Payload size.
        len: usize,
        /// The limit.
        max: usize,
    },
    /// The transport failed (I/O, session).
    #[error("transport failure: {0}")]
    Failed(String),
    /// The peer does not take what it is sent: its queue is full. It is reported down
    /// until it has caught up with its queue, then up again (and caught up by the ICI).
    #[error(
        "{peer} is not reading what it is sent: dropped until it catches up{}",
        if *overflowed { " (its queue just overflowed)" } else { "" }
    )]
    Congested {
        /// The peer's address.
        peer: String,
        /// This send is the one that overflowed the queue.
        overflowed: bool,
    },
}

/// What a publication does when a receiver cannot keep up with its publisher
/// ([`Transport::publish_with`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Flow {
    /// Dropped rather than waited for: a receiver that falls behind loses publications
    /// and gets the latest state later, by catch-up (what [`Transport::publish`] does).
    #[default]
    Latest,
    /// Every publication, in order, to each live peer on the link that reads: a
    /// publisher faster than its slowest receiver is slowed (the call waits for room),
    /// its messages are not dropped. For a class that needs every update (events).
    Every,
}

/// Receives what a transport delivers. Called from the transport's threads (or the
/// simulator's step loop); it must not block for long.
pub trait Handler: Send + Sync {
    /// A message from `from`.
    fn message(&self, from: &Address, payload: &[u8]);

    /// A peer became reachable (`up`) or stopped being so.
    fn peer(&self, peer: &Address, up: bool);
}

/// Moves ICI messages between modules.
///
/// Contract (checked by the `conformance` suite, built with the `testing` feature):
/// - [`publish`](Transport::publish) is best effort: a message reaches each live peer on
///   that kind of link once, or not at all, or twice, in any order.
///   [`publish_with`](Transport::publish_with) and [`Flow::Every`] ask a transport that
///   can for every message in order, the publisher waiting for slow receivers.
/// - [`send`](Transport::send) is reliable: messages to one peer arrive once and in order
///   while the peer stays reachable; a peer that goes down may miss some. It never
///   blocks on a slow peer: sends to each peer are queued (bounded); a peer whose queue
///   overflows is reported down ([`SendError::Congested`] until then) and up again once
///   it has caught up, so one peer that does not read cannot stall the others.
/// - Request and response are two `send`s (a catch-up request, then its answer); there is
///   no separate query primitive.
/// - Liveliness: the handler's [`peer`](Handler::peer) hears every peer that comes up and
///   goes down; [`peers`](Transport::peers) lists those currently up.
/// - Neither `publish` nor `send` calls the handler synchronously: a handler may send.
/// - An endpoint never receives its own messages.
pub trait Transport: Send + Sync {
    /// This endpoint's module address.
    fn address(&self) -> &Address;

    /// Installs the handler of inbound messages and peer events (replacing any other).
    fn set_handler(&self, handler: Arc<dyn Handler>);

    /// Sends to every live peer on `link` (best effort).
    fn publish(&self, link: LinkKind, kind: MsgKind, payload: &[u8]) -> Result<(), SendError>;

    /// Publishes on `link` as [`publish`](Transport::publish) does, with `flow` saying
    /// whether a receiver that cannot keep up loses the message ([`Flow::Latest`]) or
    /// slows this call down ([`Flow::Every`]: the call may wait while a peer's link or
    /// its handler is congested). Only publications are concerned: sends are reliable
    /// anyway.
    ///
    /// This default ignores `flow` and publishes best effort, for transports that
    /// cannot hold a publisher back: the simulator's (its links lose what their loss
    /// model says, and virtual time never makes a writer wait), and wrappers that do not
    /// forward it. slate-zenoh honours it (congestion control `Block`, and a receive
    /// queue that waits for room instead of dropping).
    fn publish_with(
        &self,
        link: LinkKind,
        kind: MsgKind,
        payload: &[u8],
        flow: Flow,
    ) -> Result<(), SendError> {
        let _ = flow;
        self.publish(link, kind, payload)
    }

    /// Sends to one peer, reliably and in order.
    fn send(&self, to: &Address, kind: MsgKind, payload: &[u8]) -> Result<(), SendError>;

    /// The peers currently up.
    fn peers(&self) -> Vec<Address>;

    /// Counters of what this endpoint sent and received.
    fn stats(&self) -> LinkStats;

    /// Leaves the network: stops sending and receiving; peers see it go down.
    fn close(&self);

    /// Starts (`on`) or stops receiving the publications other modules make on `link`.
    /// An endpoint listens to both kinds of links until told otherwise. Only
    /// publications are concerned: sends addressed to the endpoint and peer events still
    /// arrive, and the endpoint may still publish and send on `link`.
    ///
    /// Returns whether the transport honours the choice (the simulator and slate-zenoh
    /// do). `false` (this default, for transports that cannot choose what they
    /// receive) means nothing changed: the endpoint keeps
    /// receiving every publication, whatever `on` says, and the ICI must expect them.
    fn listen(&self, link: LinkKind, on: bool) -> bool {
        let _ = (link, on);
        false
    }

    /// Whether a send reaches a peer that stays reachable, the transport retransmitting
    /// what the network lost (TCP; the simulator's sends). `false` for a transport over
    /// datagrams that lose what the network loses (Zenoh's `udp/` links): plan circuits
    /// then send an unanswered plan again and repeat a circuit's last step themselves,
    /// which on a retransmitting transport would only add load to a slow link.
    fn retransmits(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_are_read_from_the_header_byte() {
        assert_eq!(MsgKind::of(&[0x11]), MsgKind::Report);
        assert_eq!(MsgKind::of(&[0x19]), MsgKind::Heartbeat);
        assert_eq!(MsgKind::of(&[0x01]), MsgKind::Hello);
        assert_eq!(MsgKind::of(&[0x03]), MsgKind::ObjectList);
        for bad in [
            [0x10],
            [0x1a],
            [0x00],
            [0x0e],
            [0x30],
            [0x3e],
            [0x40],
            [0xff],
        ] {
            assert_eq!(MsgKind::of(&bad), MsgKind::Unknown, "{bad:?}");
        }
        assert_eq!(MsgKind::of(&[]), MsgKind::Unknown);
    }

    /// The kind of every header byte, written out by hand (not by `of`'s rule), so a
    /// change to either one shows here.
    fn expected_kind(header: u8) -> MsgKind {
        let old = [MsgKind::Hello, MsgKind::Lifecycle, MsgKind::ObjectList];
        let wire = &MsgKind::ALL[..9];
        let team = &MsgKind::ALL[14..24];
        match header {
            0x01..=0x03 => old[usize::from(header - 1)],
            0x04..=0x0d => team[usize::from(header - 4)],
            0x11..=0x19 => wire[usize::from(header - 0x11)],
            0x20..=0x2f => MsgKind::TeamFrame,
            0x3f => MsgKind::TeamRepair,
            _ => MsgKind::Unknown,
        }
    }

    #[test]
    fn every_header_byte_maps_to_its_kind() {
        for header in 0..=u8::MAX {
            assert_eq!(
                MsgKind::of(&[header, 9]),
                expected_kind(header),
                "{header:#04x}"
            );
        }
    }

    #[test]
    fn the_team_protocols_headers_name_their_frames() {
        let named = [
            (0x20, "team_frame"),
            (0x2e, "team_frame"),
            (0x2f, "team_frame"),
            (0x3f, "team_repair"),
            (0x04, "robot_hello"),
            (0x05, "robot_heartbeat"),
            (0x06, "nack"),
            (0x07, "gone"),
            (0x08, "uplink"),
            (0x09, "want"),
            (0x0a, "state_request"),
            (0x0b, "team_interest"),
            (0x0c, "fill"),
            (0x0d, "forward"),
        ];
        assert_names(&named);
    }

    /// Each header reads as the kind of that name.
    fn assert_names(named: &[(u8, &str)]) {
        for &(header, name) in named {
            assert_eq!(MsgKind::of(&[header]).name(), name, "{header:#04x}");
        }
    }

    #[test]
    fn the_old_kinds_keep_their_headers_and_names() {
        let old = [
            (0x11, "report"),
            (0x12, "names"),
            (0x13, "classes"),
            (0x14, "plan"),
            (0x15, "plan_ack"),
            (0x16, "plan_cancel"),
            (0x17, "catch_up_request"),
            (0x18, "catch_up_answer"),
            (0x19, "heartbeat"),
            (0x01, "hello"),
            (0x02, "lifecycle"),
            (0x03, "object_list"),
        ];
        assert_names(&old);
    }

    #[test]
    fn every_kind_has_its_own_name() {
        let names: std::collections::BTreeSet<_> = MsgKind::ALL.iter().map(|k| k.name()).collect();
        assert_eq!(names.len(), MsgKind::ALL.len());
    }

    #[test]
    fn links_are_robot_or_team_by_address() {
        let a = Address::new("t/r1/nav").unwrap();
        let b = Address::new("t/r1/cam").unwrap();
        let c = Address::new("t/r2/nav").unwrap();
        assert_eq!(LinkKind::between(&a, &b), LinkKind::Robot);
        assert_eq!(LinkKind::between(&a, &c), LinkKind::Team);
    }
}
