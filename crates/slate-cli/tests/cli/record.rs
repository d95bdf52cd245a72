//! Recording in MCAP from the command line: a node recording its own board from its
//! config, `slate record` recording the team from outside, both read back with the `mcap`
//! crate; and a recording node killed with SIGKILL, its file read up to the last chunk.

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use mcap::read::Options;
use serde_json::{Value as Json, json};

use crate::support::{Team, eventually, show, temp_dir, wait_output};

/// The JSON of every message on `topic` in `bytes` (a finished file, or one cut off: read
/// to the last complete record); a class channel's message is a list of packets
/// (`{"packets": [...]}`): each of them.
fn on(bytes: &[u8], topic: &str) -> Vec<Json> {
    let Ok(stream) = mcap::MessageStream::new_with_options(bytes, Options::IgnoreEndMagic.into())
    else {
        return Vec::new();
    };
    stream
        .map_while(Result::ok)
        .filter(|m| m.channel.topic == topic)
        .flat_map(|m| {
            let j: Json = serde_json::from_slice(&m.data).unwrap();
            match j["packets"].as_array() {
                Some(packets) if topic.starts_with("/slate/class/") => packets.clone(),
                _ => vec![j],
            }
        })
        .collect()
}

/// The values of `object.attr` on the class channel `class`, in order.
fn values(bytes: &[u8], class: &str, object: &str, attr: &str) -> Vec<Json> {
    on(bytes, &format!("/slate/class/{class}"))
        .into_iter()
        .filter(|j| j["object"] == object && j["attr"] == attr)
        .map(|j| j["values"][attr].clone())
        .collect()
}

/// Waits (at most 20 s) until the file on disk holds `value` for `object.attr`.
pub(crate) fn wait_recorded(
    path: &Path,
    class: &str,
    object: &str,
    attr: &str,
    value: &Json,
) -> bool {
    eventually(Duration::from_secs(20), || {
        let bytes = std::fs::read(path).unwrap_or_default();
        values(&bytes, class, object, attr).contains(value)
    })
}

/// A finished file: it ends with the magic and has a summary counting its messages.
fn finished(path: &Path) -> Vec<u8> {
    let bytes = std::fs::read(path).unwrap();
    assert!(
        bytes.ends_with(mcap::MAGIC),
        "{} is finished",
        path.display()
    );
    let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
    let count = mcap::MessageStream::new(&bytes).unwrap().count() as u64;
    assert_eq!(summary.stats.map(|s| s.message_count), Some(count));
    bytes
}

#[test]
fn a_node_records_its_board_and_slate_record_records_the_team_from_outside() {
    let mut team = Team::new("record");
    let own = team.dir.join("nav.mcap");
    let outside = team.dir.join("team.mcap");
    team.add_recording("t/r1/nav", "object gsr : Vehicle context self;", &own);
    team.add("t/r2/loco", "object rock : Obstacle { range = 7.5; }");
    team.wait_connected();
    let out = outside.to_str().unwrap();
    let recorder = team.spawn(&["record", "-o", out, "Vehicle", "rock", "--format", "json"]);
    // The team's state is in the file as soon as the recorder has joined.
    assert!(
        wait_recorded(&outside, "Obstacle", "rock", "range", &json!(7.5)),
        "{}",
        team.logs()
    );
    team.ok(&["put", "gsr.speed", "1.5"]);
    team.ok(&["put", "rock.range", "3.25"]);
    assert!(
        wait_recorded(&outside, "Vehicle", "gsr", "speed", &json!(1.5)),
        "{}",
        team.logs()
    );
    assert!(wait_recorded(
        &outside,
        "Obstacle",
        "rock",
        "range",
        &json!(3.25)
    ));
    let child = recorder.take();
    let pid = child.id().to_string();
    assert!(
        Command::new("kill")
            .args(["-INT", &pid])
            .status()
            .unwrap()
            .success()
    );
    let output = wait_output(child, Duration::from_secs(20));
    assert!(output.status.success(), "{}", show(&output));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("recording Vehicle, rock on t"), "{stderr}");
    let summary: Json = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(summary["event"], "recorded");
    assert_eq!(summary["files"], json!([out]));
    assert_eq!(summary["dropped"], json!(0));

    let bytes = finished(&outside);
    assert_eq!(
        values(&bytes, "Obstacle", "rock", "range"),
        [json!(7.5), json!(3.25)]
    );
    assert!(values(&bytes, "Vehicle", "gsr", "speed").contains(&json!(1.5)));
    let put = on(&bytes, "/slate/class/Vehicle")
        .into_iter()
        .find(|j| j["values"]["speed"] == json!(1.5))
        .unwrap();
    assert!(put["source"].as_str().unwrap().contains("/cli-"), "{put}");
    let objects: Vec<Json> = on(&bytes, "/slate/objects");
    assert!(
        objects
            .iter()
            .all(|j| j["object"] == "gsr" || j["object"] == "rock"),
        "{objects:?}"
    );
    assert_eq!(
        summary["messages"].as_u64(),
        Some(mcap::MessageStream::new(&bytes).unwrap().count() as u64)
    );

    let nav_log = team.logs();
    let live_objects = object_names(&team.nodes[0].snapshot());
    let (clean, _) = team.nodes.remove(0).stop();
    assert!(clean, "{nav_log}");
    let bytes = finished(&own);
    assert!(
        values(&bytes, "Vehicle", "gsr", "speed").contains(&json!(1.5)),
        "{nav_log}"
    );
    assert!(values(&bytes, "Obstacle", "rock", "range").contains(&json!(3.25)));
    let loco_up = on(&bytes, "/slate/liveliness")
        .iter()
        .any(|j| j["module"] == "t/r2/loco" && j["alive"] == json!(true));
    assert!(loco_up, "nav recorded loco coming up");
    assert!(!on(&bytes, "/slate/links").is_empty(), "link counters");

    // The recording replayed: the board nav ended with, same objects, same packets.
    let out = crate::support::slate_ok(&[
        "play",
        own.to_str().unwrap(),
        "--speed",
        "max",
        "--format",
        "json",
    ]);
    let played: Json = serde_json::from_str(&out).unwrap();
    assert_eq!(
        (&played["event"], &played["address"], &played["refused"]),
        (&json!("played"), &json!("t/r1/nav"), &json!(0)),
        "{played}"
    );
    let objects = played["objects"].as_object().unwrap();
    let replayed: Vec<String> = objects
        .keys()
        .filter(|k| objects[*k]["class"] != "Module")
        .cloned()
        .collect();
    assert_eq!(replayed, live_objects);
    assert_eq!(objects["gsr"]["attrs"]["speed"]["value"], json!(1.5));
    assert_eq!(objects["rock"]["attrs"]["range"]["value"], json!(3.25));
    let source = objects["rock"]["attrs"]["range"]["source"]
        .as_str()
        .unwrap();
    assert!(source.contains("/cli-"), "the writer is kept: {source}");
    team.stop();
}

/// The names of the objects (not `Module`s) of a dashboard snapshot, sorted.
fn object_names(snapshot: &Json) -> Vec<String> {
    let mut names: Vec<String> = snapshot["objects"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|o| o["class"] != "Module")
        .map(|o| o["name"].as_str().unwrap().to_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn a_recording_node_killed_mid_write_leaves_a_file_readable_up_to_its_last_chunk() {
    let mut team = Team::new("record-kill");
    let own = team.dir.join("nav.mcap");
    team.add_recording("t/r1/nav", "object gsr : Vehicle context self;", &own);
    for speed in ["1", "2", "3"] {
        team.ok(&["put", "gsr.speed", speed]);
    }
    assert!(
        wait_recorded(&own, "Vehicle", "gsr", "speed", &json!(3.0)),
        "{}",
        team.logs()
    );
    team.nodes.remove(0).kill();
    let bytes = std::fs::read(&own).unwrap();
    assert!(!bytes.ends_with(mcap::MAGIC), "killed: no footer");
    assert_eq!(
        values(&bytes, "Vehicle", "gsr", "speed"),
        [json!(1.0), json!(2.0), json!(3.0)]
    );
    assert!(!on(&bytes, "/slate/classes").is_empty());
    let out = crate::support::slate_ok(&[
        "play",
        own.to_str().unwrap(),
        "--speed",
        "max",
        "--format",
        "json",
    ]);
    let played: Json = serde_json::from_str(&out).unwrap();
    assert_eq!(played["complete"], json!(false), "{played}");
    assert_eq!(
        played["objects"]["gsr"]["attrs"]["speed"]["value"],
        json!(3.0)
    );
    team.stop();
}

#[test]
fn record_explains_itself_and_refuses_a_bad_duration_before_joining() {
    let help = crate::support::slate_ok(&["record", "--help"]);
    for words in [
        "MCAP",
        "Ctrl-C",
        "-o, --output <FILE.mcap>",
        "[PATTERN]...",
        "--max-size-mb",
    ] {
        assert!(help.contains(words), "{words}: {help}");
    }
    let err = crate::support::slate_err(&["record", "-o", "x.mcap", "--for", "-1"]);
    assert!(
        err.contains("--for -1: expected a positive number of seconds"),
        "{err}"
    );
    assert!(!Path::new("x.mcap").exists());
    for (args, expected) in [
        (
            &["play", "x.mcap", "--speed", "0"][..],
            "--speed 0: expected a positive number, or max",
        ),
        (
            &["play", "x.mcap", "--until", "-2"][..],
            "--until -2: expected a number of seconds >= 0",
        ),
        (
            &["play", "/nonexistent/x.mcap"][..],
            "cannot read the recording /nonexistent/x.mcap",
        ),
    ] {
        let err = crate::support::slate_err(args);
        assert!(
            err.contains(expected) && err.lines().count() == 1,
            "{args:?}: {err}"
        );
    }
    let dir = temp_dir("not-mcap");
    let not_mcap = dir.join("hello.mcap");
    std::fs::write(&not_mcap, "hello").unwrap();
    let err = crate::support::slate_err(&["play", not_mcap.to_str().unwrap()]);
    assert!(err.contains("is not an MCAP recording"), "{err}");
}

#[test]
fn play_onto_publishes_a_recording_on_a_live_team_as_a_replay_module_of_its_own() {
    let mut team = Team::new("play-onto");
    let own = team.dir.join("nav.mcap");
    team.add_recording("t/r1/nav", "object gsr : Vehicle context self;", &own);
    team.wait_connected();
    team.ok(&["put", "gsr.speed", "1.5"]);
    team.ok(&["put", "gsr.mode", "manual"]);
    let recorded = wait_recorded(&own, "Vehicle", "gsr", "mode", &json!("manual"));
    assert!(recorded, "{}", team.logs());
    let (clean, rest) = team.nodes.remove(0).stop();
    assert!(clean, "nav stopped cleanly: {rest}");
    // A team that never had gsr hears it from the replay.
    team.add("t/base/console", "");
    team.wait_connected();
    let file = own.to_str().unwrap();
    let args = [
        "play", file, "--onto", "t", "--speed", "max", "--format", "json",
    ];
    let replay = team.spawn(&args);
    let console = &team.nodes[0];
    let heard = console.wait_value("gsr", "mode", "manual");
    assert!(heard, "the console hears the replay\n{}", team.logs());
    let gsr = &console.snapshot()["objects"];
    let gsr = crate::support::entry(gsr, "name", "gsr")
        .cloned()
        .unwrap_or_default();
    assert_eq!(gsr["owner"], "t/replay/nav", "{gsr}");
    let out = wait_output(replay.take(), Duration::from_secs(30));
    assert!(out.status.success(), "{}", show(&out));
    let played: Json = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(played["address"], "t/replay/nav", "{played}");
    assert_eq!(played["refused"], 0, "{played}");
    team.stop();
}
