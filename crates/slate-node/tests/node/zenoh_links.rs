//! Zenoh's own settings reach a node, and its link kinds work, on 127.0.0.1: a plain
//! Zenoh config file's lease decides how soon a silent session is dropped, and two
//! nodes share values over `udp/` links and over a Unix socket.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use slate_model::Value;
use slate_node::{Node, NodeConfig};
use slate_testing::{eventually, free_port, temp_dir};
use slate_transport::Transport;

/// Starts a module from a TOML config written in `dir` (`world.slate` loaded).
fn module(dir: &Path, address: &str, extra: &str) -> Node {
    let stem = address.replace('/', "_");
    let toml = format!(
        "address = \"{address}\"\nfiles = [\"world.slate\"]\nexport = [\"Vehicle\"]\n{extra}"
    );
    std::fs::write(dir.join(format!("{stem}.toml")), toml).unwrap();
    let config = NodeConfig::read(&dir.join(format!("{stem}.toml"))).unwrap();
    Node::start(&config).unwrap_or_else(|e| panic!("{address}: {e}"))
}

/// `alive` of `peer`'s `Module` object on `node`'s board, if there is one.
fn alive(node: &Node, peer: &str) -> Option<bool> {
    let object = peer.replace('/', "_");
    match node.board().read(&object, "alive").ok()?.value {
        Value::Bool(b) => Some(b),
        _ => None,
    }
}

/// A TCP forwarder on 127.0.0.1 to `target` that can be frozen: it then stops moving
/// bytes but keeps both connections open, as a radio out of range does (no close, no
/// reset: only the lease can tell). Stopped, with its threads, when dropped.
struct Freezer {
    port: u16,
    frozen: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
}

impl Freezer {
    fn new(target: u16) -> Freezer {
        let listener = TcpListener::bind(("127.0.0.1", free_port())).unwrap();
        listener.set_nonblocking(true).unwrap();
        let port = listener.local_addr().unwrap().port();
        let (frozen, stop) = (
            Arc::new(AtomicBool::new(false)),
            Arc::new(AtomicBool::new(false)),
        );
        let (f, s) = (frozen.clone(), stop.clone());
        let accept = std::thread::spawn(move || accept_loop(listener, target, f, s));
        Freezer {
            port,
            frozen,
            stop,
            threads: vec![accept],
        }
    }

    fn freeze(&self) {
        self.frozen.store(true, Ordering::SeqCst);
    }
}

impl Drop for Freezer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// Accepts connections until stopped; each is forwarded both ways to `target`.
fn accept_loop(listener: TcpListener, target: u16, frozen: Arc<AtomicBool>, stop: Arc<AtomicBool>) {
    let mut pumps = Vec::new();
    while !stop.load(Ordering::SeqCst) {
        let Ok((inbound, _)) = listener.accept() else {
            std::thread::sleep(Duration::from_millis(10));
            continue;
        };
        let Ok(outbound) = TcpStream::connect(("127.0.0.1", target)) else {
            continue;
        };
        for (from, to) in [
            (inbound.try_clone().unwrap(), outbound.try_clone().unwrap()),
            (outbound, inbound),
        ] {
            let (f, s) = (frozen.clone(), stop.clone());
            pumps.push(std::thread::spawn(move || pump(from, to, f, s)));
        }
    }
    for p in pumps {
        let _ = p.join();
    }
}

/// Copies bytes from `from` to `to` while not frozen, until stopped or either closes.
fn pump(mut from: TcpStream, mut to: TcpStream, frozen: Arc<AtomicBool>, stop: Arc<AtomicBool>) {
    from.set_read_timeout(Some(Duration::from_millis(50)))
        .unwrap();
    let mut buf = [0u8; 16 * 1024];
    while !stop.load(Ordering::SeqCst) {
        if frozen.load(Ordering::SeqCst) {
            std::thread::sleep(Duration::from_millis(20));
            continue;
        }
        match from.read(&mut buf) {
            Ok(0) => return,
            Ok(n) if to.write_all(&buf[..n]).is_err() => return,
            Ok(_) => {}
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            Err(_) => return,
        }
    }
}

#[test]
fn a_plain_zenoh_config_files_lease_decides_how_soon_a_silent_peer_is_dropped() {
    let d = temp_dir("node-zenoh-lease");
    std::fs::write(d.join("world.slate"), crate::support::WORLD).unwrap();
    // A Zenoh file as Zenoh documents it: a 1 s lease (Zenoh's default is 10 s), which a
    // session announces to its peers: they drop it once silent that long.
    std::fs::write(
        d.join("zenoh.json5"),
        "{ transport: { link: { tx: { lease: 1000 } } } }",
    )
    .unwrap();
    let port = free_port();
    // Heartbeats every 0.5 s (2 s once the link is idle): the transport's down is then
    // believed 4.5 s after the last one, well inside the 8 s below.
    let ici = "[ici]\nteam_heartbeat = \"0.5s\"\n";
    let listen = format!(
        "zenoh_config = \"zenoh.json5\"\n[zenoh]\nlisten = [\"tcp/127.0.0.1:{port}\"]\n{ici}"
    );
    let nav = module(&d, "t/r1/nav", &listen);
    let radio = Freezer::new(port);
    let connect = format!(
        "[zenoh]\nconnect = [\"tcp/127.0.0.1:{}\"]\n{ici}team_timeout = \"30s\"\n",
        radio.port
    );
    let base = module(&d, "t/r2/base", &connect);
    let met = eventually(Duration::from_secs(20), || {
        alive(&base, "t/r1/nav") == Some(true)
    });
    assert!(met, "r2/base never heard r1/nav");
    radio.freeze();
    // The team link's timeout is 30 s here and Zenoh's default lease 10 s: a down
    // within 8 s is the file's lease at work.
    let dropped = eventually(Duration::from_secs(8), || {
        alive(&base, "t/r1/nav") == Some(false)
    });
    assert!(
        dropped,
        "r2/base still holds r1/nav alive 8 s after the link froze"
    );
    base.close();
    nav.close();
    drop(radio);
}

/// Two nodes, one listening on `endpoint` and the other connecting to it, share a value.
fn two_nodes_share_a_value_over(dir: &Path, endpoint: &str) {
    std::fs::write(dir.join("world.slate"), crate::support::WORLD).unwrap();
    let nav = module(
        dir,
        "t/r1/nav",
        &format!("[zenoh]\nlisten = [{endpoint:?}]\n"),
    );
    let base = module(
        dir,
        "t/r2/base",
        &format!("[zenoh]\nconnect = [{endpoint:?}]\n"),
    );
    assert_eq!(nav.listening(), [endpoint]);
    assert!(eventually(Duration::from_secs(20), || base.peers().len() == 1));
    nav.board().create("Vehicle", "gsr").unwrap();
    nav.board().write("gsr", "speed", 2.5).unwrap();
    let speed = || {
        base.board()
            .read("gsr", "speed")
            .ok()
            .and_then(|p| p.value.as_f64())
    };
    let arrived = eventually(Duration::from_secs(20), || speed() == Some(2.5));
    assert!(arrived, "r2/base over {endpoint} holds {:?}", speed());
    base.close();
    nav.close();
}

#[test]
fn two_nodes_share_a_value_over_udp_links() {
    let d = temp_dir("node-zenoh-udp");
    two_nodes_share_a_value_over(&d, &format!("udp/127.0.0.1:{}", free_port()));
}

/// Modules of one computer may talk over Unix sockets instead of loopback TCP.
#[test]
fn two_nodes_share_a_value_over_a_unix_socket() {
    let d = temp_dir("node-zenoh-unix");
    let socket = d.join("nav.sock");
    two_nodes_share_a_value_over(&d, &format!("unixsock-stream/{}", socket.display()));
}

/// A peer the node's transport had met before the node started (its ICI marks it alive
/// at once, before the monitor watches the `Module` objects) is told of in the node's
/// log like the others: a node's log lacked `peer X up` for the peers it met first.
#[test]
fn a_peer_met_before_the_node_started_is_in_its_log() {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let zenoh = |listen: Vec<String>, connect: Vec<String>| slate_zenoh::ZenohConfig {
        listen,
        connect,
        ..slate_zenoh::ZenohConfig::default()
    };
    let nav_address = slate_model::Address::new("t/r1/nav").unwrap();
    let nav =
        slate_zenoh::ZenohTransport::open(nav_address, &zenoh(vec![endpoint.clone()], vec![]))
            .unwrap();
    let loco_address = slate_model::Address::new("t/r1/loco").unwrap();
    let loco_transport =
        slate_zenoh::ZenohTransport::open(loco_address.clone(), &zenoh(vec![], vec![endpoint]))
            .unwrap();
    assert!(eventually(Duration::from_secs(10), || !loco_transport
        .peers()
        .is_empty()));
    let loco = Node::builder(loco_address)
        .transport(loco_transport)
        .start()
        .unwrap();
    assert!(
        eventually(Duration::from_secs(5), || loco
            .events()
            .iter()
            .any(|e| e.text == "peer t/r1/nav up")),
        "{:?}",
        loco.events()
    );
    loco.close();
    nav.close();
}
