//! Each live verb against a two-node team: t/r1/nav owns gsr and rock, t/r2/loco runs
//! plans. Both export everything.

use std::io::{BufRead, BufReader};
use std::time::Duration;

use crate::support::{Team, class_in, entry, keys, show, steps, wait_output};

const NAV: &str = "object gsr : Vehicle context self { position = [10.0, 20.0] accuracy 0.5; }\nobject rock : Obstacle { position = [15.0, 22.0]; range = 5.4; }";

fn two_nodes(name: &str) -> Team {
    Team::connected(name, &[("t/r1/nav", NAV), ("t/r2/loco", "")])
}

#[test]
fn tree_ls_and_get_show_the_team_as_text_and_json() {
    let team = two_nodes("inspect");
    let tree = team.ok(&["tree"]);
    assert!(tree.starts_with("Thing\n"), "{tree}");
    assert!(
        tree.contains("Vehicle (position, speed, mode): 1 object"),
        "{tree}"
    );
    assert!(
        tree.contains("Obstacle (position, range): 1 object"),
        "{tree}"
    );
    let j = team.json(&["tree"]);
    let vehicle = class_in(&j, "Vehicle");
    assert_eq!(vehicle["objects"], 1);
    assert_eq!(vehicle["parent"], "Thing");

    let ls = team.ok(&["ls", "Vehicle"]);
    assert!(ls.starts_with("gsr") && ls.contains("t/r1/nav"), "{ls}");
    let j = team.json(&["ls", "Thing"]);
    let names = keys(&j["objects"], "name");
    assert!(
        names.contains(&"gsr") && names.contains(&"rock") && names.contains(&"t_r1_nav"),
        "{names:?}"
    );

    let get = team.ok(&["get", "gsr"]);
    assert!(get.contains("gsr: Vehicle"), "{get}");
    assert!(
        get.contains("position = [10.0, 20.0] ± 0.5 m  confidence 1.00"),
        "{get}"
    );
    assert!(get.contains("from t/r1/nav"), "{get}");
    let j = team.json(&["get", "rock.range"]);
    assert_eq!(j["object"], "rock");
    assert_eq!(j["owner"], "t/r1/nav");
    let a = &j["attrs"][0];
    assert_eq!(
        (a["attr"].as_str(), a["value"].as_f64(), a["unit"].as_str()),
        (Some("range"), Some(5.4), Some("m"))
    );
    assert_eq!(a["confidence"], 1.0);
    assert_eq!(a["source"], "t/r1/nav");
    assert!(
        a["age"].is_null(),
        "an initial value from a file claims no time: {a}"
    );
    team.stop();
}

#[test]
fn put_on_one_node_is_seen_by_get_and_on_the_other_node_and_watch_prints_it() {
    let team = two_nodes("put");
    // A watcher, started first; it says on stderr when it is watching.
    let args = [
        "watch",
        "gsr.speed",
        "--count",
        "2",
        "--format",
        "json",
        "--log",
        "slate_ici=debug,slate_node=debug",
    ];
    let mut watcher = team.spawn(&args);
    let stderr = watcher.0.as_mut().and_then(|c| c.stderr.take()).unwrap();
    let mut stderr = BufReader::new(stderr);
    let mut line = String::new();
    let mut log = String::new();
    while stderr.read_line(&mut line).unwrap() > 0 && !line.starts_with("watching") {
        log.push_str(&line);
        line.clear();
    }
    assert!(line.starts_with("watching gsr.speed on team t"), "{line}");
    let rest = std::thread::spawn(move || {
        let mut text = String::new();
        let _ = std::io::Read::read_to_string(&mut stderr, &mut text);
        text
    });

    let out = team.ok(&[
        "put",
        "gsr.speed",
        "3.5",
        "--accuracy",
        "0.1",
        "--confidence",
        "0.8",
    ]);
    assert!(out.starts_with("gsr.speed = 3.5 ± 0.1"), "{out}");
    let j = team.json(&["put", "gsr.speed", "4"]);
    assert_eq!(j["value"], 4.0);

    let loco = team.node("t/r2/loco");
    assert!(loco.wait_value("gsr", "speed", "4.0"), "{}", team.logs());
    let nav = team.node("t/r1/nav");
    assert!(nav.wait_value("gsr", "speed", "4.0"));
    let got = team.json(&["get", "gsr.speed"]);
    assert_eq!(got["attrs"][0]["value"], 4.0);
    assert!(
        got["attrs"][0]["source"]
            .as_str()
            .unwrap()
            .contains("/cli-")
    );

    let out = wait_output(watcher.take(), Duration::from_secs(20));
    let log = log + &rest.join().unwrap();
    assert!(out.status.success(), "{}\n{log}", show(&out));
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 2, "{}", show(&out));
    assert_eq!(lines[0]["object"], "gsr");
    assert_eq!(lines[0]["value"], 3.5);
    assert_eq!(lines[1]["value"], 4.0);
    assert_eq!(lines[1]["kind"], "write");
    team.stop();
}

#[test]
fn plan_send_prints_acks_and_plan_ls_and_cancel_work() {
    let team = two_nodes("plans");
    let plans = team.dir.join("fast.slate");
    std::fs::write(
        &plans,
        "plan fast {\n    trigger: gsr.speed > 5.0;\n    termination: gsr.mode == \"stopped\";\n    action { set gsr.mode = \"slow\"; }\n}\n",
    )
    .unwrap();
    let file = plans.to_str().unwrap();
    // Triggered at once (speed 6 before it is sent), then terminated by the mode.
    team.ok(&["put", "gsr.speed", "6"]);
    let sender = team.spawn(&["plan", "send", file, "--to", "t/r2/loco", "--timeout", "20"]);
    let loco = team.node("t/r2/loco");
    assert!(
        crate::support::eventually(Duration::from_secs(15), || loco
            .value("gsr", "mode")
            .as_deref()
            == Some("slow")),
        "{}",
        team.logs()
    );
    let ls = team.ok(&["plan", "ls"]);
    assert!(
        ls.contains("fast") && ls.contains("fired 1") && ls.contains("on t/r2/loco"),
        "{ls}"
    );
    team.ok(&["put", "gsr.mode", "stopped"]);
    let out = wait_output(sender.take(), Duration::from_secs(25));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", show(&out));
    for step in [
        "received",
        "accepted",
        "initiated",
        "triggered ok",
        "terminated",
    ] {
        assert!(
            text.contains(&format!("fast -> t/r2/loco: {step}")),
            "{step}: {text}"
        );
    }
    let j = team.json(&["plan", "ls"]);
    let fast = entry(&j["plans"], "name", "fast").unwrap();
    assert_eq!(fast["state"], "terminated");
    assert_eq!(fast["on"], "t/r2/loco");
    assert_eq!(fast["fired"], 1);

    // A plan that stays active, cancelled from another command.
    let slow = team.dir.join("slow.slate");
    std::fs::write(
        &slow,
        "plan slow { trigger: gsr.speed > 9.0; action { set gsr.mode = \"x\"; } }",
    )
    .unwrap();
    let out = team.send_plan(&slow, "t/r2/loco", "2");
    assert!(out.status.success(), "{}", show(&out));
    let steps = steps(&out);
    assert_eq!(steps, ["received", "accepted", "initiated"]);
    let out = team.ok(&["plan", "cancel", "slow", "--on", "t/r2/loco"]);
    assert_eq!(out, "plan slow cancelled on t/r2/loco\n");
    let j = team.json(&["plan", "ls"]);
    let slow = entry(&j["plans"], "name", "slow").unwrap();
    assert_eq!(slow["state"], "cancelled");
    let again = team.slate(&["plan", "cancel", "slow"]);
    assert_eq!(again.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&again.stderr).contains("already cancelled"));
    team.stop();
}

#[test]
fn get_shows_a_never_written_default_as_a_default_not_as_fresh() {
    let team = two_nodes("defaults");
    let get = team.ok(&["get", "gsr"]);
    assert!(
        get.contains("mode = auto  confidence 1.00  default, never written\n"),
        "{get}"
    );
    // An initial value from nav's file claims no time either, but has its writer.
    assert!(
        get.contains("position = [10.0, 20.0] ± 0.5 m  confidence 1.00  initial value from t/r1/nav, no time\n"),
        "{get}"
    );
    let j = team.json(&["get", "gsr.speed"]);
    let speed = &j["attrs"][0];
    assert_eq!(speed["default"], true, "{j}");
    assert!(speed["age"].is_null() && speed["source"].is_null(), "{j}");
    let j = team.json(&["get", "gsr.position"]);
    let position = &j["attrs"][0];
    assert_eq!(position["default"], false, "{j}");
    assert!(position["age"].is_null(), "{j}");
    assert_eq!(position["source"], "t/r1/nav", "{j}");
    // A packet written since has an age and a source.
    team.ok(&["put", "gsr.speed", "1.0"]);
    let j = team.json(&["get", "gsr.speed"]);
    let speed = &j["attrs"][0];
    assert_eq!(speed["default"], false, "{j}");
    assert!(speed["age"].as_f64().is_some_and(|a| a >= 0.0), "{j}");
    team.stop();
}

/// t/r2/loco runs a plan of its own and exports its vehicle but not its `Plan` objects.
const LOCO: &str = "object cart : Vehicle context self;\nplan idle { trigger: cart.speed > 9.0; action { set cart.mode = \"x\"; } }";

#[test]
fn introspection_says_which_modules_it_sees_only_through_their_export() {
    let mut team = Team::new("unexported");
    team.add("t/r1/nav", NAV);
    team.add_exporting("t/r2/loco", LOCO, "\"Vehicle\"");
    team.wait_connected();
    // The observer is on robot r1: loco's plan is not exported to it.
    let out = team.slate(&["plan", "ls"]);
    assert!(out.status.success(), "{}", show(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("t/r2/loco") && err.contains("--as t/r2/"),
        "{}",
        show(&out)
    );
    let j = team.json(&["plan", "ls"]);
    assert_eq!(j["plans"].as_array().map(Vec::len), Some(0), "{j}");
    assert_eq!(j["seen_through_export"], serde_json::json!(["t/r2/loco"]));
    // The same for the other verbs.
    let j = team.json(&["ls", "Thing"]);
    assert_eq!(j["seen_through_export"], serde_json::json!(["t/r2/loco"]));
    let j = team.json(&["tree"]);
    assert_eq!(j["seen_through_export"], serde_json::json!(["t/r2/loco"]));
    let out = team.slate(&["get", "idle"]);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("t/r2/loco") && err.contains("--as t/r2/"),
        "{err}"
    );
    // Following the advice shows it.
    let j = team.json(&["plan", "ls", "--as", "t/r2/cli-test"]);
    let names = keys(&j["plans"], "name");
    assert_eq!(names, ["idle"], "{j}");
    assert_eq!(j["seen_through_export"], serde_json::json!(["t/r1/nav"]));
    team.stop();
}

#[test]
fn tree_shows_a_class_two_modules_define_differently() {
    let mut team = Team::new("conflict");
    team.add(
        "t/r1/nav",
        "class Sonar { ping: real; }\nobject s1 : Sonar { ping = 0.5; }",
    );
    team.add(
        "t/r2/loco",
        "class Sonar { ping: int; }\nobject s2 : Sonar { ping = 3; }",
    );
    team.wait_connected();
    let tree = team.ok(&["tree"]);
    assert!(
        tree.contains("[conflict: defined differently by t/r"),
        "{tree}"
    );
    let j = team.json(&["tree"]);
    let sonar = class_in(&j, "Sonar");
    assert_eq!(sonar["conflicts"].as_array().map(Vec::len), Some(1), "{j}");
    // The object of the other definition is not held, and `get` says why.
    let missing: Vec<String> = ["s1", "s2"]
        .iter()
        .map(|o| team.slate(&["get", o]))
        .filter(|out| !out.status.success())
        .map(|out| String::from_utf8_lossy(&out.stderr).into_owned())
        .collect();
    assert_eq!(missing.len(), 1, "{missing:?}");
    assert!(
        missing[0].contains("Sonar (t/r") && missing[0].contains("defined differently"),
        "{missing:?}"
    );
}
