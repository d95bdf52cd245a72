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
        // A static is never dropped, so a temp_dir guard here would leave its folder
        // behind: the recording goes to a fixed folder of the target dir, replaced each run.
        let dir = slate_testing::target_dir().join("demo-record");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
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
    // `slate play` counts each packet of a class channel's message (a list of packets).
    let (messages, played_steps) = counts(&demo.mcap);
    assert_eq!(recording["messages"], messages);
    assert!(
        played_steps >= messages,
        "{played_steps} steps in {messages} messages"
    );
    assert_eq!(played["messages"], played_steps);
    assert_eq!(played["refused"], 0);
    let objects = played["objects"].as_object().unwrap();
    assert!(
        objects.contains_key("mission") && objects.len() > 20,
        "{played}"
    );
    assert_eq!(played["objects"], demo.board);
}

/// The messages of a recording as the `mcap` crate reads them, and its packets and
/// other messages (what `slate play` plays one by one).
fn counts(path: &std::path::Path) -> (u64, u64) {
    let bytes = std::fs::read(path).unwrap();
    let (mut messages, mut steps) = (0, 0);
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        messages += 1;
        steps += if m.channel.topic.starts_with("/slate/class/") {
            let j: Json = serde_json::from_slice(&m.data).unwrap();
            j["packets"].as_array().unwrap().len() as u64
        } else {
            1
        };
    }
    (messages, steps)
}

/// `(plan, event, fired)` of each firing but the installation, in order.
fn firings(list: &Json) -> Vec<(String, String, Option<u64>)> {
    list.as_array()
        .unwrap()
        .iter()
        .filter(|f| f["event"] != "installed")
        .map(|f| {
            let text = |k: &str| f[k].as_str().unwrap().to_owned();
            (text("plan"), text("event"), f["fired"].as_u64())
        })
        .collect()
}

#[test]
fn the_consoles_plans_tested_against_the_demo_recording_fire_as_they_did_live() {
    let demo = recorded();
    let console = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/demo/console.slate"
    );
    let mcap = demo.mcap.to_str().unwrap();
    // The recording has no derived attributes: `Robot.alive`, which mission_complete
    // reads, is declared in the classes' file.
    let classes = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/demo/classes.slate"
    );
    let out = slate_ok(&[
        "plan",
        "test",
        console,
        "--against",
        mcap,
        "--with",
        classes,
        "--format",
        "json",
    ]);
    let test: Json = serde_json::from_str(&out).unwrap();
    assert_eq!(
        test["plans"],
        serde_json::json!(["call_return", "mission_complete"])
    );
    let (predicted, recorded) = (firings(&test["predicted"]), firings(&test["recorded"]));
    let done = |plan: &str, event: &str| (plan.to_owned(), event.to_owned(), None);
    assert!(
        recorded.contains(&done("call_return", "initiated")),
        "{test}"
    );
    assert!(
        recorded.contains(&done("mission_complete", "initiated")),
        "{test}"
    );
    assert_eq!(predicted, recorded, "{test}");
    let wrote: Vec<&Json> = test["predicted"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["event"] == "triggered")
        .flat_map(|f| f["wrote"].as_array().unwrap())
        .collect();
    let phase = |v: &str| serde_json::json!({"object": "mission", "attr": "phase", "value": v});
    assert_eq!(wrote, [&phase("return"), &phase("complete")], "{test}");
    assert_eq!(demo.summary["mission_phase"], "complete");
}

#[test]
fn a_plan_naming_what_the_recording_lacks_is_refused_with_the_diagnostics() {
    let demo = recorded();
    let dir = temp_dir("plan-test-unknown");
    let plan = dir.join("bad.slate");
    std::fs::write(
        &plan,
        "plan bad { trigger: nowhere.speed > 1.0; action { set nowhere.speed = 0.0; } }",
    )
    .unwrap();
    let out = crate::support::slate(&[
        "plan",
        "test",
        plan.to_str().unwrap(),
        "--against",
        demo.mcap.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("does not load on the recorded board") && err.contains("nowhere"),
        "{err}"
    );
}
