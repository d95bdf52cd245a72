//! Convergence under loss, duplication, reordering, partitions, late joins, restarts,
//! and a killed module seen dead everywhere.

use std::sync::Arc;

use slate_ici::{Ici, IciConfig, LinkConfig, LinkKind, Rng, SimConfig, module_object_name};
use slate_model::{Context, NewObject, Timestamp, Update, Value};

use crate::support::{Team, addr, classes, open, secs, workload};

/// 3 robots × 2 modules on links with these faults, some random work, then the boards
/// must agree (faults still on).
fn converge_under(seed: u64, link: LinkConfig) -> Team {
    let config = SimConfig {
        robot: link.delay(secs(0.0001)),
        team: link.delay(secs(0.02)),
        ..SimConfig::default()
    };
    let team = Team::grid(seed, config, 3, 2);
    team.run(0.5);
    workload(&team, &mut Rng::new(seed), 150, 0.05);
    team.assert_converges(60);
    team
}

#[test]
fn boards_converge_without_loss() {
    converge_under(20, LinkConfig::clean());
}

#[test]
fn boards_converge_with_10_percent_loss() {
    converge_under(21, LinkConfig::clean().loss(0.1));
}

#[test]
fn boards_converge_with_30_percent_loss() {
    converge_under(22, LinkConfig::clean().loss(0.3));
}

#[test]
fn boards_converge_with_50_percent_loss() {
    let team = converge_under(23, LinkConfig::clean().loss(0.5));
    let requested: u64 = team.total(|s| s.catch_up.completed);
    assert!(requested > 0, "loss was recovered by catch-ups");
}

#[test]
fn boards_converge_with_duplication() {
    let team = converge_under(24, LinkConfig::clean().duplicate(0.5));
    let dups: u64 = team.total(|s| s.rejects.duplicates);
    assert!(dups > 0);
}

#[test]
fn boards_converge_with_reordering() {
    converge_under(25, LinkConfig::clean().jitter(secs(0.5)));
}

#[test]
fn boards_converge_on_a_slow_lossy_radio() {
    let team = converge_under(26, LinkConfig::clean().bandwidth(9600).loss(0.1));
    let radios = team.net.stats().radios;
    let queued = radios
        .iter()
        .filter(|((_, link), _)| *link == LinkKind::Team)
        .map(|(_, r)| r.queued)
        .max()
        .unwrap_or_default();
    assert!(queued > secs(0.0), "the 9600 bit/s link queued messages");
}

#[test]
fn boards_converge_after_a_partition_heals() {
    let team = Team::grid(27, SimConfig::default(), 3, 2);
    team.run(0.5);
    let r0 = [addr("t/r0/m0"), addr("t/r0/m1")];
    let rest: Vec<_> = team
        .members
        .iter()
        .map(|n| n.address.clone())
        .filter(|a| !r0.contains(a))
        .collect();
    let mut rng = Rng::new(27);
    workload(&team, &mut rng, 40, 0.05);
    team.net.partition(&r0, &rest);
    workload(&team, &mut rng, 100, 0.05);
    assert!(
        crate::support::divergence(&team.members).is_some(),
        "the partition made a difference"
    );
    team.net.heal();
    team.assert_converges(60);
}

#[test]
fn a_late_joiner_catches_up_with_the_current_state() {
    let mut team = Team::grid(28, SimConfig::default(), 2, 2);
    team.run(0.5);
    workload(&team, &mut Rng::new(28), 100, 0.05);
    team.add("t/r2/late", open());
    team.assert_converges(30);
    let late = team.member("t/r2/late").ici.stats();
    assert!(late.catch_up.completed >= 4, "{:?}", late.catch_up);
}

#[test]
fn a_restarted_module_catches_up_and_is_caught_up_with() {
    let mut team = Team::grid(29, SimConfig::default(), 2, 2);
    team.run(0.5);
    let mut rng = Rng::new(29);
    workload(&team, &mut rng, 60, 0.05);
    // The module restarts with an empty board: same address, new incarnation.
    team.add("t/r1/m0", open());
    workload(&team, &mut rng, 60, 0.05);
    team.assert_converges(30);
    let restarts: u64 = team.total(|s| s.liveliness.restarts);
    assert!(restarts >= 1);
}

#[test]
fn a_killed_module_is_dead_on_every_other_board_and_alive_again_when_back() {
    let team = Team::grid(30, SimConfig::default(), 3, 2);
    team.run(1.0);
    let victim = addr("t/r1/m1");
    let name = module_object_name(&victim);
    let alive = |n: &crate::support::Member| n.board.read(&name, "alive").map(|p| p.value).ok();
    for n in team.members.iter().filter(|n| n.address != victim) {
        assert_eq!(alive(n), Some(Value::Bool(true)), "{}", n.address);
    }
    team.net.kill(&victim);
    team.run(6.0);
    for n in team.members.iter().filter(|n| n.address != victim) {
        assert_eq!(alive(n), Some(Value::Bool(false)), "{}", n.address);
        assert!(n.ici.stats().liveliness.lost >= 1);
    }
    team.net.revive(&victim);
    team.run(2.0);
    for n in team.members.iter().filter(|n| n.address != victim) {
        assert_eq!(alive(n), Some(Value::Bool(true)), "{}", n.address);
    }
}

/// The transport at `watcher` says `peer` went down while the two still talk (Zenoh
/// withdraws a liveliness token when a session elsewhere fails); the watcher's board must
/// keep `peer` alive all along, over `seconds`, and never count it lost.
fn a_false_down_kills_nothing(seed: u64, watcher: &str, peer: &str, seconds: u32) {
    let team = Team::grid(seed, SimConfig::default(), 2, 2);
    team.run(1.0);
    let (watcher, peer) = (addr(watcher), addr(peer));
    let name = module_object_name(&peer);
    let member = team.members.iter().find(|m| m.address == watcher).unwrap();
    let alive = || member.board.read(&name, "alive").map(|p| p.value).ok();
    assert_eq!(alive(), Some(Value::Bool(true)));
    team.net.false_down(&watcher, &peer);
    for _ in 0..seconds * 10 {
        assert_eq!(
            alive(),
            Some(Value::Bool(true)),
            "{peer} marked dead on {watcher}"
        );
        team.run(0.1);
    }
    assert_eq!(member.ici.stats().liveliness.lost, 0);
}

#[test]
fn a_transport_down_does_not_kill_a_mate_still_heard() {
    a_false_down_kills_nothing(33, "t/r0/m0", "t/r0/m1", 3);
}

#[test]
fn a_transport_down_does_not_kill_a_remote_module_still_heard() {
    a_false_down_kills_nothing(34, "t/r0/m0", "t/r1/m0", 8);
}

#[test]
fn a_transport_down_of_a_module_that_went_silent_kills_it_after_the_timeout() {
    // The lease is longer than the test: the only down is the one given below.
    let config = SimConfig {
        lease: secs(1000.0),
        ..SimConfig::default()
    };
    let team = Team::grid(35, config, 1, 2);
    team.run(1.0);
    let (watcher, victim) = (addr("t/r0/m0"), addr("t/r0/m1"));
    team.net.kill(&victim);
    team.net.false_down(&watcher, &victim);
    let name = module_object_name(&victim);
    let alive = || team.board("t/r0/m0").read(&name, "alive").unwrap().value;
    team.run(2.0);
    assert_eq!(alive(), Value::Bool(false));
}

#[test]
fn a_transport_down_of_a_module_silent_for_two_heartbeat_periods_is_believed() {
    // A robot that died: its modules are silent from then on, and the transport's down
    // (its lease ran out) is believed once they missed two heartbeats, well before the
    // 5 s team timeout (the demo sees a robot's death in about 2 s).
    let config = SimConfig {
        lease: secs(1000.0),
        ..SimConfig::default()
    };
    let team = Team::grid(36, config, 2, 1);
    team.run(1.0);
    let (watcher, victim) = (addr("t/r0/m0"), addr("t/r1/m0"));
    team.net.kill(&victim);
    team.run(1.5); // past the team heartbeat (1 s), well within its timeout (5 s)
    let name = module_object_name(&victim);
    let alive = || team.board("t/r0/m0").read(&name, "alive").unwrap().value;
    assert_eq!(alive(), Value::Bool(true), "not yet timed out");
    team.net.false_down(&watcher, &victim);
    team.run(1.0);
    assert_eq!(alive(), Value::Bool(false));
}

#[test]
fn a_last_message_that_arrives_just_after_the_down_does_not_undo_it() {
    // A module that closes sends its last messages, then withdraws its token; Zenoh sends
    // declarations ahead of data, so the down can arrive first and the last messages a
    // few milliseconds after it. Taken as "heard after the down", they held the module
    // alive until its timeout (a plan's origin waited that long for `destination lost`).
    let config = SimConfig {
        lease: secs(1000.0),
        ..SimConfig::default()
    };
    let team = Team::grid(38, config, 2, 1);
    team.run(1.0);
    let (watcher, victim) = (addr("t/r0/m0"), addr("t/r1/m0"));
    let victims = &team
        .members
        .iter()
        .find(|m| m.address == victim)
        .unwrap()
        .board;
    team.net.false_down(&watcher, &victim);
    victims
        .create_with(NewObject::new("Rock", "last_words").context(Context::Surroundings))
        .unwrap();
    team.run(0.05);
    assert!(
        team.board("t/r0/m0").snapshot().exists("last_words"),
        "its report arrived, after the down"
    );
    team.net.kill(&victim);
    let name = module_object_name(&victim);
    let alive = || team.board("t/r0/m0").read(&name, "alive").unwrap().value;
    team.run(2.6); // 2.25 heartbeat periods after it was last heard; its timeout is 5 s
    assert_eq!(alive(), Value::Bool(false));
}

#[test]
fn a_transport_down_of_a_module_that_missed_one_heartbeat_kills_nothing() {
    // At 30 % loss a heartbeat is often lost; a transport's down that comes then (Zenoh
    // withdrew a token) is not news while the module is heard again within two periods.
    let config = SimConfig {
        lease: secs(1000.0),
        ..SimConfig::default()
    };
    let team = Team::grid(37, config, 2, 1);
    team.run(1.0);
    let (watcher, peer) = (addr("t/r0/m0"), addr("t/r1/m0"));
    let name = module_object_name(&peer);
    let member = team.members.iter().find(|m| m.address == watcher).unwrap();
    let alive = || member.board.read(&name, "alive").unwrap().value;
    team.net.kill(&peer); // its next heartbeat is lost
    team.run(1.1);
    team.net.false_down(&watcher, &peer);
    team.run(0.1);
    team.net.revive(&peer);
    for _ in 0..30 {
        assert_eq!(
            alive(),
            Value::Bool(true),
            "{peer} marked dead on {watcher}"
        );
        team.run(0.1);
    }
    assert_eq!(member.ici.stats().liveliness.lost, 0);
}

#[test]
fn a_silent_module_is_declared_dead_by_the_heartbeat_timeout() {
    // The transport never reports it down (a lease longer than the test): only the
    // ICI's heartbeat timeout can tell.
    let config = SimConfig {
        lease: secs(1000.0),
        ..SimConfig::default()
    };
    let team = Team::grid(31, config, 2, 1);
    team.run(1.0);
    let victim = addr("t/r1/m0");
    team.net.kill(&victim);
    team.run(6.0);
    let other = team.board("t/r0/m0");
    let name = module_object_name(&victim);
    assert_eq!(
        other.read(&name, "alive").unwrap().value,
        Value::Bool(false)
    );
    let seen = other
        .read(&name, "last_seen")
        .unwrap()
        .value
        .as_f64()
        .unwrap();
    let now = team.net.clock().physical().as_secs_f64();
    assert!(now - seen >= 5.0, "last seen {seen}, now {now}");
}

#[test]
fn a_live_modules_heartbeats_refresh_last_seen_without_rewriting_alive() {
    // Plans that read `alive` (a robot's liveliness is derived from its modules') are
    // evaluated again on every write of it: a refresh that changes nothing must not write it.
    let team = Team::grid(31, SimConfig::default(), 2, 1);
    team.run(1.0);
    let board = team.board("t/r0/m0");
    let name = module_object_name(&addr("t/r1/m0"));
    let found = board.read(&name, "alive").unwrap();
    assert_eq!(found.value, Value::Bool(true));
    team.run(20.0);
    let alive = board.read(&name, "alive").unwrap();
    assert_eq!(alive.value, Value::Bool(true));
    assert_eq!(
        alive.timestamp, found.timestamp,
        "alive rewritten though unchanged"
    );
    let seen = board.read(&name, "last_seen").unwrap();
    assert!(seen.timestamp > found.timestamp, "last_seen not refreshed");
}

/// A transport that loses the first hellos it is asked to send, as Zenoh loses a
/// message sent before the peer's subscriptions have reached this module.
struct LosesHellos {
    inner: std::sync::Arc<slate_ici::SimTransport>,
    left: std::sync::atomic::AtomicUsize,
}

impl slate_ici::Transport for LosesHellos {
    fn address(&self) -> &slate_model::Address {
        self.inner.address()
    }

    fn set_handler(&self, handler: std::sync::Arc<dyn slate_ici::Handler>) {
        self.inner.set_handler(handler);
    }

    fn publish(
        &self,
        link: LinkKind,
        kind: slate_ici::MsgKind,
        payload: &[u8],
    ) -> Result<(), slate_ici::SendError> {
        self.inner.publish(link, kind, payload)
    }

    fn send(
        &self,
        to: &slate_model::Address,
        kind: slate_ici::MsgKind,
        payload: &[u8],
    ) -> Result<(), slate_ici::SendError> {
        use std::sync::atomic::Ordering;
        let lose = kind == slate_ici::MsgKind::Hello
            && self
                .left
                .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| n.checked_sub(1))
                .is_ok();
        if lose {
            return Ok(());
        }
        self.inner.send(to, kind, payload)
    }

    fn peers(&self) -> Vec<slate_model::Address> {
        self.inner.peers()
    }

    fn stats(&self) -> slate_ici::LinkStats {
        self.inner.stats()
    }

    fn close(&self) {
        self.inner.close();
    }
}

#[test]
fn a_lost_hello_is_said_again_until_answered() {
    use std::sync::Arc;
    let team = Team::new(5);
    let mut nodes = Vec::new();
    for a in ["t/r1/a", "t/r1/b"] {
        let address = addr(a);
        let board = team.board_at(&address, &classes());
        let transport = Arc::new(LosesHellos {
            inner: team.net.join(&address),
            left: 1.into(),
        });
        let ici = slate_ici::Ici::new(board.clone(), transport, open()).unwrap();
        nodes.push((board, ici));
    }
    team.run(1.0);
    nodes[0].0.create("Tracked", "x1").unwrap();
    team.run(2.0);
    nodes[0].0.write("x1", "x", 4.0).unwrap();
    team.run(0.5);
    let got = nodes[1].0.read("x1", "x").ok().map(|p| p.value);
    assert_eq!(got, Some(Value::Real(4.0)), "b hears a's reports");
    for (_, ici) in &nodes {
        assert!(ici.stats().liveliness.hellos_resent >= 1);
        assert_eq!(ici.alive_peers().len(), 1);
    }
}

/// Starts (or restarts) `address` as a node does from its files: the board holds the
/// object `gsr` with its initial speed, written as files write initial values (stamped
/// `Timestamp::ZERO`), before the ICI starts.
fn start_from_files(team: &mut Team, address: &str, speed: f64) {
    let address = addr(address);
    let board = team.board_at(&address, &classes());
    board
        .create_with(NewObject::new("Vehicle", "gsr").context(Context::Self_))
        .unwrap();
    let initial = Update::new(speed).timestamp(Timestamp::ZERO);
    board.write("gsr", "speed", initial).unwrap();
    team.join(board, open());
}

fn speed(team: &Team, address: &str) -> Option<f64> {
    team.board(address)
        .read("gsr", "speed")
        .ok()?
        .value
        .as_f64()
}

#[test]
fn a_restarted_module_leaves_the_team_its_newer_values_and_gets_them_back() {
    let mut team = Team::new(34);
    start_from_files(&mut team, "t/r1/nav", 1.0);
    team.add("t/r1/cam", open());
    team.add("t/r2/loco", open());
    team.add("t/r2/operator", open());
    team.run(1.0);
    assert_eq!(
        speed(&team, "t/r2/loco"),
        Some(1.0),
        "initial values reach the team"
    );
    // An operator's `slate put`: a short-lived module writes, and is gone.
    team.board("t/r2/operator")
        .write("gsr", "speed", 5.0)
        .unwrap();
    team.run(1.0);
    assert_eq!(speed(&team, "t/r1/nav"), Some(5.0));
    team.kill("t/r2/operator");
    team.run(0.3);
    team.net.kill(&addr("t/r1/nav"));
    team.run(0.3);
    start_from_files(&mut team, "t/r1/nav", 1.0);
    team.assert_converges(10);
    for n in ["t/r1/nav", "t/r1/cam", "t/r2/loco"] {
        assert_eq!(speed(&team, n), Some(5.0), "{n}");
    }
}

#[test]
fn initial_values_written_while_running_reach_the_team_and_are_not_stale() {
    let team = Team::grid(35, SimConfig::default(), 2, 1);
    team.run(1.0);
    let nav = team.board("t/r0/m0");
    nav.create_with(NewObject::new("Vehicle", "gsr")).unwrap();
    nav.write("gsr", "speed", Update::new(2.0).timestamp(Timestamp::ZERO))
        .unwrap();
    team.run(1.0);
    assert_eq!(
        speed(&team, "t/r1/m0"),
        Some(2.0),
        "{:?} {:?}",
        team.member("t/r1/m0").ici.stats(),
        team.member("t/r0/m0").ici.stats().reports
    );
    let stats = team.member("t/r1/m0").ici.stats();
    assert_eq!(stats.rejects.stale, 0, "{:?}", stats.rejects);
}

/// How many objects the boards of t/r1/nav and t/r2/loco hold.
fn objects(team: &Team) -> (usize, usize) {
    let count = |n: &str| team.board(n).stats().objects;
    (count("t/r1/nav"), count("t/r2/loco"))
}

/// Asserts that the boards hold what they held `before` the modules came and went, with
/// no object left for t/r1/cli-3 on t/r2/loco; returns that object's name.
fn assert_forgotten(team: &Team, before: (usize, usize)) -> String {
    assert_eq!(objects(team), before);
    let name = module_object_name(&addr("t/r1/cli-3"));
    assert!(team.board("t/r2/loco").info(&name).is_none());
    name
}

/// Ten modules `t/r1/cli-{i}` with `config` join one after another, each killed half a
/// second after it joined.
fn come_and_go(team: &mut Team, config: IciConfig) {
    for i in 0..10 {
        let cli = format!("t/r1/cli-{i}");
        team.add(&cli, config.clone());
        team.run(0.5);
        team.kill(&cli);
        team.run(0.5);
    }
}

#[test]
fn modules_that_come_and_go_leave_no_lasting_module_objects() {
    let mut team = Team::new(36);
    let config = open().forget_dead(secs(20.0));
    team.add("t/r1/nav", config.clone());
    team.add("t/r2/loco", config);
    team.run(1.0);
    let before = objects(&team);
    come_and_go(&mut team, open());
    assert!(
        objects(&team).0 > before.0,
        "each was a module while it lived"
    );
    team.run(30.0);
    let name = assert_forgotten(&team, before);
    // One that comes back is found again.
    team.add("t/r1/cli-3", open());
    team.run(1.0);
    let alive = team.board("t/r2/loco").read(&name, "alive").unwrap().value;
    assert_eq!(alive, Value::Bool(true));
}

#[test]
fn observers_leave_no_module_object_once_they_are_gone() {
    let mut team = Team::of(37, [("t/r1/nav", open()), ("t/r2/loco", open())]);
    team.run(1.0);
    let before = objects(&team);
    come_and_go(&mut team, open().observer(true));
    // Well within the default forget_dead (10 min): a module would still be there.
    team.run(5.0);
    assert_forgotten(&team, before);
    // A module that is no observer is remembered, dead, for forget_dead.
    team.add("t/r1/vision", open());
    team.run(0.5);
    team.kill("t/r1/vision");
    team.run(5.0);
    let vision = module_object_name(&addr("t/r1/vision"));
    let alive = team
        .board("t/r2/loco")
        .read(&vision, "alive")
        .unwrap()
        .value;
    assert_eq!(alive, Value::Bool(false));
}

/// Counts the catch-up answers a raw module receives.
#[derive(Default)]
struct Answers(std::sync::atomic::AtomicUsize);

impl slate_ici::Handler for Answers {
    fn message(&self, _: &slate_model::Address, payload: &[u8]) {
        if slate_ici::MsgKind::of(payload) == slate_ici::MsgKind::CatchUpAnswer {
            self.0.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        }
    }

    fn peer(&self, _: &slate_model::Address, _: bool) {}
}

#[test]
fn a_module_asking_again_and_again_gets_one_current_state_per_interval() {
    use slate_ici::{MsgKind, Transport};
    use slate_wire::{CatchUpRequest, Encoder, Message, Schema};
    let team = Team::of(38, [("t/r1/nav", open())]);
    team.board("t/r1/nav").create("Vehicle", "v1").unwrap();
    team.board("t/r1/nav").write("v1", "speed", 2.0).unwrap();
    let flood = team.net.join(&addr("t/r1/flood"));
    let answers = Arc::new(Answers::default());
    flood.set_handler(answers.clone());
    team.run(1.0);
    let request = Message::CatchUpRequest(CatchUpRequest::default());
    let bytes = Encoder::new(addr("t/r1/flood"))
        .encode(&request, &Schema::new(&[]))
        .unwrap();
    for _ in 0..20 {
        flood
            .send(&addr("t/r1/nav"), MsgKind::CatchUpRequest, &bytes)
            .unwrap();
    }
    team.run(0.1);
    let stats = || team.member("t/r1/nav").ici.stats().catch_up;
    assert_eq!((stats().answered, stats().deferred), (1, 19));
    // The nineteen that waited, merged, are answered once the interval is over.
    team.run(1.0);
    assert_eq!(stats().answered, 2);
    assert!(answers.0.load(std::sync::atomic::Ordering::SeqCst) >= 2);
}

#[test]
fn an_observer_whose_own_hello_was_lost_is_still_forgotten_once_gone() {
    let team = Team::of(39, [("t/r1/nav", open())]);
    team.run(1.0);
    let before = team.board("t/r1/nav").stats().objects;
    let address = addr("t/r1/cli-1");
    let board = team.board_at(&address, &[]);
    let transport = Arc::new(LosesHellos {
        inner: team.net.join(&address),
        left: 1.into(),
    });
    let ici = Ici::new(board, transport, open().observer(true)).unwrap();
    // It answers nav's hello (with a reply), and leaves before saying hello again.
    team.run(0.1);
    drop(ici);
    team.net.kill(&address);
    team.run(5.0);
    assert_eq!(team.board("t/r1/nav").stats().objects, before);
}

/// Two robots of one module each, where the only down is the one a test gives (the
/// lease is longer than any test), run until their team link has nothing else to say.
fn idle_pair(seed: u64) -> (Team, slate_model::Address, slate_model::Address) {
    let config = SimConfig {
        lease: secs(1000.0),
        ..SimConfig::default()
    };
    let team = Team::grid(seed, config, 2, 1);
    team.run(30.0);
    (team, addr("t/r0/m0"), addr("t/r1/m0"))
}

#[test]
fn an_idle_team_link_sends_a_heartbeat_every_four_periods() {
    // Nothing written: each module's team heartbeat backs off to 4 s (4 periods of 1 s),
    // so an idle link carries a quarter of the heartbeats it did.
    let (team, _, _) = idle_pair(38);
    let before = team
        .net
        .stats()
        .kind(LinkKind::Team, slate_ici::MsgKind::Heartbeat);
    team.run(60.0);
    let after = team
        .net
        .stats()
        .kind(LinkKind::Team, slate_ici::MsgKind::Heartbeat);
    let sent = after.sent_msgs - before.sent_msgs;
    // 2 modules x 60 s / 4 s, one more each for where the minute falls.
    assert!(sent <= 32, "{sent} team heartbeats in an idle minute");
    assert!(
        sent >= 28,
        "{sent} team heartbeats in an idle minute: detection needs them"
    );
    let bytes = (after.sent_bytes - before.sent_bytes) as f64 / 60.0;
    let total = team.net.stats().total(LinkKind::Team);
    assert!(
        bytes <= 10.0,
        "{bytes:.1} B/s of heartbeats on the idle team link"
    );
    assert!(total.sent_msgs > 0);
}

#[test]
fn a_silent_idle_peer_is_found_dead_after_eight_missed_heartbeats_not_five() {
    // An idle peer's heartbeats come 4 s apart. Five missed in a row (20 s) happen at
    // 30 % loss about once in 400 such stretches, which marked healthy idle modules dead
    // on real links (docs/real-links.md, session 21): its timeout is eight of its gaps
    // (32 s; 0.3^8 is about 1 in 15 000), and it is found dead within that bound.
    let (team, watcher, victim) = idle_pair(39);
    let name = module_object_name(&victim);
    let member = team.members.iter().find(|m| m.address == watcher).unwrap();
    let alive = || member.board.read(&name, "alive").unwrap().value;
    team.net.kill(&victim);
    team.run(25.0);
    assert_eq!(
        alive(),
        Value::Bool(true),
        "an idle peer missing five heartbeats (20 s) is not yet dead"
    );
    team.run(8.0);
    assert_eq!(
        alive(),
        Value::Bool(false),
        "found dead within 32 s of its last heartbeat"
    );
}

#[test]
fn a_peer_that_speaks_after_idling_is_held_to_the_links_timeout_again() {
    // One write ends the idle: the peer's heartbeats come every period again, and its
    // silence is judged by the link's own timeout (5 s).
    let (team, watcher, victim) = idle_pair(40);
    let writer = team.members.iter().find(|m| m.address == victim).unwrap();
    writer.board.create("Vehicle", "probe").unwrap();
    team.run(3.0);
    let name = module_object_name(&victim);
    let member = team.members.iter().find(|m| m.address == watcher).unwrap();
    let alive = || member.board.read(&name, "alive").unwrap().value;
    team.net.kill(&victim);
    team.run(6.5);
    assert_eq!(
        alive(),
        Value::Bool(false),
        "dead within the link's 5 s timeout"
    );
}
