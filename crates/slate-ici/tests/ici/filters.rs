//! Report policies: fewer messages, never a lost final value.

use std::time::Duration;

use slate_ici::{LinkKind, MsgKind};
use slate_model::{AttrDecl, ClassDef, ReportPolicy, ValueType};

use crate::support::{Team, classes, open};

fn with_policy(policy: ReportPolicy) -> Team {
    let mut defs = classes();
    defs.push(ClassDef::new("Gauge").attr(AttrDecl::new("level", ValueType::Real).report(policy)));
    let mut team = Team::new(5);
    team.add_with("t/r1/sensor", open(), &defs);
    team.add_with("t/r1/console", open(), &defs);
    team.run(0.5);
    team.board("t/r1/sensor").create("Gauge", "tank").unwrap();
    team.run(0.1);
    team
}

fn level(team: &Team, at: &str) -> Option<f64> {
    team.board(at).read("tank", "level").ok()?.value.as_f64()
}

/// MOOS drops the last value written inside a minimum interval; slate must not.
#[test]
fn the_final_value_inside_a_min_interval_is_delivered_at_the_trailing_edge() {
    let policy = ReportPolicy {
        min_interval: Some(Duration::from_secs(1)),
        ..Default::default()
    };
    let team = with_policy(policy);
    team.write_series("t/r1/sensor", "tank", "level", 1..=10, 0.05);
    // 0.5 s after the first write: only it went out.
    assert_eq!(level(&team, "t/r1/console"), Some(1.0));
    team.run(0.6);
    assert_eq!(
        level(&team, "t/r1/console"),
        Some(10.0),
        "the final value was lost"
    );
    let stats = team.member("t/r1/sensor").ici.stats();
    assert_eq!(stats.reports.trailing, 1);
    assert_eq!(
        stats.get(LinkKind::Robot, MsgKind::Report).sent_msgs,
        2,
        "ten writes, two reports"
    );
}

#[test]
fn a_value_held_by_the_deadband_is_delivered_once_it_settles() {
    let team = with_policy(ReportPolicy {
        deadband: Some(1.0),
        ..Default::default()
    });
    let sensor = team.board("t/r1/sensor");
    sensor.write("tank", "level", 5.0).unwrap();
    team.run(0.1);
    for v in [5.2, 5.4, 5.6] {
        sensor.write("tank", "level", v).unwrap();
        team.run(0.1);
    }
    assert_eq!(
        level(&team, "t/r1/console"),
        Some(5.0),
        "small changes are held"
    );
    team.run(1.5);
    assert_eq!(
        level(&team, "t/r1/console"),
        Some(5.6),
        "the settled value arrives"
    );
    sensor.write("tank", "level", 9.0).unwrap();
    team.run(0.1);
    assert_eq!(
        level(&team, "t/r1/console"),
        Some(9.0),
        "a big change goes at once"
    );
}

#[test]
fn changes_within_the_accuracy_wait_and_larger_ones_go() {
    let team = with_policy(ReportPolicy {
        on_accuracy: true,
        ..Default::default()
    });
    let sensor = team.board("t/r1/sensor");
    let write = |v: f64| {
        sensor
            .write("tank", "level", slate_model::Update::new(v).accuracy(0.0))
            .unwrap()
    };
    write(1.0);
    team.run(0.1);
    sensor
        .write("tank", "level", slate_model::Update::new(1.3).accuracy(0.5))
        .unwrap();
    team.run(0.1);
    assert_eq!(level(&team, "t/r1/console"), Some(1.0));
    write(2.0);
    team.run(0.1);
    assert_eq!(level(&team, "t/r1/console"), Some(2.0));
}

#[test]
fn an_attribute_heartbeat_repeats_the_value_when_nothing_changes() {
    let policy = ReportPolicy {
        heartbeat: Some(Duration::from_secs(1)),
        ..Default::default()
    };
    let team = with_policy(policy);
    team.board("t/r1/sensor")
        .write("tank", "level", 3.0)
        .unwrap();
    team.run(5.05);
    let stats = team.member("t/r1/sensor").ici.stats();
    assert_eq!(stats.reports.heartbeats, 5);
    assert_eq!(level(&team, "t/r1/console"), Some(3.0));
}

#[test]
fn a_lost_final_report_is_recovered_through_the_module_heartbeat() {
    let team = with_policy(ReportPolicy::default());
    let sensor = team.board("t/r1/sensor");
    sensor.write("tank", "level", 1.0).unwrap();
    team.run(0.2);
    // The last report is lost: the link drops everything for a moment.
    team.net
        .set_link(LinkKind::Robot, slate_ici::LinkConfig::clean().loss(1.0));
    sensor.write("tank", "level", 2.0).unwrap();
    team.run(0.01);
    team.net
        .set_link(LinkKind::Robot, slate_ici::LinkConfig::clean());
    assert_eq!(level(&team, "t/r1/console"), Some(1.0));
    team.run(2.0);
    assert_eq!(level(&team, "t/r1/console"), Some(2.0));
    assert!(team.member("t/r1/console").ici.stats().catch_up.completed >= 1);
}
