//! "At most one a period": the one rate limit for news that a flood could repeat (a
//! refused packet, an undecodable message), so that a hostile or broken peer fills
//! no event log and no channel, however much it sends.
//!
//! Time is what the caller passes: a board's [`Clock::physical`](crate::Clock::physical),
//! so on a manual clock (the simulator) the same run tells the same news.

use std::collections::HashMap;
use std::hash::Hash;
use std::time::Duration;

/// At most one occasion every `period`: [`due`](Every::due) says yes the first time,
/// then not again until `period` has passed since it last said yes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Every {
    /// The shortest time between two occasions.
    period: Duration,
    /// When `due` last said yes (none yet: the next call does).
    last: Option<Duration>,
}

impl Every {
    /// One occasion at most every `period`.
    pub const fn new(period: Duration) -> Every {
        Every { period, last: None }
    }

    /// Is an occasion due at `now` (none in the `period` before it)? If so, it is taken:
    /// the next is due `period` after `now`. A `now` before the last occasion (a clock set
    /// back) is not due until the clock passes it by `period`.
    pub fn due(&mut self, now: Duration) -> bool {
        let due = self
            .last
            .is_none_or(|t| now.checked_sub(t).is_some_and(|d| d >= self.period));
        if due {
            self.last = Some(now);
        }
        due
    }

    /// The earliest time at which [`Every::due`] says yes (zero before the first).
    pub fn next(&self) -> Duration {
        self.last
            .map_or(Duration::ZERO, |t| t.saturating_add(self.period))
    }
}

/// One [`Every`] per key (a source), each counting the occasions it held back: at most
/// one event a period per source, and the next one says how many it stands for. At most
/// `keys` keys are tracked; past that, the keys not tracked share one limit, so that
/// made-up sources cannot grow it.
#[derive(Clone, Debug)]
pub struct EveryPer<K> {
    /// The shortest time between two occasions of one key.
    period: Duration,
    /// Keys tracked at most.
    keys: usize,
    /// Each key's limit, and the occasions it held back since it last let one through.
    each: HashMap<K, (Every, u64)>,
    /// The limit the keys past `keys` share.
    others: (Every, u64),
}

impl<K: Hash + Eq> EveryPer<K> {
    /// At most one occasion every `period` per key, for at most `keys` keys apart.
    pub fn new(period: Duration, keys: usize) -> EveryPer<K> {
        EveryPer {
            period,
            keys,
            each: HashMap::new(),
            others: (Every::new(period), 0),
        }
    }

    /// Is an occasion of `key` due at `now`? If so, `Some(held)`: how many of its
    /// occasions were held back since the last one let through (and its count starts
    /// again); if not, `None`, and this one is counted as held back.
    pub fn due(&mut self, key: K, now: Duration) -> Option<u64> {
        let period = self.period;
        if !self.each.contains_key(&key) && self.each.len() >= self.keys {
            self.forget_quiet(now);
        }
        let slot = if self.each.contains_key(&key) || self.each.len() < self.keys {
            self.each.entry(key).or_insert((Every::new(period), 0))
        } else {
            &mut self.others
        };
        take(slot, now)
    }

    /// Forgets the keys whose period is over: forgotten, they would be due at once
    /// anyway (only the count they held back is lost, which their next event would have
    /// told).
    fn forget_quiet(&mut self, now: Duration) {
        self.each.retain(|_, (every, _)| !{ *every }.due(now));
    }
}

/// [`EveryPer::due`] on one slot.
fn take((every, held): &mut (Every, u64), now: Duration) -> Option<u64> {
    if every.due(now) {
        Some(std::mem::take(held))
    } else {
        *held += 1;
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SEC: Duration = Duration::from_secs(1);

    #[test]
    fn once_a_period_at_most() {
        let mut every = Every::new(SEC);
        let ms = Duration::from_millis;
        assert!(every.due(ms(0)));
        assert!(!every.due(ms(999)));
        assert!(every.due(ms(1000)));
        assert!(!every.due(ms(500)), "a clock set back is not due");
        assert!(every.due(ms(2000)));
    }

    #[test]
    fn each_key_has_its_own_limit_and_says_what_it_held_back() {
        let mut per = EveryPer::new(SEC, 4);
        assert_eq!(per.due("a", Duration::ZERO), Some(0));
        assert_eq!(per.due("a", Duration::from_millis(10)), None);
        assert_eq!(per.due("a", Duration::from_millis(20)), None);
        assert_eq!(per.due("b", Duration::from_millis(30)), Some(0));
        assert_eq!(per.due("a", SEC), Some(2));
        assert_eq!(per.due("a", SEC * 2), Some(0));
    }

    #[test]
    fn keys_past_the_bound_share_one_limit() {
        let mut per = EveryPer::new(SEC, 2);
        let now = Duration::ZERO;
        assert_eq!(per.due(0, now), Some(0));
        assert_eq!(per.due(0, now), None);
        assert_eq!(per.due(1, now), Some(0));
        assert_eq!(per.due(1, now), None);
        let told = (2..1000).filter(|k| per.due(*k, now).is_some()).count();
        assert_eq!(told, 1, "made-up keys share one event");
        assert!(per.each.len() <= 2);
        // Once the tracked keys are quiet, a new one takes a slot of its own.
        let later = SEC * 5;
        assert_eq!(per.due(0, later), Some(1));
        assert_eq!(per.due(1, later), Some(1));
        assert_eq!(per.due(7, later * 2), Some(0));
    }
}
