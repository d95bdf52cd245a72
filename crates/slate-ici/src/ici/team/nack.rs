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

use std::collections::BTreeMap;

/// A robot stream's tag (docs/team-protocol.md 2.2): one epoch of one robot's stream.
pub(crate) type StreamTag = u16;

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

    /// The parts of the set inside `range`, in order.
    pub fn within(&self, range: SeqRange) -> impl Iterator<Item = SeqRange> + '_ {
        let before = self.by_first.range(..range.first).next_back();
        let from = before.filter(|(_, l)| **l >= range.first).map(|(f, _)| *f);
        let start = from.unwrap_or(range.first);
        self.by_first
            .range(start..=range.last)
            .filter_map(move |(&f, &l)| SeqRange::new(f.max(range.first), l.min(range.last)))
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

    /// The highest position, if any.
    pub fn last(&self) -> Option<u64> {
        self.by_first.last_key_value().map(|(_, l)| *l)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
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
        assert_eq!((s.len(), s.positions(), s.last()), (2, 4, Some(9)));
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
        assert!(s.is_empty() && s.last().is_none());
    }

    #[test]
    fn the_part_of_a_set_within_a_range_is_clipped_to_it() {
        let s = spans(&[(1, 3), (5, 8), (10, 12)]);
        let got: Vec<_> = s.within(r(2, 10)).map(|x| (x.first(), x.last())).collect();
        assert_eq!(got, vec![(2, 3), (5, 8), (10, 10)]);
        assert_eq!(s.within(r(4, 4)).count(), 0);
    }

    fn small_range() -> impl Strategy<Value = SeqRange> {
        (1u64..40, 0u64..8).prop_map(|(f, len)| r(f, f + len))
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
