//! Hybrid logical clock: physical time in the high bits, a logical counter in the low bits.
//!
//! A [`Timestamp`] is a `u64`: microseconds since the Unix epoch in the high 52 bits
//! (enough until the year 2112) and a logical counter in the low [`LOGICAL_BITS`] bits.
//! [`Clock::now`] never returns the same or a smaller timestamp twice, and
//! [`Clock::observe`] merges timestamps received from other boards so that a packet
//! stamped after receiving another always orders after it, even when the two robots'
//! wall clocks disagree.

use std::fmt;
use std::sync::{Arc, Weak};

use parking_lot::Mutex;

use crate::Wake;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

/// Bits of a timestamp used by the logical counter.
pub const LOGICAL_BITS: u32 = 12;
const LOGICAL_MASK: u64 = (1 << LOGICAL_BITS) - 1;

/// Default limit on how far ahead of local physical time a received timestamp may be.
pub const DEFAULT_MAX_DRIFT: Duration = Duration::from_millis(500);

/// A hybrid logical clock timestamp. `Timestamp::ZERO` means "never".
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Timestamp(u64);

impl Timestamp {
    /// The timestamp of packets that were never written.
    pub const ZERO: Timestamp = Timestamp(0);

    /// A timestamp from its raw 64-bit form.
    pub const fn from_raw(raw: u64) -> Self {
        Timestamp(raw)
    }

    /// The raw 64-bit form.
    pub const fn raw(self) -> u64 {
        self.0
    }

    /// A timestamp at a physical time (logical counter zero).
    #[inline]
    pub fn from_duration(since_epoch: Duration) -> Self {
        let micros = u64::try_from(since_epoch.as_micros()).unwrap_or(u64::MAX);
        Timestamp(micros.min(u64::MAX >> LOGICAL_BITS) << LOGICAL_BITS)
    }

    /// Physical part, as time since the Unix epoch.
    pub fn physical(self) -> Duration {
        Duration::from_micros(self.0 >> LOGICAL_BITS)
    }

    /// Logical counter part.
    pub fn logical(self) -> u64 {
        self.0 & LOGICAL_MASK
    }

    /// Seconds since the epoch as a float (for display and the language).
    pub fn as_secs_f64(self) -> f64 {
        self.physical().as_secs_f64()
    }
}

impl fmt::Display for Timestamp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:.6}+{}", self.as_secs_f64(), self.logical())
    }
}

/// A received timestamp was too far ahead of this board's physical clock to be merged.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("timestamp {remote} is {ahead:?} ahead of local time, more than the allowed {max:?}")]
pub struct ClockDriftError {
    /// The timestamp that was refused.
    pub remote: Timestamp,
    /// How far ahead of local physical time it was.
    pub ahead: Duration,
    /// The configured limit.
    pub max: Duration,
}

/// Error of [`Clock::advance`] and [`Clock::set`].
#[non_exhaustive]
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ClockError {
    /// Only a manual clock can be moved by hand.
    #[error("this is the system clock; only a manual clock (Clock::manual) can be advanced")]
    NotManual,
    /// Manual time never goes backwards.
    #[error("manual time cannot go backwards")]
    Backwards,
    /// A timestamp cannot hold a time that late.
    #[error(
        "a timestamp holds times up to {:.0} s since the Unix epoch (the year 2112); \
         the clock was left where it was",
        max.as_secs_f64()
    )]
    OutOfRange {
        /// The latest time a timestamp holds ([`MAX_TIME`]).
        max: Duration,
    },
}

/// The latest time since the Unix epoch a [`Timestamp`] holds (its physical bits full).
pub const MAX_TIME: Duration = Duration::from_micros(u64::MAX >> LOGICAL_BITS);

#[derive(Debug)]
enum Physical {
    System(WallClock),
    Manual(AtomicU64),
}

/// Wall-clock time read from the CPU's time-stamp counter (a few ns, where the system
/// call costs tens), re-anchored to the system clock every second so that it follows
/// NTP adjustments. Re-anchoring may move it back slightly; the HLC stays monotonic.
#[derive(Debug)]
struct WallClock {
    tsc: quanta::Clock,
    start: quanta::Instant,
    /// Wall time minus TSC time since `start`, in ns.
    offset: AtomicU64,
    /// TSC time since `start` (ns) after which to re-anchor.
    next_anchor: AtomicU64,
}

const ANCHOR_EVERY: u64 = 1_000_000_000;

/// The process's one calibrated TSC clock: calibrating one takes some 40 µs, which
/// every board on the system clock paid (a fifth to a third of a small `.slate` load's
/// time: the `slate_check` fuzz target's), for the same result. Clones share it.
fn shared_tsc() -> quanta::Clock {
    static TSC: std::sync::OnceLock<quanta::Clock> = std::sync::OnceLock::new();
    TSC.get_or_init(quanta::Clock::new).clone()
}

impl WallClock {
    fn new() -> Self {
        let tsc = shared_tsc();
        let start = tsc.now();
        let wall = WallClock {
            tsc,
            start,
            offset: AtomicU64::new(0),
            next_anchor: AtomicU64::new(0),
        };
        wall.anchor(0);
        wall
    }

    fn anchor(&self, mono: u64) {
        let wall = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap_or_default();
        let wall = u64::try_from(wall.as_nanos()).unwrap_or(u64::MAX);
        self.offset
            .store(wall.wrapping_sub(mono), Ordering::Release);
        self.next_anchor
            .store(mono.saturating_add(ANCHOR_EVERY), Ordering::Release);
    }

    #[inline]
    fn now(&self) -> Duration {
        let mono =
            u64::try_from(self.tsc.now().duration_since(self.start).as_nanos()).unwrap_or(u64::MAX);
        if mono >= self.next_anchor.load(Ordering::Acquire) {
            self.anchor(mono);
        }
        Duration::from_nanos(mono.wrapping_add(self.offset.load(Ordering::Acquire)))
    }
}

struct Inner {
    physical: Physical,
    last: AtomicU64,
    max_drift: Duration,
    listeners: Mutex<Listeners>,
}

/// A listener, and when it next has something to do if it said ([`Clock::subscribe_waking`]).
#[derive(Clone)]
struct Listener {
    listener: Weak<dyn ClockListener>,
    wake: Option<Arc<Wake>>,
}

/// A manual clock's listeners, in the order they subscribed: a list never changed in
/// place, replaced whole by a subscription. A move takes the list of the moment with one
/// lock hold and walks it without the lock (a lock and an unlock per listener told were
/// most of a move's cost in the simulator, where every event moves the clock); those
/// that subscribe meanwhile are in the next move's list, and those dropped meanwhile fail
/// to upgrade and are skipped.
#[derive(Default)]
struct Listeners {
    list: Arc<[Listener]>,
}

impl fmt::Debug for Inner {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Clock")
            .field("physical", &self.physical)
            .field("last", &self.last)
            .finish()
    }
}

/// Told when a manual clock moves, so that timers on it (plan deadlines) run at once.
/// The system clock never calls listeners: code on it runs its own timer.
pub trait ClockListener: Send + Sync {
    /// The manual clock now reads `now` (physical time since the Unix epoch).
    fn advanced(&self, now: Duration);
}

/// A hybrid logical clock over either the system clock or a manual clock that tests move.
///
/// Cloning gives another handle to the same clock.
///
/// ```
/// use slate_model::Clock;
/// use std::time::Duration;
/// let clock = Clock::manual();
/// let a = clock.now();
/// clock.advance(Duration::from_secs(2))?;
/// let b = clock.now();
/// assert!(b > a);
/// assert_eq!(clock.age(a), Duration::from_secs(2));
/// # Ok::<(), slate_model::ClockError>(())
/// ```
#[derive(Clone, Debug)]
pub struct Clock {
    inner: Arc<Inner>,
}

/// Where a manual clock starts: 2026-01-01T00:00:00Z, so timestamps look like real ones.
pub const MANUAL_EPOCH: Duration = Duration::from_secs(1_767_225_600);

impl Default for Clock {
    fn default() -> Self {
        Clock::system()
    }
}

impl Clock {
    /// A clock over the system's wall clock.
    pub fn system() -> Self {
        Self::with(Physical::System(WallClock::new()))
    }

    /// A clock that only moves when [`Clock::advance`] or [`Clock::set`] is called.
    pub fn manual() -> Self {
        Self::with(Physical::Manual(AtomicU64::new(
            MANUAL_EPOCH.as_nanos() as u64
        )))
    }

    fn with(physical: Physical) -> Self {
        Clock {
            inner: Arc::new(Inner {
                physical,
                last: AtomicU64::new(0),
                max_drift: DEFAULT_MAX_DRIFT,
                listeners: Mutex::default(),
            }),
        }
    }

    /// Is this a manual clock?
    pub fn is_manual(&self) -> bool {
        matches!(self.inner.physical, Physical::Manual(_))
    }

    /// Current physical time, as time since the Unix epoch.
    #[inline]
    pub fn physical(&self) -> Duration {
        match &self.inner.physical {
            Physical::System(wall) => wall.now(),
            Physical::Manual(n) => Duration::from_nanos(n.load(Ordering::Acquire)),
        }
    }

    /// A new timestamp, greater than every timestamp this clock issued or observed.
    #[inline]
    pub fn now(&self) -> Timestamp {
        let phys = Timestamp::from_duration(self.physical()).0;
        let prev = self
            .inner
            .last
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |last| {
                Some(next(last, phys))
            })
            .unwrap_or_else(|last| last);
        Timestamp(next(prev, phys))
    }

    /// Merges a timestamp received from another board, so that later [`Clock::now`]
    /// values order after it. Refuses timestamps too far in the future (a broken or
    /// unsynchronised clock elsewhere must not drag this one forward).
    pub fn observe(&self, remote: Timestamp) -> Result<(), ClockDriftError> {
        self.check(remote)?;
        self.inner.last.fetch_max(remote.0, Ordering::AcqRel);
        Ok(())
    }

    /// Is `stamp` within this clock's tolerance (not further ahead of its physical time
    /// than [`DEFAULT_MAX_DRIFT`])? Changes nothing: [`Clock::observe`] merges.
    pub fn check(&self, stamp: Timestamp) -> Result<(), ClockDriftError> {
        let ahead = stamp.physical().saturating_sub(self.physical());
        if ahead > self.inner.max_drift {
            return Err(ClockDriftError {
                remote: stamp,
                ahead,
                max: self.inner.max_drift,
            });
        }
        Ok(())
    }

    /// How long ago `ts` was, by physical time (zero for timestamps in the future).
    pub fn age(&self, ts: Timestamp) -> Duration {
        self.physical().saturating_sub(ts.physical())
    }

    /// Moves a manual clock forward, then tells its listeners.
    /// Refused with [`ClockError::OutOfRange`] past [`MAX_TIME`] (stamps would stop
    /// moving there and no longer order writes).
    pub fn advance(&self, by: Duration) -> Result<(), ClockError> {
        let by = u64::try_from(by.as_nanos()).unwrap_or(u64::MAX);
        self.move_manual(|t| Ok(t.saturating_add(by)))
    }

    /// Sets a manual clock to a physical time (since the Unix epoch), then tells its
    /// listeners; never backwards, never past [`MAX_TIME`].
    pub fn set(&self, to: Duration) -> Result<(), ClockError> {
        let to = u64::try_from(to.as_nanos()).unwrap_or(u64::MAX);
        self.move_manual(|t| {
            if to >= t {
                Ok(to)
            } else {
                Err(ClockError::Backwards)
            }
        })
    }

    /// Moves a manual clock to `step(now)` in nanoseconds, if that is a time a timestamp
    /// holds.
    fn move_manual(
        &self,
        mut step: impl FnMut(u64) -> Result<u64, ClockError>,
    ) -> Result<(), ClockError> {
        let Physical::Manual(n) = &self.inner.physical else {
            return Err(ClockError::NotManual);
        };
        let max_nanos = u64::try_from(MAX_TIME.as_nanos()).unwrap_or(u64::MAX);
        let mut refused = ClockError::Backwards;
        let checked = |t| match step(t) {
            Ok(to) if to <= max_nanos => Some(to),
            Ok(_) => {
                refused = ClockError::OutOfRange { max: MAX_TIME };
                None
            }
            Err(e) => {
                refused = e;
                None
            }
        };
        n.fetch_update(Ordering::AcqRel, Ordering::Acquire, checked)
            .map_err(|_| refused)?;
        let now = self.physical();
        // Each listener is looked at as its turn comes (one before it may have touched
        // its wake); those asleep are neither called nor upgraded.
        let list = self.inner.listeners.lock().list.clone();
        for l in list.iter() {
            if l.wake.as_ref().is_some_and(|w| w.asleep_at(now)) {
                continue;
            }
            if let Some(listener) = l.listener.upgrade() {
                listener.advanced(now);
            }
        }
        Ok(())
    }

    /// Registers a listener, told whenever this manual clock moves (held weakly: dropping
    /// the listener unsubscribes it). Listeners are told in the order they subscribed.
    pub fn subscribe(&self, listener: Weak<dyn ClockListener>) {
        self.subscribe_with(listener, None);
    }

    /// Registers a listener as [`Clock::subscribe`] does, told of a move only if it is
    /// not before `wake`'s time.
    pub fn subscribe_waking(&self, listener: Weak<dyn ClockListener>, wake: Arc<Wake>) {
        self.subscribe_with(listener, Some(wake));
    }

    /// Also forgets the listeners dropped (a move only skips them): the new list holds
    /// those still alive and this one; a move under way keeps the list it took.
    fn subscribe_with(&self, listener: Weak<dyn ClockListener>, wake: Option<Arc<Wake>>) {
        let mut listeners = self.inner.listeners.lock();
        let list: Vec<Listener> = listeners
            .list
            .iter()
            .filter(|l| l.listener.strong_count() > 0)
            .cloned()
            .chain([Listener { listener, wake }])
            .collect();
        listeners.list = list.into();
    }
}

/// The HLC step: physical time if it moved past the last stamp, else last + 1 (the
/// logical counter; on overflow it carries into the physical bits, which stays monotonic).
#[inline]
fn next(last: u64, phys: u64) -> u64 {
    if phys > last {
        phys
    } else {
        last.saturating_add(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn now_is_strictly_monotonic_when_time_stands_still() {
        let clock = Clock::manual();
        let a = clock.now();
        let b = clock.now();
        assert!(b > a);
        assert_eq!(a.physical(), b.physical());
        assert_eq!(b.logical(), a.logical() + 1);
    }

    #[test]
    fn physical_time_resets_the_logical_counter() {
        let clock = Clock::manual();
        clock.now();
        clock.now();
        clock.advance(Duration::from_millis(1)).unwrap();
        let c = clock.now();
        assert_eq!(c.logical(), 0);
        assert_eq!(c.physical(), MANUAL_EPOCH + Duration::from_millis(1));
    }

    #[test]
    fn observing_a_skewed_remote_orders_later_stamps_after_it() {
        let clock = Clock::manual();
        let remote = Timestamp::from_duration(MANUAL_EPOCH + Duration::from_millis(300));
        clock.observe(remote).unwrap();
        assert!(clock.now() > remote);
    }

    #[test]
    fn a_remote_too_far_ahead_is_refused() {
        let clock = Clock::manual();
        let remote = Timestamp::from_duration(MANUAL_EPOCH + Duration::from_secs(10));
        let err = clock.observe(remote).unwrap_err();
        assert_eq!(err.ahead, Duration::from_secs(10));
        assert!(clock.now() < remote);
    }

    #[test]
    fn the_system_clock_cannot_be_advanced_and_manual_time_never_goes_back() {
        assert_eq!(
            Clock::system().advance(Duration::from_secs(1)),
            Err(ClockError::NotManual)
        );
        let clock = Clock::manual();
        assert_eq!(
            clock.set(Duration::from_secs(1)),
            Err(ClockError::Backwards)
        );
    }

    #[test]
    fn a_manual_clock_is_not_moved_past_the_last_time_a_timestamp_holds() {
        let clock = Clock::manual();
        let before = clock.now();
        let too_far = Duration::from_secs(5_000_000_000);
        assert!(matches!(
            clock.advance(too_far),
            Err(ClockError::OutOfRange { .. })
        ));
        assert!(matches!(
            clock.set(too_far),
            Err(ClockError::OutOfRange { .. })
        ));
        assert_eq!(clock.physical(), MANUAL_EPOCH, "the clock did not move");
        // Up to the last representable microsecond, time still moves and stamps order.
        clock.set(MAX_TIME).unwrap();
        let last = clock.now();
        assert!(last > before);
        assert_eq!(last.physical(), MAX_TIME);
        assert_eq!(
            clock.advance(Duration::from_micros(1)),
            Err(ClockError::OutOfRange { max: MAX_TIME })
        );
    }

    #[test]
    fn the_system_clock_follows_the_wall_clock() {
        let clock = Clock::system();
        let wall = SystemTime::now().duration_since(UNIX_EPOCH).unwrap();
        let ours = clock.physical();
        let diff = ours.abs_diff(wall);
        assert!(diff < Duration::from_millis(50), "{ours:?} vs {wall:?}");
    }

    /// A listener that writes down the moves it hears.
    struct Heard(Mutex<Vec<Duration>>);

    impl ClockListener for Heard {
        fn advanced(&self, now: Duration) {
            self.0.lock().push(now);
        }
    }

    /// A new [`Heard`], and the weak handle a clock holds.
    fn heard() -> (Arc<Heard>, Weak<dyn ClockListener>) {
        let heard = Arc::new(Heard(Mutex::new(Vec::new())));
        let weak: Weak<dyn ClockListener> =
            Arc::downgrade(&(heard.clone() as Arc<dyn ClockListener>));
        (heard, weak)
    }

    #[test]
    fn listeners_hear_a_manual_clock_move_until_dropped() {
        let clock = Clock::manual();
        let (heard, weak) = heard();
        clock.subscribe(weak);
        clock.advance(Duration::from_secs(1)).unwrap();
        clock.set(MANUAL_EPOCH + Duration::from_secs(5)).unwrap();
        assert_eq!(
            *heard.0.lock(),
            [
                MANUAL_EPOCH + Duration::from_secs(1),
                MANUAL_EPOCH + Duration::from_secs(5)
            ]
        );
        drop(heard);
        clock.advance(Duration::from_secs(1)).unwrap();
    }

    #[test]
    fn a_waking_listener_hears_only_the_moves_at_or_past_its_wake_or_after_a_touch() {
        let clock = Clock::manual();
        let (heard, weak) = heard();
        let wake = Arc::new(Wake::default());
        clock.subscribe_waking(weak, wake.clone());
        let at = |s| MANUAL_EPOCH + Duration::from_secs(s);
        wake.set(at(3));
        for s in 1..=4 {
            clock.set(at(s)).unwrap();
        }
        wake.set(at(10));
        clock.set(at(5)).unwrap();
        wake.touched();
        clock.set(at(6)).unwrap();
        assert_eq!(*heard.0.lock(), [at(3), at(4), at(6)]);
    }

    /// A listener that, told of a move, drops two listeners after it and subscribes a
    /// new one (a board closing while another starts): the move goes on with the ones
    /// still alive, in order, and neither skips one nor fails.
    #[test]
    fn listeners_dropped_and_subscribed_during_a_move_leave_the_others_told() {
        struct Churn {
            clock: Clock,
            doomed: Mutex<Vec<Arc<Heard>>>,
            newcomer: Mutex<Option<Arc<Heard>>>,
        }
        impl ClockListener for Churn {
            fn advanced(&self, _now: Duration) {
                self.doomed.lock().clear();
                let (heard, weak) = heard();
                self.clock.subscribe(weak);
                *self.newcomer.lock() = Some(heard);
            }
        }
        let clock = Clock::manual();
        let (b, wb) = heard();
        let (c, wc) = heard();
        let churn: Arc<dyn ClockListener> = Arc::new(Churn {
            clock: clock.clone(),
            doomed: Mutex::new(vec![b, c]),
            newcomer: Mutex::new(None),
        });
        let (last, wl) = heard();
        clock.subscribe(Arc::downgrade(&churn));
        clock.subscribe(wb);
        clock.subscribe(wc);
        clock.subscribe(wl);
        clock.advance(Duration::from_secs(1)).unwrap();
        assert_eq!(*last.0.lock(), [MANUAL_EPOCH + Duration::from_secs(1)]);
    }

    #[test]
    fn a_listener_touched_by_one_before_it_in_the_same_move_hears_that_move() {
        struct Toucher(Arc<Wake>);
        impl ClockListener for Toucher {
            fn advanced(&self, _now: Duration) {
                self.0.touched();
            }
        }
        let clock = Clock::manual();
        let wake = Arc::new(Wake::default());
        wake.set(Duration::MAX);
        let toucher: Arc<dyn ClockListener> = Arc::new(Toucher(wake.clone()));
        let (heard, weak) = heard();
        clock.subscribe(Arc::downgrade(&toucher));
        clock.subscribe_waking(weak, wake);
        clock.advance(Duration::from_secs(1)).unwrap();
        assert_eq!(*heard.0.lock(), [MANUAL_EPOCH + Duration::from_secs(1)]);
        drop(heard);
        clock.advance(Duration::from_secs(1)).unwrap();
        clock.subscribe(Arc::downgrade(&toucher));
        assert_eq!(
            clock.inner.listeners.lock().list.len(),
            2,
            "the dropped one forgotten"
        );
    }

    #[test]
    fn concurrent_stamps_are_all_distinct() {
        let clock = Clock::system();
        let stamps: Vec<Timestamp> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..4)
                .map(|_| s.spawn(|| (0..10_000).map(|_| clock.now()).collect::<Vec<_>>()))
                .collect();
            handles
                .into_iter()
                .flat_map(|h| h.join().unwrap())
                .collect()
        });
        let mut sorted = stamps.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(sorted.len(), stamps.len());
    }
}
