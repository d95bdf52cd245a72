//! The gateway's history of its robot stream (docs/team-protocol.md 2.3 item 4, 2.5):
//! the data frames it published, by position, kept for replay repairs, with the index
//! of which members' inner positions each frame carried (for `Gone` and for repairs by
//! difference). Bounded by bytes and by age; a position it no longer holds is "gone".
//!
//! One history per epoch of the stream: positions are pushed in order from 1, so the
//! positions held are always one contiguous run, and everything below it is gone.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Duration;

/// What one frame carried of one member: its inner positions `first ..= last`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Carried {
    pub member: u8,
    pub first: u64,
    pub last: u64,
}

/// Bytes charged against `history_bytes` for each `Carried` of the index, beside the
/// frames' own bytes, so that the index is bounded with them.
pub(crate) const CARRIED_COST: usize = std::mem::size_of::<Carried>();

/// The bounds of a history (`TeamProtocol::history_bytes`, `history_age`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct HistoryLimits {
    /// Frame bytes plus `CARRIED_COST` per index entry, all frames together.
    pub bytes: usize,
    /// A frame sent longer ago than this is dropped.
    pub age: Duration,
}

/// A frame that could not be taken into the history.
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub(crate) enum HistoryError {
    /// Not the next position of the stream: the history holds one contiguous run.
    #[error("position {got} pushed where {expected} was next")]
    OutOfOrder { expected: u64, got: u64 },
    /// Larger than the whole byte limit: it is not kept, and neither is anything
    /// before it (the run stays contiguous), so all of them are gone.
    #[error("a frame of {cost} bytes is more than the history's {limit}")]
    TooLarge { cost: usize, limit: usize },
}

/// What a history holds of a requested range.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct Lookup {
    /// The positions held, in order, with their frames.
    pub held: Vec<(u64, Arc<[u8]>)>,
    /// The part of the range no longer held, as `(from, n)`: what a `Gone` says.
    pub gone: Option<(u64, u64)>,
}

#[derive(Debug)]
struct Entry {
    seq: u64,
    frame: Arc<[u8]>,
    sent_at: Duration,
    carried: Box<[Carried]>,
}

impl Entry {
    /// What the entry counts against the byte limit.
    fn cost(&self) -> usize {
        self.frame.len() + self.carried.len() * CARRIED_COST
    }
}

/// The frames of one epoch of a robot stream, oldest first.
///
/// Invariants: the entries' positions are consecutive and end at `next - 1`; their
/// costs sum to `bytes`, which is at most `limits.bytes`.
#[derive(Debug)]
pub(crate) struct History {
    entries: VecDeque<Entry>,
    /// The position the next frame must have.
    next: u64,
    bytes: usize,
    limits: HistoryLimits,
}

impl History {
    /// An empty history of a new epoch, whose first frame is position 1.
    pub fn new(limits: HistoryLimits) -> History {
        History {
            entries: VecDeque::new(),
            next: 1,
            bytes: 0,
            limits,
        }
    }

    /// Keep the frame at `seq`, sent at `sent_at`, which carried the members' inner
    /// positions `carried` (`(member, inner_seq)` in frame order). Older frames are
    /// dropped to make room, and those past the age limit as of `sent_at`.
    pub fn push(
        &mut self,
        seq: u64,
        frame: Arc<[u8]>,
        sent_at: Duration,
        carried: &[(u8, u64)],
    ) -> Result<(), HistoryError> {
        if seq != self.next {
            return Err(HistoryError::OutOfOrder {
                expected: self.next,
                got: seq,
            });
        }
        self.next = seq + 1;
        let entry = Entry {
            seq,
            frame,
            sent_at,
            carried: compact(carried),
        };
        self.expire(sent_at);
        self.make_room(entry.cost())?;
        self.bytes += entry.cost();
        self.entries.push_back(entry);
        Ok(())
    }

    /// The frames held of `from .. from + n` as of `now`, and the part that is gone.
    /// Positions not sent yet (`>= next`) are in neither: a NACK for them is not this
    /// epoch's.
    pub fn get(&mut self, from: u64, n: u64, now: Duration) -> Lookup {
        self.expire(now);
        let end = from.saturating_add(n).min(self.next);
        let oldest = self.oldest();
        let held_from = from.max(oldest);
        let gone_to = end.min(oldest);
        Lookup {
            held: (held_from..end).map(|seq| self.frame_at(seq)).collect(),
            gone: (from.max(1) < gone_to).then(|| (from.max(1), gone_to - from.max(1))),
        }
    }

    /// The members' inner positions carried by the frames held in `from .. from + n`:
    /// per member (in member order), the first and last inner position seen there.
    pub fn carried(&self, from: u64, n: u64) -> Vec<Carried> {
        let end = from.saturating_add(n).min(self.next);
        let mut out: Vec<Carried> = Vec::new();
        for seq in from.max(self.oldest())..end {
            for c in self.entry(seq).carried.iter() {
                widen(&mut out, *c);
            }
        }
        out.sort_by_key(|c| c.member);
        out
    }

    /// The oldest position held (`next` when none is).
    pub fn oldest(&self) -> u64 {
        self.entries.front().map_or(self.next, |e| e.seq)
    }

    /// The position the next frame will have.
    pub fn next(&self) -> u64 {
        self.next
    }

    /// Bytes counted against the limit.
    pub fn bytes(&self) -> usize {
        self.bytes
    }

    /// How many frames are held.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Drop the frames sent more than `limits.age` before `now`.
    fn expire(&mut self, now: Duration) {
        while self
            .entries
            .front()
            .is_some_and(|e| now.saturating_sub(e.sent_at) > self.limits.age)
        {
            self.pop_oldest();
        }
    }

    /// Drop the oldest frames until `cost` more bytes fit; all of them, and an error,
    /// when it can never fit.
    fn make_room(&mut self, cost: usize) -> Result<(), HistoryError> {
        if cost > self.limits.bytes {
            while self.pop_oldest() {}
            return Err(HistoryError::TooLarge {
                cost,
                limit: self.limits.bytes,
            });
        }
        while self.bytes + cost > self.limits.bytes {
            self.pop_oldest();
        }
        Ok(())
    }

    fn pop_oldest(&mut self) -> bool {
        let Some(e) = self.entries.pop_front() else {
            return false;
        };
        self.bytes -= e.cost();
        true
    }

    /// The entry of a held position (`oldest() <= seq < next`).
    fn entry(&self, seq: u64) -> &Entry {
        &self.entries[(seq - self.oldest()) as usize]
    }

    fn frame_at(&self, seq: u64) -> (u64, Arc<[u8]>) {
        (seq, Arc::clone(&self.entry(seq).frame))
    }
}

/// `(member, inner_seq)` pairs as ranges: a member's consecutive inner positions in a
/// row make one `Carried`.
fn compact(carried: &[(u8, u64)]) -> Box<[Carried]> {
    let mut out: Vec<Carried> = Vec::new();
    for &(member, seq) in carried {
        match out.last_mut() {
            Some(c) if c.member == member && c.last.checked_add(1) == Some(seq) => c.last = seq,
            _ => out.push(Carried {
                member,
                first: seq,
                last: seq,
            }),
        }
    }
    out.into_boxed_slice()
}

/// Widen the member's entry in `out` to cover `c` (or add one).
fn widen(out: &mut Vec<Carried>, c: Carried) {
    match out.iter_mut().find(|o| o.member == c.member) {
        Some(o) => {
            o.first = o.first.min(c.first);
            o.last = o.last.max(c.last);
        }
        None => out.push(c),
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    const T0: Duration = Duration::ZERO;

    fn secs(s: u64) -> Duration {
        Duration::from_secs(s)
    }

    fn history(bytes: usize, age_secs: u64) -> History {
        History::new(HistoryLimits {
            bytes,
            age: secs(age_secs),
        })
    }

    fn frame(len: usize) -> Arc<[u8]> {
        vec![0xAB; len].into()
    }

    /// Push positions `1..=n`, `len` bytes each, sent one a second from `T0`.
    fn filled(h: &mut History, n: u64, len: usize) {
        for seq in 1..=n {
            h.push(seq, frame(len), secs(seq - 1), &[]).unwrap();
        }
    }

    /// A history of `bytes` holding positions 1 and 2 (10 bytes each), after a push of
    /// `len` bytes at `seq`: the history, and what the push returned.
    fn two_then_push(bytes: usize, seq: u64, len: usize) -> (History, Result<(), HistoryError>) {
        let mut h = history(bytes, 600);
        filled(&mut h, 2, 10);
        let pushed = h.push(seq, frame(len), T0, &[]);
        (h, pushed)
    }

    fn seqs(l: &Lookup) -> Vec<u64> {
        l.held.iter().map(|(s, _)| *s).collect()
    }

    #[test]
    fn a_range_held_whole_is_returned_in_order_with_nothing_gone() {
        let mut h = history(10_000, 60);
        filled(&mut h, 5, 100);
        let l = h.get(2, 3, secs(5));
        assert_eq!((seqs(&l), l.gone), (vec![2, 3, 4], None));
        assert_eq!(l.held[0].1.len(), 100);
    }

    #[test]
    fn the_oldest_frames_are_evicted_when_the_bytes_would_pass_the_limit() {
        let mut h = history(1_000, 600);
        filled(&mut h, 10, 300);
        assert_eq!((h.oldest(), h.len(), h.bytes()), (8, 3, 900));
        let l = h.get(5, 6, secs(10));
        assert_eq!((seqs(&l), l.gone), (vec![8, 9, 10], Some((5, 3))));
    }

    #[test]
    fn the_index_counts_against_the_byte_limit() {
        let mut h = history(2 * (100 + CARRIED_COST), 600);
        h.push(1, frame(100), T0, &[(0, 1)]).unwrap();
        h.push(2, frame(100), T0, &[(0, 2)]).unwrap();
        assert_eq!(h.len(), 2);
        h.push(3, frame(100), T0, &[(0, 3), (1, 1)]).unwrap();
        assert_eq!(
            (h.oldest(), h.len()),
            (3, 1),
            "two index entries took the room"
        );
    }

    #[test]
    fn frames_older_than_the_age_limit_are_evicted() {
        let mut h = history(1_000_000, 60);
        filled(&mut h, 3, 10);
        let l = h.get(1, 3, secs(61));
        assert_eq!(
            (seqs(&l), l.gone),
            (vec![2, 3], Some((1, 1))),
            "sent at 0 s"
        );
        h.push(4, frame(10), secs(200), &[]).unwrap();
        assert_eq!((h.oldest(), h.len()), (4, 1), "a push expires too");
    }

    #[test]
    fn a_frame_exactly_at_the_age_limit_is_still_held() {
        let mut h = history(1_000, 60);
        filled(&mut h, 1, 10);
        assert_eq!(h.get(1, 1, secs(60)).gone, None);
    }

    #[test]
    fn the_gone_range_is_the_requested_part_below_the_oldest_position_held() {
        let mut h = history(1_000, 600);
        filled(&mut h, 20, 100);
        assert_eq!(h.oldest(), 11);
        assert_eq!(h.get(3, 4, secs(20)).gone, Some((3, 4)), "all of it gone");
        let l = h.get(0, 12, secs(20));
        assert_eq!(
            (seqs(&l), l.gone),
            (vec![11], Some((1, 10))),
            "there is no 0"
        );
    }

    #[test]
    fn positions_not_sent_yet_are_neither_held_nor_gone() {
        let mut h = history(1_000, 600);
        filled(&mut h, 3, 10);
        let l = h.get(3, u64::MAX, secs(3));
        assert_eq!((seqs(&l), l.gone), (vec![3], None));
        assert_eq!(h.get(9, 2, secs(3)), Lookup::default());
    }

    #[test]
    fn a_position_out_of_order_is_refused() {
        let (h, err) = two_then_push(1_000, 5, 10);
        assert_eq!(
            err,
            Err(HistoryError::OutOfOrder {
                expected: 3,
                got: 5
            })
        );
        assert_eq!((h.next(), h.len()), (3, 2), "nothing changed");
    }

    #[test]
    fn a_frame_larger_than_the_limit_is_gone_with_everything_before_it() {
        let (mut h, err) = two_then_push(100, 3, 101);
        assert_eq!(
            err,
            Err(HistoryError::TooLarge {
                cost: 101,
                limit: 100
            })
        );
        assert_eq!((h.len(), h.bytes(), h.next()), (0, 0, 4));
        assert_eq!(h.get(1, 3, T0).gone, Some((1, 3)));
        h.push(4, frame(10), T0, &[]).unwrap();
        assert_eq!(seqs(&h.get(1, 4, T0)), vec![4]);
    }

    #[test]
    fn the_index_gives_each_members_inner_range_over_the_frames_held() {
        let mut h = history(10_000, 600);
        h.push(1, frame(10), T0, &[(2, 7), (0, 1), (0, 2)]).unwrap();
        h.push(2, frame(10), T0, &[(0, 3), (2, 8)]).unwrap();
        h.push(3, frame(10), T0, &[(5, 1)]).unwrap();
        let c = |member, first, last| Carried {
            member,
            first,
            last,
        };
        assert_eq!(h.carried(1, 2), vec![c(0, 1, 3), c(2, 7, 8)]);
        assert_eq!(h.carried(3, 100), vec![c(5, 1, 1)]);
        assert!(h.carried(4, 1).is_empty());
    }

    #[test]
    fn consecutive_inner_positions_of_a_member_make_one_index_entry() {
        let c = compact(&[(1, 4), (1, 5), (1, 6), (2, 1), (1, 7), (1, 9)]);
        let ranges: Vec<_> = c.iter().map(|c| (c.member, c.first, c.last)).collect();
        assert_eq!(ranges, vec![(1, 4, 6), (2, 1, 1), (1, 7, 7), (1, 9, 9)]);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// Whatever is pushed and asked, the bytes stay within the limit, the positions
        /// held are contiguous up to the last one pushed, and every position asked for
        /// is either held, gone, or not sent yet, once.
        #[test]
        fn the_limits_hold_and_a_range_splits_into_gone_and_held(
            frames in prop::collection::vec((0usize..400, 0u64..30, 0usize..4), 1..200),
            from in 0u64..250,
            n in 0u64..300,
        ) {
            let mut h = history(2_000, 100);
            let mut now = T0;
            for (i, (len, gap, parts)) in frames.iter().enumerate() {
                now += secs(*gap);
                let carried: Vec<(u8, u64)> = (0..*parts).map(|p| (p as u8, i as u64)).collect();
                let _ = h.push(i as u64 + 1, frame(*len), now, &carried);
                prop_assert!(h.bytes() <= 2_000);
                prop_assert_eq!(h.oldest() + h.len() as u64, h.next());
            }
            let l = h.get(from, n, now);
            let gone = l.gone.map_or(0, |g| g.1);
            let unsent = from.saturating_add(n).saturating_sub(h.next().max(from));
            let zero = u64::from(from == 0 && n > 0);
            prop_assert_eq!(gone + l.held.len() as u64 + unsent + zero, n);
            prop_assert!(l.held.windows(2).all(|w| w[1].0 == w[0].0 + 1));
        }
    }
}
