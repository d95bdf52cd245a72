//! Link policies (`link team { ... }` in `.slate` files, `Ici::set_link_policy`): the team
//! link's own filters on top of the classes', `never`, export and liveliness.

use std::sync::Arc;
use std::time::Duration;

use slate_ici::{ClassSet, IciConfig, LinkKind, LinkPolicy, LinkReport, MsgKind, link_kind};
use slate_model::{Board, Clock, Context, ReportPolicy, Value};
use slate_plans::{Engine, LinkName};

use crate::support::{Team, classes, open};

/// `sensor` and `console` on robot r1, `base` on robot r2; `sensor` has `policy` on the
/// team link and owns the vehicle `gsr`.
fn team_with(policy: LinkPolicy) -> Team {
    let mut team = Team::new(11);
    team.add("t/r1/sensor", open());
    team.add("t/r1/console", IciConfig::default());
    team.add("t/r2/base", IciConfig::default());
    team.member("t/r1/sensor")
        .ici
        .set_link_policy(LinkKind::Team, policy);
    team.run(0.5);
    team.board("t/r1/sensor").create("Vehicle", "gsr").unwrap();
    team.run(0.2);
    team
}

fn speed(team: &Team, at: &str) -> Option<f64> {
    team.board(at).read("gsr", "speed").ok()?.value.as_f64()
}

fn every(s: u64) -> LinkReport {
    LinkReport::Policy(ReportPolicy {
        min_interval: Some(Duration::from_secs(s)),
        ..ReportPolicy::default()
    })
}

#[test]
fn a_team_filter_holds_a_value_the_robot_link_sends_and_its_trailing_edge_reaches_the_team() {
    let team = team_with(LinkPolicy::default().report("Vehicle", "speed", every(5)));
    team.write_series("t/r1/sensor", "gsr", "speed", 1..=10, 0.1);
    assert_eq!(speed(&team, "t/r1/console"), Some(10.0), "the robot link");
    assert_eq!(
        speed(&team, "t/r2/base"),
        Some(1.0),
        "the team filter holds"
    );
    team.run(4.2);
    assert_eq!(speed(&team, "t/r2/base"), Some(10.0), "the trailing edge");
    let stats = team.member("t/r1/sensor").ici.stats();
    assert_eq!(stats.get(LinkKind::Team, MsgKind::Report).sent_msgs, 2);
    assert_eq!(stats.get(LinkKind::Robot, MsgKind::Report).sent_msgs, 10);
}

#[test]
fn a_team_report_interval_sends_an_attribute_at_most_once_per_interval_and_its_last_value() {
    // 20 Hz for 2 s, with the team link's own 200 ms interval: at most one report per
    // interval leaves on the team link (a radio pays a frame for each), the robot link
    // takes every value, and the last value reaches the other robot.
    let mut team = Team::new(12);
    let every = Some(Duration::from_millis(200));
    team.add("t/r1/sensor", open().team_report_every(every));
    team.add("t/r1/console", IciConfig::default());
    team.add("t/r2/base", IciConfig::default());
    team.run(0.5);
    team.board("t/r1/sensor").create("Vehicle", "gsr").unwrap();
    team.run(0.5);
    let before = team.member("t/r1/sensor").ici.stats();
    let sent = |s: &slate_ici::IciStats, link| s.get(link, MsgKind::Report).sent_msgs;
    team.write_series("t/r1/sensor", "gsr", "speed", 1..=40, 0.05);
    team.run(0.5);
    let after = team.member("t/r1/sensor").ici.stats();
    let on_team = sent(&after, LinkKind::Team) - sent(&before, LinkKind::Team);
    let on_robot = sent(&after, LinkKind::Robot) - sent(&before, LinkKind::Robot);
    assert!(on_team <= 12, "{on_team} team reports for 40 values in 2 s");
    assert_eq!(on_robot, 40);
    assert_eq!(speed(&team, "t/r2/base"), Some(40.0), "the trailing edge");
    assert_eq!(speed(&team, "t/r1/console"), Some(40.0));
}

#[test]
fn never_keeps_an_attribute_off_the_team_link() {
    let policy = LinkPolicy::default().report("Vehicle", "mode", LinkReport::Never);
    let team = team_with(policy);
    let sensor = team.board("t/r1/sensor");
    sensor.write("gsr", "mode", "auto").unwrap();
    sensor.write("gsr", "speed", 2.0).unwrap();
    team.run(3.0);
    let mode = |at: &str| {
        let written = team.board(at).read("gsr", "mode").ok();
        written.map(|p| p.value).filter(|v| *v != Value::None)
    };
    assert_eq!(mode("t/r1/console"), Some("auto".into()));
    assert_eq!(mode("t/r2/base"), None, "mode crossed the team link");
    assert_eq!(speed(&team, "t/r2/base"), Some(2.0), "other attributes do");
}

/// The policy `text` compiles to on an engine whose board has the test classes.
fn policy_of(text: &str) -> (LinkKind, LinkPolicy) {
    let board = Arc::new(Board::builder().clock(Clock::manual()).build());
    for def in classes() {
        board.define(def).unwrap();
    }
    let engine = Engine::new(&board);
    engine.load("link.slate", text).unwrap();
    let policies = engine.link_policies();
    let (name, policy) = policies.iter().next().expect("a link policy");
    (link_kind(*name), LinkPolicy::from(policy))
}

#[test]
fn export_from_a_link_block_equals_the_same_ici_config_export() {
    let (link, policy) = policy_of("link team { export Vehicle (self), Target; }");
    assert_eq!(link, LinkKind::Team);
    let mut from_file = IciConfig::default();
    policy.apply_to(link, &mut from_file);
    let in_rust = IciConfig::default().export(
        ClassSet::none()
            .class_in("Vehicle", &[Context::Self_])
            .class("Target"),
    );
    assert_eq!(from_file, in_rust);
}

#[test]
fn a_link_blocks_liveliness_becomes_the_links_timing() {
    let (link, policy) = policy_of("link robot { heartbeat 500ms timeout 3s; }");
    assert_eq!(link, link_kind(LinkName::Robot));
    let mut config = IciConfig::default();
    policy.apply_to(link, &mut config);
    let expected = IciConfig::default().liveliness(
        LinkKind::Robot,
        Duration::from_millis(500),
        Duration::from_secs(3),
    );
    assert_eq!(config, expected);
}

#[test]
fn a_link_policys_export_adds_to_the_export_the_ici_started_with() {
    let mut team = Team::new(3);
    let started = IciConfig::default().export(ClassSet::none().class("Tracked"));
    team.add("t/r1/sensor", started);
    team.add("t/r2/base", IciConfig::default());
    let ici = &team.member("t/r1/sensor").ici;
    ici.set_link_policy(
        LinkKind::Team,
        LinkPolicy::default().export(ClassSet::none().class("Vehicle")),
    );
    ici.set_link_policy(
        LinkKind::Team,
        LinkPolicy::default().export(ClassSet::none().class("Target")),
    );
    team.run(0.5);
    let sensor = team.board("t/r1/sensor");
    for (class, name) in [("Tracked", "t1"), ("Vehicle", "v1"), ("Target", "g1")] {
        sensor.create(class, name).unwrap();
    }
    team.run(1.0);
    let base = team.board("t/r2/base");
    assert!(base.info("t1").is_some(), "the started export stays");
    assert!(base.info("v1").is_none(), "the earlier policy was replaced");
    assert!(base.info("g1").is_some());
    let stored = ici.link_policy(LinkKind::Team).expect("stored");
    assert_eq!(stored.export, ClassSet::none().class("Target"));
}

/// A module's team export widened after it wrote: what it holds of the newly exported
/// classes reaches the other robots then, not only its later writes (the demo's exec
/// writes its `Robot` once, at the start, before its `.slate` file's export is set).
fn export_widened_later(protocol: Option<slate_ici::TeamProtocol>) {
    let mut team = Team::new(5);
    let config = |p: Option<u8>| {
        IciConfig::default()
            .export(ClassSet::none())
            .team_protocol(protocol.clone().map(|t| t.priority(p)))
    };
    team.add("t/r1/sensor", config(Some(0)));
    team.add("t/r2/base", config(Some(0)));
    team.run(0.5);
    let sensor = team.board("t/r1/sensor");
    sensor.create("Vehicle", "gsr").unwrap();
    sensor.write("gsr", "speed", Value::Real(2.5)).unwrap();
    team.run(1.0);
    assert!(
        team.board("t/r2/base").info("gsr").is_none(),
        "not exported yet"
    );
    team.member("t/r1/sensor").ici.set_link_policy(
        LinkKind::Team,
        LinkPolicy::default().export(ClassSet::none().class("Vehicle")),
    );
    team.run(3.0);
    assert_eq!(
        speed(&team, "t/r2/base"),
        Some(2.5),
        "the value written before"
    );
}

#[test]
fn what_a_widened_export_newly_covers_reaches_the_team_at_once() {
    export_widened_later(Some(slate_ici::TeamProtocol::radio()));
}

#[test]
fn what_a_widened_export_newly_covers_reaches_the_team_without_the_team_protocol() {
    export_widened_later(None);
}
