//! Many threads on one board: readers never wait behind active functions, functions may
//! use the board, batches stay atomic, nothing deadlocks.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread;
use std::time::Duration;

use crossbeam_channel::bounded;
use slate_model::{Board, Value};

use crate::support::board;

/// Runs `f` on a thread and fails the test if it has not finished within `limit`
/// (a deadlock guard: the test asserts completion, never a duration).
fn finishes<T: Send + 'static>(limit: Duration, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = bounded(1);
    thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(limit)
        .expect("deadlock: the work did not finish")
}

#[test]
fn reads_do_not_wait_behind_a_long_write() {
    let b = Arc::new(board());
    b.create("Vehicle", "v").unwrap();
    b.create("Obstacle", "o").unwrap();
    let (read_done_tx, read_done_rx) = bounded::<()>(1);
    let (in_fn_tx, in_fn_rx) = bounded::<()>(1);
    // A slow on-write function: it does not return until a reader on another thread
    // has completed a read of the same board. If reads waited behind writes, this would
    // never happen and the function would time out.
    b.on_write("Vehicle", "speed", move |_| {
        in_fn_tx.send(()).ok();
        read_done_rx
            .recv_timeout(Duration::from_secs(20))
            .map_err(|_| "reader was blocked".into())
    })
    .unwrap();
    let events = b.events();
    let writer = {
        let b = b.clone();
        thread::spawn(move || b.write("v", "speed", 1.0).unwrap())
    };
    in_fn_rx.recv_timeout(Duration::from_secs(20)).unwrap();
    let b2 = b.clone();
    finishes(Duration::from_secs(20), move || {
        assert_eq!(b2.read("v", "speed").unwrap().value.as_f64(), Some(1.0));
        b2.write("o", "range", 4.0).unwrap(); // other writers are not blocked either
        read_done_tx.send(()).unwrap();
    });
    writer.join().unwrap();
    assert!(
        events.try_iter().next().is_none(),
        "the slow function succeeded"
    );
}

#[test]
fn hammering_with_readers_writers_batches_and_functions() {
    let b = Arc::new(board());
    for i in 0..8 {
        b.create("Gsr", &format!("g{i}")).unwrap();
    }
    // Functions that read and write the board from inside writes and reads.
    b.on_write("Vehicle", "speed", |call| {
        let w = (call.packet().value.as_f64().unwrap_or(0.0) as i64) % 16;
        call.write(call.object(), "wheels", w)?;
        Ok(())
    })
    .unwrap();
    b.on_read("Vehicle", "mode", |call| {
        let _ = call.read(call.object(), "wheels")?;
        Ok(())
    })
    .unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let mut handles = Vec::new();
    for t in 0..4 {
        let (b, stop) = (b.clone(), stop.clone());
        handles.push(thread::spawn(move || {
            let mut n = 0u64;
            while !stop.load(Ordering::Relaxed) {
                let name = format!("g{}", n % 8);
                match (t + n) % 4 {
                    0 => drop(b.write(&name, "speed", (n % 50) as f64).unwrap()),
                    1 => drop(b.read(&name, "mode").unwrap()),
                    2 => {
                        let mut batch = b.batch();
                        batch.write(&name, "mode", "a").write(&name, "armed", true);
                        batch.commit().unwrap();
                    }
                    _ => drop(b.instances("Vehicle").unwrap()),
                }
                n += 1;
            }
            n
        }));
    }
    finishes(Duration::from_secs(60), move || {
        thread::sleep(Duration::from_millis(300));
        stop.store(true, Ordering::Relaxed);
        let total: u64 = handles.into_iter().map(|h| h.join().unwrap()).sum();
        assert!(total > 0);
    });
    // Every function-driven write matched its trigger.
    for i in 0..8 {
        let name = format!("g{i}");
        let speed = b
            .read(&name, "speed")
            .unwrap()
            .value
            .as_f64()
            .unwrap_or(0.0);
        let wheels = b.read(&name, "wheels").unwrap().value;
        if speed > 0.0 {
            assert_eq!(wheels, Value::Int((speed as i64) % 16), "{name}");
        }
    }
    assert_eq!(b.stats().function_failures, 0);
}

#[test]
fn concurrent_creators_and_deleters_keep_names_and_queries_consistent() {
    let b = Arc::new(Board::new());
    b.define(slate_model::ClassDef::new("Blip")).unwrap();
    let workers: Vec<_> = (0..4)
        .map(|t| {
            let b = b.clone();
            thread::spawn(move || {
                for i in 0..500 {
                    let name = format!("b{t}_{i}");
                    b.create("Blip", &name).unwrap();
                    if i % 2 == 0 {
                        b.delete(&name).unwrap();
                    }
                }
            })
        })
        .collect();
    finishes(Duration::from_secs(60), move || {
        workers.into_iter().for_each(|w| w.join().unwrap())
    });
    let ids = b.instances("Blip").unwrap();
    assert_eq!(ids.len(), 4 * 250);
    for id in ids {
        let name = b.name_of(id).unwrap();
        assert_eq!(b.info(&name).unwrap().id, id);
    }
}
