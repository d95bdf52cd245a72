//! Fixtures shared by the integration tests of slate's crates.
//!
//! A dev-dependency only (`publish = false`): nothing here is part of any crate's API.
//! Each helper is one that several crates' tests would otherwise write out themselves;
//! a fixture used by one crate's tests stays in that crate's `tests/<name>/support.rs`.
//!
//! Every wait here is bounded and returns or panics with what it waited for; none
//! asserts how long anything took.

use std::fmt::Display;
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream, ToSocketAddrs};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use slate_cdp::{Chromium, Page};
use slate_model::Address;

/// The classes the node and CLI tests load: a vehicle with a position, a speed and a
/// mode, and obstacles with a position and a range.
pub const WORLD: &str = r#"
class Vehicle {
    position: vec<2> [m] = [0.0, 0.0] accuracy 1.0;
    speed: real [m/s] in 0 .. 10 = 0.0;
    mode: string = "auto";
}
class Obstacle { position: vec<2> [m]; range: real [m]; }
"#;

/// How long [`http_get`] waits to connect, and for each read.
const HTTP_TIMEOUT: Duration = Duration::from_secs(10);

/// How often [`eventually`] looks again.
const POLL: Duration = Duration::from_millis(10);

/// The address `text`, which the test wrote and knows to be valid.
pub fn addr(text: &str) -> Address {
    Address::new(text).unwrap()
}

/// A port on 127.0.0.1 free for TCP and UDP (bound once and released), below the
/// kernel's ephemeral range: see [`free_ports`].
pub fn free_port() -> u16 {
    free_ports(1)
}

/// The first of `n` consecutive ports on 127.0.0.1 free for TCP and for UDP (each bound
/// once and released: a node listens on UDP beside each TCP port), at most 200 tries. They are drawn below the kernel's ephemeral range: a
/// node that connects to a mate before the mate listens can, for a port in that range,
/// get the port itself as its connection's source (a TCP self-connect), after which the
/// mate cannot listen there ("Address already in use"; seen in CI with 16 processes).
pub fn free_ports(n: u16) -> u16 {
    use std::sync::atomic::{AtomicU64, Ordering};
    static DRAWS: AtomicU64 = AtomicU64::new(0);
    let ephemeral = std::fs::read_to_string("/proc/sys/net/ipv4/ip_local_port_range")
        .ok()
        .and_then(|t| t.split_whitespace().next()?.parse::<u16>().ok())
        .unwrap_or(32768);
    let (low, high) = (10_000u16, ephemeral.saturating_sub(n).max(10_001));
    let start = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    for _ in 0..200 {
        let draw = DRAWS.fetch_add(1, Ordering::Relaxed);
        let seed = (u64::from(std::process::id()) << 32 ^ draw ^ u64::from(start))
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let base = low + ((seed >> 33) % u64::from(high - low)) as u16;
        let free = |port: u16| {
            TcpListener::bind(("127.0.0.1", port)).is_ok()
                && std::net::UdpSocket::bind(("127.0.0.1", port)).is_ok()
        };
        if (0..n).all(|i| free(base + i)) {
            return base;
        }
    }
    panic!("no block of {n} free TCP and UDP ports on 127.0.0.1 below {ephemeral}");
}

/// A free UDP port on 127.0.0.1 (the OS picks it; the socket is dropped before use).
pub fn free_udp_port() -> u16 {
    std::net::UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .map(|a| a.port())
        .expect("a free udp port")
}

/// Polls `done` until it holds or `limit` passes; whether it held. For what runs on
/// real time (threads, processes, sockets); simulated runs step their own clock.
pub fn eventually(limit: Duration, mut done: impl FnMut() -> bool) -> bool {
    let deadline = Instant::now() + limit;
    while Instant::now() < deadline {
        if done() {
            return true;
        }
        std::thread::sleep(POLL);
    }
    done()
}

/// Runs `f` on its own thread and fails the test if it takes longer than `limit` (a
/// guard against hangs, not a performance assertion).
pub fn within<T: Send + 'static>(limit: Duration, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(limit)
        .unwrap_or_else(|_| panic!("did not finish within {limit:?}"))
}

/// The cargo target directory the running test binary was built into (`target/`).
pub fn target_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("current exe");
    // <target>/<profile>/deps/<test binary>
    exe.ancestors().nth(3).expect("target dir").to_path_buf()
}

/// A fresh, empty folder under the system's temporary folder, unique to this process,
/// `name` and the moment. The folder lives as long as the returned guard: dropping it
/// removes the folder and all it holds, so keep the guard bound for the test's length
/// (`let dir = temp_dir("x"); let f = dir.join("f")`, never `temp_dir("x").join("f")`,
/// whose guard is dropped at the end of the statement).
pub fn temp_dir(name: &str) -> TempDir {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let unique = format!("slate-{name}-{}-{nanos}", std::process::id());
    let path = std::env::temp_dir().join(unique);
    std::fs::create_dir_all(&path).unwrap();
    TempDir { path }
}

/// A folder made by [`temp_dir`], removed with all it holds when this is dropped (also
/// when the test fails and unwinds), so test runs leave nothing in the temporary folder.
#[derive(Debug)]
#[must_use = "the folder is removed when this guard is dropped"]
pub struct TempDir {
    /// The folder's path; it exists until the guard is dropped.
    path: PathBuf,
}

impl TempDir {
    /// The folder's path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl std::ops::Deref for TempDir {
    type Target = Path;

    fn deref(&self) -> &Path {
        &self.path
    }
}

impl AsRef<Path> for TempDir {
    fn as_ref(&self) -> &Path {
        &self.path
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
    }
}

/// Saves a screenshot of `page` as `file` in [`target_dir`] and fails the test if the
/// page logged any console error (with the browser's log to tell why); the path saved.
pub fn screenshot_without_errors(page: &mut Page, chromium: &Chromium, file: &str) -> PathBuf {
    let shot = target_dir().join(file);
    page.screenshot(&shot);
    assert_no_console_errors(page, chromium);
    shot
}

/// Fails the test if `page` logged any console error, showing the browser's log.
pub fn assert_no_console_errors(page: &mut Page, chromium: &Chromium) {
    let errors = page.console_errors();
    assert!(
        errors.is_empty(),
        "console errors: {errors:#?}\nchromium log:\n{}",
        chromium.log_tail()
    );
}

/// One HTTP response, as read off the socket.
pub struct Response {
    /// The status code.
    pub status: u16,
    /// The status line and the headers.
    pub head: String,
    /// Everything after the head.
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

    /// The body as JSON; fails the test, showing the body, if it is not.
    pub fn json(&self) -> serde_json::Value {
        serde_json::from_str(&self.body).unwrap_or_else(|e| panic!("{e}: {}", self.body))
    }
}

/// `GET path` over HTTP/1.1 with `Connection: close` from `server` (a socket address,
/// or a URL such as `http://127.0.0.1:8080/`); the servers tested send lengths, not chunks.
pub fn http_get(server: impl Display, path: &str) -> Response {
    let url = server.to_string();
    let host = url.trim_start_matches("http://").trim_end_matches('/');
    let addr = host.to_socket_addrs().ok().and_then(|mut a| a.next());
    let addr = addr.unwrap_or_else(|| panic!("{host} is not a socket address"));
    let mut stream = TcpStream::connect_timeout(&addr, HTTP_TIMEOUT).expect("connect");
    stream.set_read_timeout(Some(HTTP_TIMEOUT)).unwrap();
    let request = format!("GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n");
    stream.write_all(request.as_bytes()).unwrap();
    let mut raw = String::new();
    stream.read_to_string(&mut raw).expect("read response");
    parse_response(&raw)
}

/// Splits a whole HTTP response into status, head and body.
fn parse_response(raw: &str) -> Response {
    let (head, body) = raw.split_once("\r\n\r\n").expect("response has a head");
    let status = head.split(' ').nth(1).and_then(|s| s.parse().ok());
    Response {
        status: status.expect("status code"),
        head: head.to_owned(),
        body: body.to_owned(),
    }
}

/// The first entry of the JSON array `list` whose `key` is `value` (`None` if there is
/// none, or `list` is not an array): how the tests pick a class, plan or object out of
/// a snapshot or a verb's JSON.
pub fn entry<'j>(
    list: &'j serde_json::Value,
    key: &str,
    value: &str,
) -> Option<&'j serde_json::Value> {
    list.as_array()?.iter().find(|e| e[key] == value)
}

/// The text `key` of each entry of the JSON array `list` that has one (none if `list` is
/// not an array): the names of the classes, objects or plans in a snapshot.
pub fn keys<'j>(list: &'j serde_json::Value, key: &str) -> Vec<&'j str> {
    let entries = list.as_array().map_or(&[][..], Vec::as_slice);
    entries.iter().filter_map(|e| e[key].as_str()).collect()
}
