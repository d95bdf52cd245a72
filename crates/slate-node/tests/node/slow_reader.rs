//! A peer that never reads what it is sent must not stall a node: the node keeps
//! hearing, and holding alive, an unrelated module. Over real Zenoh sessions on
//! 127.0.0.1; the slow reader is a normal session behind a TCP proxy that stops
//! forwarding what the node sends it.

use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use parking_lot::Mutex;
use slate_ici::{ClassSet, Handler, IciConfig, MsgKind, PlanHandler, Transport};
use slate_model::{Address, AttrDecl, ClassDef, Value, ValueType};
use slate_testing::free_port;
use slate_wire::{CatchUpRequest, Encoder, Message, Schema};
use slate_zenoh::{ZenohConfig, ZenohTransport};

use crate::support::ZenohModule;

fn classes() -> Vec<ClassDef> {
    vec![
        ClassDef::new("Doc").attr(AttrDecl::new("text", ValueType::Str)),
        ClassDef::new("Vehicle").attr(AttrDecl::new("speed", ValueType::Real)),
    ]
}

/// A TCP proxy whose direction towards the client can be stalled: the proxy then stops
/// reading what the server sends, as a peer that never reads would.
struct Proxy {
    stalled: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    threads: Arc<Mutex<Vec<JoinHandle<()>>>>,
}

impl Proxy {
    /// Listens on `port` and forwards each connection to `server_port`.
    fn start(port: u16, server_port: u16) -> Proxy {
        let listener = TcpListener::bind(("127.0.0.1", port)).expect("proxy listens");
        listener.set_nonblocking(true).unwrap();
        let proxy = Proxy {
            stalled: Arc::default(),
            stop: Arc::default(),
            threads: Arc::default(),
        };
        let (stalled, stop, threads) = (
            proxy.stalled.clone(),
            proxy.stop.clone(),
            proxy.threads.clone(),
        );
        let accept = thread::spawn(move || {
            while !stop.load(Ordering::Acquire) {
                let Ok((client, _)) = listener.accept() else {
                    thread::sleep(Duration::from_millis(10));
                    continue;
                };
                let Ok(server) = TcpStream::connect(("127.0.0.1", server_port)) else {
                    continue;
                };
                let never = Arc::new(AtomicBool::new(false));
                let up = pump(&client, &server, never, stop.clone());
                let down = pump(&server, &client, stalled.clone(), stop.clone());
                threads.lock().extend([up, down]);
            }
        });
        proxy.threads.lock().push(accept);
        proxy
    }

    /// Stops reading what the server sends to the client.
    fn stall(&self) {
        self.stalled.store(true, Ordering::Release);
    }

    /// Stops every thread it started.
    fn stop(self) {
        self.stop.store(true, Ordering::Release);
        loop {
            let Some(t) = self.threads.lock().pop() else {
                break;
            };
            let _ = t.join();
        }
    }
}

/// Copies `from` to `to` until `stop`, not reading while `stalled`.
fn pump(
    from: &TcpStream,
    to: &TcpStream,
    stalled: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
) -> JoinHandle<()> {
    let (mut from, mut to) = (from.try_clone().unwrap(), to.try_clone().unwrap());
    from.set_read_timeout(Some(Duration::from_millis(50)))
        .unwrap();
    thread::spawn(move || {
        let mut buf = vec![0u8; 64 * 1024];
        while !stop.load(Ordering::Acquire) {
            if stalled.load(Ordering::Acquire) {
                thread::sleep(Duration::from_millis(10));
                continue;
            }
            match from.read(&mut buf) {
                Ok(0) => return,
                Ok(n) if to.write_all(&buf[..n]).is_err() => return,
                Ok(_) => {}
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
                Err(_) => return,
            }
        }
    })
}

/// Records the modules an ICI judged dead.
#[derive(Default)]
struct Deaths(Mutex<Vec<Address>>);

impl PlanHandler for Deaths {
    fn message(&self, _: &Address, _: Message) {}

    fn peer(&self, peer: &Address, alive: bool) {
        if !alive {
            self.0.lock().push(peer.clone());
        }
    }
}

/// Ignores everything: the slow reader's handler.
struct Deaf;

impl Handler for Deaf {
    fn message(&self, _: &Address, _: &[u8]) {}
    fn peer(&self, _: &Address, _: bool) {}
}

fn wait(bound: Duration, mut done: impl FnMut() -> bool) -> bool {
    let end = Instant::now() + bound;
    while Instant::now() < end {
        if done() {
            return true;
        }
        thread::sleep(Duration::from_millis(10));
    }
    done()
}

#[test]
fn a_peer_that_never_reads_does_not_stall_a_node_for_the_others() {
    let (node_port, proxy_port) = (free_port(), free_port());
    let listen = |port: u16| ZenohConfig {
        listen: vec![format!("tcp/127.0.0.1:{port}")],
        ..ZenohConfig::default()
    };
    let connect = |port: u16| ZenohConfig {
        connect: vec![format!("tcp/127.0.0.1:{port}")],
        ..ZenohConfig::default()
    };
    let open = |address: &str, zenoh: &ZenohConfig| {
        let address = Address::new(address).unwrap();
        let config = IciConfig::default().export(ClassSet::all());
        ZenohModule::open(&address, &classes(), zenoh, config, |z| z)
    };
    let node = open("t/r1/node", &listen(node_port));
    let deaths = Arc::new(Deaths::default());
    node.ici.set_plan_handler(deaths.clone());
    // Enough state that answering a catch-up takes about a megabyte.
    let text = "x".repeat(50_000);
    for i in 0..24 {
        let name = format!("doc{i}");
        node.board().create("Doc", &name).unwrap();
        node.board().write(&name, "text", text.as_str()).unwrap();
    }
    let other = open("t/r1/other", &connect(node_port));
    let proxy = Proxy::start(proxy_port, node_port);
    let slow_address = Address::new("t/r1/slow").unwrap();
    let slow = ZenohTransport::open(slow_address.clone(), &connect(proxy_port)).unwrap();
    slow.set_handler(Arc::new(Deaf));

    other.board().create("Vehicle", "car").unwrap();
    other.board().write("car", "speed", 1.0).unwrap();
    let alive = |a: &Address| node.ici.alive_peers().contains(a);
    let other_address = other.transport.address().clone();
    assert!(
        wait(Duration::from_secs(10), || alive(&other_address)
            && alive(&slow_address)
            && node.board().read("car", "speed").is_ok()),
        "the node hears both"
    );

    proxy.stall();
    let request = Message::CatchUpRequest(CatchUpRequest {
        have_seq: 0,
        needs_names: true,
        needs_classes: false,
    });
    let bytes = Encoder::new(slow_address.clone())
        .encode(&request, &Schema::new(&classes()))
        .unwrap();
    for _ in 0..12 {
        slow.send(node.transport.address(), MsgKind::CatchUpRequest, &bytes)
            .unwrap();
    }
    thread::sleep(Duration::from_millis(500));
    other.board().write("car", "speed", 42.0).unwrap();
    // Generous, yet shorter than Zenoh's 5 s block on a congested reliable put.
    let heard = wait(Duration::from_secs(4), || {
        node.board().read("car", "speed").map(|p| p.value) == Ok(Value::Real(42.0))
    });
    // Long enough for a stalled node to have timed the other module out.
    thread::sleep(Duration::from_secs(3));
    let dead = deaths.0.lock().clone();

    slow.close();
    proxy.stop();
    other.close();
    node.close();
    assert!(heard, "a report from the other module still arrives");
    assert!(
        !dead.contains(&other_address),
        "the other module is never reported down: {dead:?}"
    );
}
