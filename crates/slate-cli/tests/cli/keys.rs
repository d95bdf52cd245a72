//! `slate keys`: a team's certificate authority and its members' keys, as files.

use std::os::unix::fs::PermissionsExt;
use std::path::Path;

use slate_node::team_keys::{self, Identity};

use crate::support::{slate_err, slate_ok, temp_dir};

fn mode(path: &Path) -> u32 {
    std::fs::metadata(path).unwrap().permissions().mode() & 0o777
}

#[test]
fn keys_init_makes_an_authority_whose_private_key_only_its_owner_reads() {
    let dir = temp_dir("keys-init");
    let out = slate_ok(&["keys", "init", dir.to_str().unwrap()]);
    assert!(out.contains("ca.pem") && out.contains("ca.key"), "{out}");
    assert_eq!(mode(&dir.join("ca.key")), 0o600);
    let cert = std::fs::read_to_string(dir.join("ca.pem")).unwrap();
    assert!(cert.starts_with("-----BEGIN CERTIFICATE-----"), "{cert}");
}

#[test]
fn keys_init_refuses_to_replace_an_authority_without_force() {
    let dir = temp_dir("keys-again");
    let d = dir.to_str().unwrap();
    slate_ok(&["keys", "init", d]);
    let before = std::fs::read(dir.join("ca.key")).unwrap();
    let err = slate_err(&["keys", "init", d]);
    assert!(
        err.contains("already exists; pass --force to replace it"),
        "{err}"
    );
    assert_eq!(std::fs::read(dir.join("ca.key")).unwrap(), before);
    slate_ok(&["keys", "init", d, "--force"]);
    assert_ne!(std::fs::read(dir.join("ca.key")).unwrap(), before);
    assert_eq!(mode(&dir.join("ca.key")), 0o600);
}

#[test]
fn keys_issue_writes_certificates_named_by_identity_and_signed_by_the_authority() {
    let dir = temp_dir("keys-issue");
    let d = dir.to_str().unwrap();
    slate_ok(&["keys", "init", d]);
    let out = slate_ok(&[
        "keys", "issue", d, "t/r1/nav", "t/alice", "--format", "json",
    ]);
    let written: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(written["written"].as_array().unwrap().len(), 4, "{out}");
    assert_eq!(mode(&dir.join("t/r1/nav.key")), 0o600);
    assert_eq!(mode(&dir.join("t/alice.key")), 0o600);
    // The node's own check: readable, signed by ca.pem, for this identity, its key.
    let nav = Identity::parse("t/r1/nav").unwrap();
    let security = team_keys::security(&dir, &nav).unwrap();
    let team = security.team.unwrap();
    assert_eq!(team.modules.len(), 1);
    assert_eq!(team.operators, [("t".to_owned(), "alice".to_owned())]);
    let err = slate_err(&["keys", "issue", d, "t/r1/nav"]);
    assert!(err.contains("nav.pem: already exists"), "{err}");
}

#[test]
fn keys_issue_without_an_authority_says_to_run_init() {
    let dir = temp_dir("keys-no-ca");
    let d = dir.to_str().unwrap();
    let err = slate_err(&["keys", "issue", d, "t/r1/nav"]);
    assert!(
        err.contains("no team certificate authority there; run `slate keys init"),
        "{err}"
    );
    assert!(!dir.join("t").exists());
}

#[test]
fn keys_issue_refuses_a_malformed_identity_and_issues_nothing() {
    let dir = temp_dir("keys-bad");
    let d = dir.to_str().unwrap();
    slate_ok(&["keys", "init", d]);
    let err = slate_err(&["keys", "issue", d, "t/r1/nav", "t/r 1/cam"]);
    assert!(
        err.contains("\"t/r 1/cam\" is no identity: expected a module address TEAM/ROBOT/MODULE or an operator TEAM/NAME"),
        "{err}"
    );
    assert!(!dir.join("t/r1/nav.pem").exists());
}
