//! Integration tests of the world model: one binary, one module per area in `tests/model/`.

// Active functions: on-read, on-write and on-change functions and their chains.
#[path = "model/active.rs"]
mod active;
// Batches: several writes applied together or not at all.
#[path = "model/batch.rs"]
mod batch;
// The class tree: definitions, inheritance, class-level values.
#[path = "model/classes.rs"]
mod classes;
// Many threads on one board: no waiting behind functions, no deadlock.
#[path = "model/concurrency.rs"]
mod concurrency;
// The crate's examples, run end to end.
#[path = "model/examples.rs"]
mod examples;
// Change hooks: called once per revision with what it touched.
#[path = "model/hooks.rs"]
mod hooks;
// Packets of pure on-read functions kept until what they read changes.
#[path = "model/kept.rs"]
mod kept;
// Merge policies of received packets (latest, confident, owned, fused).
#[path = "model/merge.rs"]
mod merge;
// Own writes that receivers would judge differently end the same on every board.
#[path = "model/own_writes.rs"]
mod own_writes;
// Random operation sequences against a plain reference model.
#[path = "model/reference.rs"]
mod reference;
// The world the tests share (the helper module).
#[path = "model/support.rs"]
mod support;
// Values and packets: types, bounds, units, conversions.
#[path = "model/values.rs"]
mod values;
// Watching a board: revisions and change notifications.
#[path = "model/watch.rs"]
mod watch;

// The `gsr_world` example itself, which `examples` runs.
#[allow(dead_code)]
#[path = "../examples/gsr_world.rs"]
mod gsr_world;
