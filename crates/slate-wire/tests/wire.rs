//! Integration tests of the wire format, one module per area (files in `wire/`).

#[path = "wire/common.rs"]
mod common;
#[path = "wire/golden.rs"]
mod golden;
#[path = "wire/props.rs"]
mod props;
#[path = "wire/robustness.rs"]
mod robustness;
#[path = "wire/roundtrip.rs"]
mod roundtrip;
#[path = "wire/sizes.rs"]
mod sizes;
#[path = "wire/sources.rs"]
mod sources;
