use std::sync::Arc;
use std::thread;
use std::time::Duration;

use slate_model::{ChangeItem, Filter, LookupError};

use crate::support::{board, with_vehicle};

fn writes(change: &slate_model::Change) -> Vec<String> {
    change
        .items
        .iter()
        .map(|i| match i {
            ChangeItem::Write { object, attr, .. } => format!("{object}.{attr}"),
            ChangeItem::Create { object, .. } => format!("+{object}"),
            ChangeItem::Delete { object, .. } => format!("-{object}"),
        })
        .collect()
}

fn drain(w: &slate_model::Watch) -> Vec<String> {
    std::iter::from_fn(|| w.try_recv())
        .flat_map(|c| writes(&c))
        .collect()
}

#[test]
fn watch_an_object_a_class_or_an_attribute() {
    let b = board();
    b.create("Gsr", "g").unwrap();
    b.create("Obstacle", "rock").unwrap();
    let on_g = b.watch(Filter::object("g")).unwrap();
    let on_ground = b.watch(Filter::class("GroundVehicle")).unwrap();
    let on_speed = b.watch(Filter::attribute("speed")).unwrap();
    let on_g_speed = b.watch(Filter::object("g").attr("speed")).unwrap();
    b.write("g", "speed", 1.0).unwrap();
    b.write("g", "mode", "go").unwrap();
    b.write("rock", "range", 2.0).unwrap();
    b.write("Vehicle", "speed", 3.0).unwrap(); // class-level, above g's class
    b.create("Vehicle", "car").unwrap();
    b.write("car", "speed", 4.0).unwrap();
    assert_eq!(drain(&on_g), ["g.speed", "g.mode", "Vehicle.speed"]);
    assert_eq!(drain(&on_ground), ["g.speed", "g.mode"]);
    assert_eq!(
        drain(&on_speed),
        ["g.speed", "Vehicle.speed", "+car", "car.speed"]
    );
    assert_eq!(drain(&on_g_speed), ["g.speed", "Vehicle.speed"]);
}

#[test]
fn watching_unknown_names_is_an_error() {
    let b = board();
    assert!(matches!(
        b.watch(Filter::object("ghost")),
        Err(LookupError::UnknownObject(_))
    ));
    assert!(matches!(
        b.watch(Filter::class("Ghost")),
        Err(LookupError::UnknownClass(_))
    ));
    assert!(matches!(
        b.watch(Filter::attribute("ghostliness")),
        Err(LookupError::UnknownAttribute { .. })
    ));
}

#[test]
fn notifications_arrive_in_revision_order_with_revisions() {
    let b = with_vehicle();
    let w = b.watch(Filter::object("v")).unwrap();
    let revs: Vec<u64> = (0..10)
        .map(|i| b.write("v", "wheels", i).unwrap())
        .collect();
    let seen: Vec<u64> = std::iter::from_fn(|| w.try_recv())
        .map(|c| c.revision)
        .collect();
    assert_eq!(seen, revs);
}

#[test]
fn a_writer_can_wait_until_a_reader_has_seen_its_write() {
    let b = Arc::new(board());
    b.create("Vehicle", "v").unwrap();
    let watch = b.watch(Filter::object("v")).unwrap();
    let cursor = watch.cursor();
    let reader = thread::spawn(move || {
        let mut last = 0.0;
        for change in watch {
            if let Some(ChangeItem::Write { packet, .. }) = change.items.last() {
                last = packet.value.as_f64().unwrap_or(last);
                if last >= 9.0 {
                    break;
                }
            }
        }
        last
    });
    let mut rev = 0;
    for i in 0..10 {
        rev = b.write("v", "speed", f64::from(i)).unwrap();
    }
    assert!(
        cursor.wait_for(rev, Duration::from_secs(10)),
        "the reader saw revision {rev}"
    );
    assert!(cursor.seen() >= rev);
    assert_eq!(reader.join().unwrap(), 9.0);
    assert!(
        !cursor.wait_for(rev + 100, Duration::from_millis(10)),
        "a revision nobody wrote is never seen"
    );
}

#[test]
fn dropping_a_watch_unsubscribes() {
    let b = with_vehicle();
    let w = b.watch(Filter::all()).unwrap();
    drop(w);
    b.write("v", "speed", 1.0).unwrap(); // must not fail or block on the dropped receiver
    let w2 = b.watch(Filter::all()).unwrap();
    b.write("v", "speed", 2.0).unwrap();
    assert_eq!(w2.pending(), 1);
}

#[test]
fn deletions_reach_object_watchers() {
    let b = board();
    b.create("Obstacle", "rock").unwrap();
    let w = b.watch(Filter::object("rock")).unwrap();
    b.delete("rock").unwrap();
    assert_eq!(drain(&w), ["-rock"]);
}

/// A recorder's watch must never hold a writer up: when its reader falls behind, the
/// changes that do not fit are dropped and counted, and the writes all commit.
#[test]
fn a_bounded_watch_drops_and_counts_what_does_not_fit_and_never_blocks_the_writer() {
    let b = board();
    b.create("Gsr", "g").unwrap();
    let slow = b.watch_bounded(Filter::all(), 4).unwrap();
    for i in 0..10 {
        b.write("g", "speed", f64::from(i)).unwrap();
    }
    assert_eq!(slow.dropped(), 6);
    let kept = drain(&slow);
    assert_eq!(kept, ["g.speed"; 4]);
    b.write("g", "speed", 11.0).unwrap();
    assert_eq!(drain(&slow), ["g.speed"]);
    assert_eq!(slow.dropped(), 6, "a drained watch has room again");
    let unbounded = b.watch(Filter::all()).unwrap();
    assert_eq!(unbounded.dropped(), 0);
}
