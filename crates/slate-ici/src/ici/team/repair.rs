//! The ICI's glue for repair by NACK (docs/team-protocol.md 2.5, step 10, replay):
//!
//! * receivers feed the stream tracker's gaps, the NACKs they hear and the positions
//!   they receive to the [`NackScheduler`], publish the NACKs it fires, and ask the
//!   members' state (today's per-member catch-up, until step 11) when it gives up;
//! * a receiver holding parked frames of a robot whose hello it lacks NACKs the hello,
//!   with the same suppression ([`HelloAsk`]);
//! * the source gateway gathers the NACKs for its stream in its [`RepairScheduler`]
//!   and answers once, by broadcast: `TeamRepair` replays from its history, split at
//!   the MTU, and `Gone` for what the history no longer holds.
//!
//! Every listener NACKs for itself (no foreign cache): the suppression bounds the cost
//! to about one NACK per loss, whoever lost it. A member that does not listen hears the
//! streams through its gateway (`Forward`) and NACKs no frames: it lacks what its gateway
//! lacks. Its state and hello asks go to the gateway as a `Want`.

use std::time::Duration;

use slate_model::Address;
use slate_transport::Rng;

use super::frame::{
    Gone, MAX_MEMBERS, Nack, NackEntry, Part, RepairContent, Span, StreamTag, TeamFrame, TeamMsg,
    TeamRepair,
};
use super::nack::{MissingRange, NackAction, NackScheduler, NackTiming, RepairTiming, SeqRange};
use crate::MsgKind;
use crate::ici::TeamProtocol;
use crate::ici::state::State;

/// The stream tag a hello NACK carries when the receiver never heard the tag of the
/// robot it lacks the hello of (frames carry no tag): every gateway takes it as its own.
/// A real tag of 0 (1 in 65 536) only makes that gateway answer such NACKs too.
pub(crate) const ANY_TAG: StreamTag = StreamTag(0);

/// Entries per `Nack` published: a NACK of many streams goes as several.
const ENTRIES_PER_NACK: usize = 32;

/// A receiver's pending NACK of one robot's hello (at most one per remote gateway).
///
/// Invariant: `due` is the next time the hello may be NACKed; a NACK heard from
/// another robot for the same hello pushes it back by `repair_wait`, as for frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct HelloAsk {
    /// The tag the NACK names (`ANY_TAG` until a heartbeat told the robot's tag).
    pub tag: StreamTag,
    pub due: Duration,
}

impl HelloAsk {
    /// Is this ask suppressed by another robot's hello NACK for `tag`?
    pub fn covered_by(&self, tag: StreamTag) -> bool {
        tag == self.tag || tag == ANY_TAG
    }
}

/// The receiver's timing from the ICI's settings; an MTU under 64 bytes takes the
/// acoustic bounds (a `Nack` must fit one modem frame).
pub(crate) fn nack_timing(p: &TeamProtocol) -> NackTiming {
    let base = if p.mtu < 64 {
        NackTiming::acoustic()
    } else {
        NackTiming::radio()
    };
    NackTiming {
        gap_grace: p.gap_grace,
        nack_backoff: p.nack_backoff,
        repair_wait: p.repair_wait,
        max_nack_frames: p.max_nack_frames,
        ..base
    }
}

/// The source gateway's timing from the ICI's settings (bounds as `nack_timing`'s).
pub(crate) fn repair_timing(p: &TeamProtocol) -> RepairTiming {
    let base = if p.mtu < 64 {
        RepairTiming::acoustic()
    } else {
        RepairTiming::radio()
    };
    RepairTiming {
        repair_gather: p.repair_gather,
        repair_holdoff: p.repair_holdoff,
        ..base
    }
}

/// The seed of one ICI's back-off draws: its address (FNV-1a 64) and the clock's time
/// when it first needed one. The simulator's clock is virtual, so one seed of the
/// network gives one run; two modules never share a sequence.
pub(crate) fn nack_seed(me: &Address, started_raw: u64) -> u64 {
    let fnv = me
        .to_string()
        .bytes()
        .fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
        });
    fnv ^ started_raw.rotate_left(32)
}

/// Replays of `bodies` (consecutive positions from the first one's, each with its
/// original parts) of the stream tagged `tag`, split so that every repair is at most
/// `mtu` bytes. A body too large to fit with a repair's header alone goes alone (the
/// transport may refuse it).
pub(crate) fn replays(
    tag: StreamTag,
    bodies: Vec<(u64, Vec<Part>)>,
    mtu: usize,
) -> Vec<TeamRepair> {
    let mut out: Vec<TeamRepair> = Vec::new();
    let (mut from, mut open): (u64, Vec<Vec<Part>>) = (0, Vec::new());
    for (seq, parts) in bodies {
        let follows = !open.is_empty() && from + open.len() as u64 == seq;
        if follows && fits(tag, from, &mut open, &parts, mtu) {
            continue;
        }
        if !open.is_empty() {
            out.push(replay(tag, from, std::mem::take(&mut open)));
        }
        (from, open) = (seq, vec![parts]);
    }
    if !open.is_empty() {
        out.push(replay(tag, from, open));
    }
    out
}

/// Adds `parts` to the open replay if the repair stays within `mtu`.
fn fits(tag: StreamTag, from: u64, open: &mut Vec<Vec<Part>>, parts: &[Part], mtu: usize) -> bool {
    open.push(parts.to_vec());
    let candidate = replay(tag, from, std::mem::take(open));
    let ok = candidate.encoded_len() <= mtu;
    if let RepairContent::Replay(back) = candidate.content {
        *open = back;
    }
    if !ok {
        open.pop();
    }
    ok
}

fn replay(tag: StreamTag, from: u64, bodies: Vec<Vec<Part>>) -> TeamRepair {
    TeamRepair {
        from,
        check: tag.check(),
        content: RepairContent::Replay(bodies),
    }
}

fn range_of(span: Span) -> Option<SeqRange> {
    SeqRange::from_wire(span.from, span.n).ok()
}

// ----- the receiver -----

impl State {
    /// The NACK scheduler, made on first use with this ICI's seed.
    fn nacks(&mut self) -> Option<&mut NackScheduler> {
        let protocol = self.config.team_protocol.as_ref()?;
        if self.team.nacks.is_none() {
            let seed = nack_seed(&self.me, self.board.clock().now().raw());
            let timing = nack_timing(protocol);
            self.team.nacks = Some(NackScheduler::new(timing, Rng::new(seed)));
        }
        self.team.nacks.as_mut()
    }

    /// A back-off `U(0, max)` from the NACK scheduler's seeded draws.
    pub(super) fn nack_draw(&mut self, max: Duration) -> Duration {
        self.nacks().map_or(Duration::ZERO, |n| n.draw(max))
    }

    /// The tracker of gateway `from` found positions `first .. first + n` missing.
    pub(super) fn team_gap(&mut self, from: &Address, first: u64, n: u64) {
        let (now, tag) = (self.now, self.speaker_tag(from));
        let range = SeqRange::from_wire(first, n).ok();
        if let (Some(tag), Some(range)) = (tag, range)
            && let Some(s) = self.nacks()
        {
            s.gap_found(tag, range, now);
        }
    }

    /// Position `seq` of stream `tag` arrived (the original, late or not).
    pub(super) fn team_received(&mut self, tag: StreamTag, seq: u64) {
        if let (Some(s), Some(range)) = (self.team.nacks.as_mut(), SeqRange::one(seq)) {
            s.received(tag, range);
        }
    }

    /// The tag of the stream followed for gateway `from`, if any.
    pub(super) fn speaker_tag(&self, from: &Address) -> Option<StreamTag> {
        let s = self.team.speakers.get(from)?;
        s.outer.as_ref().map(|o| StreamTag(o.tag()))
    }

    /// A NACK heard on the team link: our stream's entries go to the repair
    /// scheduler (gateway); the others suppress our own NACKs for the same positions.
    pub(super) fn on_nack(&mut self, from: &Address, nack: Nack) {
        for entry in nack.entries {
            self.gateway_nack_heard(&entry);
            self.gateway_state_asked(from, &entry);
            if let Some(ask) = entry.state {
                self.state_ask_heard(entry.tag, ask);
            }
            if let Some(span) = entry.frames {
                self.nack_heard(entry.tag, span);
            }
            if entry.hello {
                self.hello_nack_heard(entry.tag);
            }
        }
    }

    /// Another robot NACKed `span` of stream `tag`: positions we did not know were
    /// sent (a lost tail) are announced first, so they join its round.
    fn nack_heard(&mut self, tag: StreamTag, span: Span) {
        let now = self.now;
        let Some(range) = range_of(span) else { return };
        let speaker =
            self.team.speakers.iter_mut().find(|(_, s)| {
                s.hello.is_some() && s.outer.as_ref().is_some_and(|o| o.tag() == tag.0)
            });
        let Some((gateway, s)) = speaker else { return };
        let gateway = gateway.clone();
        let change = s
            .outer
            .as_mut()
            .and_then(|o| o.announce(tag.0, range.last(), now));
        if let Some(change) = change {
            self.stream_changed(&gateway, change);
        }
        if let Some(s) = self.nacks() {
            let ours = (s.missing(tag).iter())
                .any(|m| m.first() <= range.last() && range.first() <= m.last());
            s.nack_heard(tag, range, now);
            self.stats.team.nacks_suppressed += u64::from(ours);
        }
    }

    /// Runs the receiver's NACK timers and carries out what they fired.
    pub(super) fn nack_tick(&mut self) {
        let now = self.now;
        let mut entries = self.hello_asks_due();
        entries.extend(self.state_asks_due());
        if let Some(s) = self.team.nacks.as_mut() {
            s.tick(now);
        }
        while let Some(action) = self.team.nacks.as_mut().and_then(NackScheduler::poll) {
            match action {
                NackAction::Nack(missing) => entries.extend(missing.iter().map(frames_entry)),
                NackAction::AskState { tag, through } => {
                    tracing::debug!(me = %self.me, at = ?now, tag = tag.0, through, "NACKs gave up: state asked");
                    self.ask_stream_state(tag, through)
                }
            }
        }
        if !entries.is_empty() {
            tracing::debug!(me = %self.me, at = ?now, ?entries, "NACK");
        }
        self.publish_nacks(entries);
    }

    fn publish_nacks(&mut self, entries: Vec<NackEntry>) {
        if self.team.listening == Some(false) {
            return self.want(entries);
        }
        for chunk in entries.chunks(ENTRIES_PER_NACK) {
            let nack = Nack {
                entries: chunk.to_vec(),
            };
            self.publish_team_msg(MsgKind::Nack, &TeamMsg::Nack(nack));
        }
    }

    /// A member that does not listen tells its gateway what it asks of the other robots
    /// (`Want`): its state asks (a member's inner gap, names it lacks) and hello asks.
    /// Frame NACKs are left out: the frames it lacks are the ones its gateway lacks (it
    /// got what the gateway heard), and the gateway NACKs those itself.
    fn want(&mut self, entries: Vec<NackEntry>) {
        let asks: Vec<NackEntry> = entries
            .into_iter()
            .map(|e| NackEntry { frames: None, ..e })
            .filter(|e| e.hello || e.state.is_some())
            .collect();
        if asks.is_empty() {
            // Nothing to ask (the common case: this runs at every tick): no election.
            return;
        }
        let Some(gateway) = self.gateway().filter(|g| *g != self.me) else {
            return;
        };
        for chunk in asks.chunks(ENTRIES_PER_NACK) {
            let want = TeamMsg::Want(Nack {
                entries: chunk.to_vec(),
            });
            self.send_to(&gateway, MsgKind::Want, &want.encode());
        }
    }

    /// A mate's `Want` (as gateway): its state asks join ours, which go on the team link
    /// with our NACKs; a hello it lacks is forwarded to it again from what we hold.
    pub(super) fn on_want(&mut self, from: &Address, want: Nack) {
        if self.team.gateway.is_none() {
            return self.stats.team.uplinks_misrouted += 1;
        }
        for entry in want.entries {
            let speakers = self.team.speakers.iter();
            let of_tag = speakers.filter(|(_, s)| {
                s.hello
                    .as_ref()
                    .is_some_and(|h| h.tag == entry.tag || entry.tag == ANY_TAG)
            });
            let found: Vec<(Address, TeamMsg)> = of_tag
                .filter_map(|(g, s)| Some((g.clone(), TeamMsg::Hello(s.hello.clone()?))))
                .collect();
            for (gateway, hello) in found {
                if entry.hello {
                    self.forward_to(from, &gateway, &hello.encode());
                }
                let Some(ask) = entry.state.filter(|_| entry.tag != ANY_TAG) else {
                    continue;
                };
                for index in (0..MAX_MEMBERS).filter(|i| ask.members & 1 << i != 0) {
                    self.merge_state_ask(&gateway, index, ask.names, ask.classes);
                }
            }
        }
    }

    /// The NACK gave up stream `tag` up to `through`: its positions count as covered
    /// and every member of its robot is asked for its state (today's catch-up, one
    /// request per member, which `answer.rs` merges into one `Nack` entry `what = state`).
    pub(super) fn ask_stream_state(&mut self, tag: StreamTag, through: u64) {
        let now = self.now;
        let speaker = self
            .team
            .speakers
            .iter_mut()
            .find(|(_, s)| s.outer.as_ref().is_some_and(|o| o.tag() == tag.0));
        let Some((gateway, s)) = speaker else { return };
        let gateway = gateway.clone();
        if let Some(o) = s.outer.as_mut() {
            o.cover(1, through, now);
        }
        self.ask_members_state(&gateway);
    }

    /// Asks each member of gateway `from`'s robot for its current state.
    pub(super) fn ask_members_state(&mut self, from: &Address) {
        self.stats.team.state_asked += 1;
        let members: Vec<Address> = self
            .team
            .speakers
            .get(from)
            .map_or(vec![], |s| s.members.iter().flatten().cloned().collect());
        members
            .iter()
            .for_each(|m| self.request_catch_up(m, false, false));
    }

    /// A repair of gateway `from`'s stream: each position not held yet is taken as if
    /// its frame had come; those held are skipped. Before the hello, they are parked.
    pub(super) fn on_repair(&mut self, from: &Address, repair: TeamRepair) {
        let RepairContent::Replay(bodies) = repair.content else {
            // Repairs by difference come with step 13.
            self.stats.team.refused += 1;
            return;
        };
        for (i, parts) in bodies.into_iter().enumerate() {
            let frame = TeamFrame {
                seq: repair.from + i as u64,
                check: repair.check,
                parts,
            };
            self.stats.team.repaired += 1;
            self.on_team_frame(from, frame);
        }
    }

    /// Positions gateway `from` can no longer repair: they are closed, and the
    /// members' inner positions it gives are announced, so a member whose messages
    /// were lost with them shows an inner gap and is asked for its state.
    pub(super) fn on_gone(&mut self, from: &Address, gone: Gone) {
        let now = self.now;
        let Some(s) = self.team.speakers.get_mut(from) else {
            return;
        };
        let Some(outer) = s.outer.as_mut().filter(|o| o.tag() == gone.tag.0) else {
            return;
        };
        outer.cover(gone.span.from, gone.span.n, now);
        self.stats.team.gone_heard += 1;
        if let (Some(n), Some(range)) = (self.team.nacks.as_mut(), range_of(gone.span)) {
            n.received(gone.tag, range);
        }
        let mut positions = vec![0; usize::from(super::frame::MAX_MEMBERS)];
        for (member, seq) in &gone.positions {
            // The decoder refuses indices past `MAX_MEMBERS`; `get_mut` needs no trust.
            if let Some(p) = positions.get_mut(usize::from(*member)) {
                *p = *seq;
            }
        }
        self.announce_positions(from, &positions);
    }

    /// The robots (team, robot) whose stream has a gap, so that their members' inner
    /// gaps wait for its repair (2.6) instead of asking the members for their state.
    /// Empty with the switch off. O(speakers), once per tick.
    pub(crate) fn team_gapped_robots(&self) -> GappedRobots {
        let gapped = self
            .team
            .speakers
            .iter()
            .filter(|(_, s)| s.outer.as_ref().is_some_and(|o| o.has_gap()));
        GappedRobots(
            gapped
                .map(|(g, _)| (g.team().to_string(), g.robot().to_string()))
                .collect(),
        )
    }
}

/// The robots (team, robot) whose stream has a gap.
pub(crate) struct GappedRobots(Vec<(String, String)>);

impl GappedRobots {
    /// Is `member` a module of one of them?
    pub(crate) fn holds(&self, member: &Address) -> bool {
        self.0
            .iter()
            .any(|(t, r)| t == member.team() && r == member.robot())
    }
}

fn frames_entry(missing: &MissingRange) -> NackEntry {
    NackEntry {
        tag: missing.tag,
        frames: Some(Span {
            from: missing.range.first(),
            n: missing.range.n(),
        }),
        hello: false,
        state: None,
    }
}

// ----- the hello NACK -----

impl State {
    /// A frame of gateway `from` was parked: its hello is NACKed after `gap_grace`
    /// and a back-off, unless already asked. `tag` is the robot's, if a heartbeat said it.
    pub(super) fn ask_hello(&mut self, from: &Address, tag: Option<StreamTag>) {
        let Some(s) = self.team.speakers.get(from) else {
            return;
        };
        let known = s.hello.as_ref().map(|h| h.tag);
        if known.is_some() && (tag.is_none() || tag == known) {
            return;
        }
        let asked = s.hello_ask;
        let Some(p) = self.config.team_protocol.clone() else {
            return;
        };
        let due = match asked {
            Some(a) => a.due,
            None => {
                self.now
                    + p.gap_grace
                    + self
                        .nacks()
                        .map_or(Duration::ZERO, |n| n.draw(p.nack_backoff))
            }
        };
        let tag = tag.or(asked.map(|a| a.tag)).unwrap_or(ANY_TAG);
        if let Some(s) = self.team.speakers.get_mut(from) {
            s.hello_ask = Some(HelloAsk { tag, due });
        }
    }

    /// Another robot NACKed the hello of stream `tag`: ours waits `repair_wait` more.
    fn hello_nack_heard(&mut self, tag: StreamTag) {
        let Some(wait) = self.config.team_protocol.as_ref().map(|p| p.repair_wait) else {
            return;
        };
        let later = self.now + wait;
        for s in self.team.speakers.values_mut() {
            if let Some(ask) = s.hello_ask.as_mut().filter(|a| a.covered_by(tag)) {
                ask.due = ask.due.max(later);
            }
        }
    }

    /// The hello NACK entries due now; each is asked again after `repair_wait` until
    /// the hello comes, or until nothing was heard from that gateway for the team
    /// timeout (a dead gateway is not asked forever).
    fn hello_asks_due(&mut self) -> Vec<NackEntry> {
        let now = self.now;
        let Some(wait) = self.config.team_protocol.as_ref().map(|p| p.repair_wait) else {
            return vec![];
        };
        let silent_since = now.saturating_sub(self.config.team.timeout);
        let mut tags: Vec<StreamTag> = Vec::new();
        for s in self.team.speakers.values_mut() {
            if s.last_heard < silent_since {
                // A robot silent past the timeout is not asked again until heard.
                s.hello_ask = None;
            }
            if let Some(ask) = s.hello_ask.as_mut().filter(|a| a.due <= now) {
                ask.due = now + wait;
                tags.push(ask.tag);
            }
        }
        tags.sort_by_key(|t| t.0);
        tags.dedup();
        tags.into_iter().map(hello_entry).collect()
    }
}

fn hello_entry(tag: StreamTag) -> NackEntry {
    NackEntry {
        tag,
        frames: None,
        hello: true,
        state: None,
    }
}

// ----- the source gateway -----

impl State {
    /// A NACK entry for this gateway's stream: frames gathered for a repair, a hello
    /// said again (at most once per `hello_min_interval`).
    fn gateway_nack_heard(&mut self, entry: &NackEntry) {
        let now = self.now;
        let Some(gw) = self.team.gateway.as_mut() else {
            return;
        };
        if entry.hello && (entry.tag == gw.tag || entry.tag == ANY_TAG) {
            gw.hello_due = true;
        }
        if entry.tag != gw.tag {
            return;
        }
        let head = gw.framer.position();
        if let Some(range) = entry.frames.and_then(range_of) {
            tracing::debug!(me = %self.me, at = ?now, ?range, head, "NACK heard for our stream");
            gw.repairs.nack_heard(range, head, now);
        }
    }

    /// The repair due now, if the gathering window closed: replays of what the
    /// history holds, `Gone` for the rest. It does not wait for the bucket: like a
    /// control message it is charged as it goes, and the queued data waits instead
    /// (2.3). Held behind a debt (a multi-frame state answer at the acoustic share is
    /// tens of seconds of it), it came after the receivers' NACK rounds ran out and
    /// they asked for the whole state instead.
    pub(super) fn repair_tick(&mut self) {
        let now = self.now;
        let Some(gw) = self.team.gateway.as_mut() else {
            return;
        };
        if !gw.repair_bucket.ready(now) {
            return; // NACKs heard meanwhile join the repair
        }
        let Some(ranges) = gw.repairs.poll(now) else {
            return;
        };
        for range in ranges {
            self.repair_range(range);
        }
    }

    /// Replays `range` from the history, split at the MTU, and says `Gone` for the
    /// positions it no longer holds.
    fn repair_range(&mut self, range: SeqRange) {
        let now = self.now;
        let mtu = self.config.team_protocol.as_ref().map_or(1024, |p| p.mtu);
        let Some(gw) = self.team.gateway.as_mut() else {
            return;
        };
        let tag = gw.tag;
        let lookup = gw.history.get(range.first(), range.n(), now);
        let gone = lookup.gone.map(|(from, n)| Gone {
            tag: gw.tag,
            span: Span { from, n },
            positions: gw.inner_positions(),
        });
        let mut bytes = 0;
        if let Some(gone) = gone {
            bytes += self
                .publish_team_msg(MsgKind::Gone, &TeamMsg::Gone(gone))
                .len();
        }
        tracing::debug!(me = %self.me, at = ?now, ?range, gone = ?lookup.gone, "repair");
        for repair in replays(tag, bodies_of(&lookup.held), mtu) {
            bytes += self
                .publish_team_msg(MsgKind::TeamRepair, &TeamMsg::Repair(repair))
                .len();
        }
        if let Some(gw) = self.team.gateway.as_mut() {
            gw.repair_bucket.spend(bytes, now);
        }
    }
}

/// The parts of the frames a history holds, by position (the history keeps encoded
/// frames, so each is decoded again; one that does not decode is left out).
fn bodies_of(held: &[(u64, std::sync::Arc<[u8]>)]) -> Vec<(u64, Vec<Part>)> {
    let decoded = held
        .iter()
        .map(|(seq, bytes)| (*seq, TeamMsg::decode(bytes)));
    decoded
        .filter_map(|(seq, msg)| match msg {
            Ok(TeamMsg::Frame(f)) => Some((seq, f.parts)),
            _ => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use slate_testing::addr;

    use super::super::gateway::{Framer, Gateway};
    use super::super::history::HistoryLimits;
    use super::super::nack::RepairScheduler;
    use super::super::pace::{Queued, TokenBucket};
    use super::super::test_state::{START, lifecycle, ms, robot_hello, tick_at};
    use super::*;
    use crate::ici::IciConfig;

    use crate::{LinkKind, SimNet};

    /// A state of `t/r0/m0` with the team protocol on (radio), on its own network.
    fn state() -> (SimNet, State) {
        let config = IciConfig::default().team_protocol(Some(TeamProtocol::radio()));
        let (net, mut state) = super::super::test_state::alone("t/r0/m0", config);
        state.now = START;
        (net, state)
    }

    fn tag_of(gateway: &Address) -> StreamTag {
        StreamTag::of(gateway, 9)
    }

    /// The hello of `gateway`'s robot: one member, m1.
    fn hello(gateway: &Address) -> Vec<u8> {
        hello_of(gateway, 9)
    }

    /// The hello of the epoch the gateway began at `epoch`.
    fn hello_of(gateway: &Address, epoch: u64) -> Vec<u8> {
        TeamMsg::Hello(robot_hello(gateway, epoch, &["m1"])).encode()
    }

    /// A frame of `t/r1/g`'s stream at `seq` holding m1's lifecycle message `seq`.
    fn frame(seq: u64) -> Vec<u8> {
        let parts = vec![Part::member(0, lifecycle(seq))];
        let check = tag_of(&addr("t/r1/g")).check();
        TeamMsg::Frame(TeamFrame { seq, check, parts }).encode()
    }

    fn nack(tag: StreamTag, from: u64, n: u64) -> Vec<u8> {
        let entry = NackEntry {
            tag,
            frames: Some(Span { from, n }),
            hello: false,
            state: None,
        };
        TeamMsg::Nack(Nack {
            entries: vec![entry],
        })
        .encode()
    }

    /// Team publications of `kind` this state made.
    fn sent(st: &State, kind: MsgKind) -> u64 {
        super::super::test_state::sent(st, LinkKind::Team, kind)
    }

    /// `st` hears gateway `t/r1/g` say its hello, then frames 1 and 3 at time 0.
    fn with_a_gap(st: &mut State) -> Address {
        let gw = addr("t/r1/g");
        st.on_team(&gw, &hello(&gw));
        st.on_team(&gw, &frame(1));
        st.on_team(&gw, &frame(3));
        gw
    }

    #[test]
    fn a_gap_in_a_robot_stream_is_nacked_once_after_the_grace_and_a_back_off() {
        let (_net, mut st) = state();
        with_a_gap(&mut st);
        tick_at(&mut st, ms(99));
        assert_eq!(sent(&st, MsgKind::Nack), 0, "within gap_grace");
        tick_at(&mut st, ms(400));
        assert_eq!(sent(&st, MsgKind::Nack), 1);
        tick_at(&mut st, ms(900));
        assert_eq!(sent(&st, MsgKind::Nack), 1, "the repair is awaited");
    }

    #[test]
    fn a_new_epoch_of_the_robot_stream_stops_the_nacks_of_the_old_one() {
        let (_net, mut st) = state();
        let gw = with_a_gap(&mut st);
        st.on_team(&gw, &hello_of(&gw, 10));
        let old = tag_of(&gw);
        assert!(st.team.nacks.as_ref().unwrap().missing(old).is_empty());
        tick_at(&mut st, ms(5000));
        assert_eq!(sent(&st, MsgKind::Nack), 0);
    }

    #[test]
    fn another_robots_nack_for_the_same_positions_suppresses_ours() {
        let (_net, mut st) = state();
        let gw = with_a_gap(&mut st);
        st.on_team(&addr("t/r2/g"), &nack(tag_of(&gw), 2, 1));
        tick_at(&mut st, ms(400));
        assert_eq!(sent(&st, MsgKind::Nack), 0);
    }

    #[test]
    fn a_repair_hands_on_the_missing_position_and_skips_those_held() {
        let (_net, mut st) = state();
        let gw = with_a_gap(&mut st);
        let bodies = (1..=3)
            .map(|s| vec![Part::member(0, lifecycle(s))])
            .collect();
        let repair = TeamRepair {
            from: 1,
            check: tag_of(&gw).check(),
            content: RepairContent::Replay(bodies),
        };
        st.on_team(&gw, &TeamMsg::Repair(repair).encode());
        let outer = st.team.speakers[&gw].outer.as_ref().unwrap();
        assert_eq!((outer.have(), outer.has_gap()), (3, false));
        let tag = tag_of(&gw);
        assert!(st.team.nacks.as_ref().unwrap().missing(tag).is_empty());
        tick_at(&mut st, ms(2000));
        assert_eq!(sent(&st, MsgKind::Nack), 0);
    }

    #[test]
    fn a_hello_is_nacked_while_frames_are_parked_and_not_once_it_came() {
        let (_net, mut st) = state();
        let gw = addr("t/r1/g");
        st.on_team(&gw, &frame(1));
        st.on_team(&gw, &frame(2));
        tick_at(&mut st, ms(400));
        assert_eq!(
            sent(&st, MsgKind::Nack),
            1,
            "one NACK for both parked frames"
        );
        st.on_team(&gw, &hello(&gw));
        assert_eq!(
            st.team.speakers[&gw].outer.as_ref().map(|o| o.have()),
            Some(2)
        );
        tick_at(&mut st, ms(5000));
        assert_eq!(sent(&st, MsgKind::Nack), 1);
    }

    #[test]
    fn a_hello_is_asked_again_until_its_gateway_is_silent_past_the_timeout() {
        let (_net, mut st) = state();
        st.on_team(&addr("t/r1/g"), &frame(1));
        for at in (400..60_000).step_by(100) {
            tick_at(&mut st, ms(at));
        }
        let asked = sent(&st, MsgKind::Nack);
        assert!(asked >= 2, "asked again after repair_wait");
        assert!(asked <= 6, "not past the 5 s timeout: {asked}");
    }

    /// Makes `st` the gateway of a stream whose frames 1..=3 it sent at time 0.
    fn gateway_of_three(st: &mut State, age: Duration) {
        let limits = HistoryLimits { bytes: 4096, age };
        let mut gw = Gateway::new(StreamTag(77), 1, Framer::new(1024, ms(250)), limits);
        gw.repairs = RepairScheduler::new(repair_timing(&TeamProtocol::radio()));
        for s in 1..=3u64 {
            let mut closed = gw.framer.push(0, lifecycle(s), START);
            closed.extend(gw.framer.flush());
            for f in closed {
                let bytes: Arc<[u8]> = TeamMsg::Frame(f.clone()).encode().into();
                gw.history.push(f.seq, bytes, START, &[]).unwrap();
            }
        }
        st.team.gateway = Some(gw);
    }

    #[test]
    fn nacks_from_many_robots_for_one_loss_get_one_broadcast_repair() {
        let (_net, mut st) = state();
        gateway_of_three(&mut st, Duration::from_secs(60));
        for robot in 1..=5 {
            st.on_team(&addr(&format!("t/r{robot}/g")), &nack(StreamTag(77), 2, 2));
        }
        st.now = START + ms(49);
        st.repair_tick();
        assert_eq!(sent(&st, MsgKind::TeamRepair), 0, "still gathering");
        st.now = START + ms(50);
        st.repair_tick();
        assert_eq!(sent(&st, MsgKind::TeamRepair), 1);
        st.on_team(&addr("t/r6/g"), &nack(StreamTag(77), 2, 1));
        st.now = START + ms(200);
        st.repair_tick();
        assert_eq!(
            sent(&st, MsgKind::TeamRepair),
            1,
            "held off: repaired lately"
        );
    }

    /// Repairs do not wait for the data's bucket, but they have one of their own at the
    /// link's rate: a member NACKing the same frames in a loop (a hostile one, or one
    /// that cannot hear) gets no more repair bytes than the link carries.
    #[test]
    fn a_member_nacking_in_a_loop_gets_no_more_repairs_than_the_link_carries() {
        let (_net, mut st) = state();
        gateway_of_three(&mut st, Duration::from_secs(60));
        let gw = st.team.gateway.as_mut().unwrap();
        // A byte a second, a byte deep: the first repair's bytes take longer to earn
        // than the loop lasts.
        gw.repair_bucket = TokenBucket::new(8, 1, START);
        let timing = repair_timing(&TeamProtocol::radio());
        for round in 1..=20u32 {
            st.on_team(&addr("t/r1/g"), &nack(StreamTag(77), 1, 3));
            st.now = START + (timing.repair_gather + timing.repair_holdoff) * round;
            st.repair_tick();
        }
        assert_eq!(sent(&st, MsgKind::TeamRepair), 1);
    }

    /// Seed 7 of the acoustic demo (session 15): the console framed a 401-byte state
    /// answer (13 frames) at 175.7 s, 46 s of debt at its 70 bit/s share; r1's NACK came
    /// at 193.7 s and the repair waited for the bucket until 232.6 s, while r1's three
    /// rounds of `repair_wait` ran out at 220.2 s and it asked for the console's state.
    #[test]
    fn a_repair_does_not_wait_for_the_bucket_and_the_data_behind_it_does() {
        let (_net, mut st) = state();
        gateway_of_three(&mut st, Duration::from_secs(60));
        let acoustic = TeamProtocol::acoustic();
        let gw = st.team.gateway.as_mut().unwrap();
        gw.repairs = RepairScheduler::new(repair_timing(&acoustic));
        gw.bucket = TokenBucket::of(&acoustic, START);
        gw.bucket.spend(401, START);
        gw.queue.push(Queued {
            member: 0,
            message: lifecycle(4),
            mark: None,
            since: START,
            answer: false,
        });
        st.on_team(&addr("t/r1/g"), &nack(StreamTag(77), 2, 1));
        st.now = START + acoustic.repair_gather;
        st.repair_tick();
        st.pump();
        assert_eq!(
            sent(&st, MsgKind::TeamRepair),
            1,
            "the repair goes within the receivers' round (repair_wait {:?}), not after the \
             46 s the debt takes to pay",
            acoustic.repair_wait
        );
        let gw = st.team.gateway.as_mut().unwrap();
        assert!(!gw.queue.is_empty(), "the data waits for the bucket");
        assert!(!gw.bucket.ready(st.now), "the repair was charged");
    }

    #[test]
    fn positions_the_history_no_longer_holds_are_answered_with_gone() {
        let (_net, mut st) = state();
        gateway_of_three(&mut st, ms(10));
        st.now = START + ms(100);
        st.on_team(&addr("t/r1/g"), &nack(StreamTag(77), 1, 3));
        st.now = START + ms(150);
        st.repair_tick();
        assert_eq!(sent(&st, MsgKind::Gone), 1);
        assert_eq!(sent(&st, MsgKind::TeamRepair), 0);
    }

    fn part(member: u8, len: usize) -> Part {
        Part::member(member, vec![0x11; len])
    }

    #[test]
    fn consecutive_bodies_share_a_repair_up_to_the_mtu() {
        let bodies: Vec<(u64, Vec<Part>)> = (5..10).map(|s| (s, vec![part(0, 30)])).collect();
        let repairs = replays(StreamTag(7), bodies, 80);
        assert!(repairs.len() > 1);
        let mut next = 5;
        for r in &repairs {
            assert!(r.encoded_len() <= 80, "{} bytes", r.encoded_len());
            assert_eq!(r.from, next);
            assert_eq!(TeamMsg::Repair(r.clone()).encode().len(), r.encoded_len());
            next = r.span().end();
        }
        assert_eq!(next, 10);
    }

    #[test]
    fn a_hole_in_the_positions_starts_a_new_repair() {
        let bodies = vec![
            (3, vec![part(0, 4)]),
            (4, vec![part(1, 4)]),
            (9, vec![part(0, 4)]),
        ];
        let repairs = replays(StreamTag(7), bodies, 1024);
        let spans: Vec<(u64, u64)> = repairs.iter().map(|r| (r.from, r.span().n)).collect();
        assert_eq!(spans, vec![(3, 2), (9, 1)]);
    }

    #[test]
    fn a_hello_nack_for_any_tag_or_the_same_tag_covers_an_ask() {
        let ask = HelloAsk {
            tag: StreamTag(7),
            due: Duration::ZERO,
        };
        assert!(ask.covered_by(StreamTag(7)));
        assert!(ask.covered_by(ANY_TAG));
        assert!(!ask.covered_by(StreamTag(8)));
    }

    #[test]
    fn two_modules_draw_different_back_offs() {
        let a = nack_seed(&slate_testing::addr("t/r1/m0"), 5);
        let b = nack_seed(&slate_testing::addr("t/r1/m1"), 5);
        assert_ne!(a, b);
        assert_eq!(a, nack_seed(&slate_testing::addr("t/r1/m0"), 5));
    }
}
