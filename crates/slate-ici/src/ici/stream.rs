//! Stream positions: what a receiver got of a source's numbered stream (reports and
//! lifecycle frames share one sequence per source and link kind).
//!
//! A message costs the receiver O(1) word operations however many wait above a gap:
//! the positions received ahead of it sit in a bit window (`window.rs`), not a set
//! that is scanned. The window holds `WINDOW_SPAN` positions; when a message lands
//! beyond it, the lowest missing positions are given up (counted by `skipped`): their
//! content comes with the catch-up that the open gap asks for, which carries the
//! source's current state, so a receiver that falls behind gets the latest state, not
//! every update. A given-up message that arrives after all is refused as a duplicate.

use std::time::Duration;

use super::window::{WINDOW_SPAN, Window};

/// A receiver's view of one source's stream.
///
/// Invariants: every position `<= have` arrived, was covered by a catch-up, or was given
/// up (then `skipped >= ` it until a catch-up covers it); the window holds exactly the
/// positions received in `have + 1 ..= have + WINDOW_SPAN`; `top` is the highest
/// position received; `gap_since` is set exactly when [`has_gap`](Self::has_gap).
#[derive(Debug, Default)]
pub(crate) struct Inbound {
    /// Every message up to this one was received (or covered, or given up).
    have: u64,
    /// Received out of order, above `have`.
    window: Window,
    /// The highest position received (0: none).
    top: u64,
    /// The highest position known to exist (from messages and heartbeats).
    want: u64,
    /// The highest position given up without being received (0: none): only a catch-up
    /// at or beyond it closes the gap.
    skipped: u64,
    /// Since when a gap has been open.
    gap_since: Option<Duration>,
}

impl Inbound {
    /// A message at `seq` arrived: true if it is new (not a duplicate, not given up).
    pub fn receive(&mut self, seq: u64, now: Duration) -> bool {
        if self.held(seq) {
            return false;
        }
        self.top = self.top.max(seq);
        self.want = self.want.max(seq);
        if seq == self.have + 1 && self.window.held == 0 {
            // In order, nothing pending: the common case, without touching the window.
            self.have = seq;
        } else {
            self.give_up_below(seq);
            self.window.insert(seq);
        }
        self.advance(now);
        true
    }

    /// A heartbeat says the source is at `seq`.
    pub fn announce(&mut self, seq: u64, now: Duration) {
        self.want = self.want.max(seq);
        self.advance(now);
    }

    /// A catch-up answer brought the receiver up to date as of `seq`.
    /// The answer is the authority on where the stream is: a position announced beyond
    /// it and not received (a heartbeat of a previous incarnation, or one overtaking
    /// the answer) is forgotten; the next heartbeat announces it again if it is real.
    pub fn caught_up(&mut self, seq: u64, now: Duration) {
        self.jump_to(seq);
        if seq >= self.skipped {
            self.skipped = 0;
        }
        self.want = self.have.max(self.top);
        self.advance(now);
    }

    /// When the gap open now opened, if one is.
    pub fn gap_since(&self) -> Option<Duration> {
        self.gap_since
    }

    /// How long a gap has been open, if one is.
    pub fn gap_age(&self, now: Duration) -> Option<Duration> {
        self.gap_since.map(|t| now.saturating_sub(t))
    }

    /// Did messages after `seq` arrive before it (is `seq` late)? A position only
    /// announced by a heartbeat does not count.
    pub fn overtaken(&self, seq: u64) -> bool {
        self.top > self.have && self.top > seq
    }

    /// Is anything missing (including positions given up until a catch-up covers them)?
    pub fn has_gap(&self) -> bool {
        self.have < self.want || self.skipped > 0
    }

    /// The position up to which everything arrived (or was covered, or given up).
    pub fn have(&self) -> u64 {
        self.have
    }

    /// Word operations done on the window so far: the receiver's work, which the
    /// O(1)-per-message claim is about.
    #[cfg(test)]
    pub fn visited(&self) -> u64 {
        self.window.ops
    }

    /// Is `seq` a duplicate: at or below `have`, or in the window already? A position
    /// beyond the window is not looked up: its slot belongs to another position.
    fn held(&mut self, seq: u64) -> bool {
        seq <= self.have || (seq - self.have <= WINDOW_SPAN && self.window.contains(seq))
    }

    /// Make room for `seq` in the window: the positions more than `WINDOW_SPAN` below it
    /// are given up, to the catch-up.
    fn give_up_below(&mut self, seq: u64) {
        if seq - self.have > WINDOW_SPAN {
            let bottom = seq - WINDOW_SPAN;
            self.jump_to(bottom);
            self.skipped = self.skipped.max(bottom);
        }
    }

    /// `have` moves up to `seq` (if it is higher), clearing the window below it.
    fn jump_to(&mut self, seq: u64) {
        if seq > self.have {
            self.window.forget(self.have + 1, seq);
            self.have = seq;
        }
    }

    /// Move `have` over the run of positions received just above it, and keep
    /// `gap_since` in step.
    fn advance(&mut self, now: Duration) {
        if self.window.held > 0 {
            self.have += self.window.take_run(self.have + 1);
        }
        if !self.has_gap() {
            self.gap_since = None;
        } else if self.gap_since.is_none() {
            self.gap_since = Some(now);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T0: Duration = Duration::ZERO;

    #[test]
    fn in_order_messages_leave_no_gap() {
        let mut s = Inbound::default();
        assert!(s.receive(1, T0) && s.receive(2, T0));
        assert!(!s.has_gap());
        assert!(!s.receive(2, T0), "a duplicate");
        assert_eq!(s.have(), 2);
    }

    #[test]
    fn a_gap_opens_and_closes_when_the_missing_message_arrives() {
        let mut s = Inbound::default();
        s.receive(1, T0);
        s.receive(3, Duration::from_secs(1));
        assert!(s.has_gap());
        assert_eq!(
            s.gap_age(Duration::from_secs(3)),
            Some(Duration::from_secs(2))
        );
        assert!(s.receive(2, Duration::from_secs(4)));
        assert!(!s.has_gap() && s.gap_age(Duration::from_secs(5)).is_none());
        assert_eq!(s.have(), 3);
    }

    #[test]
    fn a_message_is_overtaken_by_later_ones_received_not_announced() {
        let mut s = Inbound::default();
        s.receive(1, T0);
        s.announce(3, T0);
        assert!(!s.overtaken(2), "a heartbeat's position is not a message");
        s.receive(3, T0);
        assert!(s.overtaken(2));
        s.receive(2, T0);
        assert!(!s.overtaken(4));
    }

    #[test]
    fn a_heartbeat_reveals_a_lost_tail_and_a_catch_up_closes_it() {
        let mut s = Inbound::default();
        s.receive(1, T0);
        s.announce(4, T0);
        assert!(s.has_gap());
        s.caught_up(4, T0);
        assert!(!s.has_gap());
        assert!(!s.receive(3, T0), "covered by the catch-up");
        assert!(s.receive(5, T0));
    }

    /// The work to take `n` messages above a gap at position 2 that stays open, once
    /// `backlog` messages wait above it already.
    fn cost_of_messages_after(backlog: u64, n: u64) -> u64 {
        let mut s = Inbound::default();
        s.receive(1, T0);
        let first = 3 + backlog;
        (3..first).for_each(|seq| assert!(s.receive(seq, T0)));
        let before = s.visited();
        (first..first + n).for_each(|seq| assert!(s.receive(seq, T0)));
        assert!(s.has_gap(), "position 2 never came");
        s.visited() - before
    }

    #[test]
    fn a_receivers_cost_per_message_does_not_grow_with_the_backlog() {
        let short = cost_of_messages_after(10, 1_000);
        let long = cost_of_messages_after(20_000, 1_000);
        assert!(
            long <= short,
            "1000 messages cost {short} behind a backlog of 10, {long} behind 20000"
        );
    }

    #[test]
    fn a_gap_left_behind_the_window_stays_open_until_a_catch_up_covers_it() {
        let mut s = Inbound::default();
        s.receive(1, T0);
        let far = 2 + WINDOW_SPAN;
        (3..=far).for_each(|seq| assert!(s.receive(seq, Duration::from_secs(1))));
        assert_eq!(s.have(), far, "position 2 was given up, the rest taken");
        assert!(s.has_gap(), "until a catch-up brings what 2 held");
        assert_eq!(
            s.gap_age(Duration::from_secs(4)),
            Some(Duration::from_secs(3)),
            "the gap is as old as position 2's absence"
        );
        assert!(
            !s.receive(2, T0),
            "given up: the catch-up brings its content"
        );
        s.caught_up(1, T0);
        assert!(s.has_gap(), "an answer older than the given-up position");
        s.caught_up(2, T0);
        assert!(!s.has_gap());
        assert!(s.receive(far + 1, T0));
    }

    #[test]
    fn a_catch_up_answer_overrides_a_stale_announcement() {
        let mut s = Inbound::default();
        s.announce(9, T0);
        s.receive(7, T0);
        s.caught_up(5, T0);
        assert!(s.has_gap(), "7 arrived, 6 is missing");
        s.receive(6, T0);
        assert!(!s.has_gap(), "the answer said 5: the 9 was stale");
        assert_eq!(s.have(), 7);
    }
}
