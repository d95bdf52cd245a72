//! The conformance suite every [`Transport`] must pass.
//!
//! An implementation provides a [`TransportFactory`] (a fresh network per test) and
//! instantiates the suite in its tests with [`transport_conformance!`](crate::transport_conformance),
//! one `#[test]` per case, or calls [`run_all`]. The simulator's instantiation is in this
//! crate's `tests/conformance.rs`; a Zenoh transport does the same:
//!
//! ```ignore
//! mod conformance {
//!     slate_transport::transport_conformance!(my_transport::Factory::new());
//! }
//! ```
//!
//! Addresses used: `conf/r1/a`, `conf/r1/b` (one robot) and `conf/r2/c` (another).
//!
//! Compiled only with the crate's `testing` feature: the suite and [`SimFactory`] are
//! test support for transport implementations, not part of the transport API.

use std::sync::Arc;
use std::time::Duration;

use parking_lot::Mutex;
use slate_model::Address;

use crate::{Handler, LinkKind, MsgKind, SendError, SimNet, SimTransport, Transport};

/// Makes endpoints on one fresh network and lets it run.
pub trait TransportFactory {
    /// The transport under test.
    type Transport: Transport + 'static;

    /// A new endpoint at `address`.
    fn join(&mut self, address: &Address) -> Arc<Self::Transport>;

    /// Lets the network run until `done()` holds or the factory's bound passes (virtual
    /// time for a simulator, a few seconds of wall time for a real network); returns
    /// whether `done()` held.
    fn run_until(&mut self, done: &mut dyn FnMut() -> bool) -> bool;

    /// Lets whatever is in flight arrive (a short, bounded while).
    fn settle(&mut self);
}

/// A handler that records everything, for the suite's assertions.
#[derive(Default)]
pub struct Inbox {
    messages: Mutex<Vec<(Address, Vec<u8>)>>,
    peers: Mutex<Vec<(Address, bool)>>,
}

impl Inbox {
    /// The messages received so far, in order.
    pub fn messages(&self) -> Vec<(Address, Vec<u8>)> {
        self.messages.lock().clone()
    }

    /// The peer events received so far, in order.
    pub fn peer_events(&self) -> Vec<(Address, bool)> {
        self.peers.lock().clone()
    }

    /// How many messages arrived.
    pub fn len(&self) -> usize {
        self.messages.lock().len()
    }

    /// Has nothing arrived?
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl Handler for Inbox {
    fn message(&self, from: &Address, payload: &[u8]) {
        self.messages.lock().push((from.clone(), payload.to_vec()));
    }

    fn peer(&self, peer: &Address, up: bool) {
        self.peers.lock().push((peer.clone(), up));
    }
}

/// Three endpoints: `a` and `b` on robot r1, `c` on robot r2, each with an [`Inbox`].
pub struct Trio<T> {
    /// `conf/r1/a`.
    pub a: Arc<T>,
    /// `conf/r1/b`.
    pub b: Arc<T>,
    /// `conf/r2/c`.
    pub c: Arc<T>,
    /// What `a`, `b`, `c` received.
    pub inboxes: [Arc<Inbox>; 3],
}

fn address(text: &str) -> Address {
    Address::new(text).unwrap_or_else(|e| panic!("{text}: {e}"))
}

fn endpoint<F: TransportFactory>(f: &mut F, text: &str) -> (Arc<F::Transport>, Arc<Inbox>) {
    let t = f.join(&address(text));
    let inbox = Arc::new(Inbox::default());
    t.set_handler(inbox.clone());
    (t, inbox)
}

/// Joins the three endpoints and waits until each sees the two others.
pub fn trio<F: TransportFactory>(f: &mut F) -> Trio<F::Transport> {
    let (a, ia) = endpoint(f, "conf/r1/a");
    let (b, ib) = endpoint(f, "conf/r1/b");
    let (c, ic) = endpoint(f, "conf/r2/c");
    let all = [a.clone(), b.clone(), c.clone()];
    let up = f.run_until(&mut || all.iter().all(|t| t.peers().len() == 2));
    assert!(up, "the three endpoints never saw each other");
    Trio {
        a,
        b,
        c,
        inboxes: [ia, ib, ic],
    }
}

/// Every endpoint hears the others come up, through `peers()` and its handler.
pub fn peers_come_up<F: TransportFactory>(f: &mut F) {
    let t = trio(f);
    let mut seen: Vec<Address> = t.a.peers();
    seen.sort();
    assert_eq!(seen, vec![address("conf/r1/b"), address("conf/r2/c")]);
    for inbox in &t.inboxes {
        let ups = inbox.peer_events().iter().filter(|(_, up)| *up).count();
        assert!(ups >= 2, "{:?}", inbox.peer_events());
    }
}

/// A publish on the robot link reaches the robot's other modules, not other robots,
/// not the sender.
pub fn publish_on_the_robot_link_stays_on_the_robot<F: TransportFactory>(f: &mut F) {
    let t = trio(f);
    t.a.publish(LinkKind::Robot, MsgKind::Report, b"robot")
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(f.run_until(&mut || t.inboxes[1].len() == 1));
    f.settle();
    assert_eq!(
        t.inboxes[1].messages(),
        vec![(address("conf/r1/a"), b"robot".to_vec())]
    );
    assert!(t.inboxes[0].is_empty(), "no echo to the sender");
    assert!(
        t.inboxes[2].is_empty(),
        "another robot got a robot-link publish"
    );
}

/// A publish on the team link reaches the other robots' modules only.
pub fn publish_on_the_team_link_reaches_other_robots<F: TransportFactory>(f: &mut F) {
    let t = trio(f);
    t.a.publish(LinkKind::Team, MsgKind::Heartbeat, b"team")
        .unwrap_or_else(|e| panic!("{e}"));
    only_one_arrives(f, &t, 2, ("conf/r1/a", b"team"));
}

/// A send reaches its addressee only, which learns who sent it.
pub fn send_reaches_only_the_addressee<F: TransportFactory>(f: &mut F) {
    let t = trio(f);
    t.c.send(t.b.address(), MsgKind::Plan, b"to b")
        .unwrap_or_else(|e| panic!("{e}"));
    only_one_arrives(f, &t, 1, ("conf/r2/c", b"to b"));
}

/// Waits until the inbox `to` holds a message and the network settles, then asserts
/// that it holds only `(from, payload)` and that the two other inboxes are empty.
fn only_one_arrives<F: TransportFactory>(
    f: &mut F,
    t: &Trio<F::Transport>,
    to: usize,
    (from, payload): (&str, &[u8]),
) {
    assert!(f.run_until(&mut || t.inboxes[to].len() == 1));
    f.settle();
    assert_eq!(
        t.inboxes[to].messages(),
        vec![(address(from), payload.to_vec())]
    );
    assert!((0..3).filter(|&i| i != to).all(|i| t.inboxes[i].is_empty()));
}

/// Sends to one peer arrive once each, in order.
pub fn sends_arrive_once_and_in_order<F: TransportFactory>(f: &mut F) {
    let t = trio(f);
    let n: u32 = 200;
    for i in 0..n {
        t.a.send(t.c.address(), MsgKind::PlanAck, &i.to_be_bytes())
            .unwrap_or_else(|e| panic!("{e}"));
    }
    assert!(f.run_until(&mut || t.inboxes[2].len() >= n as usize));
    f.settle();
    let got: Vec<u32> = t.inboxes[2]
        .messages()
        .iter()
        .map(|(_, p)| u32::from_be_bytes(p[..4].try_into().unwrap_or_default()))
        .collect();
    assert_eq!(got, (0..n).collect::<Vec<_>>());
}

/// Payloads arrive byte for byte up to the wire format's limit; larger ones are refused.
pub fn payloads_arrive_intact_up_to_the_limit<F: TransportFactory>(f: &mut F) {
    let t = trio(f);
    let sizes = [1usize, 1000, slate_wire::MAX_MESSAGE_BYTES];
    let payloads: Vec<Vec<u8>> = sizes
        .iter()
        .map(|n| (0..*n).map(|i| (i * 7 % 251) as u8).collect())
        .collect();
    for p in &payloads {
        t.a.send(t.b.address(), MsgKind::CatchUpAnswer, p)
            .unwrap_or_else(|e| panic!("{e}"));
    }
    assert!(f.run_until(&mut || t.inboxes[1].len() == payloads.len()));
    let got: Vec<Vec<u8>> = t.inboxes[1]
        .messages()
        .into_iter()
        .map(|(_, p)| p)
        .collect();
    assert_eq!(got, payloads);
    let big = vec![0u8; slate_wire::MAX_MESSAGE_BYTES + 1];
    assert!(matches!(
        t.a.send(t.b.address(), MsgKind::CatchUpAnswer, &big),
        Err(SendError::TooLarge { .. })
    ));
}

/// A closed endpoint goes down for its peers, cannot send, and receives nothing more.
pub fn a_closed_endpoint_goes_down_and_goes_quiet<F: TransportFactory>(f: &mut F) {
    let t = trio(f);
    t.c.close();
    let c = address("conf/r2/c");
    assert!(f.run_until(&mut || !t.a.peers().contains(&c) && !t.b.peers().contains(&c)));
    assert!(t.inboxes[0].peer_events().contains(&(c.clone(), false)));
    assert_eq!(
        t.c.send(t.a.address(), MsgKind::Plan, b"x"),
        Err(SendError::Closed)
    );
    t.a.publish(LinkKind::Team, MsgKind::Heartbeat, b"x")
        .unwrap_or_else(|e| panic!("{e}"));
    t.a.send(&c, MsgKind::Plan, b"x")
        .unwrap_or_else(|e| panic!("{e}"));
    f.settle();
    assert!(t.inboxes[2].is_empty());
}

/// Stats count messages and bytes by link kind and message kind, both ways.
pub fn stats_count_traffic_by_link_and_kind<F: TransportFactory>(f: &mut F) {
    let t = trio(f);
    let (s0a, s0c) = (t.a.stats(), t.c.stats());
    t.a.publish(LinkKind::Team, MsgKind::Report, &[1; 10])
        .unwrap_or_else(|e| panic!("{e}"));
    t.a.send(t.c.address(), MsgKind::Plan, &[2; 20])
        .unwrap_or_else(|e| panic!("{e}"));
    t.a.send(t.b.address(), MsgKind::Plan, &[3; 30])
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(f.run_until(&mut || t.inboxes[2].len() == 2 && t.inboxes[1].len() == 1));
    let (sa, sc) = (t.a.stats(), t.c.stats());
    let diff = |a: u64, b: u64| a - b;
    let team_report = sa.get(LinkKind::Team, MsgKind::Report);
    let base = s0a.get(LinkKind::Team, MsgKind::Report);
    assert_eq!(diff(team_report.sent_msgs, base.sent_msgs), 1);
    assert_eq!(diff(team_report.sent_bytes, base.sent_bytes), 10);
    let plan_team = sa.get(LinkKind::Team, MsgKind::Plan);
    assert_eq!(
        diff(
            plan_team.sent_bytes,
            s0a.get(LinkKind::Team, MsgKind::Plan).sent_bytes
        ),
        20
    );
    let plan_robot = sa.get(LinkKind::Robot, MsgKind::Plan);
    assert_eq!(
        diff(
            plan_robot.sent_bytes,
            s0a.get(LinkKind::Robot, MsgKind::Plan).sent_bytes
        ),
        30
    );
    let got = sc.link(LinkKind::Team);
    let before = s0c.link(LinkKind::Team);
    assert_eq!(diff(got.recv_msgs, before.recv_msgs), 2);
    assert_eq!(diff(got.recv_bytes, before.recv_bytes), 30);
}

/// A module that stops listening to the team link gets no team publications, and still
/// gets robot-link publications and sends (team ones included); once it listens again,
/// team publications reach it. A transport whose [`listen`](Transport::listen) returns
/// `false` (it cannot choose what an endpoint hears, the trait's default) skips the case.
pub fn a_module_not_listening_gets_no_team_publications<F: TransportFactory>(f: &mut F) {
    let t = trio(f);
    if !t.a.listen(LinkKind::Team, false) {
        tracing::info!("listen is not supported: case skipped");
        return;
    }
    t.c.publish(LinkKind::Team, MsgKind::Report, b"team 1")
        .unwrap_or_else(|e| panic!("{e}"));
    t.b.publish(LinkKind::Robot, MsgKind::Report, b"robot")
        .unwrap_or_else(|e| panic!("{e}"));
    t.c.send(t.a.address(), MsgKind::Plan, b"sent")
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(f.run_until(&mut || t.inboxes[0].len() == 2 && t.inboxes[1].len() == 1));
    f.settle();
    let mut got: Vec<Vec<u8>> = t.inboxes[0].messages().into_iter().map(|m| m.1).collect();
    got.sort();
    assert_eq!(got, vec![b"robot".to_vec(), b"sent".to_vec()]);
    assert!(t.a.listen(LinkKind::Team, true));
    t.c.publish(LinkKind::Team, MsgKind::Report, b"team 2")
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(f.run_until(&mut || t.inboxes[0].len() == 3));
    assert_eq!(t.inboxes[0].messages()[2].1, b"team 2".to_vec());
}

/// One case of the suite: its name and the test.
pub type Case<F> = (&'static str, fn(&mut F));

/// Every case of the suite, by name.
pub fn cases<F: TransportFactory>() -> Vec<Case<F>> {
    vec![
        ("peers_come_up", peers_come_up::<F>),
        (
            "publish_on_the_robot_link_stays_on_the_robot",
            publish_on_the_robot_link_stays_on_the_robot::<F>,
        ),
        (
            "publish_on_the_team_link_reaches_other_robots",
            publish_on_the_team_link_reaches_other_robots::<F>,
        ),
        (
            "send_reaches_only_the_addressee",
            send_reaches_only_the_addressee::<F>,
        ),
        (
            "sends_arrive_once_and_in_order",
            sends_arrive_once_and_in_order::<F>,
        ),
        (
            "payloads_arrive_intact_up_to_the_limit",
            payloads_arrive_intact_up_to_the_limit::<F>,
        ),
        (
            "a_closed_endpoint_goes_down_and_goes_quiet",
            a_closed_endpoint_goes_down_and_goes_quiet::<F>,
        ),
        (
            "stats_count_traffic_by_link_and_kind",
            stats_count_traffic_by_link_and_kind::<F>,
        ),
        (
            "a_module_not_listening_gets_no_team_publications",
            a_module_not_listening_gets_no_team_publications::<F>,
        ),
    ]
}

/// Runs every case, each on a fresh network from `new`.
pub fn run_all<F: TransportFactory>(mut new: impl FnMut() -> F) {
    for (name, case) in cases::<F>() {
        tracing::info!(case = name, "transport conformance");
        case(&mut new());
    }
}

/// Instantiates the conformance suite: one `#[test]` per case, each on a fresh network
/// made by evaluating `$factory`.
#[macro_export]
macro_rules! transport_conformance {
    ($factory:expr) => {
        $crate::transport_conformance!(@cases $factory;
            peers_come_up,
            publish_on_the_robot_link_stays_on_the_robot,
            publish_on_the_team_link_reaches_other_robots,
            send_reaches_only_the_addressee,
            sends_arrive_once_and_in_order,
            payloads_arrive_intact_up_to_the_limit,
            a_closed_endpoint_goes_down_and_goes_quiet,
            stats_count_traffic_by_link_and_kind,
            a_module_not_listening_gets_no_team_publications
        );
    };
    (@cases $factory:expr; $($case:ident),*) => {
        $(
            #[test]
            fn $case() {
                let mut factory = $factory;
                $crate::conformance::$case(&mut factory);
            }
        )*
    };
}

/// The conformance suite's factory for the simulator: a fresh clean network per test;
/// waits are bounded by 30 s of virtual time, settling is 1 s.
pub struct SimFactory {
    /// The network.
    pub net: SimNet,
}

impl SimFactory {
    /// A factory over a new network with this seed.
    pub fn new(seed: u64) -> Self {
        SimFactory {
            net: SimNet::new(seed),
        }
    }
}

impl TransportFactory for SimFactory {
    type Transport = SimTransport;

    fn join(&mut self, address: &Address) -> Arc<SimTransport> {
        self.net.join(address)
    }

    fn run_until(&mut self, done: &mut dyn FnMut() -> bool) -> bool {
        self.net.run_until(done, Duration::from_secs(30))
    }

    fn settle(&mut self) {
        self.net.run_for(Duration::from_secs(1));
    }
}
