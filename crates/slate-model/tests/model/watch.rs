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

/// Two threads, each writing one of `g` and `h` `writes` times.
fn two_writers(b: &Arc<slate_model::Board>, writes: u64) -> Vec<thread::JoinHandle<()>> {
    ["g", "h"]
        .into_iter()
        .map(|name| {
            let b = b.clone();
            thread::spawn(move || {
                for i in 0..writes {
                    b.write(name, "speed", (i % 40) as f64).unwrap();
                }
            })
        })
        .collect()
}

/// A recorder's or a store's watch: the reader takes every waiting item at once, each
/// with its change's revision, in order; a change that does not fit whole is dropped and
/// counted, and the writes all commit.
#[test]
fn a_gathered_watch_hands_over_every_waiting_item_with_its_revision_and_drops_what_does_not_fit() {
    let b = board();
    b.create("Gsr", "g").unwrap();
    let w = b.watch_gathered(Filter::all(), 4).unwrap();
    assert!(!w.wait(Duration::from_millis(1)), "nothing waits yet");
    let first = b.write("g", "speed", 1.0).unwrap();
    let mut batch = b.batch();
    batch.write("g", "speed", 2.0).create("Gsr", "h");
    let second = batch.commit().unwrap();
    assert!(w.wait(Duration::ZERO));
    assert_eq!(w.pending(), 3);
    // A batch of two does not fit in the one place left: dropped whole.
    let mut batch = b.batch();
    batch.write("g", "speed", 3.0).write("h", "speed", 3.0);
    batch.commit().unwrap();
    assert_eq!(w.dropped(), 1);
    let mut taken = Vec::new();
    assert_eq!(w.take(&mut taken), 3);
    let got: Vec<(u64, String)> = taken
        .iter()
        .map(|(revision, item)| {
            let change = slate_model::Change {
                revision: *revision,
                items: vec![item.clone()],
            };
            (*revision, writes(&change).concat())
        })
        .collect();
    assert_eq!(
        got,
        [
            (first, "g.speed".to_owned()),
            (second, "g.speed".to_owned()),
            (second, "+h".to_owned())
        ]
    );
    assert_eq!(w.pending(), 0, "taken whole");
    b.write("g", "speed", 4.0).unwrap();
    taken.clear();
    assert_eq!(w.take(&mut taken), 1, "room again once taken");
    // A reader gone: the writes go on (the board forgets it at the next change).
    drop(w);
    b.write("g", "speed", 5.0).unwrap();
}

/// A reader asleep on an empty gathered watch (for an hour: nothing wakes it but a
/// writer) is woken by each write: the writer waits until the reader has taken its item
/// before the next, so the reader is asleep again each time. A lost wake-up would leave
/// the writer waiting.
#[test]
fn a_reader_asleep_on_a_gathered_watch_is_woken_by_each_write() {
    const WRITES: usize = 200;
    let b = Arc::new(board());
    b.create("Gsr", "g").unwrap();
    let w = b.watch_gathered(Filter::all(), 1024).unwrap();
    let (tx, rx) = crossbeam_channel::unbounded();
    let reader = thread::spawn(move || {
        let mut taken = Vec::new();
        for _ in 0..WRITES {
            while !w.wait(Duration::from_secs(3600)) {}
            taken.clear();
            tx.send(w.take(&mut taken)).unwrap();
        }
    });
    for i in 0..WRITES {
        b.write("g", "speed", (i % 40) as f64).unwrap();
        let got = rx.recv_timeout(Duration::from_secs(10));
        assert_eq!(got, Ok(1), "write {i} woke the reader");
    }
    reader.join().unwrap();
}

/// A reader blocked on `recv` gets what is left, then `None`, once the board is gone.
#[test]
fn a_waiting_reader_gets_what_is_left_then_none_when_the_board_is_dropped() {
    let b = with_vehicle();
    let w = b.watch(Filter::all()).unwrap();
    b.write("v", "speed", 1.0).unwrap();
    let reader = thread::spawn(move || {
        let first = w.recv().map(|c| writes(&c));
        let second = w.recv().map(|c| writes(&c));
        (first, second)
    });
    thread::sleep(Duration::from_millis(50));
    drop(b);
    let (first, second) = reader.join().unwrap();
    assert_eq!(first, Some(vec!["v.speed".to_owned()]));
    assert_eq!(second, None);
}

/// Two writers and a reader that waits, each on its own thread: every change arrives once,
/// in revision order, or is counted as dropped; no wake-up is lost (the reader would
/// wait for ever).
#[test]
fn changes_from_two_writer_threads_all_reach_a_waiting_reader_in_revision_order() {
    const WRITES: u64 = 20_000;
    for capacity in [None, Some(64)] {
        let b = Arc::new(board());
        b.create("Gsr", "g").unwrap();
        b.create("Gsr", "h").unwrap();
        let w = match capacity {
            None => b.watch(Filter::all()).unwrap(),
            Some(n) => b.watch_bounded(Filter::all(), n).unwrap(),
        };
        let writers = two_writers(&b, WRITES);
        let total = 2 * WRITES;
        let (mut seen, mut last) = (0, 0);
        while seen + w.dropped() < total {
            let c = w
                .recv_timeout(Duration::from_secs(10))
                .expect("a change within 10 s");
            assert!(c.revision > last, "{} after {last}", c.revision);
            last = c.revision;
            seen += 1;
        }
        writers.into_iter().for_each(|t| t.join().unwrap());
        assert_eq!(w.try_recv(), None, "nothing beyond the writes");
        assert_eq!(seen + w.dropped(), total, "capacity {capacity:?}");
        if capacity.is_none() {
            assert_eq!(w.dropped(), 0);
        }
    }
}

/// The same with a gathered watch: every item arrives once, in revision order, or its
/// change is counted as dropped; a reader waiting on an empty buffer is always woken.
#[test]
fn changes_from_two_writer_threads_all_reach_a_waiting_gathered_reader_in_revision_order() {
    const WRITES: u64 = 20_000;
    for capacity in [1 << 20, 64] {
        let b = Arc::new(board());
        b.create("Gsr", "g").unwrap();
        b.create("Gsr", "h").unwrap();
        let w = b.watch_gathered(Filter::all(), capacity).unwrap();
        let writers = two_writers(&b, WRITES);
        let total = 2 * WRITES;
        let (mut seen, mut last, mut taken) = (0, 0, Vec::new());
        while seen + w.dropped() < total {
            assert!(w.wait(Duration::from_secs(10)), "an item within 10 s");
            w.take(&mut taken);
            for (revision, _) in taken.drain(..) {
                assert!(revision > last, "{revision} after {last}");
                last = revision;
                seen += 1;
            }
        }
        writers.into_iter().for_each(|t| t.join().unwrap());
        assert_eq!(w.pending(), 0, "nothing beyond the writes");
        assert_eq!(seen + w.dropped(), total, "capacity {capacity}");
        if capacity > total as usize {
            assert_eq!(w.dropped(), 0);
        }
    }
}

/// A reader asleep in `recv` (no timeout: nothing wakes it but a writer) gets each change
/// as it is written: the writer waits until the reader has seen its write before the
/// next, so the reader is asleep again each time. A lost wake-up would leave the writer
/// waiting.
#[test]
fn a_reader_asleep_in_recv_is_woken_by_each_write() {
    let b = Arc::new(with_vehicle());
    let w = b.watch(Filter::all()).unwrap();
    let cursor = w.cursor();
    let reader = thread::spawn(move || {
        (0..20)
            .map(|_| w.recv().map(|c| c.revision))
            .collect::<Vec<_>>()
    });
    let mut revs = Vec::new();
    for i in 0..20 {
        thread::sleep(Duration::from_millis(5));
        let rev = b.write("v", "speed", f64::from(i)).unwrap();
        assert!(
            cursor.wait_for(rev, Duration::from_secs(10)),
            "the reader did not get write {i}"
        );
        revs.push(Some(rev));
    }
    assert_eq!(reader.join().unwrap(), revs);
}

/// A reader that keeps up with a writer writing flat out gets every change once, in
/// order, each with its own items.
#[test]
fn a_reader_keeping_up_with_a_fast_writer_gets_every_change_in_order() {
    const WRITES: u32 = 50_000;
    let b = Arc::new(with_vehicle());
    let w = b.watch(Filter::all()).unwrap();
    let reader = thread::spawn(move || {
        let mut values = Vec::new();
        while values.len() < WRITES as usize {
            let c = w.recv_timeout(Duration::from_secs(10)).expect("a change");
            for item in c.items {
                if let ChangeItem::Write { packet, .. } = item {
                    values.push(packet.value);
                }
            }
        }
        (values, w.try_recv())
    });
    for i in 0..WRITES {
        b.write("v", "speed", f64::from(i % 40)).unwrap();
    }
    let (values, more) = reader.join().unwrap();
    let expected: Vec<slate_model::Value> = (0..WRITES)
        .map(|i| slate_model::Value::Real(f64::from(i % 40)))
        .collect();
    assert!(values == expected, "changes lost, repeated or out of order");
    assert_eq!(more, None);
}

#[test]
fn a_change_of_one_write_holds_a_list_of_exactly_one() {
    // A longer list (four items, the first growth of a `Vec`) is a block of about 400
    // bytes; freed by the reader in its own thread, blocks that large let the heap shrink,
    // and the writer faulted fresh pages in at every few writes (docs/performance.md).
    let b = board();
    b.create("Gsr", "g").unwrap();
    let one = b.watch(Filter::all()).unwrap();
    let other = b.watch(Filter::all()).unwrap();
    b.write("g", "speed", 1.0).unwrap();
    for w in [&one, &other] {
        let change = w.try_recv().unwrap();
        assert_eq!(writes(&change), ["g.speed"]);
        assert_eq!(change.items.capacity(), 1);
    }
    let mut batch = b.batch();
    batch.write("g", "speed", 2.0).write("g", "mode", "go");
    batch.commit().unwrap();
    assert_eq!(drain(&one), ["g.speed", "g.mode"]);
}
