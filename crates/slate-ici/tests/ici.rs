//! Integration tests of the ICI and the simulator: one binary, one module per area in `tests/ici/`.

// Reports, objects, contexts, classes and deletions on clean links.
#[path = "ici/basics.rs"]
mod basics;
// Plan circuits: a plan sent to another module and every step of its progression.
#[path = "ici/circuits.rs"]
mod circuits;
// One seed, one run: the same scenario twice gives the same counters and boards.
#[path = "ici/determinism.rs"]
mod determinism;
// Convergence under loss, duplication, reordering, partitions, late joins, restarts.
#[path = "ici/faults.rs"]
mod faults;
// Report policies: fewer messages, never a lost final value.
#[path = "ici/filters.rs"]
mod filters;
// Gateway election: one module speaks for its robot on the team link.
#[path = "ici/gateway.rs"]
mod gateway;
// Interest (what a board models) and export policy (what leaves a robot).
#[path = "ici/interest.rs"]
mod interest;
// Link policies: the team link's own filters, `never`, export and liveliness from `link` blocks.
// Bounds per source and in total: objects, modules heard of.
#[path = "ici/limits.rs"]
mod limits;
#[path = "ici/links.rs"]
mod links;
// Lossless classes: published with `Flow::Every`, past the links' filters.
#[path = "ici/lossless.rs"]
mod lossless;
// Merge policies across boards: owned, confident, fused.
#[path = "ici/merge.rs"]
mod merge;
// Own writes receivers would judge differently are refused at the writer.
#[path = "ici/own_writes.rs"]
mod own_writes;
// The plan engine's extension point: raw plan messages out, a handler in.
#[path = "ici/plans.rs"]
mod plans;
// Random fault mixes on a small team, from many seeds: every board must agree.
#[path = "ici/random.rs"]
mod random;
// A module restarted with its board restored: its peers keep its objects.
#[path = "ici/restart.rs"]
mod restart;
// Robot-stream repair: NACK with suppression, one broadcast repair, hello NACK, Gone.
#[path = "ici/repair.rs"]
mod repair;
// State requests through the robot stream: newcomers, restarts, healed partitions.
#[path = "ici/state.rs"]
mod state;
// A team on a simulated network, and the convergence check (the helper module).
#[path = "ici/support.rs"]
mod support;
// The team protocol switched on: gateways, frames, convergence, liveliness.
#[path = "ici/team.rs"]
mod team;
// The ICI under threads: writers on several threads, no deadlock, boards agree.
#[path = "ici/threads.rs"]
mod threads;
