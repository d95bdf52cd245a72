//! A module that restarts with its board restored (a node's `state`): its hello tells a
//! new incarnation, its peers ask it for its current state, and the object list it
//! answers holds what it owned, so the catch-up is a difference, not a wipe. The same
//! restart with an empty board sweeps the objects it had created at run time.

use std::sync::Arc;

use slate_model::{Board, MODULE_CLASS, NewObject, PLAN_CLASS, Packet};

use crate::support::{Team, addr, classes, open};

const NAV: &str = "t/r1/nav";
const PEERS: [&str; 2] = ["t/r1/cam", "t/r2/loco"];

/// A board as a store hands it back: objects, and `(object, attribute, packet)`.
type Kept = (Vec<NewObject>, Vec<(String, String, Packet)>);

/// What a store keeps of `board`: its objects (not liveliness nor plans) and their own
/// packets, as a node's `state` directory would hand them back.
fn kept(board: &Board) -> Kept {
    let snap = board.snapshot();
    let mut objects = Vec::new();
    let mut packets = Vec::new();
    for id in snap.objects() {
        let Some(info) = snap.info(id).filter(|i| !i.is_class) else {
            continue;
        };
        if &*info.class == MODULE_CLASS || &*info.class == PLAN_CLASS {
            continue;
        }
        objects.push(
            NewObject::new(&info.class, &info.name)
                .context(info.context)
                .owner(info.owner.clone()),
        );
        for (attr, p, _) in snap.own_values(id) {
            packets.push((info.name.to_string(), attr.to_string(), p));
        }
    }
    (objects, packets)
}

/// Restarts nav on the same address: a new board (restored from `kept` if given) and a
/// new ICI, which joins after the restore, as a node starts.
fn restart_nav(team: &mut Team, restored: Option<&Kept>) {
    let address = addr(NAV);
    team.net.kill(&address);
    team.run(0.3);
    let board: Arc<Board> = team.board_at(&address, &classes());
    if let Some((objects, packets)) = restored {
        for o in objects {
            board.create_with(o.clone()).unwrap();
        }
        for r in board.merge_all(packets.iter().cloned()) {
            r.unwrap();
        }
    }
    team.join(board, open());
}

/// nav creates `probe` at run time and writes it; every peer holds it.
fn team_with_probe() -> Team {
    let mut team = Team::new(18);
    team.add(NAV, open());
    for p in PEERS {
        team.add(p, open());
    }
    team.run(1.0);
    let nav = team.board(NAV);
    nav.create_with(NewObject::new("Vehicle", "probe")).unwrap();
    nav.write("probe", "speed", 4.5).unwrap();
    team.run(1.0);
    for p in PEERS {
        assert!(
            team.board(p).info("probe").is_some(),
            "{p} holds nav's object"
        );
    }
    team
}

fn stamp_on(team: &Team, at: &str) -> Option<slate_model::Timestamp> {
    Some(team.board(at).read("probe", "speed").ok()?.timestamp)
}

#[test]
fn a_module_restarted_with_its_board_keeps_its_objects_on_every_peer() {
    let mut team = team_with_probe();
    let before = stamp_on(&team, PEERS[0]);
    let state = kept(team.board(NAV));
    restart_nav(&mut team, Some(&state));
    team.run(3.0);
    let restarts: u64 = team.total(|s| s.liveliness.restarts);
    assert!(restarts >= 1, "the peers saw a new incarnation");
    for p in PEERS {
        assert_eq!(
            stamp_on(&team, p),
            before,
            "{p} kept nav's packet as it was"
        );
    }
    // The new incarnation's writes are its own, not late messages of the old one.
    team.board(NAV).write("probe", "speed", 6.0).unwrap();
    team.assert_converges(10);
    for p in PEERS {
        let speed = team.board(p).read("probe", "speed").unwrap().value;
        assert_eq!(speed.as_f64(), Some(6.0), "{p}");
    }
}

#[test]
fn a_module_restarted_empty_has_its_run_time_objects_swept_from_its_peers() {
    let mut team = team_with_probe();
    restart_nav(&mut team, None);
    team.run(3.0);
    for p in PEERS {
        assert!(
            team.board(p).info("probe").is_none(),
            "{p} swept nav's object"
        );
    }
}
