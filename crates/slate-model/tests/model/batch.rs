use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread;

use slate_model::{BatchError, ChangeItem, Filter, ReadError, Update, Value, WriteError};

use crate::support::{board, with_vehicle};

#[test]
fn a_failing_batch_applies_nothing() {
    let b = with_vehicle();
    b.write("v", "speed", 1.0).unwrap();
    let rev = b.revision();
    let mut batch = b.batch();
    batch
        .write("v", "speed", 2.0)
        .create("Obstacle", "rock")
        .write("rock", "range", 5.0)
        .delete("v")
        .write("v", "speed", 3.0); // v was deleted above: this fails
    match batch.commit() {
        Err(BatchError::Write {
            index: 4,
            source: WriteError::UnknownObject(o),
        }) => assert_eq!(o, "v"),
        other => panic!("{other:?}"),
    }
    assert_eq!(b.revision(), rev);
    assert_eq!(b.read("v", "speed").unwrap().value.as_f64(), Some(1.0));
    assert!(matches!(
        b.read("rock", "range"),
        Err(ReadError::UnknownObject(_))
    ));
    assert_eq!(b.instances("Obstacle").unwrap().len(), 0);
    // The rolled-back names and handles still work normally.
    let k = b.key("v", "speed").unwrap();
    b.write_key(k, 4.0).unwrap();
    b.create("Obstacle", "rock").unwrap();
}

#[test]
fn a_batch_is_one_revision_and_one_notification() {
    let b = with_vehicle();
    let watch = b.watch(Filter::all()).unwrap();
    let rev = b.revision();
    let mut batch = b.batch();
    batch
        .write("v", "speed", 2.0)
        .write("v", "mode", "go")
        .create("Obstacle", "rock")
        .delete("rock");
    let committed = batch.commit().unwrap();
    assert_eq!(committed, rev + 1);
    let change = watch.try_recv().expect("one notification");
    assert_eq!(change.revision, committed);
    assert_eq!(change.items.len(), 4);
    assert!(matches!(&change.items[2], ChangeItem::Create { object, .. } if &**object == "rock"));
    assert!(watch.try_recv().is_none(), "exactly one notification");
}

#[test]
fn delete_and_recreate_in_one_batch() {
    let b = with_vehicle();
    b.write("v", "speed", 9.0).unwrap();
    let mut batch = b.batch();
    batch.delete("v").create("Vehicle", "v");
    batch.commit().unwrap();
    assert_eq!(
        b.read("v", "speed").unwrap().value.as_f64(),
        Some(0.0),
        "the new v starts fresh"
    );
    // And the same rolled back: the old v with its value comes back.
    b.write("v", "speed", 8.0).unwrap();
    let mut batch = b.batch();
    batch
        .delete("v")
        .create("Vehicle", "v")
        .write("v", "speed", 99.0);
    assert!(batch.commit().is_err());
    assert_eq!(b.read("v", "speed").unwrap().value.as_f64(), Some(8.0));
}

#[test]
fn no_reader_ever_sees_half_a_batch() {
    let b = Arc::new(board());
    b.create("Vehicle", "left").unwrap();
    b.create("Vehicle", "right").unwrap();
    let kl = b.key("left", "wheels").unwrap();
    let kr = b.key("right", "wheels").unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let checked = Arc::new(AtomicU64::new(0));
    let readers: Vec<_> = (0..3)
        .map(|_| {
            let (b, stop, checked) = (b.clone(), stop.clone(), checked.clone());
            thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    let snap = b.snapshot();
                    let l = snap.read_key(kl).unwrap().value;
                    let r = snap.read_key(kr).unwrap().value;
                    assert_eq!(
                        l,
                        r,
                        "a snapshot saw half a batch at revision {}",
                        snap.revision()
                    );
                    checked.fetch_add(1, Ordering::Relaxed);
                }
            })
        })
        .collect();
    // Keep committing until the readers have looked many times (bounded, never timed).
    let mut batches = 0i64;
    while batches < 2000 || (checked.load(Ordering::Relaxed) < 3000 && batches < 5_000_000) {
        let mut batch = b.batch();
        batch
            .write_key(kl, batches % 16)
            .write_key(kr, batches % 16);
        batch.commit().unwrap();
        batches += 1;
    }
    stop.store(true, Ordering::Relaxed);
    readers.into_iter().for_each(|r| r.join().unwrap());
    assert!(checked.load(Ordering::Relaxed) >= 3000, "the readers ran");
}

#[test]
fn batch_writes_validate_like_single_writes() {
    let b = with_vehicle();
    let mut batch = b.batch();
    batch.write("v", "speed", Update::new(1.0).confidence(-0.5));
    assert!(matches!(
        batch.commit(),
        Err(BatchError::Write {
            index: 0,
            source: WriteError::Invalid { .. }
        })
    ));
    let mut batch = b.batch();
    batch.create("Nope", "x");
    assert!(matches!(
        batch.commit(),
        Err(BatchError::Create { index: 0, .. })
    ));
    assert_eq!(b.read("v", "mode").unwrap().value, Value::from("idle"));
    assert!(b.batch().commit().is_ok(), "an empty batch is fine");
}

#[test]
fn the_board_counts_objects_per_owner_through_creates_deletes_and_undone_batches() {
    let b = board();
    let other = slate_model::Address::new("t/r2/nav").unwrap();
    let remote = |name: &str| slate_model::NewObject::new("Obstacle", name).owner(other.clone());
    b.create_with(remote("a")).unwrap();
    b.create_with(remote("b")).unwrap();
    b.create("Obstacle", "mine").unwrap();
    assert_eq!(b.owned_count(&other), 2);
    assert_eq!(b.object_counts(), (3, 1));
    b.delete("a").unwrap();
    assert_eq!(b.owned_count(&other), 1);
    // A batch that fails puts back what it deleted and removes what it created.
    let mut batch = b.batch();
    batch
        .delete("b")
        .create("Obstacle", "c")
        .write("nothing", "range", 1.0);
    assert!(batch.commit().is_err());
    assert_eq!(b.owned_count(&other), 1);
    assert_eq!(b.object_counts(), (2, 1));
    b.delete("b").unwrap();
    assert_eq!(b.owned_count(&other), 0);
}
