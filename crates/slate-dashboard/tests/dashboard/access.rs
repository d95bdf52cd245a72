//! Who may read the dashboard: with a token, only a client that shows it (in the query or
//! an `Authorization: Bearer` header); and no route writes anything.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};

use crate::support::{IO_TIMEOUT, counting_source, http_get, serve_local};

/// `METHOD path` with `headers`, and the status code of the answer.
fn status_of(addr: SocketAddr, method: &str, path: &str, headers: &str) -> u16 {
    let mut stream = TcpStream::connect_timeout(&addr, IO_TIMEOUT).unwrap();
    stream.set_read_timeout(Some(IO_TIMEOUT)).unwrap();
    let request = format!(
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\nContent-Length: 0\r\n{headers}\r\n"
    );
    stream.write_all(request.as_bytes()).unwrap();
    let mut raw = String::new();
    stream.read_to_string(&mut raw).unwrap();
    raw.split(' ').nth(1).and_then(|s| s.parse().ok()).unwrap()
}

#[test]
fn a_dashboard_with_a_token_answers_only_a_client_that_shows_it() {
    let token = "s3cret-token".to_owned();
    let loopback = SocketAddr::from(([127, 0, 0, 1], 0));
    let dashboard =
        slate_dashboard::serve_with_token(loopback, counting_source(), Some(token.clone()))
            .unwrap();
    let addr = dashboard.local_addr();
    assert_eq!(dashboard.url(), format!("http://{addr}/?token={token}"));
    for path in ["/", "/api/snapshot", "/ws"] {
        let refused = http_get(addr, path);
        assert_eq!(refused.status, 401, "{path}");
        assert!(
            refused.body.contains("this dashboard needs its token"),
            "{}",
            refused.body
        );
        assert_eq!(http_get(addr, &format!("{path}?token=wrong")).status, 401);
    }
    assert_eq!(
        http_get(addr, &format!("/api/snapshot?token={token}")).status,
        200
    );
    let bearer = format!("Authorization: Bearer {token}\r\n");
    assert_eq!(status_of(addr, "GET", "/api/snapshot", &bearer), 200);
    let page = http_get(addr, &format!("/?token={token}"));
    assert_eq!(page.status, 200);
    assert!(
        page.body.contains("tokenQuery"),
        "the page passes its token on"
    );
    // The health check says only "ok", to anyone.
    assert_eq!(http_get(addr, "/healthz").status, 200);
}

#[test]
fn a_dashboard_on_loopback_needs_no_token() {
    let dashboard = serve_local(counting_source());
    assert_eq!(dashboard.token(), None);
    assert_eq!(
        http_get(dashboard.local_addr(), "/api/snapshot").status,
        200
    );
}

#[test]
fn no_route_of_the_dashboard_writes() {
    let dashboard = serve_local(counting_source());
    let addr = dashboard.local_addr();
    for path in ["/", "/api/snapshot", "/ws", "/healthz"] {
        for method in ["POST", "PUT", "PATCH", "DELETE"] {
            assert_eq!(status_of(addr, method, path, ""), 405, "{method} {path}");
        }
    }
}
