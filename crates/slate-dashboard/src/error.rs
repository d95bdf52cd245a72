//! Errors returned by [`serve`](crate::serve).

use std::io;
use std::net::SocketAddr;

/// Why the dashboard could not start serving.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ServeError {
    /// Another process (or another dashboard) already listens on the address.
    #[error("cannot serve the dashboard on {addr}: the address is already in use")]
    AddrInUse {
        /// The address that was asked for.
        addr: SocketAddr,
        /// The error from the operating system.
        #[source]
        source: io::Error,
    },
    /// The address could not be bound for another reason (permission, not local, ...).
    #[error("cannot serve the dashboard on {addr}: {source}")]
    Bind {
        /// The address that was asked for.
        addr: SocketAddr,
        /// The error from the operating system.
        #[source]
        source: io::Error,
    },
    /// The server's runtime or thread could not be started.
    #[error("cannot start the dashboard server: {0}")]
    Start(#[source] io::Error),
}

impl ServeError {
    pub(crate) fn bind(addr: SocketAddr, source: io::Error) -> Self {
        if source.kind() == io::ErrorKind::AddrInUse {
            Self::AddrInUse { addr, source }
        } else {
            Self::Bind { addr, source }
        }
    }
}
