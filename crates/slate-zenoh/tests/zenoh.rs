//! The transport conformance suite, over real Zenoh sessions on 127.0.0.1, and what
//! listening (`Transport::listen`) changes in Zenoh's routing.

use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use slate_model::Address;
use slate_testing::free_port;
use slate_transport::conformance::{Inbox, TransportFactory};
use slate_transport::{LinkKind, MsgKind, Transport};
use slate_zenoh::{ZenohConfig, ZenohTransport};
use zenoh::Wait;
use zenoh::sample::Locality;

/// A fresh Zenoh network per test: every endpoint listens on its own loopback port and
/// connects to the ones before it.
#[derive(Default)]
pub struct Loopback {
    endpoints: Vec<String>,
    /// Each session's `ZenohConfig::udp_reports`.
    udp_reports: bool,
}

impl TransportFactory for Loopback {
    type Transport = ZenohTransport;

    fn join(&mut self, address: &Address) -> Arc<ZenohTransport> {
        let endpoint = format!("tcp/127.0.0.1:{}", free_port());
        let config = ZenohConfig {
            listen: vec![endpoint.clone()],
            connect: self.endpoints.clone(),
            udp_reports: self.udp_reports,
            ..ZenohConfig::default()
        };
        self.endpoints.push(endpoint);
        ZenohTransport::open(address.clone(), &config).expect("zenoh session opens")
    }

    fn run_until(&mut self, done: &mut dyn FnMut() -> bool) -> bool {
        let deadline = Instant::now() + Duration::from_secs(10);
        while Instant::now() < deadline {
            if done() {
                return true;
            }
            thread::sleep(Duration::from_millis(10));
        }
        done()
    }

    fn settle(&mut self) {
        thread::sleep(Duration::from_millis(300));
    }
}

slate_transport::transport_conformance!(Loopback::default());

/// The suite again with a UDP link beside each TCP one, as a node opens its sessions.
mod udp_beside_tcp {
    slate_transport::transport_conformance!(super::Loopback {
        udp_reports: true,
        ..super::Loopback::default()
    });
}

/// What a module hears, with the network the test made.
struct Endpoint {
    transport: Arc<ZenohTransport>,
    inbox: Arc<Inbox>,
}

fn endpoint(net: &mut Loopback, address: &str) -> Endpoint {
    let transport = net.join(&Address::new(address).unwrap());
    let inbox = Arc::new(Inbox::default());
    transport.set_handler(inbox.clone());
    Endpoint { transport, inbox }
}

/// A session of its own for `name`, with what it hears.
fn session(name: &str, config: &ZenohConfig) -> Endpoint {
    let transport = ZenohTransport::open(Address::new(name).unwrap(), config)
        .unwrap_or_else(|e| panic!("{name} opens on {config:?}: {e}"));
    let inbox = Arc::new(Inbox::default());
    transport.set_handler(inbox.clone());
    Endpoint { transport, inbox }
}

/// Does a publication of `from` on `link` go out to any other session? Zenoh routes a
/// put only to the sessions whose subscriptions match, so `false` means it costs the
/// network nothing.
fn routed_anywhere(from: &ZenohTransport, link: LinkKind) -> bool {
    let publisher = from
        .session()
        .declare_publisher(slate_zenoh::keys::publication(from.address(), link))
        .allowed_destination(Locality::Remote)
        .wait()
        .expect("publisher");
    publisher
        .matching_status()
        .wait()
        .expect("status")
        .matching()
}

fn payloads(e: &Endpoint) -> Vec<Vec<u8>> {
    let mut got: Vec<Vec<u8>> = e.inbox.messages().into_iter().map(|m| m.1).collect();
    got.sort();
    got
}

/// Two modules of one robot stop listening to the team link: the other robot's team
/// publications are routed to neither session (its publisher matches no one), while
/// robot-link publications and sends still arrive; listening again brings them back.
#[test]
fn a_zenoh_module_not_listening_to_the_team_is_routed_no_team_publications() {
    let mut net = Loopback::default();
    let a = endpoint(&mut net, "t/r1/a");
    let b = endpoint(&mut net, "t/r1/b");
    let c = endpoint(&mut net, "t/r2/c");
    let all_up = |e: &Endpoint| e.transport.peers().len() == 2;
    assert!(net.run_until(&mut || all_up(&a) && all_up(&b) && all_up(&c)));
    assert!(net.run_until(&mut || routed_anywhere(&c.transport, LinkKind::Team)));
    assert!(a.transport.listen(LinkKind::Team, false));
    assert!(b.transport.listen(LinkKind::Team, false));
    assert!(net.run_until(&mut || !routed_anywhere(&c.transport, LinkKind::Team)));
    c.transport
        .publish(LinkKind::Team, MsgKind::Report, b"team 1")
        .unwrap();
    b.transport
        .publish(LinkKind::Robot, MsgKind::Report, b"robot")
        .unwrap();
    c.transport
        .send(a.transport.address(), MsgKind::Plan, b"sent")
        .unwrap();
    a.transport
        .send(c.transport.address(), MsgKind::PlanAck, b"ack")
        .unwrap();
    assert!(net.run_until(&mut || a.inbox.len() == 2 && c.inbox.len() == 1));
    net.settle();
    assert_eq!(payloads(&a), vec![b"robot".to_vec(), b"sent".to_vec()]);
    assert!(b.inbox.is_empty(), "{:?}", payloads(&b));
    assert!(a.transport.listen(LinkKind::Team, true));
    assert!(
        routed_anywhere(&c.transport, LinkKind::Team),
        "known on return"
    );
    c.transport
        .publish(LinkKind::Team, MsgKind::Report, b"team 2")
        .unwrap();
    assert!(net.run_until(&mut || a.inbox.len() == 3));
    assert_eq!(a.inbox.messages()[2].1, b"team 2".to_vec());
    net.settle();
    assert!(b.inbox.is_empty(), "{:?}", payloads(&b));
}

/// Two modules whose only link is UDP (`udp/` endpoints, Zenoh's `transport_udp`):
/// publications and direct sends both arrive.
#[test]
fn modules_joined_only_by_udp_endpoints_exchange_publications_and_sends() {
    let endpoint = format!("udp/127.0.0.1:{}", slate_testing::free_udp_port());
    let open = |name: &str, listen: Vec<String>, connect: Vec<String>| {
        let config = ZenohConfig {
            listen,
            connect,
            ..ZenohConfig::default()
        };
        session(name, &config)
    };
    let a = open("t/r1/a", vec![endpoint.clone()], vec![]);
    let b = open("t/r2/b", vec![], vec![endpoint.clone()]);
    let mut net = Loopback::default();
    let up = |e: &Endpoint| e.transport.peers().len() == 1;
    assert!(net.run_until(&mut || up(&a) && up(&b)), "peers over udp");
    assert!(net.run_until(&mut || routed_anywhere(&b.transport, LinkKind::Team)));
    b.transport
        .publish(LinkKind::Team, MsgKind::Report, b"over udp")
        .unwrap();
    a.transport
        .send(b.transport.address(), MsgKind::Plan, b"sent over udp")
        .unwrap();
    assert!(net.run_until(&mut || a.inbox.len() == 1 && b.inbox.len() == 1));
    assert_eq!(payloads(&a), vec![b"over udp".to_vec()]);
    assert_eq!(payloads(&b), vec![b"sent over udp".to_vec()]);
    a.transport.close();
    b.transport.close();
}

/// A send to a module whose inbox this session does not route to yet (the module is
/// starting, or its link was just opened again and its declarations are on the way)
/// waits for the route instead of vanishing: Zenoh drops a put that matches no
/// subscriber, and a plan sent so was lost for good over a link that retransmits.
#[test]
fn a_send_made_before_the_addressee_is_routed_arrives_once_it_is() {
    let mut net = Loopback::default();
    let a = endpoint(&mut net, "t/r1/a");
    let b_address = Address::new("t/r2/b").unwrap();
    a.transport
        .send(&b_address, MsgKind::Plan, b"sent early")
        .unwrap();
    thread::sleep(Duration::from_millis(300));
    let b = endpoint(&mut net, "t/r2/b");
    assert!(
        net.run_until(&mut || b.inbox.len() == 1),
        "the send waited for b's inbox"
    );
    assert_eq!(payloads(&b), vec![b"sent early".to_vec()]);
    a.transport.close();
    b.transport.close();
}

/// A handler that takes 50 µs per message (a slow board), counting what it got.
#[derive(Default)]
struct Slow {
    got: std::sync::Mutex<Vec<u32>>,
}

impl slate_transport::Handler for Slow {
    fn message(&self, _from: &Address, payload: &[u8]) {
        let started = Instant::now();
        while started.elapsed() < Duration::from_micros(50) {
            std::hint::spin_loop();
        }
        let n = u32::from_le_bytes(payload[1..5].try_into().unwrap());
        self.got.lock().unwrap().push(n);
    }

    fn peer(&self, _peer: &Address, _up: bool) {}
}

/// A writer publishing as fast as it can to a receiver whose handler is slower: with
/// `Flow::Every` every message arrives, in order (the writer is slowed down); with the
/// default `Flow::Latest` the receiver's queue drops some, and counts them.
#[test]
fn every_publication_of_flow_every_reaches_a_slow_handler_in_order_and_latest_ones_are_dropped() {
    const N: u32 = 20_000;
    for flow in [slate_transport::Flow::Every, slate_transport::Flow::Latest] {
        let mut net = Loopback::default();
        let writer = net.join(&Address::new("t/r1/writer").unwrap());
        let receiver = net.join(&Address::new("t/r1/receiver").unwrap());
        let slow = Arc::new(Slow::default());
        receiver.set_handler(slow.clone());
        assert!(net.run_until(&mut || writer.peers().len() == 1 && receiver.peers().len() == 1));
        net.settle();
        for n in 0..N {
            let mut payload = vec![0x11];
            payload.extend(n.to_le_bytes());
            writer
                .publish_with(LinkKind::Robot, MsgKind::Report, &payload, flow)
                .unwrap();
        }
        let last = |s: &Slow| s.got.lock().unwrap().last() == Some(&(N - 1));
        let deadline = Instant::now() + Duration::from_secs(20);
        while Instant::now() < deadline && !last(&slow) {
            thread::sleep(Duration::from_millis(20));
        }
        net.settle();
        let got = slow.got.lock().unwrap().clone();
        let dropped = receiver.stats().behind_dropped;
        match flow {
            slate_transport::Flow::Every => {
                let misplaced = (0..N).zip(&got).find(|(n, g)| n != *g);
                assert!(
                    got.len() == N as usize && misplaced.is_none(),
                    "{flow:?}: {} of {N} arrived, first out of place {misplaced:?}",
                    got.len()
                );
                assert_eq!(dropped, 0);
            }
            _ => {
                assert!(
                    got.len() < N as usize,
                    "{flow:?}: all {} arrived",
                    got.len()
                );
                assert!(dropped > 0, "{flow:?}");
                assert!(got.windows(2).all(|w| w[0] < w[1]), "in order, with holes");
            }
        }
        writer.close();
        receiver.close();
    }
}

/// A relay on 127.0.0.1 between one connecting session and one listening session: TCP
/// and UDP on the same port, each forwarded to the listener's port of the same protocol,
/// keeping every byte it forwarded (both directions) per protocol.
struct Relay {
    port: u16,
    tcp: Arc<std::sync::Mutex<Vec<u8>>>,
    udp: Arc<std::sync::Mutex<Vec<u8>>>,
    stop: Arc<std::sync::atomic::AtomicBool>,
    /// Whether it relays new TCP connections (it closes them at once when not).
    tcp_open: Arc<std::sync::atomic::AtomicBool>,
    /// Both ends of each TCP connection it relays, to cut them.
    tcp_streams: Arc<std::sync::Mutex<Vec<std::net::TcpStream>>>,
}

impl Relay {
    fn start(to: u16) -> Relay {
        Relay::start_with(to, true)
    }

    /// A relay to `to` that relays TCP connections from the start or not
    /// ([`Relay::open_tcp`]).
    fn start_with(to: u16, tcp_open: bool) -> Relay {
        use std::io::{Read, Write};
        use std::net::{TcpListener, TcpStream, UdpSocket};
        use std::sync::atomic::{AtomicBool, Ordering};
        let port = free_port();
        let stop = Arc::new(AtomicBool::new(false));
        let tcp = Arc::new(std::sync::Mutex::new(Vec::new()));
        let udp = Arc::new(std::sync::Mutex::new(Vec::new()));
        let tcp_open = Arc::new(AtomicBool::new(tcp_open));
        let tcp_streams = Arc::new(std::sync::Mutex::new(Vec::new()));
        let tick = Some(Duration::from_millis(50));
        let listener = TcpListener::bind(("127.0.0.1", port)).expect("relay listens on tcp");
        listener.set_nonblocking(true).unwrap();
        let (seen, done) = (tcp.clone(), stop.clone());
        let (open, streams) = (tcp_open.clone(), tcp_streams.clone());
        thread::spawn(move || {
            while !done.load(Ordering::Relaxed) {
                let Ok((down, _)) = listener.accept() else {
                    thread::sleep(Duration::from_millis(10));
                    continue;
                };
                if !open.load(Ordering::Relaxed) {
                    continue;
                }
                down.set_nonblocking(false).unwrap();
                let up = TcpStream::connect(("127.0.0.1", to)).expect("relay reaches the listener");
                let mut held = streams.lock().unwrap();
                held.extend([down.try_clone().unwrap(), up.try_clone().unwrap()]);
                drop(held);
                for (mut from, mut to) in [
                    (down.try_clone().unwrap(), up.try_clone().unwrap()),
                    (up, down),
                ] {
                    from.set_read_timeout(tick).unwrap();
                    let (seen, done) = (seen.clone(), done.clone());
                    thread::spawn(move || {
                        let mut buf = [0u8; 65536];
                        while !done.load(Ordering::Relaxed) {
                            match from.read(&mut buf) {
                                Ok(0) => return,
                                Ok(n) => {
                                    seen.lock().unwrap().extend_from_slice(&buf[..n]);
                                    if to.write_all(&buf[..n]).is_err() {
                                        return;
                                    }
                                }
                                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
                                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                                Err(_) => return,
                            }
                        }
                    });
                }
            }
        });
        let down = UdpSocket::bind(("127.0.0.1", port)).expect("relay binds udp on its tcp port");
        let up = UdpSocket::bind("127.0.0.1:0").unwrap();
        up.connect(("127.0.0.1", to)).unwrap();
        let peer = Arc::new(std::sync::Mutex::new(None));
        for (inward, socket) in [
            (true, down.try_clone().unwrap()),
            (false, up.try_clone().unwrap()),
        ] {
            let (down, up) = (down.try_clone().unwrap(), up.try_clone().unwrap());
            let (seen, done, peer) = (udp.clone(), stop.clone(), peer.clone());
            socket.set_read_timeout(tick).unwrap();
            thread::spawn(move || {
                let mut buf = [0u8; 65536];
                while !done.load(Ordering::Relaxed) {
                    let Ok((n, from)) = socket.recv_from(&mut buf) else {
                        continue;
                    };
                    seen.lock().unwrap().extend_from_slice(&buf[..n]);
                    if inward {
                        *peer.lock().unwrap() = Some(from);
                        let _ = up.send(&buf[..n]);
                    } else if let Some(back) = *peer.lock().unwrap() {
                        let _ = down.send_to(&buf[..n], back);
                    }
                }
            });
        }
        Relay {
            port,
            tcp,
            udp,
            stop,
            tcp_open,
            tcp_streams,
        }
    }

    /// Relays new TCP connections from now on, or not.
    fn open_tcp(&self, open: bool) {
        self.tcp_open
            .store(open, std::sync::atomic::Ordering::Relaxed);
    }

    /// Closes every TCP connection it relays and relays no new one (UDP goes on).
    fn cut_tcp(&self) {
        self.open_tcp(false);
        for stream in self.tcp_streams.lock().unwrap().drain(..) {
            let _ = stream.shutdown(std::net::Shutdown::Both);
        }
    }

    /// Did `marker` cross on TCP, on UDP?
    fn carried(&self, marker: &[u8]) -> (bool, bool) {
        let has = |bytes: &std::sync::Mutex<Vec<u8>>| {
            bytes
                .lock()
                .unwrap()
                .windows(marker.len())
                .any(|w| w == marker)
        };
        (has(&self.tcp), has(&self.udp))
    }
}

impl Drop for Relay {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
    }
}

/// With `udp_reports`, the team link's reports and heartbeats (its droppable
/// publications) cross on the UDP link beside the TCP one, and never on TCP once that
/// link is up; direct sends and lossless publications stay on TCP, and the robot link's
/// reports never take UDP. Read off the bytes a relay between the two sessions forwarded on each protocol.
#[test]
fn with_udp_reports_team_reports_go_over_udp_and_everything_else_over_tcp() {
    let port = free_port();
    let relay = Relay::start(port);
    let (b, a) = udp_beside_pair(port, &relay);
    let mut net = Loopback::default();
    let up = |e: &Endpoint| e.transport.peers().len() == 1;
    assert!(net.run_until(&mut || up(&a) && up(&b)), "peers");
    assert!(net.run_until(&mut || routed_anywhere(&a.transport, LinkKind::Team)));
    // Until the UDP link is up, Zenoh sends reports on TCP: wait for one on UDP.
    assert!(
        udp_joined(&mut net, &a, &relay, "early"),
        "no team report crossed on UDP"
    );
    let kinds = [
        (LinkKind::Team, MsgKind::Report),
        (LinkKind::Team, MsgKind::Heartbeat),
        (LinkKind::Robot, MsgKind::Report),
    ];
    for i in 0..20 {
        for (link, kind) in kinds {
            let text = format!("{link:?} {kind:?} {i}");
            a.transport.publish(link, kind, text.as_bytes()).unwrap();
        }
        let every = format!("every {i}");
        a.transport
            .publish_with(
                LinkKind::Team,
                MsgKind::Report,
                every.as_bytes(),
                slate_transport::Flow::Every,
            )
            .unwrap();
        let send = format!("send {i}");
        a.transport
            .send(b.transport.address(), MsgKind::Plan, send.as_bytes())
            .unwrap();
    }
    assert!(net.run_until(&mut || b.inbox.messages().iter().any(|m| m.1 == b"send 19")));
    net.settle();
    for i in 0..20 {
        for (link, kind) in kinds {
            let text = format!("{link:?} {kind:?} {i}");
            let (tcp, udp) = relay.carried(text.as_bytes());
            if link == LinkKind::Team {
                assert!(!tcp, "{text} crossed on TCP");
                assert!(udp, "{text} did not cross on UDP");
            } else {
                // Another robot does not subscribe to r1's robot link: it crosses nowhere.
                assert!(!udp, "{text} crossed on UDP");
            }
        }
        for text in [format!("every {i}"), format!("send {i}")] {
            let (tcp, udp) = relay.carried(text.as_bytes());
            assert!(tcp && !udp, "{text}: on TCP {tcp}, on UDP {udp}");
        }
    }
    a.transport.close();
    b.transport.close();
}

/// A session's Zenoh peers (transports open), whatever slate's liveliness says.
fn zenoh_peers(e: &Endpoint) -> usize {
    e.transport.session().info().peers_zid().wait().count()
}

/// Two sessions with `udp_reports`, the second connecting to the first through `relay`:
/// (listener, connector).
fn udp_beside_pair(port: u16, relay: &Relay) -> (Endpoint, Endpoint) {
    let b = udp_beside_session("t/r2/b", Some(port), None);
    let a = udp_beside_session("t/r1/a", None, Some(relay.port));
    (b, a)
}

/// A session with `udp_reports` for `name`, listening on 127.0.0.1:`listen` and
/// connecting to 127.0.0.1:`connect` over TCP, where given.
fn udp_beside_session(name: &str, listen: Option<u16>, connect: Option<u16>) -> Endpoint {
    let tcp = |port: Option<u16>| port.map(|p| format!("tcp/127.0.0.1:{p}")).into_iter();
    let config = ZenohConfig {
        listen: tcp(listen).collect(),
        connect: tcp(connect).collect(),
        udp_reports: true,
        ..ZenohConfig::default()
    };
    session(name, &config)
}

/// Publishes team reports from `a` until one crosses `relay` on UDP (the UDP link has
/// joined the transport): whether one did.
fn udp_joined(net: &mut Loopback, a: &Endpoint, relay: &Relay, what: &str) -> bool {
    let mut n = 0;
    net.run_until(&mut || {
        n += 1;
        let report = format!("{what} report {n}");
        let _ = a
            .transport
            .publish(LinkKind::Team, MsgKind::Report, report.as_bytes());
        thread::sleep(Duration::from_millis(20));
        relay.carried(report.as_bytes()).1
    })
}

/// Zenoh sends a message on a link of its reliability, else on any: a transport born on
/// the UDP link beside TCP sent its declarations over UDP, where one lost or overtaken
/// left a module deaf to another for good (vendor/README.md). With only the UDP link
/// reachable no transport opens; once TCP is, one does, and the UDP link joins it.
#[test]
fn with_udp_reports_a_transport_opens_on_tcp_and_the_udp_link_joins_it() {
    let port = free_port();
    let relay = Relay::start_with(port, false);
    let (b, a) = udp_beside_pair(port, &relay);
    for _ in 0..15 {
        thread::sleep(Duration::from_millis(100));
        assert_eq!(
            zenoh_peers(&a),
            0,
            "a transport opened on the UDP link alone"
        );
    }
    relay.open_tcp(true);
    let mut net = Loopback::default();
    assert!(net.run_until(&mut || zenoh_peers(&a) == 1 && zenoh_peers(&b) == 1));
    assert!(net.run_until(&mut || routed_anywhere(&a.transport, LinkKind::Team)));
    assert!(
        udp_joined(&mut net, &a, &relay, "joined"),
        "the UDP link never joined"
    );
    a.transport
        .send(b.transport.address(), MsgKind::Plan, b"after the join")
        .unwrap();
    assert!(net.run_until(&mut || b.inbox.messages().iter().any(|m| m.1 == b"after the join")));
    assert_eq!(relay.carried(b"after the join"), (true, false));
    a.transport.close();
    b.transport.close();
}

/// A session's Zenoh links by protocol: (TCP, UDP).
fn links_by_protocol(e: &Endpoint) -> (usize, usize) {
    let links: Vec<_> = e.transport.session().info().links().wait().collect();
    let count = |protocol: &str| {
        links
            .iter()
            .filter(|l| l.dst().protocol().as_str() == protocol)
            .count()
    };
    (count("tcp"), count("udp"))
}

/// Two robots that each `connect` to the other keep one TCP and one UDP link between
/// them, not two of each: every idle link sends its own keep-alives, and a radio pays
/// for each (docs/performance.md, *Bytes on the radio*). A node that opens a link to a
/// peer it already has a link of that kind with leaves it at the handshake
/// (vendor/README.md, rule 3), and its connector counts the peer as reached.
#[test]
fn with_udp_reports_robots_that_connect_to_each_other_keep_one_link_of_each_kind() {
    let (pa, pb) = (free_port(), free_port());
    // `a` finds nobody at first and retries (Zenoh: 1 s, then 2 and 4 s apart); `b`
    // reaches `a` at once: a's retries find the transport b made.
    let a = udp_beside_session("t/r1/a", Some(pa), Some(pb));
    let b = udp_beside_session("t/r2/b", Some(pb), Some(pa));
    let mut net = Loopback::default();
    let both = |e: &Endpoint| {
        let (tcp, udp) = links_by_protocol(e);
        tcp >= 1 && udp >= 1
    };
    assert!(net.run_until(&mut || both(&a) && both(&b)), "links");
    // Past the longest retry of every connector (4 s), a link of each kind, no more.
    let until = Instant::now() + Duration::from_secs(7);
    while Instant::now() < until {
        for (e, name) in [(&a, "a"), (&b, "b")] {
            let (tcp, udp) = links_by_protocol(e);
            assert!(
                tcp <= 1 && udp <= 1,
                "{name} holds {tcp} TCP and {udp} UDP links"
            );
        }
        thread::sleep(Duration::from_millis(100));
    }
    assert_eq!(links_by_protocol(&a), (1, 1));
    assert_eq!(links_by_protocol(&b), (1, 1));
    assert!(net.run_until(&mut || routed_anywhere(&a.transport, LinkKind::Team)));
    for (from, to, what) in [(&a, &b, "a to b"), (&b, &a, "b to a")] {
        let text = format!("one link {what}");
        from.transport
            .send(to.transport.address(), MsgKind::Plan, text.as_bytes())
            .unwrap();
        assert!(
            net.run_until(&mut || to.inbox.messages().iter().any(|m| m.1 == text.as_bytes())),
            "no send {what}"
        );
    }
    a.transport.close();
    b.transport.close();
}

/// The connector whose link is left at its handshake (the peer already has a link of
/// that kind to it) counts the peer as reached and stops: it does not open a handshake
/// every few seconds (Zenoh retries up to 4 s apart), each a radio's bytes.
#[test]
fn with_udp_reports_a_connector_left_for_the_peers_link_stops() {
    let (pa, pb) = (free_port(), free_port());
    // b reaches a through `relay`, which refuses b's connections until a's link is up.
    let relay = Relay::start_with(pa, false);
    let a = udp_beside_session("t/r1/a", Some(pa), Some(pb));
    let b = udp_beside_session("t/r2/b", Some(pb), Some(relay.port));
    let mut net = Loopback::default();
    assert!(net.run_until(&mut || zenoh_peers(&a) == 1 && zenoh_peers(&b) == 1));
    relay.open_tcp(true);
    // b's next try crosses the relay once, and no more past its longest retry (4 s).
    let relayed = || relay.tcp_streams.lock().unwrap().len() / 2;
    assert!(net.run_until(&mut || relayed() >= 1), "b never tried again");
    thread::sleep(Duration::from_secs(9));
    assert_eq!(relayed(), 1, "b's connector went on trying");
    assert_eq!(links_by_protocol(&a).0, 1);
    assert_eq!(links_by_protocol(&b).0, 1);
    a.transport.close();
    b.transport.close();
}

/// A transport whose TCP link breaks while its UDP link lives closes, rather than send
/// its reliable messages on UDP, and opens again on TCP when it can.
#[test]
fn with_udp_reports_a_transport_that_loses_its_tcp_link_closes_and_opens_again() {
    let port = free_port();
    let relay = Relay::start(port);
    let (b, a) = udp_beside_pair(port, &relay);
    let mut net = Loopback::default();
    assert!(net.run_until(&mut || zenoh_peers(&a) == 1 && zenoh_peers(&b) == 1));
    assert!(net.run_until(&mut || routed_anywhere(&a.transport, LinkKind::Team)));
    assert!(
        udp_joined(&mut net, &a, &relay, "before"),
        "the UDP link never joined"
    );
    relay.cut_tcp();
    assert!(
        net.run_until(&mut || zenoh_peers(&a) == 0),
        "the transport lives on its UDP link"
    );
    relay.open_tcp(true);
    assert!(net.run_until(&mut || zenoh_peers(&a) == 1 && zenoh_peers(&b) == 1));
    // Both ways (a transport whose two ends disagree fails in one direction only), on
    // TCP, and the UDP link joins again.
    for (from, to, what) in [(&a, &b, "a to b"), (&b, &a, "b to a")] {
        let mut n = 0;
        let delivered = net.run_until(&mut || {
            n += 1;
            let text = format!("healed {what} {n}");
            let _ = from
                .transport
                .send(to.transport.address(), MsgKind::Plan, text.as_bytes());
            thread::sleep(Duration::from_millis(50));
            let heard = to.inbox.messages();
            heard
                .iter()
                .any(|m| m.1.starts_with(format!("healed {what}").as_bytes()))
        });
        assert!(delivered, "no send {what} after the heal");
        for i in 1..=n {
            let text = format!("healed {what} {i}");
            assert!(!relay.carried(text.as_bytes()).1, "{text} crossed on UDP");
        }
    }
    assert!(
        udp_joined(&mut net, &a, &relay, "after"),
        "the UDP link never joined again"
    );
    a.transport.close();
    b.transport.close();
}
