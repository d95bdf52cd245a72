//! A node that keeps its board (`state`) restarts with it, and its peers keep its
//! objects: the catch-up after the restart is a difference, not a wipe. On the
//! simulator, with the node closed and started again on the same address.

use slate_ici::{ClassSet, IciConfig, SimNet};
use slate_model::{Update, Value};
use slate_node::state::{FILE, StateError};
use slate_node::{Node, StartError, StateConfig};
use slate_testing::temp_dir;

use crate::support::{on_net, run_until, start};

const NAV: &str = "t/r1/nav";
const CONSOLE: &str = "t/base/console";

/// The nav module, exporting everything, keeping its board in `state` if given.
fn nav(net: &SimNet, state: Option<&std::path::Path>) -> Result<Node, StartError> {
    let mut b = on_net(net, NAV, "").ici(IciConfig::default().export(ClassSet::all()));
    if let Some(dir) = state {
        b = b.state(StateConfig::new(dir));
    }
    b.start()
}

fn speed(node: &Node, object: &str) -> Option<f64> {
    node.board().read(object, "speed").ok()?.value.as_f64()
}

/// nav creates an object at run time (no file declares it) and writes it; the console
/// holds it; nav closes and starts again (with `state` or without). What does each
/// board hold of it once the restart has settled?
fn restart(state: Option<&std::path::Path>) -> (Option<f64>, Option<f64>, Node, Node) {
    let net = SimNet::new(18);
    let console = start(&net, CONSOLE, "");
    let first = nav(&net, state).unwrap();
    net.run_for(std::time::Duration::from_millis(500));
    first.board().create("Vehicle", "probe").unwrap();
    first.board().write("probe", "speed", 4.5).unwrap();
    assert!(run_until(&net, 5.0, || speed(&console, "probe") == Some(4.5)));
    first.close();
    drop(first);
    net.run_for(std::time::Duration::from_millis(300));
    let second = nav(&net, state).unwrap();
    net.run_for(std::time::Duration::from_secs(5));
    (
        speed(&second, "probe"),
        speed(&console, "probe"),
        second,
        console,
    )
}

#[test]
fn a_restarted_node_with_state_keeps_its_objects_and_its_peers_keep_them_too() {
    let dir = temp_dir("node-state-restart");
    let (on_nav, on_console, nav, console) = restart(Some(&dir));
    assert_eq!(on_nav, Some(4.5), "nav restored its board");
    assert_eq!(on_console, Some(4.5), "the console kept nav's object");
    let restored = nav.restored().expect("nav keeps state");
    assert_eq!((restored.objects, restored.packets), (1, 1), "{restored:?}");
    assert!(
        console.ici().stats().liveliness.restarts >= 1,
        "the console saw a restart"
    );
    nav.board()
        .write("probe", "speed", Update::new(6.0))
        .unwrap();
    nav.close();
    console.close();
}

#[test]
fn a_restarted_node_without_state_comes_back_empty_and_its_peers_drop_its_objects() {
    let (on_nav, on_console, nav, console) = restart(None);
    assert_eq!(on_nav, None, "nav starts from its files only");
    assert_eq!(
        on_console, None,
        "the catch-up swept nav's object from the console"
    );
    nav.close();
    console.close();
}

#[test]
fn a_node_whose_state_is_damaged_does_not_start_and_says_how_to_recover() {
    let dir = temp_dir("node-state-damaged");
    std::fs::write(
        dir.join(FILE),
        b"not a database, not at all; long enough to read",
    )
    .unwrap();
    let net = SimNet::new(19);
    let Err(e) = nav(&net, Some(&dir)) else {
        panic!("a node started on a damaged state");
    };
    assert!(
        matches!(e, StartError::State(StateError::Corrupt { .. })),
        "{e:?}"
    );
    let text = e.to_string();
    assert!(text.contains(&dir.display().to_string()), "{text}");
    assert!(text.contains("--reset-state"), "{text}");
    slate_node::state::reset(&dir).unwrap();
    let node = nav(&net, Some(&dir)).expect("after a reset the node starts empty");
    assert_eq!(node.restored().map(|r| r.objects), Some(0));
    node.close();
}

#[test]
fn a_state_directory_of_another_module_is_refused() {
    let dir = temp_dir("node-state-other");
    let net = SimNet::new(20);
    nav(&net, Some(&dir)).unwrap().close();
    let other = on_net(&net, "t/r2/loco", "")
        .state(StateConfig::new(dir.path()))
        .start();
    let Err(e) = other else {
        panic!("another module's state was taken");
    };
    assert!(e.to_string().contains(NAV), "{e}");
}

const PLANNER: &str = "t/r1/planner";
const LOCO: &str = "t/r1/loco";
/// A plan with no termination: it runs until cancelled.
const SLOW: &str = "plan slow { trigger: gsr.speed > 5.0; action { set gsr.mode = \"slow\"; } }";

/// The loco module (it runs plans from the planner), keeping its board in `dir`.
fn loco(net: &SimNet, dir: &std::path::Path) -> Node {
    on_net(net, LOCO, "object gsr : Vehicle context self;")
        .ici(IciConfig::default().export(ClassSet::all()))
        .plans_from(vec!["t/r1/planner".parse().unwrap()])
        .state(StateConfig::new(dir))
        .start()
        .unwrap()
}

/// loco accepts `plan` from the planner, is written `speed` (then `mode`, if given),
/// runs a while, and restarts on its state while the planner is gone (a planner still up
/// would send its plan again by itself).
fn restart_after_plan(dir: &std::path::Path, plan: &str, speed: f64) -> Node {
    restart_after_plan_with(dir, plan, &[("speed", speed.into())])
}

/// [`restart_after_plan`] with the writes to `gsr` made once the plan is accepted, in
/// order, each followed by a while for the plan and the store.
fn restart_after_plan_with(dir: &std::path::Path, plan: &str, writes: &[(&str, Value)]) -> Node {
    let net = SimNet::new(21);
    let planner = start(&net, PLANNER, "");
    let first = loco(&net, dir);
    net.run_for(std::time::Duration::from_millis(500));
    let handle = planner.send_plan(&slate_testing::addr(LOCO), plan).unwrap();
    let accepted = |h: &slate_ici::PlanHandle| {
        h.acks()
            .try_iter()
            .any(|s| s == slate_wire::PlanStep::Accepted)
    };
    assert!(run_until(&net, 3.0, || accepted(&handle)));
    for (attr, value) in writes {
        first.board().write("gsr", attr, value.clone()).unwrap();
        net.run_for(std::time::Duration::from_millis(500));
    }
    planner.close();
    first.close();
    drop(first);
    net.run_for(std::time::Duration::from_millis(300));
    let second = loco(&net, dir);
    net.run_for(std::time::Duration::from_secs(2));
    second
}

#[test]
fn a_plan_received_and_accepted_comes_back_after_a_restart_with_state() {
    let dir = temp_dir("node-state-plan");
    let loco = restart_after_plan(&dir, SLOW, 1.0);
    let status = loco.engine().status("slow").expect("the plan came back");
    assert_eq!(status.state.name(), "active", "{status:?}");
    assert_eq!(loco.restored().map(|r| r.plans), Some(1));
    let origin = loco.board().read("slow", "origin").unwrap().value;
    assert_eq!(
        origin,
        Value::Str(PLANNER.into()),
        "it runs for the planner"
    );
    // It still acts.
    loco.board().write("gsr", "speed", 6.0).unwrap();
    let mode = loco.board().read("gsr", "mode").unwrap().value;
    assert_eq!(mode, Value::Str("slow".into()));
    loco.close();
}

#[test]
fn a_received_plan_that_ended_before_the_restart_does_not_come_back() {
    let dir = temp_dir("node-state-plan-ended");
    let once = "plan once { trigger: gsr.speed > 5.0; termination: gsr.mode == \"slow\"; action { set gsr.mode = \"slow\"; } }";
    let loco = restart_after_plan(&dir, once, 6.0);
    assert!(
        loco.engine().status("once").is_none(),
        "an ended plan stays ended"
    );
    assert_eq!(loco.restored().map(|r| r.plans), Some(0));
    loco.close();
}

/// The plan fired for `gsr.speed > 5.0`; `mode` was then set back by hand while the
/// trigger still held. After the restart the trigger still holds, but it already fired
/// for that state: it must not set `mode` again.
#[test]
fn a_reinstated_plan_whose_trigger_held_does_not_fire_again_for_the_same_state() {
    let dir = temp_dir("node-state-plan-held");
    let writes = [("speed", 6.0.into()), ("mode", "manual".into())];
    let loco = restart_after_plan_with(&dir, SLOW, &writes);
    let status = loco.engine().status("slow").expect("the plan came back");
    assert_eq!(status.state.name(), "active", "{status:?}");
    assert_eq!(status.fired, 1, "it kept its count and did not fire again");
    let mode = loco.board().read("gsr", "mode").unwrap().value;
    assert_eq!(mode, Value::Str("manual".into()), "not set again");
    // The next rising edge fires it.
    loco.board().write("gsr", "speed", 1.0).unwrap();
    loco.board().write("gsr", "speed", 7.0).unwrap();
    let mode = loco.board().read("gsr", "mode").unwrap().value;
    assert_eq!(mode, Value::Str("slow".into()));
    assert_eq!(loco.engine().status("slow").map(|s| s.fired), Some(2));
    loco.close();
}

/// Initiation is latched: a plan initiated before the restart is still active after it,
/// although its initiation no longer holds.
#[test]
fn a_reinstated_plan_that_had_initiated_stays_initiated() {
    let dir = temp_dir("node-state-plan-latched");
    let plan = "plan go { initiation: gsr.mode == \"go\"; trigger: gsr.speed > 5.0; action { set gsr.mode = \"slow\"; } }";
    let writes = [("mode", "go".into()), ("mode", "auto".into())];
    let loco = restart_after_plan_with(&dir, plan, &writes);
    let status = loco.engine().status("go").expect("the plan came back");
    assert_eq!(status.state.name(), "active", "{status:?}");
    loco.board().write("gsr", "speed", 6.0).unwrap();
    let mode = loco.board().read("gsr", "mode").unwrap().value;
    assert_eq!(
        mode,
        Value::Str("slow".into()),
        "it acts without initiating again"
    );
    loco.close();
}
