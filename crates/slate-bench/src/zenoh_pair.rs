//! Two slate nodes (board + ICI) over Zenoh on 127.0.0.1, in one process: what the
//! `wire` and `net` suites measure. Everything is closed on drop.

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use slate_ici::{Ici, IciConfig, Rng};
use slate_model::{Address, AttrDecl, Board, ClassDef, Update, ValueType};
use slate_node::team_keys::Identity;
use slate_zenoh::{Security, ZenohConfig, ZenohTransport};

use crate::wait;

/// Objects the sender writes.
pub const OBJECTS: usize = 100;

/// Attributes of a tracked object (reals in 0..1000 at 0.01, as in `docs/wire.md`).
pub const ATTRS: [&str; 4] = ["range", "level", "depth", "width"];

/// The classes both nodes hold: tracked objects, and a robot pose.
pub fn classes() -> Vec<ClassDef> {
    let level = |name| {
        AttrDecl::new(name, ValueType::Real)
            .bounds(0.0, 1000.0)
            .resolution(0.01)
    };
    let coord = |name| {
        AttrDecl::new(name, ValueType::Real)
            .unit("m")
            .bounds(-10_000.0, 10_000.0)
            .resolution(0.01)
    };
    vec![
        ATTRS
            .iter()
            .fold(ClassDef::new("Tracked"), |c, a| c.attr(level(a))),
        ClassDef::new("Robot")
            .attr(coord("x"))
            .attr(coord("y"))
            .attr(
                AttrDecl::new("heading", ValueType::Real)
                    .unit("rad")
                    .bounds(0.0, std::f64::consts::TAU)
                    .resolution(0.001),
            )
            .attr(
                AttrDecl::new("speed", ValueType::Real)
                    .unit("m/s")
                    .bounds(0.0, 20.0)
                    .resolution(0.01),
            ),
    ]
}

/// One update of tracked object `i`: a value on the resolution grid, accuracy and
/// confidence not the defaults.
pub fn update(rng: &mut Rng) -> Update {
    let value = (rng.next_f64() * 100_000.0).round() / 100.0;
    Update::new(value)
        .accuracy(0.01 + rng.next_f64())
        .confidence(0.5 + rng.next_f64() / 2.0)
}

/// One node: board, Zenoh transport, ICI.
pub struct Node {
    pub board: Arc<Board>,
    pub transport: Arc<ZenohTransport>,
    pub ici: Ici,
}

impl Node {
    /// A node at `address` listening on / connecting to the given endpoints, secured
    /// with `security` (TLS endpoints then) or not.
    pub fn open(
        address: &str,
        listen: Vec<String>,
        connect: Vec<String>,
        security: Option<Security>,
    ) -> anyhow::Result<Node> {
        let address = Address::new(address)?;
        let board = Arc::new(Board::builder().address(address.clone()).build());
        for def in classes() {
            board.define(def)?;
        }
        let config = ZenohConfig {
            listen,
            connect,
            security,
            ..ZenohConfig::default()
        };
        let transport = ZenohTransport::open(address, &config)?;
        let ici = Ici::new(board.clone(), transport.clone(), IciConfig::default())?;
        Ok(Node {
            board,
            transport,
            ici,
        })
    }
}

/// The sender `a` (`TEAM/r1/a`) and the receiver `b` (`TEAM/r1/b`), modules of one
/// robot, with a thread running both ICIs' timers. Each suite names its own team, so
/// that two suites running at once never mistake each other's modules.
pub struct Pair {
    pub a: Node,
    pub b: Node,
    stop: Arc<AtomicBool>,
    ticker: Option<JoinHandle<()>>,
}

impl Pair {
    /// `b` listens on `b_port`; `a` connects to `a_connects` (b's port, or a proxy in
    /// front of it) and listens nowhere, so every byte between them takes that path.
    pub fn open(team: &str, b_port: u16, a_connects: u16) -> anyhow::Result<Pair> {
        Pair::open_with(team, b_port, a_connects, None)
    }

    /// As [`open`](Self::open), over TLS with mutual authentication and the team's
    /// access control: each node's key and certificate, for its address, from the keys
    /// folder `keys` (made by `slate keys init` and `issue`).
    pub fn open_secured(team: &str, port: u16, keys: &Path) -> anyhow::Result<Pair> {
        Pair::open_with(team, port, port, Some(keys))
    }

    fn open_with(
        team: &str,
        b_port: u16,
        a_connects: u16,
        keys: Option<&Path>,
    ) -> anyhow::Result<Pair> {
        let scheme = if keys.is_some() { "tls" } else { "tcp" };
        let (a_name, b_name) = (format!("{team}/r1/a"), format!("{team}/r1/b"));
        let listen = vec![format!("{scheme}/127.0.0.1:{b_port}")];
        let b = Node::open(&b_name, listen, vec![], security(keys, &b_name)?)?;
        let connect = vec![format!("{scheme}/127.0.0.1:{a_connects}")];
        let a = Node::open(&a_name, vec![], connect, security(keys, &a_name)?)?;
        let stop = Arc::new(AtomicBool::new(false));
        let (ia, ib, flag) = (a.ici.clone(), b.ici.clone(), stop.clone());
        let ticker = std::thread::Builder::new()
            .name("bench-ici-ticks".into())
            .spawn(move || {
                while !flag.load(Ordering::Relaxed) {
                    ia.tick();
                    ib.tick();
                    std::thread::sleep(Duration::from_millis(20));
                }
            })?;
        let pair = Pair {
            a,
            b,
            stop,
            ticker: Some(ticker),
        };
        let met = wait(Duration::from_secs(10), || {
            pair.a.ici.alive_peers().contains(pair.b.board.address())
                && pair.b.ici.alive_peers().contains(pair.a.board.address())
        });
        anyhow::ensure!(met, "the two Zenoh sessions did not meet within 10 s");
        Ok(pair)
    }

    /// Creates the tracked objects on `a` and waits until `b` has them.
    pub fn create_objects(&self) -> anyhow::Result<()> {
        let mut batch = self.a.board.batch();
        for i in 0..OBJECTS {
            batch.create("Tracked", &format!("t{i}"));
        }
        batch.commit()?;
        let met = wait(Duration::from_secs(10), || {
            (0..OBJECTS).all(|i| self.b.board.info(&format!("t{i}")).is_some())
        });
        anyhow::ensure!(met, "the receiver did not get the objects within 10 s");
        Ok(())
    }

    /// Does `b` hold every packet `a` holds on the tracked objects?
    pub fn converged(&self) -> bool {
        (0..OBJECTS).all(|i| {
            let name = format!("t{i}");
            ATTRS.iter().all(|attr| {
                let a = self.a.board.read(&name, attr).ok();
                a.is_some() && a == self.b.board.read(&name, attr).ok()
            })
        })
    }
}

/// What module `address` needs to run secured from the keys folder `keys`, if any.
fn security(keys: Option<&Path>, address: &str) -> anyhow::Result<Option<Security>> {
    let Some(dir) = keys else {
        return Ok(None);
    };
    let identity = Identity::parse(address)?;
    Ok(Some(slate_node::team_keys::security(dir, &identity)?))
}

impl Drop for Pair {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.ticker.take() {
            let _ = t.join();
        }
        slate_ici::Transport::close(&*self.a.transport);
        slate_ici::Transport::close(&*self.b.transport);
    }
}
