//! Why the server cannot start.

use crate::history::DbError;
use std::net::SocketAddr;

/// Why the server cannot start (a request that cannot be answered gets a 4xx or 5xx with its
/// reason instead, `routes`).
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The results database is missing, not wheelflat's, newer, or unreadable.
    #[error(transparent)]
    Db(#[from] DbError),
    /// The fleet store cannot be read (`serve --fleet`).
    #[error(transparent)]
    Fleet(#[from] crate::fleet::FleetError),
    /// A non-local address without a token.
    #[error("refusing to listen on {addr} without a token: the pages name the fleet's wheels and their flats. Give one with --token-file (at least 16 characters), or listen on 127.0.0.1 behind a reverse proxy that authenticates (docs/serve.md)")]
    Exposed {
        /// The address asked for.
        addr: SocketAddr,
    },
    /// A token that is not one.
    #[error("{0}")]
    Token(String),
    /// The address could not be bound.
    #[error("cannot listen on {addr}")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The server's runtime failed.
    #[error("the server stopped")]
    Runtime(#[source] std::io::Error),
}
