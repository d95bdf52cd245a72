//! Helpers shared by the test modules: a tiny HTTP client, sources, timeouts.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use serde_json::{Value, json};
use slate_dashboard::{Dashboard, DashboardSource};
pub use slate_testing::{target_dir, within};

/// Socket timeouts: generous, only there so a broken server fails a test instead of hanging it.
pub const IO_TIMEOUT: Duration = Duration::from_secs(10);

/// Serves `source` on a free loopback port.
pub fn serve_local(source: Arc<dyn DashboardSource>) -> Dashboard {
    slate_dashboard::serve(SocketAddr::from(([127, 0, 0, 1], 0)), source).expect("serve")
}

/// A source whose `time` counts its calls: 1, 2, 3, ...
pub fn counting_source() -> Arc<dyn DashboardSource> {
    let calls = AtomicU64::new(0);
    Arc::new(move || {
        let n = calls.fetch_add(1, Ordering::SeqCst) + 1;
        json!({"title": "counting", "time": n as f64, "status": "running",
               "map": {"items": [{"id": "r1", "kind": "robot", "x": n as f64, "y": 0.0}]}})
    })
}

/// One HTTP response, as read off the socket.
pub struct Response {
    pub status: u16,
    pub head: String,
    pub body: String,
}

impl Response {
    /// The value of `name` in the headers (case-insensitive), if present.
    pub fn header(&self, name: &str) -> Option<&str> {
        self.head.lines().find_map(|line| {
            let (key, value) = line.split_once(':')?;
            key.eq_ignore_ascii_case(name).then(|| value.trim())
        })
    }

    pub fn json(&self) -> Value {
        serde_json::from_str(&self.body).expect("body is JSON")
    }
}

/// `GET path` over HTTP/1.1 with `Connection: close`; the server sends lengths, not chunks.
pub fn http_get(addr: SocketAddr, path: &str) -> Response {
    let mut stream = TcpStream::connect_timeout(&addr, IO_TIMEOUT).expect("connect");
    stream.set_read_timeout(Some(IO_TIMEOUT)).unwrap();
    write!(
        stream,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut raw = String::new();
    stream.read_to_string(&mut raw).expect("read response");
    let (head, body) = raw.split_once("\r\n\r\n").expect("response has a head");
    let status = head
        .split(' ')
        .nth(1)
        .and_then(|s| s.parse().ok())
        .expect("status code");
    Response {
        status,
        head: head.to_owned(),
        body: body.to_owned(),
    }
}
