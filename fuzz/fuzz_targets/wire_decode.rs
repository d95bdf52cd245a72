//! slate-wire's decoder on any bytes (as from a peer): it never panics, and a message it
//! accepts encodes again and decodes back equal (`slate_wire::fuzz_decode`).
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| slate_wire::fuzz_decode(bytes));
