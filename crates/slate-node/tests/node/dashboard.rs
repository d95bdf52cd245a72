//! The dashboard a node serves: its snapshot follows docs/dashboard.md.

use std::time::Duration;

use slate_ici::SimNet;

use crate::support::{WORLD, addr, eventually, on_net};
use slate_node::Node;
use slate_testing::{entry, http_get, keys};

/// t/r1/nav on `net`, loading [`WORLD`](crate::support::WORLD) and `objects`, serving its
/// dashboard on a free loopback port.
fn nav_serving(net: &SimNet, objects: &str) -> Node {
    on_net(net, "t/r1/nav", objects)
        .dashboard("127.0.0.1:0".parse().unwrap())
        .start()
        .unwrap()
}

#[test]
fn the_snapshot_has_map_items_classes_objects_plans_links_and_events() {
    let net = SimNet::new(9);
    let nav = nav_serving(
        &net,
        "object gsr : Vehicle context self { position = [3.0, 4.0] accuracy 0.5; }\nobject rock : Obstacle { position = [5.0, 6.0]; }\nplan p { trigger: gsr.speed > 1.0; action { set gsr.mode = \"go\"; } }",
    );
    let b = addr("t/r1/loco");
    let _loco = Node::builder(b.clone())
        .transport(net.join(&b))
        .clock(net.clock())
        .source("w.slate", WORLD)
        .start()
        .unwrap();
    net.run_for(Duration::from_millis(500));
    assert!(eventually(|| nav
        .events()
        .iter()
        .any(|e| e.text == "peer t/r1/loco up")));
    let url = nav.dashboard_url().expect("serves a dashboard");
    let j: serde_json::Value = http_get(&url, "/api/snapshot").json();
    assert_eq!(j["title"], "slate node t/r1/nav");
    let items = j["map"]["items"].as_array().unwrap();
    let gsr = items.iter().find(|i| i["id"] == "gsr").unwrap();
    assert_eq!(
        (gsr["kind"].as_str(), gsr["x"].as_f64(), gsr["y"].as_f64()),
        (Some("robot"), Some(3.0), Some(4.0))
    );
    assert_eq!(gsr["accuracy"], 0.5);
    assert!(
        items
            .iter()
            .any(|i| i["id"] == "rock" && i["kind"] == "obstacle")
    );
    let classes = keys(&j["classes"], "name");
    assert!(
        classes.contains(&"Vehicle") && classes.contains(&"Module"),
        "{classes:?}"
    );
    let objects = j["objects"].as_array().unwrap();
    let o = objects.iter().find(|o| o["name"] == "gsr").unwrap();
    assert_eq!(o["owner"], "t/r1/nav");
    assert!(
        o["attrs"]
            .as_array()
            .unwrap()
            .iter()
            .any(|a| a["name"] == "position" && a["value"] == "[3.0, 4.0]")
    );
    assert_eq!(j["plans"][0]["name"], "p");
    assert_eq!(j["plans"][0]["state"], "active");
    let links = j["links"].as_array().unwrap();
    assert_eq!(links.len(), 2);
    assert!(links[0]["total_bytes"].as_u64().unwrap() > 0, "{links:?}");
    assert!(entry(&j["events"], "text", "peer t/r1/loco up").is_some());
    assert_eq!(http_get(&url, "/healthz").body, "ok");
    nav.close();
    assert!(nav.dashboard_url().is_none(), "stopped with the node");
}

#[test]
fn a_never_written_default_has_no_age_on_the_dashboard() {
    let net = SimNet::new(4);
    let nav = nav_serving(&net, "object gsr : Vehicle context self { speed = 2.0; }");
    net.run_for(Duration::from_secs(1));
    nav.board().write("gsr", "speed", 2.5).unwrap();
    net.run_for(Duration::from_secs(29));
    let url = nav.dashboard_url().expect("serves a dashboard");
    let j: serde_json::Value = http_get(&url, "/api/snapshot").json();
    // gsr's position is its declared default: no age, and so never stale.
    let gsr = entry(&j["map"]["items"], "id", "gsr").unwrap();
    assert!(gsr["age"].is_null() && gsr["stale"] == false, "{gsr}");
    let o = entry(&j["objects"], "name", "gsr").unwrap();
    let attr = |name: &str| entry(&o["attrs"], "name", name).unwrap().clone();
    assert!(attr("mode")["age"].is_null(), "{o}");
    // A value written since the start has an age.
    assert!(
        attr("speed")["age"].as_f64().is_some_and(|a| a > 0.0),
        "{o}"
    );
    nav.close();
}
