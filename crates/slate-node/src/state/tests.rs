//! The store on its own: what it gives back, what it leaves out, and the errors of a
//! directory it cannot use.

use std::collections::HashSet;
use std::sync::Arc;

use slate_model::{
    Address, AttrDecl, Board, ClassDef, Context, MODULE_CLASS, NewObject, Timestamp, Update,
    ValueType,
};
use slate_testing::temp_dir;

use super::pending::Pending;
use super::{Durability, FILE, StateError, Store, reset, restore};
use crate::record::board_state;

const ME: &str = "t/r1/nav";

fn board() -> Arc<Board> {
    let board = Board::builder().address(Address::new(ME).unwrap()).build();
    board
        .define(
            ClassDef::new("Vehicle")
                .attr(AttrDecl::new("speed", ValueType::Real).bounds(0.0, 10.0))
                .attr(AttrDecl::new("mode", ValueType::Str))
                .attr(AttrDecl::new("pos", ValueType::Vector(2))),
        )
        .unwrap();
    board
        .define(
            ClassDef::new("Truck")
                .parent("Vehicle")
                .attr(AttrDecl::new("load", ValueType::Int)),
        )
        .unwrap();
    Arc::new(board)
}

fn fresh_board() -> Board {
    Board::builder().address(Address::new(ME).unwrap()).build()
}

/// Saves the whole of `board` to a new store in `dir`.
fn save(board: &Board, dir: &std::path::Path) -> Store {
    let store = Store::open(dir, board.address(), Durability::Immediate).unwrap();
    let (pending, _) = Pending::full(board, &mut HashSet::new());
    store.commit(&pending).unwrap();
    store
}

#[test]
fn a_store_gives_back_the_classes_objects_and_packets_with_their_stamps_and_sources() {
    let dir = temp_dir("state-roundtrip");
    let b = board();
    b.create_with(NewObject::new("Truck", "t1").context(Context::Self_))
        .unwrap();
    b.create_with(NewObject::new("Vehicle", "v9").owner(Address::new("t/r2/loco").unwrap()))
        .unwrap();
    b.write(
        "t1",
        "speed",
        Update::new(2.5).accuracy(0.25).confidence(0.5),
    )
    .unwrap();
    b.write("t1", "mode", "cruise").unwrap();
    b.write("t1", "pos", vec![1.0, -2.0]).unwrap();
    b.write("t1", "load", 7).unwrap();
    let stamp = b.clock().now();
    let peer = Address::new("t/r2/loco").unwrap();
    let mut received = b.read("v9", "speed").unwrap();
    received.value = slate_model::Value::Real(4.0);
    received.timestamp = stamp;
    received.source = peer;
    b.merge("v9", "speed", received).unwrap();
    let store = save(&b, &dir);
    let again = fresh_board();
    let restored = restore(&again, store.load().unwrap());
    assert_eq!(board_state(&again), board_state(&b));
    assert_eq!(restored.objects, 2);
    assert_eq!(restored.packets, 5);
    assert_eq!(restored.refused, 0);
    assert!(
        again.clock().now() > stamp,
        "the clock moves past every stamp restored"
    );
}

#[test]
fn a_restored_real_keeps_every_bit_of_its_stored_value() {
    // A real whose shortest decimal form a reader without exact parsing rounds to the
    // neighbouring double (the store keeps packets as JSON).
    let (speed, confidence) = (2.9215999999999998, 0.9882352941176471);
    let dir = temp_dir("state-reals");
    let b = board();
    b.create("Vehicle", "v1").unwrap();
    b.write("v1", "speed", Update::new(speed).confidence(confidence))
        .unwrap();
    b.write("v1", "pos", vec![83.29999999999995, 21.300000000000068])
        .unwrap();
    let store = save(&b, &dir);
    let again = fresh_board();
    restore(&again, store.load().unwrap());
    let restored = again.read("v1", "speed").unwrap();
    assert_eq!(restored.value, slate_model::Value::Real(speed));
    assert_eq!(restored.confidence.to_bits(), confidence.to_bits());
    assert_eq!(board_state(&again), board_state(&b));
}

#[test]
fn a_stored_packet_replaces_an_initial_value_and_loses_to_a_newer_write() {
    let dir = temp_dir("state-merge");
    let b = board();
    b.create("Vehicle", "gsr").unwrap();
    b.write("gsr", "speed", 3.0).unwrap();
    b.write("gsr", "mode", "old").unwrap();
    let store = save(&b, &dir);
    let again = board();
    again.create("Vehicle", "gsr").unwrap();
    let initial = Update::new(1.0).timestamp(Timestamp::ZERO);
    again.write("gsr", "speed", initial).unwrap();
    again.write("gsr", "mode", "new").unwrap();
    restore(&again, store.load().unwrap());
    assert_eq!(
        again.read("gsr", "speed").unwrap().value.as_f64(),
        Some(3.0)
    );
    assert_eq!(
        again.read("gsr", "mode").unwrap().value,
        slate_model::Value::Str("new".into())
    );
}

#[test]
fn a_deleted_object_leaves_the_store_with_its_packets() {
    let dir = temp_dir("state-delete");
    let b = board();
    b.create("Vehicle", "gone").unwrap();
    b.write("gone", "speed", 1.0).unwrap();
    b.create("Vehicle", "kept").unwrap();
    let store = save(&b, &dir);
    let watch = b.watch_gathered(slate_model::Filter::all(), 16).unwrap();
    b.delete("gone").unwrap();
    let mut pending = Pending::default();
    let mut taken = Vec::new();
    watch.take(&mut taken);
    for (revision, item) in taken {
        pending.fold(&b, revision, item, &mut HashSet::new());
    }
    store.commit(&pending).unwrap();
    let saved = store.load().unwrap();
    let names: Vec<&str> = saved.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["kept"]);
    assert!(saved.packets.iter().all(|p| p.object != "gone"));
}

#[test]
fn liveliness_objects_are_not_kept() {
    let dir = temp_dir("state-module");
    let b = board();
    b.create(MODULE_CLASS, "t_r2_loco").unwrap();
    b.write("t_r2_loco", "alive", true).unwrap();
    let saved = save(&b, &dir).load().unwrap();
    assert!(saved.objects.is_empty(), "{:?}", saved.objects);
    assert!(saved.packets.is_empty(), "{:?}", saved.packets);
}

#[test]
fn a_store_of_another_module_is_refused_with_both_names() {
    let dir = temp_dir("state-other");
    drop(save(&board(), &dir));
    let other = Address::new("t/r9/cam").unwrap();
    let Err(e) = Store::open(&dir, &other, Durability::Immediate) else {
        panic!("another module's store opened");
    };
    assert!(matches!(e, StateError::OtherModule { .. }), "{e:?}");
    let text = e.to_string();
    assert!(text.contains(ME) && text.contains("t/r9/cam"), "{text}");
}

#[test]
fn a_damaged_store_is_an_error_naming_the_directory_and_the_way_out() {
    let dir = temp_dir("state-damaged");
    std::fs::write(dir.join(FILE), vec![0x5a; 64 * 1024]).unwrap();
    let Err(e) = Store::open(&dir, &Address::new(ME).unwrap(), Durability::Immediate) else {
        panic!("a damaged store opened");
    };
    let text = e.to_string();
    assert!(text.contains(&dir.display().to_string()), "{text}");
    assert!(text.contains("--reset-state"), "{text}");
}

#[test]
fn a_state_path_that_is_a_file_is_an_error_naming_it() {
    let dir = temp_dir("state-file");
    let path = dir.join("not-a-dir");
    std::fs::write(&path, "x").unwrap();
    let Err(e) = Store::open(&path, &Address::new(ME).unwrap(), Durability::Immediate) else {
        panic!("a file opened as a state directory");
    };
    assert!(matches!(e, StateError::Open { .. }), "{e:?}");
    assert!(e.to_string().contains(&path.display().to_string()), "{e}");
}

#[test]
fn reset_moves_the_store_aside_and_the_next_open_is_empty() {
    let dir = temp_dir("state-reset");
    let b = board();
    b.create("Vehicle", "gsr").unwrap();
    drop(save(&b, &dir));
    let aside = reset(&dir).unwrap().expect("there was a store");
    assert!(aside.exists());
    let store = Store::open(&dir, b.address(), Durability::Immediate).unwrap();
    assert!(store.load().unwrap().objects.is_empty());
    assert_eq!(
        reset(&std::env::temp_dir().join("slate-no-such-state")).unwrap(),
        None
    );
}

#[test]
fn a_store_damaged_inside_is_an_error_or_a_consistent_board_never_a_panic() {
    let b = board();
    for i in 0..200 {
        b.create("Vehicle", &format!("v{i}")).unwrap();
        b.write(&format!("v{i}"), "mode", "x".repeat(100)).unwrap();
    }
    let dir = temp_dir("state-flipped");
    drop(save(&b, &dir));
    let clean = std::fs::read(dir.join(FILE)).unwrap();
    for at in (0..clean.len()).step_by(clean.len() / 24 + 1) {
        let mut bytes = clean.clone();
        for byte in bytes.iter_mut().skip(at).take(64) {
            *byte ^= 0xa5;
        }
        std::fs::write(dir.join(FILE), &bytes).unwrap();
        let opened = Store::open(&dir, b.address(), Durability::Immediate);
        match opened.and_then(|s| s.load()) {
            Ok(saved) => {
                restore(&fresh_board(), saved);
            }
            Err(e) => assert!(e.to_string().contains(&dir.display().to_string()), "{e}"),
        }
    }
}
