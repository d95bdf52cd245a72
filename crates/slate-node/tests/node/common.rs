//! A team of nodes on one simulated network.

use std::time::{Duration, Instant};

use slate_ici::{ClassSet, IciConfig, SimNet};
use slate_model::Address;
use slate_node::Node;

/// Classes every node of the tests loads.
pub const WORLD: &str = r#"
class Vehicle {
    position: vec<2> [m] = [0.0, 0.0] accuracy 1.0;
    speed: real [m/s] in 0 .. 10 = 0.0;
    mode: string = "auto";
}
class Obstacle { position: vec<2> [m]; range: real [m]; }
"#;

pub fn addr(text: &str) -> Address {
    Address::new(text).unwrap()
}

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

/// Waits in real time (the node's monitor thread runs on its own) until `done`.
pub fn eventually(mut done: impl FnMut() -> bool) -> bool {
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline {
        if done() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    done()
}
