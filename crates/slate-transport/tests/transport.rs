//! Integration tests of slate-transport: one binary, one module per area in
//! `tests/transport/`.

// The transport conformance suite, on the simulator.
#[path = "transport/conformance.rs"]
mod conformance;
// The simulator's shared channel: one half-duplex transmitter, bounded frames, frame loss.
#[path = "transport/shared_channel.rs"]
mod shared_channel;
// The team link's settings for the team protocol: loss per robot, listening, no team
// liveliness, switching the link mid-run, dropping one publication at named receivers.
#[path = "transport/team_link.rs"]
mod team_link;
