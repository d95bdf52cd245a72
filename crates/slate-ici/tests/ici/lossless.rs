//! Lossless classes (`IciConfig::lossless`): their reports are published with
//! `Flow::Every`, every update of them passes the links' filters, and everything else
//! stays best effort.

use std::sync::Arc;
use std::time::Duration;

use parking_lot::Mutex;
use slate_ici::{ClassSet, Flow, Ici, LinkKind, LinkPolicy, LinkReport, MsgKind};
use slate_model::{Address, AttrDecl, ClassDef, ReportPolicy, ValueType};
use slate_transport::tap::Tapped;

use crate::support::{Team, open};

#[test]
fn a_lossless_class_is_published_with_flow_every_and_passes_the_links_filter() {
    let real = |n| AttrDecl::new(n, ValueType::Real);
    let defs = [
        ClassDef::new("Event").attr(real("seq")),
        ClassDef::new("Gauge").attr(real("level")),
    ];
    let mut team = Team::new(3);
    let board = team.board_at(&Address::new("t/r1/writer").unwrap(), &defs);
    // The flow of each report published.
    let flows = Arc::new(Mutex::new(Vec::new()));
    let noted = flows.clone();
    let tapped = Tapped::new(team.net.join(board.address()), move |_, kind, flow| {
        if kind == MsgKind::Report {
            noted.lock().push(flow);
        }
        true
    });
    let config = open().lossless(ClassSet::none().class("Event"));
    let ici = Ici::new(board.clone(), Arc::new(tapped), config).unwrap();
    // The robot link holds both attributes to one report a second.
    let every_second = LinkReport::Policy(ReportPolicy {
        min_interval: Some(Duration::from_secs(1)),
        ..Default::default()
    });
    let policy = LinkPolicy::default()
        .report("Event", "seq", every_second.clone())
        .report("Gauge", "level", every_second);
    ici.set_link_policy(LinkKind::Robot, policy);
    team.add_with("t/r1/console", open(), &defs);
    team.run(0.5);
    board.create("Event", "ev").unwrap();
    board.create("Gauge", "tank").unwrap();
    // The first reports announce the names (and go with `Flow::Every` for it, whatever
    // their class); then the robot link's second passes.
    board.write("ev", "seq", 0.0).unwrap();
    board.write("tank", "level", 0.0).unwrap();
    team.run(1.1);
    assert_eq!(
        *flows.lock(),
        [Flow::Every, Flow::Every],
        "the reports that announce names"
    );
    flows.lock().clear();
    for i in 1..=10 {
        board.write("ev", "seq", f64::from(i)).unwrap();
        board.write("tank", "level", f64::from(i)).unwrap();
        team.run(0.02);
    }
    let reports = flows.lock().clone();
    let every = reports.iter().filter(|f| **f == Flow::Every).count();
    let latest = reports.iter().filter(|f| **f == Flow::Latest).count();
    assert_eq!(every, 10, "every event, each its own report: {reports:?}");
    assert_eq!(
        latest, 1,
        "the gauge's first value; the link holds the rest: {reports:?}"
    );
    team.run(1.5);
    let console = team.board("t/r1/console");
    assert_eq!(
        console.read("ev", "seq").unwrap().value.as_f64(),
        Some(10.0)
    );
    assert_eq!(
        console.read("tank", "level").unwrap().value.as_f64(),
        Some(10.0)
    );
    drop(ici);
}
