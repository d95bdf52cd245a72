//! The ICI's receive path on any sequence of messages from its peers (slate-wire
//! messages, the ICI's hello, lifecycle and object-list frames, the team protocol's
//! frames and repairs), on the robot link and the team link: it never panics
//! (`slate_fuzz::ici_receive`; the input format is `slate_fuzz::records`).
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| slate_fuzz::ici_receive(bytes));
