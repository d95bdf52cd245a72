//! A live web dashboard for a slate world model, served on localhost: a map of objects with
//! their accuracy, confidence and staleness, the class tree, an object inspector, plans with
//! their acknowledgements, links against their budgets, and the event log.
//!
//! The crate knows nothing of boards or nodes: whoever serves it (a node, the multi-robot
//! demo) implements [`DashboardSource`] and returns the view as JSON: it fills a
//! [`Snapshot`], the contract of `docs/dashboard.md` as types, and hands over
//! [`Snapshot::to_json`]. The server runs on its own thread, so the host need not be async.
//!
//! ```
//! use std::net::SocketAddr;
//! use std::sync::Arc;
//! use serde_json::json;
//!
//! # fn main() -> Result<(), slate_dashboard::ServeError> {
//! let source = Arc::new(|| json!({"title": "hello", "time": 1.5, "status": "running"}));
//! let dashboard = slate_dashboard::serve(SocketAddr::from(([127, 0, 0, 1], 0)), source)?;
//! println!("open {}", dashboard.url());
//! dashboard.stop();
//! # Ok(())
//! # }
//! ```
//!
//! Routes: `GET /` (the page, self-contained), `GET /api/snapshot` (the JSON),
//! `GET /ws` (a WebSocket pushing the JSON every 250 ms), `GET /healthz`; nothing writes.
//! On an address other than loopback, every route but `/healthz` requires a token
//! ([`serve_with_token`]).
#![warn(missing_docs)]

mod access;
mod contract;
mod error;
mod page;
mod routes;
#[cfg(feature = "testing")]
mod sample;
mod server;
mod snapshots;
mod source;

pub use contract::{
    AttrRow, ClassRow, EventRow, ItemKind, Level, LinkRow, MapItem, MapView, ObjectRow, PlanRow,
    STALE_AFTER_S, Snapshot, Status, is_stale,
};
pub use error::ServeError;
#[cfg(feature = "testing")]
pub use sample::SampleTeam;
pub use server::{Dashboard, serve, serve_with_token};
pub use source::DashboardSource;
