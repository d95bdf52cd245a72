//! The gateway's pacing (docs/team-protocol.md, 2.3): members' messages wait in the
//! gateway's queue, not in the radio's, and go into frames only as fast as a token
//! bucket at `rate_bps` allows. Control messages (hellos, heartbeats, NACKs) and repairs
//! do not wait: they are charged to the bucket as they go, so the data behind them
//! waits instead. The ICI thereby never offers the radio more than it can carry, a
//! repair overtakes every queued message, and the queue's length says how busy the
//! link is (state requests wait while it is not empty).
//!
//! Pure state fed with virtual time; `team/send.rs` moves messages from the queue into
//! the framer.

use std::collections::VecDeque;
use std::time::Duration;

use slate_model::Address;

/// Bits a bucket earns per second and may hold; `rate_bps` 0 never limits.
///
/// Invariant: `bits` never exceeds `depth` (it may be negative: sends that may not wait
/// are charged all the same, and data waits until the debt is paid).
#[derive(Clone, Debug)]
pub(crate) struct TokenBucket {
    rate_bps: u64,
    depth: i64,
    bits: i64,
    at: Duration,
    /// Bit-nanoseconds earned and not yet a whole bit (below `NANOS_PER_SEC`).
    carry: u128,
}

const NANOS_PER_SEC: u128 = 1_000_000_000;

impl TokenBucket {
    /// A full bucket at `now` earning `rate_bps`, holding at most `depth_bytes`.
    pub fn new(rate_bps: u32, depth_bytes: usize, now: Duration) -> TokenBucket {
        let depth = i64::try_from(depth_bytes.saturating_mul(8)).unwrap_or(i64::MAX);
        TokenBucket {
            rate_bps: u64::from(rate_bps),
            depth,
            bits: depth,
            at: now,
            carry: 0,
        }
    }

    /// A full bucket at `now` for a gateway of `protocol`: its `rate_bps`, one frame
    /// (`mtu`) deep.
    pub fn of(protocol: &crate::TeamProtocol, now: Duration) -> TokenBucket {
        TokenBucket::new(protocol.rate_bps, protocol.mtu, now)
    }

    /// May data go at `now` (no debt left)?
    pub fn ready(&mut self, now: Duration) -> bool {
        self.refill(now);
        self.rate_bps == 0 || self.bits >= 0
    }

    /// The earliest time at which [`ready`](Self::ready) holds if nothing is spent
    /// meanwhile (its last refill's time, if it holds already).
    pub fn ready_at(&self) -> Duration {
        if self.rate_bps == 0 || self.bits >= 0 {
            return self.at;
        }
        // Bit-nanoseconds still to earn; the carry is below a whole bit's.
        let owed = u128::from(self.bits.unsigned_abs()) * NANOS_PER_SEC - self.carry;
        let nanos = owed.div_ceil(u128::from(self.rate_bps));
        let wait = Duration::from_nanos(u64::try_from(nanos).unwrap_or(u64::MAX));
        self.at.saturating_add(wait)
    }

    /// Charges `bytes` sent at `now`.
    pub fn spend(&mut self, bytes: usize, now: Duration) {
        self.refill(now);
        let bits = i64::try_from(bytes.saturating_mul(8)).unwrap_or(i64::MAX);
        self.bits = self.bits.saturating_sub(bits);
    }

    /// Earns the bits of the time since the last call. The fraction of a bit left over
    /// is carried to the next call (at 70 bit/s a 10 ms tick earns 0.7 bits: rounded
    /// down every tick, a bucket asked that often never earned anything).
    fn refill(&mut self, now: Duration) {
        let elapsed = now.saturating_sub(self.at);
        self.at = self.at.max(now);
        let credit = elapsed.as_nanos() * u128::from(self.rate_bps) + self.carry;
        self.carry = credit % NANOS_PER_SEC;
        let earned = i64::try_from(credit / NANOS_PER_SEC).unwrap_or(i64::MAX);
        self.bits = self.bits.saturating_add(earned);
        if self.bits >= self.depth {
            (self.bits, self.carry) = (self.depth, 0);
        }
    }
}

/// A member's message waiting for the radio, with the inner position its member had
/// reached when it was handed over (told in the hello and full heartbeats only once
/// the message is framed: a receiver must never be told of a position still queued).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Queued {
    pub member: u8,
    /// Empty for a `Mark` (a position, no message).
    pub message: Vec<u8>,
    pub mark: Option<u64>,
    pub since: Duration,
    /// A part of the member's state answer.
    pub answer: bool,
}

/// A team message held until this module knows its gateway: its own (`from` is this
/// module; its mark is taken when it is routed), or a mate's uplink that came while this
/// module, which the mate's election chose, had not taken the role yet (the start-up
/// wait, 2.1).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Held {
    pub from: Address,
    pub message: Vec<u8>,
    pub mark: Option<u64>,
    /// A part of a state answer.
    pub answer: bool,
}

/// What a [`ByteQueue`] bounds: the bytes each entry holds.
pub(crate) trait ByteLen {
    fn byte_len(&self) -> usize;
}

impl ByteLen for Held {
    fn byte_len(&self) -> usize {
        self.message.len()
    }
}

impl ByteLen for Queued {
    fn byte_len(&self) -> usize {
        self.message.len()
    }
}

/// Messages in the order they came, at most `max` bytes of them: past it the oldest are
/// dropped, and counted by the caller. The gateway's queue for the radio ([`TxQueue`])
/// and a member's messages held until a gateway is known are both one.
///
/// Invariant: `bytes` is the sum of the entries' lengths and at most `max`, unless one
/// entry alone is larger.
#[derive(Debug)]
pub(crate) struct ByteQueue<T> {
    queue: VecDeque<T>,
    bytes: usize,
    max: usize,
}

/// The gateway's queue of members' messages, in the order they came (a member's
/// messages must keep their order: a later one may use a name an earlier one
/// announced).
pub(crate) type TxQueue = ByteQueue<Queued>;

impl<T> Default for ByteQueue<T> {
    /// An empty queue with no bound.
    fn default() -> Self {
        ByteQueue {
            queue: VecDeque::new(),
            bytes: 0,
            max: usize::MAX,
        }
    }
}

impl<T: ByteLen> ByteQueue<T> {
    /// An empty queue of at most `max` bytes.
    pub fn new(max: usize) -> ByteQueue<T> {
        ByteQueue {
            max,
            ..ByteQueue::default()
        }
    }

    /// Queues an entry; returns how many of the oldest were dropped to make room.
    pub fn push(&mut self, entry: T) -> u64 {
        self.bytes += entry.byte_len();
        self.queue.push_back(entry);
        let mut dropped = 0;
        while self.bytes > self.max && self.queue.len() > 1 {
            self.pop();
            dropped += 1;
        }
        dropped
    }

    /// The oldest entry.
    pub fn pop(&mut self) -> Option<T> {
        let entry = self.queue.pop_front()?;
        self.bytes -= entry.byte_len();
        Some(entry)
    }

    /// The bytes of the entries queued.
    pub fn bytes(&self) -> usize {
        self.bytes
    }

    pub fn len(&self) -> usize {
        self.queue.len()
    }

    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }

    /// The entries, oldest first.
    pub fn iter(&self) -> impl Iterator<Item = &T> {
        self.queue.iter()
    }

    /// Everything queued, oldest first.
    pub fn drain(&mut self) -> Vec<T> {
        self.bytes = 0;
        self.queue.drain(..).collect()
    }
}

impl TxQueue {
    /// Does a part of member `member`'s state answer wait here?
    pub fn holds_answer_of(&self, member: u8) -> bool {
        self.queue.iter().any(|q| q.answer && q.member == member)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn a_bucket_earns_its_rate_and_holds_no_more_than_its_depth() {
        let mut b = TokenBucket::new(8_000, 100, ms(0));
        b.spend(300, ms(0));
        assert!(!b.ready(ms(199)), "200 B of debt at 1 000 B/s");
        assert!(b.ready(ms(200)));
        assert!(b.ready(ms(10_000)));
        b.spend(101, ms(10_000));
        assert!(!b.ready(ms(10_000)), "no more than 100 B were held");
    }

    /// A gateway asks its bucket every tick (10 ms in the simulator). At the acoustic
    /// share of 70 bit/s a tick earns 0.7 bits: rounded down each time, the bucket never
    /// earned anything, and a gateway in debt never sent again (no repair, no data: the
    /// demo's robots went silent at sea).
    #[test]
    fn a_slow_bucket_asked_often_earns_its_rate() {
        let mut b = TokenBucket::new(70, 32, ms(0));
        b.spend(32 + 7, ms(0));
        let ready_at = (1..=2_000).map(|t| ms(t * 10)).find(|t| b.ready(*t));
        assert_eq!(ready_at, Some(ms(800)), "56 bits of debt at 70 bit/s");
    }

    /// The simulator runs a gateway's timers only from the instant its bucket says it
    /// is ready: one nanosecond later than the truth and data waits a clock move more,
    /// earlier and nothing is lost.
    #[test]
    fn a_bucket_says_the_first_instant_it_is_ready() {
        let mut b = TokenBucket::new(70, 32, ms(0));
        b.spend(32 + 7, ms(3));
        b.ready(ms(5)); // a refill that leaves a carry
        let at = b.ready_at();
        assert_eq!(at, ms(803), "56 bits of debt at 70 bit/s from 3 ms");
        assert!(!b.clone().ready(at - Duration::from_nanos(1)));
        assert!(b.clone().ready(at));
        let mut full = TokenBucket::new(70, 32, ms(9));
        assert_eq!(full.ready_at(), ms(9));
        assert!(full.ready(ms(9)));
    }

    #[test]
    fn a_rate_of_zero_never_limits() {
        let mut b = TokenBucket::new(0, 10, ms(0));
        b.spend(1_000_000, ms(0));
        assert!(b.ready(ms(0)));
    }

    fn queued(member: u8, len: usize, since: u64) -> Queued {
        Queued {
            member,
            message: vec![0; len],
            mark: None,
            since: ms(since),
            answer: false,
        }
    }

    #[test]
    fn a_full_queue_drops_its_oldest() {
        let mut q = TxQueue::new(100);
        let dropped: u64 = (0..4).map(|i| q.push(queued(i, 40, 0))).sum();
        assert_eq!((dropped, q.bytes()), (2, 80));
        assert_eq!(q.pop().map(|q| q.member), Some(2));
    }

    #[test]
    fn one_message_larger_than_the_queue_is_kept_alone() {
        let mut q = TxQueue::new(10);
        assert_eq!(q.push(queued(1, 40, 0)), 0);
        assert!(!q.is_empty());
    }
}
