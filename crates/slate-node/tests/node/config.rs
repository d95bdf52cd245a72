//! Starting from a config file, and the errors of a bad one.

use std::path::PathBuf;

use slate_node::{Node, NodeConfig, StartError};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("slate-node-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn files_named_by_the_config_are_loaded_relative_to_it() {
    let d = dir("files");
    std::fs::write(d.join("world.slate"), crate::support::WORLD).unwrap();
    std::fs::write(d.join("gsr.slate"), "object gsr : Vehicle context self;").unwrap();
    std::fs::write(
        d.join("m.toml"),
        "address = \"t/r1/nav\"\nfiles = [\"world.slate\", \"gsr.slate\"]\n[zenoh]\nlisten = [\"tcp/127.0.0.1:0\"]\n",
    )
    .unwrap();
    let config = NodeConfig::read(&d.join("m.toml")).unwrap();
    let node = Node::start(&config).unwrap();
    assert!(node.board().info("gsr").is_some());
    assert_eq!(node.listening(), ["tcp/127.0.0.1:0"]);
    node.close();
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn a_slate_file_with_errors_stops_the_start_with_its_diagnostics() {
    let d = dir("diag");
    std::fs::write(d.join("bad.slate"), "class V { speed: real }").unwrap();
    let mut config = NodeConfig::new(slate_model::Address::new("t/r1/nav").unwrap());
    config.files = vec![d.join("bad.slate"), d.join("missing.slate")];
    let err = Node::start(&config).err().unwrap();
    assert!(matches!(err, StartError::Load(_)), "{err}");
    assert!(err.to_string().contains("bad.slate:1:23: error"), "{err}");
    config.files = vec![d.join("missing.slate")];
    let err = Node::start(&config).err().unwrap();
    assert!(err.to_string().starts_with("cannot read "), "{err}");
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn a_node_whose_file_names_the_builtin_module_class_starts() {
    let d = dir("builtin");
    std::fs::write(
        d.join("watch.slate"),
        "plan watch_modules { trigger: any m: Module where not m.alive; action { } }\n",
    )
    .unwrap();
    std::fs::write(
        d.join("m.toml"),
        "address = \"t/r1/nav\"\nfiles = [\"watch.slate\"]\n[zenoh]\nlisten = [\"tcp/127.0.0.1:0\"]\n",
    )
    .unwrap();
    let config = NodeConfig::read(&d.join("m.toml")).unwrap();
    let node = Node::start(&config).unwrap();
    assert!(node.board().info("watch_modules").is_some());
    node.close();
    std::fs::remove_dir_all(&d).unwrap();
}
