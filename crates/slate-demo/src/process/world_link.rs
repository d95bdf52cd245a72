//! The physical world as a module: the world simulator writes what moves (bodies,
//! targets, the world's time) on the board of `gsr-world/world/sim`, a module of a team
//! of its own, and each driver keeps a replica of the world from that board; locomotion
//! writes its command there, and the world applies it. The world reaches the drivers,
//! and the drivers the world, only through slate.
//!
//! The world team is not the mission's: none of its traffic is on the mission's links or
//! in its counters. What does not move (terrain, obstacles, routes) every process draws
//! from the seed, as the simulator does ([`Layout::generate`](crate::world::Layout)).

use std::sync::Arc;

use slate_model::{Address, Board, Update};

use crate::drivers::Sbip;
use crate::world::World;

/// The world's team: separate from the mission's (`team`).
pub const WORLD_TEAM: &str = "gsr-world";

/// The world's classes: what moves, and the commands that move it.
pub const WORLD_CLASSES: &str = "\
// The physical world of `slate demo --network processes` (docs/demo.md).
class Clock { time: real [s]; }
class Body {
    position: vec<2> [m];
    heading: real [rad];
    speed: real [m/s];
    odometer: real [m];
    powered: bool = true;
}
class Truth { position: vec<2> [m]; }
class Command { speed: real [m/s]; turn: real [rad/s]; }
";

/// The world simulator's module address, `gsr-world/world/sim`.
pub fn world_address() -> Address {
    Address::new(&format!("{WORLD_TEAM}/world/sim")).unwrap_or_else(|_| Address::unknown())
}

/// The address on the world team of a driver of `robot`'s module `role`.
pub fn reader_address(robot: &str, role: &str) -> Address {
    Address::new(&format!("{WORLD_TEAM}/{robot}/{role}")).unwrap_or_else(|_| Address::unknown())
}

/// The object of robot `name`'s body on the world board.
fn body(name: &str) -> String {
    format!("body_{name}")
}

/// The object of robot `name`'s locomotion command on the world board.
fn command(name: &str) -> String {
    format!("command_{name}")
}

/// The object of target `id`'s true position on the world board.
fn truth(id: &str) -> String {
    format!("truth_{id}")
}

/// Writes what moves in `world` on the world module's board (through `sbip`).
pub(crate) fn publish(world: &World, sbip: &mut Sbip) {
    sbip.write_object("Clock", "clock", &[("time", Update::new(world.time))]);
    for b in &world.bodies {
        let writes = [
            ("position", Update::new(b.pos.to_vec())),
            ("heading", Update::new(b.heading)),
            ("speed", Update::new(b.speed)),
            ("odometer", Update::new(b.odometer)),
            ("powered", Update::new(b.powered)),
        ];
        sbip.write_object("Body", &body(&b.name), &writes);
    }
    for t in &world.targets {
        let writes = [("position", Update::new(t.pos.to_vec()))];
        sbip.write_object("Truth", &truth(&t.id), &writes);
    }
}

/// Gives every powered body the last command its locomotion wrote on `board`.
pub(crate) fn apply_commands(world: &mut World, board: &Arc<Board>) {
    let reader = Sbip::new(board.clone());
    for i in 0..world.bodies.len() {
        let name = command(&world.bodies[i].name);
        let (Some(speed), Some(turn)) = (reader.real(&name, "speed"), reader.real(&name, "turn"))
        else {
            continue;
        };
        if world.bodies[i].powered {
            world.command(i, speed, turn);
        }
    }
}

/// Brings `replica` up to what the world board says; false until the board has heard
/// the world's time (the replica is then as the seed drew it).
pub(crate) fn mirror(replica: &mut World, board: &Arc<Board>) -> bool {
    let reader = Sbip::new(board.clone());
    let Some(time) = reader.real("clock", "time") else {
        return false;
    };
    replica.time = time;
    for b in &mut replica.bodies {
        let name = body(&b.name);
        if let Some((pos, _)) = reader.point(&name, "position") {
            b.pos = pos;
        }
        b.heading = reader.real(&name, "heading").unwrap_or(b.heading);
        b.speed = reader.real(&name, "speed").unwrap_or(b.speed);
        b.odometer = reader.real(&name, "odometer").unwrap_or(b.odometer);
        b.powered = reader.packet(&name, "powered").is_none() || reader.flag(&name, "powered");
    }
    for t in &mut replica.targets {
        if let Some((pos, _)) = reader.point(&truth(&t.id), "position") {
            t.pos = pos;
        }
    }
    true
}

/// Writes robot `robot`'s command, as its locomotion gave it to `replica`, on the
/// driver's world board (through `sbip`).
pub(crate) fn publish_command(replica: &World, robot: usize, sbip: &mut Sbip) {
    let Some(b) = replica.bodies.get(robot) else {
        return;
    };
    let writes = [
        ("speed", Update::new(b.command.0)),
        ("turn", Update::new(b.command.1)),
    ];
    sbip.write_object("Command", &command(&b.name), &writes);
}

#[cfg(test)]
mod tests {
    use slate_ici::SimNet;
    use slate_node::Node;

    use super::*;
    use crate::world::Layout;

    /// A board with the world's classes (a node alone on a simulated network).
    fn board(address: Address) -> Arc<Board> {
        let net = SimNet::new(1);
        let node = Node::builder(address.clone())
            .transport(net.join(&address))
            .clock(net.clock())
            .source("world.slate", WORLD_CLASSES)
            .start()
            .expect("the world's classes load");
        node.board().clone()
    }

    #[test]
    fn a_replica_mirrors_the_world_it_reads_from_the_world_board() {
        let layout = Layout::generate(7, 3);
        let mut world = World::new(&layout, 7);
        world.command(0, 2.0, 0.3);
        for _ in 0..30 {
            world.step(0.1);
        }
        let sim = board(world_address());
        publish(&world, &mut Sbip::new(sim.clone()));
        let mut replica = World::new(&layout, 7);
        assert!(mirror(&mut replica, &sim));
        assert_eq!(replica.time, world.time);
        for (r, w) in replica.bodies.iter().zip(&world.bodies) {
            assert_eq!(
                (r.pos, r.heading, r.odometer),
                (w.pos, w.heading, w.odometer)
            );
        }
        for (r, w) in replica.targets.iter().zip(&world.targets) {
            assert_eq!(r.pos, w.pos);
        }
    }

    #[test]
    fn a_replica_waits_for_the_worlds_time_before_it_is_believed() {
        let layout = Layout::generate(7, 2);
        let mut replica = World::new(&layout, 7);
        assert!(!mirror(&mut replica, &board(world_address())));
    }

    #[test]
    fn a_command_written_by_locomotion_moves_the_body_of_the_world() {
        let layout = Layout::generate(7, 2);
        let mut replica = World::new(&layout, 7);
        replica.command(1, 1.5, -0.2);
        let shared = board(reader_address("r2", "loco"));
        publish_command(&replica, 1, &mut Sbip::new(shared.clone()));
        let mut world = World::new(&layout, 7);
        apply_commands(&mut world, &shared);
        assert_eq!(world.bodies[1].command, (1.5, -0.2));
        assert_eq!(world.bodies[0].command, (0.0, 0.0));
        world.power_off(1);
        world.bodies[1].command = (0.0, 0.0);
        apply_commands(&mut world, &shared);
        assert_eq!(
            world.bodies[1].command,
            (0.0, 0.0),
            "a dead body takes no command"
        );
    }
}
