//! Integration tests of the `slate` binary: one binary, one module per area in `tests/cli/`.
//! The live areas run real teams (`slate node` processes on 127.0.0.1, temp configs, free
//! ports, each stopped by pid) and the other verbs as processes against them. Every wait
//! is bounded; nothing is left running.

// `slate demo`: the team's size range and the acoustic team link.
#[path = "cli/demo.rs"]
mod demo;
// `slate demo --record`: its recording replayed by `slate play`, a plan tested against it.
#[path = "cli/demo_record.rs"]
mod demo_record;
// Bad input: a one-line error on stderr, nothing on stdout, a non-zero exit.
#[path = "cli/errors.rs"]
mod errors;
// `slate keys`: a team's certificate authority and its members' keys.
#[path = "cli/keys.rs"]
mod keys;
// `slate node --foxglove`: a Foxglove WebSocket client's channels, schemas and packets.
#[path = "cli/foxglove.rs"]
mod foxglove;
// `slate launch`: the example teams as processes, restarts, SIGTERM, `--check`.
#[path = "cli/launch.rs"]
mod launch;
// Teams of two and three `slate node` processes: reports, plans, a late joiner, shutdown.
#[path = "cli/multi.rs"]
mod multi;
// `slate hz`, `stats` and `bw` against a two-node team written at a known rate.
#[path = "cli/observe.rs"]
mod observe;
// Verbs that need no team: `check`, `bench`, `help`, and argument errors.
#[path = "cli/offline.rs"]
mod offline;
// Recording in MCAP: from a node's config and with `slate record`, and after a SIGKILL.
#[path = "cli/record.rs"]
mod record;
// Modules that crash and come back, and observers that come and go.
#[path = "cli/restart.rs"]
mod restart;
// A node keeping its board (`state`) killed mid-write and restarted; a damaged store.
#[path = "cli/state.rs"]
mod state;
// Secured teams: TLS with keys from `slate keys`, each member speaking only as itself.
#[path = "cli/secure.rs"]
mod secure;
// A team of `slate node` processes on loopback, and `slate` run with a time limit (helpers).
#[path = "cli/support.rs"]
mod support;
// Each live verb against a two-node team: t/r1/nav owns gsr and rock, t/r2/loco runs plans.
#[path = "cli/verbs.rs"]
mod verbs;
