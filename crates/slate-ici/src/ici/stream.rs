//! Stream positions: what a receiver got of a source's numbered stream (reports and
//! lifecycle frames share one sequence per source and link kind).

use std::collections::BTreeSet;
use std::time::Duration;

/// A receiver's view of one source's stream.
#[derive(Debug, Default)]
pub(crate) struct Inbound {
    /// Every message up to this one was received (or covered by a catch-up).
    have: u64,
    /// Received out of order, above `have`.
    above: BTreeSet<u64>,
    /// The highest position known to exist (from messages and heartbeats).
    want: u64,
    /// Since when a gap has been open.
    gap_since: Option<Duration>,
}

impl Inbound {
    /// A message at `seq` arrived: true if it is new (not a duplicate).
    pub fn receive(&mut self, seq: u64, now: Duration) -> bool {
        if seq <= self.have {
            return false;
        }
        if seq == self.have + 1 && self.above.is_empty() {
            // In order, nothing pending: the common case, without touching the set.
            self.have = seq;
        } else if !self.above.insert(seq) {
            return false;
        }
        self.want = self.want.max(seq);
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
        self.have = self.have.max(seq);
        self.want = self.have.max(self.above.last().copied().unwrap_or(0));
        self.advance(now);
    }

    /// How long a gap has been open, if one is.
    pub fn gap_age(&self, now: Duration) -> Option<Duration> {
        self.gap_since.map(|t| now.saturating_sub(t))
    }

    /// Did messages after `seq` arrive before it (is `seq` late)? A position only
    /// announced by a heartbeat does not count.
    pub fn overtaken(&self, seq: u64) -> bool {
        self.above.last().is_some_and(|&after| after > seq)
    }

    /// Is anything missing?
    pub fn has_gap(&self) -> bool {
        self.have < self.want
    }

    /// The position up to which everything arrived.
    pub fn have(&self) -> u64 {
        self.have
    }

    fn advance(&mut self, now: Duration) {
        while self.above.remove(&(self.have + 1)) {
            self.have += 1;
        }
        self.above.retain(|s| *s > self.have);
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
