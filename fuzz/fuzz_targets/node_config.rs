//! A node's TOML config on any text, read as `slate node --config` reads it: no panic,
//! a refusal says why (`slate_fuzz::node_config`).
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| {
    if let Ok(text) = std::str::from_utf8(bytes) {
        slate_fuzz::node_config(text);
    }
});
