//! Runs `examples/fake_team.rs` end to end.

use std::io::{BufRead, BufReader};
use std::net::SocketAddr;
use std::process::{Command, Stdio};
use std::time::Duration;

use crate::support::{http_get, target_dir, within};

#[test]
fn fake_team_example_serves_a_moving_team() {
    // `cargo test` builds the examples next to the test binaries' profile directory.
    let exe = std::env::current_exe().unwrap();
    let example = exe
        .parent()
        .unwrap()
        .parent()
        .unwrap()
        .join("examples/fake_team");
    assert!(
        example.exists(),
        "{} is missing; run `cargo test -p slate-dashboard` (which builds examples) (target {})",
        example.display(),
        target_dir().display()
    );
    let mut child = Command::new(&example)
        .args(["127.0.0.1:0", "--for", "3"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start example");
    let stdout = child.stdout.take().unwrap();
    let url = within(Duration::from_secs(15), move || {
        let mut line = String::new();
        BufReader::new(stdout)
            .read_line(&mut line)
            .expect("read url");
        line
    });
    let addr: SocketAddr = url
        .trim()
        .trim_start_matches("http://")
        .trim_end_matches('/')
        .parse()
        .expect("example prints its URL first");
    let first = http_get(addr, "/api/snapshot").json();
    std::thread::sleep(Duration::from_millis(300));
    let second = http_get(addr, "/api/snapshot").json();
    assert!(second["time"].as_f64() > first["time"].as_f64());
    let robots = first["map"]["items"].as_array().unwrap().iter();
    assert_eq!(robots.filter(|i| i["kind"] == "robot").count(), 3);
    let status = within(Duration::from_secs(15), move || child.wait().expect("wait"));
    assert!(status.success(), "example exited with {status}");
}
