//! The team protocol's frames and their byte layouts (docs/team-protocol.md, section
//! 2.2): on the team link the robot stream's data frames (`TeamFrame`) and repairs
//! (`TeamRepair`), the robot hello and heartbeat, `Nack` and `Gone`; on the robot link
//! `Uplink`, `Want`, `StateRequest`, `TeamInterest` and `Forward`; and `Fill`, an inner
//! message of a repair by difference. Also the stream tag that names one epoch of a robot stream.
//!
//! Header byte: version 0 (kinds 4-13) for the control frames, version 2 for data frames
//! (the low nibble is the member index of a single-part frame, 15 for multi part), 0x3F
//! for repairs. Fields use the ICI frames' varints and strings (`ici/frame.rs`). Decoding
//! checks every length against the bytes left, bounds every count, refuses trailing
//! bytes and never panics. This module holds no state: the tracker, the NACK scheduler
//! and the gateway call it.

use std::sync::Arc;

use slate_model::Address;

use crate::ici::classes::ClassSet;
use crate::ici::frame::{FrameError, MAX_ITEMS, Reader, Writer, read_class_set};

const ROBOT_HELLO: u8 = 0x04;
const ROBOT_HEARTBEAT: u8 = 0x05;
const NACK: u8 = 0x06;
const GONE: u8 = 0x07;
const UPLINK: u8 = 0x08;
const WANT: u8 = 0x09;
const STATE_REQUEST: u8 = 0x0A;
const TEAM_INTEREST: u8 = 0x0B;
const FILL: u8 = 0x0C;
const FORWARD: u8 = 0x0D;
/// Header version 2: a data frame; the low nibble is the member index, or `MULTI_PART`.
const DATA: u8 = 0x20;
const MULTI_PART: u8 = 0x2F;
const REPAIR: u8 = 0x3F;
/// Bytes before a frame's or repair's first position: the header and the tag check.
pub(crate) const FRAME_HEADER: usize = 2;

/// Members a robot can have: the part byte's 5-bit index, less the two special codes.
pub(crate) const MAX_MEMBERS: u8 = 30;
/// Members whose lone message can go in a single-part frame (the header's low nibble).
pub(crate) const SINGLE_PART_MEMBERS: u8 = 15;
/// The most positions one range (`Span`) may cover: far above `max_nack_frames` (64),
/// so that a corrupt varint cannot make a receiver walk 2⁶⁴ positions.
pub(crate) const MAX_SPAN: u64 = MAX_ITEMS;

/// The bits of a part's first byte.
const PART_INDEX: u8 = 0x1F;
const PART_CONTROL: u8 = 30;
const PART_ADDRESSED: u8 = 31;
const PART_LAST: u8 = 1 << 5;
const PART_CONT: u8 = 1 << 6;
const PART_MORE: u8 = 1 << 7;

/// A team frame that could not be read.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub(crate) enum TeamFrameError {
    /// The bytes end inside a field.
    #[error("team frame truncated")]
    Truncated,
    /// A field holds what its layout forbids; the text says which.
    #[error("bad team frame: {0}")]
    Bad(&'static str),
    /// The header byte is not one of the team protocol's.
    #[error("not a team frame: header {0:#04x}")]
    NotTeam(u8),
}

impl From<FrameError> for TeamFrameError {
    fn from(e: FrameError) -> Self {
        match e {
            FrameError::Truncated => TeamFrameError::Truncated,
            FrameError::Bad(what) => TeamFrameError::Bad(what),
        }
    }
}

type Result<T> = std::result::Result<T, TeamFrameError>;

// ----- the stream tag -----

/// Names one epoch of one robot stream in 2 bytes: the FNV-1a-16 (the 32-bit FNV-1a,
/// xor-folded to 16 bits) of the gateway's address text followed by its incarnation as
/// 8 big-endian bytes. A new gateway or a restarted one gives a new tag. Two streams
/// of one team may share a tag (section 2.9): that costs a second repair, not
/// correctness, since each repair is checked against its own stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) struct StreamTag(pub u16);

impl StreamTag {
    /// What each frame and repair carries of its stream's tag: the low byte. It tells a
    /// frame of a gateway's new epoch, heard before the new hello, from the old epoch's
    /// position of the same number (which the old hello would otherwise make it): a
    /// second byte would only shrink the chance that two epochs of one gateway share
    /// the byte (1 in 256 per restart) further.
    pub fn check(self) -> u8 {
        self.0 as u8
    }
}

impl StreamTag {
    /// The tag of the stream `gateway` starts in its incarnation `incarnation`.
    pub fn of(gateway: &Address, incarnation: u64) -> StreamTag {
        let text = gateway.as_str().bytes();
        let hash = fnv1a_32(text.chain(incarnation.to_be_bytes()));
        StreamTag(((hash >> 16) ^ (hash & 0xFFFF)) as u16)
    }
}

fn fnv1a_32(bytes: impl IntoIterator<Item = u8>) -> u32 {
    bytes.into_iter().fold(0x811C_9DC5, |hash, b| {
        (hash ^ u32::from(b)).wrapping_mul(0x0100_0193)
    })
}

// ----- the frames -----

/// Positions `from .. from + n` of a robot stream. Invariant (checked when decoded):
/// `1 <= n <= MAX_SPAN` and `from + n` does not overflow.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Span {
    pub from: u64,
    pub n: u64,
}

impl Span {
    /// One past the last position (saturating, for a span built against the invariant).
    pub fn end(self) -> u64 {
        self.from.saturating_add(self.n)
    }
}

/// Who a part of a frame is for, or from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PartOf {
    /// A message of the member with this index (`< MAX_MEMBERS`) in its robot's hello.
    Member(u8),
    /// A whole `Nack` or `RobotHeartbeat` frame (header byte included), so that a NACK
    /// can ride in a data frame on the acoustic link. Decode it with `TeamMsg::decode`.
    Control,
    /// A message from member `src_member` of the sending robot to member `dest_member`
    /// of the robot whose stream is `dest_tag` (plans, acks, explicit reports).
    Addressed {
        dest_tag: StreamTag,
        dest_member: u8,
        src_member: u8,
    },
}

/// One part of a frame: a member's message, or a fragment of one. `cont`: these bytes
/// continue the previous position's message; `more`: the message continues in the next
/// position's first part. Whether a part is the frame's last (and so has no length) is
/// decided by its place when encoding, not stored.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Part {
    pub of: PartOf,
    pub cont: bool,
    pub more: bool,
    pub bytes: Vec<u8>,
}

impl Part {
    /// A whole message of member `index`.
    pub fn member(index: u8, bytes: Vec<u8>) -> Part {
        debug_assert!(index < MAX_MEMBERS);
        Part {
            of: PartOf::Member(index),
            cont: false,
            more: false,
            bytes,
        }
    }

    /// Bytes this part takes in a frame, `last` when it ends the frame (no length).
    pub fn encoded_len(&self, last: bool) -> usize {
        let addressed = usize::from(matches!(self.of, PartOf::Addressed { .. }));
        let len = usize::from(!last) * var_len(self.bytes.len() as u64);
        1 + 4 * addressed + len + self.bytes.len()
    }

    /// Can this part be a frame's only part in single-part form (header `0x2m`)?
    fn fits_single(&self) -> bool {
        let low_member = matches!(self.of, PartOf::Member(m) if m < SINGLE_PART_MEMBERS);
        low_member && !self.cont && !self.more
    }
}

/// A numbered frame of a robot stream. Invariant: at least one part. It goes in
/// single-part form (1 header byte, no part byte) when it holds one whole message of a
/// member below `SINGLE_PART_MEMBERS`, in multi-part form otherwise; a decoded frame
/// gives its parts the same way in both.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct TeamFrame {
    pub seq: u64,
    /// Its stream's [`StreamTag::check`].
    pub check: u8,
    pub parts: Vec<Part>,
}

impl TeamFrame {
    /// The member index and message of a frame that goes in single-part form.
    fn single(&self) -> Option<(u8, &[u8])> {
        match self.parts.as_slice() {
            [only] if only.fits_single() => match only.of {
                PartOf::Member(index) => Some((index, &only.bytes)),
                _ => None,
            },
            _ => None,
        }
    }

    /// The frame's length once encoded, without encoding it (the gateway's MTU check).
    pub fn encoded_len(&self) -> usize {
        let header = FRAME_HEADER + var_len(self.seq);
        match self.single() {
            Some((_, message)) => header + message.len(),
            None => header + parts_len(&self.parts),
        }
    }
}

/// What a repair carries for positions `from ..`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum RepairContent {
    /// Mode 0: the original frames' parts, one list per position from `from` on.
    /// Invariant: 1 to `MAX_SPAN` positions, each with at least one part.
    Replay(Vec<Vec<Part>>),
    /// Mode 1: parts that stand for positions `from .. from + n` as a whole. Invariant:
    /// at least one part.
    Difference { n: u64, parts: Vec<Part> },
}

/// A broadcast repair of a range of the sender's robot stream.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct TeamRepair {
    pub from: u64,
    /// Its stream's [`StreamTag::check`].
    pub check: u8,
    pub content: RepairContent,
}

impl TeamRepair {
    /// The positions the repair covers.
    pub fn span(&self) -> Span {
        let n = match &self.content {
            RepairContent::Replay(bodies) => bodies.len() as u64,
            RepairContent::Difference { n, .. } => *n,
        };
        Span { from: self.from, n }
    }

    /// The repair's length once encoded, without encoding it (to split at the MTU).
    pub fn encoded_len(&self) -> usize {
        let span = self.span();
        let head = FRAME_HEADER + var_len(span.from) + var_len(span.n) + 1;
        match &self.content {
            RepairContent::Replay(bodies) => {
                head + bodies.iter().map(|b| body_len(b)).sum::<usize>()
            }
            RepairContent::Difference { parts, .. } => head + parts_len(parts),
        }
    }
}

/// Bytes of a replay body: its length, then its parts.
fn body_len(parts: &[Part]) -> usize {
    let len = parts_len(parts);
    var_len(len as u64) + len
}

/// A member as its robot's hello lists it; its index is its place in the list.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Member {
    /// The module segment of the member's address.
    pub name: Arc<str>,
    pub incarnation: u64,
    /// The member's last inner team sequence number.
    pub inner_seq: u64,
    pub alive: bool,
    pub listener: bool,
}

/// A robot's hello: its stream, members, union interest and exports. Invariant: at
/// most `MAX_MEMBERS` members.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct RobotHello {
    /// Changes (+1, wrapping) with membership, an incarnation or the interest.
    pub version: u8,
    pub tag: StreamTag,
    pub gw_incarnation: u64,
    /// Sent by a short-lived observer: answer it by unicast.
    pub observer: bool,
    pub interest: ClassSet,
    pub exports: ClassSet,
    pub members: Vec<Member>,
}

/// A robot's heartbeat, sent when its stream has been idle. Invariants: `alive` uses
/// only the low `MAX_MEMBERS` bits; at most `MAX_MEMBERS` positions.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct RobotHeartbeat {
    pub tag: StreamTag,
    pub hello_version: u8,
    /// The last position of the robot stream.
    pub seq: u64,
    /// Bit i: member i is alive.
    pub alive: u32,
    /// Every member's inner position, in a *full* heartbeat (every `full_every`).
    pub positions: Option<Vec<u64>>,
}

/// A receiver's ask for a member's state. Invariant: `members` uses only the low
/// `MAX_MEMBERS` bits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct StateAsk {
    /// Bit i: member i.
    pub members: u32,
    /// Re-announce the dictionary's names.
    pub names: bool,
    /// Send the class definitions.
    pub classes: bool,
}

/// What a receiver lacks of one robot stream. Invariant: asks for something.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct NackEntry {
    pub tag: StreamTag,
    pub frames: Option<Span>,
    pub hello: bool,
    pub state: Option<StateAsk>,
}

/// A NACK on the team link (`Nack`) or a member's lack told to its gateway (`Want`):
/// one entry per stream. Invariant: 1 to `MAX_ITEMS` entries.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Nack {
    pub entries: Vec<NackEntry>,
}

/// Positions a gateway can no longer repair, with its members' current inner positions
/// (member index, inner seq) so receivers can tell who they must ask for state.
/// Invariant: at most `MAX_MEMBERS` positions, indices below `MAX_MEMBERS`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Gone {
    pub tag: StreamTag,
    pub span: Span,
    pub positions: Vec<(u8, u64)>,
}

/// A member's message handed to its gateway over the robot link.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Uplink {
    /// The destination module of an addressed message.
    pub to: Option<Address>,
    /// The message is (part of) a state answer.
    pub state_answer: bool,
    /// A mark after a takeover: the member's current inner team sequence number.
    pub mark: Option<u64>,
    /// The inner message, as the member would have published it.
    pub message: Vec<u8>,
}

/// What a gateway heard on the team link, handed over the robot link to a member that
/// does not listen there (2.1): the sender on the team link, and its bytes as heard.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Forward {
    pub from: Address,
    /// A team-link frame (never a `Forward`: the receiver refuses one inside another).
    pub message: Vec<u8>,
}

/// A gateway's request to a member for its current state, on behalf of robots.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct StateRequest {
    pub names: bool,
    pub classes: bool,
    /// The robot segments of the robots asking. Invariant: at most `MAX_ITEMS`.
    pub robots: Vec<Arc<str>>,
}

/// The remote robots' union interest and exports, from a gateway to its members.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct TeamInterest {
    pub version: u64,
    pub interest: ClassSet,
    pub exports: ClassSet,
}

/// A member's inner positions `from..=to` are covered (by a repair by difference).
/// Invariant: `from <= to`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Fill {
    pub from: u64,
    pub to: u64,
}

/// Any team protocol frame, by its header byte.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum TeamMsg {
    Frame(TeamFrame),
    Repair(TeamRepair),
    Hello(RobotHello),
    Heartbeat(RobotHeartbeat),
    Nack(Nack),
    Gone(Gone),
    Uplink(Uplink),
    /// Same body as a `Nack`, on the robot link.
    Want(Nack),
    StateRequest(StateRequest),
    Interest(TeamInterest),
    Fill(Fill),
    Forward(Forward),
}

// ----- writing -----

/// Bytes of `v` as a varint.
fn var_len(v: u64) -> usize {
    (64 - v.max(1).leading_zeros() as usize).div_ceil(7)
}

fn parts_len(parts: &[Part]) -> usize {
    let last = parts.len().saturating_sub(1);
    let each = parts.iter().enumerate();
    each.map(|(i, p)| p.encoded_len(i == last)).sum()
}

impl TeamMsg {
    /// The frame's bytes, header included.
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::default();
        match self {
            TeamMsg::Frame(f) => write_frame(&mut w, f),
            TeamMsg::Repair(r) => write_repair(&mut w, r),
            TeamMsg::Hello(h) => write_hello(&mut w, h),
            TeamMsg::Heartbeat(h) => write_heartbeat(&mut w, h),
            TeamMsg::Nack(n) => write_nack(&mut w, NACK, n),
            TeamMsg::Gone(g) => write_gone(&mut w, g),
            TeamMsg::Uplink(u) => write_uplink(&mut w, u),
            TeamMsg::Want(n) => write_nack(&mut w, WANT, n),
            TeamMsg::StateRequest(s) => write_state_request(&mut w, s),
            TeamMsg::Interest(i) => write_interest(&mut w, i),
            TeamMsg::Fill(f) => write_fill(&mut w, f),
            TeamMsg::Forward(f) => write_forward(&mut w, f),
        }
        w.0
    }
}

fn write_tag(w: &mut Writer, tag: StreamTag) {
    w.0.extend_from_slice(&tag.0.to_be_bytes());
}

fn write_span(w: &mut Writer, span: Span) {
    w.var(span.from);
    w.var(span.n);
}

fn write_classes(w: &mut Writer, set: &ClassSet) {
    w.var(set.rules().len() as u64);
    for (class, mask) in set.rules() {
        w.str(class);
        w.0.push(*mask);
    }
}

fn write_part(w: &mut Writer, part: &Part, last: bool) {
    let flags = (u8::from(last) * PART_LAST)
        | (u8::from(part.cont) * PART_CONT)
        | (u8::from(part.more) * PART_MORE);
    match part.of {
        PartOf::Member(index) => w.0.push(index | flags),
        PartOf::Control => w.0.push(PART_CONTROL | flags),
        PartOf::Addressed {
            dest_tag,
            dest_member,
            src_member,
        } => {
            w.0.push(PART_ADDRESSED | flags);
            write_tag(w, dest_tag);
            w.0.extend_from_slice(&[dest_member, src_member]);
        }
    }
    if !last {
        w.var(part.bytes.len() as u64);
    }
    w.0.extend_from_slice(&part.bytes);
}

fn write_parts(w: &mut Writer, parts: &[Part]) {
    let last = parts.len().saturating_sub(1);
    for (i, part) in parts.iter().enumerate() {
        write_part(w, part, i == last);
    }
}

fn write_frame(w: &mut Writer, f: &TeamFrame) {
    match f.single() {
        Some((index, message)) => {
            w.0.extend_from_slice(&[DATA | index, f.check]);
            w.var(f.seq);
            w.0.extend_from_slice(message);
        }
        None => {
            w.0.extend_from_slice(&[MULTI_PART, f.check]);
            w.var(f.seq);
            write_parts(w, &f.parts);
        }
    }
}

fn write_repair(w: &mut Writer, r: &TeamRepair) {
    w.0.extend_from_slice(&[REPAIR, r.check]);
    write_span(w, r.span());
    match &r.content {
        RepairContent::Replay(bodies) => {
            w.0.push(0);
            for parts in bodies {
                w.var(parts_len(parts) as u64);
                write_parts(w, parts);
            }
        }
        RepairContent::Difference { parts, .. } => {
            w.0.push(1);
            write_parts(w, parts);
        }
    }
}

/// The bits of a robot hello's flags and of a member's flags.
const HELLO_OBSERVER: u8 = 1;
const MEMBER_ALIVE: u8 = 1;
const MEMBER_LISTENER: u8 = 2;

fn write_hello(w: &mut Writer, h: &RobotHello) {
    w.0.push(ROBOT_HELLO);
    w.0.push(h.version);
    write_tag(w, h.tag);
    w.var(h.gw_incarnation);
    w.0.push(u8::from(h.observer) * HELLO_OBSERVER);
    write_classes(w, &h.interest);
    write_classes(w, &h.exports);
    w.var(h.members.len() as u64);
    h.members.iter().for_each(|m| write_hello_member(w, m));
}

fn write_hello_member(w: &mut Writer, m: &Member) {
    w.str(&m.name);
    w.var(m.incarnation);
    w.var(m.inner_seq);
    w.0.push((u8::from(m.alive) * MEMBER_ALIVE) | (u8::from(m.listener) * MEMBER_LISTENER));
}

fn write_heartbeat(w: &mut Writer, h: &RobotHeartbeat) {
    w.0.push(ROBOT_HEARTBEAT);
    write_tag(w, h.tag);
    w.0.push(h.hello_version);
    w.var(h.seq);
    w.var(u64::from(h.alive));
    if let Some(positions) = &h.positions {
        w.var(positions.len() as u64);
        positions.iter().for_each(|p| w.var(*p));
    }
}

/// The bits of a NACK entry's `what` and of its state flags.
const WHAT_FRAMES: u8 = 1;
const WHAT_HELLO: u8 = 2;
const WHAT_STATE: u8 = 4;
const STATE_NAMES: u8 = 1;
const STATE_CLASSES: u8 = 2;

fn write_entry(w: &mut Writer, e: &NackEntry) {
    write_tag(w, e.tag);
    let what = (u8::from(e.frames.is_some()) * WHAT_FRAMES)
        | (u8::from(e.hello) * WHAT_HELLO)
        | (u8::from(e.state.is_some()) * WHAT_STATE);
    w.0.push(what);
    if let Some(span) = e.frames {
        write_span(w, span);
    }
    if let Some(ask) = e.state {
        w.var(u64::from(ask.members));
        w.0.push(state_flags(ask.names, ask.classes));
    }
}

fn state_flags(names: bool, classes: bool) -> u8 {
    (u8::from(names) * STATE_NAMES) | (u8::from(classes) * STATE_CLASSES)
}

fn write_nack(w: &mut Writer, header: u8, n: &Nack) {
    w.0.push(header);
    w.var(n.entries.len() as u64);
    n.entries.iter().for_each(|e| write_entry(w, e));
}

fn write_gone(w: &mut Writer, g: &Gone) {
    w.0.push(GONE);
    write_tag(w, g.tag);
    write_span(w, g.span);
    w.var(g.positions.len() as u64);
    for (member, inner_seq) in &g.positions {
        w.0.push(*member);
        w.var(*inner_seq);
    }
}

/// The bits of an uplink's flags.
const UPLINK_ADDRESSED: u8 = 1;
const UPLINK_STATE_ANSWER: u8 = 2;
const UPLINK_MARK: u8 = 4;

fn write_uplink(w: &mut Writer, u: &Uplink) {
    w.0.push(UPLINK);
    let flags = (u8::from(u.to.is_some()) * UPLINK_ADDRESSED)
        | (u8::from(u.state_answer) * UPLINK_STATE_ANSWER)
        | (u8::from(u.mark.is_some()) * UPLINK_MARK);
    w.0.push(flags);
    if let Some(to) = &u.to {
        w.str(to.as_str());
    }
    if let Some(inner_seq) = u.mark {
        w.var(inner_seq);
    }
    w.0.extend_from_slice(&u.message);
}

fn write_forward(w: &mut Writer, f: &Forward) {
    w.0.push(FORWARD);
    w.str(f.from.as_str());
    w.0.extend_from_slice(&f.message);
}

fn write_state_request(w: &mut Writer, s: &StateRequest) {
    w.0.push(STATE_REQUEST);
    w.0.push(state_flags(s.names, s.classes));
    w.var(s.robots.len() as u64);
    s.robots.iter().for_each(|r| w.str(r));
}

fn write_interest(w: &mut Writer, i: &TeamInterest) {
    w.0.push(TEAM_INTEREST);
    w.var(i.version);
    write_classes(w, &i.interest);
    write_classes(w, &i.exports);
}

fn write_fill(w: &mut Writer, f: &Fill) {
    w.0.push(FILL);
    w.var(f.from);
    w.var(f.to);
}

// ----- reading -----

impl TeamMsg {
    /// Reads a team protocol frame; refuses anything else, short or long.
    pub fn decode(bytes: &[u8]) -> Result<TeamMsg> {
        let mut r = Reader { bytes, at: 0 };
        let msg = read_msg(&mut r)?;
        if r.at != bytes.len() {
            return Err(TeamFrameError::Bad("trailing bytes"));
        }
        Ok(msg)
    }
}

fn read_msg(r: &mut Reader<'_>) -> Result<TeamMsg> {
    Ok(match r.byte()? {
        header @ DATA..MULTI_PART => TeamMsg::Frame(read_single(r, header & 0xF)?),
        MULTI_PART => TeamMsg::Frame(read_multi(r)?),
        REPAIR => TeamMsg::Repair(read_repair(r)?),
        ROBOT_HELLO => TeamMsg::Hello(read_hello(r)?),
        ROBOT_HEARTBEAT => TeamMsg::Heartbeat(read_heartbeat(r)?),
        NACK => TeamMsg::Nack(read_nack(r)?),
        GONE => TeamMsg::Gone(read_gone(r)?),
        UPLINK => TeamMsg::Uplink(read_uplink(r)?),
        WANT => TeamMsg::Want(read_nack(r)?),
        STATE_REQUEST => TeamMsg::StateRequest(read_state_request(r)?),
        TEAM_INTEREST => TeamMsg::Interest(read_interest(r)?),
        FILL => TeamMsg::Fill(read_fill(r)?),
        FORWARD => TeamMsg::Forward(read_forward(r)?),
        other => return Err(TeamFrameError::NotTeam(other)),
    })
}

/// The bytes from here to the end.
fn rest<'a>(r: &mut Reader<'a>) -> &'a [u8] {
    let rest = &r.bytes[r.at..];
    r.at = r.bytes.len();
    rest
}

/// The next `len` bytes, if there are that many.
fn take<'a>(r: &mut Reader<'a>, len: u64) -> Result<&'a [u8]> {
    let left = r.bytes.len() - r.at;
    if len > left as u64 {
        return Err(TeamFrameError::Truncated);
    }
    let taken = &r.bytes[r.at..r.at + len as usize];
    r.at += len as usize;
    Ok(taken)
}

fn read_tag(r: &mut Reader<'_>) -> Result<StreamTag> {
    Ok(StreamTag(u16::from_be_bytes([r.byte()?, r.byte()?])))
}

fn read_span(r: &mut Reader<'_>) -> Result<Span> {
    let span = Span {
        from: r.var()?,
        n: r.var()?,
    };
    if span.n == 0 || span.n > MAX_SPAN {
        return Err(TeamFrameError::Bad("range length"));
    }
    if span.from.checked_add(span.n).is_none() {
        return Err(TeamFrameError::Bad("range beyond the last position"));
    }
    Ok(span)
}

/// A member index (below `MAX_MEMBERS`).
fn read_member(r: &mut Reader<'_>) -> Result<u8> {
    let index = r.byte()?;
    if index >= MAX_MEMBERS {
        return Err(TeamFrameError::Bad("member index"));
    }
    Ok(index)
}

/// A bitmap over member indices.
fn read_bitmap(r: &mut Reader<'_>) -> Result<u32> {
    let bits = r.var()?;
    if bits >> MAX_MEMBERS != 0 {
        return Err(TeamFrameError::Bad("member bitmap"));
    }
    Ok(bits as u32)
}

/// A count of members (at most `MAX_MEMBERS`, and no more than the bytes left).
fn read_member_count(r: &mut Reader<'_>) -> Result<usize> {
    let n = r.count()?;
    if n > usize::from(MAX_MEMBERS) {
        return Err(TeamFrameError::Bad("more members than a robot can have"));
    }
    Ok(n)
}

/// Flags whose bits outside `known` must be 0.
fn read_flags(r: &mut Reader<'_>, known: u8, what: &'static str) -> Result<u8> {
    let flags = r.byte()?;
    if flags & !known != 0 {
        return Err(TeamFrameError::Bad(what));
    }
    Ok(flags)
}

/// An address segment (robot or module name): letters, digits, `_` and `-`.
fn read_segment(r: &mut Reader<'_>) -> Result<Arc<str>> {
    let text = r.text()?;
    let ok = !text.is_empty()
        && (text.bytes()).all(|c| c.is_ascii_alphanumeric() || c == b'_' || c == b'-');
    if !ok {
        return Err(TeamFrameError::Bad("not an address segment"));
    }
    Ok(text.into())
}

fn read_classes(r: &mut Reader<'_>) -> Result<ClassSet> {
    Ok(read_class_set(r)?)
}

fn read_single(r: &mut Reader<'_>, index: u8) -> Result<TeamFrame> {
    let (check, seq) = (r.byte()?, r.var()?);
    let only = Part::member(index, rest(r).to_vec());
    Ok(TeamFrame {
        seq,
        check,
        parts: vec![only],
    })
}

fn read_multi(r: &mut Reader<'_>) -> Result<TeamFrame> {
    let (check, seq) = (r.byte()?, r.var()?);
    Ok(TeamFrame {
        seq,
        check,
        parts: read_parts(r)?,
    })
}

/// Parts up to the end of the reader's bytes: at least one, the last marked LAST.
fn read_parts(r: &mut Reader<'_>) -> Result<Vec<Part>> {
    let mut parts = Vec::new();
    while r.at < r.bytes.len() {
        let (part, last) = read_part(r)?;
        parts.push(part);
        if !last && r.at == r.bytes.len() {
            return Err(TeamFrameError::Bad("the last part is not marked LAST"));
        }
    }
    if parts.is_empty() {
        return Err(TeamFrameError::Bad("no parts"));
    }
    Ok(parts)
}

/// One part, and whether it was marked LAST.
fn read_part(r: &mut Reader<'_>) -> Result<(Part, bool)> {
    let p = r.byte()?;
    let of = match p & PART_INDEX {
        PART_CONTROL => PartOf::Control,
        PART_ADDRESSED => read_addressed(r)?,
        index => PartOf::Member(index),
    };
    let last = p & PART_LAST != 0;
    let bytes = if last {
        rest(r)
    } else {
        let len = r.var()?;
        take(r, len)?
    };
    let (cont, more) = (p & PART_CONT != 0, p & PART_MORE != 0);
    let bytes = bytes.to_vec();
    Ok((
        Part {
            of,
            cont,
            more,
            bytes,
        },
        last,
    ))
}

fn read_addressed(r: &mut Reader<'_>) -> Result<PartOf> {
    Ok(PartOf::Addressed {
        dest_tag: read_tag(r)?,
        dest_member: read_member(r)?,
        src_member: read_member(r)?,
    })
}

fn read_repair(r: &mut Reader<'_>) -> Result<TeamRepair> {
    let check = r.byte()?;
    let span = read_span(r)?;
    let content = match r.byte()? {
        0 => RepairContent::Replay(read_bodies(r, span.n)?),
        1 => RepairContent::Difference {
            n: span.n,
            parts: read_parts(r)?,
        },
        _ => return Err(TeamFrameError::Bad("repair mode")),
    };
    Ok(TeamRepair {
        from: span.from,
        check,
        content,
    })
}

/// `n` length-prefixed bodies of parts (each takes at least 2 bytes).
fn read_bodies(r: &mut Reader<'_>, n: u64) -> Result<Vec<Vec<Part>>> {
    if n > (r.bytes.len() - r.at) as u64 / 2 {
        return Err(TeamFrameError::Bad("more positions than bytes"));
    }
    let mut bodies = Vec::new();
    for _ in 0..n {
        let len = r.var()?;
        let mut body = Reader {
            bytes: take(r, len)?,
            at: 0,
        };
        bodies.push(read_parts(&mut body)?);
    }
    Ok(bodies)
}

fn read_hello(r: &mut Reader<'_>) -> Result<RobotHello> {
    let version = r.byte()?;
    let tag = read_tag(r)?;
    let gw_incarnation = r.var()?;
    let flags = read_flags(r, HELLO_OBSERVER, "robot hello flags")?;
    let interest = read_classes(r)?;
    let exports = read_classes(r)?;
    let mut members = Vec::new();
    for _ in 0..read_member_count(r)? {
        members.push(read_hello_member(r)?);
    }
    let observer = flags & HELLO_OBSERVER != 0;
    Ok(RobotHello {
        version,
        tag,
        gw_incarnation,
        observer,
        interest,
        exports,
        members,
    })
}

fn read_hello_member(r: &mut Reader<'_>) -> Result<Member> {
    let name = read_segment(r)?;
    let incarnation = r.var()?;
    let inner_seq = r.var()?;
    let flags = read_flags(r, MEMBER_ALIVE | MEMBER_LISTENER, "member flags")?;
    let alive = flags & MEMBER_ALIVE != 0;
    let listener = flags & MEMBER_LISTENER != 0;
    Ok(Member {
        name,
        incarnation,
        inner_seq,
        alive,
        listener,
    })
}

fn read_heartbeat(r: &mut Reader<'_>) -> Result<RobotHeartbeat> {
    let tag = read_tag(r)?;
    let hello_version = r.byte()?;
    let seq = r.var()?;
    let alive = read_bitmap(r)?;
    let positions = if r.at < r.bytes.len() {
        Some(read_positions(r)?)
    } else {
        None
    };
    Ok(RobotHeartbeat {
        tag,
        hello_version,
        seq,
        alive,
        positions,
    })
}

fn read_positions(r: &mut Reader<'_>) -> Result<Vec<u64>> {
    let mut positions = Vec::new();
    for _ in 0..read_member_count(r)? {
        positions.push(r.var()?);
    }
    Ok(positions)
}

fn read_nack(r: &mut Reader<'_>) -> Result<Nack> {
    let n = r.count()?;
    if n == 0 {
        return Err(TeamFrameError::Bad("no entries"));
    }
    let mut entries = Vec::new();
    for _ in 0..n {
        entries.push(read_entry(r)?);
    }
    Ok(Nack { entries })
}

fn read_entry(r: &mut Reader<'_>) -> Result<NackEntry> {
    let tag = read_tag(r)?;
    let what = read_flags(r, WHAT_FRAMES | WHAT_HELLO | WHAT_STATE, "what a NACK asks")?;
    if what == 0 {
        return Err(TeamFrameError::Bad("a NACK entry that asks for nothing"));
    }
    let frames = if what & WHAT_FRAMES != 0 {
        Some(read_span(r)?)
    } else {
        None
    };
    let state = if what & WHAT_STATE != 0 {
        Some(read_state_ask(r)?)
    } else {
        None
    };
    Ok(NackEntry {
        tag,
        frames,
        hello: what & WHAT_HELLO != 0,
        state,
    })
}

fn read_state_ask(r: &mut Reader<'_>) -> Result<StateAsk> {
    let members = read_bitmap(r)?;
    let flags = read_flags(r, STATE_NAMES | STATE_CLASSES, "state flags")?;
    let (names, classes) = (flags & STATE_NAMES != 0, flags & STATE_CLASSES != 0);
    Ok(StateAsk {
        members,
        names,
        classes,
    })
}

fn read_gone(r: &mut Reader<'_>) -> Result<Gone> {
    let tag = read_tag(r)?;
    let span = read_span(r)?;
    let mut positions = Vec::new();
    for _ in 0..read_member_count(r)? {
        positions.push((read_member(r)?, r.var()?));
    }
    Ok(Gone {
        tag,
        span,
        positions,
    })
}

fn read_uplink(r: &mut Reader<'_>) -> Result<Uplink> {
    let known = UPLINK_ADDRESSED | UPLINK_STATE_ANSWER | UPLINK_MARK;
    let flags = read_flags(r, known, "uplink flags")?;
    let to = if flags & UPLINK_ADDRESSED != 0 {
        Some(read_address(r)?)
    } else {
        None
    };
    let mark = if flags & UPLINK_MARK != 0 {
        Some(r.var()?)
    } else {
        None
    };
    let state_answer = flags & UPLINK_STATE_ANSWER != 0;
    Ok(Uplink {
        to,
        state_answer,
        mark,
        message: rest(r).to_vec(),
    })
}

fn read_forward(r: &mut Reader<'_>) -> Result<Forward> {
    let from = read_address(r)?;
    let message = rest(r).to_vec();
    if message.is_empty() {
        return Err(TeamFrameError::Bad("forward without a message"));
    }
    Ok(Forward { from, message })
}

fn read_address(r: &mut Reader<'_>) -> Result<Address> {
    let text = r.text()?;
    Address::new(text).map_err(|_| TeamFrameError::Bad("destination address"))
}

fn read_state_request(r: &mut Reader<'_>) -> Result<StateRequest> {
    let flags = read_flags(r, STATE_NAMES | STATE_CLASSES, "state flags")?;
    let mut robots = Vec::new();
    for _ in 0..r.count()? {
        robots.push(read_segment(r)?);
    }
    let (names, classes) = (flags & STATE_NAMES != 0, flags & STATE_CLASSES != 0);
    Ok(StateRequest {
        names,
        classes,
        robots,
    })
}

fn read_interest(r: &mut Reader<'_>) -> Result<TeamInterest> {
    let version = r.var()?;
    let interest = read_classes(r)?;
    let exports = read_classes(r)?;
    Ok(TeamInterest {
        version,
        interest,
        exports,
    })
}

fn read_fill(r: &mut Reader<'_>) -> Result<Fill> {
    let fill = Fill {
        from: r.var()?,
        to: r.var()?,
    };
    if fill.from > fill.to {
        return Err(TeamFrameError::Bad("fill ends before it starts"));
    }
    Ok(fill)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MsgKind;
    use crate::ici::classes::ALL_CONTEXTS;
    use proptest::prelude::*;
    use proptest::sample::select;

    fn addr(s: &str) -> Address {
        Address::new(s).unwrap()
    }

    fn decode(bytes: &[u8]) -> Result<TeamMsg> {
        TeamMsg::decode(bytes)
    }

    fn frame(seq: u64, parts: Vec<Part>) -> TeamMsg {
        TeamMsg::Frame(TeamFrame {
            seq,
            check: 0xA5,
            parts,
        })
    }

    fn range(from: u64, n: u64) -> Span {
        Span { from, n }
    }

    fn frames_entry(tag: u16, from: u64, n: u64) -> NackEntry {
        NackEntry {
            tag: StreamTag(tag),
            frames: Some(range(from, n)),
            hello: false,
            state: None,
        }
    }

    /// A 2026 hybrid-clock stamp: 63 bits, so a 9-byte varint.
    const STAMP: u64 = (1 << 62) + 123_456_789;

    fn member(name: &str, inner_seq: u64) -> Member {
        Member {
            name: name.into(),
            incarnation: STAMP,
            inner_seq,
            alive: true,
            listener: name == "exec",
        }
    }

    /// A demo robot's hello: 5 members, the union of their interests with SELF taken
    /// out (exec's classes plus the sensor classes of the others), the exports of exec
    /// and vision.
    fn demo_hello() -> RobotHello {
        let not_self = [Context::Surroundings, Context::System];
        let interest = ["Pose", "Sensor", "Robot", "Target", "Waypoint", "Mission"]
            .into_iter()
            .chain(["Obstacle", "Contact"])
            .fold(ClassSet::none(), |s, c| s.class_in(c, &not_self));
        let exports = ClassSet::none()
            .class_in("Robot", &[Context::Self_])
            .class("Target")
            .class("Waypoint");
        let names = ["exec", "vision", "nav", "loco", "prox"];
        RobotHello {
            version: 3,
            tag: StreamTag::of(&addr("demo/r1/exec"), STAMP),
            gw_incarnation: STAMP,
            observer: false,
            interest,
            exports,
            members: names.iter().map(|n| member(n, 300)).collect(),
        }
    }

    use slate_model::Context;

    fn samples() -> Vec<TeamMsg> {
        let addressed = PartOf::Addressed {
            dest_tag: StreamTag(0xBEEF),
            dest_member: 2,
            src_member: 0,
        };
        let fragment = Part {
            of: PartOf::Member(4),
            cont: true,
            more: true,
            bytes: vec![9; 20],
        };
        vec![
            frame(7, vec![Part::member(3, vec![0x11, 1, 2])]),
            frame(
                300,
                vec![
                    Part::member(20, vec![0x02, 5]),
                    fragment.clone(),
                    Part {
                        of: addressed,
                        cont: false,
                        more: false,
                        bytes: vec![0x14, 8],
                    },
                ],
            ),
            TeamMsg::Repair(TeamRepair {
                from: 40,
                check: 0xA5,
                content: RepairContent::Replay(vec![
                    vec![Part::member(1, vec![0x11, 3])],
                    vec![fragment.clone(), Part::member(0, vec![])],
                ]),
            }),
            TeamMsg::Repair(TeamRepair {
                from: 40,
                check: 0xA5,
                content: RepairContent::Difference {
                    n: 5,
                    parts: vec![Part::member(1, vec![0x0C, 1, 4])],
                },
            }),
            TeamMsg::Hello(demo_hello()),
            TeamMsg::Heartbeat(RobotHeartbeat {
                tag: StreamTag(1),
                hello_version: 3,
                seq: 90,
                alive: 0b10111,
                positions: None,
            }),
            TeamMsg::Heartbeat(RobotHeartbeat {
                tag: StreamTag(1),
                hello_version: 3,
                seq: 90,
                alive: 0b10111,
                positions: Some(vec![5, 0, 300]),
            }),
            TeamMsg::Nack(Nack {
                entries: vec![
                    frames_entry(0x1234, 100, 3),
                    NackEntry {
                        tag: StreamTag(9),
                        frames: None,
                        hello: true,
                        state: Some(StateAsk {
                            members: 0b101,
                            names: true,
                            classes: false,
                        }),
                    },
                ],
            }),
            TeamMsg::Gone(Gone {
                tag: StreamTag(77),
                span: range(1, 64),
                positions: vec![(0, 40), (4, 3)],
            }),
            TeamMsg::Uplink(Uplink {
                to: Some(addr("demo/r2/exec")),
                state_answer: false,
                mark: None,
                message: vec![0x14, 1, 2, 3],
            }),
            TeamMsg::Uplink(Uplink {
                to: None,
                state_answer: true,
                mark: Some(12),
                message: vec![],
            }),
            TeamMsg::Want(Nack {
                entries: vec![frames_entry(5, 1, 1)],
            }),
            TeamMsg::StateRequest(StateRequest {
                names: true,
                classes: true,
                robots: vec!["r1".into(), "base-2".into()],
            }),
            TeamMsg::Interest(TeamInterest {
                version: 4,
                interest: ClassSet::none().class("Robot"),
                exports: ClassSet::none().class_in("Target", &[Context::System]),
            }),
            TeamMsg::Fill(Fill { from: 3, to: 9 }),
            TeamMsg::Forward(Forward {
                from: addr("demo/r2/exec"),
                message: vec![0x21, 0x07, 0x05, 0x14, 1],
            }),
        ]
    }

    /// Frames whose last field is counted, not "the rest of the bytes": any cut or any
    /// extra byte makes them unreadable.
    fn counted(msg: &TeamMsg) -> bool {
        match msg {
            TeamMsg::Frame(_) | TeamMsg::Uplink(_) | TeamMsg::Heartbeat(_) => false,
            TeamMsg::Forward(_) => false,
            TeamMsg::Repair(r) => matches!(r.content, RepairContent::Replay(_)),
            _ => true,
        }
    }

    #[test]
    fn every_frame_round_trips() {
        for msg in samples() {
            assert_eq!(decode(&msg.encode()), Ok(msg.clone()), "{msg:?}");
        }
    }

    #[test]
    fn headers_are_the_kinds_the_transport_counts() {
        let kinds: Vec<&str> = samples()
            .iter()
            .map(|m| MsgKind::of(&m.encode()).name())
            .collect();
        let frame = ["team_frame"; 2];
        let repair = ["team_repair"; 2];
        let hello = ["robot_hello"];
        let heartbeat = ["robot_heartbeat"; 2];
        let control = ["nack", "gone", "uplink", "uplink", "want", "state_request"];
        let rest = ["team_interest", "fill", "forward"];
        let expected = [&frame[..], &repair, &hello, &heartbeat, &control, &rest].concat();
        assert_eq!(kinds, expected);
    }

    #[test]
    fn a_lone_message_of_a_low_member_goes_in_single_part_form() {
        let msg = frame(5, vec![Part::member(3, b"abc".to_vec())]);
        assert_eq!(msg.encode(), [0x23, 0xA5, 5, b'a', b'b', b'c']);
        let TeamMsg::Frame(f) = msg else { return };
        assert_eq!(f.encoded_len(), 6);
    }

    #[test]
    fn a_high_member_a_fragment_or_a_second_part_takes_the_multi_part_form() {
        let high = frame(5, vec![Part::member(15, vec![0xAA])]);
        assert_eq!(high.encode(), [0x2F, 0xA5, 5, 15 | PART_LAST, 0xAA]);
        let fragment = Part {
            more: true,
            ..Part::member(3, vec![0xAA])
        };
        let more = PART_MORE | PART_LAST | 3;
        let fragment = frame(5, vec![fragment]).encode();
        assert_eq!(fragment, [0x2F, 0xA5, 5, more, 0xAA]);
        let two = frame(
            5,
            vec![Part::member(2, vec![1, 2]), Part::member(0, vec![3])],
        );
        assert_eq!(two.encode(), [0x2F, 0xA5, 5, 2, 2, 1, 2, PART_LAST, 3]);
    }

    #[test]
    fn an_addressed_part_names_the_destination_stream_and_both_members() {
        let part = Part {
            of: PartOf::Addressed {
                dest_tag: StreamTag(0x0102),
                dest_member: 4,
                src_member: 1,
            },
            cont: true,
            more: false,
            bytes: vec![0x15],
        };
        let p = PART_ADDRESSED | PART_CONT | PART_LAST;
        assert_eq!(
            frame(1, vec![part]).encode(),
            [0x2F, 0xA5, 1, p, 1, 2, 4, 1, 0x15]
        );
    }

    #[test]
    fn a_control_part_carries_a_whole_nack_inside_a_data_frame() {
        let nack = TeamMsg::Nack(Nack {
            entries: vec![frames_entry(3, 10, 2)],
        });
        let control = Part {
            of: PartOf::Control,
            cont: false,
            more: false,
            bytes: nack.encode(),
        };
        let data = Part::member(0, vec![0x11]);
        let bytes = frame(8, vec![data, control]).encode();
        let Ok(TeamMsg::Frame(f)) = decode(&bytes) else {
            panic!("{bytes:?}")
        };
        assert_eq!(f.parts[1].of, PartOf::Control);
        assert_eq!(decode(&f.parts[1].bytes), Ok(nack));
    }

    #[test]
    fn a_frame_whose_last_part_is_not_marked_last_is_refused() {
        let unmarked = [0x2F, 0xA5, 1, 2, 1, 0xAA];
        assert_eq!(
            decode(&unmarked),
            Err(TeamFrameError::Bad("the last part is not marked LAST"))
        );
        let empty = decode(&[0x2F, 0xA5, 1]);
        assert_eq!(empty, Err(TeamFrameError::Bad("no parts")));
    }

    #[test]
    fn a_part_longer_than_the_frame_is_refused() {
        assert_eq!(
            decode(&[0x2F, 0xA5, 1, 2, 9, 0xAA]),
            Err(TeamFrameError::Truncated)
        );
    }

    #[test]
    fn a_repair_covers_its_positions_by_replay_or_as_a_whole() {
        let replay = TeamRepair {
            from: 10,
            check: 0xA5,
            content: RepairContent::Replay(vec![
                vec![Part::member(1, vec![7])],
                vec![Part::member(2, vec![8])],
            ]),
        };
        assert_eq!(replay.span(), range(10, 2));
        let bytes = TeamMsg::Repair(replay).encode();
        let body = |m| [2, m | PART_LAST, m + 6];
        let expected = [&[0x3F, 0xA5, 10, 2, 0][..], &body(1), &body(2)].concat();
        assert_eq!(bytes, expected);
        let whole = TeamRepair {
            from: 10,
            check: 0xA5,
            content: RepairContent::Difference {
                n: 30,
                parts: vec![Part::member(1, vec![7])],
            },
        };
        assert_eq!(whole.span(), range(10, 30));
        assert_eq!(whole.span().end(), 40);
    }

    #[test]
    fn a_replay_with_more_positions_than_bytes_is_refused() {
        let bytes = [0x3F, 0xA5, 10, 100, 0, 2, PART_LAST, 7];
        assert_eq!(
            decode(&bytes),
            Err(TeamFrameError::Bad("more positions than bytes"))
        );
    }

    #[test]
    fn a_demo_robots_hello_takes_190_bytes_give_or_take_30() {
        let len = TeamMsg::Hello(demo_hello()).encode().len();
        assert!((160..=220).contains(&len), "{len} B");
    }

    #[test]
    fn an_idle_heartbeat_takes_at_most_6_bytes_below_position_128() {
        let heartbeat = |seq| RobotHeartbeat {
            tag: StreamTag(0xFFFF),
            hello_version: 255,
            seq,
            alive: 0b11111,
            positions: None,
        };
        let len = |seq| TeamMsg::Heartbeat(heartbeat(seq)).encode().len();
        assert!(len(127) <= 6, "{} B", len(127));
        assert!(len(16_383) <= 7, "{} B", len(16_383));
    }

    #[test]
    fn a_nack_entry_for_a_frame_range_takes_at_most_5_bytes_below_position_128() {
        let nack = |entries| TeamMsg::Nack(Nack { entries }).encode().len();
        let one = nack(vec![frames_entry(0xFFFF, 120, 7)]);
        let two = nack(vec![frames_entry(0xFFFF, 120, 7); 2]);
        assert!(two - one <= 5, "{} B", two - one);
        assert_eq!(one, 2 + (two - one), "header, count, one entry");
    }

    #[test]
    fn the_stream_tag_is_the_folded_fnv1a_of_address_and_incarnation() {
        assert_eq!(fnv1a_32(*b""), 0x811C_9DC5);
        assert_eq!(fnv1a_32(*b"a"), 0xE40C_292C);
        assert_eq!(fnv1a_32(*b"foobar"), 0xBF9C_F968);
        let exec = addr("demo/r1/exec");
        assert_eq!(StreamTag::of(&exec, 7), StreamTag(0x59E5));
        assert_ne!(StreamTag::of(&exec, 7), StreamTag::of(&exec, 8));
        assert_ne!(
            StreamTag::of(&exec, 7),
            StreamTag::of(&addr("demo/r2/exec"), 7)
        );
    }

    #[test]
    fn the_gateways_of_a_24_robot_team_have_distinct_tags() {
        let tags: std::collections::BTreeSet<StreamTag> = (0..24)
            .map(|i| StreamTag::of(&addr(&format!("demo/r{i}/exec")), STAMP + i))
            .collect();
        assert_eq!(tags.len(), 24);
    }

    #[test]
    fn a_cut_frame_never_reads_as_the_whole() {
        for msg in samples() {
            let bytes = msg.encode();
            for n in 0..bytes.len() {
                let cut = decode(&bytes[..n]);
                assert_ne!(cut, Ok(msg.clone()), "{msg:?} cut at {n}");
                assert!(cut.is_err() || !counted(&msg), "{msg:?} cut at {n}");
            }
        }
    }

    #[test]
    fn a_counted_frame_with_a_byte_more_is_refused() {
        for msg in samples().into_iter().filter(counted) {
            let mut long = msg.encode();
            long.push(0);
            assert!(decode(&long).is_err(), "{msg:?}");
        }
    }

    #[test]
    fn other_headers_are_not_team_frames() {
        for header in [0x00, 0x01, 0x03, 0x0E, 0x11, 0x30, 0x3E, 0x40, 0xFF] {
            assert_eq!(decode(&[header, 0]), Err(TeamFrameError::NotTeam(header)));
        }
    }

    /// The bytes of `msg` with the byte at `at` (from the end, if negative) replaced.
    fn with_byte(msg: &TeamMsg, at: isize, byte: u8) -> Vec<u8> {
        let mut bytes = msg.encode();
        let at = if at < 0 {
            bytes.len() as isize + at
        } else {
            at
        };
        bytes[at as usize] = byte;
        bytes
    }

    #[test]
    fn unknown_flag_bits_are_refused() {
        let hello = TeamMsg::Hello(demo_hello());
        assert!(decode(&with_byte(&hello, 13, 2)).is_err(), "hello flags");
        assert!(decode(&with_byte(&hello, -1, 4)).is_err(), "member flags");
        let uplink = TeamMsg::Uplink(Uplink {
            to: None,
            state_answer: false,
            mark: None,
            message: vec![1],
        });
        assert!(decode(&with_byte(&uplink, 1, 8)).is_err(), "uplink flags");
        let want = TeamMsg::Want(Nack {
            entries: vec![frames_entry(1, 1, 1)],
        });
        assert!(decode(&with_byte(&want, 4, 8)).is_err(), "what");
        assert!(decode(&with_byte(&want, 4, 0)).is_err(), "asks for nothing");
        let request = &samples()[12];
        assert!(decode(&with_byte(request, 1, 4)).is_err(), "state flags");
        let repair = &samples()[2];
        assert!(decode(&with_byte(repair, 4, 2)).is_err(), "repair mode");
    }

    #[test]
    fn counts_and_indices_beyond_a_robots_members_are_refused() {
        let mut hello = demo_hello();
        hello.members = (0..31).map(|i| member(&format!("m{i}"), 1)).collect();
        let refused = Err(TeamFrameError::Bad("more members than a robot can have"));
        assert_eq!(decode(&TeamMsg::Hello(hello).encode()), refused);
        let gone = |member| {
            TeamMsg::Gone(Gone {
                tag: StreamTag(1),
                span: range(1, 1),
                positions: vec![(member, 5)],
            })
        };
        assert!(decode(&gone(29).encode()).is_ok());
        assert_eq!(
            decode(&gone(30).encode()),
            Err(TeamFrameError::Bad("member index"))
        );
        let heartbeat = |alive| {
            TeamMsg::Heartbeat(RobotHeartbeat {
                tag: StreamTag(1),
                hello_version: 0,
                seq: 1,
                alive,
                positions: None,
            })
        };
        assert!(decode(&heartbeat(1 << 29).encode()).is_ok());
        assert_eq!(
            decode(&heartbeat(1 << 30).encode()),
            Err(TeamFrameError::Bad("member bitmap"))
        );
        let addressed = [0x2F, 0xA5, 1, PART_ADDRESSED | PART_LAST, 0, 0, 30, 0];
        assert_eq!(decode(&addressed), Err(TeamFrameError::Bad("member index")));
    }

    #[test]
    fn empty_huge_or_overflowing_ranges_are_refused() {
        let gone = |from, n| {
            TeamMsg::Gone(Gone {
                tag: StreamTag(1),
                span: range(from, n),
                positions: vec![],
            })
        };
        let length = Err(TeamFrameError::Bad("range length"));
        assert_eq!(decode(&gone(1, 0).encode()), length);
        assert_eq!(decode(&gone(1, MAX_SPAN + 1).encode()), length);
        assert!(decode(&gone(1, MAX_SPAN).encode()).is_ok());
        let beyond = Err(TeamFrameError::Bad("range beyond the last position"));
        assert_eq!(decode(&gone(u64::MAX, 1).encode()), beyond);
        assert!(decode(&gone(u64::MAX - 1, 1).encode()).is_ok());
    }

    #[test]
    fn a_nack_without_entries_or_with_more_than_its_bytes_is_refused() {
        let none = TeamMsg::Nack(Nack { entries: vec![] }).encode();
        assert_eq!(decode(&none), Err(TeamFrameError::Bad("no entries")));
        let mut many = vec![NACK];
        many.extend_from_slice(&[0xA0, 0x1F]);
        many.extend_from_slice(&[0, 1, 2]);
        assert_eq!(decode(&many), Err(TeamFrameError::Bad("count too large")));
    }

    #[test]
    fn names_and_addresses_are_checked() {
        let bad_address = [UPLINK, UPLINK_ADDRESSED, 3, b'a', b'/', b'b'];
        assert_eq!(
            decode(&bad_address),
            Err(TeamFrameError::Bad("destination address"))
        );
        let bad_robot = [STATE_REQUEST, 0, 1, 3, b'r', b'/', b'1'];
        assert_eq!(
            decode(&bad_robot),
            Err(TeamFrameError::Bad("not an address segment"))
        );
        let bad_class = [TEAM_INTEREST, 1, 1, 3, b'1', b'a', b'b', 7, 0];
        assert_eq!(
            decode(&bad_class),
            Err(TeamFrameError::Bad("name is not an identifier"))
        );
        let no_context = [TEAM_INTEREST, 1, 1, 1, b'A', 0, 0];
        assert_eq!(
            decode(&no_context),
            Err(TeamFrameError::Bad("context mask"))
        );
    }

    #[test]
    fn a_fill_that_ends_before_it_starts_is_refused() {
        let back = TeamMsg::Fill(Fill { from: 9, to: 3 }).encode();
        assert_eq!(
            decode(&back),
            Err(TeamFrameError::Bad("fill ends before it starts"))
        );
        assert!(decode(&TeamMsg::Fill(Fill { from: 3, to: 3 }).encode()).is_ok());
    }

    // ----- property tests -----

    fn tag() -> impl Strategy<Value = StreamTag> {
        any::<u16>().prop_map(StreamTag)
    }

    fn index() -> impl Strategy<Value = u8> {
        0..MAX_MEMBERS
    }

    fn part() -> impl Strategy<Value = Part> {
        let addressed = (tag(), index(), index()).prop_map(|(dest_tag, d, s)| PartOf::Addressed {
            dest_tag,
            dest_member: d,
            src_member: s,
        });
        let of = prop_oneof![
            index().prop_map(PartOf::Member),
            Just(PartOf::Control),
            addressed
        ];
        let bytes = proptest::collection::vec(any::<u8>(), 0..200);
        (of, any::<bool>(), any::<bool>(), bytes).prop_map(|(of, cont, more, bytes)| Part {
            of,
            cont,
            more,
            bytes,
        })
    }

    fn parts() -> impl Strategy<Value = Vec<Part>> {
        proptest::collection::vec(part(), 1..4)
    }

    fn span() -> impl Strategy<Value = Span> {
        (any::<u64>(), 1..=MAX_SPAN).prop_map(|(from, n)| range(from.min(u64::MAX - n), n))
    }

    fn classes() -> impl Strategy<Value = ClassSet> {
        let names = ["Robot", "Target", "Waypoint", "Mission", "Pose", "_x1"];
        let rule = (select(names.to_vec()), 1u8..=ALL_CONTEXTS);
        proptest::collection::vec(rule, 0..4).prop_map(|rules| {
            rules
                .iter()
                .fold(ClassSet::none(), |s, (c, m)| s.with(c, *m))
        })
    }

    fn segment() -> impl Strategy<Value = Arc<str>> {
        select(&["exec", "nav", "r1", "base-2", "robot_10"][..]).prop_map(Arc::from)
    }

    fn repair() -> impl Strategy<Value = TeamMsg> {
        let replay = proptest::collection::vec(parts(), 1..4).prop_map(RepairContent::Replay);
        let difference =
            (1..=MAX_SPAN, parts()).prop_map(|(n, parts)| RepairContent::Difference { n, parts });
        (any::<u64>(), prop_oneof![replay, difference]).prop_map(|(from, content)| {
            let n = match &content {
                RepairContent::Replay(b) => b.len() as u64,
                RepairContent::Difference { n, .. } => *n,
            };
            let from = from.min(u64::MAX - n);
            TeamMsg::Repair(TeamRepair {
                from,
                check: from as u8,
                content,
            })
        })
    }

    fn hello() -> impl Strategy<Value = TeamMsg> {
        let member = (
            segment(),
            any::<u64>(),
            any::<u64>(),
            any::<bool>(),
            any::<bool>(),
        )
            .prop_map(|(name, incarnation, inner_seq, alive, listener)| Member {
                name,
                incarnation,
                inner_seq,
                alive,
                listener,
            });
        let members = proptest::collection::vec(member, 0..=usize::from(MAX_MEMBERS));
        (
            any::<u8>(),
            tag(),
            any::<u64>(),
            any::<bool>(),
            classes(),
            classes(),
            members,
        )
            .prop_map(
                |(version, tag, gw_incarnation, observer, interest, exports, members)| {
                    TeamMsg::Hello(RobotHello {
                        version,
                        tag,
                        gw_incarnation,
                        observer,
                        interest,
                        exports,
                        members,
                    })
                },
            )
    }

    fn bitmap() -> impl Strategy<Value = u32> {
        0..(1u32 << MAX_MEMBERS)
    }

    fn heartbeat() -> impl Strategy<Value = TeamMsg> {
        let positions = proptest::collection::vec(any::<u64>(), 0..=usize::from(MAX_MEMBERS));
        (
            tag(),
            any::<u8>(),
            any::<u64>(),
            bitmap(),
            proptest::option::of(positions),
        )
            .prop_map(|(tag, hello_version, seq, alive, positions)| {
                TeamMsg::Heartbeat(RobotHeartbeat {
                    tag,
                    hello_version,
                    seq,
                    alive,
                    positions,
                })
            })
    }

    fn entry() -> impl Strategy<Value = NackEntry> {
        let ask = (bitmap(), any::<bool>(), any::<bool>()).prop_map(|(members, names, classes)| {
            StateAsk {
                members,
                names,
                classes,
            }
        });
        let frames = proptest::option::of(span());
        (tag(), frames, any::<bool>(), proptest::option::of(ask)).prop_map(
            |(tag, frames, hello, state)| NackEntry {
                tag,
                frames,
                // An entry asks for something: the hello, if nothing else.
                hello: hello || (frames.is_none() && state.is_none()),
                state,
            },
        )
    }

    fn nack() -> impl Strategy<Value = Nack> {
        proptest::collection::vec(entry(), 1..5).prop_map(|entries| Nack { entries })
    }

    fn gone() -> impl Strategy<Value = TeamMsg> {
        let positions = proptest::collection::vec((index(), any::<u64>()), 0..8);
        (tag(), span(), positions).prop_map(|(tag, span, positions)| {
            TeamMsg::Gone(Gone {
                tag,
                span,
                positions,
            })
        })
    }

    fn uplink() -> impl Strategy<Value = TeamMsg> {
        let to = select(&["demo/r1/exec", "t-1/base/console"][..]).prop_map(addr);
        let message = proptest::collection::vec(any::<u8>(), 0..64);
        let fields = (
            proptest::option::of(to),
            any::<bool>(),
            proptest::option::of(any::<u64>()),
        );
        (fields, message).prop_map(|((to, state_answer, mark), message)| {
            TeamMsg::Uplink(Uplink {
                to,
                state_answer,
                mark,
                message,
            })
        })
    }

    fn robot_link() -> impl Strategy<Value = TeamMsg> {
        let request = (
            any::<bool>(),
            any::<bool>(),
            proptest::collection::vec(segment(), 0..4),
        )
            .prop_map(|(names, classes, robots)| {
                TeamMsg::StateRequest(StateRequest {
                    names,
                    classes,
                    robots,
                })
            });
        let interest = (any::<u64>(), classes(), classes()).prop_map(|(version, i, e)| {
            TeamMsg::Interest(TeamInterest {
                version,
                interest: i,
                exports: e,
            })
        });
        let fill = (any::<u64>(), any::<u64>()).prop_map(|(a, b)| {
            TeamMsg::Fill(Fill {
                from: a.min(b),
                to: a.max(b),
            })
        });
        prop_oneof![
            uplink(),
            nack().prop_map(TeamMsg::Want),
            request,
            interest,
            fill
        ]
    }

    fn any_msg() -> impl Strategy<Value = TeamMsg> {
        let data = (any::<u64>(), parts()).prop_map(|(seq, parts)| frame(seq, parts));
        prop_oneof![
            data,
            repair(),
            hello(),
            heartbeat(),
            nack().prop_map(TeamMsg::Nack),
            gone(),
            robot_link(),
        ]
    }

    proptest! {
        #[test]
        fn any_frame_round_trips(msg in any_msg()) {
            prop_assert_eq!(decode(&msg.encode()), Ok(msg));
        }

        #[test]
        fn a_data_frames_encoded_len_is_its_length(seq in any::<u64>(), parts in parts()) {
            let f = TeamFrame { seq, check: seq as u8, parts };
            prop_assert_eq!(f.encoded_len(), TeamMsg::Frame(f.clone()).encode().len());
        }

        #[test]
        fn a_repairs_encoded_len_is_its_length(msg in repair()) {
            let TeamMsg::Repair(r) = &msg else { unreachable!("repair() makes repairs") };
            prop_assert_eq!(r.encoded_len(), msg.encode().len());
        }

        #[test]
        fn any_bytes_decode_or_fail_without_panicking(
            bytes in proptest::collection::vec(any::<u8>(), 0..96)
        ) {
            let _ = decode(&bytes);
        }

        #[test]
        fn a_mutated_frame_fails_or_reads_as_what_it_re_encodes_to(
            i in 0usize..15, at in 0usize..256, byte in any::<u8>()
        ) {
            let mut bytes = samples()[i].encode();
            let at = at % bytes.len();
            bytes[at] = byte;
            if let Ok(msg) = decode(&bytes) {
                prop_assert_eq!(decode(&msg.encode()), Ok(msg));
            }
        }
    }
}
