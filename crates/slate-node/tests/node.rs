//! Integration tests of slate-node: one binary, one module per area in `tests/node/`.

// Starting from a config file, and the errors of a bad one.
#[path = "node/config.rs"]
mod config;
// A plan nested too deep, from a made-up address over real Zenoh: rejected, the node runs on.
#[path = "node/deep_plan.rs"]
mod deep_plan;
// The dashboard a node serves: its snapshot follows docs/dashboard.md.
#[path = "node/dashboard.rs"]
mod dashboard;
// The Foxglove server a node serves: its port, its stop, a port in use.
#[path = "node/foxglove.rs"]
mod foxglove;
// A node hands the `link` blocks of the files it loads to its ICI.
#[path = "node/links.rs"]
mod links;
// A lossless class over real Zenoh: every update, in order, while catch-ups close gaps.
#[path = "node/lossless.rs"]
mod lossless;
// Reports that linger: a burst of writes in a few reports over real Zenoh.
#[path = "node/linger.rs"]
mod linger;
// Recording a board in MCAP, read back with the mcap crate.
#[path = "node/record.rs"]
mod record;
// Two robots' LANs joined only through a Zenoh router (`zenoh_config`).
#[path = "node/router.rs"]
mod router;
// A node keeps its board across a restart (`state`); its peers keep its objects.
#[path = "node/state.rs"]
mod state;
// Secured sessions: a member speaks only in its own name, an outsider gets no link.
#[path = "node/secure.rs"]
mod secure;
// Nodes on the deterministic simulator: reports, late joiners, plans with acks, shutdown.
#[path = "node/sim.rs"]
mod sim;
// A peer that never reads what it is sent must not stall a node (real Zenoh, loopback).
#[path = "node/slow_reader.rs"]
mod slow_reader;
// A team of nodes on one simulated network (the helper module).
#[path = "node/support.rs"]
mod support;
// Zenoh's own settings reach a node (a config file's lease), and `udp/` links work.
#[path = "node/zenoh_links.rs"]
mod zenoh_links;
