//! Teams of two and three `slate node` processes over Zenoh on 127.0.0.1: reports, a plan
//! with its acknowledgements, a late joiner catching up, clean shutdown.

use std::time::Duration;

use crate::support::{NodeProc, Team, entry, eventually, show, steps};

#[test]
fn two_nodes_exchange_reports_both_ways_and_stop_cleanly() {
    let team = Team::connected(
        "two",
        &[
            ("t/r1/nav", "object gsr : Vehicle context self;"),
            ("t/r2/loco", "object rock : Obstacle { range = 7.5; }"),
        ],
    );
    let nav = team.node("t/r1/nav");
    let loco = team.node("t/r2/loco");
    assert!(nav.wait_value("rock", "range", "7.5"), "{}", team.logs());
    assert!(
        loco.wait_value("gsr", "mode", "auto")
            || entry(&loco.snapshot()["objects"], "name", "gsr").is_some()
    );
    team.ok(&["put", "rock.range", "3.25"]);
    assert!(nav.wait_value("rock", "range", "3.25"), "{}", team.logs());
    assert!(loco.wait_value("rock", "range", "3.25"));
    assert!(nav.log().contains("peer t/r2/loco up"), "{}", nav.log());
    team.stop();
}

#[test]
fn three_nodes_a_plan_with_acks_and_a_late_joiner_that_catches_up() {
    let mut team = Team::connected(
        "three",
        &[
            ("t/r1/nav", "object gsr : Vehicle context self;"),
            ("t/r2/loco", ""),
        ],
    );
    // Writes before the third node exists.
    for speed in ["1", "2", "3"] {
        team.ok(&["put", "gsr.speed", speed]);
    }
    team.ok(&["put", "gsr.position", "[4.5, 6.0]"]);
    team.add("t/base/console", "");
    team.wait_connected();
    let console = team.node("t/base/console");
    assert!(console.wait_value("gsr", "speed", "3.0"), "{}", team.logs());
    assert!(console.wait_value("gsr", "position", "[4.5, 6.0]"));

    // A plan from the console's side of the team to loco, acknowledged step by step.
    let plan = team.dir.join("go.slate");
    std::fs::write(&plan, "plan go { trigger: gsr.speed > 2.0; termination: gsr.mode == \"go\"; action { set gsr.mode = \"go\"; } }").unwrap();
    let out = team.send_plan(&plan, "t/r2/loco", "20");
    assert!(out.status.success(), "{}\n{}", show(&out), team.logs());
    let steps = steps(&out);
    assert_eq!(
        steps,
        [
            "received",
            "accepted",
            "initiated",
            "triggered",
            "terminated"
        ],
        "{}",
        show(&out)
    );
    for node in &team.nodes {
        assert!(
            node.wait_value("gsr", "mode", "go"),
            "{}: {}",
            node.address,
            team.logs()
        );
    }
    let loco = team.node("t/r2/loco");
    let snap = loco.snapshot();
    let go = entry(&snap["plans"], "name", "go").unwrap().clone();
    assert_eq!(go["state"], "terminated");
    assert!(go["origin"].as_str().unwrap().contains("/cli-"), "{go}");
    assert_eq!(go["acks"].as_array().unwrap().last().unwrap(), "terminated");

    // A node that stops is seen going down by the others.
    let console = team.nodes.pop().unwrap();
    let (clean, _) = console.stop();
    assert!(clean);
    let nav = team.node("t/r1/nav");
    assert!(
        eventually(Duration::from_secs(10), || nav
            .log()
            .contains("peer t/base/console down")),
        "{}",
        nav.log()
    );
    team.stop();
}

/// `slate node --format json` streams its events after its ready line, one JSON object
/// each (`"event": "news"`), and ends with its `stopped` line.
#[test]
fn a_node_with_format_json_streams_its_events_on_stdout() {
    let mut team = Team::connected("news", &[("t/r1/nav", ""), ("t/r2/loco", "")]);
    let loco = team.nodes.pop().unwrap();
    assert!(loco.stop().0, "t/r2/loco did not stop cleanly");
    let nav = team.nodes.pop().unwrap();
    let down = eventually(Duration::from_secs(15), || {
        nav.log().contains("peer t/r2/loco down")
    });
    assert!(down, "{}", nav.log());
    let (clean, rest) = nav.stop();
    assert!(clean);
    let lines: Vec<serde_json::Value> = rest
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    let news: Vec<&str> = lines
        .iter()
        .filter(|j| j["event"] == "news")
        .filter_map(|j| j["text"].as_str())
        .collect();
    for said in ["peer t/r2/loco up", "peer t/r2/loco down"] {
        assert!(news.contains(&said), "{said:?} not in {news:?}");
    }
    let last = lines.last().unwrap();
    assert_eq!(last["event"], "stopped", "{rest}");
    assert!(
        lines
            .iter()
            .all(|j| j["event"] != "news" || j["level"].is_string())
    );
}

/// `[ici] speakers = "robots"` in both nodes' configs: each is its robot's gateway, the
/// value crosses the team link in the team protocol's frames, and no module heartbeat
/// goes on the team link.
#[test]
fn two_robots_speaking_through_their_gateways_exchange_a_value() {
    let mut team = Team::new("robots-speak");
    let robots = "speakers = \"robots\"";
    for (address, file) in [
        ("t/r1/nav", "object gsr : Vehicle context self;"),
        ("t/r2/loco", "object rock : Obstacle { range = 7.5; }"),
    ] {
        let connect: Vec<String> = team.nodes.iter().map(|n| n.endpoint.clone()).collect();
        let export = "\"Vehicle\", \"Obstacle\"";
        let node = NodeProc::start_with(&team.dir, address, file, &connect, export, robots);
        team.nodes.push(node);
    }
    let nav = team.node("t/r1/nav");
    assert!(nav.wait_value("rock", "range", "7.5"), "{}", team.logs());
    let stats = team.json(&["stats", "t/r2/loco", "--interval", "1"]);
    let text = stats.to_string();
    assert!(text.contains("\"team_frame\""), "no team frames: {stats}");
    assert!(
        !text.contains("\"heartbeat\""),
        "module heartbeats: {stats}"
    );
    team.stop();
}
