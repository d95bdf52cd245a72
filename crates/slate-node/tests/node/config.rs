//! Starting from a config file, and the errors of a bad one.

use std::path::Path;

use slate_node::{Node, NodeConfig, StartError};
use slate_testing::temp_dir;

/// Writes `dir/m.toml` for t/r1/nav listening on a free loopback port and loading
/// `files` (a TOML list), and reads it back.
fn config_loading(dir: &Path, files: &str) -> NodeConfig {
    let toml = format!(
        "address = \"t/r1/nav\"\nfiles = {files}\n[zenoh]\nlisten = [\"tcp/127.0.0.1:0\"]\n"
    );
    std::fs::write(dir.join("m.toml"), toml).unwrap();
    NodeConfig::read(&dir.join("m.toml")).unwrap()
}

#[test]
fn files_named_by_the_config_are_loaded_relative_to_it() {
    let d = temp_dir("node-files");
    std::fs::write(d.join("world.slate"), crate::support::WORLD).unwrap();
    std::fs::write(d.join("gsr.slate"), "object gsr : Vehicle context self;").unwrap();
    let config = config_loading(&d, r#"["world.slate", "gsr.slate"]"#);
    let node = Node::start(&config).unwrap();
    assert!(node.board().info("gsr").is_some());
    assert_eq!(node.listening(), ["tcp/127.0.0.1:0"]);
    node.close();
}

#[test]
fn a_slate_file_with_errors_stops_the_start_with_its_diagnostics() {
    let d = temp_dir("node-diag");
    std::fs::write(d.join("bad.slate"), "class V { speed: real }").unwrap();
    let mut config = NodeConfig::new(slate_model::Address::new("t/r1/nav").unwrap());
    config.files = vec![d.join("bad.slate").into(), d.join("missing.slate").into()];
    let err = Node::start(&config).err().unwrap();
    assert!(matches!(err, StartError::Load(_)), "{err}");
    assert!(err.to_string().contains("bad.slate:1:23: error"), "{err}");
    config.files = vec![d.join("missing.slate").into()];
    let err = Node::start(&config).err().unwrap();
    assert!(err.to_string().starts_with("cannot read "), "{err}");
}

#[test]
fn a_node_whose_file_names_the_builtin_module_class_starts() {
    let d = temp_dir("node-builtin");
    std::fs::write(
        d.join("watch.slate"),
        "plan watch_modules { trigger: any m: Module where not m.alive; action { } }\n",
    )
    .unwrap();
    let config = config_loading(&d, r#"["watch.slate"]"#);
    let node = Node::start(&config).unwrap();
    assert!(node.board().info("watch_modules").is_some());
    node.close();
}

#[test]
fn a_file_entry_with_placeholders_is_loaded_with_them_replaced() {
    let d = temp_dir("node-substitute");
    std::fs::write(d.join("world.slate"), crate::support::WORLD).unwrap();
    std::fs::write(
        d.join("robot.slate"),
        "object ROBOT_car : Vehicle context self;",
    )
    .unwrap();
    let files = r#"["world.slate", { path = "robot.slate", substitute = { ROBOT = "r2" } }]"#;
    let config = config_loading(&d, files);
    let node = Node::start(&config).unwrap();
    assert!(node.board().info("r2_car").is_some());
    assert!(node.board().info("ROBOT_car").is_none());
    node.close();
}

#[test]
fn a_bad_file_entry_is_refused_naming_the_key() {
    let d = temp_dir("node-substitute-bad");
    for (files, says) in [
        (
            r#"[{ substitute = { ROBOT = "r2" } }]"#,
            "without a string `path`",
        ),
        (
            r#"[{ path = "a.slate", substitute = { "" = "r2" } }]"#,
            "is not a name",
        ),
        (
            r#"[{ path = "a.slate", robot = "r2" }]"#,
            "unknown key `robot`",
        ),
        (
            r#"[{ path = "a.slate", substitute = { ROBOT = 2 } }]"#,
            "`substitute.ROBOT` integer 2",
        ),
    ] {
        let toml = format!("address = \"t/r1/nav\"\nfiles = {files}\n");
        std::fs::write(d.join("m.toml"), toml).unwrap();
        let err = NodeConfig::read(&d.join("m.toml")).unwrap_err().to_string();
        assert!(
            err.contains("key `files`") && err.contains(says),
            "{files}: {err}"
        );
    }
}

/// A plain Zenoh config file, as Zenoh documents it.
const ZENOH_FILE: &str = r#"{
  // Zenoh's own keys: a longer lease, an endpoint and timestamps slate replaces.
  mode: "peer",
  listen: { endpoints: ["tcp/127.0.0.1:1"] },
  transport: { link: { tx: { lease: 4321 } } },
  timestamping: { enabled: { router: true, peer: true, client: true } },
}"#;

#[test]
fn a_zenoh_config_file_is_loaded_by_zenoh_and_slates_keys_win() {
    let d = temp_dir("node-zenoh-file");
    std::fs::write(d.join("zenoh.json5"), ZENOH_FILE).unwrap();
    let port = slate_testing::free_port();
    let toml = format!(
        "address = \"t/r1/nav\"\nzenoh_config = \"zenoh.json5\"\n[zenoh]\nlisten = [\"tcp/127.0.0.1:{port}\"]\n"
    );
    std::fs::write(d.join("m.toml"), toml).unwrap();
    let config = NodeConfig::read(&d.join("m.toml")).unwrap();
    assert_eq!(
        config.zenoh.file.as_deref(),
        Some(d.join("zenoh.json5").as_path())
    );
    let zenoh = config.zenoh.to_zenoh().unwrap();
    // The file's lease stands; slate's endpoint (with the UDP one a node opens beside
    // it, `zenoh.udp_reports`) and timestamping win over the file's.
    assert_eq!(zenoh.get_json("transport/link/tx/lease").unwrap(), "4321");
    let listen = zenoh.get_json("listen/endpoints").unwrap();
    let want = format!("[\"tcp/127.0.0.1:{port}\",\"udp/127.0.0.1:{port}\"]");
    assert_eq!(listen, want);
    let stamps = zenoh.get_json("timestamping/enabled").unwrap();
    assert!(stamps.contains("\"peer\":false"), "{stamps}");
    let node = Node::start(&config).unwrap();
    assert_eq!(node.listening(), [format!("tcp/127.0.0.1:{port}")]);
    node.close();
}

#[test]
fn a_zenoh_config_file_zenoh_refuses_stops_the_start_naming_it() {
    let d = temp_dir("node-zenoh-bad");
    std::fs::write(
        d.join("zenoh.json5"),
        "{ transport: { link: { tx: { lease: \"soon\" } } } }",
    )
    .unwrap();
    std::fs::write(
        d.join("m.toml"),
        "address = \"t/r1/nav\"\nzenoh_config = \"zenoh.json5\"\n",
    )
    .unwrap();
    let config = NodeConfig::read(&d.join("m.toml")).unwrap();
    let err = Node::start(&config).err().unwrap().to_string();
    assert!(
        err.contains("zenoh config file") && err.contains("zenoh.json5"),
        "{err}"
    );
    assert!(!err.contains(".cargo"), "{err}");
}
