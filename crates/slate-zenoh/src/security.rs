//! A secured session: Zenoh's TLS with mutual authentication, and Zenoh's access control
//! generated from the team's identities, so that each identity may publish only on the
//! keys of the address its certificate names.
//!
//! slate invents no cryptography here: [`Security::settings`] writes Zenoh's own keys
//! (`transport/link/tls/*`, `access_control`). Every link is `tls/` or `quic/`; each side
//! presents a certificate signed by the team's certificate authority and checks the
//! other's (`enable_mtls`). Host names are not checked (`verify_name_on_connect` off): a
//! module's identity is its address, carried as the certificate's common name, and what
//! that identity may do is decided by the access control below, not by where it runs.
//!
//! The access control, the same on every node of a team, denies by default and allows:
//! - every team identity to subscribe, query, answer queries and watch liveliness on any
//!   `slate/**` key (reading is not restricted inside the team);
//! - every node to send anything on `slate/**` to a team identity (egress);
//! - a module `T/R/M`, on what it receives (ingress) from it, to put, delete and declare
//!   liveliness only on its own keys: `slate/pub/*/T/R/M`, `slate/to/*/*/*/from/T/R/M`,
//!   `slate/alive/T/R/M` (see [`crate::keys`]);
//! - an operator `T/NAME` the same on the keys of `T/*/cli-NAME-*` (the observers the CLI
//!   runs, one per command, on any robot: an observer joins the robot it looks at), from
//!   the operator itself and from any module, since an observer is a Zenoh client whose
//!   messages the node it connects to relays.
//!
//! Zenoh applies access control per link, to the identity of the link's other end: a
//! message relayed by a module is judged as that module's. Zenoh 1.10 does not tell a
//! subscriber which authenticated identity a sample came from, so a receiver cannot check
//! it again itself; the key's sender is what the link's access control allowed.

use std::path::PathBuf;

use serde_json::{Value as Json, json};
use slate_model::Address;

/// The protocols a secured session may use: both run over TLS.
pub const SECURE_PROTOCOLS: &[&str] = &["tls", "quic"];

/// What a session needs to run secured: its own key and certificate, the team's
/// certificate authority, and whom the access control knows.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Security {
    /// The team's certificate authority (PEM), which signed every member's certificate.
    pub ca_certificate: PathBuf,
    /// This session's certificate (PEM), signed by the authority.
    pub certificate: PathBuf,
    /// This session's private key (PEM, PKCS#8).
    pub private_key: PathBuf,
    /// The team's identities, from which the access control is generated; `None`: no
    /// access control, for a Zenoh client, which hears the team only through the node it
    /// connects to (authenticated by TLS): that node relays every module's messages, which
    /// a client's own access control would take for that node's.
    pub team: Option<TeamIdentities>,
}

/// The identities of a team: its modules, and its operators (who use the CLI).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TeamIdentities {
    /// Each module, by address (`team/r1/nav`).
    pub modules: Vec<Address>,
    /// Each operator, as `(team, name)`.
    pub operators: Vec<(String, String)>,
}

/// The messages that declare interest or answer: allowed on every `slate/**` key to
/// every team identity.
const READS: &[&str] = &[
    "declare_subscriber",
    "declare_queryable",
    "query",
    "reply",
    "declare_liveliness_subscriber",
    "liveliness_query",
];

/// The messages that speak in an identity's name: allowed on its own keys only.
const WRITES: &[&str] = &["put", "delete", "liveliness_token"];

impl Security {
    /// Zenoh's keys and values (JSON5) for TLS with mutual authentication and the access
    /// control of [`TeamIdentities`].
    pub fn settings(&self) -> Vec<(&'static str, String)> {
        let path = |p: &PathBuf| json!(p.display().to_string()).to_string();
        let mut settings = vec![
            (
                "transport/link/tls/root_ca_certificate",
                path(&self.ca_certificate),
            ),
            (
                "transport/link/tls/listen_certificate",
                path(&self.certificate),
            ),
            (
                "transport/link/tls/listen_private_key",
                path(&self.private_key),
            ),
            (
                "transport/link/tls/connect_certificate",
                path(&self.certificate),
            ),
            (
                "transport/link/tls/connect_private_key",
                path(&self.private_key),
            ),
            ("transport/link/tls/enable_mtls", "true".to_owned()),
            (
                "transport/link/tls/verify_name_on_connect",
                "false".to_owned(),
            ),
        ];
        if let Some(team) = &self.team {
            settings.push(("access_control", team.access_control().to_string()));
        }
        settings
    }
}

impl TeamIdentities {
    /// Zenoh's `access_control` section for this team (the rules are in the file's doc).
    pub fn access_control(&self) -> Json {
        let mut acl = Acl::default();
        acl.rule(
            "read",
            READS,
            &["ingress", "egress"],
            vec!["slate/**".into()],
        );
        acl.rule("send", WRITES, &["egress"], vec!["slate/**".into()]);
        let modules: Vec<String> = self.modules.iter().map(|m| m.to_string()).collect();
        for (i, module) in self.modules.iter().enumerate() {
            let subject = acl.subject(&format!("module{i}"), &module.to_string());
            let speak = acl.rule(&format!("speak{i}"), WRITES, &["ingress"], own_keys(module));
            acl.policy(vec!["read".into(), "send".into(), speak], vec![subject]);
        }
        let module_subjects: Vec<String> =
            (0..modules.len()).map(|i| format!("module{i}")).collect();
        for (i, (team, name)) in self.operators.iter().enumerate() {
            let subject = acl.subject(&format!("operator{i}"), &format!("{team}/{name}"));
            let keys = own_keys_on_any_robot(team, name);
            let speak = acl.rule(&format!("operator_speak{i}"), WRITES, &["ingress"], keys);
            acl.policy(
                vec!["read".into(), "send".into(), speak.clone()],
                vec![subject],
            );
            if !module_subjects.is_empty() {
                acl.policy(vec![speak], module_subjects.clone());
            }
        }
        acl.into_json()
    }
}

/// The keys on which `module` speaks: its publications, its direct sends, its token.
fn own_keys(module: &Address) -> Vec<String> {
    vec![
        format!("slate/pub/*/{module}"),
        format!("slate/to/*/*/*/from/{module}"),
        format!("slate/alive/{module}"),
    ]
}

/// The keys on which operator `name` of `team` speaks: those of its observers
/// `team/ROBOT/cli-NAME-ANYTHING` on any robot (`$*` is Zenoh's wildcard within a chunk).
fn own_keys_on_any_robot(team: &str, name: &str) -> Vec<String> {
    let observer = format!("{team}/*/{}{name}-$*", OPERATOR_PREFIX);
    vec![
        format!("slate/pub/*/{observer}"),
        format!("slate/to/*/*/*/from/{observer}"),
        format!("slate/alive/{observer}"),
    ]
}

/// The module segment of an operator's observers starts with this and the operator's
/// name: `cli-alice-4242` (the CLI's observers are `cli-*`).
pub const OPERATOR_PREFIX: &str = "cli-";

/// Zenoh's access control document as it is built.
#[derive(Default)]
struct Acl {
    rules: Vec<Json>,
    subjects: Vec<Json>,
    policies: Vec<Json>,
}

impl Acl {
    /// Adds an allow rule; its id.
    fn rule(&mut self, id: &str, messages: &[&str], flows: &[&str], keys: Vec<String>) -> String {
        self.rules.push(json!({
            "id": id, "messages": messages, "flows": flows,
            "permission": "allow", "key_exprs": keys,
        }));
        id.to_owned()
    }

    /// Adds a subject known by its certificate's common name; its id.
    fn subject(&mut self, id: &str, common_name: &str) -> String {
        self.subjects
            .push(json!({ "id": id, "cert_common_names": [common_name] }));
        id.to_owned()
    }

    fn policy(&mut self, rules: Vec<String>, subjects: Vec<String>) {
        let id = format!("policy{}", self.policies.len());
        self.policies
            .push(json!({ "id": id, "rules": rules, "subjects": subjects }));
    }

    fn into_json(self) -> Json {
        json!({
            "enabled": true, "default_permission": "deny",
            "rules": self.rules, "subjects": self.subjects, "policies": self.policies,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn team() -> TeamIdentities {
        TeamIdentities {
            modules: vec![
                Address::new("t/r1/nav").unwrap(),
                Address::new("t/r2/loco").unwrap(),
            ],
            operators: vec![("t".into(), "alice".into())],
        }
    }

    #[test]
    fn a_module_may_speak_only_on_its_own_keys() {
        let acl = team().access_control();
        let rule = acl["rules"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["id"] == "speak0")
            .unwrap();
        assert_eq!(
            rule["key_exprs"],
            json!([
                "slate/pub/*/t/r1/nav",
                "slate/to/*/*/*/from/t/r1/nav",
                "slate/alive/t/r1/nav"
            ])
        );
        assert_eq!(rule["flows"], json!(["ingress"]));
        assert_eq!(acl["default_permission"], "deny");
        let nav = &acl["subjects"][0];
        assert_eq!(nav["cert_common_names"], json!(["t/r1/nav"]));
    }

    #[test]
    fn modules_relay_an_operator_but_not_each_other() {
        let acl = team().access_control();
        let policies = acl["policies"].as_array().unwrap();
        let relays: Vec<&Json> = policies
            .iter()
            .filter(|p| p["rules"] == json!(["operator_speak0"]))
            .collect();
        assert_eq!(relays.len(), 1);
        assert_eq!(relays[0]["subjects"], json!(["module0", "module1"]));
        let nav = policies
            .iter()
            .find(|p| p["subjects"] == json!(["module0"]))
            .unwrap();
        assert_eq!(nav["rules"], json!(["read", "send", "speak0"]));
    }

    #[test]
    fn zenoh_takes_the_settings() {
        let security = Security {
            ca_certificate: "/keys/ca.pem".into(),
            certificate: "/keys/t/r1/nav.pem".into(),
            private_key: "/keys/t/r1/nav.key".into(),
            team: Some(team()),
        };
        let mut config = zenoh::Config::default();
        for (key, value) in security.settings() {
            config
                .insert_json5(key, &value)
                .unwrap_or_else(|e| panic!("{key}: {e}"));
        }
        assert_eq!(
            config.get_json("transport/link/tls/enable_mtls").unwrap(),
            "true"
        );
        assert_eq!(
            config
                .get_json("access_control/default_permission")
                .unwrap(),
            "\"deny\""
        );
    }
}
