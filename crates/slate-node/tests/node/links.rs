//! A node hands the `link` blocks of the files it loads to its ICI: at start, and when a
//! file is loaded later.

use slate_ici::{ClassSet, IciConfig, LinkKind, SimNet};
use slate_node::Node;

use crate::support::{on_net, run_until};

/// A node on `net` that exports nothing in Rust and loads
/// [`WORLD`](crate::support::WORLD) then `extra`.
fn start_closed(net: &SimNet, address: &str, extra: &str) -> Node {
    on_net(net, address, extra)
        .ici(IciConfig::default())
        .start()
        .expect("node starts")
}

const OBJECTS: &str = "object gsr : Vehicle context self;\nobject rock : Obstacle;\n";

#[test]
fn a_node_that_loads_a_link_team_block_exports_its_classes() {
    let net = SimNet::new(21);
    let nav = start_closed(
        &net,
        "t/r1/nav",
        &format!("{OBJECTS}link team {{ export Vehicle; }}"),
    );
    let base = start_closed(&net, "t/r2/base", "");
    assert!(run_until(&net, 3.0, || base.board().info("gsr").is_some()));
    assert!(
        base.board().info("rock").is_none(),
        "Obstacle is not exported"
    );
    let exported = &nav.ici().link_policy(LinkKind::Team).expect("set").export;
    assert_eq!(*exported, ClassSet::none().class("Vehicle"));
}

#[test]
fn a_link_block_loaded_later_changes_what_leaves_the_robot() {
    let net = SimNet::new(22);
    let nav = start_closed(&net, "t/r1/nav", OBJECTS);
    let base = start_closed(&net, "t/r2/base", "");
    net.run_for(std::time::Duration::from_secs(2));
    assert!(base.board().info("gsr").is_none(), "nothing exported yet");
    let loaded = nav
        .load("link.slate", "link team { export Vehicle; }")
        .unwrap();
    assert_eq!(loaded.links, [slate_plans::LinkName::Team]);
    nav.board().write("gsr", "speed", 2.0).unwrap();
    assert!(run_until(&net, 3.0, || base.board().info("gsr").is_some()));
}
