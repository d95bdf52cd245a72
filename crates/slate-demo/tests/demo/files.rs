//! The demo's `.slate` files: they load where they are meant to, and every plan the
//! console sends (and every sub-plan those send) loads on its destination's board.

use std::sync::Arc;

use slate_demo::files::{self, ALL, CLASSES, CONSOLE, EXEC, MISSION, ROBOT_OBJECTS, sent_plans};
use slate_model::{Address, Board, Clock};
use slate_plans::Engine;

/// A board with the ICI's `Module` class, and its engine (which holds the board weakly:
/// keep both).
fn board(address: &str) -> (Arc<Board>, Engine) {
    let board = Arc::new(
        Board::builder()
            .clock(Clock::manual())
            .address(Address::new(address).unwrap())
            .build(),
    );
    board.define(slate_ici::module_class()).unwrap();
    let engine = Engine::new(&board);
    (board, engine)
}

fn load(engine: &Engine, file: files::SlateFile, robot: &str) {
    if let Err(e) = engine.load(&file.label(robot), &file.for_robot(robot).unwrap()) {
        panic!("{}", e.rendered);
    }
}

#[test]
fn every_file_checks_as_written_in_order() {
    let (_board, engine) = board("team/ROBOT/exec");
    for file in ALL {
        if let Err(e) = engine.load(file.name, file.source) {
            panic!("{}", e.rendered);
        }
    }
}

#[test]
fn every_plan_the_console_sends_loads_on_its_destination() {
    let (_board, console) = board("team/base/console");
    load(&console, CLASSES, "r2");
    load(&console, MISSION, "r2");
    load(&console, CONSOLE, "r2");
    let sent = sent_plans(&MISSION.for_robot("r2").unwrap());
    assert_eq!(sent.len(), 11, "{sent:#?}");
    for plan in sent {
        let (_board, destination) = board(&plan.to);
        load(&destination, CLASSES, "r2");
        load(&destination, ROBOT_OBJECTS, "r2");
        if plan.to.ends_with("/exec") {
            load(&destination, EXEC, "r2");
        }
        if let Err(e) = destination.load(&plan.name, &plan.text) {
            panic!(
                "{} does not load on {}:\n{}",
                plan.name, plan.to, e.rendered
            );
        }
    }
}

#[test]
fn the_sent_plans_carry_no_comments_once_terse() {
    let terse = files::terse(&MISSION.for_robot("r1").unwrap());
    for plan in sent_plans(&terse) {
        assert!(
            !plan.text.contains("//") && !plan.text.contains('\n'),
            "{}",
            plan.text
        );
    }
    assert!(
        terse.len() * 2 < MISSION.source.len(),
        "terse should at least halve it"
    );
}
