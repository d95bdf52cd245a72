//! The team protocol switched on (docs/team-protocol.md): 3 robots × 3 modules, only
//! gateways on the team link, frames within the MTU, boards that converge as with the
//! switch off, idle robots' heartbeats, and remote deaths seen everywhere.

use std::sync::Arc;

use slate_ici::{
    IciConfig, LinkConfig, LinkKind, Listen, MsgKind, Rng, SimConfig, TeamProtocol,
    module_object_name,
};
use slate_model::{Context, NewObject, Value};

use crate::support::{Tap, Team, addr, open, secs, workload};

/// Module m{j} of every robot has priority j: m0 is each robot's gateway.
fn config(module: usize, mtu: usize, on: bool) -> IciConfig {
    let mut protocol = TeamProtocol::radio().priority(Some(module as u8));
    protocol.mtu = mtu;
    open().team_protocol(on.then_some(protocol))
}

/// A clean robot link and `link` as the team link, 20 ms away.
fn sim(link: LinkConfig) -> SimConfig {
    SimConfig {
        robot: LinkConfig::clean().delay(secs(0.0001)),
        team: link.delay(secs(0.02)),
        ..SimConfig::default()
    }
}

/// 3 robots × 3 modules on `link` (team link; the robot link is clean), the team
/// protocol on or off; returns the team and each module's largest team publish.
fn grid(seed: u64, link: LinkConfig, mtu: usize, on: bool) -> (Team, Vec<Arc<Tap>>) {
    let mut team = Team::with(seed, sim(link));
    let mut recorders = Vec::new();
    for r in 0..3 {
        for m in 0..3 {
            recorders.push(team.join_tapped(&format!("t/r{r}/m{m}"), config(m, mtu, on)));
        }
    }
    (team, recorders)
}

/// Runs the same random work as the fault tests, then the boards must agree.
fn work_and_converge(team: &Team, seed: u64) {
    team.run(0.5);
    workload(team, &mut Rng::new(seed), 150, 0.05);
    team.assert_converges(60);
}

/// The senders of publications on the team link (kinds a module publishes).
fn team_publishers(team: &Team) -> Vec<(String, MsgKind)> {
    let published = [
        MsgKind::Report,
        MsgKind::Lifecycle,
        MsgKind::Heartbeat,
        MsgKind::TeamFrame,
        MsgKind::RobotHello,
        MsgKind::RobotHeartbeat,
    ];
    let stats = team.net.stats();
    let mut out: Vec<(String, MsgKind)> = stats
        .links
        .iter()
        .filter(|((from, to), _)| LinkKind::between(from, to) == LinkKind::Team)
        .flat_map(|((from, _), kinds)| kinds.keys().map(move |k| (from.to_string(), *k)))
        .filter(|(_, k)| published.contains(k))
        .collect();
    out.sort_by_key(|(a, k)| (a.clone(), k.name()));
    out.dedup();
    out
}

#[test]
fn only_gateways_publish_on_the_team_link_and_boards_converge() {
    let (team, _) = grid(80, LinkConfig::clean(), 1024, true);
    work_and_converge(&team, 80);
    let publishers = team_publishers(&team);
    assert!(!publishers.is_empty());
    for (from, kind) in &publishers {
        assert!(
            from.ends_with("/m0"),
            "{from} published {kind} on the team link"
        );
    }
    let frames = team.net.stats().kind(LinkKind::Team, MsgKind::TeamFrame);
    assert!(
        frames.sent_msgs > 0,
        "the gateways framed the members' messages"
    );
}

#[test]
fn no_team_frame_is_larger_than_the_mtu() {
    let mtu = 96;
    let (team, recorders) = grid(81, LinkConfig::clean(), mtu, true);
    work_and_converge(&team, 81);
    for (m, r) in team.members.iter().zip(&recorders) {
        let largest = r.largest();
        assert!(largest <= mtu, "{} published {largest} bytes", m.address);
    }
}

/// The objects and values of a board by name (`Module` objects left out), to compare
/// runs: packets' stamps differ between runs, values do not.
fn values(board: &slate_model::Board) -> Vec<(String, Vec<(String, Value)>)> {
    let snap = board.snapshot();
    let mut out: Vec<_> = snap
        .objects()
        .into_iter()
        .filter_map(|id| snap.info(id).map(|i| (id, i)))
        .filter(|(_, i)| &*i.class != slate_ici::MODULE_CLASS)
        .map(|(id, i)| {
            let mut vals: Vec<(String, Value)> = snap
                .own_values(id)
                .into_iter()
                .map(|(a, p, _)| (a.to_string(), p.value.clone()))
                .collect();
            vals.sort_by(|a, b| a.0.cmp(&b.0));
            (i.name.to_string(), vals)
        })
        .collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// The same work whatever the timing: every module creates a rock and a vehicle
/// (SELF, so other robots hold them in SYSTEM), writes them, one module of each robot
/// deletes its rock, and a class-level value is written.
fn scripted(team: &Team) {
    team.run(0.5);
    for m in &team.members {
        let tail = format!("{}_{}", m.address.robot(), m.address.module());
        let new = |class: &str, name: &str, context| {
            let obj = NewObject::new(class, name).context(context);
            m.board.create_with(obj).unwrap();
        };
        new("Rock", &format!("rock_{tail}"), Context::Surroundings);
        new("Vehicle", &format!("vehicle_{tail}"), Context::Self_);
    }
    team.run(0.5);
    for (i, m) in team.members.iter().enumerate() {
        let tail = format!("{}_{}", m.address.robot(), m.address.module());
        let rock = format!("rock_{tail}");
        m.board.write(&rock, "hits", Value::Int(i as i64)).unwrap();
        m.board.write(&rock, "label", format!("l{i}")).unwrap();
        m.board
            .write(&format!("vehicle_{tail}"), "speed", 2.5 * i as f64)
            .unwrap();
    }
    team.run(0.5);
    for m in team.members.iter().filter(|m| m.address.module() == "m1") {
        let tail = format!("{}_{}", m.address.robot(), m.address.module());
        m.board.delete(&format!("rock_{tail}")).unwrap();
    }
    team.board("t/r2/m2")
        .write("Tracked", "label", "everyone")
        .unwrap();
    team.assert_converges(30);
}

#[test]
fn boards_hold_the_same_values_with_the_switch_on_as_off() {
    let (on, _) = grid(82, LinkConfig::clean(), 1024, true);
    let (off, _) = grid(82, LinkConfig::clean(), 1024, false);
    scripted(&on);
    scripted(&off);
    for m in &on.members {
        let board = m.address.as_str();
        let held = values(on.board(board));
        assert!(
            held.iter().any(|(name, _)| name == "vehicle_r1_m2"),
            "{board}"
        );
        assert!(
            !held.iter().any(|(name, _)| name == "rock_r0_m1"),
            "{board}"
        );
        assert_eq!(held, values(off.board(board)), "{board}");
    }
}

#[test]
fn a_silent_robot_sends_about_one_heartbeat_per_interval() {
    let (team, _) = grid(83, LinkConfig::clean(), 1024, true);
    team.run(2.0);
    let count = |team: &Team| {
        let stats = team.net.stats();
        let from_r1 = stats
            .links
            .iter()
            .filter(|((from, to), _)| from.robot() == "r1" && to == &addr("t/r0/m0"));
        from_r1
            .filter_map(|(_, kinds)| kinds.get(&MsgKind::RobotHeartbeat))
            .map(|c| c.sent_msgs)
            .sum::<u64>()
    };
    let before = count(&team);
    team.run(20.0);
    let heartbeats = count(&team) - before;
    assert!(
        (18..=22).contains(&heartbeats),
        "{heartbeats} heartbeats in 20 s"
    );
}

#[test]
fn a_killed_remote_module_is_dead_on_every_other_board() {
    let (mut team, _) = grid(84, LinkConfig::clean(), 1024, true);
    team.run(2.0);
    let victim = addr("t/r1/m2");
    team.net.kill(&victim);
    team.members.retain(|m| m.address != victim);
    team.run(6.0);
    let name = module_object_name(&victim);
    for m in &team.members {
        let alive = m.board.read(&name, "alive").ok().map(|p| p.value);
        assert_eq!(alive, Some(Value::Bool(false)), "as {} sees it", m.address);
    }
}

/// Lost frames are NACKed and repaired from the gateway's history, and a lost robot
/// hello is NACKed (before step 10, 13 of these 20 seeds did not converge: a lost hello
/// left a robot's frames parked, and lost frames were never repaired).
#[test]
fn boards_converge_with_5_percent_loss() {
    for seed in 89..109 {
        let (team, _) = grid(seed, LinkConfig::clean().loss(0.05), 1024, true);
        work_and_converge(&team, seed);
    }
}

/// Does every board hold `object` with `attr` = `value`?
fn everyone_holds(team: &Team, object: &str, attr: &str, value: &Value) -> Result<(), String> {
    for m in &team.members {
        let held = m.board.read(object, attr).ok().map(|p| p.value);
        if held.as_ref() != Some(value) {
            return Err(format!("{} holds {object}.{attr} = {held:?}", m.address));
        }
    }
    Ok(())
}

#[test]
fn after_its_gateway_dies_a_robot_speaks_through_the_next_one() {
    let (mut team, _) = grid(86, LinkConfig::clean(), 1024, true);
    team.run(2.0);
    let gateway = addr("t/r1/m0");
    team.net.kill(&gateway);
    team.members.retain(|m| m.address != gateway);
    team.run(2.5);
    assert_eq!(team.member("t/r1/m2").ici.gateway(), Some(addr("t/r1/m1")));
    let board = team.board("t/r1/m2");
    board
        .create_with(NewObject::new("Rock", "rock_after").context(Context::Surroundings))
        .unwrap();
    board.write("rock_after", "hits", Value::Int(7)).unwrap();
    team.run(1.0);
    everyone_holds(&team, "rock_after", "hits", &Value::Int(7)).unwrap();
    team.assert_converges(10);
}

#[test]
fn a_restarted_remote_module_is_restarted_on_every_board_and_heard_again() {
    let (mut team, _) = grid(87, LinkConfig::clean(), 1024, true);
    team.run(0.5);
    workload(&team, &mut Rng::new(87), 40, 0.05);
    team.run(1.0);
    // Same address, new incarnation, empty board.
    let member = "t/r1/m2";
    let restarts = |team: &Team| team.member("t/r0/m1").ici.stats().liveliness.restarts;
    let before = restarts(&team);
    team.join_tapped(member, config(2, 1024, true));
    team.run(2.0);
    assert!(
        restarts(&team) > before,
        "the robot hello showed the restart"
    );
    let board = team.board(member);
    board
        .create_with(NewObject::new("Rock", "rock_reborn").context(Context::Surroundings))
        .unwrap();
    board.write("rock_reborn", "hits", Value::Int(3)).unwrap();
    team.run(1.0);
    everyone_holds(&team, "rock_reborn", "hits", &Value::Int(3)).unwrap();
}

#[test]
fn boards_converge_with_duplication() {
    let (team, _) = grid(88, LinkConfig::clean().duplicate(0.5), 1024, true);
    work_and_converge(&team, 88);
    let frames = team.net.stats().kind(LinkKind::Team, MsgKind::TeamFrame);
    assert!(frames.duplicated > 0, "frames were delivered twice");
}

#[test]
fn boards_converge_with_reordering() {
    let (team, _) = grid(89, LinkConfig::clean().jitter(secs(0.5)), 1024, true);
    work_and_converge(&team, 89);
}

#[test]
fn a_changed_interest_is_said_in_the_robot_hello_not_to_each_team_peer() {
    let (team, _) = grid(90, LinkConfig::clean(), 1024, true);
    team.run(2.0);
    let hellos = |team: &Team| {
        team.net
            .stats()
            .kind(LinkKind::Team, MsgKind::RobotHello)
            .sent_msgs
    };
    let per_pair = |team: &Team| {
        team.net
            .stats()
            .kind(LinkKind::Team, MsgKind::Hello)
            .sent_msgs
    };
    let before = (hellos(&team), per_pair(&team));
    let member = team.member("t/r1/m2");
    member
        .ici
        .set_interest(slate_ici::ClassSet::none().class("Rock"));
    team.run(2.0);
    assert_eq!(
        per_pair(&team),
        before.1,
        "no per-pair hello on the team link"
    );
    assert!(
        hellos(&team) > before.0,
        "r1's gateway said its hello again"
    );
}

#[test]
fn a_module_that_never_listens_gets_the_team_through_its_gateway_until_it_is_gateway() {
    let deaf = |priority: u8| {
        let mut protocol = TeamProtocol::radio().priority(Some(priority));
        protocol.listen = slate_ici::Listen::Never;
        open().team_protocol(Some(protocol))
    };
    let sim = SimConfig {
        team: LinkConfig::clean().delay(secs(0.02)),
        ..SimConfig::default()
    };
    let mut team = Team::with(91, sim);
    team.join_tapped("t/r0/m0", config(0, 1024, true));
    team.join_tapped("t/r1/m0", config(0, 1024, true));
    team.join_tapped("t/r1/m1", deaf(1));
    team.run(1.0);
    let rock = NewObject::new("Rock", "rock_r0").context(Context::Surroundings);
    team.board("t/r0/m0").create_with(rock).unwrap();
    team.run(1.0);
    let frames = |team: &Team, m: &str| {
        let stats = team.member(m).ici.stats();
        stats
            .traffic
            .get(&(LinkKind::Team, MsgKind::TeamFrame))
            .map_or(0, |t| t.recv_msgs)
    };
    assert!(frames(&team, "t/r1/m0") > 0);
    assert_eq!(frames(&team, "t/r1/m1"), 0, "it does not listen");
    let forwarded = team.member("t/r1/m0").ici.stats().team.forwarded;
    assert!(forwarded > 0, "its gateway forwarded what it heard");
    let rock = team.board("t/r1/m1").info("rock_r0");
    assert!(rock.is_some(), "it got the rock through its gateway");
    team.net.kill(&addr("t/r1/m0"));
    team.members.retain(|m| m.address != addr("t/r1/m0"));
    team.run(2.0);
    team.board("t/r0/m0")
        .write("rock_r0", "hits", Value::Int(1))
        .unwrap();
    team.run(1.0);
    assert!(frames(&team, "t/r1/m1") > 0, "as gateway it listens");
}

/// What `at` holds of `module`'s liveliness (its `Module` object's `alive`).
fn alive_on(team: &Team, at: &slate_model::Address, module: &str) -> Option<Value> {
    let name = module_object_name(&addr(module));
    let board = &team.members.iter().find(|m| m.address == *at)?.board;
    board.read(&name, "alive").ok().map(|p| p.value)
}

/// A robot's gateway dies; its other modules live. Every other robot holds the gateway
/// dead within 2.5 s and the robot's live modules alive throughout (the robot stays on
/// the team: it loses exactly the gateway's own exports), and a live module's writes
/// keep arriving through the next gateway.
#[test]
fn a_robots_gateway_dies_while_its_other_modules_live() {
    for seed in [88, 89, 90] {
        let (mut team, _) = grid(seed, LinkConfig::clean().loss(0.05), 1024, true);
        team.run(3.0);
        let gateway = addr("t/r1/m0");
        team.net.kill(&gateway);
        team.members.retain(|m| m.address != gateway);
        let remote: Vec<_> = team
            .members
            .iter()
            .map(|m| m.address.clone())
            .filter(|a| a.robot() != "r1")
            .collect();
        for step in 1..=60 {
            team.run(0.1);
            for at in &remote {
                for live in ["t/r1/m1", "t/r1/m2"] {
                    let held = alive_on(&team, at, live);
                    assert_eq!(held, Some(Value::Bool(true)), "{at} on {live}, seed {seed}");
                }
                let dead = alive_on(&team, at, "t/r1/m0");
                if step >= 25 {
                    assert_eq!(dead, Some(Value::Bool(false)), "{at}, seed {seed}");
                }
            }
        }
        let board = team.board("t/r1/m2");
        board
            .create_with(NewObject::new("Rock", "rock_after").context(Context::Surroundings))
            .unwrap();
        board.write("rock_after", "hits", Value::Int(9)).unwrap();
        team.assert_converges(30);
        everyone_holds(&team, "rock_after", "hits", &Value::Int(9)).unwrap();
    }
}

/// A value a member writes as the modules start, before its robot has a gateway, announces
/// the names and the timestamp epoch that its source's later reports are encoded against:
/// every board must hear it, or each refuses the next report and asks the source for its
/// whole state. Its uplink reached the gateway-to-be before that one took the role.
#[test]
fn a_value_written_before_the_streams_start_announces_its_names_to_everyone() {
    let (team, _) = grid(85, LinkConfig::clean(), 1024, true);
    let source = team.board("t/r0/m1");
    let vehicle = NewObject::new("Vehicle", "vehicle_early").context(Context::Self_);
    source.create_with(vehicle).unwrap();
    source.write("vehicle_early", "speed", 1.5).unwrap();
    team.run(3.0);
    source.write("vehicle_early", "speed", 2.5).unwrap();
    team.run(2.0);
    let refused = team.total(|s| s.rejects.decode.rejected());
    let asked = team.total(|s| s.team.state_asked);
    assert_eq!((refused, asked), (0, 0), "messages refused, states asked");
    assert!(everyone_holds(&team, "vehicle_early", "speed", &Value::Real(2.5)).is_ok());
}

/// A console alone on its robot `base` that has created `vehicle_early` and written its
/// speed (1.5) before anyone else joined or any time passed.
fn console_writing_at_start(seed: u64) -> (Team, Arc<slate_model::Board>) {
    let mut team = Team::with(seed, sim(LinkConfig::clean()));
    team.add("t/base/console", config(0, 1024, true));
    let console = team.board("t/base/console").clone();
    let vehicle = NewObject::new("Vehicle", "vehicle_early").context(Context::Self_);
    console.create_with(vehicle).unwrap();
    console.write("vehicle_early", "speed", 1.5).unwrap();
    (team, console)
}

/// Modules that join after a lone robot's stream has begun (a console started before
/// its robots), or with it, learn the names and epoch of what it said before they heard
/// it: its later reports decode on every board.
#[test]
fn modules_that_join_after_or_with_a_lone_robot_decode_its_later_reports() {
    for join_after in [2.0, 0.0] {
        let (mut team, console) = console_writing_at_start(86);
        team.run(join_after);
        for r in 0..2 {
            for m in 0..2 {
                team.add(&format!("t/r{r}/m{m}"), config(m, 1024, true));
            }
        }
        team.run(3.0);
        console.write("vehicle_early", "speed", 2.5).unwrap();
        team.run(2.0);
        let refused = team.total(|s| s.rejects.decode.rejected());
        assert_eq!(refused, 0, "messages refused, joining {join_after} s after");
        let speed = Value::Real(2.5);
        assert!(everyone_holds(&team, "vehicle_early", "speed", &speed).is_ok());
    }
}

/// A lone robot (a console) that writes once and then stays quiet is still alive on every
/// board: its robot heartbeats vouch for it where they are heard, and members that do not
/// listen to the team link (and so hear no other robot) do not take silence for death.
/// When it writes again, its report decodes.
#[test]
fn a_quiet_lone_robot_stays_alive_everywhere_and_its_next_report_decodes() {
    let (mut team, console) = console_writing_at_start(87);
    for r in 0..2 {
        for m in 0..3 {
            let mut c = config(m, 1024, true);
            if m > 0 {
                c.team_protocol.as_mut().unwrap().listen = Listen::Never;
            }
            team.add(&format!("t/r{r}/m{m}"), c);
        }
    }
    team.run(12.0);
    console.write("vehicle_early", "speed", 2.5).unwrap();
    team.run(2.0);
    let lost = team.total(|s| s.liveliness.lost);
    let refused = team.total(|s| s.rejects.decode.rejected());
    assert_eq!((lost, refused), (0, 0), "modules lost, messages refused");
    for gateway in ["t/r0/m0", "t/r1/m0"] {
        let speed = team.board(gateway).read("vehicle_early", "speed");
        assert_eq!(
            speed.map(|p| p.value).ok(),
            Some(Value::Real(2.5)),
            "{gateway}"
        );
    }
}

/// A robot held dead for a while (cut off past the team timeout, its heartbeats queued
/// behind a radio's backlog) and heard again keeps the names its modules announced: their
/// next reports decode, and nobody asks for their whole state for want of them.
#[test]
fn a_robot_heard_again_after_being_held_dead_keeps_its_names() {
    let (mut team, _) = grid(88, LinkConfig::clean(), 1024, true);
    team.add("t/base/console", config(0, 1024, true));
    let console = team.board("t/base/console").clone();
    let vehicle = NewObject::new("Vehicle", "vehicle_early").context(Context::Self_);
    console.create_with(vehicle).unwrap();
    console.write("vehicle_early", "speed", 1.5).unwrap();
    team.run(3.0);
    let others: Vec<_> = team.members.iter().map(|m| m.address.clone()).collect();
    let others: Vec<_> = others.into_iter().filter(|a| a.robot() != "base").collect();
    team.net.partition(&[addr("t/base/console")], &others);
    team.run(12.0);
    assert!(
        team.total(|s| s.liveliness.lost) > 0,
        "held dead while cut off"
    );
    team.net.heal();
    team.run(3.0);
    console.write("vehicle_early", "speed", 2.5).unwrap();
    team.run(2.0);
    let refused = team.total(|s| s.rejects.decode.rejected());
    assert_eq!(refused, 0, "messages refused");
    let speed = Value::Real(2.5);
    assert!(everyone_holds(&team, "vehicle_early", "speed", &speed).is_ok());
}

/// The acoustic preset (`TeamProtocol::acoustic()`: 32-byte frames, 2 s batches, slow
/// NACK and repair timers) for module m{j}, priority j.
fn acoustic_config(module: usize) -> IciConfig {
    let protocol = TeamProtocol::acoustic().priority(Some(module as u8));
    open().team_protocol(Some(protocol))
}

/// Who listens to the team link in [`acoustic_work_converges`].
#[derive(Clone, Copy, PartialEq)]
enum Listeners {
    /// Every module (the preset's `Listen::Auto`), with the default 1 s team heartbeat.
    All,
    /// Each robot's gateway only (`Listen::Never` for the others), with the demo's
    /// 20 s team heartbeat and 90 s timeout.
    Gateways,
}

/// 3 robots × 3 modules with the acoustic preset on `link`: after the random work the
/// boards agree within 900 s. Returns the team.
fn acoustic_work_converges(link: LinkConfig, listeners: Listeners) -> Team {
    let mut team = Team::with(
        90,
        SimConfig {
            robot: LinkConfig::clean().delay(secs(0.0001)),
            team: link,
            ..SimConfig::default()
        },
    );
    for r in 0..3 {
        for m in 0..3 {
            let mut c = acoustic_config(m);
            if listeners == Listeners::Gateways {
                c = c.liveliness(LinkKind::Team, secs(20.0), secs(90.0));
                if m > 0 {
                    c.team_protocol.as_mut().unwrap().listen = Listen::Never;
                }
            }
            team.add(&format!("t/r{r}/m{m}"), c);
        }
    }
    team.run(0.5);
    workload(&team, &mut Rng::new(90), 30, 0.05);
    team.assert_converges(900);
    team
}

/// One shared channel of 32-byte frames at 9600 bit/s (the acoustic channel's shape, a
/// fast rate), 20 ms away.
fn shared_frames() -> LinkConfig {
    LinkConfig::clean()
        .delay(secs(0.02))
        .bandwidth(9600)
        .shared()
        .frames(32, secs(0.25))
}

#[test]
fn the_acoustic_preset_converges_on_a_shared_channel_of_32_byte_frames() {
    let _ = acoustic_work_converges(shared_frames(), Listeners::All);
}

#[test]
fn the_acoustic_preset_converges_at_20_percent_loss_on_whole_messages() {
    let _ = acoustic_work_converges(
        LinkConfig::clean().delay(secs(0.02)).loss(0.2),
        Listeners::All,
    );
}

/// Finding of session 13: with both (a shared channel of 32-byte frames and 20 % loss
/// per frame and receiver) the boards never agree: `x` that r2's gateway wrote never
/// reaches t/r1/m1 in 900 s. Each part alone converges (the two tests above); so does
/// the radio preset with a 32-byte MTU at 20 % loss. In 300 s the gateways made 6 858
/// NACK transmissions against 1 710 team frames, and of 138 robot hellos (73 B, three
/// frames each) 41 arrived: a NACK storm on a half-duplex channel, where a gateway that
/// transmits misses what it would hear. This is why no demo mission completes on
/// `--team-link acoustic` with the robots speaking (docs/demo.md).
///
/// Session 14: state asks no longer go every 3 s (`answer_interval + repair_wait`), but
/// here all nine modules listen, each NACKing for itself, with a 1 s team heartbeat: more
/// than 32-byte frames at this rate carry. With one listener per robot and a 20 s
/// heartbeat it converges (session 15, the test below), once the gateway forwards what
/// it hears to the members that do not listen.
#[test]
#[ignore = "finding: the acoustic preset does not converge on a lossy shared framed channel (docs/demo.md, the narrow channel)"]
fn the_acoustic_preset_converges_on_a_lossy_shared_channel_of_32_byte_frames() {
    let _ = acoustic_work_converges(shared_frames().loss(0.2), Listeners::All);
}

/// One listener per robot on the lossy shared framed channel (a 20 s team heartbeat):
/// the members that do not listen get the other robots' streams from their gateway
/// (`Forward`), and leave the NACKs to it. Before the gateway forwarded, they got
/// nothing of the other robots but the class values of robot-link catch-ups: 140
/// disagreements after 900 s.
#[test]
fn one_listener_per_robot_converges_on_a_lossy_shared_channel_of_32_byte_frames() {
    let team = acoustic_work_converges(shared_frames().loss(0.2), Listeners::Gateways);
    let stats = team.net.stats();
    let members: Vec<String> = stats
        .radios
        .iter()
        .filter(|((_, link), radio)| *link == LinkKind::Team && radio.msgs > 0)
        .map(|((from, _), _)| from.to_string())
        .filter(|from| !from.ends_with("/m0"))
        .collect();
    assert_eq!(
        members,
        Vec::<String>::new(),
        "members sent on the team link"
    );
}
