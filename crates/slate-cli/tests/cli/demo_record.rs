//! A recording of the demo (`slate demo --record`, the console's board) replayed with
//! `slate play`, and a plan tested against it with `slate plan test --against`. The demo
//! runs once for every test here.

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::time::Duration;

use serde_json::Value as Json;

use crate::support::{show, slate_ok, temp_dir, wait_output};

/// Longest the recorded demo may take (a debug build runs it in about half a minute).
const DEMO_LIMIT: Duration = Duration::from_secs(300);

/// The demo's recording, its summary and the console's board as the run ended.
struct Recorded {
    mcap: PathBuf,
    summary: Json,
    board: Json,
}

fn recorded() -> &'static Recorded {
    static RECORDED: OnceLock<Recorded> = OnceLock::new();
    RECORDED.get_or_init(|| {
        let dir = temp_dir("demo-record");
        let (mcap, board) = (dir.join("demo.mcap"), dir.join("final.json"));
        let child = Command::new(env!("CARGO_BIN_EXE_slate"))
            .args(["demo", "--quiet", "--format", "json", "--record"])
            .arg(&mcap)
            .arg("--final-board")
            .arg(&board)
            .env_remove("RUST_LOG")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("run slate demo");
        let out = wait_output(child, DEMO_LIMIT);
        assert!(out.status.success(), "{}", show(&out));
        Recorded {
            summary: serde_json::from_slice(&out.stdout).expect("the summary"),
            board: serde_json::from_str(&std::fs::read_to_string(&board).unwrap()).unwrap(),
            mcap,
        }
    })
}

#[test]
fn a_replayed_demo_recording_ends_with_the_console_board_the_demo_ended_with() {
    let demo = recorded();
    let recording = &demo.summary["recording"];
    assert_eq!(recording["dropped"], 0, "{recording}");
    let mcap = demo.mcap.to_str().unwrap();
    let out = slate_ok(&["play", mcap, "--speed", "max", "--format", "json"]);
    let played: Json = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(played["address"], "team/base/console");
    assert_eq!(played["complete"], true);
    assert_eq!(played["messages"], recording["messages"]);
    assert_eq!(played["refused"], 0);
    let objects = played["objects"].as_object().unwrap();
    assert!(
        objects.contains_key("mission") && objects.len() > 20,
        "{played}"
    );
    assert_eq!(played["objects"], demo.board);
}
