//! Two robots' LANs joined through Zenoh routers, configured the way Zenoh users do
//! (`zenoh_config`): each robot's modules are clients of their LAN's router, a plain
//! Zenoh session in router mode, and the two routers are connected to each other. A
//! value written on robot A's LAN reaches robot B's boards through Zenoh's own routing.

use std::path::Path;
use std::time::Duration;

use slate_node::{Node, NodeConfig};
use slate_testing::{eventually, free_port, temp_dir};
use zenoh::Wait;

/// A Zenoh router listening on `listen` and connected to `connect`; no slate module.
fn router(listen: &str, connect: &[String]) -> zenoh::Session {
    let mut c = zenoh::Config::default();
    let listen = format!("[{listen:?}]");
    let connect = format!(
        "[{}]",
        connect
            .iter()
            .map(|e| format!("{e:?}"))
            .collect::<Vec<_>>()
            .join(",")
    );
    for (key, value) in [
        ("mode", "\"router\""),
        ("listen/endpoints", listen.as_str()),
        ("connect/endpoints", connect.as_str()),
        ("scouting/multicast/enabled", "false"),
    ] {
        c.insert_json5(key, value).unwrap();
    }
    zenoh::open(c).wait().expect("the router opens")
}

/// A module's Zenoh file, as a Zenoh user writes it: a client of its LAN's router.
fn client_file(dir: &Path, name: &str, router: &str) -> String {
    let text = format!("{{ mode: \"client\", connect: {{ endpoints: [{router:?}] }} }}");
    std::fs::write(dir.join(format!("{name}.json5")), text).unwrap();
    format!("{name}.json5")
}

/// Starts a module from a config written in `dir` that takes Zenoh from `zenoh_file`.
fn module(dir: &Path, address: &str, zenoh_file: &str) -> Node {
    let stem = address.replace('/', "_");
    let toml = format!(
        "address = \"{address}\"\nfiles = [\"world.slate\"]\nexport = [\"Vehicle\"]\nzenoh_config = \"{zenoh_file}\"\n"
    );
    std::fs::write(dir.join(format!("{stem}.toml")), toml).unwrap();
    let config = NodeConfig::read(&dir.join(format!("{stem}.toml"))).unwrap();
    Node::start(&config).unwrap_or_else(|e| panic!("{address}: {e}"))
}

#[test]
fn a_value_written_on_one_robots_lan_reaches_another_lan_through_a_zenoh_router() {
    let d = temp_dir("node-router");
    std::fs::write(d.join("world.slate"), crate::support::WORLD).unwrap();
    let endpoint = || format!("tcp/127.0.0.1:{}", free_port());
    let (lan_a, lan_b) = (endpoint(), endpoint());
    let _router_a = router(&lan_a, &[]);
    let _router_b = router(&lan_b, std::slice::from_ref(&lan_a));
    let nav = module(&d, "t/r1/nav", &client_file(&d, "nav", &lan_a));
    let loco = module(&d, "t/r1/loco", &client_file(&d, "loco", &lan_a));
    let base = module(&d, "t/r2/exec", &client_file(&d, "exec", &lan_b));
    let vision = module(&d, "t/r2/vision", &client_file(&d, "vision", &lan_b));
    let met = eventually(Duration::from_secs(20), || base.peers().len() == 3);
    assert!(met, "r2/exec met {:?}", base.peers());
    nav.board().create("Vehicle", "gsr").unwrap();
    nav.board().write("gsr", "speed", 2.5).unwrap();
    let speed = |n: &Node| {
        n.board()
            .read("gsr", "speed")
            .ok()
            .and_then(|p| p.value.as_f64())
    };
    let arrived = eventually(Duration::from_secs(20), || {
        [&base, &vision, &loco]
            .iter()
            .all(|n| speed(n) == Some(2.5))
    });
    let seen = [speed(&base), speed(&vision), speed(&loco)];
    assert!(arrived, "r2/exec, r2/vision, r1/loco: {seen:?}");
    for n in [nav, loco, base, vision] {
        n.close();
    }
}
