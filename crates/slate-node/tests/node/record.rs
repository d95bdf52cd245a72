//! Recording a node's board in MCAP: what its writes, objects, classes, plans and
//! circuits become as messages, read back with the `mcap` crate's reader; rotation; and
//! a file cut off mid-write (the state a crash leaves) read up to its last chunk.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;

use mcap::read::Options;
use serde_json::{Value as Json, json};
use slate_ici::{ClassSet, IciConfig, SimNet};
use slate_node::RecordConfig;
use slate_node::record::{PROFILE, rotated_path, topic};
use slate_testing::temp_dir;

use crate::support::{addr, on_net, plans_from, run_until, start};

/// One message read back: its topic, schema name and encoding, and its JSON.
#[derive(Debug)]
struct Read {
    topic: String,
    schema: String,
    schema_encoding: String,
    message_encoding: String,
    json: Json,
}

/// Every message of a file, in order, until the end or the first unreadable record
/// (`complete` says which).
fn read(bytes: &[u8]) -> (Vec<Read>, bool) {
    let stream = mcap::MessageStream::new_with_options(bytes, Options::IgnoreEndMagic.into())
        .expect("a file that begins like an MCAP");
    let mut out = Vec::new();
    for message in stream {
        let Ok(m) = message else {
            return (out, false);
        };
        let schema = m
            .channel
            .schema
            .as_ref()
            .expect("every channel has a schema");
        out.push(Read {
            topic: m.channel.topic.clone(),
            schema: schema.name.clone(),
            schema_encoding: schema.encoding.clone(),
            message_encoding: m.channel.message_encoding.clone(),
            json: serde_json::from_slice(&m.data).expect("JSON messages"),
        });
    }
    (out, true)
}

fn read_file(path: &Path) -> Vec<Read> {
    let bytes = std::fs::read(path).unwrap();
    let (messages, complete) = read(&bytes);
    assert!(complete, "{} reads to its end", path.display());
    let summary = mcap::Summary::read(&bytes)
        .unwrap()
        .expect("a finished file has a summary");
    let header_profile = mcap::read::LinearReader::new(&bytes)
        .unwrap()
        .find_map(|r| match r {
            Ok(mcap::records::Record::Header(h)) => Some(h.profile),
            _ => None,
        });
    assert_eq!(header_profile.as_deref(), Some(PROFILE));
    assert_eq!(
        summary.stats.map(|s| s.message_count),
        Some(messages.len() as u64)
    );
    messages
}

/// The JSON of every message on `topic`; a class channel's message is a list of packets
/// (`{"packets": [...]}`): each of them.
fn on(messages: &[Read], topic: &str) -> Vec<Json> {
    messages
        .iter()
        .filter(|m| m.topic == topic)
        .flat_map(|m| match m.json["packets"].as_array() {
            Some(packets) if topic.starts_with(topic::CLASS_PREFIX) => packets.clone(),
            _ => vec![m.json.clone()],
        })
        .collect()
}

fn speeds(messages: &[Read]) -> Vec<f64> {
    on(messages, "/slate/class/Vehicle")
        .iter()
        .filter(|j| j["object"] == "gsr" && j["attr"] == "speed")
        .filter_map(|j| j["values"]["speed"].as_f64())
        .collect()
}

#[test]
fn a_boards_writes_become_packets_on_their_class_channel() {
    let dir = temp_dir("record-writes");
    let path = dir.join("nav.mcap");
    let net = SimNet::new(11);
    let nav = on_net(&net, "t/r1/nav", "object gsr : Vehicle context self;")
        .record(RecordConfig::new(&path))
        .start()
        .unwrap();
    for s in [1.0, 2.5, 4.0] {
        nav.board().write("gsr", "speed", s).unwrap();
    }
    nav.board().create("Obstacle", "rock").unwrap();
    nav.board().write("rock", "range", 7.5).unwrap();
    nav.board().create("Obstacle", "tree").unwrap();
    nav.board().delete("rock").unwrap();
    let stats = nav.stop_recording().unwrap().expect("it was recording");
    nav.close();

    let messages = read_file(&path);
    assert_eq!(stats.messages, messages.len() as u64);
    assert_eq!(stats.dropped, 0);
    assert_eq!(speeds(&messages), [1.0, 2.5, 4.0]);
    // A class channel's message is a list of the packets the recorder found waiting.
    let packets: usize = messages
        .iter()
        .filter(|m| m.topic.starts_with(topic::CLASS_PREFIX))
        .map(|m| m.json["packets"].as_array().map_or(0, Vec::len))
        .sum();
    assert_eq!(stats.packets, packets as u64);
    let packet = on(&messages, "/slate/class/Vehicle")
        .into_iter()
        .find(|j| j["values"]["speed"] == json!(2.5))
        .unwrap();
    assert_eq!(packet["source"], "t/r1/nav");
    assert_eq!(packet["confidence"], json!(1.0));
    assert!(packet["hlc"].as_u64().unwrap() > 0 && packet["time"].as_f64().unwrap() > 0.0);
    let vehicle = messages
        .iter()
        .find(|m| m.topic == "/slate/class/Vehicle")
        .unwrap();
    assert_eq!(
        (
            vehicle.schema.as_str(),
            vehicle.schema_encoding.as_str(),
            vehicle.message_encoding.as_str()
        ),
        ("Vehicle", "jsonschema", "json")
    );
    let objects: Vec<(String, String)> = on(&messages, topic::OBJECTS)
        .iter()
        .filter(|j| j["class"] != "Module")
        .map(|j| {
            (
                j["op"].as_str().unwrap().to_owned(),
                j["object"].as_str().unwrap().to_owned(),
            )
        })
        .collect();
    assert_eq!(
        objects,
        [
            ("exists".into(), "gsr".into()),
            ("create".into(), "rock".into()),
            ("create".into(), "tree".into()),
            ("delete".into(), "rock".into())
        ]
    );
    let objects = on(&messages, topic::OBJECTS);
    let gsr = objects.iter().find(|j| j["object"] == "gsr").unwrap();
    assert_eq!(
        (gsr["class"].as_str(), gsr["context"].as_str()),
        (Some("Vehicle"), Some("self"))
    );
    let tree = objects.iter().find(|j| j["object"] == "tree").unwrap();
    assert_eq!(
        (tree["class"].as_str(), tree["context"].as_str()),
        (Some("Obstacle"), Some("surroundings"))
    );
    assert_eq!(tree["owner"], "t/r1/nav");
    assert_eq!(
        on(&messages, "/slate/class/Obstacle")[0]["values"]["range"],
        json!(7.5)
    );
    let classes: Vec<String> = on(&messages, topic::CLASSES)
        .iter()
        .map(|j| j["name"].as_str().unwrap().to_owned())
        .collect();
    assert!(
        classes.contains(&"Vehicle".to_owned()) && classes.contains(&"Obstacle".to_owned()),
        "{classes:?}"
    );
    let recorder = on(&messages, topic::RECORDER);
    assert_eq!(recorder.last().unwrap()["dropped"], json!(0));
}

#[test]
fn plan_progress_circuit_steps_and_liveliness_are_recorded() {
    let dir = temp_dir("record-plans");
    let path = dir.join("planner.mcap");
    let net = SimNet::new(12);
    let planner = on_net(&net, "t/r1/planner", "")
        .ici(IciConfig::default().export(ClassSet::all()))
        .record(RecordConfig::new(&path))
        .start()
        .unwrap();
    let loco = on_net(&net, "t/r2/loco", "object gsr : Vehicle context self;")
        .ici(IciConfig::default().export(ClassSet::all()))
        .plans_from(plans_from(&["robot", "t/r1/planner"]))
        .start()
        .unwrap();
    assert!(run_until(&net, 2.0, || planner.peers().len() == 1));
    let plan = "plan slow { trigger: gsr.speed > 5.0; termination: gsr.mode == \"slow\"; action { set gsr.mode = \"slow\"; } }";
    let handle = planner.send_plan(&addr("t/r2/loco"), plan).unwrap();
    net.run_for(Duration::from_millis(300));
    loco.board().write("gsr", "speed", 6.0).unwrap();
    assert!(run_until(&net, 3.0, || handle
        .acks()
        .try_iter()
        .any(|s| s.is_final())));
    loco.close();
    assert!(run_until(&net, 10.0, || planner.peers().is_empty()));
    planner.close();

    let messages = read_file(&path);
    let steps: Vec<String> = on(&messages, topic::CIRCUITS)
        .iter()
        .inspect(|j| {
            assert_eq!(
                (&j["direction"], &j["plan"], &j["peer"]),
                (&json!("sent"), &json!("slow"), &json!("t/r2/loco"))
            )
        })
        .map(|j| j["step"].as_str().unwrap().to_owned())
        .collect();
    assert_eq!(
        steps,
        [
            "received",
            "accepted",
            "initiated",
            "triggered",
            "terminated"
        ]
    );
    let loco_up_down: Vec<bool> = on(&messages, topic::LIVELINESS)
        .iter()
        .filter(|j| j["module"] == "t/r2/loco")
        .map(|j| j["alive"].as_bool().unwrap())
        .collect();
    assert_eq!(loco_up_down, [true, false]);
    assert!(
        speeds(&messages).contains(&6.0),
        "the packets merged from loco are recorded"
    );
}

#[test]
fn the_plan_engines_events_are_recorded() {
    let dir = temp_dir("record-engine");
    let path = dir.join("loco.mcap");
    let net = SimNet::new(13);
    let rule = "object gsr : Vehicle context self;\nplan slow { trigger: gsr.speed > 5.0; action { set gsr.mode = \"slow\"; } }";
    let loco = on_net(&net, "t/r1/loco", rule)
        .record(RecordConfig::new(&path))
        .start()
        .unwrap();
    loco.board().write("gsr", "speed", 6.0).unwrap();
    net.run_for(Duration::from_millis(100));
    loco.close();
    let events: Vec<(String, Json)> = on(&read_file(&path), topic::PLANS)
        .iter()
        .map(|j| (j["event"].as_str().unwrap().to_owned(), j["fired"].clone()))
        .collect();
    assert!(
        events.contains(&("triggered".into(), json!(1))),
        "{events:?}"
    );
}

#[test]
fn a_recording_rotates_by_size_and_each_file_starts_with_the_boards_state() {
    let dir = temp_dir("record-rotate");
    let path = dir.join("nav.mcap");
    let net = SimNet::new(14);
    let mut config = RecordConfig::new(&path);
    config.max_bytes = Some(4096);
    config.flush_every = Duration::ZERO;
    let nav = on_net(&net, "t/r1/nav", "object gsr : Vehicle context self;")
        .record(config)
        .start()
        .unwrap();
    let written: Vec<f64> = (0..3000).map(|i| f64::from(i % 100) / 10.0).collect();
    for s in &written {
        nav.board().write("gsr", "speed", *s).unwrap();
    }
    let stats = nav.stop_recording().unwrap().unwrap();
    nav.close();
    assert!(stats.files >= 2, "{stats:?}");
    let mut all = Vec::new();
    let mut per_file = BTreeMap::new();
    for i in 0..stats.files {
        let messages = read_file(&rotated_path(&path, i));
        let exists = on(&messages, topic::OBJECTS)
            .iter()
            .any(|j| j["op"] == "exists" && j["object"] == "gsr");
        assert!(exists, "file {i} says gsr is there");
        assert!(
            !on(&messages, topic::CLASSES).is_empty(),
            "file {i} holds the classes"
        );
        per_file.insert(i, messages.len());
        all.extend(messages);
    }
    // Each file repeats gsr's current speed (its state); every write is recorded once,
    // in order.
    let mut recorded = speeds(&all);
    recorded.dedup();
    let mut expected = written.clone();
    expected.dedup();
    assert_eq!(recorded.len(), expected.len(), "files {per_file:?}");
    assert!(recorded == expected, "files {per_file:?}");
}

#[test]
fn a_recording_cut_off_mid_write_reads_up_to_its_last_chunk() {
    let dir = temp_dir("record-cut");
    let path = dir.join("nav.mcap");
    let net = SimNet::new(15);
    let mut config = RecordConfig::new(&path);
    config.flush_every = Duration::ZERO;
    let nav = on_net(&net, "t/r1/nav", "object gsr : Vehicle context self;")
        .record(config)
        .start()
        .unwrap();
    for i in 0..200 {
        nav.board()
            .write("gsr", "speed", f64::from(i % 100) / 10.0)
            .unwrap();
    }
    // What is on disk while the recorder runs is what a crash (SIGKILL) leaves.
    let mut cut = Vec::new();
    let got_all = slate_testing::eventually(Duration::from_secs(10), || {
        cut = std::fs::read(&path).unwrap();
        speeds(&read(&cut).0).len() >= 200
    });
    assert!(got_all, "every write reached the file in closed chunks");
    assert!(!cut.ends_with(mcap::MAGIC), "a cut file has no footer");
    let (messages, _) = read(&cut);
    assert_eq!(speeds(&messages).len(), 200, "every write");
    nav.close();
}

#[test]
fn a_recording_that_cannot_be_created_is_a_clear_start_error() {
    let net = SimNet::new(16);
    let err = on_net(&net, "t/r1/nav", "")
        .record(RecordConfig::new("/nonexistent/dir/nav.mcap"))
        .start()
        .err()
        .expect("no folder, no node");
    let text = err.to_string();
    assert!(
        text.starts_with("cannot record: cannot create the recording /nonexistent/dir/nav.mcap:")
            && text.ends_with("(check that its folder exists and is writable)"),
        "{text}"
    );
}

#[test]
fn only_the_named_objects_and_classes_are_recorded() {
    let dir = temp_dir("record-only");
    let path = dir.join("nav.mcap");
    let net = SimNet::new(17);
    let mut config = RecordConfig::new(&path);
    config.only = vec!["Obstacle".into()];
    let nav = on_net(&net, "t/r1/nav", "object gsr : Vehicle context self;")
        .record(config)
        .start()
        .unwrap();
    nav.board().write("gsr", "speed", 3.0).unwrap();
    nav.board().create("Obstacle", "rock").unwrap();
    nav.board().write("rock", "range", 4.5).unwrap();
    nav.close();
    let messages = read_file(&path);
    assert!(speeds(&messages).is_empty());
    let objects: Vec<Json> = on(&messages, topic::OBJECTS);
    assert_eq!(objects.len(), 1, "{objects:?}");
    assert_eq!(objects[0]["object"], "rock");
    assert_eq!(
        on(&messages, "/slate/class/Obstacle")[0]["values"]["range"],
        json!(4.5)
    );
}

#[test]
fn a_recording_replayed_into_a_new_board_rebuilds_the_recorded_board() {
    let dir = temp_dir("record-replay");
    let path = dir.join("planner.mcap");
    let net = SimNet::new(18);
    let ugv = "class Ugv : Vehicle { wheels: int = 4; }";
    let planner = on_net(
        &net,
        "t/r1/planner",
        &format!("{ugv}\nobject rock : Obstacle {{ range = 7.5; }}"),
    )
    .ici(IciConfig::default().export(ClassSet::all()))
    .record(RecordConfig::new(&path))
    .start()
    .unwrap();
    let loco = start(
        &net,
        "t/r2/loco",
        &format!("{ugv}\nobject gsr : Ugv context self;"),
    );
    assert!(run_until(&net, 2.0, || planner
        .board()
        .info("gsr")
        .is_some()));
    for s in [1.0, 2.5, 4.0] {
        loco.board().write("gsr", "speed", s).unwrap();
        loco.board().write("gsr", "position", [s, -s]).unwrap();
        net.run_for(Duration::from_millis(100));
    }
    loco.board().write("gsr", "wheels", 6).unwrap();
    planner.board().create("Obstacle", "tree").unwrap();
    planner.board().write("tree", "range", 2.0).unwrap();
    planner.board().delete("rock").unwrap();
    net.run_for(Duration::from_millis(300));
    let recorded = slate_node::record::board_state(planner.board());
    planner.close();
    loco.close();

    let recording = slate_node::record::Recording::read(&path).unwrap();
    assert!(recording.complete);
    assert_eq!(recording.address.as_deref(), Some("t/r1/planner"));
    let clock = slate_model::Clock::manual();
    let board = slate_model::Board::builder()
        .address(addr("t/r1/planner"))
        .clock(clock.clone())
        .build();
    let mut refused = Vec::new();
    for t in &recording.steps {
        clock.set(t.time.max(clock.physical())).unwrap();
        if !slate_node::record::Recording::apply(&board, &t.step) {
            refused.push(format!("{:?}", t.step));
        }
    }
    assert!(refused.is_empty(), "{refused:?}");
    let replayed = slate_node::record::board_state(&board);
    assert_eq!(replayed, recorded);
    assert!(
        replayed.get("rock").is_none() && replayed["tree"]["attrs"]["range"]["value"] == json!(2.0)
    );
    assert_eq!(replayed["gsr"]["attrs"]["wheels"]["value"], json!(6));
}

#[test]
fn a_class_redefined_while_recording_gets_a_channel_with_its_new_schema() {
    use slate_model::{AttrDecl, ClassDef, ValueType};
    let dir = temp_dir("record-redefine");
    let path = dir.join("nav.mcap");
    let net = SimNet::new(19);
    let mut config = RecordConfig::new(&path);
    config.flush_every = Duration::ZERO;
    let nav = on_net(&net, "t/r1/nav", "").record(config).start().unwrap();
    let probe = |ty| ClassDef::new("Probe").attr(AttrDecl::new("level", ty));
    nav.board().define(probe(ValueType::Int)).unwrap();
    nav.board().create("Probe", "p1").unwrap();
    nav.board().write("p1", "level", 3).unwrap();
    // The recorder reads a class's definition from the board when it first needs it:
    // the redefinition must come after it has recorded p1.
    let recorded = slate_testing::eventually(Duration::from_secs(10), || {
        let bytes = std::fs::read(&path).unwrap();
        on(&read(&bytes).0, "/slate/class/Probe").len() == 1
    });
    assert!(recorded);
    nav.board().delete("p1").unwrap();
    nav.board().delete_class("Probe").unwrap();
    nav.board().define(probe(ValueType::Real)).unwrap();
    nav.board().create("Probe", "p2").unwrap();
    nav.board().write("p2", "level", 2.5).unwrap();
    nav.close();
    let bytes = std::fs::read(&path).unwrap();
    let mut schemas: Vec<Json> = mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(Result::unwrap)
        .filter(|m| m.channel.topic == "/slate/class/Probe")
        .map(|m| {
            let schema = m.channel.schema.as_ref().unwrap();
            let schema = serde_json::from_slice::<Json>(&schema.data).unwrap();
            schema["properties"]["packets"]["items"]["properties"]["values"]["properties"]["level"]
                ["type"]
                .clone()
        })
        .collect();
    schemas.dedup();
    assert_eq!(
        schemas,
        [json!(["integer", "null"]), json!(["number", "null"])]
    );
}

#[test]
fn a_replayed_real_keeps_every_bit_of_its_recorded_value() {
    // Reals whose shortest decimal form a reader without exact parsing rounds to the
    // neighbouring double: seen in the demo's replay (a heading, confidences, accuracies).
    let reals = [2.9215999999999998, 1.9027313840043538, 0.9882352941176471];
    let dir = temp_dir("record-reals");
    let path = dir.join("nav.mcap");
    let net = SimNet::new(19);
    let nav = on_net(&net, "t/r1/nav", "object rock : Obstacle;")
        .record(RecordConfig::new(&path))
        .start()
        .unwrap();
    let update = slate_model::Update::new(reals[0])
        .accuracy(reals[1])
        .confidence(reals[2]);
    nav.board().write("rock", "range", update).unwrap();
    nav.board()
        .write("rock", "position", [83.29999999999995, 21.300000000000068])
        .unwrap();
    net.run_for(Duration::from_millis(100));
    let recorded = slate_node::record::board_state(nav.board());
    nav.close();

    let recording = slate_node::record::Recording::read(&path).unwrap();
    let board = slate_model::Board::builder()
        .address(addr("t/r1/nav"))
        .clock(slate_model::Clock::manual())
        .build();
    for t in &recording.steps {
        slate_node::record::Recording::apply(&board, &t.step);
    }
    let replayed = slate_node::record::board_state(&board);
    let (live, again) = (
        &recorded["rock"]["attrs"]["range"],
        &replayed["rock"]["attrs"]["range"],
    );
    let bits = |j: &Json| j.as_f64().map(f64::to_bits);
    assert_eq!(bits(&again["value"]), Some(reals[0].to_bits()), "{again}");
    assert_eq!(
        bits(&again["confidence"]),
        Some(reals[2].to_bits()),
        "{again}"
    );
    assert_eq!(bits(&again["accuracy"]), bits(&live["accuracy"]), "{again}");
    assert_eq!(replayed, recorded);
}

/// `(plan, event, fired)` of each firing but the installation.
fn firings(list: &[slate_node::record::Firing]) -> Vec<(String, String, Option<u64>)> {
    list.iter()
        .filter(|f| f.name() != "installed")
        .map(|f| {
            let plan = f.event["plan"].as_str().unwrap().to_owned();
            (plan, f.name().to_owned(), f.event["fired"].as_u64())
        })
        .collect()
}

#[test]
fn a_plan_tested_against_a_recording_fires_as_the_same_plan_did_live() {
    let plan = "plan slow { initiation: gsr.mode == \"auto\"; trigger: gsr.speed > 5.0; termination: gsr.mode == \"manual\"; action { set gsr.mode = \"slow\"; } }";
    let dir = temp_dir("record-against");
    let path = dir.join("nav.mcap");
    let net = SimNet::new(20);
    let nav = on_net(&net, "t/r1/nav", "object gsr : Vehicle context self;")
        .source("slow.slate", plan)
        .record(RecordConfig::new(&path))
        .start()
        .unwrap();
    for (speed, mode) in [
        (2.0, "auto"),
        (6.0, "auto"),
        (3.0, "auto"),
        (7.0, "auto"),
        (0.5, "manual"),
    ] {
        nav.board().write("gsr", "mode", mode).unwrap();
        nav.board().write("gsr", "speed", speed).unwrap();
        net.run_for(Duration::from_millis(200));
    }
    nav.close();

    let recording = slate_node::record::Recording::read(&path).unwrap();
    let test = slate_node::record::test_plans(&recording, &[], "slow.slate", plan).unwrap();
    assert_eq!(test.plans, ["slow"]);
    assert_eq!(test.refused, 0);
    let live = firings(&test.recorded);
    assert_eq!(
        live.iter().filter(|f| f.1 == "triggered").count(),
        2,
        "{live:?}"
    );
    assert!(live.iter().any(|f| f.1 == "terminated"), "{live:?}");
    assert_eq!(firings(&test.predicted), live);
    let triggered = test
        .predicted
        .iter()
        .find(|f| f.name() == "triggered")
        .unwrap();
    assert_eq!(
        triggered.wrote,
        [json!({"object": "gsr", "attr": "mode", "value": "slow"})]
    );
}

#[test]
fn a_plan_naming_what_a_recording_lacks_is_a_load_error_with_the_diagnostics() {
    let dir = temp_dir("record-against-unknown");
    let path = dir.join("nav.mcap");
    let net = SimNet::new(21);
    let nav = start(&net, "t/r1/nav", "object gsr : Vehicle context self;");
    nav.start_recording(RecordConfig::new(&path)).unwrap();
    nav.board().write("gsr", "speed", 1.0).unwrap();
    nav.close();
    let recording = slate_node::record::Recording::read(&path).unwrap();
    let plan = "plan p { trigger: rover.speed > 1.0; action { set gsr.speed = 0.0; } }";
    let err = slate_node::record::test_plans(&recording, &[], "p.slate", plan).unwrap_err();
    assert!(
        matches!(&err, slate_node::record::AgainstError::Load(d) if d.contains("rover")),
        "{err}"
    );
}
