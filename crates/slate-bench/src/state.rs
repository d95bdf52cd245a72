//! `slate bench state`: a node's write path with its board kept in a state directory
//! (redb, `state = "DIR"`), against a node of the same config without, in the same run.

use std::hint::black_box;
use std::time::Duration;

use serde_json::json;
use slate_ici::{ClassSet, IciConfig, SimNet};
use slate_model::Address;
use slate_node::{Node, NodeBuilder, StateConfig};

use crate::{Config, Figures, measure};

/// The module measured: one vehicle written again and again, exporting everything (the
/// ICI builds its reports on the write path, as in a team). The same as `record`'s.
const WORLD: &str = "class Vehicle { speed: real [m/s] in 0 .. 50 = 0.0; x: real [m]; }\nobject gsr : Vehicle context self;";

/// Runs the suite; `progress` is told each step.
pub fn run(cfg: &Config, progress: &mut dyn FnMut(&str)) -> anyhow::Result<Figures> {
    let mut r = Figures::new(
        "slate bench state: a node's writes with its board kept in redb vs the same node without",
    );
    let net = SimNet::new(1);
    let address = Address::new("team/r1/nav")?;
    progress("node writes, no state");
    let plain = node(&net, &address).start()?;
    r.add("node_write_ns", writes(cfg, &plain)?);
    plain.close();
    net.run_for(Duration::from_millis(10));
    let dir = std::env::temp_dir().join(format!("slate-bench-state-{}", std::process::id()));
    progress("node writes, keeping its board (a commit every 100 ms, fsync)");
    let kept = node(&net, &address).state(StateConfig::new(&dir)).start()?;
    let ns = writes(cfg, &kept)?;
    r.compare("node_write_state_ns", ns, "node_write_ns", Some(2.0));
    kept.close();
    let stats = kept.state().unwrap_or_default();
    net.run_for(Duration::from_millis(10));
    let size = std::fs::metadata(dir.join(slate_node::state::FILE)).map_or(0, |m| m.len());
    let _ = std::fs::remove_dir_all(&dir);
    r.fact("commits", json!(stats.commits));
    r.fact("packets_stored", json!(stats.packets));
    r.fact("full_saves_after_drops", json!(stats.resyncs));
    r.fact("store_bytes", json!(size));
    r.fact("state_failed", json!(stats.failed));
    Ok(r)
}

/// A node on `net` at `address` with the bench's world.
fn node(net: &SimNet, address: &Address) -> NodeBuilder {
    Node::builder(address.clone())
        .transport(net.join(address))
        .clock(net.clock())
        .ici(IciConfig::default().export(ClassSet::all()))
        .source("bench.slate", WORLD)
}

/// The median time of one write of `gsr.speed` on `node`.
fn writes(cfg: &Config, node: &Node) -> anyhow::Result<f64> {
    let key = node.board().key("gsr", "speed")?;
    let mut values = crate::Cycle::new(0.0, 49.0);
    let mut write = || drop(black_box(node.board().write_key(key, values.next_value())));
    Ok(measure(cfg, &mut write))
}

/// Every timed field of the JSON object.
pub const TIMED_FIELDS: &[&str] = &["node_write_ns", "node_write_state_ns"];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_state_suite_reports_every_field() {
        let j = run(&crate::TINY, &mut |_| {}).unwrap().json();
        crate::assert_fields(&j, TIMED_FIELDS, |x| x > 0.0);
        assert!(j["commits"].as_u64() > Some(0), "{j}");
        assert_eq!(j["state_failed"], serde_json::Value::Null, "{j}");
    }
}
