//! A team of nodes on one simulated network.

use std::time::Duration;

use slate_ici::{ClassSet, IciConfig, SimNet};
use slate_node::Node;
pub use slate_testing::{WORLD, addr};

/// A node on `net` that exports everything and loads [`WORLD`] then `extra`.
pub fn start(net: &SimNet, address: &str, extra: &str) -> Node {
    let a = addr(address);
    let mut b = Node::builder(a.clone())
        .transport(net.join(&a))
        .clock(net.clock())
        .ici(IciConfig::default().export(ClassSet::all()))
        .source("world.slate", WORLD);
    if !extra.is_empty() {
        b = b.source(&format!("{address}.slate"), extra);
    }
    b.start().expect("node starts")
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
