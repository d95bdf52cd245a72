//! Packets of pure on-read functions kept until what they read changes: every way the
//! board can change what a function read must drop what it returned, and what cannot be
//! followed must not be kept.

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use slate_model::{ActiveFn, Address, Call, FnError, Packet, Trigger, Value};

use crate::support::{board, with_vehicle};

/// A pure function made of a closure, counting its calls.
struct Pure<F> {
    calls: Arc<AtomicUsize>,
    f: F,
}

impl<F> ActiveFn for Pure<F>
where
    F: Fn(&mut Call<'_>) -> Result<(), FnError> + Send + Sync,
{
    fn name(&self) -> &str {
        "pure"
    }
    fn call(&self, call: &mut Call<'_>) -> Result<(), FnError> {
        self.calls.fetch_add(1, Ordering::SeqCst);
        (self.f)(call)
    }
    fn pure(&self) -> bool {
        true
    }
}

/// Attaches `f` as a pure on-read function of `target.attr`; returns its call count.
fn attach_pure<F>(
    b: &slate_model::Board,
    target: &str,
    attr: &str,
    f: F,
) -> impl Fn() -> usize + use<F>
where
    F: Fn(&mut Call<'_>) -> Result<(), FnError> + Send + Sync + 'static,
{
    let calls = Arc::new(AtomicUsize::new(0));
    let pure = Pure {
        calls: calls.clone(),
        f,
    };
    b.attach(target, attr, Trigger::Read, Arc::new(pure))
        .unwrap();
    move || calls.load(Ordering::SeqCst)
}

/// `v.wheels` reads `u.speed` (rounded): the world of most tests here.
fn wheels_from_speed() -> (slate_model::Board, impl Fn() -> usize) {
    let b = with_vehicle();
    b.create("Vehicle", "u").unwrap();
    let calls = attach_pure(&b, "v", "wheels", |call| {
        let speed = call.read("u", "speed")?.value.as_f64().unwrap_or(-1.0);
        call.set_value(speed.round() as i64);
        Ok(())
    });
    (b, calls)
}

fn wheels(b: &slate_model::Board) -> Value {
    b.read("v", "wheels").unwrap().value
}

#[test]
fn a_pure_functions_packet_is_served_until_what_it_read_is_written() {
    let (b, calls) = wheels_from_speed();
    b.write("u", "speed", 3.0).unwrap();
    assert_eq!((wheels(&b), wheels(&b)), (Value::Int(3), Value::Int(3)));
    assert_eq!(calls(), 1, "the second read is served the kept packet");
    b.write("u", "mode", "fast").unwrap();
    b.write("v", "speed", 9.0).unwrap();
    assert_eq!(wheels(&b), Value::Int(3));
    assert_eq!(calls(), 1, "writes of what it did not read keep it");
    b.write("u", "speed", 4.0).unwrap();
    assert_eq!(
        wheels(&b),
        Value::Int(4),
        "a write of what it read drops it"
    );
    assert_eq!(calls(), 2);
    let key = b.key("u", "speed").unwrap();
    b.write_key(key, 5.0).unwrap();
    assert_eq!(wheels(&b), Value::Int(5), "through a key too");
}

#[test]
fn a_batch_a_merge_and_a_rolled_back_batch_drop_it_too() {
    let (b, _) = wheels_from_speed();
    b.write("u", "speed", 1.0).unwrap();
    assert_eq!(wheels(&b), Value::Int(1));
    let mut batch = b.batch();
    batch.write("v", "mode", "x").write("u", "speed", 2.0);
    batch.commit().unwrap();
    assert_eq!(wheels(&b), Value::Int(2), "a batch");
    let merged = Packet {
        value: Value::Real(6.0),
        timestamp: b.clock().now(),
        source: Address::new("team/r2/nav").unwrap(),
        ..Packet::none()
    };
    b.merge("u", "speed", merged).unwrap();
    assert_eq!(
        wheels(&b),
        Value::Int(6),
        "a received packet that won its merge"
    );
    // A batch whose last operation fails leaves nothing behind: its first write was
    // stored (and dropped the kept packet), then taken back.
    let mut batch = b.batch();
    batch.write("u", "speed", 8.0).write("nobody", "speed", 1.0);
    assert!(batch.commit().is_err());
    assert_eq!(
        wheels(&b),
        Value::Int(6),
        "the rolled-back write is not seen"
    );
}

#[test]
fn a_snapshot_serves_and_drops_kept_packets_as_the_board_does() {
    let (b, calls) = wheels_from_speed();
    b.write("u", "speed", 2.0).unwrap();
    {
        let snap = b.snapshot();
        assert_eq!(snap.read("v", "wheels").unwrap().value, Value::Int(2));
        assert_eq!(snap.read("v", "wheels").unwrap().value, Value::Int(2));
    }
    assert_eq!(wheels(&b), Value::Int(2));
    assert_eq!(calls(), 1, "one computation for the snapshot and the board");
    b.write("u", "speed", 7.0).unwrap();
    assert_eq!(
        b.snapshot().read("v", "wheels").unwrap().value,
        Value::Int(7)
    );
}

#[test]
fn a_class_level_value_it_inherited_drops_it() {
    let (b, _) = wheels_from_speed();
    // `u` has no speed of its own: it reads the declared default, then its class's.
    assert_eq!(wheels(&b), Value::Int(0));
    b.write("Vehicle", "speed", 12.0).unwrap();
    assert_eq!(wheels(&b), Value::Int(12), "the class-level value is read");
}

#[test]
fn objects_created_and_deleted_drop_what_counted_them() {
    let b = with_vehicle();
    let calls = attach_pure(&b, "v", "wheels", |call| {
        let n = call.instances("Obstacle")?.len();
        call.set_value(n as i64);
        Ok(())
    });
    assert_eq!(wheels(&b), Value::Int(0));
    b.create("Obstacle", "rock").unwrap();
    assert_eq!(wheels(&b), Value::Int(1), "a creation");
    b.create("Obstacle", "tree").unwrap();
    b.delete("rock").unwrap();
    assert_eq!(wheels(&b), Value::Int(1), "a deletion");
    b.delete("tree").unwrap();
    assert_eq!(wheels(&b), Value::Int(0));
    assert_eq!(wheels(&b), Value::Int(0));
    assert_eq!(calls(), 4);
}

#[test]
fn a_name_that_did_not_resolve_is_read_again_once_the_object_exists() {
    let b = with_vehicle();
    let calls = attach_pure(&b, "v", "wheels", |call| {
        let speed = call
            .read("late", "speed")
            .map_or(15.0, |p| p.value.as_f64().unwrap_or(14.0));
        call.set_value(speed as i64);
        Ok(())
    });
    assert_eq!(wheels(&b), Value::Int(15), "no such object");
    b.create("Vehicle", "late").unwrap();
    assert_eq!(calls(), 1);
    b.write("late", "speed", 3.0).unwrap();
    assert_eq!(wheels(&b), Value::Int(3));
    assert_eq!(calls(), 2);
}

#[test]
fn a_packet_that_read_the_clock_is_kept_only_while_the_clock_shows_that_time() {
    let b = with_vehicle();
    let calls = attach_pure(&b, "v", "wheels", |call| {
        call.set_value((call.now().as_millis() % 1000) as i64);
        Ok(())
    });
    let first = wheels(&b);
    assert_eq!(wheels(&b), first);
    assert_eq!(calls(), 1, "the same time: kept");
    b.clock().advance(Duration::from_millis(5)).unwrap();
    let later = wheels(&b);
    assert_ne!(later, first, "the clock moved: computed again");
    assert_eq!(calls(), 2);
    // A write stamps with the clock but does not move its physical time: no reason
    // to compute again (and nothing it read was written).
    b.write("v", "mode", "x").unwrap();
    assert_eq!(wheels(&b), later);
    assert_eq!(calls(), 2);
}

#[test]
fn attaching_or_detaching_a_function_drops_every_kept_packet() {
    let (b, _) = wheels_from_speed();
    b.write("u", "speed", 2.0).unwrap();
    assert_eq!(wheels(&b), Value::Int(2));
    let plus_ten: Arc<dyn ActiveFn> = Arc::new(Pure {
        calls: Arc::default(),
        f: |call: &mut Call<'_>| {
            let w = call.packet().value.as_f64().map_or(0, |x| x as i64);
            call.set_value(w + 10);
            Ok(())
        },
    });
    b.attach("v", "wheels", Trigger::Read, plus_ten.clone())
        .unwrap();
    assert_eq!(wheels(&b), Value::Int(12), "the new function runs");
    b.detach("v", "wheels", Trigger::Read, &plus_ten).unwrap();
    assert_eq!(wheels(&b), Value::Int(2), "the detached one no longer does");
}

#[test]
fn functions_that_are_not_pure_run_at_every_read() {
    let b = with_vehicle();
    let calls = Arc::new(AtomicUsize::new(0));
    let c = calls.clone();
    b.on_read("v", "wheels", move |call| {
        c.fetch_add(1, Ordering::SeqCst);
        call.set_value(1);
        Ok(())
    })
    .unwrap();
    wheels(&b);
    wheels(&b);
    assert_eq!(calls.load(Ordering::SeqCst), 2);
}

#[test]
fn a_pure_function_reading_another_is_computed_again_and_sees_its_changes() {
    let (b, inner_calls) = wheels_from_speed();
    // `u.mode` reads `v.wheels`, itself pure and kept.
    let outer_calls = attach_pure(&b, "u", "mode", |call| {
        let w = call
            .read("v", "wheels")?
            .value
            .as_f64()
            .map_or(-1, |x| x as i64);
        call.set_value(format!("w{w}"));
        Ok(())
    });
    b.write("u", "speed", 2.0).unwrap();
    let mode = |b: &slate_model::Board| b.read("u", "mode").unwrap().value.to_string();
    assert_eq!((mode(&b), mode(&b)), ("\"w2\"".into(), "\"w2\"".into()));
    assert_eq!(
        (outer_calls(), inner_calls()),
        (2, 1),
        "the outer one read a function's attribute: not kept; the inner one is"
    );
    b.write("u", "speed", 5.0).unwrap();
    assert_eq!(mode(&b), "\"w5\"");
}

#[test]
fn a_cycle_is_cut_at_every_read_not_once() {
    let b = with_vehicle();
    let calls = attach_pure(&b, "v", "wheels", |call| {
        let w = call
            .read("v", "wheels")?
            .value
            .as_f64()
            .map_or(0, |x| x as i64);
        call.set_value(w + 1);
        Ok(())
    });
    wheels(&b);
    let after_one = b.stats();
    wheels(&b);
    let after_two = b.stats();
    assert!(after_one.chain_cuts >= 1);
    assert_eq!(
        after_two.chain_cuts,
        after_one.chain_cuts * 2,
        "each read cuts its cycle (and tells it) again"
    );
    assert_eq!(after_two.function_failures, after_one.function_failures * 2);
    assert_eq!(calls(), 2);
}

#[test]
fn a_failed_function_is_run_again() {
    let b = with_vehicle();
    let calls = attach_pure(&b, "v", "wheels", |_| Err("no wheels today".into()));
    wheels(&b);
    wheels(&b);
    assert_eq!(calls(), 2);
    assert_eq!(b.stats().function_failures, 2, "each failure is told");
}

#[test]
fn a_packet_computed_while_what_it_read_changed_is_not_kept() {
    // The function writes what it read after reading it, as another thread could between
    // its read and the end of the computation: what it computed is stale at once.
    let b = with_vehicle();
    b.create("Vehicle", "u").unwrap();
    b.write("u", "speed", 1.0).unwrap();
    let once = Arc::new(AtomicUsize::new(0));
    let calls = attach_pure(&b, "v", "wheels", move |call| {
        let speed = call.read("u", "speed")?.value.as_f64().unwrap_or(-1.0);
        if once.fetch_add(1, Ordering::SeqCst) == 0 {
            call.write("u", "speed", 9.0)?;
        }
        call.set_value(speed as i64);
        Ok(())
    });
    assert_eq!(wheels(&b), Value::Int(1), "what it read then");
    assert_eq!(wheels(&b), Value::Int(9), "not the stale packet");
    assert_eq!(wheels(&b), Value::Int(9));
    assert_eq!(calls(), 2, "that one is kept");
}

#[test]
fn reads_of_another_board_are_not_followed() {
    let other = Arc::new(with_vehicle());
    let b = board();
    b.create("Vehicle", "v").unwrap();
    let o = other.clone();
    let calls = attach_pure(&b, "v", "wheels", move |call| {
        let s = o.read("v", "speed").unwrap().value.as_f64().unwrap_or(-1.0);
        call.set_value(s as i64);
        Ok(())
    });
    assert_eq!(wheels(&b), Value::Int(0));
    other.write("v", "speed", 4.0).unwrap();
    assert_eq!(wheels(&b), Value::Int(4));
    assert_eq!(calls(), 2);
}

#[test]
fn traces_ended_out_of_order_give_only_their_own_reads() {
    let b = with_vehicle();
    b.create("Vehicle", "u").unwrap();
    let snap = b.snapshot();
    let outer = snap.trace();
    let _ = snap.read("u", "speed");
    let inner = snap.trace();
    let _ = snap.read("v", "speed");
    // Out of order: the outer one ends first. What it read meanwhile went to the inner
    // one, so neither can be followed (a plan evaluated so is evaluated again).
    assert!(outer.stop().is_none(), "its reads are not all its own");
    assert!(
        inner.stop().is_none(),
        "its reads went with the outer trace"
    );
    drop(snap); // it holds the board: writes wait for it
    // A trace after them records only its own reads: nothing was left to collect them.
    let snap = b.snapshot();
    let later = snap.trace();
    let _ = snap.read("u", "speed");
    let later = later.stop().unwrap();
    drop(snap);
    b.write("v", "speed", 3.0).unwrap();
    assert!(b.unchanged_since(&later), "v was not read by it");
    b.write("u", "speed", 3.0).unwrap();
    assert!(!b.unchanged_since(&later));
}
