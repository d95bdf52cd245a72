//! The ICI transport over Eclipse Zenoh.
//!
//! [`ZenohTransport`] implements [`slate_transport::Transport`]: publications per link kind,
//! reliable direct sends, liveliness tokens for peer up/down, and listening per link kind
//! (a link not listened to has no subscriber, so nothing of it is routed here). By default a
//! node runs in peer mode with explicit endpoints and no multicast scouting, so a team on
//! one LAN needs no router; a team that spans networks connects its nodes to Zenoh routers.
//! Every key expression is built in [`keys`].
#![warn(missing_docs)]

mod endpoint;
pub mod keys;
mod outbox;
mod security;
mod transport;

pub use endpoint::{EndpointError, PROTOCOLS, check_endpoint};
pub use security::{OPERATOR_PREFIX, SECURE_PROTOCOLS, Security, TeamIdentities};
pub use transport::{Mode, OpenError, ZenohConfig, ZenohTransport};
