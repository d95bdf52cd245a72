//! A window of stream positions received ahead of a gap: one bit per position in a
//! fixed ring of `u128` words, so taking a position, testing one, or moving the bottom
//! of the window costs O(1) word operations whatever the window holds. The robot-stream
//! tracker of the team protocol (`team/outer.rs`) and a receiver's view of a peer's
//! stream (`stream.rs`) both keep their positions in one.

/// `u128` words in the window ring (128 bytes per stream).
pub(crate) const WINDOW_WORDS: usize = 8;
pub(crate) const WORD_BITS: u64 = u128::BITS as u64;

/// Positions in the ring.
const RING: u64 = WINDOW_WORDS as u64 * WORD_BITS;

/// How far above `have` a received position can be held. One word less than the ring,
/// so that the positions `have + 1 ..= have + WINDOW_SPAN` never share a word slot.
pub(crate) const WINDOW_SPAN: u64 = (WINDOW_WORDS as u64 - 1) * WORD_BITS;

/// The positions received above `have`, one bit each, in a ring of words indexed by
/// absolute position: position `p` is bit `p % 128` of word `(p / 128) % WINDOW_WORDS`.
/// Bits at or below `have` are always clear, so a word is free for reuse by the time
/// the window reaches it again.
#[derive(Debug, Default)]
pub(crate) struct Window {
    words: [u128; WINDOW_WORDS],
    /// How many bits are set.
    pub(crate) held: u64,
    /// Word operations done (reads and writes of a word, one each).
    pub(crate) ops: u64,
}

/// The word and bit of position `seq`.
fn slot(seq: u64) -> (usize, u32) {
    (
        (seq / WORD_BITS) as usize % WINDOW_WORDS,
        (seq % WORD_BITS) as u32,
    )
}

/// `len` bits from bit `from` (`from + len <= 128`).
fn bits(from: u32, len: u64) -> u128 {
    let ones = if len >= WORD_BITS {
        u128::MAX
    } else {
        (1u128 << len) - 1
    };
    ones << from
}

impl Window {
    pub(crate) fn contains(&mut self, seq: u64) -> bool {
        self.ops += 1;
        let (w, b) = slot(seq);
        self.words[w] >> b & 1 == 1
    }

    /// Set the bit of `seq` (not set before: the caller checked).
    pub(crate) fn insert(&mut self, seq: u64) {
        self.ops += 1;
        let (w, b) = slot(seq);
        self.words[w] |= 1 << b;
        self.held += 1;
    }

    /// Set the bits of `first ..= last` (within the window), counting those newly set.
    pub(crate) fn mark(&mut self, first: u64, last: u64) {
        self.each_word(first, last, |word, mask, held| {
            *held += u64::from((mask & !*word).count_ones());
            *word |= mask;
        });
    }

    /// Calls `f(word, mask, held)` for each word `first ..= last` touches, with the mask
    /// of the range's bits in it: one word operation per word.
    fn each_word(&mut self, first: u64, last: u64, mut f: impl FnMut(&mut u128, u128, &mut u64)) {
        let mut at = first;
        while at <= last {
            self.ops += 1;
            let (w, b) = slot(at);
            let len = (last - at + 1).min(WORD_BITS - u64::from(b));
            f(&mut self.words[w], bits(b, len), &mut self.held);
            at += len;
        }
    }

    /// Clear the run of set bits that starts at `next`, and say how long it was. One
    /// word operation per word the run touches.
    pub(crate) fn take_run(&mut self, next: u64) -> u64 {
        let mut taken = 0;
        loop {
            self.ops += 1;
            let (w, b) = slot(next + taken);
            // Shifted right, the top `b` bits are clear: the run ends within the word.
            let run = u64::from((self.words[w] >> b).trailing_ones());
            self.words[w] &= !bits(b, run);
            self.held -= run;
            taken += run;
            if run == 0 || u64::from(b) + run < WORD_BITS {
                return taken;
            }
        }
    }

    /// Clear the bits of `first ..= last` (positions given up), counting those that were
    /// set. At most one word operation per word of the ring, however long the range.
    pub(crate) fn forget(&mut self, first: u64, last: u64) {
        if last.saturating_sub(first) >= RING {
            self.clear();
            return;
        }
        self.each_word(first, last, |word, mask, held| {
            *held -= u64::from((mask & *word).count_ones());
            *word &= !mask;
        });
    }

    pub(crate) fn clear(&mut self) {
        self.ops += WINDOW_WORDS as u64;
        self.words = [0; WINDOW_WORDS];
        self.held = 0;
    }

    /// The runs of clear bits in `have + 1 ..= want`, as `(from, n)`.
    pub(crate) fn gaps(&self, have: u64, want: u64) -> Vec<(u64, u64)> {
        let mut out: Vec<(u64, u64)> = Vec::new();
        let mut at = have + 1;
        while at <= want {
            let (w, b) = slot(at);
            let here = self.words[w] >> b;
            let left = (WORD_BITS - u64::from(b)).min(want - at + 1);
            let held = u64::from(here.trailing_ones()).min(left);
            let len = if held > 0 {
                held
            } else {
                let missing = u64::from(here.trailing_zeros()).min(left);
                push_range(&mut out, at, missing);
                missing
            };
            at += len;
        }
        out
    }
}

/// Append `(from, n)`, joined to the last range when they touch (across a word).
fn push_range(out: &mut Vec<(u64, u64)>, from: u64, n: u64) {
    match out.last_mut() {
        Some((start, len)) if *start + *len == from => *len += n,
        _ => out.push((from, n)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn holding(positions: impl IntoIterator<Item = u64>) -> Window {
        let mut w = Window::default();
        positions.into_iter().for_each(|p| w.insert(p));
        w
    }

    #[test]
    fn forgetting_a_range_clears_only_its_bits_and_counts_them() {
        let mut w = holding([3, 5, 130, 200]);
        w.forget(4, 130);
        assert_eq!(w.held, 2);
        assert!(w.contains(3) && w.contains(200));
        assert!(!w.contains(5) && !w.contains(130));
    }

    #[test]
    fn forgetting_more_than_the_ring_clears_it_in_one_pass_per_word() {
        let mut w = holding([1, 600, 890]);
        let before = w.ops;
        w.forget(1, 1_000_000);
        assert_eq!(w.held, 0);
        assert!(w.ops - before <= WINDOW_WORDS as u64);
        assert!(!w.contains(600));
    }

    #[test]
    fn a_run_taken_from_the_bottom_stops_at_the_first_missing_position() {
        let mut w = holding(1..=300);
        w.insert(302);
        assert_eq!(w.take_run(1), 300);
        assert_eq!(w.held, 1);
        assert_eq!(w.gaps(300, 302), vec![(301, 1)]);
    }
}
