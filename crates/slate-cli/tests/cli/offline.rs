//! Verbs that need no team, run as the real `slate` binary: `check`, `bench`, `help`, and
//! argument errors.

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::support::{TempDir, show, slate, slate_ok, temp_dir};

#[test]
fn bench_core_prints_one_json_object_with_every_field() {
    let out = slate(&[
        "bench",
        "core",
        "--format",
        "json",
        "--samples",
        "3",
        "--sample-ms",
        "1",
    ]);
    assert!(out.status.success(), "{}", show(&out));
    let j: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("stdout is one JSON object");
    let ratios = ["read_ratio", "write_ratio"];
    for f in slate_bench::core::TIMED_FIELDS.iter().chain(&ratios) {
        assert!(
            j[f].as_f64().is_some_and(|x| x > 0.0),
            "{f} missing or not positive: {j}"
        );
    }
    assert!(j["targets_met"].is_boolean());
}

#[test]
fn bench_core_text_shows_the_baselines_and_targets() {
    let text = slate_ok(&["bench", "core", "--samples", "3", "--sample-ms", "1"]);
    assert!(
        text.contains("hashmap_get_ns") && text.contains("target <= 2x"),
        "{text}"
    );
}

#[test]
fn bad_input_gives_a_short_error_and_a_nonzero_exit() {
    for args in [
        &["bench", "warp"][..],
        &["bench", "core", "--samples", "1"],
        &["bench", "core", "--secure"],
        &["teleport"],
    ] {
        let out = slate(args);
        assert!(!out.status.success(), "{args:?} succeeded");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.starts_with("slate: error: "), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(out.stdout.is_empty());
    }
}

/// One line on stderr, `slate: error: ...` saying `says`, nothing on stdout, exit `code`.
fn one_line_error(out: &Output, code: i32, says: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    let shown = format!("exit {:?}\n{err}", out.status.code());
    assert_eq!(out.status.code(), Some(code), "{shown}");
    assert!(out.stdout.is_empty(), "{shown}");
    assert_eq!(err.lines().count(), 1, "{shown}");
    assert!(err.starts_with("slate: error: "), "{shown}");
    assert!(err.contains(says), "want {says:?}\n{shown}");
}

/// Nothing listens on port 9 of 127.0.0.1 (discard): a join there fails at once.
const NOWHERE: &str = "tcp/127.0.0.1:9";

#[test]
fn a_negative_number_is_a_value_checked_like_any_other_not_a_usage_error() {
    let put = |flag: &str, value: &str| {
        slate(&["put", "gsr.speed", "1", flag, value, "--connect", NOWHERE])
    };
    let out = put("--accuracy", "-1");
    one_line_error(&out, 2, "accuracy -1 must be finite and >= 0");
    let out = put("--confidence", "-0.5");
    one_line_error(&out, 2, "confidence -0.5 must be between 0 and 1");
    let out = slate(&["get", "gsr", "--wait", "-1", "--connect", NOWHERE]);
    one_line_error(&out, 2, "--wait -1: expected a positive number of seconds");
    let out = slate(&["watch", "*", "--count", "-1", "--connect", NOWHERE]);
    one_line_error(&out, 2, "'-1' for '--count <N>'");
}

#[test]
fn a_malformed_endpoint_is_named_at_once_not_reported_unreachable() {
    for (endpoint, says) in [
        ("not-an-endpoint", "is not PROTOCOL/ADDRESS"),
        ("ws/127.0.0.1:7447", "protocol \"ws\""),
        ("tcp/127.0.0.1", "no port"),
        ("tcp/127.0.0.1:99999", "port \"99999\""),
    ] {
        let out = slate(&["get", "gsr", "--connect", endpoint]);
        one_line_error(&out, 2, says);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains(&format!("--connect: endpoint {endpoint:?}"))
                && err.contains("like tcp/127.0.0.1:7447")
                && !err.contains("reachable"),
            "{err}"
        );
    }
}

#[test]
fn help_explains_the_bench_verb_with_an_example() {
    let text = slate_ok(&["bench", "--help"]);
    assert!(text.contains("slate bench core --format json"), "{text}");
}

#[test]
fn check_accepts_the_gsr_example_and_exits_zero() {
    let gsr = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/gsr.slate");
    let text = slate_ok(&["check", gsr]);
    assert!(text.contains("gsr.slate: ok (4 classes"), "{text}");
}

#[test]
fn check_reports_every_error_with_a_caret_and_exits_one() {
    let (dir, bad, out) = check(
        "check",
        "bad.slate",
        "class V { speed: real; }\nobject v : V;\nplan p { trigger: v.sped > 1.0; action { set v.speed = \"x\"; } }\n",
    );
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.slate:3:21: error: class V has no attribute sped"),
        "{err}"
    );
    assert!(
        err.contains("bad.slate:3:56: error: v.speed is real, but this value is string"),
        "{err}"
    );
    assert!(err.contains("^^^^"), "{err}");
    let out = slate(&["check", "--format", "json", bad.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(j["ok"], false);
    assert_eq!(j["files"][0]["diagnostics"].as_array().unwrap().len(), 2);
    assert_eq!(j["files"][0]["diagnostics"][0]["line"], 3);
    let out = slate(&["check", dir.join("missing.slate").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).starts_with("slate: error: cannot read"));
}

#[test]
fn check_accepts_the_demo_files_that_together_form_a_module() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/demo");
    let mut files: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path().display().to_string())
        .filter(|p| p.ends_with(".slate"))
        .collect();
    files.sort();
    let mut args = vec!["check"];
    args.extend(files.iter().map(String::as_str));
    let out = slate(&args);
    assert!(out.status.success(), "{}", show(&out));
}

#[test]
fn check_accepts_a_plan_over_the_builtin_module_class() {
    let (_dir, _, out) = check(
        "check-builtin",
        "watch.slate",
        "plan watch { trigger: any m: Module where not m.alive; action { } }\n",
    );
    assert!(out.status.success(), "{}", show(&out));
}

#[test]
fn a_load_error_says_error_once_and_keeps_its_caret() {
    let dir = temp_dir("node-load");
    std::fs::write(dir.join("bad.slate"), "class V { speed: real }").unwrap();
    std::fs::write(
        dir.join("m.toml"),
        "address = \"t/r1/nav\"\nfiles = [\"bad.slate\"]\n[zenoh]\nlisten = [\"tcp/127.0.0.1:0\"]\n",
    )
    .unwrap();
    let out = slate(&["node", "--config", dir.join("m.toml").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    let first = err.lines().next().unwrap_or_default();
    assert_eq!(first.matches("error").count(), 1, "{err}");
    assert!(first.contains("bad.slate:1:23: error: "), "{err}");
    assert!(err.contains('^'), "{err}");
}

#[test]
fn check_says_a_builtin_class_cannot_be_redefined() {
    let (_dir, _, out) = check("check-thing", "thing.slate", "class Thing { x: real; }\n");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("thing.slate:1:7: error: Thing is a built-in class"),
        "{err}"
    );
}

#[test]
fn check_refuses_a_deep_operator_chain_with_the_limit_not_a_crash() {
    // Issue 17: a trigger of 100 000 additions on one line aborted `slate check`.
    let chain = format!("x{}", " + 1.0".repeat(99_999));
    let source = format!(
        "class C {{ v: real; }}\nobject x : C;\nplan p {{\n  trigger: {chain} > 0.0;\n  action {{ }}\n}}\n"
    );
    let (_dir, _, out) = check("check-deep", "deep.slate", &source);
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("deep.slate:4:"), "{err}");
    assert!(err.contains("at most 64 levels"), "{err}");
    assert!(
        err.len() < 2_000,
        "the error quotes a window of the line: {} bytes",
        err.len()
    );
}

/// Writes `source` as `file` in a new temporary folder named after `dir` and runs
/// `slate check` on it: the folder, the file, and what `slate` did.
fn check(dir: &str, file: &str, source: &str) -> (TempDir, PathBuf, Output) {
    let dir = temp_dir(dir);
    let path = dir.join(file);
    std::fs::write(&path, source).unwrap();
    let out = slate(&["check", path.to_str().unwrap()]);
    (dir, path, out)
}

/// Asserts that a suite's JSON has each field, positive, and says whether its targets
/// were met.
fn assert_reports(j: &serde_json::Value, fields: &[&str]) {
    for f in fields {
        assert!(j[f].as_f64().is_some_and(|x| x > 0.0), "{f}: {}", j[f]);
    }
    assert!(j["targets_met"].is_boolean());
}

/// The `cli` suite runs `slate` processes, so it is tested here, where cargo has built
/// the executable; a test binary cannot run verbs.
#[test]
fn the_cli_suite_reports_every_field() {
    let cfg = slate_bench::Config {
        samples: 3,
        sample_ms: 1,
    };
    let slate = Path::new(env!("CARGO_BIN_EXE_slate"));
    let j = slate_bench::cli::run_with(slate, &cfg, &mut |_| {})
        .expect("the suite runs")
        .json();
    assert_reports(
        &j,
        &[
            "process_start_ms",
            "raw_zenoh_query_ms",
            "process_start_plus_raw_zenoh_ms",
            "get_round_trip_ms",
            "get_round_trip_p90_ms",
            "get_round_trip_ratio",
            "get_round_trip_p90_ratio",
            "get_round_trip_min_ms",
            "get_round_trip_max_ms",
            "process_start_p90_ms",
            "raw_zenoh_query_p90_ms",
            "raw_zenoh_query_replies",
            "runs",
        ],
    );
    assert!(j["get_round_trips_over_twice_the_median"].is_u64());
    assert!(
        j["get_command"]
            .as_str()
            .is_some_and(|c| c.starts_with("slate get"))
    );
}
