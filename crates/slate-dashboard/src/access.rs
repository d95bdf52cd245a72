//! Who may read the dashboard: anyone who can reach a loopback address, and otherwise only
//! a client that shows the dashboard's token (`?token=TOKEN` in the URL, or the header
//! `Authorization: Bearer TOKEN`). The dashboard is read-only (every route is a `GET`);
//! the token keeps the team's world model from whoever else shares the network. It is
//! sent in clear over HTTP: on an untrusted network, reach the dashboard through an SSH
//! tunnel or a TLS proxy (docs/security.md).

use std::io::Read;
use std::net::SocketAddr;
use std::sync::Arc;

use axum::extract::{Request, State};
use axum::http::{StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

/// Bytes of randomness in a generated token.
const TOKEN_BYTES: usize = 16;

/// The token a dashboard on `addr` requires: `given` if any; none on a loopback address;
/// otherwise one generated from the system's randomness (`/dev/urandom`).
pub(crate) fn token_for(
    addr: SocketAddr,
    given: Option<String>,
) -> std::io::Result<Option<String>> {
    match given {
        Some(token) => Ok(Some(token)),
        None if addr.ip().is_loopback() => Ok(None),
        None => generate().map(Some),
    }
}

/// A random token, as hex.
fn generate() -> std::io::Result<String> {
    let mut bytes = [0u8; TOKEN_BYTES];
    std::fs::File::open("/dev/urandom")?.read_exact(&mut bytes)?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// Lets a request through if no token is required or it shows the token; answers 401
/// with what to do otherwise. `/healthz` is always open (it says only "ok").
pub(crate) async fn require(
    State(token): State<Option<Arc<str>>>,
    request: Request,
    next: Next,
) -> Response {
    let Some(token) = token else {
        return next.run(request).await;
    };
    if request.uri().path() == "/healthz" || shows(&request, &token) {
        return next.run(request).await;
    }
    (
        StatusCode::UNAUTHORIZED,
        [(header::CONTENT_TYPE, "text/plain; charset=utf-8")],
        "this dashboard needs its token: open the URL the node printed at start (ending in ?token=...), or send the header `Authorization: Bearer TOKEN`\n",
    )
        .into_response()
}

/// Does the request carry `token` in its query or its `Authorization` header?
fn shows(request: &Request, token: &str) -> bool {
    let in_query = request
        .uri()
        .query()
        .into_iter()
        .flat_map(|q| q.split('&'))
        .filter_map(|pair| pair.strip_prefix("token="))
        .any(|given| same(given, token));
    let in_header = request
        .headers()
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "))
        .is_some_and(|given| same(given.trim(), token));
    in_query || in_header
}

/// Compares in time independent of where the texts differ (not of their lengths).
fn same(given: &str, token: &str) -> bool {
    given.len() == token.len()
        && given
            .bytes()
            .zip(token.bytes())
            .fold(0u8, |acc, (a, b)| acc | (a ^ b))
            == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_loopback_address_needs_no_token_and_any_other_gets_one() {
        let lo: SocketAddr = "127.0.0.1:0".parse().unwrap();
        let any: SocketAddr = "0.0.0.0:0".parse().unwrap();
        assert_eq!(token_for(lo, None).unwrap(), None);
        let generated = token_for(any, None).unwrap().unwrap();
        assert_eq!(generated.len(), 2 * TOKEN_BYTES);
        assert_ne!(token_for(any, None).unwrap().unwrap(), generated);
        assert_eq!(token_for(lo, Some("t".into())).unwrap(), Some("t".into()));
    }

    #[test]
    fn tokens_compare_whole() {
        assert!(same("abc", "abc"));
        assert!(!same("abd", "abc"));
        assert!(!same("ab", "abc"));
    }
}
