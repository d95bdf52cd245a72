//! [`ZenohTransport`]: a Zenoh session per module.

use std::collections::{BTreeSet, HashMap};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Weak, mpsc};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use parking_lot::{Condvar, Mutex, RwLock};
use rustc_hash::FxHashMap;
use slate_model::Address;
use slate_transport::{Flow, Handler, LinkKind, LinkStats, MsgKind, SendError, Transport};
use zenoh::Wait;
use zenoh::key_expr::KeyExpr;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::{CongestionControl, Reliability};
use zenoh::query::{ConsolidationMode, Query, QueryTarget, Queryable};
use zenoh::sample::{Locality, Sample, SampleKind};

use crate::keys;
use crate::outbox::{Outbox, Refused};

/// Zenoh's role for this node.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    /// Talks to its peers directly (the default: no infrastructure needed).
    #[default]
    Peer,
    /// Routes for others (a team spanning networks).
    Router,
    /// Connects to a router only.
    Client,
}

impl Mode {
    fn name(self) -> &'static str {
        match self {
            Mode::Peer => "peer",
            Mode::Router => "router",
            Mode::Client => "client",
        }
    }
}

/// How to join the network.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ZenohConfig {
    /// Peer, router or client.
    pub mode: Mode,
    /// Endpoints to listen on, like `tcp/127.0.0.1:7447`.
    pub listen: Vec<String>,
    /// Endpoints to connect to.
    pub connect: Vec<String>,
    /// Find peers by UDP multicast scouting (off by default: endpoints are explicit).
    pub multicast_scouting: bool,
    /// A Zenoh config file (JSON5) to start from, read by Zenoh's own loader, so that
    /// routers, client mode, TLS and QUIC certificates, access control and every other
    /// Zenoh setting are written as Zenoh documents them; slate's keys are applied on top
    /// ([`ZenohConfig::to_zenoh`] says which).
    pub file: Option<PathBuf>,
    /// TLS with mutual authentication and access control by identity (`None`: links
    /// neither authenticated nor encrypted). With it, every endpoint must be `tls/` or
    /// `quic/`.
    pub security: Option<crate::Security>,
    /// Beside each `tcp/HOST:PORT` endpoint, a `udp/HOST:PORT` one that carries the team
    /// link's reports and heartbeats (its publications that may be dropped), so that
    /// they cost a radio no TCP acknowledgement; everything else (Zenoh's declarations
    /// and liveliness, direct sends: plans, hellos, catch-up; lossless classes) stays on
    /// TCP. Zenoh chooses the link by a message's reliability ([`udp_beside`]). Ignored
    /// with [`security`](ZenohConfig::security) or when an endpoint is already `udp/`.
    /// A node's default is on (docs/performance.md, *Bytes on the radio*); off here, for
    /// the command line's short sessions.
    pub udp_reports: bool,
}

/// The session could not be opened.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// A configuration value was refused.
    #[error("zenoh configuration {key}: {reason}")]
    Config {
        /// The configuration key.
        key: &'static str,
        /// Zenoh's reason.
        reason: String,
    },
    /// Zenoh failed to open the session or declare what slate needs.
    #[error("zenoh: {0}")]
    Zenoh(String),
    /// An endpoint to listen on or connect to is malformed (checked before Zenoh starts).
    #[error(transparent)]
    Endpoint(#[from] crate::EndpointError),
    /// The Zenoh config file could not be read, or Zenoh refused it.
    #[error("zenoh config file {}: {reason}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// Zenoh's reason, without its source locations.
        reason: String,
    },
    /// A secured session was given an endpoint that is not `tls/` or `quic/`.
    #[error(
        "endpoint {endpoint:?} is not secured: a node with [security] listens and connects only with tls/HOST:PORT or quic/HOST:PORT endpoints (write tls/ in place of tcp/)"
    )]
    Insecure {
        /// The endpoint as given.
        endpoint: String,
    },
}

impl ZenohConfig {
    /// The Zenoh config a session opens with: the [`file`](ZenohConfig::file)'s (Zenoh's
    /// defaults without one), then slate's keys on top, which win over the file's:
    ///
    /// - always: `timestamping/enabled` off (slate stamps its own packets) and
    ///   `transport/link/tx/queue/size/data` 8 (a deeper queue absorbs report bursts);
    /// - `mode`, `listen/endpoints`, `connect/endpoints` and `scouting/multicast/enabled`
    ///   always without a file; with one, only those slate's config gives a value other
    ///   than its default (peer, no endpoints, no multicast scouting), so that a file
    ///   can say client mode, its routers or multicast scouting;
    /// - with a UDP link beside each TCP one ([`ZenohConfig::udp_reports`]): a `udp/`
    ///   endpoint beside each `tcp/` one, `transport/unicast/max_links` 2 (unless a file
    ///   allows more), and without a file `transport/link/tx/lease` 60 s. With
    ///   `max_links` above 1 a node keeps one link of each kind (reliable, best effort)
    ///   to a peer, whatever a file allows: a second TCP path to one peer is not opened
    ///   (vendor/README.md, rule 3).
    ///
    /// ```
    /// let config = slate_zenoh::ZenohConfig {
    ///     listen: vec!["udp/127.0.0.1:7447".into()],
    ///     ..Default::default()
    /// };
    /// let zenoh = config.to_zenoh()?;
    /// assert_eq!(zenoh.get_json("listen/endpoints").unwrap(), r#"["udp/127.0.0.1:7447"]"#);
    /// # Ok::<(), slate_zenoh::OpenError>(())
    /// ```
    pub fn to_zenoh(&self) -> Result<zenoh::Config, OpenError> {
        for endpoint in self.listen.iter().chain(&self.connect) {
            crate::check_endpoint(endpoint)?;
        }
        self.check_secure_endpoints()?;
        let mut c = self.base()?;
        let scouting = self.scouting_unless_named(&c);
        for (key, value) in self.settings(&c).into_iter().chain(scouting) {
            c.insert_json5(key, &value).map_err(|e| OpenError::Config {
                key,
                reason: crate::endpoint::error_text(&e.to_string()),
            })?;
        }
        Ok(c)
    }

    /// Multicast scouting off when a file leaves it unnamed (`null` in `base`): Zenoh's
    /// own default for a peer is on, which links the node to every Zenoh session that
    /// answers on its networks (across a radio, every module of every robot), where
    /// slate's default is to link only to the endpoints it is given.
    fn scouting_unless_named(&self, base: &zenoh::Config) -> Option<(&'static str, String)> {
        let unnamed = base.get_json(MULTICAST_SCOUTING).is_ok_and(|v| v == "null");
        (self.file.is_some() && !self.multicast_scouting && unnamed)
            .then(|| (MULTICAST_SCOUTING, "false".to_owned()))
    }

    /// With [`security`](ZenohConfig::security), every endpoint is `tls/` or `quic/`: a
    /// `tcp/` listener would take links that carry no identity (the access control would
    /// then refuse all they say, as from nobody, which reads like a node that is down).
    fn check_secure_endpoints(&self) -> Result<(), OpenError> {
        if self.security.is_none() {
            return Ok(());
        }
        let plain = self.listen.iter().chain(&self.connect).find(|e| {
            let protocol = e.split_once('/').map_or(e.as_str(), |(p, _)| p);
            !crate::security::SECURE_PROTOCOLS.contains(&protocol)
        });
        match plain {
            Some(e) => Err(OpenError::Insecure {
                endpoint: e.clone(),
            }),
            None => Ok(()),
        }
    }

    /// Whether a UDP link goes beside each TCP one ([`ZenohConfig::udp_reports`]): asked
    /// for, not secured (a `udp/` link would carry no identity), and no endpoint is
    /// `udp/` already (the user chose datagrams for everything).
    fn udp_beside_tcp(&self) -> bool {
        self.udp_reports && self.security.is_none() && !self.has_udp_endpoint()
    }

    /// Is one of the endpoints listened on or connected to a `udp/` one?
    fn has_udp_endpoint(&self) -> bool {
        let mut endpoints = self.listen.iter().chain(&self.connect);
        endpoints.any(|e| e.starts_with("udp/"))
    }

    /// The file's config, or Zenoh's defaults.
    fn base(&self) -> Result<zenoh::Config, OpenError> {
        let Some(path) = &self.file else {
            return Ok(zenoh::Config::default());
        };
        zenoh::Config::from_file(path).map_err(|e| OpenError::File {
            path: path.clone(),
            reason: crate::endpoint::error_text(&e.to_string()),
        })
    }

    /// slate's keys and their values (JSON5), as [`ZenohConfig::to_zenoh`] applies them
    /// over `base` (the file's config, or Zenoh's defaults).
    fn settings(&self, base: &zenoh::Config) -> Vec<(&'static str, String)> {
        let json = |v: &[String]| {
            let items: Vec<String> = v.iter().map(|e| format!("{e:?}")).collect();
            format!("[{}]", items.join(","))
        };
        let all = self.file.is_none();
        let mut settings = Vec::new();
        if all || self.mode != Mode::Peer {
            settings.push(("mode", format!("{:?}", self.mode.name())));
        }
        let beside = self.udp_beside_tcp();
        let (listen, connect) = if beside {
            (
                udp_beside(&self.listen, ""),
                udp_beside(&self.connect, UDP_CONNECT_RETRY),
            )
        } else {
            (self.listen.clone(), self.connect.clone())
        };
        if all || !listen.is_empty() {
            settings.push(("listen/endpoints", json(&listen)));
        }
        if all || !connect.is_empty() {
            settings.push(("connect/endpoints", json(&connect)));
        }
        if beside {
            // A peer's TCP and UDP links in (and as many out): Zenoh's default takes one.
            // A file that allows more keeps its value.
            let links = base.get_json(MAX_LINKS).ok();
            if links.and_then(|v| v.parse::<usize>().ok()).unwrap_or(1) < 2 {
                settings.push((MAX_LINKS, "2".to_owned()));
            }
            if all {
                // An idle link sends a keep-alive every lease / 4: TCP's, and its
                // acknowledgement, are most of an idle radio's bytes once the heartbeats
                // go over UDP. A file's lease stands.
                settings.push(("transport/link/tx/lease", UDP_BESIDE_LEASE_MS.to_string()));
            }
        }
        if all || self.multicast_scouting {
            let on = self.multicast_scouting.to_string();
            settings.push((MULTICAST_SCOUTING, on));
        }
        // Reports are published with congestion control `Drop`: a burst larger than
        // the link's queue of batches (2 by default) loses reports, which receivers
        // then recover by catching up, a slow path. A deeper queue (allocated only
        // when used) absorbs the bursts of a busy writer and a descheduled sender.
        settings.push(("transport/link/tx/queue/size/data", "8".to_owned()));
        // slate stamps its own packets (hybrid logical clock); Zenoh need not add bytes.
        let off = "{ router: false, peer: false, client: false }".to_owned();
        settings.push(("timestamping/enabled", off));
        if let Some(security) = &self.security {
            settings.extend(security.settings());
        }
        settings
    }
}

/// Zenoh's key for finding peers by UDP multicast.
const MULTICAST_SCOUTING: &str = "scouting/multicast/enabled";

/// Zenoh's key for the links a peer may open to this session.
const MAX_LINKS: &str = "transport/unicast/max_links";

/// Zenoh's lease (ms) when a UDP link goes beside each TCP one and no Zenoh file is
/// given: 60 s, so that an idle TCP link sends a keep-alive every 15 s, not every 2.5 s
/// (Zenoh's default lease is 10 s). slate's heartbeats, not Zenoh's lease, judge whether
/// a module lives (docs/ici.md, *Liveliness*); a link that closes (a process that exits)
/// is still seen at once. docs/performance.md, *Bytes on the radio*, has the figures.
const UDP_BESIDE_LEASE_MS: u64 = 60_000;

/// `endpoints` with a `udp/` endpoint beside each `tcp/` one, at the same address
/// ([`ZenohConfig::udp_reports`]). Zenoh sends a message on a link whose reliability is
/// the message's (a TCP link is reliable, a plain UDP one best effort), else on any link:
/// the publications marked best effort ([`Inner::publisher`]) take the UDP link when it
/// is up, and TCP otherwise (a peer that listens on TCP only, or before the UDP link is
/// open). A reliable message would take the UDP link were it a peer's only one: the
/// workspace's patched Zenoh transport (vendor/README.md) opens a connection on TCP only,
/// lets the UDP link join it after, and closes one left with UDP alone. The UDP endpoint
/// carries no metadata (`udp/...?rel=1` would be a QUIC link), only `config` (Zenoh's
/// endpoint configuration, after `#`).
fn udp_beside(endpoints: &[String], config: &str) -> Vec<String> {
    let mut out = Vec::with_capacity(endpoints.len() * 2);
    for e in endpoints {
        out.push(e.clone());
        let parsed = e.parse::<zenoh::config::EndPoint>();
        if let Some(tcp) = parsed.ok().filter(|p| p.protocol().as_str() == "tcp") {
            out.push(format!("udp/{}{config}", tcp.address()));
        }
    }
    out
}

/// The retry of a UDP link connected beside a TCP one: Zenoh's connector tries again
/// 100 ms after a refusal, then (with Zenoh's defaults) twice as long each time up to
/// 4 s; the connect retry's start is otherwise 1 s. The patched transport refuses the UDP link until the TCP link has
/// made the connection, tens of milliseconds after both were tried at once; with 1 s and
/// then 2 s the reports went on TCP for one to three seconds of every new connection
/// (docs/performance.md, *The UDP link and Zenoh's choice of link*). A peer that is down
/// costs three more attempts in its first 2 s, then one every 4 s, as before.
const UDP_CONNECT_RETRY: &str = "#retry_period_init_ms=100";

/// Longest wait, when a link is listened to again, for the modules that publish on it to
/// confirm they know the new subscription ([`keys::sync`]): a peer that has not answered
/// by then (slow or gone) may miss what it publishes meanwhile, which the ICI repairs as
/// it does any loss.
const LISTEN_BARRIER_TIMEOUT: Duration = Duration::from_secs(2);

/// Longest wait, when the transport closes, for its outboxes to hand Zenoh what they hold.
const CLOSE_FLUSH: Duration = Duration::from_millis(500);

/// Key expressions whose source is remembered, at most (a few per peer are used).
const MAX_SOURCES: usize = 4096;

/// Where a message goes.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
enum Dest {
    /// Published on a link kind, dropped when congested ([`Flow::Latest`]) or waited for
    /// ([`Flow::Every`]).
    Publication(LinkKind, Flow),
    /// Sent to one module's inbox.
    Direct(Address),
}

pub(crate) struct Inner {
    address: Address,
    session: zenoh::Session,
    handler: RwLock<Option<Arc<dyn Handler>>>,
    peers: Mutex<BTreeSet<Address>>,
    stats: Mutex<LinkStats>,
    /// The inbox and liveliness subscribers.
    subscribers: Mutex<Vec<Subscriber<()>>>,
    /// The queryable that answers other modules' listen barriers ([`keys::sync`]).
    barrier: Mutex<Option<Queryable<()>>>,
    /// The publication subscriber of each link kind listened to. A link not listened to
    /// has none, so the other sessions route none of its publications here: a module not
    /// listening costs the network nothing (`Transport::listen`).
    listening: Mutex<FxHashMap<LinkKind, Subscriber<()>>>,
    /// A declared publisher per destination (Zenoh resolves its routes once, not on
    /// every put): one per link kind and one per peer.
    publishers: Mutex<FxHashMap<Dest, Arc<Publisher<'static>>>>,
    /// Each live peer's queue of reliable sends ([`Outbox`]), made on first send.
    outboxes: Mutex<FxHashMap<Address, Outbox>>,
    /// The keys of live peers' messages to this module, declared to this session
    /// ([`keys::from_peer`]): a message on a declared key is routed through a table; on
    /// any other, Zenoh matches its key against every subscription (about 10 µs of the
    /// latency on 127.0.0.1). Declared for each robot mate when it comes up, and for a
    /// module of another robot only once a publication of it is heard on the team link
    /// (with the team protocol, only gateways publish there): an empty entry is one
    /// being declared.
    declared: Mutex<HashMap<Address, Vec<KeyExpr<'static>>>>,
    /// Peers up (`true`) and down, for the thread that declares their keys: a
    /// declaration made in a Zenoh callback may deadlock.
    declarer: Mutex<Option<Declarer>>,
    /// The sources of the key expressions heard (parsing one on every message cost
    /// several allocations); cleared when it grows past [`MAX_SOURCES`].
    sources: Mutex<FxHashMap<String, Address>>,
    token: Mutex<Option<LivelinessToken>>,
    /// The queue to the delivery thread ([`spawn_inbox`]) and that thread.
    inbox: Mutex<Option<InboxThread>>,
    /// What the delivery thread has to do, and whether a report is being handed over on
    /// Zenoh's thread ([`Inner::hand_over`]).
    gate: Mutex<Gate>,
    /// Notified when the delivery thread took one from the queue: a send that may not be
    /// dropped waits on it for room.
    room: Condvar,
    /// Publications dropped because the delivery queue was full ([`Gate::room`]).
    behind_dropped: AtomicU64,
    /// Some of its endpoints are `udp/`: sends may be lost without retransmission.
    datagrams: bool,
    /// A UDP link goes beside each TCP one: the team link's droppable publications are
    /// marked best effort, which Zenoh sends on it.
    udp_beside_tcp: bool,
    closed: AtomicBool,
}

/// One module's endpoint on a Zenoh network.
pub struct ZenohTransport {
    inner: Arc<Inner>,
}

impl ZenohTransport {
    /// Opens a Zenoh session for `address` and declares its subscriptions and liveliness.
    pub fn open(address: Address, config: &ZenohConfig) -> Result<Arc<ZenohTransport>, OpenError> {
        let zerr = |e: zenoh::Error| OpenError::Zenoh(zenoh_text(&e));
        let session = zenoh::open(config.to_zenoh()?).wait().map_err(zerr)?;
        let inner = Arc::new(Inner {
            address,
            session,
            handler: RwLock::new(None),
            peers: Mutex::new(BTreeSet::new()),
            stats: Mutex::new(LinkStats::default()),
            subscribers: Mutex::new(Vec::new()),
            barrier: Mutex::new(None),
            listening: Mutex::new(FxHashMap::default()),
            publishers: Mutex::new(FxHashMap::default()),
            outboxes: Mutex::new(FxHashMap::default()),
            declared: Mutex::new(HashMap::new()),
            declarer: Mutex::new(None),
            sources: Mutex::new(FxHashMap::default()),
            token: Mutex::new(None),
            inbox: Mutex::new(None),
            gate: Mutex::new(Gate::default()),
            room: Condvar::new(),
            behind_dropped: AtomicU64::new(0),
            datagrams: config.has_udp_endpoint(),
            udp_beside_tcp: config.udp_beside_tcp(),
            closed: AtomicBool::new(false),
        });
        let declarer = spawn_declarer(Arc::downgrade(&inner))
            .map_err(|e| OpenError::Zenoh(format!("cannot start a thread: {e}")))?;
        *inner.declarer.lock() = Some(declarer);
        let inbox = spawn_inbox(Arc::downgrade(&inner))
            .map_err(|e| OpenError::Zenoh(format!("cannot start a thread: {e}")))?;
        *inner.inbox.lock() = Some(inbox);
        declare(&inner).map_err(zerr)?;
        Ok(Arc::new(ZenohTransport { inner }))
    }

    /// The Zenoh session (for tools that need more than the transport trait).
    pub fn session(&self) -> &zenoh::Session {
        &self.inner.session
    }
}

/// Declares the subscriptions (robot and team publications, the inbox), the listen
/// barrier and liveliness.
fn declare(inner: &Arc<Inner>) -> zenoh::Result<()> {
    for link in [LinkKind::Robot, LinkKind::Team] {
        let sub = subscribe(
            inner,
            keys::publications_for(&inner.address, link),
            Some(link),
        )?;
        inner.listening.lock().insert(link, sub);
    }
    let inbox = subscribe(inner, keys::inbox(&inner.address), None)?;
    let alive = watch_liveliness(inner)?;
    *inner.subscribers.lock() = vec![inbox, alive];
    *inner.barrier.lock() = Some(declare_barrier(&inner.session, &inner.address)?);
    *inner.token.lock() = Some(
        inner
            .session
            .liveliness()
            .declare_token(keys::alive(&inner.address))
            .wait()?,
    );
    Ok(())
}

/// A subscriber on `key` whose samples `inner` receives as publications on `link`, or as
/// direct sends when `link` is `None`.
fn subscribe(
    inner: &Arc<Inner>,
    key: String,
    link: Option<LinkKind>,
) -> zenoh::Result<Subscriber<()>> {
    let weak = Arc::downgrade(inner);
    inner
        .session
        .declare_subscriber(key)
        .callback(move |s: Sample| {
            if let Some(inner) = weak.upgrade() {
                inner.received(&s, link);
            }
        })
        .wait()
}

/// The liveliness subscriber of the team: peers up and down.
fn watch_liveliness(inner: &Arc<Inner>) -> zenoh::Result<Subscriber<()>> {
    let weak = Arc::downgrade(inner);
    inner
        .session
        .liveliness()
        .declare_subscriber(keys::alive_in(inner.address.team()))
        .history(true)
        .callback(move |s: Sample| {
            if let Some(inner) = weak.upgrade() {
                inner.liveliness(&s);
            }
        })
        .wait()
}

/// The queryable that answers listen barriers ([`keys::sync`]) with an empty reply. It
/// holds no reference to the transport: answering needs only the session.
fn declare_barrier(session: &zenoh::Session, me: &Address) -> zenoh::Result<Queryable<()>> {
    let key = keys::sync(me);
    let reply_key = key.clone();
    session
        .declare_queryable(key)
        .callback(move |q: Query| {
            if let Err(e) = q.reply(reply_key.as_str(), Vec::<u8>::new()).wait() {
                tracing::debug!(error = %e, "listen barrier not answered");
            }
        })
        .wait()
}

/// What the declarer thread does for a peer.
enum Task {
    /// The peer came up (`true`) or went down: declare (robot mates) or drop its keys.
    Keys(bool),
    /// A publication of the peer, a module of another robot, was heard on the team link:
    /// declare its keys.
    Heard,
    /// The peer fell behind (`true`) or caught up with its queue: tell the handler it
    /// is down or up (never from inside a send).
    Congestion(bool),
}

/// The thread that declares peers' keys and reports congestion, and how to tell it.
type Declarer = (mpsc::Sender<(Address, Task)>, JoinHandle<()>);

/// How long a message heard may wait for the delivery thread, about: the queue holds
/// what the handler takes in this time at its measured pace ([`Gate::room`]), and a
/// publication beyond that is dropped, so that what the handler is given is never much
/// older than this (docs/ici.md, *A receiver that falls behind*). A bound in time, not in
/// messages: Zenoh hands over a batch read from TCP (up to 64 KiB: thousands of reports)
/// in one burst, which a fast handler takes in a few milliseconds but which a queue of a
/// few hundred messages dropped most of.
const INBOX_DELAY: Duration = Duration::from_millis(20);

/// The queue holds at least this many messages, however slow the handler (and this many
/// until its pace is measured).
pub(crate) const INBOX_MIN: usize = 256;

/// The queue's floor of [`INBOX_MIN`] messages holds no more than the handler takes in
/// this time at its pace ([`Gate::floor`]): what [`INBOX_MIN`] messages of one update
/// each took a handler of 1 ms an update.
const FLOOR_DELAY: Duration = Duration::from_millis(256);

/// The queue holds at most this many messages, however fast the handler (a bound on its
/// memory; the channel allocates as it fills).
pub(crate) const INBOX_CAPACITY: usize = 16_384;

/// What the delivery thread hands to the handler.
enum Delivery {
    /// A message from a module.
    Message(Address, Vec<u8>),
    /// A peer came up (`true`) or went down.
    Peer(Address, bool),
}

/// The queue to the delivery thread, and the thread.
type InboxThread = (mpsc::Sender<(Instant, Delivery)>, JoinHandle<()>);

/// A report heard less than this after the last one handed over on Zenoh's thread
/// ended goes through the delivery thread: Zenoh is likely draining a backlog (a batch,
/// or bytes that piled up in TCP meanwhile), which the handler must not hold.
const DIRECT_GAP: Duration = Duration::from_micros(50);

/// How long the queue stays at its floor ([`Gate::floor`]) after a publication of [`Flow::Every`] was
/// heard ([`Gate::room`]).
const EVERY_HOLD: Duration = Duration::from_secs(1);

/// The most deliveries the delivery thread times as one run ([`Gate::paced`]).
const PACE_RUN: u32 = 64;

/// How often a send waiting for room in the queue checks that the transport is still open.
const ROOM_CHECK: Duration = Duration::from_millis(100);

/// The delivery thread's work and the direct path's state ([`Inner::hand_over`]).
#[derive(Debug, Default)]
struct Gate {
    /// Deliveries queued or being handled by the delivery thread (it counts one down
    /// only once its handler returned): while one is, a report heard now must not
    /// overtake it on Zenoh's thread.
    queued: usize,
    /// A report is being handed over on a Zenoh thread.
    direct: bool,
    /// When the last direct hand-over ended.
    direct_ended: Option<Instant>,
    /// The handler's time per delivery, a moving average ([`Gate::paced`]); `None`
    /// until one was measured.
    pace: Option<Duration>,
    /// When the delivery the delivery thread is handling was queued (`None`: idle).
    handling: Option<Instant>,
    /// When a publication of [`Flow::Every`] (a back-pressured stream) was last heard.
    every_heard: Option<Instant>,
    /// When a publication of [`Flow::Every`] last waited for room: its writer is held
    /// back by this receiver ([`Gate::admits_droppable`]).
    held_back: Option<Instant>,
    /// Publications of [`Flow::Every`] waiting for room now: no best-effort one takes
    /// the room they wait for.
    holding: usize,
}

/// What a delivery does when the queue is full ([`Inner::hand_over`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Full {
    /// A best-effort publication: it is dropped.
    Drop,
    /// A direct send or a peer event: it waits for room.
    Wait,
    /// A publication of [`Flow::Every`]: it waits for room, and while it does (and for
    /// [`EVERY_HOLD`] after) best-effort publications are queued only into an idle queue.
    HoldBack,
}

impl Gate {
    /// How many deliveries the queue holds at `now`: what the handler takes in
    /// [`INBOX_DELAY`] at its pace, within [`Gate::floor`] and [`INBOX_CAPACITY`]; and
    /// no more than the floor while a back-pressured stream ([`Flow::Every`]) was heard
    /// in the last [`EVERY_HOLD`]: its writer waits on this queue, and Zenoh closes its
    /// link (losing what it buffered) when a put waits longer than its
    /// `wait_before_close`, 5 s ([`Gate::admits_droppable`]).
    fn room(&self, now: Instant) -> usize {
        let floor = self.floor();
        let every = |t: Instant| now.saturating_duration_since(t) < EVERY_HOLD;
        let Some(pace) = self.pace.filter(|_| !self.every_heard.is_some_and(every)) else {
            return floor;
        };
        let n = INBOX_DELAY.as_nanos() / pace.as_nanos().max(1);
        usize::try_from(n).map_or(INBOX_CAPACITY, |n| n.clamp(floor, INBOX_CAPACITY))
    }

    /// The least the queue holds: [`INBOX_MIN`] deliveries, or fewer once the pace is
    /// measured if they would take the handler longer than [`FLOOR_DELAY`] (at least
    /// one). A message may carry many updates (a writer's reports go together when they
    /// come faster than its linger), and 256 of them, 32 ms each with a slow Python
    /// function, were seconds of work in the queue.
    fn floor(&self) -> usize {
        let Some(pace) = self.pace else {
            return INBOX_MIN;
        };
        let n = FLOOR_DELAY.as_nanos() / pace.as_nanos().max(1);
        usize::try_from(n).map_or(INBOX_MIN, |n| n.clamp(1, INBOX_MIN))
    }

    /// May one more delivery be queued at `now`? While there is [`Gate::room`], and the
    /// delivery being handled waited at most [`INBOX_DELAY`] (or fewer than
    /// [`Gate::floor`] wait): the pace is an average, and when some deliveries are much
    /// slower than the others (a Python function on one class), a queue sized by the
    /// average holds far more than its delay's worth of the slow ones.
    fn admits(&self, now: Instant) -> bool {
        let late = |t: Instant| now.saturating_duration_since(t) > INBOX_DELAY;
        self.queued < self.room(now)
            && (self.queued < self.floor() || !self.handling.is_some_and(late))
    }

    /// May a best-effort publication be queued at `now`? As [`Gate::admits`], but while
    /// a back-pressured stream waits for room (and for [`EVERY_HOLD`] after it last
    /// did) only into an idle queue. Its writer blocks on its put until this receiver
    /// has read everything TCP's and Zenoh's buffers hold before it (megabytes on
    /// 127.0.0.1), and Zenoh closes the link when that takes longer than its
    /// `wait_before_close` (5 s), losing the backlog: best-effort publications let into
    /// the queue meanwhile (1 ms each with a slow Python function) made that drain last
    /// tens of seconds. Dropped, they are repaired by catch-up with the latest state.
    fn admits_droppable(&self, now: Instant) -> bool {
        let recent = |t: Instant| now.saturating_duration_since(t) < EVERY_HOLD;
        self.holding == 0
            && self.admits(now)
            && (self.queued == 0 || !self.held_back.is_some_and(recent))
    }

    /// May a delivery that takes a full queue as `full` be queued at `now`?
    fn admits_as(&self, full: Full, now: Instant) -> bool {
        match full {
            Full::Drop => self.admits_droppable(now),
            Full::Wait | Full::HoldBack => self.admits(now),
        }
    }

    /// The delivery thread handled `n` queued deliveries in a row in `took`: the pace
    /// moves an eighth of the way towards `took / n`.
    fn paced(&mut self, n: u32, took: Duration) {
        let each = took / n.max(1);
        self.pace = Some(self.pace.map_or(each, |p| p - p / 8 + each / 8));
    }

    /// May a report be handed over on Zenoh's thread now? Only when the delivery thread
    /// is idle with nothing queued (so nothing heard before it is still waiting: order
    /// holds), no other is being handed over directly, and the last one did not end just
    /// now.
    fn enter_direct(&mut self, now: Instant) -> bool {
        let idle = self.queued == 0 && !self.direct;
        if idle && self.direct_ended.is_none_or(|t| now - t >= DIRECT_GAP) {
            self.direct = true;
            return true;
        }
        false
    }
}

/// A report being handed over on Zenoh's thread: its end is noted when it is dropped,
/// even by a handler that panics, so that later reports are not all sent through the
/// queue for want of it.
struct DirectTurn<'a>(&'a Mutex<Gate>);

impl Drop for DirectTurn<'_> {
    fn drop(&mut self) {
        let mut gate = self.0.lock();
        gate.direct = false;
        gate.direct_ended = Some(Instant::now());
    }
}

/// Starts the delivery thread: it runs the handler for what Zenoh's callbacks heard
/// (but an isolated report, [`Inner::hand_over`]), so that a slow handler (a board
/// whose active functions are slow) does not hold Zenoh's receive threads, whose
/// backlog (in TCP and Zenoh's buffers) would otherwise be drained in full before a
/// catch-up answer behind it. It ends when the transport closes.
fn spawn_inbox(inner: Weak<Inner>) -> std::io::Result<InboxThread> {
    let (tx, rx) = mpsc::channel::<(Instant, Delivery)>();
    let thread = std::thread::Builder::new()
        .name("slate-zenoh-rx".into())
        .spawn(move || {
            // A run: what waits in the queue, handled back to back (at most PACE_RUN),
            // timed as a whole: one clock read per run, not two per delivery.
            while let Ok(first) = rx.recv() {
                let Some(inner) = inner.upgrade() else { return };
                inner.gate.lock().handling = Some(first.0);
                let started = Instant::now();
                let mut n = 0;
                let mut next = Some(first);
                while let Some((_, d)) = next {
                    inner.deliver(d);
                    n += 1;
                    next = if n < PACE_RUN {
                        rx.try_recv().ok()
                    } else {
                        None
                    };
                    let mut gate = inner.gate.lock();
                    gate.queued -= 1;
                    gate.handling = next.as_ref().map(|(queued, _)| *queued);
                    if next.is_none() {
                        gate.paced(n, started.elapsed());
                    }
                    drop(gate);
                    inner.room.notify_all();
                }
            }
        })?;
    Ok((tx, thread))
}

/// Starts the thread that declares (and undeclares) the keys of peers as they come up
/// (and go down), and reports peers that fall behind; it ends when the transport closes.
fn spawn_declarer(inner: Weak<Inner>) -> std::io::Result<Declarer> {
    let (tx, rx) = mpsc::channel::<(Address, Task)>();
    let thread = std::thread::Builder::new()
        .name("slate-zenoh-keys".into())
        .spawn(move || {
            for (peer, task) in rx {
                let Some(inner) = inner.upgrade() else { return };
                match task {
                    Task::Keys(up) => inner.declare_keys(&peer, up),
                    Task::Heard => inner.declare_heard(&peer),
                    Task::Congestion(behind) => inner.report_congestion(&peer, behind),
                }
            }
        })?;
    Ok((tx, thread))
}

impl Inner {
    fn received(&self, s: &Sample, link: Option<LinkKind>) {
        if self.closed.load(Ordering::Acquire) {
            return;
        }
        let publication = link.is_some();
        let Some(from) = self.source(s.key_expr().as_str()) else {
            return;
        };
        if from == self.address {
            return;
        }
        let between = LinkKind::between(&self.address, &from);
        let link = link.unwrap_or(between);
        if link == LinkKind::Team && between == LinkKind::Robot {
            return; // team publications of my own robot's modules are not for me
        }
        if link == LinkKind::Team {
            self.heard_on_team(&from);
        }
        let payload = s.payload().to_bytes();
        let kind = MsgKind::of(&payload);
        self.stats.lock().received(link, kind, payload.len());
        // A publication its publisher sent with `Flow::Every` (Zenoh carries the
        // congestion control with each message) waits for room like a direct send: the
        // wait holds this Zenoh thread, so the link backs up to the publisher, whose
        // blocking put slows it down.
        let full = match (publication, s.congestion_control()) {
            (false, _) => Full::Wait,
            (true, CongestionControl::Drop) => Full::Drop,
            (true, _) => Full::HoldBack,
        };
        if full == Full::HoldBack {
            self.gate.lock().every_heard = Some(Instant::now());
        }
        if self.handler.read().is_some() {
            let direct = publication && kind == MsgKind::Report;
            self.hand_over(Delivery::Message(from, payload.into()), full, direct);
        }
    }

    /// Queues `d` for the delivery thread. A publication finds the queue full when the
    /// handler is [`INBOX_DELAY`] behind at its pace, or what it is handling waited
    /// longer than that ([`Gate::admits`]): it is dropped
    /// (best effort, like Zenoh's own congestion drop: the ICI sees the gap and catches
    /// up with the latest state). A direct send, a publication of [`Flow::Every`] or a
    /// peer event waits for room, as it did when the handler ran on Zenoh's thread.
    ///
    /// A report (`direct`) heard while the delivery thread is idle is handed to the
    /// handler on this (Zenoh's) thread instead: a thread's wake-up less on the path of
    /// an occasional update (docs/performance.md, *Side by side with the peers*). Only
    /// while nothing is queued, so order holds; and not right after another, so a
    /// backlog is drained through the queue, where what the handler cannot take is
    /// dropped, not held in Zenoh's and TCP's buffers ([`Gate::enter_direct`]).
    fn hand_over(&self, d: Delivery, full: Full, direct: bool) {
        let mut now = Instant::now();
        if direct && self.gate.lock().enter_direct(now) {
            let _turn = DirectTurn(&self.gate);
            self.deliver(d);
            return;
        }
        {
            let mut gate = self.gate.lock();
            let mut holding = false;
            while !gate.admits_as(full, now) {
                if full == Full::Drop {
                    drop(gate);
                    let n = self.behind_dropped.fetch_add(1, Ordering::Relaxed) + 1;
                    tracing::debug!(dropped = n, "handler behind: publication dropped");
                    return;
                }
                if self.closed.load(Ordering::Acquire) {
                    gate.holding -= usize::from(holding);
                    return;
                }
                if full == Full::HoldBack {
                    gate.held_back = Some(now);
                    gate.holding += usize::from(!holding);
                    holding = true;
                }
                self.room.wait_for(&mut gate, ROOM_CHECK);
                now = Instant::now();
            }
            gate.holding -= usize::from(holding);
            gate.queued += 1;
        }
        // The gate bounds what the channel holds.
        let sent = match &*self.inbox.lock() {
            Some((tx, _)) => tx.send((now, d)).is_ok(),
            None => false,
        };
        if !sent {
            self.gate.lock().queued -= 1;
        }
    }

    /// Hands one queued delivery to the handler (on the delivery thread).
    fn deliver(&self, d: Delivery) {
        if self.closed.load(Ordering::Acquire) {
            return;
        }
        let Some(h) = self.handler.read().clone() else {
            return;
        };
        match d {
            Delivery::Message(from, payload) => h.message(&from, &payload),
            Delivery::Peer(peer, up) => h.peer(&peer, up),
        }
    }

    /// The module that sent on `key`.
    fn source(&self, key: &str) -> Option<Address> {
        if let Some(a) = self.sources.lock().get(key) {
            return Some(a.clone());
        }
        let a = keys::source(key)?;
        let mut sources = self.sources.lock();
        if sources.len() >= MAX_SOURCES {
            sources.clear();
        }
        sources.insert(key.to_owned(), a.clone());
        Some(a)
    }

    fn liveliness(&self, s: &Sample) {
        let Some(peer) = keys::source(s.key_expr().as_str()) else {
            return;
        };
        if peer == self.address || self.closed.load(Ordering::Acquire) {
            return;
        }
        let up = s.kind() == SampleKind::Put;
        let (changed, reported_down) = if up {
            (self.peers.lock().insert(peer.clone()), false)
        } else {
            // Its inbox publisher and queue go with it (short-lived observers come and go).
            self.publishers
                .lock()
                .retain(|dest, _| !matches!(dest, Dest::Direct(to) if *to == peer));
            let outbox = self.outboxes.lock().remove(&peer);
            let congested = outbox.is_some_and(|o| o.congested());
            (self.peers.lock().remove(&peer), congested)
        };
        if changed {
            self.tell(&peer, Task::Keys(up));
        }
        // Through the delivery queue, behind the messages heard before it.
        if changed && !reported_down && self.handler.read().is_some() {
            self.hand_over(Delivery::Peer(peer, up), Full::Wait, false);
        }
    }

    /// Hands a task to the declarer thread (gone once the transport closed).
    fn tell(&self, peer: &Address, task: Task) {
        if let Some((tx, _)) = &*self.declarer.lock() {
            let _ = tx.send((peer.clone(), task));
        }
    }

    /// `peer` fell behind (`true`: its queue overflowed) or caught up: the handler hears
    /// it go down or come up, from the declarer thread.
    pub(crate) fn congestion(&self, peer: &Address, behind: bool) {
        self.tell(peer, Task::Congestion(behind));
    }

    /// Tells the handler that `peer`, still live for Zenoh, is down while it falls behind
    /// and up once it has caught up.
    fn report_congestion(&self, peer: &Address, behind: bool) {
        if behind {
            tracing::warn!(peer = %peer, "peer not reading what it is sent: dropped until it catches up");
        }
        if !self.peers.lock().contains(peer) || self.closed.load(Ordering::Acquire) {
            return;
        }
        let handler = self.handler.read().clone();
        if let Some(h) = handler {
            h.peer(peer, !behind);
        }
    }

    /// The peers live for Zenoh that keep up with what they are sent.
    fn peers_up(&self) -> Vec<Address> {
        let outboxes = self.outboxes.lock();
        let behind = |p: &Address| outboxes.get(p).is_some_and(Outbox::congested);
        let peers = self.peers.lock();
        peers.iter().filter(|p| !behind(p)).cloned().collect()
    }

    /// A publication of `from` (another robot's module, live or not yet seen up) was
    /// heard on the team link: has the declarer declare its keys, once while it is up.
    fn heard_on_team(&self, from: &Address) {
        if !self.peers.lock().contains(from) {
            return; // asked again at its next publication once it is up
        }
        let mut declared = self.declared.lock();
        if declared.contains_key(from) {
            return;
        }
        declared.insert(from.clone(), Vec::new());
        drop(declared);
        self.tell(from, Task::Heard);
    }

    /// Declares the keys of `peer`'s messages to this module when it comes up (`up`) if
    /// it is a robot mate, or drops them when it goes down. A module of another robot has
    /// its keys declared once it is heard on the team link ([`Inner::declare_heard`]).
    fn declare_keys(&self, peer: &Address, up: bool) {
        if !up {
            let gone = self.declared.lock().remove(peer);
            drop(gone); // undeclares, outside the lock
            return;
        }
        if LinkKind::between(&self.address, peer) == LinkKind::Robot {
            self.declare_peer_keys(peer);
        }
    }

    /// Declares the keys of `peer`, heard on the team link, if it is still up. A later
    /// down event of the peer runs on the same thread, after this, and drops them.
    fn declare_heard(&self, peer: &Address) {
        if self.peers.lock().contains(peer) {
            self.declare_peer_keys(peer);
        } else {
            self.declared.lock().remove(peer);
        }
    }

    /// Declares the keys ([`keys::from_peer`]) of `peer`'s messages to this module.
    fn declare_peer_keys(&self, peer: &Address) {
        if self.closed.load(Ordering::Acquire) {
            return;
        }
        let mut declared = Vec::new();
        for key in keys::from_peer(&self.address, peer) {
            match self.session.declare_keyexpr(key).wait() {
                Ok(k) => declared.push(k),
                Err(e) => tracing::debug!(peer = %peer, error = %e, "key not declared"),
            }
        }
        self.declared.lock().insert(peer.clone(), declared);
    }

    /// Starts (`on`) or stops receiving the publications on `link` by declaring or
    /// undeclaring its subscriber: the other sessions stop routing them here, so not
    /// listening costs the network nothing. Listening again returns once the modules that
    /// publish on `link` know the subscription ([`Inner::barrier`]).
    fn listen(self: &Arc<Self>, link: LinkKind, on: bool) -> bool {
        if self.closed.load(Ordering::Acquire) {
            return true;
        }
        if !on {
            let sub = self.listening.lock().remove(&link);
            if let Some(sub) = sub {
                let _ = sub.undeclare().wait();
            }
            return true;
        }
        if self.listening.lock().contains_key(&link) {
            return true;
        }
        self.resubscribe(link);
        true
    }

    /// Declares `link`'s subscriber again and waits for the publishers to know it.
    fn resubscribe(self: &Arc<Self>, link: LinkKind) {
        match subscribe(
            self,
            keys::publications_for(&self.address, link),
            Some(link),
        ) {
            Ok(sub) => {
                self.listening.lock().insert(link, sub);
                self.barrier(link);
            }
            Err(e) => tracing::warn!(link = link.name(), error = %zenoh_text(&e), "cannot listen"),
        }
    }

    /// Waits (at most [`LISTEN_BARRIER_TIMEOUT`]) until every module publishing on `link`
    /// has answered a query sent after the subscriber's declaration. Zenoh processes a
    /// link's messages in order, so a module that answered holds the declaration and
    /// routes its next publications here. Without it, a publication made just after
    /// `listen` returned would be routed by the old tables and missed.
    fn barrier(&self, link: LinkKind) {
        let replies = self
            .session
            .get(keys::sync_for(&self.address, link))
            .target(QueryTarget::All)
            .consolidation(ConsolidationMode::None)
            .allowed_destination(Locality::Remote)
            .timeout(LISTEN_BARRIER_TIMEOUT)
            .wait();
        match replies {
            Ok(replies) => while replies.recv().is_ok() {},
            Err(e) => tracing::debug!(error = %zenoh_text(&e), "listen barrier not sent"),
        }
    }

    /// Publishes on `link`: Zenoh drops it if the link is congested ([`Flow::Latest`]),
    /// or waits for room ([`Flow::Every`]).
    fn put(
        &self,
        link: LinkKind,
        kind: MsgKind,
        payload: &[u8],
        flow: Flow,
    ) -> Result<(), SendError> {
        self.check(payload)?;
        let publisher = self.publisher(Dest::Publication(link, flow))?;
        publisher
            .put(payload.to_vec())
            .wait()
            .map_err(send_failed)?;
        self.stats.lock().sent(link, kind, payload.len());
        Ok(())
    }

    /// Queues a reliable send to `to` on its outbox: never blocks on a slow peer.
    fn send_to(
        self: &Arc<Self>,
        to: &Address,
        kind: MsgKind,
        payload: &[u8],
    ) -> Result<(), SendError> {
        self.check(payload)?;
        let mut outboxes = self.outboxes.lock();
        if !outboxes.contains_key(to) {
            let publisher = self.publisher(Dest::Direct(to.clone()))?;
            let outbox = Outbox::open(to.clone(), publisher, Arc::downgrade(self))
                .map_err(|e| SendError::Failed(format!("cannot start a thread: {e}")))?;
            outboxes.insert(to.clone(), outbox);
        }
        let outbox = outboxes.get(to).ok_or(SendError::Closed)?;
        match outbox.offer(payload.to_vec(), || self.congestion(to, true)) {
            Ok(()) => {
                let link = LinkKind::between(&self.address, to);
                self.stats.lock().sent(link, kind, payload.len());
                Ok(())
            }
            Err(refused) => {
                self.stats.lock().refused += 1;
                Err(SendError::Congested {
                    peer: to.to_string(),
                    overflowed: refused == Refused::Overflowed,
                })
            }
        }
    }

    /// Refuses a send on a closed endpoint or of a payload over the limit.
    fn check(&self, payload: &[u8]) -> Result<(), SendError> {
        if self.closed.load(Ordering::Acquire) {
            return Err(SendError::Closed);
        }
        if payload.len() > slate_wire::MAX_MESSAGE_BYTES {
            self.stats.lock().refused += 1;
            return Err(SendError::TooLarge {
                len: payload.len(),
                max: slate_wire::MAX_MESSAGE_BYTES,
            });
        }
        Ok(())
    }

    /// The publisher of `dest`, declared on first use: direct sends (reliable) block
    /// when the link is congested (in their outbox's thread, never the caller's),
    /// publications drop (the ICI catches up from the current state), except those of
    /// [`Flow::Every`], which block in the caller's thread. With a UDP link beside each
    /// TCP one, the team link's dropping publications are best effort: Zenoh sends them
    /// on the UDP link ([`udp_beside`]).
    fn publisher(&self, dest: Dest) -> Result<Arc<Publisher<'static>>, SendError> {
        if let Some(p) = self.publishers.lock().get(&dest) {
            return Ok(p.clone());
        }
        let (key, congestion) = match &dest {
            Dest::Publication(link, flow) => (
                keys::publication(&self.address, *link),
                match flow {
                    Flow::Latest => CongestionControl::Drop,
                    Flow::Every => CongestionControl::Block,
                },
            ),
            Dest::Direct(to) => (keys::direct(to, &self.address), CongestionControl::Block),
        };
        let reliability = match dest {
            Dest::Publication(LinkKind::Team, Flow::Latest) if self.udp_beside_tcp => {
                Reliability::BestEffort
            }
            _ => Reliability::Reliable,
        };
        let publisher = self
            .session
            .declare_publisher(key)
            .congestion_control(congestion)
            .reliability(reliability)
            // This session's own subscriptions drop what it sends: do not route it there.
            .allowed_destination(Locality::Remote)
            .wait()
            .map_err(send_failed)?;
        let publisher = Arc::new(publisher);
        self.publishers.lock().insert(dest, publisher.clone());
        Ok(publisher)
    }
}

impl Transport for ZenohTransport {
    fn address(&self) -> &Address {
        &self.inner.address
    }

    fn set_handler(&self, handler: Arc<dyn Handler>) {
        *self.inner.handler.write() = Some(handler.clone());
        // Peers seen before the handler was installed.
        for p in self.inner.peers_up() {
            handler.peer(&p, true);
        }
    }

    fn publish(&self, link: LinkKind, kind: MsgKind, payload: &[u8]) -> Result<(), SendError> {
        self.inner.put(link, kind, payload, Flow::Latest)
    }

    /// Honoured: [`Flow::Every`] publishes with Zenoh's congestion control `Block` (a put
    /// waits while the link's queue is full, up to Zenoh's `wait_before_close`, 5 s,
    /// after which Zenoh closes the link), and receivers wait for room in their queue to
    /// the handler instead of dropping it.
    fn publish_with(
        &self,
        link: LinkKind,
        kind: MsgKind,
        payload: &[u8],
        flow: Flow,
    ) -> Result<(), SendError> {
        self.inner.put(link, kind, payload, flow)
    }

    fn send(&self, to: &Address, kind: MsgKind, payload: &[u8]) -> Result<(), SendError> {
        self.inner.send_to(to, kind, payload)
    }

    fn peers(&self) -> Vec<Address> {
        self.inner.peers_up()
    }

    fn retransmits(&self) -> bool {
        !self.inner.datagrams
    }

    fn stats(&self) -> LinkStats {
        let mut stats = self.inner.stats.lock().clone();
        stats.behind_dropped = self.inner.behind_dropped.load(Ordering::Relaxed);
        stats
    }

    fn listen(&self, link: LinkKind, on: bool) -> bool {
        self.inner.listen(link, on)
    }

    fn close(&self) {
        if self.inner.closed.swap(true, Ordering::AcqRel) {
            return;
        }
        let declarer = self.inner.declarer.lock().take();
        if let Some((tx, thread)) = declarer {
            drop(tx);
            if thread.thread().id() != std::thread::current().id() {
                let _ = thread.join();
            }
        }
        let inbox = self.inner.inbox.lock().take();
        if let Some((tx, thread)) = inbox {
            drop(tx);
            if thread.thread().id() != std::thread::current().id() {
                let _ = thread.join();
            }
        }
        // What the outboxes hold goes first (for a while), and nothing after the token is
        // withdrawn: a peer that heard a message after this module's down would take it
        // for alive again, until its timeout (a plan's origin then waited that long to
        // hear `destination lost`).
        // Taken out of the map first: no lock is held while they drain. Dropped, an
        // outbox sends nothing more (a thread stuck in a congested put ends when Zenoh
        // gives up on it).
        let outboxes = std::mem::take(&mut *self.inner.outboxes.lock());
        let flushed_by = Instant::now() + CLOSE_FLUSH;
        for outbox in outboxes.values() {
            outbox.wait_empty(flushed_by);
        }
        drop(outboxes);
        self.inner.publishers.lock().clear();
        if let Some(token) = self.inner.token.lock().take() {
            let _ = token.undeclare().wait();
        }
        for sub in self.inner.subscribers.lock().drain(..) {
            let _ = sub.undeclare().wait();
        }
        let listening: Vec<_> = self
            .inner
            .listening
            .lock()
            .drain()
            .map(|(_, s)| s)
            .collect();
        for sub in listening {
            let _ = sub.undeclare().wait();
        }
        if let Some(barrier) = self.inner.barrier.lock().take() {
            let _ = barrier.undeclare().wait();
        }
        let declared = std::mem::take(&mut *self.inner.declared.lock());
        drop(declared);
        let _ = self.inner.session.close().wait();
    }
}

impl Drop for ZenohTransport {
    fn drop(&mut self) {
        self.close();
    }
}

/// Zenoh's message of `e`, without the source locations it appends.
fn zenoh_text(e: &zenoh::Error) -> String {
    crate::endpoint::error_text(&e.to_string())
}

/// A put Zenoh refused.
fn send_failed(e: zenoh::Error) -> SendError {
    SendError::Failed(zenoh_text(&e))
}

#[cfg(test)]
mod tests {
    use std::net::TcpListener;
    use std::time::{Duration, Instant};

    use super::*;

    /// Zenoh's TCP links must close without lingering: a lingering close of a link to
    /// an unreachable peer blocks one of Zenoh's receive threads, and every other link
    /// of the session goes deaf meanwhile (docs/real-links.md). zenoh-link-tcp reads the
    /// setting when it is compiled, from the environment `.cargo/config.toml` gives every
    /// crate of this build, this one included.
    #[test]
    fn zenoh_tcp_links_are_built_to_close_without_lingering() {
        assert_eq!(option_env!("TCP_LINGER_TIMEOUT"), Some("0"));
    }

    #[test]
    fn a_report_is_handed_over_on_zenohs_thread_only_when_nothing_waits_or_just_went() {
        let t0 = Instant::now();
        let mut gate = Gate::default();
        assert!(gate.enter_direct(t0), "idle");
        assert!(!gate.enter_direct(t0), "another is being handed over");
        gate.direct = false;
        gate.direct_ended = Some(t0);
        let soon = t0 + DIRECT_GAP / 2;
        assert!(!gate.enter_direct(soon), "right after the last: a backlog");
        let later = t0 + DIRECT_GAP;
        gate.queued = 1;
        assert!(!gate.enter_direct(later), "something queued goes first");
        gate.queued = 0;
        assert!(gate.enter_direct(later));
    }

    #[test]
    fn the_queue_holds_what_the_handler_takes_in_its_delay() {
        let t0 = Instant::now();
        let mut gate = Gate::default();
        assert_eq!(gate.room(t0), INBOX_MIN, "pace not measured yet");
        // A board taking 5 µs a report: a burst of 1 600 reports from one Zenoh batch
        // waits, where a queue of INBOX_MIN dropped most of it.
        gate.paced(64, Duration::from_micros(5 * 64));
        assert_eq!(gate.room(t0), 4_000);
        gate.queued = 1_600;
        gate.handling = Some(t0);
        assert!(gate.admits(t0), "a batch's burst is queued whole");
        gate.queued = 4_000;
        assert!(!gate.admits(t0), "20 ms behind at its pace: dropped");
        // A slow handler (a Python function taking 1 ms): no more than before.
        for _ in 0..100 {
            gate.paced(1, Duration::from_millis(1));
        }
        assert_eq!(gate.room(t0), INBOX_MIN);
        gate.queued = INBOX_MIN;
        assert!(!gate.admits(t0));
        // A handler faster than the queue's memory bound allows for.
        gate.pace = Some(Duration::ZERO);
        assert_eq!(gate.room(t0), INBOX_CAPACITY);
        // A back-pressured stream heard: as before, for a while.
        gate.every_heard = Some(t0);
        assert_eq!(gate.room(t0 + EVERY_HOLD / 2), INBOX_MIN);
        assert_eq!(gate.room(t0 + EVERY_HOLD), INBOX_CAPACITY);
    }

    #[test]
    fn the_queues_floor_is_no_more_than_its_delay_of_slow_messages() {
        // Reports that carry 32 updates each, 1 ms each with a slow Python function: 256
        // of them were 8 s of work in the queue, and a catch-up answer waited behind it.
        let t0 = Instant::now();
        let mut gate = Gate::default();
        for _ in 0..100 {
            gate.paced(1, Duration::from_millis(32));
        }
        assert_eq!(gate.floor(), 8, "FLOOR_DELAY at 32 ms a message");
        assert_eq!(gate.room(t0), 8);
        gate.queued = 8;
        assert!(!gate.admits(t0));
        // However slow, one.
        gate.pace = Some(Duration::from_secs(2));
        assert_eq!(gate.room(t0), 1);
        gate.queued = 0;
        assert!(gate.admits(t0));
    }

    #[test]
    fn a_queue_whose_head_waited_past_the_delay_admits_no_more_than_the_minimum() {
        // Fast on average, but what is handled now waited longer than the delay (slow
        // deliveries among fast ones): room by the pace, but no more than INBOX_MIN.
        let t0 = Instant::now();
        let mut gate = Gate::default();
        gate.paced(64, Duration::from_micros(5 * 64));
        gate.queued = 1_000;
        gate.handling = Some(t0);
        assert!(gate.admits(t0 + INBOX_DELAY));
        assert!(!gate.admits(t0 + INBOX_DELAY + Duration::from_millis(1)));
        gate.queued = INBOX_MIN - 1;
        assert!(
            gate.admits(t0 + Duration::from_secs(1)),
            "the minimum always"
        );
        gate.queued = 1_000;
        gate.handling = None;
        assert!(
            gate.admits(t0 + Duration::from_secs(1)),
            "idle: nothing waited"
        );
    }

    #[test]
    fn while_a_back_pressured_stream_waits_for_room_other_publications_are_queued_only_into_an_idle_queue()
     {
        // A lossless writer blocks on its put until this receiver has drained all that
        // TCP and Zenoh buffered before it (megabytes); after Zenoh's wait_before_close
        // (5 s) Zenoh closes the link and the backlog is lost. Ordinary reports let into
        // the queue meanwhile (1 ms each with a slow Python function) made that drain
        // last tens of seconds (the lossless test of test_overload.py).
        let t0 = Instant::now();
        let mut gate = Gate {
            queued: 10,
            ..Gate::default()
        };
        assert!(gate.admits_droppable(t0), "room, nothing held back");
        gate.held_back = Some(t0);
        assert!(!gate.admits_droppable(t0), "a lossless publication waited");
        assert!(gate.admits(t0), "it is queued as soon as there is room");
        gate.queued = 0;
        assert!(gate.admits_droppable(t0), "an idle queue takes one");
        gate.queued = 10;
        assert!(!gate.admits_droppable(t0 + EVERY_HOLD / 2));
        assert!(
            gate.admits_droppable(t0 + EVERY_HOLD),
            "not held back for a while"
        );
        // One waits now: the room it waits for is its own, even in an idle queue.
        gate.holding = 1;
        gate.queued = 0;
        assert!(!gate.admits_droppable(t0 + EVERY_HOLD));
        assert!(gate.admits(t0 + EVERY_HOLD));
    }

    #[test]
    fn a_direct_hand_over_that_panics_still_ends() {
        let gate = Mutex::new(Gate::default());
        let t0 = Instant::now();
        assert!(gate.lock().enter_direct(t0));
        let panicked = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let _turn = DirectTurn(&gate);
            panic!("a handler's bug");
        }));
        assert!(panicked.is_err());
        let later = Instant::now() + DIRECT_GAP;
        assert!(
            gate.lock().enter_direct(later),
            "the next report may go direct"
        );
    }

    #[test]
    fn a_malformed_endpoint_is_refused_with_the_form_to_write() {
        let config = ZenohConfig {
            connect: vec!["tcp/127.0.0.1:7447".into(), "bogus".into()],
            ..ZenohConfig::default()
        };
        let address = Address::new("t/r1/a").unwrap();
        let Err(e) = ZenohTransport::open(address, &config) else {
            panic!("a malformed endpoint was accepted");
        };
        let text = e.to_string();
        assert!(text.contains("\"bogus\" is not PROTOCOL/ADDRESS"), "{text}");
        assert!(text.contains("tcp/127.0.0.1:7447"), "{text}");
        assert!(
            !text.contains("Json5Err") && !text.contains(".cargo"),
            "{text}"
        );
    }

    #[test]
    fn udp_reports_puts_a_udp_endpoint_beside_each_tcp_one() {
        let config = ZenohConfig {
            listen: vec!["tcp/10.0.0.1:7447".into()],
            connect: vec![
                "tcp/10.0.0.2:7447".into(),
                "tcp/10.0.0.3:7447#iface=eth0".into(),
                "unixsock-stream//tmp/s".into(),
            ],
            udp_reports: true,
            ..ZenohConfig::default()
        };
        let zenoh = config.to_zenoh().unwrap();
        assert_eq!(
            zenoh.get_json("listen/endpoints").unwrap(),
            r#"["tcp/10.0.0.1:7447","udp/10.0.0.1:7447"]"#
        );
        assert_eq!(
            zenoh.get_json("connect/endpoints").unwrap(),
            concat!(
                r#"["tcp/10.0.0.2:7447","#,
                r#""udp/10.0.0.2:7447#retry_period_init_ms=100","#,
                r#""tcp/10.0.0.3:7447#iface=eth0","#,
                r#""udp/10.0.0.3:7447#retry_period_init_ms=100","#,
                r#""unixsock-stream//tmp/s"]"#
            )
        );
        assert_eq!(zenoh.get_json("transport/unicast/max_links").unwrap(), "2");
        assert_eq!(zenoh.get_json("transport/link/tx/lease").unwrap(), "60000");
    }

    #[test]
    fn udp_reports_keeps_a_files_max_links_when_it_allows_more_and_raises_a_lower_one() {
        let dir = std::env::temp_dir().join(format!("slate-zenoh-links-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (file_links, want) in [(4, "4"), (1, "2")] {
            let file = dir.join(format!("links-{file_links}.json5"));
            let text = format!("{{ transport: {{ unicast: {{ max_links: {file_links} }} }} }}");
            std::fs::write(&file, text).unwrap();
            let config = ZenohConfig {
                listen: vec!["tcp/10.0.0.1:7447".into()],
                file: Some(file),
                udp_reports: true,
                ..ZenohConfig::default()
            };
            let zenoh = config.to_zenoh().unwrap();
            let links = zenoh.get_json("transport/unicast/max_links").unwrap();
            assert_eq!(links, want, "a file's max_links {file_links}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn udp_reports_leaves_endpoints_alone_when_off_secured_or_already_udp() {
        let off = ZenohConfig {
            connect: vec!["tcp/10.0.0.2:7447".into()],
            ..ZenohConfig::default()
        };
        let udp = ZenohConfig {
            connect: vec!["tcp/10.0.0.2:7447".into(), "udp/10.0.0.2:7448".into()],
            udp_reports: true,
            ..ZenohConfig::default()
        };
        for config in [off, udp] {
            let zenoh = config.to_zenoh().unwrap();
            let want = format!("{:?}", config.connect).replace(", ", ",");
            assert_eq!(zenoh.get_json("connect/endpoints").unwrap(), want);
            assert_eq!(zenoh.get_json("transport/unicast/max_links").unwrap(), "1");
            assert_eq!(zenoh.get_json("transport/link/tx/lease").unwrap(), "10000");
            assert!(!config.udp_beside_tcp());
        }
    }

    #[test]
    fn a_zenoh_file_keeps_what_slate_leaves_at_its_defaults() {
        let dir = slate_testing::temp_dir("zenoh-file");
        let file = dir.join("client.json5");
        let text = r#"{ mode: "client", connect: { endpoints: ["tcp/10.0.0.1:7447"] },
            scouting: { multicast: { enabled: true } } }"#;
        std::fs::write(&file, text).unwrap();
        let config = ZenohConfig {
            file: Some(file.clone()),
            ..ZenohConfig::default()
        };
        let zenoh = config.to_zenoh().unwrap();
        assert_eq!(zenoh.get_json("mode").unwrap(), "\"client\"");
        let connect = zenoh.get_json("connect/endpoints").unwrap();
        assert_eq!(connect, "[\"tcp/10.0.0.1:7447\"]");
        assert_eq!(
            zenoh.get_json("scouting/multicast/enabled").unwrap(),
            "true"
        );
        // Given by slate's config, they win.
        let config = ZenohConfig {
            mode: Mode::Router,
            connect: vec!["tcp/127.0.0.1:7000".into()],
            ..config
        };
        let zenoh = config.to_zenoh().unwrap();
        assert_eq!(zenoh.get_json("mode").unwrap(), "\"router\"");
        let connect = zenoh.get_json("connect/endpoints").unwrap();
        assert_eq!(connect, "[\"tcp/127.0.0.1:7000\"]");
        let missing = ZenohConfig {
            file: Some(dir.join("missing.json5")),
            ..ZenohConfig::default()
        };
        let err = missing.to_zenoh().unwrap_err().to_string();
        assert!(
            err.starts_with("zenoh config file ") && err.contains("missing.json5"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_zenoh_file_that_does_not_name_multicast_scouting_leaves_it_off() {
        // Zenoh's own default (on, for a peer) would link the node to every session that
        // answers on its networks: across a radio, to every module of every robot.
        let dir = slate_testing::temp_dir("zenoh-file-scouting");
        let file = dir.join("lease.json5");
        let text = "{ transport: { link: { tx: { lease: 20000 } } } }";
        std::fs::write(&file, text).unwrap();
        let config = ZenohConfig {
            file: Some(file.clone()),
            ..ZenohConfig::default()
        };
        let zenoh = config.to_zenoh().unwrap();
        assert_eq!(
            zenoh.get_json("scouting/multicast/enabled").unwrap(),
            "false"
        );
        assert_eq!(zenoh.get_json("transport/link/tx/lease").unwrap(), "20000");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    fn wait(mut done: impl FnMut() -> bool) -> bool {
        let end = Instant::now() + Duration::from_secs(10);
        while Instant::now() < end && !done() {
            std::thread::sleep(Duration::from_millis(10));
        }
        done()
    }

    fn free_endpoint() -> String {
        let port = TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .map(|a| a.port())
            .expect("a free port");
        format!("tcp/127.0.0.1:{port}")
    }

    fn open(name: &str, listen: Vec<String>, connect: Vec<String>) -> Arc<ZenohTransport> {
        let config = ZenohConfig {
            listen,
            connect,
            ..ZenohConfig::default()
        };
        ZenohTransport::open(Address::new(name).unwrap(), &config).expect("opens")
    }

    /// How many keys of `peer` `t` has declared.
    fn declared(t: &ZenohTransport, peer: &Address) -> usize {
        t.inner.declared.lock().get(peer).map_or(0, Vec::len)
    }

    #[test]
    fn another_robots_module_has_its_keys_declared_once_heard_on_the_team_link() {
        let endpoint = free_endpoint();
        let a = open("t/r1/a", vec![endpoint.clone()], vec![]);
        let b = open("t/r1/b", vec![], vec![endpoint.clone()]);
        let c = open("t/r2/c", vec![], vec![endpoint]);
        let (b_address, c_address) = (b.address().clone(), c.address().clone());
        assert!(wait(|| a.peers().len() == 2), "a sees b and c");
        assert!(wait(|| declared(&a, &b_address) == 2), "a mate's, at once");
        std::thread::sleep(Duration::from_millis(300));
        assert!(!a.inner.declared.lock().contains_key(&c_address));
        c.publish(LinkKind::Robot, MsgKind::Report, &[0x11])
            .unwrap();
        b.publish(LinkKind::Team, MsgKind::Report, &[0x11]).unwrap();
        std::thread::sleep(Duration::from_millis(300));
        assert!(!a.inner.declared.lock().contains_key(&c_address));
        c.publish(LinkKind::Team, MsgKind::Report, &[0x11]).unwrap();
        assert!(
            wait(|| declared(&a, &c_address) == 2),
            "heard on the team link"
        );
        c.close();
        assert!(wait(|| !a.inner.declared.lock().contains_key(&c_address)));
        b.close();
        a.close();
    }

    #[test]
    fn a_peer_that_leaves_takes_its_keys_and_publishers_along() {
        let endpoint = free_endpoint();
        let a = open("t/r1/a", vec![endpoint.clone()], vec![]);
        let b = open("t/r1/b", vec![], vec![endpoint]);
        let b_address = b.address().clone();
        assert!(wait(|| a.peers().contains(&b_address)), "a sees b");
        assert!(
            wait(|| declared(&a, &b_address) == 2),
            "a declares b's keys"
        );
        assert!(
            wait(|| declared(&b, a.address()) == 2),
            "b declares a's keys"
        );
        a.send(&b_address, MsgKind::Hello, &[0x01]).unwrap();
        a.send(&b_address, MsgKind::Plan, &[0x15]).unwrap();
        a.publish(LinkKind::Robot, MsgKind::Report, &[0x11])
            .unwrap();
        let inboxes = |t: &ZenohTransport| {
            t.inner
                .publishers
                .lock()
                .keys()
                .filter(|d| matches!(d, Dest::Direct(..)))
                .count()
        };
        assert_eq!(
            inboxes(&a),
            1,
            "one publisher per addressee, whatever the kind"
        );
        b.close();
        assert!(wait(|| !a.peers().contains(&b_address)), "a sees b leave");
        assert!(
            wait(|| declared(&a, &b_address) == 0),
            "b's keys are dropped"
        );
        assert_eq!(inboxes(&a), 0, "b's inbox publisher is gone");
        assert_eq!(a.inner.publishers.lock().len(), 1, "the publication stays");
        a.close();
    }
}
