//! `--speakers robots`: the team protocol being built (docs/team-protocol.md), opt-in. Its
//! mission figures are not asserted until every step of its plan is in; what is asserted
//! is the part already built: one gateway per robot, the execution controller, and the
//! robot stream carrying the team traffic.

use std::time::Duration;

use slate_demo::{Demo, DemoConfig, Role, Speakers};
use slate_ici::{LinkKind, MsgKind};

use super::support::within;

fn robots_speak(seed: u64) -> Demo {
    let config = DemoConfig::default()
        .seed(seed)
        .fault_at(None)
        .speakers(Speakers::Robots);
    let mut demo = Demo::start(config).expect("starts");
    while demo.time() < 20.0 {
        demo.step();
    }
    demo
}

#[test]
fn each_robot_elects_its_execution_controller_as_gateway() {
    let demo = within(Duration::from_secs(60), || robots_speak(3));
    for (i, robot) in demo.team.robots.iter().enumerate() {
        let exec = demo.team.module(i, Role::Exec).address().clone();
        for m in demo.team.robot_modules(i) {
            assert_eq!(
                m.node.ici().gateway(),
                Some(exec.clone()),
                "{robot}: {}",
                m.address()
            );
        }
    }
}

#[test]
fn only_gateways_publish_the_team_streams_frames() {
    let demo = within(Duration::from_secs(60), || robots_speak(7));
    for m in &demo.team.modules {
        let frames = m
            .node
            .ici()
            .stats()
            .traffic
            .get(&(LinkKind::Team, MsgKind::TeamFrame))
            .map_or(0, |t| t.sent_msgs);
        let gateway = matches!(m.role, Role::Exec | Role::Console);
        assert_eq!(
            frames > 0,
            gateway,
            "{} sent {frames} team frames",
            m.address()
        );
    }
}
