//! Integration tests of the wire format: one binary, one module per area in `tests/wire/`.

// Golden vectors: the exact bytes of typical messages, in `tests/golden/*.hex`.
#[path = "wire/golden.rs"]
mod golden;
// Properties: encode → decode gives the message back, and no input makes the decoder panic.
#[path = "wire/props.rs"]
mod props;
// Malformed input: every decoder error is typed, counted, and changes nothing.
#[path = "wire/robustness.rs"]
mod robustness;
// Every message kind comes back; names are announced once; catch-up recovers.
#[path = "wire/roundtrip.rs"]
mod roundtrip;
// The headline numbers: bytes of typical messages, measured and (for the targets) asserted.
#[path = "wire/sizes.rs"]
mod sizes;
// Many sources: the per-source dictionaries are bounded, the stalest slots reclaimed.
#[path = "wire/sources.rs"]
mod sources;
// Shared fixtures (the helper module): classes, addresses, packets, the roundtrip tolerance.
#[path = "wire/support.rs"]
mod support;
