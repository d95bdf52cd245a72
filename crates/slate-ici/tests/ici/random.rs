//! Random fault mixes on a small team (3 robots × 2 modules), from many seeds: once the
//! faults end and traffic settles, every board must agree. A failure names its seed.

use slate_ici::{LinkConfig, Rng, SimConfig};

use crate::support::{Team, open, secs, workload};

/// The faults of one run, drawn from its seed.
#[derive(Debug)]
struct Mix {
    link: SimConfig,
    partition: bool,
    kill: bool,
    restart: bool,
}

fn pick<T: Copy>(rng: &mut Rng, options: &[T]) -> T {
    options[rng.below(options.len() as u64) as usize]
}

fn mix(rng: &mut Rng) -> Mix {
    let team = LinkConfig::clean()
        .delay(secs(pick(rng, &[0.005, 0.02, 0.1])))
        .jitter(secs(pick(rng, &[0.0, 0.05, 0.3])))
        .loss(pick(rng, &[0.0, 0.1, 0.3, 0.5]))
        .duplicate(pick(rng, &[0.0, 0.2]));
    let team = match pick(rng, &[0u64, 9600, 64_000]) {
        0 => team,
        bps => team.bandwidth(bps),
    };
    let robot = LinkConfig::clean()
        .delay(secs(0.0002))
        .loss(pick(rng, &[0.0, 0.05]))
        .duplicate(pick(rng, &[0.0, 0.1]));
    Mix {
        link: SimConfig {
            robot,
            team,
            ..SimConfig::default()
        },
        partition: rng.chance(0.3),
        kill: rng.chance(0.2),
        restart: rng.chance(0.1),
    }
}

fn run(seed: u64) {
    let mut rng = Rng::new(seed);
    let mix = mix(&mut rng);
    let mut team = Team::grid(seed, mix.link, 3, 2);
    team.run(0.5);
    workload(&team, &mut rng, 20, 0.05);
    let victim = team.members[rng.below(6) as usize].address.clone();
    if mix.partition {
        let robot: Vec<_> = team
            .members
            .iter()
            .map(|n| n.address.clone())
            .filter(|a| a.robot() == victim.robot())
            .collect();
        let rest: Vec<_> = team
            .members
            .iter()
            .map(|n| n.address.clone())
            .filter(|a| a.robot() != victim.robot())
            .collect();
        team.net.partition(&robot, &rest);
    }
    if mix.kill {
        team.net.kill(&victim);
    }
    workload(&team, &mut rng, 20, 0.05);
    team.net.heal();
    team.net.revive(&victim);
    if mix.restart {
        team.add(victim.as_str(), open());
    }
    workload(&team, &mut rng, 10, 0.05);
    if let Some(d) = team.settle(40) {
        panic!("seed {seed} with {mix:?} did not converge: {d}");
    }
}

/// One test per range of seeds, so that the ranges run in parallel.
macro_rules! converge_seeds {
    ($($test:ident: $seeds:expr;)*) => {
        $(
            #[test]
            fn $test() {
                ($seeds).for_each(run);
            }
        )*
    };
}

converge_seeds! {
    random_faults_converge_seeds_0_to_49: 0..50;
    random_faults_converge_seeds_50_to_99: 50..100;
    random_faults_converge_seeds_100_to_149: 100..150;
    random_faults_converge_seeds_150_to_199: 150..200;
}

/// Replays the seeds `SEED` (to `SEED_TO`, exclusive) when set, to reproduce a failure
/// or search further: `SEED=0 SEED_TO=5000 cargo test --release -p slate-ici --test ici
/// replay`. Does nothing otherwise.
#[test]
fn replay_seeds_from_the_environment() {
    let Some(from) = std::env::var("SEED")
        .ok()
        .and_then(|s| s.parse::<u64>().ok())
    else {
        return;
    };
    let to = std::env::var("SEED_TO")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(from + 1);
    let failed: Vec<u64> = (from..to)
        .filter(|seed| std::panic::catch_unwind(|| run(*seed)).is_err())
        .collect();
    assert!(failed.is_empty(), "failed seeds: {failed:?}");
}
