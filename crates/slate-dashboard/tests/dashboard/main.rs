//! Integration tests for the dashboard server, one module per area.

mod browser;
mod example;
mod lifecycle;
mod routes;
mod support;
mod websocket;
