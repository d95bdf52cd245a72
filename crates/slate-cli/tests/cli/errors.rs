//! Bad input: a one-line error on stderr, nothing on stdout, a non-zero exit. And every
//! verb explains itself with an example.

use crate::support::{Team, entry, free_port, show, slate, slate_ok, temp_dir};

fn one_line_error(out: &std::process::Output, code: i32, says: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{}", show(out));
    assert!(out.stdout.is_empty(), "{}", show(out));
    assert_eq!(err.lines().count(), 1, "{}", show(out));
    assert!(err.contains(says), "want {says:?}\n{}", show(out));
}

#[test]
fn a_bad_config_key_names_the_file_and_the_key() {
    let dir = temp_dir("badkey");
    let path = dir.join("m.toml");
    std::fs::write(
        &path,
        "address = \"t/r1/nav\"\n[zenoh]\nlisen = [\"tcp/127.0.0.1:7447\"]\n",
    )
    .unwrap();
    let out = slate(&["node", "--config", path.to_str().unwrap()]);
    one_line_error(
        &out,
        2,
        "m.toml: unknown key `zenoh.lisen` (known keys: zenoh.mode, zenoh.listen",
    );
    std::fs::write(&path, "address = \"nav\"\n").unwrap();
    let out = slate(&["node", "--config", path.to_str().unwrap()]);
    one_line_error(&out, 2, "m.toml: key `address`: expected a module address");
}

#[test]
fn no_node_to_talk_to_is_one_line() {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let out = slate(&["get", "gsr", "--connect", &endpoint, "--wait", "1"]);
    one_line_error(&out, 2, "no slate module reachable through");
    // It failed at once: it does not claim to have waited.
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("nothing there took the connection"), "{err}");
}

#[test]
fn bad_addresses_values_and_names_against_a_live_node() {
    let team = Team::connected(
        "errors",
        &[("t/r1/nav", "object gsr : Vehicle context self;")],
    );
    let cases: [(&[&str], i32, &str); 8] = [
        (
            &["get", "gsr", "--as", "nav"],
            2,
            "--as: address \"nav\" must have the form team/robot/module",
        ),
        (
            &["get", "ghost"],
            1,
            "no object or class named \"ghost\" on the boards of team t",
        ),
        (
            &["get", "gsr.sped"],
            1,
            "gsr (Vehicle) has no attribute \"sped\" (it has: position, speed, mode)",
        ),
        (&["ls", "Ghost"], 1, "no class named \"Ghost\""),
        (&["put", "gsr.speed", "fast"], 2, "\"fast\" is not a real"),
        (
            &["put", "gsr.speed", "50"],
            2,
            "outside the declared bounds [0, 10]",
        ),
        (&["put", "gsr", "1"], 2, "expected OBJ.ATTR"),
        (
            &["watch", "ghost.speed"],
            1,
            "no object or class named \"ghost\"",
        ),
    ];
    for (args, code, says) in cases {
        one_line_error(&team.slate(args), code, says);
    }
    let plan = team.dir.join("p.slate");
    std::fs::write(&plan, "plan p { action { } }").unwrap();
    let out = team.slate(&["plan", "send", plan.to_str().unwrap(), "--to", "t/r1"]);
    one_line_error(
        &out,
        2,
        "--to: address \"t/r1\" must have the form team/robot/module",
    );
    let out = team.slate(&["plan", "send", plan.to_str().unwrap(), "--to", "t/r9/ghost"]);
    one_line_error(&out, 1, "no module t/r9/ghost on team t");
    team.stop();
}

#[test]
fn help_explains_every_verb_with_an_example() {
    for verb in [
        &["node"][..],
        &["tree"],
        &["ls"],
        &["get"],
        &["put"],
        &["watch"],
        &["plan"],
        &["plan", "send"],
        &["plan", "ls"],
        &["plan", "cancel"],
        &["check"],
        &["bench"],
    ] {
        let mut args = verb.to_vec();
        args.push("--help");
        let text = slate_ok(&args);
        assert!(text.contains("Example: slate "), "{verb:?}: {text}");
        assert!(text.contains("--format"), "{verb:?}: {text}");
    }
}

#[test]
fn tree_of_files_needs_no_network() {
    let gsr = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/gsr.slate");
    let text = slate_ok(&["tree", gsr]);
    assert!(
        text.contains("├── Obstacle (observer, range, bearing, position, clearance)"),
        "{text}"
    );
    let out = slate(&["tree", gsr, "--format", "json"]);
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(entry(&j["classes"], "name", "Target").is_some());
}

#[test]
fn a_node_on_a_port_in_use_says_so_in_one_line() {
    let mut team = Team::new("portinuse");
    team.add("t/r1/nav", "");
    let taken = team.nodes[0].endpoint.clone();
    let path = team.dir.join("second.toml");
    std::fs::write(
        &path,
        format!("address = \"t/r1/two\"\n[zenoh]\nlisten = [\"{taken}\"]\n"),
    )
    .unwrap();
    let out = slate(&["node", "--config", path.to_str().unwrap()]);
    one_line_error(&out, 2, "Address already in use");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.starts_with("slate: error: "), "{err}");
    assert!(!err.contains(".rs:") && !err.contains("registry"), "{err}");
    team.stop();
}

/// `--log-format json`: every log line on stderr is one JSON object (tracing-subscriber's:
/// timestamp, level, target, fields); the error stays the one `slate: error:` line.
#[test]
fn log_format_json_writes_each_log_line_as_a_json_object() {
    let out = crate::support::slate(&[
        "stats",
        "--connect",
        "tcp/127.0.0.1:1",
        "--wait",
        "1",
        "--log",
        "debug",
        "--log-format",
        "json",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    let (errors, logs): (Vec<&str>, Vec<&str>) =
        err.lines().partition(|l| l.starts_with("slate: error:"));
    assert_eq!(errors.len(), 1, "{err}");
    assert!(!logs.is_empty(), "no log line at debug: {err}");
    for line in logs {
        let j: serde_json::Value =
            serde_json::from_str(line).unwrap_or_else(|e| panic!("{e}: {line}"));
        assert!(j["level"].is_string() && j["target"].is_string(), "{line}");
        assert!(j["fields"].is_object(), "{line}");
    }
}
