//! The mission end to end on the simulator, with fixed seeds: it completes, nobody
//! investigates a target twice, the team recovers from the fault, the team link stays
//! within its budget, the boards stay consistent, and sensor data never leaves a robot.

use std::time::Duration;

use slate_demo::{Demo, Role, Summary, run};
use slate_model::Context;

use crate::support::{config, within};

/// A guard against hangs (a debug build runs one mission in about 10 s).
const LIMIT: Duration = Duration::from_secs(300);

fn mission(seed: u64) -> Summary {
    mission_of(config(seed))
}

/// The mission of `config`, run to its end on the simulator (bounded).
pub fn mission_of(config: slate_demo::DemoConfig) -> Summary {
    within(LIMIT, move || {
        run(config, &mut |_| {}).expect("the demo runs")
    })
}

/// What every seed must show.
pub fn assert_mission(s: &Summary) {
    let text = s.to_text();
    assert!(s.mission_complete, "the mission did not complete:\n{text}");
    assert_eq!(s.targets_found, s.targets_total, "{text}");
    assert_eq!(s.duplicate_investigations, 0, "{text}");
    assert_eq!(s.robot_failures, 1, "{text}");
    let recovery = s
        .recovery_seconds
        .expect("the team recovered from the fault");
    assert!(recovery < 15.0, "recovery took {recovery} s:\n{text}");
    assert!(s.detection_seconds.is_some_and(|d| d <= recovery), "{text}");
    let budget = s.team_link_budget_bps as f64;
    assert!(s.team_link_peak_bps <= budget + 1e-6, "{text}");
    assert!(
        s.team_link_mean_bps < budget,
        "all radios together, on average: {text}"
    );
    assert!(s.team_link_max_backlog_seconds < 10.0, "{text}");
    let lag = s
        .consistency_lag_seconds
        .expect("the boards agreed at the end");
    assert!(lag < 5.0, "{text}");
    assert!(
        s.propagation_p95_seconds.is_some_and(|p| p < 10.0),
        "{text}"
    );
    assert_eq!(s.plans_rejected, 0, "{text}");
    assert_eq!(s.plans_accepted, s.plans_sent, "{text}");
    assert!(
        s.team_link_bytes > 0 && s.intra_robot_bytes > s.team_link_bytes,
        "{text}"
    );
}

/// The team link's cost at 3 robots with robots speaking (the default): its protocol
/// overhead (team bytes that are neither reports, plans nor plan acks) and its bytes per
/// robot per minute stay within today's figures and a small margin. Bytes are
/// deterministic per seed, so a change that costs the radio more fails here. Today
/// (docs/demo.md): overhead 0.28 / 0.28 / 0.31 and 4 621 / 5 498 / 5 679 B per robot
/// per minute for seeds 3 / 7 / 11; the team protocol's target is an overhead of 0.20.
pub const OVERHEAD_AT_3: f64 = 0.33;
/// See [`OVERHEAD_AT_3`].
pub const BYTES_PER_ROBOT_MINUTE_AT_3: f64 = 6_000.0;

/// What every seed must show of the team link's cost at 3 robots.
fn assert_team_link_cost(s: &Summary) {
    let text = s.to_text();
    assert_eq!(s.robots, 3, "{text}");
    let overhead = s.team_overhead_fraction();
    assert!(overhead <= OVERHEAD_AT_3, "overhead {overhead}:\n{text}");
    let per_robot = s.team_bytes_per_robot_minute();
    assert!(
        per_robot <= BYTES_PER_ROBOT_MINUTE_AT_3,
        "{per_robot} B per robot per minute:\n{text}"
    );
}

#[test]
fn seed_3_completes_without_duplicates_and_recovers_from_the_fault() {
    let s = mission(3);
    assert_mission(&s);
    assert_team_link_cost(&s);
}

#[test]
fn seed_7_completes_without_duplicates_and_recovers_from_the_fault() {
    let s = mission(7);
    assert_mission(&s);
    assert_team_link_cost(&s);
}

#[test]
fn seed_11_completes_without_duplicates_and_recovers_from_the_fault() {
    let s = mission(11);
    assert_mission(&s);
    assert_team_link_cost(&s);
}

/// Runs a demo for `seconds` of world time.
fn run_for(seed: u64, seconds: f64) -> Demo {
    let mut demo = Demo::start(config(seed)).expect("starts");
    while demo.time() < seconds {
        demo.step();
    }
    demo
}

#[test]
fn one_seed_gives_one_run() {
    let (a, b) = within(LIMIT, || (run_for(21, 40.0), run_for(21, 40.0)));
    let events = |d: &Demo| d.observer.events.clone();
    assert_eq!(events(&a), events(&b));
    assert_eq!(a.traffic.total, b.traffic.total);
    assert_eq!(a.net_stats(), b.net_stats());
    assert_eq!(a.world.bodies, b.world.bodies);
}

#[test]
fn the_team_link_never_carries_sensor_data() {
    let demo = within(LIMIT, || run_for(13, 40.0));
    let team = &demo.team;
    for i in 0..team.robots.len() {
        for m in team.robot_modules(i) {
            for class in ["Pose", "Obstacle", "Contact", "Sighting"] {
                for id in m.node.board().instances(class).unwrap() {
                    let info = m.node.board().snapshot().info(id).unwrap();
                    assert_eq!(
                        info.owner.robot(),
                        team.robots[i],
                        "{} holds {} ({class}) from another robot",
                        m.address(),
                        info.name
                    );
                }
            }
        }
    }
    let console = team.console().node.board();
    for class in ["Pose", "Obstacle", "Contact", "Sighting", "Sensor"] {
        assert!(
            console.instances(class).unwrap().is_empty(),
            "the console holds a {class}"
        );
    }
    let suppressed: u64 = team
        .modules
        .iter()
        .map(|m| m.node.ici().stats().reports.suppressed_export)
        .sum();
    assert!(
        suppressed > 0,
        "the export policies kept sensor reports in the robots"
    );
}

#[test]
fn other_robots_are_system_context_and_their_death_a_world_model_fact() {
    let demo = within(LIMIT, || run_for(17, 40.0));
    let team = &demo.team;
    let r1 = team.module(0, Role::Exec).node.board();
    let r2 = r1.info(&team.robots[1]).expect("r1's controller knows r2");
    assert_eq!(r2.context, Context::System);
    assert_eq!(r1.info(&team.robots[0]).unwrap().context, Context::Self_);
    let dead = team.robots.last().unwrap();
    assert!(team.dead.last().copied().unwrap());
    let module = format!("team_{dead}_exec");
    assert_eq!(r1.read(&module, "alive").unwrap().value, false.into());
    assert_eq!(r1.read(dead, "alive").unwrap().value, false.into());
}
