//! A `slate node` that keeps its board (`state = "DIR"`) is killed with SIGKILL while a
//! writer writes 10 000 updates: every change its store had acknowledged (the node's
//! dashboard says up to which revision) is there after the kill, it restarts with its
//! board, and its peers keep the object it had created at run time. A damaged state
//! directory stops the start with an error naming it, and `--reset-state` is the way out.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use slate_model::{Address, Value};
use slate_node::state::{Durability, FILE, Store};
use slate_node::{Node, NodeConfig};

use crate::support::{
    Guard, NodeProc, Team, WORLD, eventually, free_port, show, slate, wait_output,
};

const NAV: &str = "t/r1/nav";
const LOCO: &str = "t/r2/loco";
const COUNTERS: i64 = 100;
const UPDATES: i64 = 10_000;
const COUNTER: &str = "class Counter { n: int = 0; }\n";

/// nav's file: the counters it owns, and a plan that creates `probe` when told to
/// (`c0.n == -1`), so that nav owns an object no file declares.
fn nav_source() -> String {
    let mut s = COUNTER.to_owned();
    for j in 0..COUNTERS {
        s.push_str(&format!("object c{j} : Counter;\n"));
    }
    s.push_str(
        "plan spawn { trigger: c0.n == -1; action { create Vehicle probe { speed = 4.5; } } }\n",
    );
    s
}

/// Starts nav, keeping its board in `state`, connected to `connect`.
fn start_nav(dir: &Path, state: &Path, connect: &[String]) -> NodeProc {
    let top = format!("state = {:?}", state.display().to_string());
    let settings = ["\"Thing\"", "", top.as_str()];
    NodeProc::start_config(dir, NAV, &nav_source(), connect, &settings)
}

/// The writer: a module in this process, listening on `endpoint`, connected to loco.
fn writer(endpoint: &str, loco: &str) -> Node {
    let text = format!(
        "address = \"t/r1/writer\"\nexport = [\"Thing\"]\n[zenoh]\nlisten = [{endpoint:?}]\nconnect = [{loco:?}]\n"
    );
    let config = NodeConfig::parse("writer.toml", &text, Path::new(".")).unwrap();
    let node = Node::start(&config).unwrap();
    node.load("world.slate", WORLD).unwrap();
    node.load("counter.slate", COUNTER).unwrap();
    node
}

/// `c0..c99`'s `n` on a node's dashboard (those it shows as integers).
fn counters(snapshot: &serde_json::Value) -> BTreeMap<String, i64> {
    let mut out = BTreeMap::new();
    for j in 0..COUNTERS {
        let name = format!("c{j}");
        let value = crate::support::value_in(snapshot, &name, "n");
        if let Some(n) = value.and_then(|v| v.parse().ok()) {
            out.insert(name, n);
        }
    }
    out
}

fn summary(node: &NodeProc, key: &str) -> u64 {
    node.snapshot()["summary"][key].as_u64().unwrap_or(0)
}

fn has(node: &NodeProc, object: &str) -> bool {
    let snap = node.snapshot();
    let objects = snap["objects"].as_array().cloned().unwrap_or_default();
    objects.iter().any(|o| o["name"] == object)
}

#[test]
fn a_node_killed_mid_write_restarts_with_every_acknowledged_change_and_its_peers_keep_its_objects()
{
    let mut team = Team::new("state-kill");
    let state = team.dir.join("nav-state");
    team.add(LOCO, "");
    let loco_endpoint = team.nodes[0].endpoint.clone();
    let writer_endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let writer = Arc::new(writer(&writer_endpoint, &loco_endpoint));
    let connect = [loco_endpoint.clone(), writer_endpoint.clone()];
    team.nodes.push(start_nav(&team.dir, &state, &connect));
    team.wait_connected();
    let ready = eventually(Duration::from_secs(20), || {
        writer.board().info("c99").is_some() && writer.board().info("c0").is_some()
    });
    assert!(ready, "the writer holds nav's counters\n{}", team.logs());

    // nav creates `probe` at run time; loco holds it.
    team.ok(&["put", "c0.n", "-1"]);
    let loco_has_probe = eventually(Duration::from_secs(20), || has(&team.nodes[0], "probe"));
    assert!(loco_has_probe, "{}", team.logs());

    let w = writer.clone();
    let writing = std::thread::spawn(move || {
        for i in 0..UPDATES {
            let object = format!("c{}", i % COUNTERS);
            w.board().write(&object, "n", Value::Int(i)).unwrap();
            std::thread::sleep(Duration::from_micros(200));
        }
    });
    let nav = &team.nodes[1];
    let midway = eventually(Duration::from_secs(30), || {
        counters(&nav.snapshot())
            .get("c50")
            .is_some_and(|n| *n >= UPDATES / 4)
    });
    assert!(midway, "nav hears the writer\n{}", team.logs());
    // What nav held, then a revision read after it: once the store has everything up to
    // that revision, all of it is acknowledged.
    let acknowledged = counters(&nav.snapshot());
    let revision = summary(nav, "revision");
    let committed = eventually(Duration::from_secs(10), || {
        summary(nav, "state revision") >= revision
    });
    assert!(
        committed,
        "the store catches up with the board\n{}",
        team.logs()
    );
    team.nodes.remove(1).kill();
    writing.join().unwrap();

    // The store, read on its own: nothing acknowledged is lost.
    let nav_address = Address::new(NAV).unwrap();
    let saved = Store::open(&state, &nav_address, Durability::Immediate)
        .unwrap()
        .load()
        .unwrap();
    let stored: BTreeMap<String, i64> = saved
        .packets
        .iter()
        .filter(|p| p.attr == "n")
        .filter_map(|p| Some((p.object.clone(), p.value.as_i64()?)))
        .collect();
    assert_eq!(acknowledged.len(), COUNTERS as usize, "{acknowledged:?}");
    for (object, n) in &acknowledged {
        let kept = stored.get(object).copied().unwrap_or(i64::MIN);
        assert!(kept >= *n, "{object}: acknowledged {n}, stored {kept}");
    }
    assert!(saved.objects.iter().any(|o| o.name == "probe"));

    // Restarted: its board is back before it joins, and the team's later writes reach it.
    team.nodes.push(start_nav(&team.dir, &state, &connect));
    team.wait_connected();
    let nav = &team.nodes[1];
    assert!(has(nav, "probe"), "nav restored probe\n{}", team.logs());
    let last = |j: i64| UPDATES - COUNTERS + j;
    let caught_up = eventually(Duration::from_secs(30), || {
        let now = counters(&nav.snapshot());
        (0..COUNTERS).all(|j| now.get(&format!("c{j}")) == Some(&last(j)))
    });
    assert!(caught_up, "nav catches up with the writer\n{}", team.logs());
    // loco saw nav come back and kept the object nav created before the kill.
    let swept = eventually(Duration::from_secs(3), || !has(&team.nodes[0], "probe"));
    assert!(!swept, "loco kept nav's object\n{}", team.logs());
    writer.close();
    team.stop();
}

#[test]
fn a_damaged_state_directory_stops_the_node_with_the_way_out_and_reset_state_takes_it() {
    let team = Team::new("state-damaged");
    let state = team.dir.join("nav-state");
    std::fs::create_dir_all(&state).unwrap();
    std::fs::write(state.join(FILE), vec![0x5a; 4096]).unwrap();
    let config = team.dir.join("nav.toml");
    let text = format!(
        "address = \"{NAV}\"\nstate = {:?}\n[zenoh]\nlisten = [\"tcp/127.0.0.1:{}\"]\n",
        state.display().to_string(),
        free_port()
    );
    std::fs::write(&config, text).unwrap();
    let out = slate(&["node", "--config", config.to_str().unwrap()]);
    assert!(!out.status.success(), "{}", show(&out));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains(&state.display().to_string()), "{stderr}");
    assert!(stderr.contains("--reset-state"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");

    let help = crate::support::slate_ok(&["node", "--help"]);
    assert!(help.contains("--reset-state"), "{help}");
    // --reset-state moves the damaged store aside; the node starts with an empty board.
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_slate"))
        .args([
            "node",
            "--config",
            config.to_str().unwrap(),
            "--reset-state",
        ])
        .args(["--format", "json"])
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let guard = Guard(Some(child));
    let mut child = guard.take();
    let mut line = String::new();
    let stdout = child.stdout.take().unwrap();
    std::io::BufRead::read_line(&mut std::io::BufReader::new(stdout), &mut line).unwrap();
    let pid = child.id().to_string();
    let _ = std::process::Command::new("kill")
        .args(["-TERM", &pid])
        .status();
    let out = wait_output(child, Duration::from_secs(20));
    let ready: serde_json::Value =
        serde_json::from_str(&line).unwrap_or_else(|e| panic!("{e}: {line:?}\n{}", show(&out)));
    assert_eq!(ready["event"], "ready", "{ready}");
    assert_eq!(ready["restored"]["objects"], 0, "{ready}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("moved the state store aside to"),
        "{stderr}"
    );
    let aside = std::fs::read_dir(&state)
        .unwrap()
        .filter_map(Result::ok)
        .any(|e| e.file_name().to_string_lossy().ends_with(".old"));
    assert!(aside, "the damaged store is kept aside, not deleted");
    drop(team);
}

/// loco as a `slate node` keeping its board in `state`.
fn start_loco(team: &Team, state: &Path) -> NodeProc {
    let top = format!("state = {:?}", state.display().to_string());
    let settings = ["\"Thing\"", "", top.as_str()];
    let extra = "object gsr : Vehicle context self;";
    NodeProc::start_config(&team.dir, LOCO, extra, &[], &settings)
}

/// The state of plan `name` on the team, as `slate plan ls` shows it.
fn plan_state(team: &Team, name: &str) -> Option<String> {
    let j = team.json(&["plan", "ls"]);
    let plan = crate::support::entry(&j["plans"], "name", name)?;
    plan["state"].as_str().map(str::to_owned)
}

/// A team of loco with a state directory (returned), to which `slate plan send` sent
/// plan `slow`: `gsr.mode = "slow"` once `gsr.speed > 5`.
fn loco_with_plan_slow(name: &str) -> (Team, PathBuf) {
    let mut team = Team::new(name);
    let state = team.dir.join("loco-state");
    team.nodes.push(start_loco(&team, &state));
    team.wait_connected();
    let slow = team.dir.join("slow.slate");
    let text = "plan slow { trigger: gsr.speed > 5.0; action { set gsr.mode = \"slow\"; } }";
    std::fs::write(&slow, text).unwrap();
    let out = team.send_plan(&slow, LOCO, "2");
    assert!(out.status.success(), "{}", show(&out));
    (team, state)
}

#[test]
fn a_plan_sent_with_slate_plan_send_runs_again_after_the_node_restarts_on_its_state() {
    let (mut team, state) = loco_with_plan_slow("state-plan");
    assert_eq!(plan_state(&team, "slow").as_deref(), Some("active"));
    // The sender (this `slate plan send`) is gone: only loco's state can bring it back.
    let (clean, rest) = team.nodes.remove(0).stop();
    assert!(clean, "loco stopped cleanly: {rest}");
    team.nodes.push(start_loco(&team, &state));
    team.wait_connected();
    assert_eq!(
        plan_state(&team, "slow").as_deref(),
        Some("active"),
        "{}",
        team.logs()
    );
    team.ok(&["put", "gsr.speed", "6"]);
    let acted = team.nodes[0].wait_value("gsr", "mode", "slow");
    assert!(acted, "the plan acts after the restart\n{}", team.logs());
    team.stop();
}

/// A plan that fired before the restart, whose trigger still holds after it, does not
/// fire again for that same state: `mode`, set back by hand once it fired, stays so.
#[test]
fn a_plan_that_fired_before_a_restart_does_not_fire_again_for_the_same_state() {
    let (mut team, state) = loco_with_plan_slow("state-plan-fired");
    team.ok(&["put", "gsr.speed", "6"]);
    assert!(
        team.nodes[0].wait_value("gsr", "mode", "slow"),
        "{}",
        team.logs()
    );
    team.ok(&["put", "gsr.mode", "manual"]);
    assert!(
        team.nodes[0].wait_value("gsr", "mode", "manual"),
        "{}",
        team.logs()
    );
    let (clean, rest) = team.nodes.remove(0).stop();
    assert!(clean, "loco stopped cleanly: {rest}");
    team.nodes.push(start_loco(&team, &state));
    team.wait_connected();
    let active = plan_state(&team, "slow");
    assert_eq!(active.as_deref(), Some("active"), "{}", team.logs());
    let mode = team.json(&["get", "gsr.mode"]);
    assert_eq!(mode["attrs"][0]["value"], "manual", "not set again: {mode}");
    team.ok(&["put", "gsr.speed", "1"]);
    team.ok(&["put", "gsr.speed", "7"]);
    let acted = team.nodes[0].wait_value("gsr", "mode", "slow");
    assert!(acted, "the next rising edge fires it\n{}", team.logs());
    team.stop();
}
