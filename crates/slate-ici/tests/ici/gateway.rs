//! Gateway election (docs/team-protocol.md, 2.1): the live, eligible module with the
//! smallest (priority, address) speaks for its robot, on every board of the robot alike.

use slate_ici::{IciConfig, TeamProtocol};

use crate::support::{Team, addr, open};

/// Open interest and export, the team protocol on with this election priority.
fn ranked(priority: Option<u8>) -> IciConfig {
    open().team_protocol(Some(TeamProtocol::radio().priority(priority)))
}

/// Two robots: r0 with priorities 2, 0, 1; r1 with 1, 0.
fn two_robots(seed: u64) -> Team {
    Team::of(
        seed,
        [
            ("t/r0/a", ranked(Some(2))),
            ("t/r0/b", ranked(Some(0))),
            ("t/r0/c", ranked(Some(1))),
            ("t/r1/x", ranked(Some(1))),
            ("t/r1/y", ranked(Some(0))),
        ],
    )
}

/// The gateway each module of `robot` sees, by module.
fn gateways_seen(team: &Team, robot: &str) -> Vec<(String, Option<String>)> {
    team.members
        .iter()
        .filter(|m| m.address.robot() == robot)
        .map(|m| {
            let gw = m.ici.gateway().map(|g| g.to_string());
            (m.address.to_string(), gw)
        })
        .collect()
}

fn assert_all_see(team: &Team, robot: &str, gateway: &str) {
    for (module, seen) in gateways_seen(team, robot) {
        assert_eq!(seen.as_deref(), Some(gateway), "as {module} sees it");
    }
}

#[test]
fn the_lowest_priority_live_module_is_gateway_on_every_board_of_its_robot() {
    let team = two_robots(70);
    team.run(1.0);
    assert_all_see(&team, "r0", "t/r0/b");
    assert_all_see(&team, "r1", "t/r1/y");
}

#[test]
fn a_killed_gateway_is_replaced_by_the_next_on_all_mates_within_1_2_s() {
    let mut team = two_robots(71);
    team.run(1.0);
    team.kill("t/r0/b");
    team.run(1.2);
    assert_all_see(&team, "r0", "t/r0/c");
    assert_all_see(&team, "r1", "t/r1/y");
}

#[test]
fn equal_priorities_elect_the_smallest_address() {
    let team = Team::of(
        72,
        [
            ("t/r0/m2", ranked(Some(1))),
            ("t/r0/m1", ranked(Some(1))),
            ("t/r0/m3", ranked(Some(1))),
        ],
    );
    team.run(1.0);
    assert_all_see(&team, "r0", "t/r0/m1");
}

#[test]
fn a_module_without_a_priority_is_never_gateway() {
    let team = Team::of(73, [("t/r0/a", ranked(None)), ("t/r0/b", ranked(Some(4)))]);
    team.run(1.0);
    assert_all_see(&team, "r0", "t/r0/b");
}

#[test]
fn the_old_hello_of_a_module_without_the_team_protocol_still_decodes() {
    let team = Team::of(74, [("t/r0/old", open()), ("t/r0/new", ranked(Some(0)))]);
    team.run(1.0);
    let new = team.member("t/r0/new");
    assert_eq!(new.ici.stats().rejects.frames, 0, "every hello decoded");
    assert!(new.ici.alive_peers().contains(&addr("t/r0/old")));
    assert_eq!(new.ici.gateway(), Some(addr("t/r0/new")));
    assert_eq!(
        team.member("t/r0/old").ici.gateway(),
        None,
        "the switch is off"
    );
    assert_eq!(team.member("t/r0/old").ici.stats().rejects.frames, 0);
}
