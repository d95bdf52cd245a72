//! The NACK scheduler of the team protocol (docs/team-protocol.md, 2.5), both ends.
//!
//! * [`NackScheduler`], at a receiver: the missing positions of each robot stream, each
//!   range with its own timer. A range is NACKed at `detected + gap_grace + U(0,
//!   nack_backoff)`, suppressed when another robot's NACK for it is heard first, NACKed
//!   again after `repair_wait` while still missing, and given up for a state request
//!   after `max_nack_tries` rounds.
//! * [`RepairScheduler`], at the source gateway: NACKs for its own stream gathered for
//!   `repair_gather`, positions repaired within `repair_holdoff` ignored, the union of the
//!   rest asked for as one repair.
//!
//! Both are plain state machines: the caller feeds events with the current virtual time
//! (`now`, a `Duration` since the ICI's epoch, never read inside), calls `tick(now)`, and
//! polls the actions to carry out. Random back-offs come from a seeded [`Rng`] (the
//! simulator's xoshiro256**), so one seed replays one run.

use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;

use slate_transport::Rng;

pub(crate) use super::frame::StreamTag;

/// A non-empty, inclusive range of robot-stream positions. Positions start at 1, so a
/// range never holds 0 and its length always fits in a `u64`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub(crate) struct SeqRange {
    first: u64,
    last: u64,
}

/// Why a range read from a NACK entry (`from v | n v`) is not a range of positions.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub(crate) enum RangeError {
    /// `n` is 0: a range of no positions.
    #[error("a range of no positions")]
    Empty,
    /// `from` is 0: stream positions start at 1.
    #[error("position 0 does not exist")]
    Zero,
    /// `from + n - 1` does not fit in a `u64`.
    #[error("range runs past the last position")]
    Overflow,
}

impl SeqRange {
    /// The positions `first..=last`, or `None` if that is empty or holds position 0.
    pub fn new(first: u64, last: u64) -> Option<Self> {
        (first >= 1 && first <= last).then_some(SeqRange { first, last })
    }

    /// The single position `seq` (`None` for 0).
    pub fn one(seq: u64) -> Option<Self> {
        Self::new(seq, seq)
    }

    /// The wire form of a NACK entry: `n` positions from `from`.
    pub fn from_wire(from: u64, n: u64) -> Result<Self, RangeError> {
        match (from, n) {
            (0, _) => Err(RangeError::Zero),
            (_, 0) => Err(RangeError::Empty),
            _ => from
                .checked_add(n - 1)
                .map(|last| SeqRange { first: from, last })
                .ok_or(RangeError::Overflow),
        }
    }

    /// The first position.
    pub fn first(&self) -> u64 {
        self.first
    }

    /// The last position (inclusive).
    pub fn last(&self) -> u64 {
        self.last
    }

    /// How many positions (the wire form's `n`).
    pub fn n(&self) -> u64 {
        self.last - self.first + 1
    }

    /// The positions of `self` up to `last`, if any.
    fn up_to(self, last: u64) -> Option<Self> {
        Self::new(self.first, self.last.min(last))
    }
}

/// A set of positions held as disjoint ranges. Invariant: no two ranges overlap or touch
/// (`a.last + 1 < b.first`), so equal sets have equal forms and `len` counts the ranges a
/// NACK or repair would need.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Spans {
    /// First position → last position (inclusive) of each range.
    by_first: BTreeMap<u64, u64>,
}

impl Spans {
    /// Adds the positions of `range`, merging it with the ranges it overlaps or touches.
    pub fn insert(&mut self, range: SeqRange) {
        let (mut first, mut last) = (range.first, range.last);
        if let Some((&f, &l)) = self.by_first.range(..first).next_back()
            && l.saturating_add(1) >= first
        {
            first = f;
            last = last.max(l);
        }
        let absorbed: Vec<u64> = self
            .by_first
            .range(first..=last.saturating_add(1))
            .map(|(f, _)| *f)
            .collect();
        for f in absorbed {
            last = last.max(self.by_first.remove(&f).unwrap_or(last));
        }
        self.by_first.insert(first, last);
    }

    /// Removes the positions of `range`, splitting a range it cuts in two.
    pub fn remove(&mut self, range: SeqRange) {
        if let Some((&f, &l)) = self.by_first.range(..range.first).next_back()
            && l >= range.first
        {
            self.by_first.insert(f, range.first - 1);
            self.keep_tail(range.last, l);
        }
        let inside: Vec<u64> = self
            .by_first
            .range(range.first..=range.last)
            .map(|(f, _)| *f)
            .collect();
        for f in inside {
            let l = self.by_first.remove(&f).unwrap_or(f);
            self.keep_tail(range.last, l);
        }
    }

    /// Re-inserts `cut + 1 ..= last` when a removal up to `cut` left it.
    fn keep_tail(&mut self, cut: u64, last: u64) {
        if last > cut {
            self.by_first.insert(cut + 1, last);
        }
    }

    /// The ranges, in order.
    pub fn iter(&self) -> impl Iterator<Item = SeqRange> + '_ {
        self.by_first
            .iter()
            .map(|(&first, &last)| SeqRange { first, last })
    }

    /// How many ranges.
    pub fn len(&self) -> usize {
        self.by_first.len()
    }

    /// No position at all?
    pub fn is_empty(&self) -> bool {
        self.by_first.is_empty()
    }

    /// How many positions, saturating.
    pub fn positions(&self) -> u64 {
        self.iter().fold(0, |sum, r| sum.saturating_add(r.n()))
    }
}

// ----- the receiver -----

/// A receiver's timing and bounds (docs/team-protocol.md 2.5; step 7's `TeamProtocol`
/// carries the same knobs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct NackTiming {
    /// Wait after a gap is found before it may be NACKed: reordering fills most gaps.
    pub gap_grace: Duration,
    /// Upper bound of the random back-off `U(0, nack_backoff)` before each NACK: more
    /// than one way's delay plus a frame's airtime, so another robot's NACK for the
    /// same loss is heard first.
    pub nack_backoff: Duration,
    /// How long a NACK round (ours, or another robot's we heard) waits for the repair.
    pub repair_wait: Duration,
    /// NACK rounds for a range before it is given up for a state request.
    pub max_nack_tries: u32,
    /// The most positions of one stream that are NACKed: a stream missing more asks for
    /// state (a replay of a long history costs more than the current state).
    pub max_nack_frames: u64,
    /// The most pending ranges of one stream: past it, the stream asks for state. A
    /// `Nack` with this many entries (est. 5 B each) still fits one frame.
    pub max_ranges: usize,
}

impl NackTiming {
    /// The radio preset (9600 bit/s, about 100 ms one way).
    pub fn radio() -> Self {
        NackTiming {
            gap_grace: Duration::from_millis(100),
            nack_backoff: Duration::from_millis(300),
            repair_wait: Duration::from_secs(1),
            max_nack_tries: 3,
            max_nack_frames: 64,
            max_ranges: 16,
        }
    }

    /// The acoustic preset (32-byte frames, 1-2 s one way): at most 4 ranges, so a
    /// `Nack` fits one modem frame.
    pub fn acoustic() -> Self {
        NackTiming {
            gap_grace: Duration::from_secs(1),
            nack_backoff: Duration::from_secs(4),
            repair_wait: Duration::from_secs(10),
            max_ranges: 4,
            ..Self::radio()
        }
    }
}

/// One entry of a `Nack` to send: positions of stream `tag` this receiver lacks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct MissingRange {
    pub tag: StreamTag,
    pub range: SeqRange,
}

/// What a receiver's caller must do.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum NackAction {
    /// Publish one `Nack` (`what = frames`) with these entries, ordered by tag and
    /// position; adjacent ranges of one stream are merged.
    Nack(Vec<MissingRange>),
    /// Give up repairing stream `tag`: ask for its robot's members' state (2.6). Its
    /// positions up to `through` are no longer tracked here; the caller counts them as
    /// covered by the state answer (the robot stream's `have` moves past them).
    AskState { tag: StreamTag, through: u64 },
}

/// Where a pending range is in its NACK cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Our NACK goes out at `due`, unless another robot's is heard first.
    Backoff { due: Duration },
    /// A NACK round is on the air (ours, or another robot's we heard): the repair is
    /// awaited until `until`, and further NACKs heard for it are the same round.
    Awaiting { until: Duration },
}

/// A range of missing positions with its timer (the first position is the map key).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Pending {
    last: u64,
    phase: Phase,
    /// NACK rounds so far: our own NACKs and the suppressing ones heard from others.
    rounds: u32,
}

/// The back-offs drawn for re-armed rounds during one stream's tick.
struct Rearm<'a> {
    timing: &'a NackTiming,
    rng: &'a mut Rng,
    /// The last draw: the round's end and the NACK's new due time.
    last: Option<(Duration, Duration)>,
}

impl Rearm<'_> {
    /// The due time of a NACK re-armed when a round ended at `until`: drawn once per
    /// round end, so the ranges of one round stay together.
    fn due_after(&mut self, until: Duration) -> Duration {
        match self.last {
            Some((end, due)) if end == until => due,
            _ => {
                let due = until + self.rng.duration(self.timing.nack_backoff);
                self.last = Some((until, due));
                due
            }
        }
    }
}

/// What one pending range did on a tick.
enum Step {
    /// Nothing due yet.
    Idle,
    /// Its NACK goes out now.
    Fired,
    /// Out of rounds: the stream asks for state.
    GiveUp,
}

impl Pending {
    fn range(&self, first: u64) -> SeqRange {
        SeqRange {
            first,
            last: self.last,
        }
    }

    /// When this range next needs a tick.
    fn due(&self) -> Duration {
        match self.phase {
            Phase::Backoff { due } => due,
            Phase::Awaiting { until } => until,
        }
    }

    /// Same timer and rounds: two touching ranges in this state are one range.
    fn same_timer(&self, other: &Pending) -> bool {
        self.phase == other.phase && self.rounds == other.rounds
    }

    /// Runs the cycle up to `now`: a round that waited in vain either gives up or
    /// schedules the next NACK after a new back-off; a due back-off sends the NACK.
    /// Ranges of one round re-arm with one draw (`Rearm`), so they go out again in one
    /// NACK.
    fn advance(&mut self, now: Duration, draw: &mut Rearm<'_>) -> Step {
        if let Phase::Awaiting { until } = self.phase
            && until <= now
        {
            if self.rounds >= draw.timing.max_nack_tries {
                return Step::GiveUp;
            }
            self.phase = Phase::Backoff {
                due: draw.due_after(until),
            };
        }
        match self.phase {
            Phase::Backoff { due } if due <= now => {
                self.start_round(now, draw.timing.repair_wait);
                Step::Fired
            }
            _ => Step::Idle,
        }
    }

    /// A NACK for this range goes on the air at `now` (ours or another robot's).
    fn start_round(&mut self, now: Duration, repair_wait: Duration) {
        self.rounds += 1;
        self.phase = Phase::Awaiting {
            until: now + repair_wait,
        };
    }
}

/// The missing positions of one robot stream, as disjoint pending ranges.
#[derive(Debug, Default)]
struct Missing {
    by_first: BTreeMap<u64, Pending>,
}

impl Missing {
    /// Adds the positions of `range` not already pending, with a fresh timer due at `due`.
    fn add(&mut self, range: SeqRange, due: Duration) {
        for hole in self.holes(range).iter() {
            let phase = Phase::Backoff { due };
            let pending = Pending {
                last: hole.last,
                phase,
                rounds: 0,
            };
            self.by_first.insert(hole.first, pending);
        }
        self.coalesce();
    }

    /// The positions of `range` not pending yet.
    fn holes(&self, range: SeqRange) -> Spans {
        let mut holes = Spans::default();
        holes.insert(range);
        self.by_first
            .iter()
            .for_each(|(f, p)| holes.remove(p.range(*f)));
        holes
    }

    /// Positions of `range` were received: they are no longer missing.
    fn remove(&mut self, range: SeqRange) {
        self.isolate(range);
        let inside: Vec<u64> = self
            .by_first
            .range(range.first..=range.last)
            .map(|(f, _)| *f)
            .collect();
        inside.iter().for_each(|f| _ = self.by_first.remove(f));
    }

    /// Another robot NACKed `range`: its positions still waiting to be NACKed by us join
    /// that round instead. Positions already in a round stay in theirs.
    fn suppress(&mut self, range: SeqRange, now: Duration, repair_wait: Duration) {
        self.isolate(range);
        for p in self.by_first.range_mut(range.first..=range.last) {
            if let Phase::Backoff { .. } = p.1.phase {
                p.1.start_round(now, repair_wait);
            }
        }
        self.coalesce();
    }

    /// Runs every range's cycle up to `now`, adding the ranges NACKed now to `fired`.
    /// True if a range ran out of rounds, or the ranges past their grace are more than
    /// the timing's bounds: the stream is given up.
    fn tick(&mut self, now: Duration, draw: &mut Rearm<'_>, fired: &mut Spans) -> bool {
        let (ranges, positions) = self.matured(now);
        if ranges > draw.timing.max_ranges || positions > draw.timing.max_nack_frames {
            return true;
        }
        for (first, p) in self.by_first.iter_mut() {
            match p.advance(now, draw) {
                Step::Idle => {}
                Step::Fired => fired.insert(p.range(*first)),
                Step::GiveUp => return true,
            }
        }
        self.coalesce();
        false
    }

    /// Splits ranges so that none straddles `range`'s ends.
    fn isolate(&mut self, range: SeqRange) {
        self.split_at(range.first);
        if let Some(after) = range.last.checked_add(1) {
            self.split_at(after);
        }
    }

    /// Splits the range holding both `at - 1` and `at`, if one does.
    fn split_at(&mut self, at: u64) {
        let Some((&first, &p)) = self.by_first.range(..at).next_back() else {
            return;
        };
        if p.last >= at {
            self.by_first.insert(first, Pending { last: at - 1, ..p });
            self.by_first.insert(at, p);
        }
    }

    /// Merges touching ranges with the same timer, so splits do not accumulate.
    fn coalesce(&mut self) {
        let mut merged: BTreeMap<u64, Pending> = BTreeMap::new();
        for (first, p) in std::mem::take(&mut self.by_first) {
            match merged.last_entry() {
                Some(mut e) if e.get().last + 1 == first && e.get().same_timer(&p) => {
                    e.get_mut().last = p.last;
                }
                _ => _ = merged.insert(first, p),
            }
        }
        self.by_first = merged;
    }

    /// The ranges, and their positions, that are past their grace at `now`: due to be
    /// NACKed, or in a round. Younger holes may still be filled by reordering.
    fn matured(&self, now: Duration) -> (usize, u64) {
        let old = self.by_first.iter().filter(|(_, p)| match p.phase {
            Phase::Backoff { due } => due <= now,
            Phase::Awaiting { .. } => true,
        });
        old.fold((0, 0), |(n, sum), (f, p)| {
            (n + 1, sum.saturating_add(p.range(*f).n()))
        })
    }

    fn positions(&self) -> u64 {
        self.by_first
            .iter()
            .fold(0, |sum, (f, p)| sum.saturating_add(p.range(*f).n()))
    }

    fn last(&self) -> u64 {
        self.by_first.last_key_value().map_or(0, |(_, p)| p.last)
    }

    fn next_due(&self) -> Option<Duration> {
        self.by_first.values().map(Pending::due).min()
    }
}

/// How many times the timing's bounds (`max_ranges`, `max_nack_frames`) a stream may
/// hold while its holes are within their grace.
const HOLD_FACTOR: usize = 4;

/// A receiver's NACK scheduler: which positions of which robot streams it lacks, when
/// to NACK them, and when to give up for a state request.
///
/// Bounds: per stream at most `max_ranges` ranges and `max_nack_frames` positions past
/// their grace, and `HOLD_FACTOR` times as many in all (past either, the stream asks
/// for state and is dropped); the number of streams is
/// that of the caller's robot streams with a gap (at most one per tag). The outbox holds
/// at most one range set and one state request per stream.
#[derive(Debug)]
pub(crate) struct NackScheduler {
    timing: NackTiming,
    /// The back-off draws; seeded by the caller, so one seed gives one schedule.
    rng: Rng,
    /// Streams with missing positions; a stream with none is removed.
    streams: BTreeMap<StreamTag, Missing>,
    /// NACK entries fired and not yet polled.
    nack_out: BTreeMap<StreamTag, Spans>,
    /// State requests not yet polled: the stream and the last position given up.
    state_out: BTreeMap<StreamTag, u64>,
}

impl NackScheduler {
    /// A scheduler with nothing missing.
    pub fn new(timing: NackTiming, rng: Rng) -> Self {
        NackScheduler {
            timing,
            rng,
            streams: BTreeMap::new(),
            nack_out: BTreeMap::new(),
            state_out: BTreeMap::new(),
        }
    }

    /// The robot stream `tag` lacks `missing` (found at `now` by the stream tracker, or
    /// wanted by a member). Positions already pending keep their timers; the others are
    /// NACKed at `now + gap_grace + U(0, nack_backoff)`.
    pub fn gap_found(&mut self, tag: StreamTag, missing: SeqRange, now: Duration) {
        let stream = self.streams.entry(tag).or_default();
        if !stream.holes(missing).is_empty() {
            let due = now + self.timing.gap_grace + self.rng.duration(self.timing.nack_backoff);
            stream.add(missing, due);
        }
        self.enforce_bounds(tag);
    }

    /// Another robot's NACK for `range` of stream `tag` was heard at `now`: our own NACK
    /// for those positions is suppressed (taken out of the outbox if not yet polled),
    /// and they wait `repair_wait` for the repair before a new back-off.
    pub fn nack_heard(&mut self, tag: StreamTag, range: SeqRange, now: Duration) {
        let Some(stream) = self.streams.get_mut(&tag) else {
            return;
        };
        stream.suppress(range, now, self.timing.repair_wait);
        self.withdraw(tag, range);
        self.enforce_bounds(tag);
    }

    /// Positions `range` of stream `tag` arrived (the original, late, or a repair): they
    /// are no longer NACKed.
    pub fn received(&mut self, tag: StreamTag, range: SeqRange) {
        self.withdraw(tag, range);
        let Some(stream) = self.streams.get_mut(&tag) else {
            return;
        };
        stream.remove(range);
        self.enforce_bounds(tag);
    }

    /// Stream `tag` ended (a new epoch of its robot, the robot dead, or state asked for
    /// by the caller): everything about it is dropped, queued actions included.
    pub fn forget(&mut self, tag: StreamTag) {
        self.streams.remove(&tag);
        self.nack_out.remove(&tag);
        self.state_out.remove(&tag);
    }

    /// Runs every timer due at `now`: fires NACKs, re-arms rounds that waited in vain,
    /// gives up streams out of rounds.
    pub fn tick(&mut self, now: Duration) {
        if self.next_due().is_none_or(|due| due > now) {
            return;
        }
        let mut given_up = Vec::new();
        for (tag, stream) in &mut self.streams {
            let fired = self.nack_out.entry(*tag).or_default();
            let mut draw = Rearm {
                timing: &self.timing,
                rng: &mut self.rng,
                last: None,
            };
            if stream.tick(now, &mut draw, fired) {
                given_up.push(*tag);
            }
        }
        self.nack_out.retain(|_, s| !s.is_empty());
        given_up.into_iter().for_each(|tag| self.ask_state(tag));
    }

    /// The earliest time a `tick` has something to do, if any: the caller may sleep
    /// until then.
    pub fn next_due(&self) -> Option<Duration> {
        self.streams.values().filter_map(Missing::next_due).min()
    }

    /// Has a `tick` fired something not polled yet?
    pub fn has_output(&self) -> bool {
        !self.nack_out.is_empty() || !self.state_out.is_empty()
    }

    /// The next action to carry out: state requests first, then one `Nack` holding
    /// every entry fired since the last poll.
    pub fn poll(&mut self) -> Option<NackAction> {
        if let Some((tag, through)) = self.state_out.pop_first() {
            return Some(NackAction::AskState { tag, through });
        }
        let entries: Vec<MissingRange> = std::mem::take(&mut self.nack_out)
            .into_iter()
            .flat_map(|(tag, spans)| {
                let ranges: Vec<SeqRange> = spans.iter().collect();
                ranges
                    .into_iter()
                    .map(move |range| MissingRange { tag, range })
            })
            .collect();
        (!entries.is_empty()).then_some(NackAction::Nack(entries))
    }

    /// A back-off `U(0, max)` from this scheduler's seeded draws (the hello NACK's,
    /// so that one seed gives one schedule for hellos too).
    pub fn draw(&mut self, max: Duration) -> Duration {
        self.rng.duration(max)
    }

    /// The positions of stream `tag` still missing (pending or awaiting a repair).
    pub fn missing(&self, tag: StreamTag) -> Spans {
        let mut spans = Spans::default();
        if let Some(stream) = self.streams.get(&tag) {
            stream
                .by_first
                .iter()
                .for_each(|(f, p)| spans.insert(p.range(*f)));
        }
        spans
    }

    /// Takes `range` of stream `tag` out of the unpolled NACK entries.
    fn withdraw(&mut self, tag: StreamTag, range: SeqRange) {
        if let Some(out) = self.nack_out.get_mut(&tag) {
            out.remove(range);
            if out.is_empty() {
                self.nack_out.remove(&tag);
            }
        }
    }

    /// Drops a stream left with nothing missing, and gives up one past the memory
    /// bounds (`HOLD_FACTOR` times the timing's). The timing's own bounds apply once
    /// the holes are past their grace (`Missing::tick`): holes a burst of reordered
    /// frames opens for a moment are no reason to ask for state.
    fn enforce_bounds(&mut self, tag: StreamTag) {
        let Some(stream) = self.streams.get(&tag) else {
            return;
        };
        let factor = HOLD_FACTOR as u64;
        if stream.by_first.is_empty() {
            self.streams.remove(&tag);
        } else if stream.by_first.len() > self.timing.max_ranges.saturating_mul(HOLD_FACTOR)
            || stream.positions() > self.timing.max_nack_frames.saturating_mul(factor)
        {
            self.ask_state(tag);
        }
    }

    /// Gives up stream `tag`: its NACKs are dropped and a state request is queued.
    fn ask_state(&mut self, tag: StreamTag) {
        let Some(stream) = self.streams.remove(&tag) else {
            return;
        };
        self.nack_out.remove(&tag);
        let through = self.state_out.entry(tag).or_default();
        *through = (*through).max(stream.last());
    }
}

// ----- the source gateway -----

/// The source gateway's repair timing and bounds (docs/team-protocol.md 2.5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct RepairTiming {
    /// How long NACKs are gathered, from the first, before one repair of their union.
    pub repair_gather: Duration,
    /// Positions repaired this recently are not repaired again: the NACKs still coming
    /// for them were sent before the repair was heard (NORM's holdoff).
    pub repair_holdoff: Duration,
    /// The most ranges one repair gathers: a NACK entry that would add more is dropped
    /// (its sender NACKs again after `repair_wait`).
    pub max_ranges: usize,
    /// The most positions one repair gathers, likewise. Receivers NACK at most
    /// `max_nack_frames` positions a stream, so this allows a few receivers' worth.
    pub max_positions: u64,
    /// The most repaired ranges remembered for the holdoff, oldest forgotten first:
    /// forgetting one early costs at worst one repair too many.
    pub max_recent: usize,
}

impl RepairTiming {
    /// The radio preset.
    pub fn radio() -> Self {
        RepairTiming {
            repair_gather: Duration::from_millis(50),
            repair_holdoff: Duration::from_millis(300),
            max_ranges: 32,
            max_positions: 256,
            max_recent: 64,
        }
    }

    /// The acoustic preset: longer windows, and a repair of at most 64 positions.
    pub fn acoustic() -> Self {
        RepairTiming {
            repair_gather: Duration::from_secs(1),
            repair_holdoff: Duration::from_secs(4),
            max_ranges: 8,
            max_positions: 64,
            max_recent: 16,
        }
    }
}

/// A source gateway's repair scheduler for its own robot stream: which positions were
/// NACKed, when to repair them, and which were repaired too recently to repeat.
///
/// Bounds: the gathered set holds at most `max_ranges` ranges and `max_positions`
/// positions, the holdoff memory at most `max_recent` ranges.
#[derive(Debug)]
pub(crate) struct RepairScheduler {
    timing: RepairTiming,
    /// Positions NACKed in the open gathering window.
    asked: Spans,
    /// When the open window closes (`None`: no window open, nothing asked).
    closes: Option<Duration>,
    /// Ranges repaired lately, oldest first, with the time their repair was handed out.
    recent: VecDeque<(Duration, SeqRange)>,
}

impl RepairScheduler {
    /// A scheduler with nothing asked.
    pub fn new(timing: RepairTiming) -> Self {
        RepairScheduler {
            timing,
            asked: Spans::default(),
            closes: None,
            recent: VecDeque::new(),
        }
    }

    /// A NACK entry for our stream asked for `range` at `now`; `head` is the last
    /// position we sent. Positions past `head` (never sent) and positions repaired
    /// within `repair_holdoff` are ignored; the rest join the gathering window, which
    /// the first of them opens.
    pub fn nack_heard(&mut self, range: SeqRange, head: u64, now: Duration) {
        self.forget_old(now);
        let Some(range) = range.up_to(head) else {
            return;
        };
        let mut wanted = Spans::default();
        wanted.insert(range);
        self.recent.iter().for_each(|(_, r)| wanted.remove(*r));
        wanted.iter().for_each(|r| self.gather(r));
        if !self.asked.is_empty() && self.closes.is_none() {
            self.closes = Some(now + self.timing.repair_gather);
        }
    }

    /// The repair due at `now`, if the gathering window has closed: the union of the
    /// positions asked, in order. They are then held off for `repair_holdoff`. The
    /// caller repairs each range from its history (or says `Gone` for what it lost).
    pub fn poll(&mut self, now: Duration) -> Option<Vec<SeqRange>> {
        if self.closes.is_none_or(|t| t > now) {
            return None;
        }
        self.closes = None;
        let repair: Vec<SeqRange> = std::mem::take(&mut self.asked).iter().collect();
        repair.iter().for_each(|r| self.remember(now, *r));
        Some(repair)
    }

    /// When `poll` next has a repair to give, if a window is open.
    pub fn next_due(&self) -> Option<Duration> {
        self.closes
    }

    /// Adds `range` to the window unless that would pass the window's bounds.
    fn gather(&mut self, range: SeqRange) {
        let mut next = self.asked.clone();
        next.insert(range);
        if next.len() <= self.timing.max_ranges && next.positions() <= self.timing.max_positions {
            self.asked = next;
        }
    }

    /// Holds `range` off from `now`, forgetting the oldest range past `max_recent`.
    fn remember(&mut self, now: Duration, range: SeqRange) {
        self.recent.push_back((now, range));
        while self.recent.len() > self.timing.max_recent {
            self.recent.pop_front();
        }
    }

    /// Forgets the repairs older than `repair_holdoff`.
    fn forget_old(&mut self, now: Duration) {
        let holdoff = self.timing.repair_holdoff;
        while self
            .recent
            .front()
            .is_some_and(|(at, _)| now.saturating_sub(*at) >= holdoff)
        {
            self.recent.pop_front();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use slate_transport::Rng;
    use std::collections::BTreeSet;

    fn r(first: u64, last: u64) -> SeqRange {
        SeqRange::new(first, last).expect("a test range")
    }

    fn spans(ranges: &[(u64, u64)]) -> Spans {
        let mut s = Spans::default();
        ranges.iter().for_each(|&(f, l)| s.insert(r(f, l)));
        s
    }

    fn listed(s: &Spans) -> Vec<(u64, u64)> {
        s.iter().map(|x| (x.first(), x.last())).collect()
    }

    // ----- ranges and spans -----

    #[test]
    fn a_wire_range_of_no_positions_at_zero_or_past_the_end_is_refused() {
        assert_eq!(SeqRange::from_wire(5, 0), Err(RangeError::Empty));
        assert_eq!(SeqRange::from_wire(0, 3), Err(RangeError::Zero));
        assert_eq!(SeqRange::from_wire(u64::MAX, 2), Err(RangeError::Overflow));
        assert_eq!(SeqRange::from_wire(u64::MAX, 1), Ok(r(u64::MAX, u64::MAX)));
        assert_eq!(
            SeqRange::from_wire(5, 3).map(|x| (x.last(), x.n())),
            Ok((7, 3))
        );
        assert!(SeqRange::new(4, 3).is_none() && SeqRange::one(0).is_none());
    }

    #[test]
    fn spans_merge_overlapping_and_touching_ranges() {
        let s = spans(&[(5, 7), (10, 12), (8, 9), (20, 21), (11, 22)]);
        assert_eq!(listed(&s), vec![(5, 22)]);
        let s = spans(&[(5, 7), (9, 9)]);
        assert_eq!(listed(&s), vec![(5, 7), (9, 9)], "a hole of one stays");
        assert_eq!((s.len(), s.positions()), (2, 4));
    }

    #[test]
    fn removing_the_middle_of_a_range_splits_it_and_removing_across_ranges_trims_them() {
        let mut s = spans(&[(5, 9)]);
        s.remove(r(7, 7));
        assert_eq!(listed(&s), vec![(5, 6), (8, 9)]);
        let mut s = spans(&[(1, 3), (5, 8), (10, 12)]);
        s.remove(r(2, 11));
        assert_eq!(listed(&s), vec![(1, 1), (12, 12)]);
        s.remove(r(1, 12));
        assert!(s.is_empty() && s.positions() == 0);
    }

    fn small_range() -> impl Strategy<Value = SeqRange> {
        (1u64..40, 0u64..8).prop_map(|(f, len)| r(f, f + len))
    }

    // ----- the receiver -----

    const TAG: StreamTag = StreamTag(0x5a17);
    const OTHER: StreamTag = StreamTag(0x0b0e);

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    fn receiver(seed: u64) -> NackScheduler {
        NackScheduler::new(NackTiming::radio(), Rng::new(seed))
    }

    fn entries(action: Option<NackAction>) -> Vec<(StreamTag, u64, u64)> {
        match action {
            Some(NackAction::Nack(e)) => e
                .iter()
                .map(|m| (m.tag, m.range.first(), m.range.last()))
                .collect(),
            other => panic!("expected a NACK, got {other:?}"),
        }
    }

    /// Ticks at each due time up to `end`, collecting what is polled, with its time.
    fn run_until(s: &mut NackScheduler, end: Duration) -> Vec<(Duration, NackAction)> {
        let mut out = Vec::new();
        while let Some(now) = s.next_due().filter(|t| *t <= end) {
            s.tick(now);
            while let Some(a) = s.poll() {
                out.push((now, a));
            }
        }
        out
    }

    #[test]
    fn a_gap_is_nacked_once_after_grace_and_a_bounded_backoff() {
        let mut s = receiver(1);
        s.gap_found(TAG, r(5, 5), ms(1000));
        let due = s.next_due().expect("a NACK is scheduled");
        assert!((ms(1100)..=ms(1400)).contains(&due), "{due:?}");
        s.tick(due - ms(1));
        assert_eq!(s.poll(), None, "not before its time");
        s.tick(due);
        assert_eq!(entries(s.poll()), vec![(TAG, 5, 5)]);
        assert_eq!(s.poll(), None, "one NACK");
        assert_eq!(
            s.next_due(),
            Some(due + ms(1000)),
            "then it awaits the repair"
        );
    }

    #[test]
    fn two_receivers_missing_one_frame_send_one_nack_between_them() {
        for seed in 0..50 {
            assert_eq!(nacks_among(&[seed, seed + 1000], r(9, 9)), 1, "seed {seed}");
        }
    }

    /// Several receivers lose `lost` at time 0; each NACK is heard by the others at
    /// once. How many NACKs go out before the first round's repair is due?
    fn nacks_among(seeds: &[u64], lost: SeqRange) -> usize {
        let mut all: Vec<NackScheduler> = seeds.iter().map(|s| receiver(*s)).collect();
        all.iter_mut().for_each(|s| s.gap_found(TAG, lost, ms(0)));
        let mut sent = 0;
        while let Some(now) = all.iter().filter_map(|s| s.next_due()).min() {
            if now >= ms(1000) {
                break;
            }
            for i in 0..all.len() {
                all[i].tick(now);
                while let Some(NackAction::Nack(e)) = all[i].poll() {
                    sent += 1;
                    let heard = |(j, s): (usize, &mut NackScheduler)| {
                        (j != i).then(|| e.iter().for_each(|m| s.nack_heard(m.tag, m.range, now)))
                    };
                    all.iter_mut().enumerate().for_each(|x| _ = heard(x));
                }
            }
        }
        sent
    }

    #[test]
    fn a_repair_heard_cancels_the_pending_nack() {
        let mut s = receiver(2);
        s.gap_found(TAG, r(5, 6), ms(0));
        s.received(TAG, r(5, 6));
        assert_eq!(s.next_due(), None);
        assert!(run_until(&mut s, ms(10_000)).is_empty());
        assert!(s.missing(TAG).is_empty());
    }

    #[test]
    fn a_repair_heard_after_our_nack_ends_the_round() {
        let mut s = receiver(3);
        s.gap_found(TAG, r(5, 5), ms(0));
        assert_eq!(run_until(&mut s, ms(500)).len(), 1);
        s.received(TAG, r(1, 10));
        assert!(
            run_until(&mut s, ms(10_000)).is_empty(),
            "no re-NACK, no state"
        );
    }

    #[test]
    fn the_original_arriving_late_takes_its_position_out_of_a_range() {
        let mut s = receiver(4);
        s.gap_found(TAG, r(5, 9), ms(0));
        s.received(TAG, r(7, 7));
        let got = run_until(&mut s, ms(500));
        assert_eq!(
            entries(got.into_iter().next().map(|x| x.1)),
            vec![(TAG, 5, 6), (TAG, 8, 9)]
        );
    }

    #[test]
    fn a_heard_nack_suppresses_ours_then_we_nack_after_repair_wait_and_a_new_backoff() {
        let mut s = receiver(5);
        s.gap_found(TAG, r(5, 5), ms(0));
        s.nack_heard(TAG, r(4, 6), ms(50));
        assert_eq!(s.next_due(), Some(ms(1050)), "waiting for the repair");
        assert!(run_until(&mut s, ms(1050)).is_empty());
        let due = s.next_due().expect("re-armed");
        assert!((ms(1050)..=ms(1350)).contains(&due), "{due:?}");
        let got = run_until(&mut s, ms(1350));
        assert_eq!(got.len(), 1);
        assert_eq!(
            entries(got.into_iter().next().map(|x| x.1)),
            vec![(TAG, 5, 5)]
        );
    }

    #[test]
    fn a_heard_nack_covering_part_of_a_range_splits_it() {
        let mut s = receiver(6);
        s.gap_found(TAG, r(5, 9), ms(0));
        s.nack_heard(TAG, r(7, 8), ms(10));
        let got = run_until(&mut s, ms(500));
        assert_eq!(
            entries(got.into_iter().next().map(|x| x.1)),
            vec![(TAG, 5, 6), (TAG, 9, 9)]
        );
        assert_eq!(
            listed(&s.missing(TAG)),
            vec![(5, 9)],
            "7-8 await the repair"
        );
    }

    #[test]
    fn a_nack_heard_for_another_stream_or_other_positions_changes_nothing() {
        let mut s = receiver(7);
        s.gap_found(TAG, r(5, 5), ms(0));
        let due = s.next_due();
        s.nack_heard(OTHER, r(5, 5), ms(10));
        s.nack_heard(TAG, r(6, 8), ms(10));
        s.received(OTHER, r(5, 5));
        assert_eq!(s.next_due(), due);
        assert!(s.missing(OTHER).is_empty());
    }

    #[test]
    fn a_fired_nack_not_yet_polled_is_withdrawn_when_another_robots_is_heard() {
        let mut s = receiver(8);
        s.gap_found(TAG, r(5, 5), ms(0));
        s.tick(ms(400));
        s.nack_heard(TAG, r(5, 5), ms(400));
        assert_eq!(s.poll(), None);
        assert_eq!(
            listed(&s.missing(TAG)),
            vec![(5, 5)],
            "still awaiting the repair"
        );
    }

    #[test]
    fn an_unanswered_nack_is_sent_again_after_repair_wait() {
        let mut s = receiver(9);
        s.gap_found(TAG, r(5, 5), ms(0));
        let got = run_until(&mut s, ms(2000));
        let times: Vec<Duration> = got.iter().map(|x| x.0).collect();
        assert_eq!(times.len(), 2, "{got:?}");
        let gap = times[1] - times[0];
        assert!((ms(1000)..=ms(1300)).contains(&gap), "{gap:?}");
    }

    #[test]
    fn after_three_unanswered_nacks_the_receiver_asks_for_state() {
        let mut s = receiver(10);
        s.gap_found(TAG, r(5, 8), ms(0));
        s.received(TAG, r(7, 7));
        let got = run_until(&mut s, ms(60_000));
        let nacks = got
            .iter()
            .filter(|x| matches!(x.1, NackAction::Nack(_)))
            .count();
        assert_eq!(nacks, 3, "{got:?}");
        let last = got.last().expect("actions");
        assert_eq!(
            last.1,
            NackAction::AskState {
                tag: TAG,
                through: 8
            }
        );
        assert!(
            last.0 >= got[2].0 + ms(1000),
            "after the third round's wait"
        );
        assert!(s.missing(TAG).is_empty() && s.next_due().is_none());
    }

    #[test]
    fn suppressed_rounds_count_toward_escalation() {
        let mut s = receiver(11);
        s.gap_found(TAG, r(5, 5), ms(0));
        let mut now = ms(10);
        for round in 1..=3 {
            s.nack_heard(TAG, r(5, 5), now);
            let until = now + ms(1000);
            assert_eq!(s.next_due(), Some(until), "round {round} awaits the repair");
            s.tick(until);
            if round < 3 {
                assert_eq!(s.poll(), None, "round {round}: our NACK is not due yet");
            }
            now = until;
        }
        let through = 5;
        assert_eq!(s.poll(), Some(NackAction::AskState { tag: TAG, through }));
    }

    #[test]
    fn ranges_found_at_different_times_go_out_in_one_nack_merged() {
        let mut s = receiver(12);
        s.gap_found(TAG, r(5, 6), ms(0));
        s.gap_found(TAG, r(7, 7), ms(20));
        s.gap_found(TAG, r(4, 7), ms(30));
        s.gap_found(OTHER, r(2, 2), ms(40));
        s.tick(ms(1000));
        assert_eq!(entries(s.poll()), vec![(OTHER, 2, 2), (TAG, 4, 7)]);
        assert_eq!(s.poll(), None);
    }

    /// A burst of frames reordered on the way (the demo's deck: the console's 66 frames
    /// within 40 ms of jitter) opens more holes than the cap for a moment; they are
    /// filled within the grace, so nothing is NACKed and no state is asked. Before, the
    /// cap was applied as the holes opened: every module of every robot asked for the
    /// console's whole state at start.
    #[test]
    fn holes_that_reordering_fills_within_the_grace_ask_for_nothing() {
        let mut s = NackScheduler::new(NackTiming::acoustic(), Rng::new(16));
        let holes = NackTiming::acoustic().max_ranges as u64 + 3;
        (1..=holes).for_each(|i| s.gap_found(TAG, r(2 * i, 2 * i), ms(i)));
        s.gap_found(TAG, r(100, 180), ms(20));
        assert_eq!(s.poll(), None, "not while reordering may fill them");
        (1..=holes).for_each(|i| s.received(TAG, r(2 * i, 2 * i)));
        s.received(TAG, r(100, 180));
        assert_eq!(run_until(&mut s, ms(120_000)), vec![]);
    }

    #[test]
    fn more_pending_ranges_than_the_cap_ask_for_state() {
        let mut s = receiver(13);
        let cap = NackTiming::radio().max_ranges as u64;
        (1..=cap).for_each(|i| s.gap_found(TAG, r(2 * i, 2 * i), ms(0)));
        assert_eq!(s.poll(), None, "at the cap");
        assert_eq!(s.missing(TAG).len() as u64, cap);
        s.gap_found(TAG, r(2 * cap + 2, 2 * cap + 2), ms(0));
        assert_eq!(s.poll(), None, "within the grace");
        s.tick(ms(400));
        let through = 2 * cap + 2;
        assert_eq!(s.poll(), Some(NackAction::AskState { tag: TAG, through }));
        assert!(s.missing(TAG).is_empty() && s.next_due().is_none());
    }

    #[test]
    fn holes_past_the_memory_bound_ask_for_state_at_once() {
        let mut s = receiver(17);
        let most = (NackTiming::radio().max_ranges * HOLD_FACTOR) as u64;
        (1..=most).for_each(|i| s.gap_found(TAG, r(2 * i, 2 * i), ms(0)));
        assert_eq!(s.poll(), None, "at the bound");
        s.gap_found(TAG, r(2 * most + 2, 2 * most + 2), ms(0));
        let through = 2 * most + 2;
        assert_eq!(s.poll(), Some(NackAction::AskState { tag: TAG, through }));
    }

    #[test]
    fn a_late_position_splitting_a_range_past_the_cap_asks_for_state() {
        let mut s = NackScheduler::new(
            NackTiming {
                max_ranges: 2,
                ..NackTiming::radio()
            },
            Rng::new(14),
        );
        s.gap_found(TAG, r(2, 2), ms(0));
        s.gap_found(TAG, r(4, 6), ms(0));
        s.received(TAG, r(5, 5));
        s.tick(ms(400));
        assert_eq!(
            s.poll(),
            Some(NackAction::AskState {
                tag: TAG,
                through: 6
            })
        );
    }

    #[test]
    fn a_gap_wider_than_max_nack_frames_asks_for_state_once_past_its_grace() {
        let mut s = receiver(15);
        s.gap_found(TAG, r(10, 73), ms(0));
        assert_eq!(s.poll(), None, "64 positions are NACKed");
        s.gap_found(TAG, r(74, 74), ms(0));
        assert_eq!(s.poll(), None, "within the grace");
        s.tick(ms(400));
        assert_eq!(
            s.poll(),
            Some(NackAction::AskState {
                tag: TAG,
                through: 74
            })
        );
        assert_eq!(s.poll(), None);
    }

    #[test]
    fn forgetting_a_stream_drops_its_ranges_and_queued_actions() {
        let mut s = receiver(16);
        s.gap_found(TAG, r(5, 5), ms(0));
        s.gap_found(OTHER, r(5, 5), ms(0));
        s.tick(ms(1000));
        s.forget(TAG);
        assert_eq!(entries(s.poll()), vec![(OTHER, 5, 5)]);
        assert!(s.missing(TAG).is_empty());
    }

    #[test]
    fn one_seed_gives_one_schedule() {
        let schedule = |seed| {
            let mut s = receiver(seed);
            (1..=5).for_each(|i| s.gap_found(TAG, r(3 * i, 3 * i), ms(10 * i)));
            run_until(&mut s, ms(60_000))
                .into_iter()
                .map(|x| x.0)
                .collect::<Vec<_>>()
        };
        assert_eq!(schedule(17), schedule(17));
        assert_ne!(schedule(17), schedule(18));
    }

    proptest! {
        #[test]
        fn receivers_missing_one_frame_send_one_nack_whatever_the_seeds(
            seed in any::<u64>(), receivers in 2usize..8
        ) {
            let seeds: Vec<u64> = (0..receivers as u64).map(|i| seed.wrapping_add(i)).collect();
            prop_assert_eq!(nacks_among(&seeds, r(3, 4)), 1);
        }
    }

    // ----- the source gateway -----

    fn source() -> RepairScheduler {
        RepairScheduler::new(RepairTiming::radio())
    }

    fn ranges(repair: Option<Vec<SeqRange>>) -> Vec<(u64, u64)> {
        let repair = repair.expect("a repair is due");
        repair.iter().map(|x| (x.first(), x.last())).collect()
    }

    #[test]
    fn nacks_heard_within_the_gather_window_make_one_repair_of_their_union() {
        let mut s = source();
        s.nack_heard(r(5, 6), 100, ms(0));
        s.nack_heard(r(6, 8), 100, ms(20));
        s.nack_heard(r(12, 12), 100, ms(40));
        assert_eq!(
            s.next_due(),
            Some(ms(50)),
            "the window opened with the first"
        );
        assert_eq!(s.poll(ms(49)), None);
        assert_eq!(ranges(s.poll(ms(50))), vec![(5, 8), (12, 12)]);
        assert_eq!(s.poll(ms(60)), None);
        assert_eq!(s.next_due(), None);
    }

    #[test]
    fn a_late_nack_within_the_holdoff_is_dropped() {
        let mut s = source();
        s.nack_heard(r(5, 5), 100, ms(0));
        assert_eq!(ranges(s.poll(ms(50))), vec![(5, 5)]);
        s.nack_heard(r(5, 5), 100, ms(200));
        assert_eq!(s.next_due(), None, "nothing asked");
        s.nack_heard(r(4, 6), 100, ms(340));
        assert_eq!(ranges(s.poll(ms(390))), vec![(4, 4), (6, 6)]);
    }

    #[test]
    fn a_nack_after_the_holdoff_is_repaired_again() {
        let mut s = source();
        s.nack_heard(r(5, 5), 100, ms(0));
        assert_eq!(ranges(s.poll(ms(50))), vec![(5, 5)]);
        s.nack_heard(r(5, 5), 100, ms(350));
        assert_eq!(ranges(s.poll(ms(400))), vec![(5, 5)]);
    }

    #[test]
    fn positions_past_the_head_are_not_repaired() {
        let mut s = source();
        s.nack_heard(r(11, 12), 10, ms(0));
        assert_eq!(s.next_due(), None);
        s.nack_heard(r(9, 20), 10, ms(0));
        assert_eq!(ranges(s.poll(ms(50))), vec![(9, 10)]);
    }

    #[test]
    fn the_gathered_repair_is_bounded_in_ranges_and_positions() {
        let mut s = source();
        let cap = RepairTiming::radio().max_ranges as u64;
        (1..=cap + 5).for_each(|i| s.nack_heard(r(2 * i, 2 * i), 1000, ms(0)));
        assert_eq!(s.poll(ms(50)).map(|v| v.len() as u64), Some(cap));
        s.nack_heard(r(1, 100_000), 1_000_000, ms(500));
        s.nack_heard(r(300, 300 + 255), 1_000_000, ms(500));
        assert_eq!(
            ranges(s.poll(ms(550))),
            vec![(300, 555)],
            "the huge one dropped"
        );
    }

    #[test]
    fn the_holdoff_memory_is_bounded_and_forgets_the_oldest_first() {
        let timing = RepairTiming {
            max_recent: 2,
            ..RepairTiming::radio()
        };
        let mut s = RepairScheduler::new(timing);
        for (i, at) in [(1, 0), (2, 50), (3, 100)] {
            s.nack_heard(r(i, i), 100, ms(at));
            assert_eq!(ranges(s.poll(ms(at + 50))), vec![(i, i)]);
        }
        s.nack_heard(r(1, 3), 100, ms(160));
        assert_eq!(ranges(s.poll(ms(210))), vec![(1, 1)], "2 and 3 held off");
    }

    proptest! {
        #[test]
        fn a_repair_holds_only_positions_asked_sent_and_not_just_repaired(
            nacks in proptest::collection::vec((0u64..2000, small_range()), 1..30)
        ) {
            let head = 30;
            let mut nacks = nacks;
            nacks.sort_by_key(|n| n.0);
            let mut s = source();
            let (mut asked, mut last_repair) = (BTreeSet::new(), BTreeMap::new());
            let mut check = |s: &mut RepairScheduler, now: Duration, asked: &mut BTreeSet<u64>| {
                let Some(repair) = s.poll(now) else { return Ok(()) };
                for p in repair.iter().flat_map(|x| x.first()..=x.last()) {
                    prop_assert!(p <= head && asked.contains(&p), "{p} not asked");
                    let held = last_repair.insert(p, now).is_some_and(|t| now - t < ms(300));
                    prop_assert!(!held, "{p} repaired twice within the holdoff");
                }
                asked.clear();
                Ok(())
            };
            for (at, range) in nacks {
                let now = ms(at);
                while let Some(due) = s.next_due().filter(|t| *t <= now) {
                    check(&mut s, due, &mut asked)?;
                }
                asked.extend(range.first()..=range.last());
                s.nack_heard(range, head, now);
            }
            while let Some(due) = s.next_due() {
                check(&mut s, due, &mut asked)?;
            }
        }
    }

    // ----- both ends -----

    /// What travels between the schedulers in `Team`.
    enum Heard {
        Nack(Vec<MissingRange>),
        Repair(Vec<SeqRange>),
    }

    /// Receivers of one source's stream and the source, on a link where everything
    /// takes `delay` to arrive; counts what is sent.
    struct Team {
        receivers: Vec<NackScheduler>,
        source: RepairScheduler,
        delay: Duration,
        air: Vec<(Duration, Heard)>,
        nacks: usize,
        repairs: usize,
    }

    impl Team {
        /// Delivers what has arrived by `now`.
        fn deliver(&mut self, now: Duration) {
            let (arrived, left) = std::mem::take(&mut self.air)
                .into_iter()
                .partition(|x| x.0 <= now);
            self.air = left;
            for (_, heard) in arrived {
                match heard {
                    Heard::Nack(e) => e.iter().for_each(|m| self.nack_heard(*m, now)),
                    Heard::Repair(rs) => rs
                        .iter()
                        .for_each(|x| self.receivers.iter_mut().for_each(|s| s.received(TAG, *x))),
                }
            }
        }

        fn nack_heard(&mut self, m: MissingRange, now: Duration) {
            self.source.nack_heard(m.range, 10, now);
            self.receivers
                .iter_mut()
                .for_each(|s| s.nack_heard(m.tag, m.range, now));
        }

        /// One step at `now`: each receiver in turn, then the source, each hearing what
        /// arrived before it acts (with no delay, what the previous one sent).
        fn step(&mut self, now: Duration) {
            for i in 0..self.receivers.len() {
                self.deliver(now);
                self.receivers[i].tick(now);
                while let Some(NackAction::Nack(e)) = self.receivers[i].poll() {
                    self.nacks += 1;
                    self.air.push((now + self.delay, Heard::Nack(e)));
                }
            }
            self.deliver(now);
            if let Some(repair) = self.source.poll(now) {
                self.repairs += 1;
                self.air.push((now + self.delay, Heard::Repair(repair)));
            }
        }
    }

    /// The receivers (one per seed) lose frame 7 at time 0; steps of 1 ms for 5 s.
    /// Returns the NACKs and repairs sent, and whether every receiver got the frame.
    fn one_loss_among(seeds: &[u64], delay: Duration) -> (usize, usize, bool) {
        let receivers = seeds.iter().map(|s| receiver(*s)).collect();
        let mut team = Team {
            receivers,
            source: source(),
            delay,
            air: Vec::new(),
            nacks: 0,
            repairs: 0,
        };
        team.receivers
            .iter_mut()
            .for_each(|s| s.gap_found(TAG, r(7, 7), ms(0)));
        (0..5000).for_each(|t| team.step(ms(t)));
        let healed = team.receivers.iter().all(|s| s.missing(TAG).is_empty());
        (team.nacks, team.repairs, healed)
    }

    #[test]
    fn one_loss_heard_by_many_receivers_costs_about_one_nack_and_one_repair() {
        for seed in 0..20 {
            let seeds: Vec<u64> = (0..8).map(|i| 100 * seed + i).collect();
            let (nacks, repairs, healed) = one_loss_among(&seeds, ms(0));
            assert_eq!(
                (nacks, repairs, healed),
                (1, 1, true),
                "seed {seed}, no delay"
            );
            let (nacks, repairs, healed) = one_loss_among(&seeds, ms(30));
            assert!(
                nacks <= 3 && repairs == 1 && healed,
                "seed {seed}: {nacks} NACKs, {repairs} repairs"
            );
        }
    }

    proptest! {
        #[test]
        fn spans_hold_exactly_the_positions_of_a_set(
            ops in proptest::collection::vec((any::<bool>(), small_range()), 0..40)
        ) {
            let (mut s, mut set) = (Spans::default(), BTreeSet::new());
            for (add, range) in ops {
                let positions = range.first()..=range.last();
                if add {
                    s.insert(range);
                    set.extend(positions);
                } else {
                    s.remove(range);
                    positions.for_each(|p| { set.remove(&p); });
                }
            }
            let held: BTreeSet<u64> = s.iter().flat_map(|x| x.first()..=x.last()).collect();
            prop_assert_eq!(&held, &set);
            let ranges: Vec<_> = s.iter().collect();
            prop_assert!(ranges.windows(2).all(|w| w[0].last() + 1 < w[1].first()));
            prop_assert_eq!(s.positions(), set.len() as u64);
        }
    }
}
