//! Interest (what a board models) and export policy (what leaves a robot).

use slate_ici::{ClassSet, IciConfig, LinkKind, MsgKind};
use slate_model::{Context, NewObject};

use crate::support::{Team, open};

fn vehicles_only() -> IciConfig {
    open().interest(ClassSet::none().class("Vehicle"))
}

#[test]
fn nothing_is_sent_that_no_board_models() {
    let team = Team::of(
        6,
        [
            ("t/r1/sensor", open().interest(ClassSet::none())),
            ("t/r1/console", vehicles_only()),
            ("t/r2/base", vehicles_only()),
        ],
    );
    team.run(0.5);
    let sensor = team.board("t/r1/sensor");
    sensor.create("Raw", "imu").unwrap();
    team.write_series("t/r1/sensor", "imu", "sample", 0..20, 0.05);
    let stats = team.member("t/r1/sensor").ici.stats();
    for link in LinkKind::ALL {
        assert_eq!(stats.get(link, MsgKind::Report).sent_msgs, 0, "{link}");
        assert_eq!(stats.get(link, MsgKind::Lifecycle).sent_msgs, 0, "{link}");
    }
    assert!(
        stats.reports.suppressed_interest >= 2 * 21,
        "{:?}",
        stats.reports
    );
    assert!(team.board("t/r1/console").info("imu").is_none());
}

#[test]
fn a_board_gets_the_classes_it_models_and_not_the_others() {
    let team = Team::of(7, [("t/r1/nav", open()), ("t/r1/console", vehicles_only())]);
    team.run(0.5);
    let nav = team.board("t/r1/nav");
    nav.create("Vehicle", "gsr").unwrap();
    nav.create("Rock", "boulder").unwrap();
    nav.write("gsr", "speed", 1.0).unwrap();
    nav.write("boulder", "x", 2.0).unwrap();
    team.run(0.5);
    let console = team.board("t/r1/console");
    assert_eq!(
        console.read("gsr", "speed").unwrap().value.as_f64(),
        Some(1.0)
    );
    assert!(console.info("boulder").is_none());
    assert!(
        team.member("t/r1/nav")
            .ici
            .stats()
            .reports
            .suppressed_interest
            >= 2
    );
}

#[test]
fn interest_by_context_uses_the_context_on_the_receiving_board() {
    let mut team = Team::of(8, [("t/r1/nav", open())]);
    team.add(
        "t/r2/nav",
        open().interest(ClassSet::none().class_in("Vehicle", &[Context::System])),
    );
    team.run(0.5);
    let nav = team.board("t/r1/nav");
    nav.create_with(NewObject::new("Vehicle", "me").context(Context::Self_))
        .unwrap();
    nav.create("Vehicle", "stranger").unwrap();
    team.run(0.5);
    let other = team.board("t/r2/nav");
    assert_eq!(other.info("me").unwrap().context, Context::System);
    assert!(other.info("stranger").is_none());
}

#[test]
fn the_export_policy_keeps_raw_data_on_the_robot() {
    let mut team = Team::new(9);
    team.add(
        "t/r1/sensor",
        IciConfig::default().export(ClassSet::none().class("Vehicle")),
    );
    team.add("t/r1/console", IciConfig::default());
    team.add("t/r2/base", IciConfig::default());
    team.run(0.5);
    let sensor = team.board("t/r1/sensor");
    sensor.create("Raw", "imu").unwrap();
    sensor.create("Vehicle", "gsr").unwrap();
    for i in 0..10 {
        sensor.write("imu", "sample", f64::from(i)).unwrap();
        sensor.write("gsr", "speed", f64::from(i)).unwrap();
        team.run(0.1);
    }
    let console = team.board("t/r1/console");
    let base = team.board("t/r2/base");
    assert_eq!(
        console.read("imu", "sample").unwrap().value.as_f64(),
        Some(9.0)
    );
    assert_eq!(base.read("gsr", "speed").unwrap().value.as_f64(), Some(9.0));
    assert!(base.info("imu").is_none(), "raw data crossed the team link");
    let stats = team.member("t/r1/sensor").ici.stats();
    assert!(stats.reports.suppressed_export >= 10);
    let robot = stats.get(LinkKind::Robot, MsgKind::Report).sent_bytes;
    let team_link = stats.get(LinkKind::Team, MsgKind::Report).sent_bytes;
    assert!(team_link < robot, "team {team_link} B, robot {robot} B");
}

#[test]
fn a_board_that_starts_modelling_a_class_catches_up_with_it() {
    let team = Team::of(
        10,
        [
            ("t/r1/nav", open()),
            ("t/r1/console", open().interest(ClassSet::none())),
        ],
    );
    team.run(0.5);
    let nav = team.board("t/r1/nav");
    nav.create("Rock", "boulder").unwrap();
    nav.write("boulder", "x", 4.0).unwrap();
    team.run(0.5);
    let console = team.member("t/r1/console");
    assert!(console.board.info("boulder").is_none());
    console.ici.set_interest(ClassSet::none().class("Tracked"));
    team.run(0.5);
    assert_eq!(
        console.board.read("boulder", "x").unwrap().value.as_f64(),
        Some(4.0)
    );
}

#[test]
fn a_report_in_flight_when_the_interest_changes_is_not_merged() {
    let team = Team::of(8, [("t/r1/nav", open()), ("t/r1/console", open())]);
    team.run(0.5);
    let (nav, console) = (team.board("t/r1/nav"), team.board("t/r1/console"));
    nav.create("Vehicle", "gsr").unwrap();
    for speed in [1.0, 2.0] {
        nav.write("gsr", "speed", speed).unwrap();
        team.run(0.5);
    }
    assert_eq!(
        console.read("gsr", "speed").unwrap().value.as_f64(),
        Some(2.0)
    );
    let uninterested = || team.member("t/r1/console").ici.stats().rejects.uninterested;
    let before = uninterested();
    // The console stops modelling vehicles while a report of one is on its way.
    team.member("t/r1/console")
        .ici
        .set_interest(ClassSet::none().class("Rock"));
    nav.write("gsr", "speed", 3.0).unwrap();
    team.run(0.5);
    assert_eq!(
        console.read("gsr", "speed").unwrap().value.as_f64(),
        Some(2.0)
    );
    assert!(uninterested() > before);
}
