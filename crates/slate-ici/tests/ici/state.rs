//! State requests through the robot stream (docs/team-protocol.md 2.6, step 11): a
//! newcomer, a restarted robot and the two halves of a healed partition get the
//! members' current state, answered once by broadcast in the robot stream; no per-pair
//! catch-up request, answer or object list is sent on the team link.

use slate_ici::{IciConfig, LinkConfig, LinkKind, MsgKind, Rng, SimConfig, TeamProtocol};
use slate_model::{Address, Context, NewObject, Value};

use crate::support::{Team, open, secs, workload};

/// Module m{j} has priority j (m0 is its robot's gateway), the radio preset.
fn config(module: usize) -> IciConfig {
    let protocol = TeamProtocol::radio().priority(Some(module as u8));
    open().team_protocol(Some(protocol))
}

/// A robot's modules `t/r{robot}/m0 ..`, joining the team (again, after a restart).
fn join_robot(team: &mut Team, robot: usize, modules: usize) {
    for m in 0..modules {
        team.add(&format!("t/r{robot}/m{m}"), config(m));
    }
}

/// `robots` × `modules` with the switch on; a clean robot link, `link` as the team link.
fn robots(seed: u64, link: LinkConfig, robots: usize, modules: usize) -> Team {
    let sim = SimConfig {
        robot: LinkConfig::clean().delay(secs(0.0001)),
        team: link.delay(secs(0.02)),
        ..SimConfig::default()
    };
    let mut team = Team::with(seed, sim);
    for r in 0..robots {
        join_robot(&mut team, r, modules);
    }
    team
}

/// Messages of `kind` sent on the team link, every pair together.
fn team_sent(team: &Team, kind: MsgKind) -> u64 {
    team.net.stats().kind(LinkKind::Team, kind).sent_msgs
}

/// Today's per-pair catch-up traffic on the team link must be gone.
fn assert_no_per_pair_catch_up(team: &Team) {
    for kind in [
        MsgKind::CatchUpRequest,
        MsgKind::CatchUpAnswer,
        MsgKind::ObjectList,
        MsgKind::Classes,
    ] {
        assert_eq!(team_sent(team, kind), 0, "{kind} sent on the team link");
    }
}

/// Current states answered by the modules of the robots `sources`.
fn answered(team: &Team, sources: &[usize]) -> u64 {
    let of = |a: &Address| sources.iter().any(|r| a.robot() == format!("r{r}"));
    let members = team.members.iter().filter(|m| of(&m.address));
    members.map(|m| m.ici.stats().catch_up.answered).sum()
}

fn rock(team: &Team, at: &str, name: &str, hits: i64) {
    let board = team.board(at);
    let _ = board.create_with(NewObject::new("Rock", name).context(Context::Surroundings));
    board.write(name, "hits", Value::Int(hits)).unwrap();
}

/// Seeds 111..114: robot 3 joins 3 robots × 2 modules long after their start.
#[test]
fn a_late_joining_robot_gets_the_whole_state() {
    for seed in 111..114 {
        late_join(seed);
    }
}

fn late_join(seed: u64) {
    let mut team = robots(seed, LinkConfig::clean(), 3, 2);
    team.run(0.5);
    workload(&team, &mut Rng::new(seed), 100, 0.05);
    // Long after the start: robot 3's modules heard none of the streams from 1.
    team.run(3.0);
    let before = answered(&team, &[0, 1, 2]);
    join_robot(&mut team, 3, 2);
    team.assert_converges(30);
    let answers = answered(&team, &[0, 1, 2]) - before;
    // Each of the 6 source members answers by broadcast at most once per answer
    // interval, whoever asked: seed 111 needs 6 answers; in seed 112 some asks come
    // after the first answer (a joiner that had not heard the hello yet, or asks again
    // for names), and the merged second round makes 11. Per pair it would be 6 answers
    // to each joining module, as reliable sends on the team link (none here).
    assert!(
        (1..=12).contains(&answers),
        "seed {seed}: {answers} state answers"
    );
    let late = team.member("t/r3/m1").ici.stats();
    assert!(
        late.catch_up.completed >= 3,
        "seed {seed}: {:?}",
        late.catch_up
    );
    assert_no_per_pair_catch_up(&team);
}

#[test]
fn a_restarted_robot_gets_the_whole_state() {
    let mut team = robots(112, LinkConfig::clean(), 3, 2);
    team.run(0.5);
    let mut rng = Rng::new(112);
    workload(&team, &mut rng, 80, 0.05);
    rock(&team, "t/r0/m1", "rock_before", 4);
    team.run(3.0);
    // Robot 1 restarts whole: same addresses, new incarnations, empty boards.
    join_robot(&mut team, 1, 2);
    team.assert_converges(30);
    let held = team.board("t/r1/m0").read("rock_before", "hits").ok();
    assert_eq!(held.map(|p| p.value), Some(Value::Int(4)));
    assert_no_per_pair_catch_up(&team);
}

/// 6 robots × 2 modules, cut 3 | 3 for 20 s of work on both sides, then healed.
#[test]
fn a_partition_between_two_halves_heals_and_converges() {
    // Per pair, each of 12 members would answer the 6 modules of the other half (72);
    // here each answers once per answer interval for every robot that asked (11).
    let answers = partition_heals(113, LinkConfig::clean());
    assert!((1..=24).contains(&answers), "{answers} state answers");
}

/// The same with 5 % loss on the team link (seeds 200..203; 200..209 gave 11 to 23
/// answers: at most two rounds per member).
#[test]
fn a_partition_heals_and_converges_on_a_lossy_radio() {
    for seed in 200..203 {
        let answers = partition_heals(seed, LinkConfig::clean().loss(0.05));
        assert!(
            (1..=24).contains(&answers),
            "seed {seed}: {answers} state answers"
        );
    }
}

/// Runs the cut and the heal; returns the state answers given after the heal.
fn partition_heals(seed: u64, link: LinkConfig) -> u64 {
    let team = robots(seed, link, 6, 2);
    team.run(0.5);
    let mut rng = Rng::new(seed);
    workload(&team, &mut rng, 40, 0.05);
    let half = |a: &Address| a.robot() < "r3";
    let all: Vec<Address> = team.members.iter().map(|m| m.address.clone()).collect();
    let (a, b): (Vec<Address>, Vec<Address>) = all.into_iter().partition(|a| half(a));
    team.net.partition(&a, &b);
    // 20 s of virtual time cut, with work on both sides.
    workload(&team, &mut rng, 200, 0.1);
    let differ = crate::support::divergence(&team.members).is_some();
    assert!(differ, "seed {seed}: the partition made a difference");
    let everyone = [0, 1, 2, 3, 4, 5];
    let before = answered(&team, &everyone);
    team.net.heal();
    team.assert_converges(60);
    assert_no_per_pair_catch_up(&team);
    answered(&team, &everyone) - before
}

#[test]
fn no_per_pair_team_catch_up_sends_remain_with_the_switch_on() {
    let team = robots(114, LinkConfig::clean().loss(0.1), 3, 2);
    team.run(0.5);
    workload(&team, &mut Rng::new(114), 150, 0.05);
    team.assert_converges(60);
    assert_no_per_pair_catch_up(&team);
    assert!(team_sent(&team, MsgKind::TeamFrame) > 0);
}

#[test]
fn a_widened_interest_gets_through_a_state_answer_what_it_did_not_model() {
    let mut team = robots(115, LinkConfig::clean(), 1, 1);
    let narrow = config(0).interest(slate_ici::ClassSet::none().class("Vehicle"));
    team.add("t/r1/m0", narrow);
    team.run(1.0);
    rock(&team, "t/r0/m0", "rock_early", 2);
    team.run(2.0);
    assert!(team.board("t/r1/m0").read("rock_early", "hits").is_err());
    team.member("t/r1/m0")
        .ici
        .set_interest(slate_ici::ClassSet::all());
    team.run(5.0);
    let held = team.board("t/r1/m0").read("rock_early", "hits").ok();
    assert_eq!(held.map(|p| p.value), Some(Value::Int(2)));
    assert_no_per_pair_catch_up(&team);
}

/// A robot that models only rocks hears the answer to a robot that models only
/// vehicles (robot 0 keeps no history, so the newcomer asks for its state): the
/// answer is filtered by the union of both, so its sweep keeps the rock.
#[test]
fn an_unasked_state_answer_sweeps_nothing_a_listener_models() {
    let only = |class: &str| config(0).interest(slate_ici::ClassSet::none().class(class));
    let mut team = robots(116, LinkConfig::clean(), 0, 0);
    // Robot 0 keeps no history: a newcomer cannot be repaired and asks for state.
    let mut protocol = TeamProtocol::radio().priority(Some(0));
    protocol.history_age = std::time::Duration::from_millis(1);
    team.add("t/r0/m0", open().team_protocol(Some(protocol)));
    team.add("t/r1/m0", only("Rock"));
    team.run(1.0);
    rock(&team, "t/r0/m0", "rock_kept", 6);
    let board = team.board("t/r0/m0");
    let _ = board.create_with(NewObject::new("Vehicle", "car").context(Context::Surroundings));
    board.write("car", "speed", Value::Real(3.0)).unwrap();
    team.run(3.0);
    let lists = |team: &Team| team.member("t/r1/m0").ici.stats().catch_up.completed;
    let before = lists(&team);
    team.add("t/r2/m0", only("Vehicle"));
    team.run(5.0);
    assert!(
        lists(&team) > before,
        "r1 applied the answer it did not ask for"
    );
    let kept = team.board("t/r1/m0").read("rock_kept", "hits").ok();
    assert_eq!(kept.map(|p| p.value), Some(Value::Int(6)));
    let car = team.board("t/r2/m0").read("car", "speed").ok();
    assert_eq!(car.map(|p| p.value), Some(Value::Real(3.0)));
    assert_no_per_pair_catch_up(&team);
}

/// Robot 0 misses robot 1's first hello, so its gateway tells its members that no
/// robot models anything yet, and robot 0's writes stay home. When the hello is
/// repaired and the interest widens, what robot 0's members hold reaches robot 1 then
/// (before, it never did: nothing was sent, so no receiver saw a gap to ask about).
#[test]
fn writes_kept_home_while_no_robot_was_heard_go_out_when_one_is() {
    let sim = SimConfig {
        robot: LinkConfig::clean().delay(secs(0.0001)),
        team: LinkConfig::clean().delay(secs(0.02)),
        ..SimConfig::default()
    };
    let mut team = Team::with(7, sim);
    join_robot(&mut team, 1, 2);
    let deaf = [
        crate::support::addr("t/r0/m0"),
        crate::support::addr("t/r0/m1"),
    ];
    join_robot(&mut team, 0, 2);
    // Every team publication of robot 1 is lost at robot 0 for 1.5 s: its hello too.
    for _ in 0..150 {
        team.net
            .drop_next_publish(&crate::support::addr("t/r1/m0"), &deaf);
        team.run(0.01);
    }
    rock(&team, "t/r0/m1", "rock_home", 3);
    team.run(0.1);
    team.assert_converges(30);
    let held = team.board("t/r1/m1").read("rock_home", "hits").ok();
    assert_eq!(held.map(|p| p.value), Some(Value::Int(3)));
}
