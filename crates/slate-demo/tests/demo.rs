//! Integration tests of the demo: one binary, one module per area in `tests/demo/`.

// The dashboard of a running demo in headless Chromium: robots, values, plans, no errors.
#[path = "demo/browser.rs"]
mod browser;
// The roles' team exports from their files, the deck phase, the acoustic link's filters.
#[path = "demo/deck.rs"]
mod deck;
// The demo's `.slate` files load where they are meant to, and so does every plan sent.
#[path = "demo/files.rs"]
mod files;
// The mission end to end on the simulator, with fixed seeds.
#[path = "demo/mission.rs"]
mod mission;
// The team at scale (up to 32 robots) and the acoustic channel.
#[path = "demo/scale.rs"]
mod scale;
// `--speakers robots`: one gateway per robot (the team protocol being built).
#[path = "demo/speakers.rs"]
mod speakers;
// Shared helpers: fast configurations (and the shared timeout guard).
#[path = "demo/support.rs"]
mod support;
