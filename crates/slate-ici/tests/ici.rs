//! Integration tests of the ICI and the simulator, one module per area (files in `ici/`).

#[path = "ici/basics.rs"]
mod basics;
#[path = "ici/circuits.rs"]
mod circuits;
#[path = "ici/common.rs"]
mod common;
#[path = "ici/determinism.rs"]
mod determinism;
#[path = "ici/faults.rs"]
mod faults;
#[path = "ici/filters.rs"]
mod filters;
#[path = "ici/interest.rs"]
mod interest;
#[path = "ici/merge.rs"]
mod merge;
#[path = "ici/own_writes.rs"]
mod own_writes;
#[path = "ici/plans.rs"]
mod plans;
#[path = "ici/random.rs"]
mod random;
#[path = "ici/threads.rs"]
mod threads;
