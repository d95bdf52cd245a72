//! Fixtures shared by the integration tests of slate's crates.
//!
//! A dev-dependency only (`publish = false`): nothing here is part of any crate's API.
//! Each helper is one that several crates' tests would otherwise write out themselves;
//! a fixture used by one crate's tests stays in that crate's `tests/<name>/support.rs`.
//!
//! Every wait here is bounded and returns or panics with what it waited for; none
//! asserts how long anything took.

use std::net::TcpListener;
use std::path::PathBuf;
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

/// How often [`eventually`] looks again.
const POLL: Duration = Duration::from_millis(10);

/// The address `text`, which the test wrote and knows to be valid.
pub fn addr(text: &str) -> Address {
    Address::new(text).unwrap()
}

/// A free TCP port on 127.0.0.1 (the OS picks it; the listener is dropped before use).
pub fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
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
/// `name` and the moment; the test removes it when it is done with it.
pub fn temp_dir(name: &str) -> PathBuf {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    let unique = format!("slate-{name}-{}-{nanos}", std::process::id());
    let dir = std::env::temp_dir().join(unique);
    std::fs::create_dir_all(&dir).unwrap();
    dir
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
