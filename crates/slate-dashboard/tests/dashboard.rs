//! Integration tests of the dashboard server: one binary, one module per area in
//! `tests/dashboard/`.

// Who may read it: a token when one is required; no route writes.
#[path = "dashboard/access.rs"]
mod access;
// Headless Chromium against a live dashboard: the map, values changing, no console errors.
#[path = "dashboard/browser.rs"]
mod browser;
// Runs `examples/fake_team.rs` end to end.
#[path = "dashboard/example.rs"]
mod example;
// Starting and stopping: stop and drop end the server and free its port; bind errors are clear.
#[path = "dashboard/lifecycle.rs"]
mod lifecycle;
// The HTTP routes: the page, the snapshot JSON, health, and unknown routes.
#[path = "dashboard/routes.rs"]
mod routes;
// Helpers shared by the test modules: a tiny HTTP client, sources, timeouts.
#[path = "dashboard/support.rs"]
mod support;
// The WebSocket stream of snapshots, and its end when the server stops.
#[path = "dashboard/websocket.rs"]
mod websocket;
