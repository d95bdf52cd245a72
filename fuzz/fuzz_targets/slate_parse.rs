//! The `.slate` lexer and parser on any text: no panic, diagnostics inside the text,
//! printed triggers parse back to themselves (`slate_fuzz::slate_parse`).
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| {
    if let Ok(source) = std::str::from_utf8(bytes) {
        slate_fuzz::slate_parse(source);
    }
});
