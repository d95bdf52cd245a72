//! The simulated network's state: endpoints, the event queue, partitions, transmitters,
//! and the model of how a message travels (or does not).

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use std::time::Duration;

use slate_model::Address;

use super::rng::Rng;
use super::stats::{LinkCounters, SimStats};
use super::{LinkConfig, SimConfig};
use crate::{Handler, LinkKind, LinkStats, MsgKind, SendError};

/// Something the step loop does at a virtual time.
pub(crate) enum Action {
    /// Hand a message to an endpoint.
    Deliver {
        from: Address,
        to: usize,
        kind: MsgKind,
        payload: Arc<[u8]>,
        /// The sending endpoint, for a reliable send (its retransmissions stop if it dies).
        reliable_from: Option<usize>,
    },
    /// Bring `to`'s view of `peer` up to date (liveliness).
    Review { to: usize, peer: Address },
}

/// What a delivery or review asks the step loop to call, outside the lock.
pub(crate) enum Call {
    Message(Arc<dyn Handler>, Address, Arc<[u8]>),
    Peer(Arc<dyn Handler>, Address, bool),
}

pub(crate) struct Endpoint {
    pub address: Address,
    pub alive: bool,
    pub handler: Option<Arc<dyn Handler>>,
    /// The peers this endpoint has heard come up, and which incarnation.
    pub view: BTreeMap<Address, usize>,
    pub stats: LinkStats,
    /// The kinds of links whose publications this endpoint does not receive
    /// (`Transport::listen(link, false)`); empty when it joins.
    pub not_listening: BTreeSet<LinkKind>,
}

impl Endpoint {
    /// Does this endpoint receive publications on `link`?
    pub fn listens(&self, link: LinkKind) -> bool {
        !self.not_listening.contains(&link)
    }
}

/// One publication on its way out: what every receiver's fate is drawn for.
struct Publication<'a> {
    sender: &'a Address,
    link: LinkKind,
    kind: MsgKind,
    payload: Arc<[u8]>,
    /// When its transmission ends.
    done: Duration,
    cfg: LinkConfig,
    /// The receivers at which it is lost whatever the draws (`drop_next_publish`).
    dropped_at: BTreeSet<Address>,
    /// With `loss_per_robot`: each receiving robot's draw (`team/robot` → lost), made at
    /// its first receiving endpoint and shared by the others.
    robot_lost: BTreeMap<String, bool>,
}

/// The transmitter key of a shared channel (no endpoint has this index): every sender
/// on the link reserves this one.
const SHARED: usize = usize::MAX;

/// Time is virtual: a `Duration` since the network was created.
pub(crate) struct Net {
    pub config: SimConfig,
    pub rng: Rng,
    pub now: Duration,
    queue: BTreeMap<(Duration, u64, u64), Action>,
    seq: u64,
    pub endpoints: Vec<Endpoint>,
    current: BTreeMap<Address, usize>,
    cuts: Vec<(BTreeSet<Address>, BTreeSet<Address>)>,
    reliable_tail: BTreeMap<(usize, usize), Duration>,
    /// When each transmitter `(sender or SHARED, link)` is free again.
    busy_until: BTreeMap<(usize, LinkKind), Duration>,
    /// Test hook: the receivers at which each sender's next team publication is lost.
    /// One entry per sender (a new request replaces the old), taken by that publication.
    drop_next: BTreeMap<Address, BTreeSet<Address>>,
    /// Everything counted but the per-link counters ([`Net::stats`] adds them).
    pub stats: SimStats,
    links: LinkCounters,
}

impl Net {
    pub fn new(seed: u64, config: SimConfig) -> Self {
        Net {
            config,
            rng: Rng::new(seed),
            now: Duration::ZERO,
            queue: BTreeMap::new(),
            seq: 0,
            endpoints: Vec::new(),
            current: BTreeMap::new(),
            cuts: Vec::new(),
            reliable_tail: BTreeMap::new(),
            busy_until: BTreeMap::new(),
            drop_next: BTreeMap::new(),
            stats: SimStats::default(),
            links: LinkCounters::default(),
        }
    }

    /// Everything counted so far.
    pub fn stats(&self) -> SimStats {
        SimStats {
            links: self.links.ordered(),
            ..self.stats.clone()
        }
    }

    fn schedule(&mut self, at: Duration, action: Action) {
        self.seq += 1;
        let tie = self.rng.next_u64();
        self.queue.insert((at, tie, self.seq), action);
    }

    /// The time of the next event, if any.
    pub fn next_at(&self) -> Option<Duration> {
        self.queue.first_key_value().map(|(k, _)| k.0)
    }

    /// Takes the next event if it is due by `limit`.
    pub fn pop_due(&mut self, limit: Duration) -> Option<(Duration, Action)> {
        if self.next_at()? > limit {
            return None;
        }
        self.stats.events += 1;
        self.queue.pop_first().map(|(k, a)| (k.0, a))
    }

    fn link_config(&self, kind: LinkKind) -> LinkConfig {
        match kind {
            LinkKind::Robot => self.config.robot,
            LinkKind::Team => self.config.team,
        }
    }

    // ----- membership -----

    /// A new endpoint at `address`; an endpoint already there is replaced (a restart).
    pub fn join(&mut self, address: &Address) -> usize {
        if let Some(old) = self.current.get(address).copied() {
            self.endpoints[old].alive = false;
            self.endpoints[old].view.clear();
        }
        let index = self.endpoints.len();
        self.endpoints.push(Endpoint {
            address: address.clone(),
            alive: true,
            handler: None,
            view: BTreeMap::new(),
            stats: LinkStats::default(),
            not_listening: BTreeSet::new(),
        });
        self.current.insert(address.clone(), index);
        self.review_all(address, self.config.liveliness_delay);
        index
    }

    /// Kills (`alive = false`) or revives the current endpoint at `address`.
    pub fn set_alive(&mut self, address: &Address, alive: bool) {
        let Some(index) = self.current.get(address).copied() else {
            return;
        };
        let ep = &mut self.endpoints[index];
        if ep.alive == alive {
            return;
        }
        ep.alive = alive;
        ep.view.clear();
        let delay = if alive {
            self.config.liveliness_delay
        } else {
            self.config.lease
        };
        self.review_all(address, delay);
    }

    /// Closes one endpoint (only if it is still the current one at its address).
    pub fn close(&mut self, index: usize) {
        let address = self.endpoints[index].address.clone();
        if self.current.get(&address) == Some(&index) {
            self.set_alive(&address, false);
        }
    }

    pub fn partition(&mut self, a: &[Address], b: &[Address]) {
        let (a, b): (BTreeSet<_>, BTreeSet<_>) =
            (a.iter().cloned().collect(), b.iter().cloned().collect());
        self.cuts.push((a.clone(), b.clone()));
        let lease = self.config.lease;
        for x in &a {
            self.review_all(x, lease);
        }
        for y in &b {
            self.review_all(y, lease);
        }
    }

    pub fn heal(&mut self) {
        let cuts = std::mem::take(&mut self.cuts);
        let delay = self.config.liveliness_delay;
        for (a, b) in cuts {
            for x in a.iter().chain(b.iter()) {
                self.review_all(x, delay);
            }
        }
    }

    fn is_cut(&self, x: &Address, y: &Address) -> bool {
        self.cuts
            .iter()
            .any(|(a, b)| (a.contains(x) && b.contains(y)) || (a.contains(y) && b.contains(x)))
    }

    /// Do two endpoints at these addresses hear each other come up and go down? Always
    /// on one robot; across robots, only with `team_liveliness`.
    fn watches(&self, a: &Address, b: &Address) -> bool {
        self.config.team_liveliness || a.same_robot(b)
    }

    /// Schedules reviews of every pair involving `address` that watch each other, both
    /// ways.
    fn review_all(&mut self, address: &Address, delay: Duration) {
        let at = self.now + delay;
        let others: Vec<(usize, Address)> = self
            .current
            .iter()
            .filter(|(a, _)| *a != address && self.watches(address, a))
            .map(|(a, i)| (*i, a.clone()))
            .collect();
        let Some(me) = self.current.get(address).copied() else {
            return;
        };
        for (other, other_address) in others {
            self.schedule(
                at,
                Action::Review {
                    to: other,
                    peer: address.clone(),
                },
            );
            self.schedule(
                at,
                Action::Review {
                    to: me,
                    peer: other_address,
                },
            );
        }
    }

    /// Which incarnation of `peer` endpoint `to` can reach now, if any.
    fn reachable(&self, to: usize, peer: &Address) -> Option<usize> {
        let ep = &self.endpoints[to];
        let index = *self.current.get(peer)?;
        let ok = ep.alive && self.endpoints[index].alive && !self.is_cut(&ep.address, peer);
        ok.then_some(index)
    }

    /// Updates `to`'s view of `peer`; returns the peer events to deliver. A pair that
    /// does not watch each other (across robots without `team_liveliness`) is left as
    /// it is.
    pub fn review(&mut self, to: usize, peer: &Address) -> Vec<Call> {
        if !self.watches(&self.endpoints[to].address, peer) {
            return Vec::new();
        }
        let truth = self.reachable(to, peer);
        let ep = &mut self.endpoints[to];
        let seen = ep.view.get(peer).copied();
        if seen == truth || !ep.alive {
            return Vec::new();
        }
        let mut events = Vec::new();
        if seen.is_some() {
            ep.view.remove(peer);
            events.push(false);
        }
        if let Some(index) = truth {
            ep.view.insert(peer.clone(), index);
            events.push(true);
        }
        let Some(handler) = ep.handler.clone() else {
            return Vec::new();
        };
        events
            .into_iter()
            .map(|up| Call::Peer(handler.clone(), peer.clone(), up))
            .collect()
    }

    /// A peer-down event for `peer` at the endpoint at `to`, though both are alive and
    /// reach each other; their views are left as they are. Nothing when `to` is unknown
    /// or has no handler.
    #[cfg(feature = "testing")]
    pub fn false_down(&mut self, to: &Address, peer: &Address) -> Vec<Call> {
        let Some(index) = self.current.get(to).copied() else {
            return Vec::new();
        };
        let handler = self.endpoints[index].handler.clone();
        handler.map_or_else(Vec::new, |h| vec![Call::Peer(h, peer.clone(), false)])
    }

    /// Starts or stops `index`'s reception of publications on `link`.
    pub fn listen(&mut self, index: usize, link: LinkKind, on: bool) {
        let ep = &mut self.endpoints[index];
        if on {
            ep.not_listening.remove(&link);
        } else {
            ep.not_listening.insert(link);
        }
    }

    /// Changes one kind of link's settings from now on. When the link becomes shared
    /// (or stops being so), the transmitters it uses change: the new ones are busy as
    /// long as the old ones were, so what is on the air finishes before anything new
    /// starts.
    pub fn set_link(&mut self, kind: LinkKind, link: LinkConfig) {
        let old = self.link_config(kind);
        match kind {
            LinkKind::Robot => self.config.robot = link,
            LinkKind::Team => self.config.team = link,
        }
        if old.shared != link.shared {
            self.hand_over_transmitters(kind, link.shared);
        }
    }

    /// Carries the busy times of `kind`'s transmitters over to the ones it uses now:
    /// the shared channel is busy until every sender's transmitter is free, and each
    /// sender's until the shared channel is.
    fn hand_over_transmitters(&mut self, kind: LinkKind, shared: bool) {
        let on_link = |((_, l), _): &(&(usize, LinkKind), &Duration)| *l == kind;
        let latest = self
            .busy_until
            .iter()
            .filter(on_link)
            .map(|(_, t)| *t)
            .max();
        let Some(latest) = latest.filter(|t| *t > self.now) else {
            return;
        };
        if shared {
            self.busy_until.insert((SHARED, kind), latest);
            return;
        }
        for index in 0..self.endpoints.len() {
            let busy = self.busy_until.entry((index, kind)).or_default();
            *busy = (*busy).max(latest);
        }
    }

    // ----- traffic -----

    /// Reserves the transmitter `from` uses on `link` (the channel's only one, if it is
    /// shared) for `attempts` transmissions of `len` bytes; returns when the first
    /// starts and how long they all take. Reservations are back to back (first come,
    /// first served), so what lies ahead of `now` is one contiguous stretch.
    fn transmit(
        &mut self,
        from: usize,
        link: LinkKind,
        cfg: &LinkConfig,
        len: usize,
        attempts: u32,
    ) -> (Duration, Duration) {
        let airtime = cfg.airtime(len) * attempts;
        let key = if cfg.shared { SHARED } else { from };
        let busy = self.busy_until.entry((key, link)).or_default();
        let start = (*busy).max(self.now);
        *busy = start + airtime;
        let waited = start - self.now;
        let bytes = len as u64 * u64::from(attempts);
        self.count_radio(from, link, bytes, airtime, waited);
        self.count_channel(link, cfg, len, attempts, airtime);
        (start, airtime)
    }

    /// Drops a message (and counts it) if the transmitter `from` uses on `link` is
    /// already reserved further ahead than the link's `max_queue`.
    fn drop_if_queue_full(&mut self, from: usize, link: LinkKind, cfg: &LinkConfig) -> bool {
        let Some(max) = cfg.max_queue else {
            return false;
        };
        let key = if cfg.shared { SHARED } else { from };
        let until = self
            .busy_until
            .get(&(key, link))
            .copied()
            .unwrap_or_default();
        let full = until.saturating_sub(self.now) > max;
        if full {
            self.stats.channels.entry(link).or_default().dropped += 1;
        }
        full
    }

    fn count_radio(
        &mut self,
        from: usize,
        link: LinkKind,
        bytes: u64,
        airtime: Duration,
        waited: Duration,
    ) {
        let address = self.endpoints[from].address.clone();
        let radio = self.stats.radios.entry((address, link)).or_default();
        radio.msgs += 1;
        radio.bytes += bytes;
        radio.busy += airtime;
        radio.queued += waited;
        radio.max_queued = radio.max_queued.max(waited);
    }

    fn count_channel(
        &mut self,
        link: LinkKind,
        cfg: &LinkConfig,
        len: usize,
        attempts: u32,
        airtime: Duration,
    ) {
        let channel = self.stats.channels.entry(link).or_default();
        channel.frames_sent += cfg.frame_count(len) * u64::from(attempts);
        channel.largest_frame = channel.largest_frame.max(cfg.largest_frame(len));
        channel.largest_message = channel.largest_message.max(len);
        channel.airtime += airtime;
    }

    /// Draws the fate of a message's `frames` frames on `link`: how many were lost
    /// (one draw per frame, so an unframed message takes exactly one). A publication
    /// with `loss_per_robot` draws once per receiving robot, so its losses count per
    /// robot, not per endpoint.
    fn lose_frames(&mut self, link: LinkKind, loss: f64, frames: u64) -> u64 {
        let lost = (0..frames).filter(|_| self.rng.chance(loss)).count() as u64;
        self.stats.channels.entry(link).or_default().frames_lost += lost;
        lost
    }

    /// The fraction of the time so far that `link`'s transmitters spent on the air:
    /// the airtime reserved, less what is still ahead of now.
    pub fn utilisation(&self, link: LinkKind) -> f64 {
        if self.now.is_zero() {
            return 0.0;
        }
        let airtime = self
            .stats
            .channels
            .get(&link)
            .map_or(Duration::ZERO, |c| c.airtime);
        let ahead: Duration = self
            .busy_until
            .iter()
            .filter(|((_, l), _)| *l == link)
            .map(|(_, until)| until.saturating_sub(self.now))
            .sum();
        airtime.saturating_sub(ahead).as_secs_f64() / self.now.as_secs_f64()
    }

    /// Refuses a send from a closed endpoint or of an oversized payload, counting the
    /// refusal; otherwise returns the sender's address.
    fn check_send(&mut self, from: usize, payload: &[u8]) -> Result<Address, SendError> {
        let endpoint = &mut self.endpoints[from];
        let checked = if !endpoint.alive {
            Err(SendError::Closed)
        } else if payload.len() > slate_wire::MAX_MESSAGE_BYTES {
            Err(SendError::TooLarge {
                len: payload.len(),
                max: slate_wire::MAX_MESSAGE_BYTES,
            })
        } else {
            Ok(endpoint.address.clone())
        };
        if checked.is_err() {
            endpoint.stats.refused += 1;
        }
        checked
    }

    /// Best effort to every live endpoint on `link` that listens to it: one
    /// transmission, then loss (per receiver, or per receiving robot), duplication and
    /// jitter per receiver. The transmission happens if any live endpoint is on the link,
    /// listening or not: not listening is the receiver's choice, not the radio's.
    pub fn publish(
        &mut self,
        from: usize,
        link: LinkKind,
        kind: MsgKind,
        payload: &[u8],
    ) -> Result<(), SendError> {
        let sender = self.check_send(from, payload)?;
        let receivers = self.live_on(&sender, link);
        self.endpoints[from].stats.sent(link, kind, payload.len());
        let dropped_at = self.take_drop(&sender, link);
        if receivers.is_empty() {
            return Ok(());
        }
        let cfg = self.link_config(link);
        if self.drop_if_queue_full(from, link, &cfg) {
            return Ok(());
        }
        let (start, airtime) = self.transmit(from, link, &cfg, payload.len(), 1);
        let mut publication = Publication {
            sender: &sender,
            link,
            kind,
            payload: payload.into(),
            done: start + airtime,
            cfg,
            dropped_at,
            robot_lost: BTreeMap::new(),
        };
        for to in receivers {
            if self.endpoints[to].listens(link) {
                self.fan_out(to, &mut publication);
            }
        }
        Ok(())
    }

    /// The live endpoints other than `sender` that `link` joins it to.
    fn live_on(&self, sender: &Address, link: LinkKind) -> Vec<usize> {
        self.current
            .iter()
            .filter(|(a, i)| {
                *a != sender && self.endpoints[**i].alive && LinkKind::between(sender, a) == link
            })
            .map(|(_, i)| *i)
            .collect()
    }

    /// Takes the test hook's receivers for this publication of `sender`: only a team
    /// publication takes them.
    fn take_drop(&mut self, sender: &Address, link: LinkKind) -> BTreeSet<Address> {
        if link != LinkKind::Team {
            return BTreeSet::new();
        }
        self.drop_next.remove(sender).unwrap_or_default()
    }

    /// Asks that `from`'s next team publication be lost at exactly `receivers` (the
    /// others get it or lose it as the link's settings draw). Replaces an earlier
    /// request for `from` that no publication took yet.
    #[cfg(feature = "testing")]
    pub fn drop_next_publish(&mut self, from: &Address, receivers: &[Address]) {
        let receivers = receivers.iter().cloned().collect();
        self.drop_next.insert(from.clone(), receivers);
    }

    fn fan_out(&mut self, to: usize, p: &mut Publication) {
        let receiver = self.endpoints[to].address.clone();
        let counter = self.links.link(p.sender, &receiver, p.kind);
        counter.sent_msgs += 1;
        counter.sent_bytes += p.payload.len() as u64;
        if self.lost_at(&receiver, p) {
            self.links.link(p.sender, &receiver, p.kind).lost += 1;
            return;
        }
        let copies = if self.rng.chance(p.cfg.duplicate) {
            2
        } else {
            1
        };
        for copy in 0..copies {
            if copy == 1 {
                self.links.link(p.sender, &receiver, p.kind).duplicated += 1;
            }
            let at = p.done + p.cfg.delay + self.rng.duration(p.cfg.jitter);
            let action = Action::Deliver {
                from: p.sender.clone(),
                to,
                kind: p.kind,
                payload: p.payload.clone(),
                reliable_from: None,
            };
            self.schedule(at, action);
        }
    }

    /// Is the publication lost at `receiver`? It is if the test hook names the
    /// receiver; otherwise the draw decides: the receiver's own, or with
    /// `loss_per_robot` its robot's, drawn at the robot's first receiving endpoint.
    fn lost_at(&mut self, receiver: &Address, p: &mut Publication) -> bool {
        let frames = p.cfg.frame_count(p.payload.len());
        if p.dropped_at.contains(receiver) {
            self.stats.channels.entry(p.link).or_default().frames_lost += frames;
            return true;
        }
        if !p.cfg.loss_per_robot {
            return self.lose_frames(p.link, p.cfg.loss, frames) > 0;
        }
        let robot = receiver.robot_path();
        if let Some(lost) = p.robot_lost.get(robot) {
            return *lost;
        }
        let lost = self.lose_frames(p.link, p.cfg.loss, frames) > 0;
        p.robot_lost.insert(robot.to_owned(), lost);
        lost
    }

    /// Reliable and in order to the current endpoint at `to`: lost attempts are
    /// retransmitted after the RTO, each occupying the transmitter again.
    pub fn send(
        &mut self,
        from: usize,
        to: &Address,
        kind: MsgKind,
        payload: &[u8],
    ) -> Result<(), SendError> {
        let sender = self.check_send(from, payload)?;
        let link = LinkKind::between(&sender, to);
        self.endpoints[from].stats.sent(link, kind, payload.len());
        let Some(target) = self.current.get(to).copied() else {
            return Ok(());
        };
        let cfg = self.link_config(link);
        if self.drop_if_queue_full(from, link, &cfg) {
            return Ok(());
        }
        let frames = cfg.frame_count(payload.len());
        let (attempts, delivered) = self.attempts(link, cfg.loss, frames);
        let (start, airtime) = self.transmit(from, link, &cfg, payload.len(), attempts);
        self.count_attempts(&sender, to, kind, payload.len(), attempts, delivered);
        if !delivered {
            return Ok(());
        }
        let rto = self.config.rto * (attempts - 1);
        let at = start + airtime + rto + cfg.delay + self.rng.duration(cfg.jitter);
        let action = Action::Deliver {
            from: sender,
            to: target,
            kind,
            payload: payload.into(),
            reliable_from: Some(from),
        };
        self.schedule_in_order(from, target, at, action);
        Ok(())
    }

    /// Schedules a reliable delivery no earlier than the previous one on its pair of
    /// endpoints: reliable sends arrive in order.
    fn schedule_in_order(&mut self, from: usize, to: usize, at: Duration, action: Action) {
        let tail = self.reliable_tail.entry((from, to)).or_default();
        let at = at.max(*tail + Duration::from_nanos(1));
        *tail = at;
        self.schedule(at, action);
    }

    fn count_attempts(
        &mut self,
        from: &Address,
        to: &Address,
        kind: MsgKind,
        len: usize,
        attempts: u32,
        delivered: bool,
    ) {
        let counter = self.links.link(from, to, kind);
        counter.sent_msgs += u64::from(attempts);
        counter.sent_bytes += len as u64 * u64::from(attempts);
        counter.retransmits += u64::from(attempts - 1);
        if !delivered {
            counter.lost += 1;
        }
    }

    /// How many attempts a reliable send of `frames` frames takes, and whether the last
    /// one got through (every frame of it).
    fn attempts(&mut self, link: LinkKind, loss: f64, frames: u64) -> (u32, bool) {
        let max = self.config.max_attempts.max(1);
        for n in 1..=max {
            if self.lose_frames(link, loss, frames) == 0 {
                return (n, true);
            }
        }
        (max, false)
    }

    /// A reliable send that met a cut its sender has not noticed (the lease has not run
    /// out: the sender still holds the addressee up) is retransmitted after the retry
    /// timeout, as a reliable transport keeps trying a peer it holds reachable; once the
    /// sender holds it down, the send is dropped. Publications are never retried.
    fn retry_across_cut(
        &mut self,
        from: &Address,
        to: usize,
        kind: MsgKind,
        payload: Arc<[u8]>,
        reliable_from: Option<usize>,
    ) {
        let receiver = &self.endpoints[to].address;
        let Some(sender) = reliable_from.filter(|&s| self.endpoints[s].view.contains_key(receiver))
        else {
            return;
        };
        let at = self.now + self.config.rto;
        let action = Action::Deliver {
            from: from.clone(),
            to,
            kind,
            payload,
            reliable_from,
        };
        self.schedule_in_order(sender, to, at, action);
    }

    /// Takes a delivery: counts it, or drops it if the receiver is dead or cut off, or
    /// if it is a reliable send whose sender died before it got through (a dead process
    /// retransmits nothing).
    pub fn deliver(
        &mut self,
        from: &Address,
        to: usize,
        kind: MsgKind,
        payload: Arc<[u8]>,
        reliable_from: Option<usize>,
    ) -> Option<Call> {
        let ep = &self.endpoints[to];
        let receiver = ep.address.clone();
        let sender_died = reliable_from.is_some_and(|i| !self.endpoints[i].alive);
        if !ep.alive || sender_died {
            self.links.link(from, &receiver, kind).dead += 1;
            return None;
        }
        if self.is_cut(from, &receiver) {
            self.links.link(from, &receiver, kind).cut += 1;
            self.retry_across_cut(from, to, kind, payload, reliable_from);
            return None;
        }
        let counter = self.links.link(from, &receiver, kind);
        counter.delivered_msgs += 1;
        counter.delivered_bytes += payload.len() as u64;
        let ep = &mut self.endpoints[to];
        ep.stats
            .received(LinkKind::between(from, &receiver), kind, payload.len());
        let handler = ep.handler.clone()?;
        Some(Call::Message(handler, from.clone(), payload))
    }
}
