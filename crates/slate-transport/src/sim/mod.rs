//! The deterministic in-process network simulator.
//!
//! One [`SimNet`] holds virtual time (a shared manual [`Clock`]), the endpoints that
//! joined it, and a queue of events (deliveries, liveliness changes) ordered by time
//! with ties broken by a PRNG seeded from the network's seed. Nothing runs by itself:
//! [`SimNet::run_for`] and [`SimNet::run_until`] move time forward event by event (never
//! more than [`SimConfig::step`] at once, so timers on the clock run on time), calling
//! handlers in the caller's thread. Same seed and same calls: same run, same counters.

mod config;
mod net;
mod rng;
mod stats;

use std::sync::Arc;
use std::time::Duration;

use parking_lot::Mutex;
use slate_model::{Address, Clock, MANUAL_EPOCH};

pub use config::{LinkConfig, SimConfig};
use net::{Action, Call, Net};
pub use rng::Rng;
pub use stats::{Channel, LinkCounter, Radio, SimStats};

use crate::{Handler, LinkKind, LinkStats, MsgKind, SendError, Transport};

/// A simulated network with virtual time and seeded faults.
///
/// ```
/// use slate_transport::{LinkKind, MsgKind, SimNet, Transport};
/// use slate_model::Address;
/// use std::time::Duration;
///
/// let net = SimNet::new(42);
/// let a = net.join(&Address::new("team/r1/nav")?);
/// let b = net.join(&Address::new("team/r2/nav")?);
/// net.run_for(Duration::from_millis(100)); // liveliness: they see each other
/// assert_eq!(b.peers(), vec![a.address().clone()]);
/// a.send(b.address(), MsgKind::Plan, b"hello")?;
/// net.run_for(Duration::from_millis(100));
/// assert_eq!(b.stats().get(LinkKind::Team, MsgKind::Plan).recv_msgs, 1);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone)]
pub struct SimNet {
    net: Arc<Mutex<Net>>,
    clock: Clock,
}

impl SimNet {
    /// A network with the default settings (clean links).
    pub fn new(seed: u64) -> Self {
        SimNet::with_config(seed, SimConfig::default())
    }

    /// A network with these settings.
    pub fn with_config(seed: u64, config: SimConfig) -> Self {
        SimNet {
            net: Arc::new(Mutex::new(Net::new(seed, config))),
            clock: Clock::manual(),
        }
    }

    /// The network's clock (manual, virtual time): give it to every board on the network.
    pub fn clock(&self) -> Clock {
        self.clock.clone()
    }

    /// Virtual time since the network was created.
    pub fn now(&self) -> Duration {
        self.net.lock().now
    }

    /// The current settings.
    pub fn config(&self) -> SimConfig {
        self.net.lock().config
    }

    /// Changes the settings from now on (messages in flight keep their fate).
    pub fn set_config(&self, config: SimConfig) {
        self.net.lock().config = config;
    }

    /// Changes one kind of link from now on: messages already on their way keep their
    /// fate, the next ones get the new delay, loss, bandwidth and so on. If the link
    /// becomes shared (or stops being so), what is on the air finishes first.
    pub fn set_link(&self, kind: LinkKind, link: LinkConfig) {
        self.net.lock().set_link(kind, link);
    }

    /// Switches the team link to `link` from now on, e.g. from the deck's fast clean
    /// radio to the mission's radio or acoustic channel (see [`set_link`](Self::set_link)).
    pub fn set_team_link(&self, link: LinkConfig) {
        self.set_link(LinkKind::Team, link);
    }

    /// Test hook: the next team publication of `from` is lost at exactly `receivers`
    /// (addresses of endpoints); every other receiver gets it, or loses it, as the
    /// link's settings draw. A second call before that publication replaces the first.
    #[cfg(feature = "testing")]
    pub fn drop_next_publish(&self, from: &Address, receivers: &[Address]) {
        self.net.lock().drop_next_publish(from, receivers);
    }

    /// Test hook: the transport at `to` tells its handler, now, that `peer` went down,
    /// while the two still reach each other and exchange messages, as Zenoh does when a
    /// liveliness token is withdrawn by a session or route that failed elsewhere. No up
    /// follows: the transport still counts the peer as up.
    #[cfg(feature = "testing")]
    pub fn false_down(&self, to: &Address, peer: &Address) {
        let calls = self.net.lock().false_down(to, peer);
        Self::call(calls);
    }

    /// A new endpoint at `address`. Joining an address already in use restarts it: the
    /// old endpoint is dead from now on, and peers see it go down and come up again.
    pub fn join(&self, address: &Address) -> Arc<SimTransport> {
        let index = self.net.lock().join(address);
        Arc::new(SimTransport {
            net: self.net.clone(),
            index,
            address: address.clone(),
        })
    }

    /// Kills a node: it stops sending and receiving, and its peers see it go down after
    /// the liveliness lease.
    pub fn kill(&self, address: &Address) {
        self.net.lock().set_alive(address, false);
    }

    /// Brings a killed node back (same endpoint, same handler).
    pub fn revive(&self, address: &Address) {
        self.net.lock().set_alive(address, true);
    }

    /// Cuts every link between a member of `a` and a member of `b` until [`heal`](Self::heal).
    pub fn partition(&self, a: &[Address], b: &[Address]) {
        self.net.lock().partition(a, b);
    }

    /// Removes every partition.
    pub fn heal(&self) {
        self.net.lock().heal();
    }

    /// Counters so far.
    pub fn stats(&self) -> SimStats {
        self.net.lock().stats()
    }

    /// The fraction of the time so far that the transmitters of one kind of link spent
    /// on the air (queued transmissions not yet started do not count). For a shared
    /// channel it is at most 1; with a transmitter per sender, it adds theirs.
    pub fn channel_utilisation(&self, link: LinkKind) -> f64 {
        self.net.lock().utilisation(link)
    }

    /// Runs the network for `d` of virtual time.
    pub fn run_for(&self, d: Duration) {
        let end = self.now() + d;
        while self.step(end) {}
    }

    /// Runs until `done()` holds (checked after every step) or `max` of virtual time has
    /// passed; returns whether `done()` held.
    pub fn run_until(&self, mut done: impl FnMut() -> bool, max: Duration) -> bool {
        let end = self.now() + max;
        loop {
            if done() {
                return true;
            }
            if !self.step(end) {
                return done();
            }
        }
    }

    /// Does the next event due by `end` (or moves time one step); false once time is
    /// at `end` and nothing is due.
    fn step(&self, end: Duration) -> bool {
        let (now, at, action) = {
            let mut net = self.net.lock();
            let now = net.now;
            let limit = (now + net.config.step).min(end);
            match net.pop_due(limit) {
                Some((at, action)) => (now, at.max(now), Some(action)),
                None => (now, limit, None),
            }
        };
        if at > now {
            self.net.lock().now = at;
            // Listeners (ICIs) tick in this thread, with no lock held.
            let _ = self.clock.set(MANUAL_EPOCH + at);
        }
        let busy = action.is_some();
        if let Some(action) = action {
            self.perform(action);
        }
        busy || at < end
    }

    fn perform(&self, action: Action) {
        let calls = {
            let mut net = self.net.lock();
            match action {
                Action::Deliver {
                    from,
                    to,
                    kind,
                    payload,
                    reliable_from,
                } => net
                    .deliver(&from, to, kind, payload, reliable_from)
                    .into_iter()
                    .collect(),
                Action::Review { to, peer } => net.review(to, &peer),
            }
        };
        Self::call(calls);
    }

    /// Calls the handlers, with no lock held.
    fn call(calls: Vec<Call>) {
        for call in calls {
            match call {
                Call::Message(handler, from, payload) => handler.message(&from, &payload),
                Call::Peer(handler, peer, up) => handler.peer(&peer, up),
            }
        }
    }
}

/// One endpoint of a [`SimNet`].
pub struct SimTransport {
    net: Arc<Mutex<Net>>,
    index: usize,
    address: Address,
}

impl SimTransport {
    /// Is this endpoint alive (not killed, closed or replaced by a restart)?
    pub fn is_alive(&self) -> bool {
        self.net.lock().endpoints[self.index].alive
    }
}

impl Transport for SimTransport {
    fn address(&self) -> &Address {
        &self.address
    }

    fn set_handler(&self, handler: Arc<dyn Handler>) {
        self.net.lock().endpoints[self.index].handler = Some(handler);
    }

    fn publish(&self, link: LinkKind, kind: MsgKind, payload: &[u8]) -> Result<(), SendError> {
        self.net.lock().publish(self.index, link, kind, payload)
    }

    fn send(&self, to: &Address, kind: MsgKind, payload: &[u8]) -> Result<(), SendError> {
        self.net.lock().send(self.index, to, kind, payload)
    }

    fn peers(&self) -> Vec<Address> {
        let net = self.net.lock();
        net.endpoints[self.index].view.keys().cloned().collect()
    }

    fn stats(&self) -> LinkStats {
        self.net.lock().endpoints[self.index].stats.clone()
    }

    fn close(&self) {
        self.net.lock().close(self.index);
    }

    /// Honoured: an endpoint not listening to a link gets none of its publications
    /// (and is not counted as one of their receivers), but still its sends.
    fn listen(&self, link: LinkKind, on: bool) -> bool {
        self.net.lock().listen(self.index, link, on);
        true
    }
}
