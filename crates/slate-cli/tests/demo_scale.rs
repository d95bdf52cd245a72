//! `slate demo --robots`: the range a team may have, as the CLI states and enforces it.

use std::process::{Command, Output};

fn slate(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_slate"))
        .args(args)
        .output()
        .expect("run slate")
}

#[test]
fn demo_refuses_33_robots_and_names_the_range() {
    let out = slate(&["demo", "--robots", "33", "--quiet"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("1..=32"), "{err}");
}

#[test]
fn demo_help_says_a_team_has_1_to_32_robots() {
    let out = slate(&["demo", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(help.contains("1 to 32"), "{help}");
}
