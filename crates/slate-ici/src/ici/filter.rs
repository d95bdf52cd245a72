//! Report filters: when a module's own packets are reported, from each attribute's
//! declared `ReportPolicy`, and, on a link whose link policy (`link team { report ... }`)
//! overrides an attribute, when they go on that link as well.
//!
//! An own packet passes the class's filter first (it decides what leaves the module at
//! all); on each link with an override, what passed is offered again, separately, to that
//! link's filter: [`LinkFilters`], one [`AttrFilters`] per link kind, or kept off the link
//! by `never`.
//!
//! Invariant: a filter never loses the last value. A value held back by the minimum
//! interval is sent when the interval ends (trailing edge); a value held back by a
//! dead-band or accuracy filter is sent once it has stopped changing for the quiet
//! period. A heartbeat re-sends the current value when nothing was sent for that long.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use std::time::Duration;

use slate_model::{Packet, ReportPolicy, Value};
use slate_plans::LinkReport;

use crate::LinkKind;

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
pub(crate) struct AttrFilters {
    states: BTreeMap<Key, State>,
    timers: BTreeSet<(Duration, Key)>,
    /// Values held back by a filter (not sent at once).
    pub held: u64,
}

impl AttrFilters {
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

/// Every report filter of the module: the classes' own, and the links' overrides.
#[derive(Default)]
pub(crate) struct Filters {
    /// The class's filter of each attribute: what leaves the module at all.
    class: AttrFilters,
    /// The link policies' filters, for the link kinds that have overrides.
    links: BTreeMap<LinkKind, LinkFilters>,
}

impl Filters {
    /// A new own packet, through its class's filter: `Some` if it is to be sent now.
    pub fn offer(
        &mut self,
        key: Key,
        packet: Packet,
        policy: &ReportPolicy,
        now: Duration,
        quiet: Duration,
    ) -> Option<Packet> {
        self.class.offer(key, packet, policy, now, quiet)
    }

    /// Records that `key` was (re)sent by the class's filter now, or has nothing to
    /// heartbeat (`None`).
    pub fn sent(&mut self, key: &Key, packet: Option<Packet>, now: Duration) {
        self.class.sent(key, packet, now);
    }

    /// The class filters' timers due by `now`, in time order.
    pub fn due(&mut self, now: Duration) -> Vec<Due> {
        self.class.due(now)
    }

    /// When the class filters' next timer is due.
    pub fn next_due(&self) -> Option<Duration> {
        self.class.next_due()
    }

    /// Drops every filter of an object (it was deleted), on every link too.
    pub fn forget(&mut self, object: &str) {
        self.class.forget(object);
        for link in self.links.values_mut() {
            link.filters.forget(object);
        }
    }

    /// Replaces the overrides of `link` (an empty set removes the link's filters,
    /// unless the link has a minimum interval of its own, whose held values stay).
    pub fn set_link(&mut self, link: LinkKind, overrides: Overrides) {
        let keep = self.links.get(&link).is_some_and(|l| l.every.is_some());
        if overrides.is_empty() && !keep {
            self.links.remove(&link);
        } else {
            self.links.entry(link).or_default().overrides = overrides;
        }
    }

    /// The filters of `link`, if its policy overrides any attribute.
    pub fn link(&mut self, link: LinkKind) -> Option<&mut LinkFilters> {
        self.links.get_mut(&link)
    }

    /// The filters of `link` with `every` as the link's own minimum interval for the
    /// attributes its policy does not override ([`LinkFilters::every`]); `None` if the
    /// link has neither.
    pub fn link_every(
        &mut self,
        link: LinkKind,
        every: Option<Duration>,
    ) -> Option<&mut LinkFilters> {
        if every.is_some() {
            self.links.entry(link).or_default().every = every;
        }
        self.links.get_mut(&link)
    }

    /// When the links' next timer is due.
    pub fn next_link_due(&self) -> Option<Duration> {
        self.links
            .values()
            .filter_map(|l| l.filters.next_due())
            .min()
    }

    /// The links' timers due by `now`: each link's in time order.
    pub fn link_due(&mut self, now: Duration) -> Vec<(LinkKind, Due)> {
        let mut out = Vec::new();
        for (link, filters) in &mut self.links {
            out.extend(filters.filters.due(now).into_iter().map(|d| (*link, d)));
        }
        out
    }
}

/// A link policy's report overrides: class → attribute → filter. A class's override
/// applies to its subclasses, the nearest class's winning. Bounded by the classes'
/// declared attributes (the loader checks each names one).
pub(crate) type Overrides = BTreeMap<Arc<str>, BTreeMap<Arc<str>, LinkReport>>;

/// What a link's filter says of a packet the class's filter let go.
#[derive(Debug, PartialEq)]
pub(crate) enum LinkVerdict {
    /// No override, or the link's filter sends it now.
    Send,
    /// The link's filter holds it (its trailing edge sends it later).
    Held,
    /// The link policy keeps the attribute off this link (`never`).
    Never,
}

/// One link kind's filters: the overrides of its link policy, the link's own minimum
/// interval, and their states.
#[derive(Default)]
pub(crate) struct LinkFilters {
    overrides: Overrides,
    /// The minimum interval between two reports of an attribute on this link, for the
    /// attributes without an override (`IciConfig::team_report_every`).
    every: Option<Duration>,
    filters: AttrFilters,
}

impl LinkFilters {
    /// Offers a packet of `key` (class chain `lineage`, class first) that the class's
    /// filter let go.
    pub fn offer(
        &mut self,
        lineage: &[Arc<str>],
        key: Key,
        packet: Packet,
        now: Duration,
        quiet: Duration,
    ) -> LinkVerdict {
        let policy = match (self.override_of(lineage, &key.1), self.every) {
            (None, None) => return LinkVerdict::Send,
            (None, Some(every)) => ReportPolicy {
                min_interval: Some(every),
                ..ReportPolicy::default()
            },
            (Some(LinkReport::Never), _) => return LinkVerdict::Never,
            (Some(LinkReport::Policy(p)), _) => p.clone(),
        };
        match self.filters.offer(key, packet, &policy, now, quiet) {
            Some(_) => LinkVerdict::Send,
            None => LinkVerdict::Held,
        }
    }

    /// Records that `key` was (re)sent on the link now, or has nothing to heartbeat.
    pub fn sent(&mut self, key: &Key, packet: Option<Packet>, now: Duration) {
        self.filters.sent(key, packet, now);
    }

    /// The override of the nearest class of `lineage` that has one for `attr`.
    fn override_of(&self, lineage: &[Arc<str>], attr: &str) -> Option<&LinkReport> {
        lineage
            .iter()
            .find_map(|class| self.overrides.get(class)?.get(attr))
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
        let mut f = AttrFilters::default();
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
        let mut f = AttrFilters::default();
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
        let mut f = AttrFilters::default();
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
        let mut f = AttrFilters::default();
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
        let mut f = AttrFilters::default();
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
        let mut f = AttrFilters::default();
        let policy = ReportPolicy {
            heartbeat: Some(ms(500)),
            ..Default::default()
        };
        f.offer(key(), p(1.0), &policy, ms(0), QUIET);
        f.forget("gsr");
        assert!(f.due(ms(10_000)).is_empty());
    }

    /// Filters whose team link holds `Robot.position` for 20 s and keeps `heading` off.
    fn team_filters() -> Filters {
        let mut by_attr = BTreeMap::new();
        let every_20s = ReportPolicy {
            min_interval: Some(ms(20_000)),
            ..Default::default()
        };
        by_attr.insert(Arc::from("position"), LinkReport::Policy(every_20s));
        by_attr.insert(Arc::from("heading"), LinkReport::Never);
        let mut f = Filters::default();
        f.set_link(
            LinkKind::Team,
            Overrides::from([(Arc::from("Robot"), by_attr)]),
        );
        f
    }

    fn robot_key(attr: &str) -> Key {
        ("r1".into(), attr.into())
    }

    /// `Scout` is a `Robot`.
    fn scout() -> Vec<Arc<str>> {
        vec!["Scout".into(), "Robot".into(), "Thing".into()]
    }

    /// Offers a packet to the class's filter (default policy) then to the team's.
    fn offer_both(f: &mut Filters, attr: &str, v: f64, at: u64) -> (bool, LinkVerdict) {
        let class = f.offer(
            robot_key(attr),
            p(v),
            &ReportPolicy::default(),
            ms(at),
            QUIET,
        );
        let team = f.link(LinkKind::Team).expect("team filters");
        (
            class.is_some(),
            team.offer(&scout(), robot_key(attr), p(v), ms(at), QUIET),
        )
    }

    #[test]
    fn a_team_filter_holds_a_value_the_robot_link_sends() {
        let mut f = team_filters();
        assert_eq!(
            offer_both(&mut f, "position", 1.0, 0),
            (true, LinkVerdict::Send)
        );
        assert_eq!(
            offer_both(&mut f, "position", 2.0, 1000),
            (true, LinkVerdict::Held)
        );
        assert_eq!(f.next_due(), None, "the class's filter holds nothing");
        assert_eq!(f.next_link_due(), Some(ms(20_000)));
    }

    #[test]
    fn the_trailing_edge_of_a_team_filter_goes_to_the_team_only() {
        let mut f = team_filters();
        offer_both(&mut f, "position", 1.0, 0);
        offer_both(&mut f, "position", 2.0, 1000);
        offer_both(&mut f, "position", 3.0, 2000);
        assert!(f.link_due(ms(19_999)).is_empty());
        let due = f.link_due(ms(20_000));
        assert_eq!(
            due,
            [(LinkKind::Team, Due::Trailing(robot_key("position"), p(3.0)))]
        );
        assert!(
            f.due(ms(20_000)).is_empty(),
            "nothing for the class's filter"
        );
    }

    #[test]
    fn never_keeps_an_attribute_off_the_link_and_keeps_no_state() {
        let mut f = team_filters();
        assert_eq!(
            offer_both(&mut f, "heading", 1.0, 0),
            (true, LinkVerdict::Never)
        );
        assert_eq!(f.next_link_due(), None);
    }

    #[test]
    fn an_attribute_without_override_goes_on_the_link_unfiltered() {
        let mut f = team_filters();
        for (i, at) in [0, 10, 20].into_iter().enumerate() {
            let v = i as f64;
            assert_eq!(
                offer_both(&mut f, "speed", v, at),
                (true, LinkVerdict::Send)
            );
        }
    }

    #[test]
    fn the_nearest_class_override_wins() {
        let mut f = team_filters();
        let mut scout_only = BTreeMap::new();
        scout_only.insert(Arc::from("position"), LinkReport::Never);
        let mut overrides = Overrides::from([(Arc::from("Scout"), scout_only)]);
        let robot = team_filters()
            .links
            .remove(&LinkKind::Team)
            .unwrap()
            .overrides;
        overrides.extend(robot);
        f.set_link(LinkKind::Team, overrides);
        assert_eq!(offer_both(&mut f, "position", 1.0, 0).1, LinkVerdict::Never);
    }

    #[test]
    fn a_link_without_overrides_has_no_filters() {
        let mut f = team_filters();
        f.set_link(LinkKind::Team, Overrides::new());
        assert!(f.link(LinkKind::Team).is_none());
    }

    #[test]
    fn forgetting_an_object_drops_its_link_timers() {
        let mut f = team_filters();
        offer_both(&mut f, "position", 1.0, 0);
        offer_both(&mut f, "position", 2.0, 1000);
        f.forget("r1");
        assert_eq!(f.next_link_due(), None);
        assert!(f.link_due(ms(60_000)).is_empty());
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
