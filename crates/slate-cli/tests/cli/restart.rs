//! Modules that crash and come back, and observers that come and go: the team keeps what
//! it knows, and the boards keep no trace of who only looked.

use std::time::Duration;

use crate::support::{NodeProc, Team, eventually, show, wait_output};

const NAV: &str = "object gsr : Vehicle context self { mode = \"patrol\"; }";

#[test]
fn a_module_killed_and_started_again_does_not_roll_the_team_back() {
    let mut team = Team::connected("restart", &[("t/r1/nav", NAV), ("t/r2/loco", "")]);
    team.ok(&["put", "gsr.mode", "manual"]);
    let loco = team.node("t/r2/loco");
    assert!(loco.wait_value("gsr", "mode", "manual"), "{}", team.logs());
    team.kill_and_restart("t/r1/nav", NAV);
    team.wait_connected();
    // The restarted module takes the team's value back instead of its file's.
    let nav = team.node("t/r1/nav");
    assert!(nav.wait_value("gsr", "mode", "manual"), "{}", team.logs());
    let loco = team.node("t/r2/loco");
    assert_eq!(loco.value("gsr", "mode").as_deref(), Some("manual"));
    team.stop();
}

#[test]
fn cli_calls_leave_no_module_objects_behind() {
    let team = Team::connected("observers", &[("t/r1/nav", NAV), ("t/r2/loco", "")]);
    let modules = |node: &NodeProc| {
        let snap = node.snapshot();
        let objects = snap["objects"].as_array().cloned().unwrap_or_default();
        objects.iter().filter(|o| o["class"] == "Module").count()
    };
    let before: Vec<usize> = team.nodes.iter().map(modules).collect();
    for _ in 0..3 {
        team.ok(&["get", "gsr"]);
    }
    // Each call was a module while it ran; once gone, no board keeps its object.
    let gone = eventually(Duration::from_secs(10), || {
        team.nodes.iter().map(modules).collect::<Vec<_>>() == before
    });
    let objects = team.nodes[0].snapshot()["objects"].to_string();
    assert!(gone, "{before:?}: {objects}\n{}", team.logs());
    team.stop();
}

#[test]
fn put_of_an_owned_attribute_by_anyone_but_its_owner_is_refused_in_one_line() {
    let mut team = Team::new("owned");
    team.add(
        "t/r1/nav",
        "class Beacon { level: real merge owned; }\nobject b : Beacon { level = 1.0; }",
    );
    team.wait_connected();
    let out = team.slate(&["put", "b.level", "2.0"]);
    assert_eq!(out.status.code(), Some(1), "{}", crate::support::show(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("owned by t/r1/nav"), "{err}");
    assert_eq!(
        team.node("t/r1/nav").value("b", "level").as_deref(),
        Some("1.0")
    );
    team.stop();
}

#[test]
fn a_node_hears_every_cli_call_after_more_of_them_than_its_source_table_holds() {
    let mut team = Team::new("sources");
    team.add_with_ici("t/r1/nav", NAV, "max_sources = 2");
    team.wait_connected();
    // Each call is a new source; the node must hear the last as it heard the first.
    for speed in ["1.0", "2.0", "3.0", "4.0", "5.0"] {
        team.ok(&["put", "gsr.speed", speed]);
    }
    let nav = team.node("t/r1/nav");
    assert!(nav.wait_value("gsr", "speed", "5.0"), "{}", team.logs());
    team.stop();
}

/// A plan whose destination is killed and started again while `plan send` follows it:
/// the command waits for the circuit's acknowledgements to resume, prints them, and
/// exits 0 when the plan terminates (not 1 at the first `destination lost`).
///
/// Ignored because it is flaky: in about 1 run of 3 the command's observer (a Zenoh
/// client of `t/r1/nav`) never hears the restarted `t/r2/loco` although nav does, so
/// the circuit cannot resume and the command ends `destination lost` at its timeout.
/// That is the session healing of issue 16 (findings 1 and 7), not the waiting logic
/// (unit tests in `command/plan.rs`) nor the circuit's resend (`circuits/origin.rs`;
/// the Python test `test_acknowledgements_go_on_after_the_destination_restarts`, whose
/// nodes are Zenoh peers, passes). Run it with `--ignored`.
#[test]
#[ignore = "flaky: an observer sometimes never hears a restarted module (issue 16, findings 1 and 7)"]
fn plan_send_waits_through_a_destination_restart_and_exits_with_the_plan() {
    let mut team = Team::connected("plan-restart", &[("t/r1/nav", NAV), ("t/r2/loco", "")]);
    let plan = team.dir.join("hold.slate");
    std::fs::write(
        &plan,
        "plan hold {\n    trigger: gsr.mode == \"go\";\n    termination: gsr.mode == \"done\";\n    action { set gsr.mode = \"going\"; }\n}\n",
    )
    .unwrap();
    let file = plan.to_str().unwrap();
    let send = ["plan", "send", file, "--to", "t/r2/loco", "--timeout", "60"];
    let sender = team.spawn_via("t/r1/nav", &send);
    let running = || team.ok(&["plan", "ls"]).contains("on t/r2/loco");
    assert!(
        eventually(Duration::from_secs(15), running),
        "{}",
        team.logs()
    );
    let at = team
        .nodes
        .iter()
        .position(|n| n.address == "t/r2/loco")
        .unwrap();
    team.nodes.remove(at).kill();
    // Down long enough for every module to see it gone, as a crash does.
    std::thread::sleep(Duration::from_secs(3));
    team.add("t/r2/loco", "");
    team.wait_connected();
    // Only the restarted destination can fire it: the circuit sent the plan again.
    team.ok(&["put", "gsr.mode", "go"]);
    let nav = team.node("t/r1/nav");
    let fired = || nav.value("gsr", "mode").as_deref() == Some("going");
    let went = eventually(Duration::from_secs(40), fired);
    team.ok(&["put", "gsr.mode", "done"]);
    let out = wait_output(sender.take(), Duration::from_secs(65));
    assert!(went, "{}\n{}", show(&out), team.logs());
    let (text, err) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{}\n{}", show(&out), team.logs());
    assert!(err.contains("t/r2/loco lost"), "the loss is noted: {err}");
    for step in ["received", "triggered ok", "terminated"] {
        assert!(
            text.contains(&format!("hold -> t/r2/loco: {step}")),
            "{step}: {text}"
        );
    }
    assert!(!text.contains("destination lost"), "{text}");
    team.stop();
}
