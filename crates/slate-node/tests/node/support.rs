//! A team of nodes on one simulated network.

use std::time::Duration;

use slate_ici::{ClassSet, IciConfig, SimNet};
use slate_node::{Node, NodeBuilder};
pub use slate_testing::{WORLD, addr};

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
