//! Who speaks on the team link. By default the robots do (docs/team-protocol.md): one
//! gateway per robot, the execution controller, and the robot stream carrying the team
//! traffic (the mission tests run it to its end). `--speakers modules`, the per-module
//! protocol a `slate node` still speaks by default, runs the mission too.

use std::time::Duration;

use slate_demo::{Demo, DemoConfig, Role, Speakers};

use crate::mission::{assert_mission, mission_of};
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

#[test]
fn every_module_speaking_completes_the_mission_too() {
    let s = mission_of(DemoConfig::default().seed(7).speakers(Speakers::Modules));
    assert_mission(&s);
    assert_eq!(
        s.team_bytes_by_kind.get("team_frame"),
        None,
        "{}",
        s.to_text()
    );
    assert!(
        s.team_bytes_by_kind.get("heartbeat") > Some(&0),
        "{}",
        s.to_text()
    );
}
