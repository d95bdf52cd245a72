//! Report filters: when a module's own packets are reported, from each attribute's
//! declared `ReportPolicy`.
//!
//! Invariant: a filter never loses the last value. A value held back by the minimum
//! interval is sent when the interval ends (trailing edge); a value held back by a
//! dead-band or accuracy filter is sent once it has stopped changing for the quiet
//! period. A heartbeat re-sends the current value when nothing was sent for that long.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use std::time::Duration;

use slate_model::{Packet, ReportPolicy, Value};

/// `(object, attribute)`.
pub(crate) type Key = (Arc<str>, Arc<str>);

#[derive(Default)]
struct State {
    policy: ReportPolicy,
    last: Option<Packet>,
    last_at: Option<Duration>,
    pending: Option<Packet>,
    hold_until: Duration,
    timer: Option<Duration>,
}

/// What a timer asks for.
#[derive(Debug, PartialEq)]
pub(crate) enum Due {
    /// Send this held value now.
    Trailing(Key, Packet),
    /// Nothing was sent for a heartbeat interval: send the current value if it is ours.
    Heartbeat(Key),
}

/// The filters of every attribute this module reported, with their timers.
#[derive(Default)]
pub(crate) struct Filters {
    states: BTreeMap<Key, State>,
    timers: BTreeSet<(Duration, Key)>,
    /// Values held back by a filter (not sent at once).
    pub held: u64,
}

impl Filters {
    /// A new own packet: `Some` if it is to be sent now, `None` if held back.
    pub fn offer(
        &mut self,
        key: Key,
        packet: Packet,
        policy: &ReportPolicy,
        now: Duration,
        quiet: Duration,
    ) -> Option<Packet> {
        if is_unfiltered(policy) {
            // Nothing to hold, nothing to repeat: no state to keep either.
            return Some(packet);
        }
        let st = self.states.entry(key.clone()).or_default();
        st.policy = policy.clone();
        let hold_until = if !significant(st, &packet) {
            Some(now + policy.min_interval.unwrap_or(quiet).max(quiet))
        } else {
            let next = st.last_at.zip(policy.min_interval).map(|(at, mi)| at + mi);
            next.filter(|t| now < *t)
        };
        let out = match hold_until {
            Some(t) => {
                st.pending = Some(packet);
                st.hold_until = t;
                self.held += 1;
                None
            }
            None => {
                mark_sent(st, packet.clone(), now);
                Some(packet)
            }
        };
        self.reschedule(&key);
        out
    }

    /// Records that `key` was (re)sent now, or that it has nothing to heartbeat (`None`).
    pub fn sent(&mut self, key: &Key, packet: Option<Packet>, now: Duration) {
        if let Some(st) = self.states.get_mut(key) {
            match packet {
                Some(p) => mark_sent(st, p, now),
                None => st.last_at = None,
            }
        }
        self.reschedule(key);
    }

    /// The timers due by `now`, in time order.
    pub fn due(&mut self, now: Duration) -> Vec<Due> {
        let mut out = Vec::new();
        while let Some((at, key)) = self.timers.first().cloned() {
            if at > now {
                break;
            }
            self.timers.pop_first();
            let Some(st) = self.states.get_mut(&key) else {
                continue;
            };
            st.timer = None;
            // The timer is the earlier of the hold's end and the heartbeat: either way,
            // a held value goes now.
            match st.pending.take() {
                Some(p) => {
                    mark_sent(st, p.clone(), now);
                    out.push(Due::Trailing(key.clone(), p));
                }
                None => {
                    st.last_at = Some(now);
                    out.push(Due::Heartbeat(key.clone()));
                }
            }
            self.reschedule(&key);
        }
        out
    }

    /// When the next timer is due.
    pub fn next_due(&self) -> Option<Duration> {
        self.timers.first().map(|(t, _)| *t)
    }

    /// Drops every filter of an object (it was deleted).
    pub fn forget(&mut self, object: &str) {
        let keys: Vec<Key> = self
            .states
            .keys()
            .filter(|(o, _)| &**o == object)
            .cloned()
            .collect();
        for key in keys {
            if let Some(st) = self.states.remove(&key)
                && let Some(t) = st.timer
            {
                self.timers.remove(&(t, key));
            }
        }
    }

    fn reschedule(&mut self, key: &Key) {
        let Some(st) = self.states.get_mut(key) else {
            return;
        };
        if let Some(t) = st.timer.take() {
            self.timers.remove(&(t, key.clone()));
        }
        let trailing = st.pending.as_ref().map(|_| st.hold_until);
        let heartbeat = st.last_at.zip(st.policy.heartbeat).map(|(at, hb)| at + hb);
        let next = match (trailing, heartbeat) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        if let Some(t) = next {
            st.timer = Some(t);
            self.timers.insert((t, key.clone()));
        }
    }
}

/// A policy that sends every packet at once and never repeats one.
pub(crate) fn is_unfiltered(p: &ReportPolicy) -> bool {
    p.min_interval.is_none() && p.heartbeat.is_none() && p.deadband.is_none() && !p.on_accuracy
}

fn mark_sent(st: &mut State, packet: Packet, now: Duration) {
    st.last = Some(packet);
    st.last_at = Some(now);
    st.pending = None;
}

/// Is the packet different enough from the last one sent to be reported now?
fn significant(st: &State, packet: &Packet) -> bool {
    let Some(last) = &st.last else {
        return true;
    };
    let threshold = match (st.policy.deadband, st.policy.on_accuracy) {
        (None, false) => return true,
        (band, on_accuracy) => {
            let acc = if on_accuracy { packet.accuracy } else { 0.0 };
            band.unwrap_or(0.0).max(acc)
        }
    };
    distance(&last.value, &packet.value) > threshold
}

/// How far apart two values are: numeric difference (Euclidean for vectors); any
/// change of another type is infinitely far.
fn distance(a: &Value, b: &Value) -> f64 {
    match (a, b) {
        (Value::Int(x), Value::Int(y)) => (*x as f64 - *y as f64).abs(),
        (Value::Real(x), Value::Real(y)) => (x - y).abs(),
        _ => match (a.as_vector(), b.as_vector()) {
            (Some(x), Some(y)) if x.len() == y.len() => x
                .iter()
                .zip(y)
                .map(|(p, q)| (p - q) * (p - q))
                .sum::<f64>()
                .sqrt(),
            _ if a == b => 0.0,
            _ => f64::INFINITY,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use slate_model::{Address, Timestamp};

    const QUIET: Duration = Duration::from_secs(1);

    fn key() -> Key {
        ("gsr".into(), "x".into())
    }

    fn p(v: f64) -> Packet {
        Packet {
            value: Value::Real(v),
            accuracy: 0.5,
            confidence: 1.0,
            timestamp: Timestamp::from_raw(1),
            source: Address::unknown(),
        }
    }

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    fn values(due: &[Due]) -> Vec<f64> {
        due.iter()
            .filter_map(|d| match d {
                Due::Trailing(_, p) => p.value.as_f64(),
                Due::Heartbeat(_) => None,
            })
            .collect()
    }

    #[test]
    fn the_default_policy_sends_every_change_at_once() {
        let mut f = Filters::default();
        let policy = ReportPolicy::default();
        for i in 0..3 {
            assert!(
                f.offer(key(), p(f64::from(i)), &policy, ms(0), QUIET)
                    .is_some()
            );
        }
        assert_eq!(f.next_due(), None);
    }

    #[test]
    fn min_interval_sends_the_final_value_at_the_trailing_edge() {
        let mut f = Filters::default();
        let policy = ReportPolicy {
            min_interval: Some(ms(1000)),
            ..Default::default()
        };
        assert!(f.offer(key(), p(1.0), &policy, ms(0), QUIET).is_some());
        assert!(f.offer(key(), p(2.0), &policy, ms(100), QUIET).is_none());
        assert!(f.offer(key(), p(3.0), &policy, ms(200), QUIET).is_none());
        assert!(f.due(ms(999)).is_empty());
        assert_eq!(values(&f.due(ms(1000))), [3.0]);
        assert!(f.due(ms(5000)).is_empty(), "sent once");
    }

    #[test]
    fn deadband_holds_small_changes_until_they_settle() {
        let mut f = Filters::default();
        let policy = ReportPolicy {
            deadband: Some(1.0),
            ..Default::default()
        };
        assert!(f.offer(key(), p(5.0), &policy, ms(0), QUIET).is_some());
        assert!(f.offer(key(), p(5.5), &policy, ms(100), QUIET).is_none());
        assert!(f.offer(key(), p(5.8), &policy, ms(600), QUIET).is_none());
        assert!(f.due(ms(1500)).is_empty(), "still changing 1 s ago");
        assert_eq!(values(&f.due(ms(1600))), [5.8]);
        assert!(f.offer(key(), p(7.0), &policy, ms(2000), QUIET).is_some());
    }

    #[test]
    fn on_accuracy_sends_only_changes_beyond_the_accuracy() {
        let mut f = Filters::default();
        let policy = ReportPolicy {
            on_accuracy: true,
            ..Default::default()
        };
        assert!(f.offer(key(), p(1.0), &policy, ms(0), QUIET).is_some());
        assert!(f.offer(key(), p(1.4), &policy, ms(10), QUIET).is_none());
        assert!(f.offer(key(), p(1.6), &policy, ms(20), QUIET).is_some());
    }

    #[test]
    fn heartbeat_asks_for_a_resend_when_quiet() {
        let mut f = Filters::default();
        let policy = ReportPolicy {
            heartbeat: Some(ms(500)),
            ..Default::default()
        };
        f.offer(key(), p(1.0), &policy, ms(0), QUIET);
        assert_eq!(f.due(ms(500)), [Due::Heartbeat(key())]);
        f.sent(&key(), Some(p(1.0)), ms(500));
        assert!(f.due(ms(999)).is_empty());
        assert_eq!(f.due(ms(1000)).len(), 1);
        f.sent(&key(), None, ms(1000));
        assert_eq!(f.next_due(), None, "not ours any more: no heartbeat");
    }

    #[test]
    fn forgetting_an_object_drops_its_timers() {
        let mut f = Filters::default();
        let policy = ReportPolicy {
            heartbeat: Some(ms(500)),
            ..Default::default()
        };
        f.offer(key(), p(1.0), &policy, ms(0), QUIET);
        f.forget("gsr");
        assert!(f.due(ms(10_000)).is_empty());
    }

    #[test]
    fn distances_by_type() {
        assert_eq!(distance(&Value::Int(3), &Value::Int(-1)), 4.0);
        assert_eq!(
            distance(&Value::from([0.0, 0.0]), &Value::from([3.0, 4.0])),
            5.0
        );
        assert_eq!(distance(&Value::Bool(true), &Value::Bool(true)), 0.0);
        assert!(distance(&Value::Bool(true), &Value::Bool(false)).is_infinite());
    }
}
