//! One seed, one run: the same scenario twice gives the same counters and boards.

use slate_ici::{IciStats, LinkConfig, Rng, SimConfig, SimStats};

use crate::support::{Team, secs, workload};

fn scenario(seed: u64) -> (SimStats, Vec<IciStats>, Vec<String>) {
    let team_link = LinkConfig::clean()
        .delay(secs(0.02))
        .jitter(secs(0.1))
        .loss(0.2)
        .duplicate(0.1)
        .bandwidth(9600);
    let config = SimConfig {
        team: team_link,
        ..SimConfig::default()
    };
    let team = Team::grid(seed, config, 3, 2);
    team.run(0.5);
    workload(&team, &mut Rng::new(seed), 100, 0.05);
    team.run(10.0);
    let stats = team.members.iter().map(|n| n.ici.stats()).collect();
    let dumps = team.members.iter().map(|n| n.board.dump()).collect();
    (team.net.stats(), stats, dumps)
}

#[test]
fn the_same_seed_gives_the_same_counters_and_the_same_boards() {
    let (a, b) = (scenario(42), scenario(42));
    assert_eq!(a.0, b.0, "network counters");
    assert_eq!(a.1, b.1, "ICI counters");
    assert_eq!(a.2, b.2, "boards");
    assert!(a.0.events > 1000);
}

#[test]
fn another_seed_gives_another_run() {
    assert_ne!(scenario(1).0, scenario(2).0);
}
