//! The receiver's tracker of one robot stream (`Outer`, docs/team-protocol.md 2.4 and
//! 2.5): which positions of a gateway's numbered stream arrived, which are missing (as
//! ranges to NACK), since when a gap has been open, when the stream restarted (a new
//! tag) or jumped (a gap too large to repair, "ask for state"), and the reassembly of
//! messages fragmented across consecutive positions (CONT/MORE parts).
//!
//! The positions received above `have` sit in a fixed ring of `u128` words (`window.rs`,
//! shared with the `Inbound` of `stream.rs`), so a frame costs O(1) word operations
//! whatever the window holds. A frame more than `WINDOW_SPAN` ahead is a gap too large
//! to repair (the large-gap rule): at the radio's 4 frames a second this is almost 4
//! minutes of stream, far more than a NACK round (`max_nack_frames`, 64, is the tighter
//! bound in practice). Time is passed in, never read.

use std::collections::BTreeMap;
use std::time::Duration;

use crate::ici::window::{WINDOW_SPAN, Window};

/// The longest message reassembled from fragments: a longer one could not be a
/// slate-wire message or ICI frame anyway. It is dropped and counted (`too_long`).
pub(crate) const MAX_MESSAGE_BYTES: usize = slate_wire::MAX_MESSAGE_BYTES;

/// Bytes of incomplete messages held per stream, all runs together. The oldest runs
/// (lowest positions) are dropped first, and counted, when more would be held.
pub(crate) const MAX_FRAGMENT_BYTES: usize = MAX_MESSAGE_BYTES;

/// Incomplete runs of fragments held per stream (the same rule as the bytes).
pub(crate) const MAX_FRAGMENT_RUNS: usize = 64;

/// What a frame's arrival means.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Heard {
    /// A position not held before: hand its parts on (fragments to [`Outer::fragment`]).
    Fresh(Change),
    /// At or below `have`, or already in the window: drop the frame whole.
    Duplicate,
    /// A frame of the epoch before the current one (its tag), arriving late: drop it.
    Retired,
}

/// What happened to the stream on the way, beside the position itself.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Change {
    /// A new tag: the gateway restarted (or another took over), a new epoch began and
    /// everything known of the old one was forgotten.
    pub restarted: bool,
    /// The gap grew larger than `max_nack_frames` (or the window): `have` jumped to the
    /// position heard and what lay between is lost for the robot stream. Ask the
    /// members' state (2.6, case b) rather than NACK the positions.
    pub ask_state: bool,
    /// Positions newly known to be missing, as `(from, n)`: those between the highest
    /// position known before and the one heard (for the NACK scheduler's
    /// `gap_found`). `None` when nothing new is missing, or after a jump.
    pub revealed: Option<(u64, u64)>,
}

/// A part that is a fragment of a longer message (CONT or MORE set, 2.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Fragment<'a> {
    /// The member index of the part (its low 5 bits).
    pub member: u8,
    /// CONT: these bytes continue the message of the previous position's last part.
    pub cont: bool,
    /// MORE: the message continues in the next position's first part.
    pub more: bool,
    pub bytes: &'a [u8],
}

/// A message whole again.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Reassembled {
    pub member: u8,
    pub bytes: Vec<u8>,
}

/// What a tracker counted since it was made (restarts do not reset it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct OuterCounts {
    /// Frames dropped as duplicates.
    pub duplicates: u64,
    /// Frames and heartbeats of the retired epoch dropped.
    pub retired: u64,
    /// New tags seen (restarts of the stream).
    pub restarts: u64,
    /// Jumps of `have` over a gap too large to NACK.
    pub resyncs: u64,
    /// Messages dropped because their fragments came to more than `MAX_MESSAGE_BYTES`.
    pub too_long: u64,
    /// Fragments dropped: their neighbour was lost or was not a fragment, their member
    /// did not match, or the buffer's limits pushed them out.
    pub fragments_dropped: u64,
    /// Word operations of the bit window: what the O(1)-per-frame claim is about.
    pub window_ops: u64,
}

/// The receiver's view of one robot stream (one per gateway address).
///
/// Invariants: every position `<= have` arrived or was covered; the window holds
/// exactly the positions received in `have + 1 ..= want`; `want - have <= WINDOW_SPAN`;
/// the positions missing in `have + 1 ..= want` number at most `max_nack_frames`;
/// `gap_since` is set exactly when `have < want`.
#[derive(Debug)]
pub(crate) struct Outer {
    tag: u16,
    /// The tag of the epoch before this one: its late frames are dropped, not taken
    /// for yet another restart.
    retired: Option<u16>,
    have: u64,
    want: u64,
    window: Window,
    gap_since: Option<Duration>,
    max_nack_frames: u64,
    fragments: Reassembly,
    counts: OuterCounts,
}

impl Outer {
    /// A tracker for a stream first heard with `tag`, nothing received yet. A gap
    /// larger than `max_nack_frames` (at most `WINDOW_SPAN`) is not NACKed.
    pub fn new(tag: u16, max_nack_frames: u64) -> Outer {
        Outer {
            tag,
            retired: None,
            have: 0,
            want: 0,
            window: Window::default(),
            gap_since: None,
            max_nack_frames: max_nack_frames.min(WINDOW_SPAN),
            fragments: Reassembly::default(),
            counts: OuterCounts::default(),
        }
    }

    /// A frame at `seq` of the epoch `tag` arrived at `now`.
    pub fn receive(&mut self, tag: u16, seq: u64, now: Duration) -> Heard {
        let Some(restarted) = self.epoch(tag) else {
            return Heard::Retired;
        };
        if self.holds(seq) {
            self.counts.duplicates += 1;
            return Heard::Duplicate;
        }
        self.fragments.collect(self.have, &mut self.counts);
        let known = self.want;
        let ask_state = self.take(seq, now);
        Heard::Fresh(Change {
            restarted,
            ask_state,
            revealed: between(known + 1, seq - 1).filter(|_| !ask_state),
        })
    }

    /// A heartbeat of the epoch `tag` says the stream is at `seq`. `None` when it is of
    /// the retired epoch (ignored).
    pub fn announce(&mut self, tag: u16, seq: u64, now: Duration) -> Option<Change> {
        let restarted = self.epoch(tag)?;
        let known = self.want;
        self.want = self.want.max(seq);
        let ask_state = self.jump_if_too_large();
        if !ask_state {
            self.advance(now);
        }
        Some(Change {
            restarted,
            ask_state,
            revealed: between(known + 1, seq).filter(|_| !ask_state),
        })
    }

    /// The positions `from .. from + n` are closed without their frames (a `Gone`, or
    /// a state answer that covers them). Only positions known to exist (`<= want`) are
    /// closed: a `Gone` answers a NACK, which asks for no more, and a bogus or foreign
    /// one (a tag collision, 2.9) must not push `have` past what the stream will send.
    pub fn cover(&mut self, from: u64, n: u64, now: Duration) {
        let last = from.saturating_add(n).saturating_sub(1).min(self.want);
        let first = from.max(self.have + 1);
        if n == 0 || first > last {
            return;
        }
        self.window.mark(first, last);
        self.advance(now);
    }

    /// A new epoch (a robot hello with a new `gw_incarnation`, or a frame with a new
    /// tag): everything known of the stream is forgotten, and the old tag's late frames
    /// will be dropped.
    pub fn restart(&mut self, tag: u16) {
        self.retired = (tag != self.tag).then_some(self.tag);
        self.tag = tag;
        self.counts.restarts += 1;
        self.reset_to(0);
    }

    /// Forget the positions up to `seq` (a robot held dead or silent came back:
    /// 2.5, "does not NACK positions"); the caller asks for state.
    pub fn resync(&mut self, seq: u64) {
        if seq > self.have {
            self.jump(seq);
        }
    }

    /// Hand on a fragment of the fresh position `seq` (call it right after
    /// [`receive`](Self::receive) said `Fresh`, for each fragment part in the frame's
    /// order). Returns the message when this fragment completed it.
    pub fn fragment(&mut self, seq: u64, part: Fragment<'_>) -> Option<Reassembled> {
        self.fragments.add(seq, part, self.have, &mut self.counts)
    }

    /// The stream tag of the current epoch.
    pub fn tag(&self) -> u16 {
        self.tag
    }

    /// Every position up to this one arrived or was covered.
    pub fn have(&self) -> u64 {
        self.have
    }

    /// The highest position known to exist (from frames and heartbeats).
    pub fn want(&self) -> u64 {
        self.want
    }

    /// Is a position missing?
    pub fn has_gap(&self) -> bool {
        self.have < self.want
    }

    /// When the current gap opened (none is open: `None`). Reset when it closes.
    pub fn gap_since(&self) -> Option<Duration> {
        self.gap_since
    }

    /// How long the current gap has been open, if one is.
    pub fn gap_age(&self, now: Duration) -> Option<Duration> {
        self.gap_since.map(|t| now.saturating_sub(t))
    }

    /// How many positions are missing (at most `max_nack_frames`).
    pub fn missing(&self) -> u64 {
        self.want - self.have - self.window.held
    }

    /// The missing positions as `(from, n)` ranges, lowest first: what to NACK.
    /// There are at most `max_nack_frames` of them.
    pub fn missing_ranges(&self) -> Vec<(u64, u64)> {
        self.window.gaps(self.have, self.want)
    }

    /// What was counted so far.
    pub fn counts(&self) -> OuterCounts {
        OuterCounts {
            window_ops: self.window.ops,
            ..self.counts
        }
    }

    /// Settle which epoch `tag` belongs to: `None` for the retired one, `Some(true)`
    /// when it starts a new one (the tracker is reset to it).
    fn epoch(&mut self, tag: u16) -> Option<bool> {
        if tag == self.tag {
            return Some(false);
        }
        if self.retired == Some(tag) {
            self.counts.retired += 1;
            return None;
        }
        self.restart(tag);
        Some(true)
    }

    /// Is `seq` held already? Position 0 does not exist: held, so dropped. A position
    /// beyond the window is not looked up: its slot belongs to another position.
    fn holds(&mut self, seq: u64) -> bool {
        seq <= self.have || (seq - self.have <= WINDOW_SPAN && self.window.contains(seq))
    }

    /// Take the fresh position `seq`; true when it made the gap too large (`have`
    /// jumped to it).
    fn take(&mut self, seq: u64, now: Duration) -> bool {
        if seq - self.have > WINDOW_SPAN {
            self.jump(seq);
            return true;
        }
        self.window.insert(seq);
        self.want = self.want.max(seq);
        if self.jump_if_too_large() {
            return true;
        }
        self.advance(now);
        false
    }

    /// The large-gap rule: more missing than `max_nack_frames` (or a position beyond
    /// the window) makes `have` jump to `want`.
    fn jump_if_too_large(&mut self) -> bool {
        let too_large =
            self.want - self.have > WINDOW_SPAN || self.missing() > self.max_nack_frames;
        if too_large {
            self.jump(self.want);
        }
        too_large
    }

    /// `have` jumps to `seq`: the positions below are given up, the window and the
    /// fragments waiting for them are emptied.
    fn jump(&mut self, seq: u64) {
        self.counts.resyncs += 1;
        self.reset_to(seq);
    }

    fn reset_to(&mut self, seq: u64) {
        self.have = seq;
        self.want = seq;
        self.gap_since = None;
        self.window.clear();
        self.fragments.clear(&mut self.counts);
    }

    /// Move `have` over the run of positions received just above it, and keep
    /// `gap_since` in step.
    fn advance(&mut self, now: Duration) {
        self.have += self.window.take_run(self.have + 1);
        if !self.has_gap() {
            self.gap_since = None;
        } else if self.gap_since.is_none() {
            self.gap_since = Some(now);
        }
    }
}

/// `first ..= last` as `(from, n)`, if it is not empty.
fn between(first: u64, last: u64) -> Option<(u64, u64)> {
    (first <= last).then(|| (first, last - first + 1))
}

/// A run of fragments over consecutive positions, not yet a whole message.
#[derive(Debug)]
struct Run {
    member: u8,
    /// The position of its last fragment.
    end: u64,
    /// Its last fragment has MORE: it waits for the next position's first part.
    more: bool,
    bytes: Vec<u8>,
}

/// Incomplete messages of one stream, keyed by where their first fragment sits:
/// `(position, opens)`, where `opens` is true when that fragment has no CONT (it is
/// its position's last part and begins the message). A CONT fragment is its
/// position's first part, so it sorts before one that opens at the same position.
///
/// Bounded by `MAX_FRAGMENT_BYTES` and `MAX_FRAGMENT_RUNS`. A run whose neighbour
/// position was handed on without completing it can never complete and is dropped,
/// at once or when `have` passes it (`collect`).
#[derive(Debug, Default)]
struct Reassembly {
    runs: BTreeMap<(u64, bool), Run>,
    bytes: usize,
}

impl Reassembly {
    /// Add the fragment `part` at `seq`; every position `<= have` but `seq` has been
    /// handed on already.
    fn add(
        &mut self,
        seq: u64,
        part: Fragment<'_>,
        have: u64,
        counts: &mut OuterCounts,
    ) -> Option<Reassembled> {
        let mut key = (seq, !part.cont);
        let mut run = Run {
            member: part.member,
            end: seq,
            more: part.more,
            bytes: part.bytes.to_vec(),
        };
        if part.cont
            && let Some((before_key, before)) = self.take_ending_at(seq.saturating_sub(1))
        {
            key = before_key;
            run = join(before, run, counts)?;
        }
        if part.more
            && let Some(after) = self.take(&(seq + 1, false))
        {
            run = join(run, after, counts)?;
        }
        self.settle(key, run, have, counts)
    }

    /// A joined run: hand it on when whole, drop it when it cannot become whole or is
    /// too long, keep it otherwise.
    fn settle(
        &mut self,
        key: (u64, bool),
        run: Run,
        have: u64,
        counts: &mut OuterCounts,
    ) -> Option<Reassembled> {
        if run.bytes.len() > MAX_MESSAGE_BYTES {
            counts.too_long += 1;
            return None;
        }
        if key.1 && !run.more {
            return Some(Reassembled {
                member: run.member,
                bytes: run.bytes,
            });
        }
        if orphaned(key, &run, have) {
            counts.fragments_dropped += 1;
            return None;
        }
        self.keep(key, run, counts);
        None
    }

    /// Store a run, first dropping the oldest ones if the limits say so.
    fn keep(&mut self, key: (u64, bool), run: Run, counts: &mut OuterCounts) {
        while self.runs.len() >= MAX_FRAGMENT_RUNS
            || self.bytes + run.bytes.len() > MAX_FRAGMENT_BYTES
        {
            let Some((_, old)) = self.runs.pop_first() else {
                break;
            };
            self.bytes -= old.bytes.len();
            counts.fragments_dropped += 1;
        }
        self.bytes += run.bytes.len();
        if let Some(old) = self.runs.insert(key, run) {
            // Two CONT parts, or two opening parts, at one position: a bad frame.
            self.bytes -= old.bytes.len();
            counts.fragments_dropped += 1;
        }
    }

    /// Remove the run whose last fragment is at `seq` and has MORE. Runs do not
    /// overlap, so it is the one that starts last at or before `seq`.
    fn take_ending_at(&mut self, seq: u64) -> Option<((u64, bool), Run)> {
        let (&key, run) = self.runs.range(..=(seq, true)).next_back()?;
        if run.end != seq || !run.more {
            return None;
        }
        self.take(&key).map(|run| (key, run))
    }

    fn take(&mut self, key: &(u64, bool)) -> Option<Run> {
        let run = self.runs.remove(key)?;
        self.bytes -= run.bytes.len();
        Some(run)
    }

    /// Drop the runs that `have` has passed without completing them. Call it before
    /// `have` moves, when every position up to it has been handed on. Runs are in
    /// position order and a dead run has only dead runs below it, so this looks at the
    /// lowest ones only: O(1) per run dropped.
    fn collect(&mut self, have: u64, counts: &mut OuterCounts) {
        while let Some(entry) = self.runs.first_entry() {
            if !orphaned(*entry.key(), entry.get(), have) {
                return;
            }
            let run = entry.remove();
            self.bytes -= run.bytes.len();
            counts.fragments_dropped += 1;
        }
    }

    fn clear(&mut self, counts: &mut OuterCounts) {
        counts.fragments_dropped += self.runs.len() as u64;
        self.runs.clear();
        self.bytes = 0;
    }
}

/// Can the run never complete? Its first fragment continues a position already handed
/// on, or its last one waits for a position already handed on.
fn orphaned(key: (u64, bool), run: &Run, have: u64) -> bool {
    let (start, opens) = key;
    (!opens && start <= have + 1) || (run.more && run.end < have)
}

/// `first` followed by `then`, if they are of the same member (else both are dropped).
fn join(mut first: Run, then: Run, counts: &mut OuterCounts) -> Option<Run> {
    if first.member != then.member {
        counts.fragments_dropped += 2;
        return None;
    }
    first.bytes.extend_from_slice(&then.bytes);
    first.end = then.end;
    first.more = then.more;
    Some(first)
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use crate::ici::window::{WINDOW_WORDS, WORD_BITS};

    use proptest::prelude::*;

    use super::*;

    const T0: Duration = Duration::ZERO;
    const TAG: u16 = 0xA1;
    const MAX_NACK: u64 = 64;

    fn secs(s: u64) -> Duration {
        Duration::from_secs(s)
    }

    fn outer() -> Outer {
        Outer::new(TAG, MAX_NACK)
    }

    fn fresh() -> Heard {
        Heard::Fresh(Change::default())
    }

    /// A stream that received position 1: `head`, the start of a message of member 0
    /// that goes on at position 2.
    fn with_a_head(head: &[u8]) -> Outer {
        let mut o = outer();
        o.receive(TAG, 1, T0);
        o.fragment(1, part(0, false, true, head));
        o
    }

    fn receive_all(o: &mut Outer, seqs: impl IntoIterator<Item = u64>) {
        for seq in seqs {
            o.receive(TAG, seq, T0);
        }
    }

    fn part(member: u8, cont: bool, more: bool, bytes: &[u8]) -> Fragment<'_> {
        Fragment {
            member,
            cont,
            more,
            bytes,
        }
    }

    #[test]
    fn frames_in_order_leave_no_gap() {
        let mut o = outer();
        assert_eq!(o.receive(TAG, 1, T0), fresh());
        assert_eq!(o.receive(TAG, 2, T0), fresh());
        assert_eq!((o.have(), o.want(), o.has_gap()), (2, 2, false));
        assert!(o.missing_ranges().is_empty());
    }

    #[test]
    fn a_frame_heard_twice_is_a_duplicate() {
        let mut o = outer();
        receive_all(&mut o, [1, 2]);
        assert_eq!(o.receive(TAG, 2, T0), Heard::Duplicate, "at have");
        o.receive(TAG, 5, T0);
        assert_eq!(o.receive(TAG, 5, T0), Heard::Duplicate, "in the window");
        assert_eq!(
            o.receive(TAG, 0, T0),
            Heard::Duplicate,
            "position 0 never exists"
        );
        assert_eq!(o.counts().duplicates, 3);
    }

    #[test]
    fn a_gap_opens_at_the_later_frame_and_closes_when_the_missing_ones_arrive() {
        let mut o = outer();
        o.receive(TAG, 1, T0);
        o.receive(TAG, 4, secs(1));
        assert_eq!(o.gap_since(), Some(secs(1)));
        assert_eq!(o.gap_age(secs(3)), Some(secs(2)));
        o.receive(TAG, 6, secs(2));
        assert_eq!(o.gap_since(), Some(secs(1)), "the gap that opened first");
        assert_eq!(o.missing_ranges(), vec![(2, 2), (5, 1)]);
        assert_eq!(o.missing(), 3);
        receive_all(&mut o, [3, 2, 5]);
        assert_eq!((o.have(), o.has_gap(), o.gap_since()), (6, false, None));
    }

    #[test]
    fn a_frame_past_want_reveals_the_positions_between_once() {
        let mut o = outer();
        let revealed = |h: Heard| match h {
            Heard::Fresh(c) => c.revealed,
            _ => None,
        };
        assert_eq!(revealed(o.receive(TAG, 4, T0)), Some((1, 3)));
        assert_eq!(revealed(o.receive(TAG, 2, T0)), None, "below want");
        assert_eq!(revealed(o.receive(TAG, 5, T0)), None, "next to want");
        assert_eq!(revealed(o.receive(TAG, 9, T0)), Some((6, 3)));
        assert_eq!(
            revealed(o.receive(TAG, 200, T0)),
            None,
            "a jump reveals nothing"
        );
    }

    #[test]
    fn a_heartbeat_above_have_reveals_a_lost_tail() {
        let mut o = outer();
        o.receive(TAG, 1, T0);
        let tail = Change {
            revealed: Some((2, 2)),
            ..Change::default()
        };
        assert_eq!(o.announce(TAG, 3, secs(2)), Some(tail));
        assert_eq!(o.missing_ranges(), vec![(2, 2)]);
        assert_eq!(o.gap_since(), Some(secs(2)));
        assert_eq!(o.announce(TAG, 1, secs(3)), Some(Change::default()));
        assert_eq!(o.want(), 3, "an older heartbeat does not lower want");
    }

    #[test]
    fn missing_ranges_join_across_words_of_the_window() {
        let mut o = Outer::new(TAG, WINDOW_SPAN);
        o.receive(TAG, 100, T0);
        o.receive(TAG, 130, T0);
        assert_eq!(o.missing_ranges(), vec![(1, 99), (101, 29)]);
        assert_eq!(o.missing(), 128);
    }

    #[test]
    fn a_new_tag_restarts_the_stream_and_the_old_tags_late_frames_are_dropped() {
        let mut o = outer();
        receive_all(&mut o, [1, 2, 3]);
        o.fragment(3, part(0, false, true, b"ab"));
        let restarted = Change {
            restarted: true,
            ..Change::default()
        };
        assert_eq!(o.receive(7, 1, T0), Heard::Fresh(restarted));
        assert_eq!((o.tag(), o.have()), (7, 1));
        assert_eq!(o.receive(TAG, 4, T0), Heard::Retired);
        assert_eq!(o.announce(TAG, 9, T0), None);
        assert_eq!(o.want(), 1, "the retired heartbeat changed nothing");
        let c = o.counts();
        assert_eq!((c.restarts, c.retired, c.fragments_dropped), (1, 2, 1));
    }

    #[test]
    fn a_hello_with_a_new_incarnation_restarts_the_stream() {
        let mut o = outer();
        receive_all(&mut o, [1, 2]);
        o.restart(9);
        assert_eq!((o.tag(), o.have(), o.want()), (9, 0, 0));
        assert_eq!(o.receive(9, 1, T0), fresh(), "the new epoch from 1");
    }

    #[test]
    fn a_gap_larger_than_max_nack_frames_jumps_to_the_position_heard_and_asks_for_state() {
        let mut o = outer();
        o.receive(TAG, 1, T0);
        o.receive(TAG, 1 + MAX_NACK + 1, T0);
        assert_eq!(o.missing(), MAX_NACK, "64 missing: still NACKed");
        let heard = o.receive(TAG, 1 + MAX_NACK + 3, secs(1));
        let jumped = Change {
            ask_state: true,
            ..Change::default()
        };
        assert_eq!(heard, Heard::Fresh(jumped));
        assert_eq!((o.have(), o.has_gap(), o.gap_since()), (68, false, None));
        assert_eq!(o.receive(TAG, 30, T0), Heard::Duplicate, "given up");
        assert_eq!(o.counts().resyncs, 1);
    }

    #[test]
    fn received_frames_do_not_count_toward_the_large_gap() {
        let mut o = outer();
        receive_all(&mut o, 2..=200);
        assert_eq!(
            (o.have(), o.missing()),
            (0, 1),
            "only position 1 is missing"
        );
        assert_eq!(o.receive(TAG, 1, T0), fresh());
        assert_eq!(o.have(), 200);
    }

    #[test]
    fn a_frame_beyond_the_window_jumps_even_with_a_small_gap() {
        let mut o = Outer::new(TAG, u64::MAX);
        receive_all(&mut o, 2..=WINDOW_SPAN);
        let heard = o.receive(TAG, WINDOW_SPAN + 1, T0);
        assert!(matches!(heard, Heard::Fresh(c) if c.ask_state));
        assert_eq!(o.have(), WINDOW_SPAN + 1);
    }

    #[test]
    fn a_frame_far_ahead_is_not_mistaken_for_one_held_in_its_slot() {
        let mut o = outer();
        o.receive(TAG, 5, T0);
        let ring = WINDOW_WORDS as u64 * WORD_BITS;
        let heard = o.receive(TAG, 5 + ring, T0);
        assert!(matches!(heard, Heard::Fresh(c) if c.ask_state));
        assert_eq!(o.have(), 5 + ring);
    }

    #[test]
    fn a_heartbeat_far_ahead_jumps_and_asks_for_state() {
        let mut o = outer();
        o.receive(TAG, 1, T0);
        let change = o.announce(TAG, 500, T0).map(|c| c.ask_state);
        assert_eq!(change, Some(true));
        assert_eq!((o.have(), o.has_gap()), (500, false));
    }

    #[test]
    fn a_gone_range_closes_its_positions() {
        let mut o = outer();
        receive_all(&mut o, [1, 5, 9]);
        o.cover(2, 3, T0);
        assert_eq!((o.have(), o.missing_ranges()), (5, vec![(6, 3)]));
        o.cover(6, 0, T0);
        assert_eq!(o.have(), 5, "an empty range closes nothing");
        o.cover(6, 2, T0);
        assert_eq!((o.have(), o.missing_ranges()), (7, vec![(8, 1)]));
        o.cover(1, 100, T0);
        assert_eq!((o.have(), o.has_gap()), (9, false));
    }

    #[test]
    fn a_gone_range_closes_nothing_past_the_positions_known_to_exist() {
        let mut o = outer();
        receive_all(&mut o, [1, 3]);
        o.cover(2, u64::MAX, T0);
        assert_eq!((o.have(), o.want()), (3, 3));
        assert_eq!(o.receive(TAG, 4, T0), fresh());
    }

    #[test]
    fn a_robot_back_from_silence_resyncs_to_the_position_heard() {
        let mut o = outer();
        receive_all(&mut o, [1, 2, 4]);
        o.resync(40);
        assert_eq!((o.have(), o.has_gap()), (40, false));
        assert_eq!(o.receive(TAG, 41, T0), fresh());
        o.resync(3);
        assert_eq!(o.have(), 41, "resync never goes back");
    }

    #[test]
    fn a_fragmented_message_in_order_is_reassembled() {
        let mut o = outer();
        o.receive(TAG, 1, T0);
        assert_eq!(o.fragment(1, part(3, false, true, b"he")), None);
        o.receive(TAG, 2, T0);
        assert_eq!(o.fragment(2, part(3, true, true, b"ll")), None);
        o.receive(TAG, 3, T0);
        let whole = o.fragment(3, part(3, true, false, b"o"));
        let expected = Reassembled {
            member: 3,
            bytes: b"hello".to_vec(),
        };
        assert_eq!(whole, Some(expected));
        assert_eq!(o.fragments.bytes, 0);
    }

    #[test]
    fn fragments_out_of_order_are_reassembled() {
        let mut o = outer();
        let pieces = [
            (3, part(1, true, false, b"c")),
            (1, part(1, false, true, b"a")),
        ];
        for (seq, p) in pieces {
            o.receive(TAG, seq, T0);
            assert_eq!(o.fragment(seq, p), None);
        }
        o.receive(TAG, 2, T0);
        let whole = o.fragment(2, part(1, true, true, b"b"));
        assert_eq!(whole.map(|m| m.bytes), Some(b"abc".to_vec()));
    }

    #[test]
    fn one_position_ends_one_message_and_begins_the_next() {
        let mut o = with_a_head(b"x1");
        o.receive(TAG, 2, T0);
        let first = o.fragment(2, part(0, true, false, b"x2"));
        assert_eq!(first.map(|m| m.bytes), Some(b"x1x2".to_vec()));
        assert_eq!(o.fragment(2, part(4, false, true, b"y1")), None);
        o.receive(TAG, 3, T0);
        let second = o.fragment(3, part(4, true, false, b"y2"));
        assert_eq!(second.map(|m| m.member), Some(4));
    }

    #[test]
    fn a_continuation_of_a_position_handed_on_without_its_head_is_dropped() {
        let mut o = outer();
        receive_all(&mut o, [1, 2]);
        assert_eq!(o.fragment(2, part(0, true, false, b"tail")), None);
        assert_eq!(o.counts().fragments_dropped, 1);
        assert!(o.fragments.runs.is_empty());
    }

    #[test]
    fn a_head_whose_next_position_was_lost_is_dropped_when_have_passes_it() {
        let mut o = with_a_head(b"head");
        o.announce(TAG, 2, T0);
        o.cover(2, 1, T0);
        o.receive(TAG, 3, T0);
        assert!(o.fragments.runs.is_empty());
        assert_eq!(o.counts().fragments_dropped, 1);
    }

    #[test]
    fn fragments_of_different_members_do_not_join() {
        let mut o = with_a_head(b"a");
        o.receive(TAG, 2, T0);
        assert_eq!(o.fragment(2, part(1, true, false, b"b")), None);
        assert_eq!(o.counts().fragments_dropped, 2);
    }

    #[test]
    fn a_message_longer_than_the_limit_is_dropped_and_counted() {
        let mut o = outer();
        let chunk = vec![7u8; 1024];
        let pieces = MAX_MESSAGE_BYTES / chunk.len() + 1;
        for seq in 1..=pieces as u64 {
            o.receive(TAG, seq, T0);
            assert_eq!(o.fragment(seq, part(0, seq > 1, true, &chunk)), None);
        }
        assert_eq!(o.counts().too_long, 1);
        assert!(o.fragments.bytes <= MAX_FRAGMENT_BYTES);
        o.receive(TAG, pieces as u64 + 1, T0);
        let rest = o.fragment(pieces as u64 + 1, part(0, true, false, b"end"));
        assert_eq!(rest, None, "the rest of the long message is dropped too");
    }

    #[test]
    fn waiting_fragments_are_bounded_in_runs_and_bytes() {
        let mut o = Outer::new(TAG, u64::MAX);
        let chunk = vec![1u8; 4096];
        for i in 0..100u64 {
            let seq = 2 + 2 * i;
            o.receive(TAG, seq, T0);
            o.fragment(seq, part(0, false, true, &chunk));
        }
        assert!(o.fragments.runs.len() <= MAX_FRAGMENT_RUNS);
        assert!(o.fragments.bytes <= MAX_FRAGMENT_BYTES);
        assert!(o.counts().fragments_dropped >= 100 - MAX_FRAGMENT_RUNS as u64);
    }

    /// 10^5 positions, each block of 64 delivered in a scrambled order (so the gap
    /// never passes `max_nack_frames`): the window's word operations per frame stay
    /// under a constant.
    #[test]
    fn out_of_order_positions_cost_o1_window_operations_each() {
        const N: u64 = 100_000;
        let mut o = outer();
        for block in (1..=N).step_by(64) {
            for i in 0..64 {
                // 37 is odd, so i -> 37 i mod 64 visits each of the block once.
                o.receive(TAG, block + (37 * i) % 64, T0);
            }
        }
        assert_eq!(
            (o.have(), o.counts().duplicates),
            (N.next_multiple_of(64), 0)
        );
        let per_frame = o.counts().window_ops as f64 / N as f64;
        assert!(per_frame <= 4.0, "{per_frame} word operations per frame");
    }

    /// The same positions through a `BTreeSet` model: same duplicates, same `have`,
    /// same missing ranges, whatever the order (no jumps: the limit is the window);
    /// every position missing was revealed once, when it went missing.
    fn check_against_a_set(seqs: &[u64]) {
        let mut o = Outer::new(TAG, WINDOW_SPAN);
        let mut got = BTreeSet::new();
        let mut revealed = BTreeSet::new();
        for &seq in seqs {
            let heard = o.receive(TAG, seq, T0);
            assert_eq!(matches!(heard, Heard::Fresh(_)), got.insert(seq), "{seq}");
            if let Heard::Fresh(Change {
                revealed: Some((from, n)),
                ..
            }) = heard
            {
                assert!((from..from + n).all(|s| revealed.insert(s)), "once");
            }
        }
        let want = got.last().copied().unwrap_or(0);
        assert!((1..=want).all(|s| got.contains(&s) || revealed.contains(&s)));
        let have = (1..).find(|s| !got.contains(s)).unwrap_or(1) - 1;
        let missing: Vec<u64> = (have + 1..=want).filter(|s| !got.contains(s)).collect();
        let from_ranges: Vec<u64> = o
            .missing_ranges()
            .into_iter()
            .flat_map(|(from, n)| from..from + n)
            .collect();
        assert_eq!((o.have(), o.want()), (have, want));
        assert_eq!(from_ranges, missing);
    }

    /// One part of a position in the generated streams below.
    #[derive(Clone, Debug)]
    struct Spec {
        message: usize,
        cont: bool,
        more: bool,
        bytes: Vec<u8>,
    }

    /// Lay messages (member = index % 30, `pieces` fragments each) out over positions
    /// as a gateway may: a head (MORE) is the last part of a position, which may also
    /// hold whole messages and the tail (CONT) of the message before; a middle piece
    /// is a position alone.
    fn lay_out(messages: &[(Vec<u8>, usize)], share: &[bool]) -> Vec<Vec<Spec>> {
        let mut positions: Vec<Vec<Spec>> = vec![Vec::new()];
        for (i, (bytes, pieces)) in messages.iter().enumerate() {
            let cuts: Vec<&[u8]> = bytes.chunks(bytes.len().div_ceil(*pieces).max(1)).collect();
            for (k, chunk) in cuts.iter().enumerate() {
                let (cont, more) = (k > 0, k + 1 < cuts.len());
                let open = positions
                    .last()
                    .is_some_and(|p| p.last().is_none_or(|s| !s.more));
                if cont || !open || !share[i] {
                    positions.push(Vec::new());
                }
                let spec = Spec {
                    message: i,
                    cont,
                    more,
                    bytes: chunk.to_vec(),
                };
                if let Some(p) = positions.last_mut() {
                    p.push(spec);
                }
            }
        }
        positions.retain(|p| !p.is_empty());
        positions
    }

    /// Deliver the positions in `order`, skipping the `lost` ones; the messages out,
    /// by index, in the order they came whole.
    fn deliver(positions: &[Vec<Spec>], order: &[usize], lost: &[bool]) -> Vec<(usize, Vec<u8>)> {
        let mut o = Outer::new(TAG, WINDOW_SPAN);
        let mut out = Vec::new();
        for &at in order.iter().filter(|&&at| !lost[at]) {
            let seq = at as u64 + 1;
            assert!(matches!(o.receive(TAG, seq, T0), Heard::Fresh(_)));
            for s in &positions[at] {
                let member = (s.message % 30) as u8;
                let whole = if s.cont || s.more {
                    o.fragment(seq, part(member, s.cont, s.more, &s.bytes))
                        .map(|m| m.bytes)
                } else {
                    Some(s.bytes.clone())
                };
                out.extend(whole.map(|b| (s.message, b)));
            }
        }
        out
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]

        #[test]
        fn the_window_agrees_with_a_set(seqs in prop::collection::vec(1u64..=600, 0..400)) {
            check_against_a_set(&seqs);
        }

        /// Every message all of whose positions arrive comes out once, whole, whatever
        /// the order; none with a lost position does.
        #[test]
        fn fragmented_messages_come_out_whole_once_in_any_order(
            messages in prop::collection::vec(
                (prop::collection::vec(any::<u8>(), 1..40), 1usize..5), 1..15),
            share in prop::collection::vec(any::<bool>(), 15),
            keys in prop::collection::vec(any::<u32>(), 80),
            lost in prop::collection::vec(prop::bool::weighted(0.1), 80),
        ) {
            let positions = lay_out(&messages, &share);
            let mut order: Vec<usize> = (0..positions.len()).collect();
            order.sort_by_key(|&at| keys[at]);
            let got = deliver(&positions, &order, &lost);
            let arrived = |m: usize| positions.iter().enumerate()
                .all(|(at, p)| !lost[at] || p.iter().all(|s| s.message != m));
            let mut expected: Vec<usize> = (0..messages.len()).filter(|&m| arrived(m)).collect();
            let mut indices: Vec<usize> = got.iter().map(|(m, _)| *m).collect();
            indices.sort_unstable();
            expected.sort_unstable();
            prop_assert_eq!(indices, expected);
            for (m, bytes) in got {
                prop_assert_eq!(&bytes, &messages[m].0);
            }
        }

        #[test]
        fn any_arrivals_keep_the_invariants(
            ops in prop::collection::vec((0u8..4, 0u64..2_000, 0u64..100), 0..300),
        ) {
            let mut o = outer();
            for (i, (op, seq, n)) in ops.into_iter().enumerate() {
                let now = Duration::from_millis(i as u64);
                match op {
                    0 | 1 => { o.receive(TAG, seq, now); }
                    2 => { o.announce(TAG, seq, now); }
                    _ => o.cover(seq, n, now),
                }
                prop_assert!(o.want() >= o.have() && o.want() - o.have() <= WINDOW_SPAN);
                prop_assert!(o.missing() <= MAX_NACK);
                prop_assert_eq!(o.gap_since().is_some(), o.has_gap());
                let listed: u64 = o.missing_ranges().iter().map(|r| r.1).sum();
                prop_assert_eq!(listed, o.missing());
            }
        }
    }
}
