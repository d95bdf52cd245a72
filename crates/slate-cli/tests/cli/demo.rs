//! `slate demo --robots`: the range a team may have, as the CLI states and enforces it.

use crate::support::{slate, slate_err};

#[test]
fn demo_refuses_33_robots_and_names_the_range() {
    let err = slate_err(&["demo", "--robots", "33", "--quiet"]);
    assert!(err.contains("1..=32"), "{err}");
}

#[test]
fn demo_help_says_a_team_has_1_to_32_robots() {
    let out = slate(&["demo", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(help.contains("1 to 32"), "{help}");
}

#[test]
fn demo_runs_on_an_acoustic_team_link_and_reports_its_frames() {
    let out = slate(&[
        "demo",
        "--team-link",
        "acoustic",
        "--team-rate",
        "400",
        "--robots",
        "1",
        "--duration",
        "10",
        "--no-fault",
        "--quiet",
        "--format",
        "json",
    ]);
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!("{e}: {}", String::from_utf8_lossy(&out.stderr));
    });
    assert_eq!(j["team_link"], "acoustic");
    assert_eq!(j["team_link_budget_bps"], 400);
    let frame = j["team_largest_frame_bytes"].as_u64().expect("a number");
    assert!(frame > 0 && frame <= 32, "{j}");
    assert!(j["team_channel_utilisation"].as_f64().is_some(), "{j}");
}

#[test]
fn demo_refuses_a_team_rate_of_zero() {
    let err = slate_err(&["demo", "--team-rate", "0", "--quiet"]);
    assert!(err.contains("--team-rate"), "{err}");
}

#[test]
fn demo_runs_as_a_secured_team_over_zenoh_and_completes() {
    // One robot on Zenoh with TLS links and the generated access control, keys made in a
    // temporary folder. The run ends once the mission completes (about 80 s of real
    // time); the wait is bounded.
    let out = crate::support::wait_output(
        std::process::Command::new(env!("CARGO_BIN_EXE_slate"))
            .args([
                "demo",
                "--network",
                "zenoh",
                "--secure",
                "--robots",
                "1",
                "--no-fault",
                "--quiet",
                "--format",
                "json",
            ])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("slate demo starts"),
        std::time::Duration::from_secs(300),
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!("{e}: {}", String::from_utf8_lossy(&out.stderr));
    });
    assert_eq!(j["network"], "zenoh", "{j}");
    assert_eq!(j["mission_complete"], true, "{j}");
    assert_eq!(j["targets_found"], j["targets_total"], "{j}");
    assert_eq!(j["plans_rejected"], 0, "{j}");
}

#[test]
fn demo_refuses_secure_without_zenoh() {
    let err = slate_err(&["demo", "--secure", "--quiet"]);
    assert!(
        err.contains("--secure") && err.contains("--network zenoh"),
        "{err}"
    );
}

/// The top-level keys of a summary.
fn keys(summary: &serde_json::Value) -> Vec<String> {
    let mut keys: Vec<String> = summary
        .as_object()
        .expect("a JSON object")
        .keys()
        .cloned()
        .collect();
    keys.sort();
    keys
}

/// The module processes' pids, from the progress line that names them.
fn module_pids(stderr: &str) -> Vec<u32> {
    let line = stderr
        .lines()
        .find_map(|l| l.split_once("module processes: pids "))
        .map(|(_, pids)| pids)
        .unwrap_or_else(|| panic!("no pids line in:\n{stderr}"));
    line.split_whitespace()
        .map(|p| p.parse().unwrap())
        .collect()
}

/// `slate demo --network processes` with `extra` arguments, bounded: its JSON summary
/// and its progress (stderr), once checked that the mission completed with every target
/// found once, the fault detected, and that no module process outlived the run nor left
/// its logs behind.
fn processes_mission(extra: &[&str]) -> (serde_json::Value, String) {
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_slate"))
        .args(["demo", "--network", "processes", "--format", "json"])
        .args(extra)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run slate");
    let logs = std::env::temp_dir().join(format!("slate-demo-{}", child.id()));
    let out = crate::support::wait_output(child, std::time::Duration::from_secs(400));
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let j: serde_json::Value =
        serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {stderr}"));
    assert_eq!(j["network"], "processes", "{j}");
    assert_eq!(j["mission_complete"], true, "{j}\n{stderr}");
    assert_eq!(j["targets_found"], j["targets_total"], "{j}");
    assert_eq!(j["duplicate_investigations"], 0, "{j}");
    assert_eq!(j["robot_failures"], 1, "{j}");
    assert!(
        j["detection_seconds"].is_number(),
        "fault not detected: {j}"
    );
    assert!(j["team_link_bytes"].as_u64().unwrap() > 0, "{j}");
    // The plans the module processes sent and accepted: the console's mission plans,
    // and the sub-plans each execution controller sends its robot's modules.
    assert!(j["plans_sent"].as_u64() > Some(0), "no plan counted: {j}");
    assert!(j["plans_accepted"].as_u64() > Some(0), "{j}");
    assert_eq!(j["plans_rejected"], 0, "{j}");
    let pids = module_pids(&stderr);
    assert_eq!(pids.len(), 16, "{stderr}");
    for pid in pids {
        assert!(
            !std::path::Path::new(&format!("/proc/{pid}")).exists(),
            "module process {pid} outlived the demo"
        );
    }
    assert!(
        !logs.exists(),
        "the module logs of a clean run are left in {logs:?}"
    );
    (j, stderr)
}

/// `--network processes`: sixteen module processes over Zenoh on 127.0.0.1, the world
/// served to their drivers as a module; the mission completes as in-process, with the
/// same summary, and no module process outlives the run. By default the robots speak
/// on the team link (one gateway per robot), not every module.
#[test]
fn the_demo_mission_completes_with_every_module_its_own_process() {
    let (j, stderr) = processes_mission(&[]);
    let sim = slate(&[
        "demo",
        "--robots",
        "1",
        "--duration",
        "10",
        "--no-fault",
        "--quiet",
        "--format",
        "json",
    ]);
    let sim: serde_json::Value = serde_json::from_slice(&sim.stdout).unwrap();
    assert_eq!(keys(&j), keys(&sim), "the same summary fields");
    let kinds = &j["team_bytes_by_kind"];
    assert!(kinds["team_frame"].as_u64() > Some(0), "{kinds}\n{stderr}");
    assert!(kinds["robot_heartbeat"].as_u64() > Some(0), "{kinds}");
    assert_eq!(
        kinds.get("heartbeat"),
        None,
        "modules said their own heartbeats on the team link: {kinds}"
    );
}

/// `--network processes --speakers modules`: the per-module protocol (every module
/// speaks on the team link) still runs the mission to its end as processes.
#[test]
fn the_processes_mission_completes_with_every_module_speaking() {
    let (j, stderr) = processes_mission(&["--speakers", "modules"]);
    let kinds = &j["team_bytes_by_kind"];
    assert!(kinds["heartbeat"].as_u64() > Some(0), "{kinds}\n{stderr}");
    assert_eq!(kinds.get("team_frame"), None, "{kinds}");
}

#[test]
fn demo_refuses_a_placement_without_module_processes_and_a_malformed_one() {
    let err = slate_err(&["demo", "--place", "r1=ns1@10.0.0.2", "--quiet"]);
    assert!(err.contains("use them with --network processes"), "{err}");
    let err = slate_err(&["demo", "--network", "processes", "--place", "r1@10.0.0.2"]);
    assert!(err.contains("expected NAME=NETNS@IP"), "{err}");
}
