//! Endpoints checked before Zenoh sees them, and Zenoh's errors made readable.
//!
//! Zenoh accepts any `PROTOCOL/ADDRESS` text in its config and fails later, when it tries
//! to connect: a typo then reads like a node that is down. [`check_endpoint`] names the
//! mistake at once, and [`error_text`] drops the source locations (`at /home/.../tcp.rs:61.`)
//! Zenoh appends to its messages, which say nothing to a user.

/// The link protocols this build of Zenoh has (its `transport_tcp`, `transport_udp`,
/// `transport_tls`, `transport_quic` and `transport_unixsock-stream` features). TLS and
/// QUIC need certificates in a Zenoh config file (`zenoh_config`, docs/config.md).
pub const PROTOCOLS: &[&str] = &["tcp", "udp", "tls", "quic", "unixsock-stream"];

/// The protocol whose address is a socket's path, not `HOST:PORT`.
const UNIX_SOCKET: &str = "unixsock-stream";

/// An endpoint that cannot be used, with what is wrong in it. Displays as one line.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "endpoint {endpoint:?} {problem}: expected PROTOCOL/HOST:PORT, like tcp/127.0.0.1:7447 (or unixsock-stream/PATH)"
)]
pub struct EndpointError {
    /// The endpoint as given.
    pub endpoint: String,
    /// What is wrong with it (`has no port`).
    pub problem: String,
}

/// Checks that `endpoint` is one Zenoh can use: `PROTOCOL/HOST:PORT` (Zenoh's syntax,
/// with optional `?metadata` and `#config`), a protocol of [`PROTOCOLS`], a host and a
/// port (0 asks the system for a free one, when listening); `unixsock-stream/PATH` for a
/// Unix socket.
pub fn check_endpoint(endpoint: &str) -> Result<(), EndpointError> {
    let bad = |problem: String| EndpointError {
        endpoint: endpoint.to_owned(),
        problem,
    };
    let parsed: zenoh::config::EndPoint = endpoint
        .parse()
        .map_err(|_| bad("is not PROTOCOL/ADDRESS".to_owned()))?;
    let protocol = parsed.protocol();
    let protocol = protocol.as_str();
    if !PROTOCOLS.contains(&protocol) {
        let have = PROTOCOLS.join(", ");
        return Err(bad(format!(
            "uses protocol {protocol:?}, which this build does not have (it has: {have})"
        )));
    }
    if protocol == UNIX_SOCKET {
        return Ok(());
    }
    check_host_port(parsed.address().as_str()).map_err(bad)
}

/// `HOST:PORT` (an IPv6 host in brackets), or what is wrong with it.
fn check_host_port(address: &str) -> Result<(), String> {
    let Some((host, port)) = address.rsplit_once(':') else {
        return Err("has no port".to_owned());
    };
    if host.is_empty() || host == "[]" {
        return Err("has no host".to_owned());
    }
    match port.parse::<u16>() {
        Ok(_) => Ok(()),
        Err(_) => Err(format!("has port {port:?}, not a number in 0..=65535")),
    }
}

/// Zenoh's message without the source locations it appends (` at PATH.rs:LINE.`).
pub fn error_text(message: &str) -> String {
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(i) = rest.find(" at ") {
        out.push_str(&rest[..i]);
        let after = &rest[i + 4..];
        let location_end = after.find(|c: char| c.is_whitespace() || c == ']');
        let location = &after[..location_end.unwrap_or(after.len())];
        if is_location(location) {
            rest = &after[location.len()..];
        } else {
            out.push_str(" at ");
            rest = after;
        }
    }
    out.push_str(rest);
    out.trim_end().to_owned()
}

/// `/path/to/file.rs:61` or `/path/to/file.rs:61.`
fn is_location(text: &str) -> bool {
    let text = text.strip_suffix('.').unwrap_or(text);
    text.rsplit_once(".rs:")
        .is_some_and(|(_, line)| !line.is_empty() && line.bytes().all(|b| b.is_ascii_digit()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_well_formed_tcp_endpoint_passes() {
        for e in [
            "tcp/127.0.0.1:7447",
            "tcp/localhost:0",
            "tcp/[::1]:7447",
            "tcp/127.0.0.1:7447#iface=lo",
            "udp/127.0.0.1:7447",
            "tls/localhost:7447",
            "quic/127.0.0.1:7447",
            "unixsock-stream//tmp/slate.sock",
        ] {
            assert_eq!(check_endpoint(e), Ok(()), "{e}");
        }
    }

    #[test]
    fn a_malformed_endpoint_says_what_is_wrong() {
        for (e, says) in [
            ("not-an-endpoint", "is not PROTOCOL/ADDRESS"),
            ("tcp/", "is not PROTOCOL/ADDRESS"),
            ("serial/ttyUSB0", "uses protocol \"serial\""),
            ("tcp/127.0.0.1", "has no port"),
            ("tcp/:7447", "has no host"),
            ("tcp/127.0.0.1:99999", "has port \"99999\""),
        ] {
            let err = check_endpoint(e).unwrap_err().to_string();
            assert!(err.contains(says), "{e}: {err}");
            assert!(err.contains("like tcp/127.0.0.1:7447"), "{err}");
        }
    }

    #[test]
    fn zenoh_source_locations_are_dropped_from_its_messages() {
        let zenoh = "Can not create a new TCP listener bound to tcp/127.0.0.1:4: [127.0.0.1:4: Address already in use (os error 98) at /root/.cargo/registry/src/x/zenoh-link-commons-1.10.2/src/tcp.rs:61.] at /root/.cargo/registry/src/x/zenoh-link-tcp-1.10.2/src/unicast.rs:338.";
        assert_eq!(
            error_text(zenoh),
            "Can not create a new TCP listener bound to tcp/127.0.0.1:4: [127.0.0.1:4: Address already in use (os error 98)]"
        );
        assert_eq!(error_text("meet at noon"), "meet at noon");
    }
}
