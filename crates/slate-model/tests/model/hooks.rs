use std::sync::Arc;

use parking_lot_free::Recorder;
use slate_model::{Board, ChangeHook, TouchKind, Touched};

use crate::support::{board, with_vehicle};

/// Records every call: (revision, touched).
mod parking_lot_free {
    use std::sync::Mutex;

    use slate_model::Touched;

    #[derive(Default)]
    pub struct Recorder(pub Mutex<Vec<(u64, Vec<Touched>)>>);
}

impl ChangeHook for Recorder {
    fn changed(&self, _board: &Board, revision: u64, touched: &[Touched]) {
        self.0.lock().unwrap().push((revision, touched.to_vec()));
    }
}

#[test]
fn hooks_see_every_revision_with_what_it_touched() {
    let b = board();
    let rec = Arc::new(Recorder::default());
    b.add_hook(rec.clone());
    let gsr = b.create("Gsr", "g").unwrap();
    let r1 = b.write("g", "speed", 1.0).unwrap();
    let mut batch = b.batch();
    batch.write("g", "mode", "go").create("Obstacle", "rock");
    let r2 = batch.commit().unwrap();
    b.delete("rock").unwrap();
    b.write("Vehicle", "speed", 2.0).unwrap();
    let calls = rec.0.lock().unwrap().clone();
    assert_eq!(calls.len(), 5);
    let gsr_class = b.info("Gsr").unwrap().id;
    let speed = b.attr_id("speed").unwrap();
    assert_eq!(
        calls[0].1,
        [Touched {
            object: gsr,
            class: gsr_class,
            attr: None,
            kind: TouchKind::Create
        }]
    );
    assert_eq!(
        calls[1],
        (
            r1,
            vec![Touched {
                object: gsr,
                class: gsr_class,
                attr: Some(speed),
                kind: TouchKind::Write
            }]
        )
    );
    assert_eq!(calls[2].0, r2);
    assert_eq!(
        calls[2].1.iter().map(|t| t.kind).collect::<Vec<_>>(),
        [TouchKind::Write, TouchKind::Create]
    );
    assert_eq!(calls[3].1[0].kind, TouchKind::Delete);
    let vehicle = b.info("Vehicle").unwrap().id;
    assert_eq!(
        calls[4].1[0].class, vehicle,
        "a class-level write names the class itself"
    );
    assert_eq!(
        b.lineage(gsr).len(),
        4,
        "Gsr, GroundVehicle, Vehicle, Thing"
    );
}

#[test]
fn a_failed_write_or_batch_calls_no_hook() {
    let b = board();
    let rec = Arc::new(Recorder::default());
    b.create("Vehicle", "v").unwrap();
    b.add_hook(rec.clone());
    assert!(b.write("v", "speed", -1.0).is_err());
    let mut batch = b.batch();
    batch.write("v", "speed", 1.0).write("v", "speed", "fast");
    assert!(batch.commit().is_err());
    assert!(rec.0.lock().unwrap().is_empty());
}

/// A hook that writes to the board: its writes are later revisions, seen by it again.
struct Echo;

impl ChangeHook for Echo {
    fn changed(&self, board: &Board, _revision: u64, touched: &[Touched]) {
        let speed = board.attr_id("speed");
        if touched.iter().any(|t| t.attr == speed && t.attr.is_some()) {
            let v = board.read("v", "speed").unwrap().value.as_f64().unwrap();
            board.write("v", "wheels", v as i64).unwrap();
        }
    }
}

#[test]
fn hooks_may_write_the_board() {
    let b = with_vehicle();
    b.add_hook(Arc::new(Echo));
    b.write("v", "speed", 6.0).unwrap();
    assert_eq!(
        b.read("v", "wheels").unwrap().value,
        slate_model::Value::Int(6)
    );
}

/// A hook that writes `v.speed` once, when `v.wheels` changes.
struct SpeedFromWheels;

impl ChangeHook for SpeedFromWheels {
    fn changed(&self, board: &Board, _revision: u64, touched: &[Touched]) {
        let wheels = board.attr_id("wheels");
        if touched.iter().any(|t| t.attr == wheels && t.attr.is_some()) {
            board.write("v", "speed", 9.0).unwrap();
        }
    }
}

#[test]
fn a_hook_called_inside_an_active_function_starts_its_own_chain() {
    let b = with_vehicle();
    // speed's function writes wheels; the hook then writes speed: not a cycle of
    // active functions (a hook bounds its own recursion).
    b.on_write("Vehicle", "speed", |call| {
        if call.packet().value.as_f64() == Some(1.0) {
            call.write("v", "wheels", 4)?;
        }
        Ok(())
    })
    .unwrap();
    b.add_hook(Arc::new(SpeedFromWheels));
    b.write("v", "speed", 1.0).unwrap();
    assert_eq!(b.read("v", "speed").unwrap().value.as_f64(), Some(9.0));
    assert_eq!(b.stats().chain_cuts, 0);
}
