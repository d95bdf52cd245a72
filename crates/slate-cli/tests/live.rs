//! The live verbs against real teams: `slate node` processes on 127.0.0.1 (temp configs,
//! free ports, each stopped by pid), and the other verbs run as processes against them.
//! Every wait is bounded; nothing is left running.

#[path = "live/errors.rs"]
mod errors;
#[path = "live/multi.rs"]
mod multi;
#[path = "live/restart.rs"]
mod restart;
#[path = "live/team.rs"]
mod team;
#[path = "live/verbs.rs"]
mod verbs;
