//! The roles' team exports as `link team` blocks in their `.slate` files, the deck phase
//! (mission plans sent before launch on a fast clean radio), and the acoustic link's
//! report filters (`link-acoustic.slate`).

use std::time::Duration;

use slate_demo::{Demo, DemoConfig, Role, TeamLink, TeamMedium};
use slate_ici::{ClassSet, LinkKind};
use slate_model::Context;

use super::support::within;

/// What each role let out of its robot when the export policy was Rust (`Role::export`).
fn export_once_in_rust(role: Role) -> ClassSet {
    match role {
        Role::Exec => ClassSet::none()
            .class_in("Robot", &[Context::Self_])
            .class("Target")
            .class("Waypoint"),
        Role::Vision => ClassSet::none().class("Target"),
        Role::Console => ClassSet::none().class("Mission").class("Waypoint"),
        Role::Nav | Role::Prox | Role::Loco => ClassSet::none(),
    }
}

#[test]
fn each_roles_team_export_from_its_files_equals_the_old_rust_one() {
    let demo = within(Duration::from_secs(20), || {
        Demo::start(DemoConfig::default().seed(3)).unwrap()
    });
    for m in &demo.team.modules {
        let export = m.node.ici().link_policy(LinkKind::Team).map(|p| p.export);
        assert_eq!(
            export.unwrap_or_default(),
            export_once_in_rust(m.role),
            "{}",
            m.address()
        );
    }
}

/// A guard against hangs (a debug build runs one mission in about 10 s).
const LIMIT: Duration = Duration::from_secs(300);

/// The default mission for `seed` with a deck phase of 10 s.
fn on_deck(seed: u64) -> DemoConfig {
    DemoConfig::default()
        .seed(seed)
        .deck(Some(Duration::from_secs(10)))
}

/// The console's sent plans that their destination accepted.
fn accepted_by_the_execs(demo: &Demo) -> usize {
    let sent = demo.team.console().node.circuits().sent();
    sent.iter()
        .filter(|c| c.steps.contains(&slate_wire::PlanStep::Accepted))
        .count()
}

#[test]
fn on_deck_the_mission_plans_are_accepted_before_launch_and_wait_for_run() {
    let demo = within(LIMIT, || {
        let mut demo = Demo::start(on_deck(7)).unwrap();
        while demo.time() < 9.5 {
            demo.step();
        }
        demo
    });
    assert_eq!(demo.mission_phase(), "ready");
    assert_eq!(accepted_by_the_execs(&demo), 3 * demo.team.robots.len());
    for i in 0..demo.team.robots.len() {
        let exec = demo.team.module(i, Role::Exec).node.board();
        let phase = exec.read(&demo.team.robots[i], "phase").unwrap().value;
        assert_eq!(phase, "ready".into(), "robot {i} left the deck");
    }
}

#[test]
fn a_deck_run_completes_at_three_robots_on_the_radio_with_its_bytes_set_apart() {
    let s = within(LIMIT, || slate_demo::run(on_deck(7), &mut |_| {}).unwrap());
    let text = s.to_text();
    assert!(s.mission_complete, "{text}");
    assert_eq!(s.duplicate_investigations, 0, "{text}");
    assert_eq!(s.deck_seconds, Some(10.0));
    assert!(
        s.deck_bytes > 0 && s.deck_bytes < s.team_link_bytes,
        "{text}"
    );
    let fault_at = s.fault.as_ref().map_or(0.0, |f| f.1);
    assert!(
        (fault_at - 40.0).abs() < 0.05,
        "the fault is 30 s after launch: {fault_at}"
    );
    assert!(s.detection_seconds.is_some(), "{text}");
    let json = s.to_json();
    assert_eq!(json["deck_bytes"], s.deck_bytes);
}

#[test]
fn a_deck_shorter_than_the_minimum_is_refused() {
    let short = DemoConfig::default().deck(Some(Duration::from_secs(2)));
    assert!(short.validate().is_err());
    assert!(on_deck(7).validate().is_ok());
}

#[test]
fn every_module_on_the_acoustic_channel_loads_its_filters_and_keeps_its_export() {
    let config = DemoConfig::default()
        .seed(3)
        .team_link(TeamLink::of(TeamMedium::Acoustic, Some(400)));
    let demo = within(LIMIT, || Demo::start(config).unwrap());
    for m in &demo.team.modules {
        let policy = m.node.ici().link_policy(LinkKind::Team).unwrap();
        assert_eq!(
            policy.heartbeat,
            Some(Duration::from_secs(20)),
            "{}",
            m.address()
        );
        assert_eq!(
            policy.timeout,
            Some(Duration::from_secs(90)),
            "{}",
            m.address()
        );
        let heading = ("Robot".to_owned(), "heading".to_owned());
        assert!(policy.reports.contains_key(&heading), "{}", m.address());
        assert_eq!(
            policy.export,
            export_once_in_rust(m.role),
            "{}",
            m.address()
        );
    }
}

/// The team heartbeat the modules that export nothing had in Rust (`Role::ici_config`):
/// 2 s, timeout 5 s; the others kept the default.
fn heartbeat_once_in_rust(role: Role) -> Option<(Duration, Duration)> {
    let quiet = (Duration::from_secs(2), Duration::from_secs(5));
    matches!(role, Role::Nav | Role::Prox | Role::Loco).then_some(quiet)
}

#[test]
fn on_the_radio_no_module_has_team_filters_and_the_quiet_ones_heartbeat_slower() {
    let demo = within(LIMIT, || {
        Demo::start(DemoConfig::default().seed(3)).unwrap()
    });
    for m in &demo.team.modules {
        let policy = m.node.ici().link_policy(LinkKind::Team).unwrap_or_default();
        assert!(policy.reports.is_empty(), "{}", m.address());
        let heartbeat = policy.heartbeat.zip(policy.timeout);
        assert_eq!(heartbeat, heartbeat_once_in_rust(m.role), "{}", m.address());
    }
}

#[test]
fn the_plans_sent_on_deck_before_an_acoustic_mission_travel_in_its_frames() {
    let config = DemoConfig::default()
        .seed(3)
        .robots(1)
        .duration(Duration::from_secs(10))
        .fault_at(None)
        .deck(Some(Duration::from_secs(5)))
        .team_link(TeamLink::of(TeamMedium::Acoustic, Some(400)));
    let s = within(LIMIT, || slate_demo::run(config, &mut |_| {}).unwrap());
    let channel = s.team_channel.clone().expect("the simulator's channel");
    assert!(channel.largest_frame_bytes <= 32, "{}", s.to_text());
    assert!(
        channel.largest_message_bytes > 32,
        "the plans: {}",
        s.to_text()
    );
    assert!(
        s.deck_bytes_by_kind.get("plan").is_some_and(|b| *b > 0),
        "{:?}",
        s.deck_bytes_by_kind
    );
    assert!(s.plans_accepted >= 3, "{}", s.to_text());
    assert_eq!(s.plans_accepted, s.plans_sent, "{}", s.to_text());
}
