//! The gateway's send path (docs/team-protocol.md, 2.3): the `Framer` packs members'
//! messages into numbered team frames (single or multi part, fragments across positions
//! for a message larger than the MTU), flushed when the next message would not fit or
//! `batch` after the first one; `Gateway` is the role's state: the epoch (tag), the
//! member list whose order gives the member indices, the history, and when the robot
//! hello and heartbeat are due.
//!
//! Pure state machines fed with virtual time: `team/send.rs` (the ICI's glue) publishes
//! what they return.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;

use super::frame::{
    FRAME_HEADER, MAX_MEMBERS, Member, Part, PartOf, SINGLE_PART_MEMBERS, StateRequest, StreamTag,
    TeamFrame,
};
use super::history::{History, HistoryLimits};
use super::nack::{RepairScheduler, RepairTiming};
use super::pace::{TokenBucket, TxQueue};

/// Packs parts into frames of at most `mtu` bytes.
///
/// Invariants: the open frame, if any, holds at least one part and encodes within
/// `mtu` (a part too large for an empty frame is fragmented, never held whole);
/// positions are handed out in order from 1 without holes.
#[derive(Debug)]
pub(crate) struct Framer {
    mtu: usize,
    batch: Duration,
    /// The last position handed out (0: none yet).
    seq: u64,
    open: Vec<Part>,
    /// The open parts' bytes in multi-part form when none is last (each with its length).
    open_len: usize,
    /// When the open frame got its first part.
    opened_at: Option<Duration>,
    /// The stream's [`StreamTag::check`], which every frame carries.
    check: u8,
}

/// The smallest MTU a framer works with: a header and tag check, a 10-byte position, a
/// part byte and one byte of message. Smaller settings are raised to it.
const MIN_MTU: usize = FRAME_HEADER + 12;

impl Framer {
    pub fn new(mtu: usize, batch: Duration) -> Framer {
        Framer {
            mtu: mtu.max(MIN_MTU),
            batch,
            seq: 0,
            open: Vec::new(),
            open_len: 0,
            opened_at: None,
            check: 0,
        }
    }

    /// The framer for the stream tagged `tag`.
    pub fn tagged(self, tag: StreamTag) -> Framer {
        let check = tag.check();
        Framer { check, ..self }
    }

    /// The last position handed out.
    pub fn position(&self) -> u64 {
        self.seq
    }

    /// When the open frame is due (`None`: no open frame).
    pub fn next_due(&self) -> Option<Duration> {
        self.opened_at.map(|t| t + self.batch)
    }

    /// Adds a member's whole message; returns the frames closed by it, in order.
    pub fn push(&mut self, member: u8, message: Vec<u8>, now: Duration) -> Vec<TeamFrame> {
        let part = Part::member(member, message);
        let mut closed = Vec::new();
        if !self.fits(&part) {
            closed.extend(self.flush());
        }
        if self.fits(&part) {
            self.open_len += part.encoded_len(false);
            self.open.push(part);
            self.opened_at.get_or_insert(now);
        } else {
            closed.extend(self.fragments(member, part.bytes));
        }
        closed
    }

    /// The open frame if `batch` has passed since its first part.
    pub fn due(&mut self, now: Duration) -> Option<TeamFrame> {
        if self.next_due().is_some_and(|t| t <= now) {
            return self.flush();
        }
        None
    }

    /// Closes the open frame now, if there is one.
    pub fn flush(&mut self) -> Option<TeamFrame> {
        if self.open.is_empty() {
            return None;
        }
        (self.opened_at, self.open_len) = (None, 0);
        self.seq += 1;
        let parts = std::mem::take(&mut self.open);
        Some(TeamFrame {
            seq: self.seq,
            check: self.check,
            parts,
        })
    }

    /// Would the open frame with `part` added still fit the MTU? A lone whole message
    /// of a low member goes in single-part form (no part byte), anything else in
    /// multi-part form, the last part without its length.
    fn fits(&self, part: &Part) -> bool {
        let header = FRAME_HEADER + var_len(self.seq + 1);
        let single = matches!(part.of, PartOf::Member(m) if m < SINGLE_PART_MEMBERS);
        let len = if self.open.is_empty() && single {
            header + part.bytes.len()
        } else {
            header + self.open_len + part.encoded_len(true)
        };
        len <= self.mtu
    }

    /// A message too large for one frame, over consecutive positions: every fragment
    /// but the last says MORE, every one but the first CONT (2.2). The open frame is
    /// empty when this is called.
    fn fragments(&mut self, member: u8, bytes: Vec<u8>) -> Vec<TeamFrame> {
        let mut frames = Vec::new();
        let mut rest = &bytes[..];
        let mut first = true;
        while !rest.is_empty() {
            self.seq += 1;
            let room = self.mtu - FRAME_HEADER - 1 - var_len(self.seq);
            let (chunk, after) = rest.split_at(room.min(rest.len()));
            let part = Part {
                of: PartOf::Member(member),
                cont: !first,
                more: !after.is_empty(),
                bytes: chunk.to_vec(),
            };
            frames.push(TeamFrame {
                seq: self.seq,
                check: self.check,
                parts: vec![part],
            });
            (rest, first) = (after, false);
        }
        frames
    }
}

fn var_len(v: u64) -> usize {
    (64 - v.max(1).leading_zeros() as usize).div_ceil(7)
}

/// A member's standing as its gateway sees it, for the robot hello and heartbeat.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Seen {
    pub name: Arc<str>,
    pub incarnation: u64,
    pub alive: bool,
    pub listener: bool,
}

/// What changed when the members were reviewed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Review {
    /// Membership or an incarnation changed: the hello's version moved on.
    pub hello: bool,
    /// Only liveliness changed: the heartbeat's bitmap says it.
    pub alive: bool,
}

/// The gateway role of one module: one epoch of its robot's stream.
///
/// Invariants: at most `MAX_MEMBERS` members, their indices (places in `members`)
/// never change within the epoch; `version` moves on exactly when the hello's content
/// (membership, an incarnation) changes.
#[derive(Debug)]
pub(crate) struct Gateway {
    /// The epoch: the gateway's clock when it took the role (unique per takeover).
    pub epoch: u64,
    pub tag: StreamTag,
    pub framer: Framer,
    pub history: History,
    pub members: Vec<Member>,
    pub version: u8,
    /// The hello must be said (again) once `hello_min_interval` allows.
    pub hello_due: bool,
    pub hello_sent: Option<Duration>,
    /// A heartbeat must go out at the next tick (liveliness changed).
    pub heartbeat_due: bool,
    /// When the stream last published anything (frame, hello or heartbeat).
    pub last_sent: Duration,
    /// Heartbeats sent in this epoch.
    pub heartbeats: u32,
    /// When the last full heartbeat (members' inner positions) went out.
    pub last_full: Duration,
    /// Messages dropped because their member had no index (more than `MAX_MEMBERS`).
    pub unindexed: u64,
    /// The NACKs heard for this epoch, gathered for one repair.
    pub repairs: RepairScheduler,
    /// Members' messages waiting for the radio (2.3).
    pub queue: TxQueue,
    /// What the radio may carry: data waits while it is in debt.
    pub bucket: TokenBucket,
    /// What repairs may carry, at the same rate: a repair does not wait for `bucket`
    /// (it is charged to it, and the data waits), but repairs alone never go faster
    /// than the link's rate, however many NACKs ask for them (a member NACKing in a
    /// loop cannot make the gateway send more than that).
    pub repair_bucket: TokenBucket,
    /// The inner positions of the messages in the open frame, taken when it goes out:
    /// a receiver is never told of a position it cannot have heard yet.
    told: Vec<(u8, Option<u64>)>,
    /// State asks for members held while the queue is not empty, merged per member
    /// (at most one per member).
    pub held_asks: BTreeMap<Arc<str>, StateRequest>,
    /// When the oldest of `held_asks` was held (`None` when none is).
    pub held_since: Option<Duration>,
}

impl Gateway {
    /// Takes the role at `now` with `epoch`, the first member being the gateway itself.
    pub fn new(tag: StreamTag, epoch: u64, framer: Framer, limits: HistoryLimits) -> Gateway {
        Gateway {
            epoch,
            tag,
            framer: framer.tagged(tag),
            history: History::new(limits),
            members: Vec::new(),
            version: 0,
            hello_due: true,
            hello_sent: None,
            heartbeat_due: false,
            last_sent: Duration::ZERO,
            heartbeats: 0,
            last_full: Duration::ZERO,
            unindexed: 0,
            repairs: RepairScheduler::new(RepairTiming::radio()),
            queue: TxQueue::new(usize::MAX),
            bucket: TokenBucket::new(0, 0, Duration::ZERO),
            repair_bucket: TokenBucket::new(0, 0, Duration::ZERO),
            told: Vec::new(),
            held_asks: BTreeMap::new(),
            held_since: None,
        }
    }

    /// Paces the radio at `protocol`'s rate from `now`: both buckets full. The repairs'
    /// is as deep as a receiver's round (`repair_wait` at the rate, at least a frame):
    /// the repairs of one round may go together, and no more than the link carries.
    pub fn pace(&mut self, protocol: &crate::TeamProtocol, now: Duration) {
        self.bucket = TokenBucket::of(protocol, now);
        let round = protocol.repair_wait.as_secs_f64() * f64::from(protocol.rate_bps) / 8.0;
        let depth = protocol.mtu.max(round as usize);
        self.repair_bucket = TokenBucket::new(protocol.rate_bps, depth, now);
    }

    /// Every member's last inner position, by index (what a `Gone` tells).
    pub fn inner_positions(&self) -> Vec<(u8, u64)> {
        let each = self.members.iter().enumerate();
        each.map(|(i, m)| (i as u8, m.inner_seq)).collect()
    }

    /// The index of the member called `name`, if it has one.
    pub fn index_of(&self, name: &str) -> Option<u8> {
        let at = self.members.iter().position(|m| &*m.name == name)?;
        Some(at as u8)
    }

    /// Brings the member list up to date with what the gateway sees: new members get
    /// the next index (while there is room), changed incarnations and liveliness are
    /// taken. Members not seen keep their index and are dead.
    pub fn review(&mut self, seen: &[Seen]) -> Review {
        let mut review = Review::default();
        for m in &mut self.members {
            let now_alive = seen.iter().any(|s| s.name == m.name && s.alive);
            review.alive |= m.alive != now_alive;
            m.alive = now_alive;
        }
        for s in seen {
            review.hello |= self.take(s);
        }
        if review.hello {
            self.version = self.version.wrapping_add(1);
            self.hello_due = true;
        }
        review.alive |= review.hello;
        self.heartbeat_due |= review.alive;
        review
    }

    /// Takes one member's standing: did the hello's content change?
    fn take(&mut self, s: &Seen) -> bool {
        if let Some(m) = self.members.iter_mut().find(|m| m.name == s.name) {
            let changed = m.incarnation != s.incarnation || m.listener != s.listener;
            (m.incarnation, m.listener) = (s.incarnation, s.listener);
            return changed;
        }
        if self.members.len() >= usize::from(MAX_MEMBERS) {
            return false;
        }
        self.members.push(Member {
            name: s.name.clone(),
            incarnation: s.incarnation,
            inner_seq: 0,
            alive: s.alive,
            listener: s.listener,
        });
        true
    }

    /// The liveliness bitmap of the heartbeat: bit i for member i.
    pub fn alive_bits(&self) -> u32 {
        let alive = self.members.iter().enumerate().filter(|(_, m)| m.alive);
        alive.fold(0, |bits, (i, _)| bits | 1 << i)
    }

    /// A member's message went out at inner position `inner_seq` (for the hello).
    pub fn sent_inner(&mut self, member: u8, inner_seq: Option<u64>) {
        if let (Some(m), Some(seq)) = (self.members.get_mut(usize::from(member)), inner_seq) {
            m.inner_seq = m.inner_seq.max(seq);
        }
    }

    /// A member's message (or `Mark`) at inner position `mark` was framed: its position
    /// is taken once no open frame holds it.
    pub fn framed(&mut self, member: u8, mark: Option<u64>) {
        self.told.push((member, mark));
        if self.framer.next_due().is_none() {
            self.frame_out();
        }
    }

    /// A frame went out: every position framed so far is taken.
    pub fn frame_out(&mut self) {
        for (member, mark) in std::mem::take(&mut self.told) {
            self.sent_inner(member, mark);
        }
    }

    /// Is a heartbeat due at `now`: the stream idle for `idle`, or liveliness changed?
    pub fn heartbeat_is_due(&self, now: Duration, idle: Duration) -> bool {
        self.heartbeat_due || now.saturating_sub(self.last_sent) >= idle
    }

    /// Is a full heartbeat due at `now`: one every `period`, busy or idle? A busy
    /// stream sends no idle heartbeats, yet its members' lost tails must be found too.
    pub fn full_is_due(&self, now: Duration, period: Duration) -> bool {
        !period.is_zero() && now.saturating_sub(self.last_full) >= period
    }

    /// Is the hello due at `now`, at most once per `min_interval`?
    pub fn hello_is_due(&self, now: Duration, min_interval: Duration) -> bool {
        let spaced = self
            .hello_sent
            .is_none_or(|t| now.saturating_sub(t) >= min_interval);
        self.hello_due && spaced
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::super::frame::TeamMsg;
    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    fn encoded(f: &TeamFrame) -> Vec<u8> {
        TeamMsg::Frame(f.clone()).encode()
    }

    #[test]
    fn messages_within_the_batch_share_one_frame() {
        let mut framer = Framer::new(1024, ms(250));
        assert!(framer.push(0, vec![0x11; 20], ms(0)).is_empty());
        assert!(framer.push(1, vec![0x11; 20], ms(100)).is_empty());
        assert_eq!(framer.due(ms(249)), None);
        let frame = framer.due(ms(250)).expect("due after the batch");
        assert_eq!((frame.seq, frame.parts.len()), (1, 2));
        assert_eq!(framer.next_due(), None);
    }

    #[test]
    fn a_message_that_would_not_fit_closes_the_open_frame() {
        let mut framer = Framer::new(64, ms(250));
        assert!(framer.push(0, vec![1; 40], ms(0)).is_empty());
        let closed = framer.push(0, vec![2; 40], ms(1));
        assert_eq!(closed.len(), 1);
        assert_eq!(closed[0].parts[0].bytes, vec![1; 40]);
        assert_eq!(framer.flush().map(|f| f.seq), Some(2));
    }

    #[test]
    fn no_frame_is_larger_than_the_mtu() {
        let mut framer = Framer::new(32, ms(2000));
        let mut frames = Vec::new();
        for len in [5, 31, 32, 100, 7, 3, 64] {
            frames.extend(framer.push(2, vec![9; len], ms(0)));
        }
        frames.extend(framer.flush());
        for f in &frames {
            assert!(
                encoded(f).len() <= 32,
                "frame {} is {} bytes",
                f.seq,
                encoded(f).len()
            );
        }
        let seqs: Vec<u64> = frames.iter().map(|f| f.seq).collect();
        assert_eq!(seqs, (1..=frames.len() as u64).collect::<Vec<_>>());
    }

    #[test]
    fn a_long_message_is_fragmented_over_consecutive_positions_and_joins_again() {
        let mut framer = Framer::new(32, ms(2000));
        let message: Vec<u8> = (0..100).collect();
        let frames = framer.push(3, message.clone(), ms(0));
        assert!(frames.len() >= 4);
        let first = &frames[0].parts[0];
        let last = &frames.last().unwrap().parts[0];
        assert!(!first.cont && first.more && last.cont && !last.more);
        let joined: Vec<u8> = frames
            .iter()
            .flat_map(|f| f.parts[0].bytes.clone())
            .collect();
        assert_eq!(joined, message);
    }

    fn seen(name: &str, incarnation: u64, alive: bool) -> Seen {
        Seen {
            name: name.into(),
            incarnation,
            alive,
            listener: true,
        }
    }

    fn gateway() -> Gateway {
        let framer = Framer::new(1024, ms(250));
        let limits = HistoryLimits {
            bytes: 1024,
            age: Duration::from_secs(60),
        };
        Gateway::new(StreamTag(7), 1, framer, limits)
    }

    #[test]
    fn a_new_member_or_incarnation_moves_the_hello_version_but_liveliness_does_not() {
        let mut gw = gateway();
        let first = gw.review(&[seen("exec", 1, true), seen("nav", 2, true)]);
        assert!(first.hello);
        assert_eq!((gw.version, gw.index_of("nav")), (1, Some(1)));
        let died = gw.review(&[seen("exec", 1, true)]);
        assert_eq!((died.hello, died.alive, gw.version), (false, true, 1));
        assert_eq!(gw.alive_bits(), 0b01);
        let restarted = gw.review(&[seen("exec", 1, true), seen("nav", 3, true)]);
        assert!(restarted.hello);
        assert_eq!(
            (gw.version, gw.index_of("nav"), gw.alive_bits()),
            (2, Some(1), 0b11)
        );
    }

    #[test]
    fn members_past_the_limit_get_no_index() {
        let mut gw = gateway();
        let many: Vec<Seen> = (0..40).map(|i| seen(&format!("m{i}"), 1, true)).collect();
        gw.review(&many);
        assert_eq!(gw.members.len(), usize::from(MAX_MEMBERS));
        assert_eq!(gw.index_of("m35"), None);
    }

    #[test]
    fn the_hello_is_said_at_most_once_per_min_interval() {
        let mut gw = gateway();
        assert!(gw.hello_is_due(ms(0), ms(1000)));
        gw.hello_sent = Some(ms(0));
        gw.review(&[seen("exec", 5, true)]);
        assert!(!gw.hello_is_due(ms(999), ms(1000)));
        assert!(gw.hello_is_due(ms(1000), ms(1000)));
    }

    #[test]
    fn a_full_heartbeat_is_due_every_period_busy_or_idle() {
        let mut gw = gateway();
        gw.last_full = ms(1000);
        gw.last_sent = ms(30_500);
        assert!(!gw.full_is_due(ms(30_999), ms(30_000)));
        assert!(gw.full_is_due(ms(31_000), ms(30_000)));
        assert!(
            !gw.full_is_due(ms(31_000), Duration::ZERO),
            "full_every 0: never"
        );
    }

    #[test]
    fn an_idle_stream_owes_a_heartbeat_after_the_idle_period() {
        let mut gw = gateway();
        gw.last_sent = ms(500);
        assert!(!gw.heartbeat_is_due(ms(1499), ms(1000)));
        assert!(gw.heartbeat_is_due(ms(1500), ms(1000)));
    }

    /// A member's message: its index and bytes.
    type Message = (u8, Vec<u8>);

    /// The messages of a run of frames, joined again from their fragments.
    fn messages(frames: &[TeamFrame]) -> Vec<Message> {
        let (mut out, mut open): (Vec<Message>, Option<Message>) = (vec![], None);
        for part in frames.iter().flat_map(|f| &f.parts) {
            let PartOf::Member(m) = part.of else { continue };
            let mut whole = if part.cont {
                open.take().unwrap_or((m, vec![]))
            } else {
                (m, vec![])
            };
            whole.1.extend_from_slice(&part.bytes);
            if part.more {
                open = Some(whole);
            } else {
                out.push(whole);
            }
        }
        out
    }

    proptest! {
        #[test]
        fn framing_keeps_every_message_in_order_within_the_mtu(
            mtu in MIN_MTU..200,
            sent in proptest::collection::vec((0u8..30, proptest::collection::vec(any::<u8>(), 1..300)), 0..20),
        ) {
            let mut framer = Framer::new(mtu, ms(250));
            let mut frames = Vec::new();
            for (i, (member, bytes)) in sent.iter().enumerate() {
                frames.extend(framer.push(*member, bytes.clone(), ms(i as u64)));
            }
            frames.extend(framer.flush());
            for (i, f) in frames.iter().enumerate() {
                prop_assert_eq!(f.seq, i as u64 + 1);
                prop_assert_eq!(encoded(f).len(), f.encoded_len());
                prop_assert!(encoded(f).len() <= mtu);
                prop_assert_eq!(TeamMsg::decode(&encoded(f)), Ok(TeamMsg::Frame(f.clone())));
            }
            prop_assert_eq!(messages(&frames), sent);
        }
    }
}
