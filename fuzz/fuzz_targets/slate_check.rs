//! A whole `.slate` load (parse, check, apply, install plans) on any text, on a fresh
//! board: no panic, a refusal says why (`slate_fuzz::slate_check`).
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| {
    if let Ok(source) = std::str::from_utf8(bytes) {
        slate_fuzz::slate_check(source);
    }
});
