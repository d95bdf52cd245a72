//! A team of nodes on one simulated network.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use slate_ici::{ClassSet, Ici, IciConfig, SimNet, Transport};
use slate_model::{Address, Board, ClassDef};
use slate_node::{Node, NodeBuilder};
pub use slate_testing::{WORLD, addr};
use slate_zenoh::{ZenohConfig, ZenohTransport};

/// A node on `net`, on its clock, that loads [`WORLD`] then `extra` (if any); the
/// caller adds the rest and starts it.
pub fn on_net(net: &SimNet, address: &str, extra: &str) -> NodeBuilder {
    let a = addr(address);
    let b = Node::builder(a.clone())
        .transport(net.join(&a))
        .clock(net.clock())
        .source("world.slate", WORLD);
    if extra.is_empty() {
        b
    } else {
        b.source(&format!("{address}.slate"), extra)
    }
}

/// A node on `net` that exports everything and loads [`WORLD`] then `extra`.
pub fn start(net: &SimNet, address: &str, extra: &str) -> Node {
    on_net(net, address, extra)
        .ici(IciConfig::default().export(ClassSet::all()))
        .start()
        .expect("node starts")
}

/// A `plans_from` list (`"robot"`, `"operators"`, address patterns).
pub fn plans_from(entries: &[&str]) -> Vec<slate_node::PlanSender> {
    entries
        .iter()
        .map(|e| e.parse().expect("a plans_from entry"))
        .collect()
}

/// Runs the network until `done` (at most `max` of virtual time).
pub fn run_until(net: &SimNet, max: f64, done: impl FnMut() -> bool) -> bool {
    net.run_until(done, Duration::from_secs_f64(max))
}

/// Waits in real time (the node's monitor thread runs on its own) until `done`, for
/// at most five seconds.
pub fn eventually(done: impl FnMut() -> bool) -> bool {
    slate_testing::eventually(Duration::from_secs(5), done)
}

/// Ticks `ici` every 10 ms on a thread of its own until `stop` is set or the ICI is
/// dropped (a test's stand-in for a node's timer thread).
pub fn ticker(
    ici: &std::sync::Arc<slate_ici::Ici>,
    stop: &std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> std::thread::JoinHandle<()> {
    let (weak, quit) = (std::sync::Arc::downgrade(ici), stop.clone());
    std::thread::spawn(move || {
        while !quit.load(std::sync::atomic::Ordering::Acquire) {
            let Some(ici) = weak.upgrade() else { return };
            ici.tick();
            drop(ici);
            std::thread::sleep(Duration::from_millis(10));
        }
    })
}

/// A module over a real Zenoh session: a board with `classes`, an ICI, and a thread
/// running its timers, as a node does.
pub struct ZenohModule {
    pub ici: Arc<Ici>,
    pub transport: Arc<ZenohTransport>,
    stop: Arc<AtomicBool>,
    ticker: Option<JoinHandle<()>>,
}

impl ZenohModule {
    /// Opens the module at `address`; its ICI runs on what `wrap` makes of the Zenoh
    /// transport (the transport itself, or a test's wrapper of it).
    pub fn open(
        address: &Address,
        classes: &[ClassDef],
        zenoh: &ZenohConfig,
        config: IciConfig,
        wrap: impl FnOnce(Arc<ZenohTransport>) -> Arc<dyn Transport>,
    ) -> ZenohModule {
        let board = Arc::new(Board::builder().address(address.clone()).build());
        for class in classes {
            board.define(class.clone()).unwrap();
        }
        let transport = ZenohTransport::open(address.clone(), zenoh).expect("opens");
        let ici = Arc::new(Ici::new(board, wrap(transport.clone()), config).unwrap());
        let stop = Arc::new(AtomicBool::new(false));
        let ticker = Some(ticker(&ici, &stop));
        ZenohModule {
            ici,
            transport,
            stop,
            ticker,
        }
    }

    pub fn board(&self) -> &Arc<Board> {
        self.ici.board()
    }

    /// Stops the timers' thread and closes the session.
    pub fn close(mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.ticker.take() {
            let _ = t.join();
        }
        self.transport.close();
    }
}
